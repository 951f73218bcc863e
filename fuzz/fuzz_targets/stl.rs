//! STL meshes from bytes (gzip through `read_mesh`, see `isogrid_fuzz::fuzz_mesh`).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    isogrid_fuzz::fuzz_mesh(data, isogrid_io::mesh::MeshFormat::Stl, "in.stl.gz");
});

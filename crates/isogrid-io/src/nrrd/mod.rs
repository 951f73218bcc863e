//! NRRD volumes: reading attached `.nrrd` and detached `.nhdr` files, writing attached `.nrrd`.
//!
//! Spec: the Teem NRRD file format, <http://teem.sourceforge.net/nrrd/format.html>.

mod header;
mod read;
mod write;

pub(crate) use header::clip;
pub(crate) use read::data_files;
pub(crate) use read::header_layers_and_keys;
pub use read::read_nrrd;
pub(crate) use read::read_nrrd_layers;
pub(crate) use read::region_layout;
pub use write::write_nrrd;

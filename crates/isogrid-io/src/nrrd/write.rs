//! Writing a volume as an attached NRRD file (NRRD0004, raw encoding, little endian).
//!
//! The geometry goes into `space dimension: 3`, `space directions` (each axis's direction row
//! scaled by its spacing) and `space origin`, which Teem, pynrrd, 3D Slicer and ITK all read. The
//! spec forbids `spacings` next to `space directions`, so spacing lives only in the vector
//! lengths; [`read_nrrd`](super::read_nrrd) recovers it as those lengths.

use isogrid::{Error, Result, Volume, VolumeData, WorldFrame};
use std::io::Write;
use std::path::Path;

/// Writes `volume` to `path` atomically (temporary file + rename). Errors name `path`.
pub fn write_nrrd(path: &Path, volume: &Volume) -> Result<()> {
    let header = header_text(volume);
    isogrid::fs::write_atomic(path, |out: &mut dyn Write| {
        out.write_all(header.as_bytes())?;
        write_samples_le(out, volume.data())
    })
}

fn header_text(volume: &Volume) -> String {
    let g = volume.geometry();
    let type_name = match volume.data() {
        VolumeData::U8(_) => "uint8",
        VolumeData::U16(_) => "uint16",
        VolumeData::I16(_) => "int16",
        VolumeData::F32(_) => "float",
        VolumeData::U32(_) => "uint32",
        VolumeData::I32(_) => "int32",
        VolumeData::U64(_) => "uint64",
        VolumeData::I64(_) => "int64",
        VolumeData::F64(_) => "double",
    };
    let vector = |v: [f64; 3]| format!("({},{},{})", v[0], v[1], v[2]);
    let directions: Vec<String> = (0..3)
        .map(|axis| vector(g.direction[axis].map(|x| x * g.spacing[axis])))
        .collect();
    let [nx, ny, nz] = g.dims;
    // The space names the convention of the coordinates, where it is known.
    let space = match g.frame {
        WorldFrame::Lps => "space: left-posterior-superior",
        WorldFrame::Ras => "space: right-anterior-superior",
        WorldFrame::Unknown => "space dimension: 3",
    };
    format!(
        "NRRD0004\n\
         # Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n\
         # written by isogrid\n\
         type: {type_name}\n\
         dimension: 3\n\
         {space}\n\
         sizes: {nx} {ny} {nz}\n\
         space directions: {}\n\
         kinds: domain domain domain\n\
         endian: little\n\
         encoding: raw\n\
         space origin: {}\n\n",
        directions.join(" "),
        vector(g.origin)
    )
}

/// Samples as little-endian bytes, in bounded chunks so that no second full copy is made.
fn write_samples_le(out: &mut dyn Write, data: &VolumeData) -> Result<()> {
    fn write<T: bytemuck::Pod>(
        out: &mut dyn Write,
        values: &[T],
        to_le: impl Fn(&T) -> T,
    ) -> Result<()> {
        if cfg!(target_endian = "little") {
            return out
                .write_all(bytemuck::cast_slice(values))
                .map_err(Error::io);
        }
        for chunk in values.chunks(1 << 16) {
            let swapped: Vec<T> = chunk.iter().map(&to_le).collect();
            out.write_all(bytemuck::cast_slice(&swapped))?;
        }
        Ok(())
    }
    match data {
        VolumeData::U8(v) => write(out, v, |x| *x),
        VolumeData::U16(v) => write(out, v, |x| x.to_le()),
        VolumeData::I16(v) => write(out, v, |x| x.to_le()),
        VolumeData::F32(v) => write(out, v, |x| f32::from_bits(x.to_bits().to_le())),
        VolumeData::U32(v) => write(out, v, |x| u32::from_le_bytes(x.to_ne_bytes())),
        VolumeData::I32(v) => write(out, v, |x| i32::from_le_bytes(x.to_ne_bytes())),
        VolumeData::U64(v) => write(out, v, |x| u64::from_le_bytes(x.to_ne_bytes())),
        VolumeData::I64(v) => write(out, v, |x| i64::from_le_bytes(x.to_ne_bytes())),
        VolumeData::F64(v) => write(out, v, |x| f64::from_le_bytes(x.to_ne_bytes())),
    }
}

//! Volume file formats for isogrid: NIfTI-1 and NIfTI-2, NRRD, NumPy `.npy`, raw, DICOM series, TIFF
//! stacks, MetaImage, FreeSurfer MGH, MRC/CCP4 maps and VTK XML image data (`.vti`), read into an [`isogrid::Volume`], and NRRD written back;
//! label volumes with the names and colours their files give, and colour tables ([`labels`]); triangle meshes ([`mesh`]) and
//! their solid voxelisation into coverage volumes ([`voxelize`], paper §4).
//!
//! Every reader keeps the file's storage order (voxel (i, j, k), i fastest; no reorientation or
//! resampling; MRC maps alone are permuted to x-fastest, see [`mrc`]), keeps spacing and origin in physical file units in [`isogrid::Geometry`] and the
//! axis directions as metadata when the format has them, and the convention of world coordinates
//! (LPS, RAS or none) in [`isogrid::Geometry::frame`]. Samples keep the file's type (8 to 64-bit
//! integers, f32, f64); i8 becomes i16 and bool u8. Malformed or truncated files give one-line errors naming the
//! file; declared sizes are checked against the file, and against the memory there is
//! ([`isogrid::memory`]), before anything is allocated. Only regular files are read: a pipe,
//! FIFO, device or directory given as a file is refused rather than waited on.

pub mod dicom;
pub mod glb;
pub mod image;
pub mod label_meshes;
pub mod label_statistics;
pub mod labels;
pub mod mesh;
pub mod mesh_write;
pub mod metaimage;
pub mod mgh;
pub mod mrc;
pub mod nifti;
pub mod npy;
pub mod nrrd;
pub mod raw;
pub mod region;
pub mod tiff;
pub mod voxelize;
pub mod vti;

mod data_file;
mod files_read;
mod four_d;
mod geometry;
mod mapped_layout;
mod read;
mod read_options;
mod samples;

pub use dicom::{read_dicom, read_dicom_series};
pub use files_read::files_read;
pub use metaimage::read_metaimage;
pub use mgh::{read_mgh, read_mgh_indexed};
pub use mrc::read_mrc;
pub use nifti::{read_nifti, read_nifti_indexed};
pub use npy::read_npy;
pub use nrrd::{read_nrrd, write_nrrd};
pub use raw::{read_raw, RawSpec};
pub use read::{read_volume, read_volume_noted, read_volume_with_progress};
pub use read_options::ssl_cert_file_from_env;
pub use read_options::{AxisPick, IndexFlag, ReadOptions};
pub use region::{open_region, ZarrOptions};
pub use tiff::read_tiff;
pub use vti::read_vti;

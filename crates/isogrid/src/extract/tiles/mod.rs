//! Extraction in independent tiles of whole blocks (paper §3.1), for runs spread over processes or
//! machines (the Python package drives it on a Dask cluster).
//!
//! Every cell belongs to exactly one 16³ block and a block reads only its own samples plus one
//! more on its high sides. So a *tile*, a box of whole blocks `bx0..bx1 × by0..by1 × bz0..bz1`,
//! needs exactly the samples `16·b0 ..= 16·b1` along each axis (its own plus a one-sample *halo*
//! on its high sides, clipped to the volume), and its blocks come out as the whole-volume
//! extraction makes them. There is no seam to stitch and nothing to de-duplicate; what the whole
//! volume decides (the value range behind the quantiser, every block's place in the file) is
//! settled between two rounds of tasks:
//!
//! 1. [`scan_tile`] on every tile, anywhere: a *scan fragment* with each block's active cells,
//!    occupied metacells and value range (24 bytes a block: the range as f64);
//! 2. [`TileExtraction::add_scan`], in any order, on the machine that writes the file; then
//!    [`TileExtraction::plan_emits`] takes prefix sums in block order (every block's record and
//!    place, the file's exact size) and cuts the tiles that hold active cells into *emit jobs*
//!    whose samples and output fit a budget;
//! 3. [`emit_tile`] on every job, anywhere: an *output fragment* holding the job's metacell slots
//!    and corner records. A job's blocks are not one run of the block table unless it spans the
//!    volume's width (and height, for several layers): each of its block rows (fixed y and z) is
//!    one run of the table, and of each output section;
//! 4. [`TileExtraction::write`] places each row's output at its offsets as fragments arrive, in
//!    whatever order (a retried task gives the same bytes), combines the section checksums in
//!    file order and writes the header last, atomically.
//!
//! **One pass** where the quantiser does not wait for the whole volume: when the value range is
//! given, or the codes do not depend on it (u8 and u16 stored as they are, 32-bit values),
//! [`TileExtraction::one_pass_task`] hands out a task and [`extract_tile`] scans *and* emits a
//! tile at once, each block row's cells numbered from 0, returning the output with the scan
//! records when it fits a budget. [`TileExtraction::add_tile`] keeps that output in a scratch
//! file (the *spool*) until [`TileExtraction::write`] copies it into place with the rows' cell
//! pointers moved to the grid's numbering; only tiles whose output did not fit become emit jobs.
//! The samples are then read once instead of twice.
//!
//! Scan and emit are [`super::scan_blocks_counted`] and [`super::emit::emit_block`], the code of the
//! in-memory and streaming extractions, run on the tile's samples, so the file is byte-identical
//! to `cgc::write(extract(volume))` whatever the tiling and the order tasks finish in.
//!
//! Fragments are plain little-endian bytes (they cross processes and machines); each starts with a
//! four-byte tag and is checked against what the receiver expects before use.
//!
//! `geometry` holds the tiles' boxes and samples; `tasks` what runs on a tile's samples, anywhere;
//! `driver` the coordinating side; `spool` the scratch file; `wire` the fragments' byte layout.

mod driver;
mod geometry;
mod spool;
mod tasks;
mod wire;

pub use driver::{EmitJob, TileExtraction, TileSummary};
pub use geometry::{block_dims, tile_samples, tiles, BlockBox};
pub(in crate::extract) use spool::Spool;
pub use tasks::{emit_tile, extract_tile, scan_tile};
pub(in crate::extract) use wire::Reader;

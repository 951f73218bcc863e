//! Packed records of the clustered grid cell structure (paper §3.1, Table 1).
//!
//! Three flat buffers, uploaded to a GPU byte for byte:
//!
//! * **blocks** — one [`Block`] per 16×16×16 cells, dense over the whole grid, in x-fastest order
//!   (`bx + nbx·(by + nby·bz)`).
//! * **metacell slots** — clusters of [`CLUSTER_SLOTS`] consecutive 12-byte slots. Slots 0–14 hold
//!   [`Metacell`]s (2×2×2 cells, Morton order within the block), slot 15 holds the cluster's
//!   [`ClusterBound`]. A block's last cluster is padded with empty metacells (all bytes zero), so no
//!   cluster spans two blocks and every block owns a whole number of clusters.
//! * **corner records** — one per active cell, 8 corner values at the grid's [`Precision`], in the order
//!   of the metacells and, inside a metacell, in cell-mask bit order.
//!
//! Cell and corner numbering: bit 0 is +x, bit 1 is +y, bit 2 is +z. Cell `b` of a metacell at
//! metacell position `(mx, my, mz)` is cell `(2mx + (b&1), 2my + (b>>1&1), 2mz + (b>>2&1))`; corner `c`
//! of cell `(x, y, z)` is sample `(x + (c&1), y + (c>>1&1), z + (c>>2&1))`. Corners 0–3 (the z-low
//! face) form the first group of four, corners 4–7 the second, as the paper's two RGBA values.

use bytemuck::{Pod, Zeroable};
use std::mem::size_of;

/// Cells per block edge (§3.1).
pub const BLOCK_CELLS: usize = 16;
/// Metacells per block edge.
pub const BLOCK_METACELLS: usize = BLOCK_CELLS / 2;
/// Metacell slots per cluster, the last holding the bound.
pub const CLUSTER_SLOTS: usize = 16;
/// Metacells a cluster holds at most.
pub const CLUSTER_METACELLS: usize = CLUSTER_SLOTS - 1;
/// Index of the bound slot inside a cluster.
pub const BOUND_SLOT: usize = CLUSTER_SLOTS - 1;

/// One 16³-cell block. 16 bytes, little-endian:
///
/// | offset | size | field |
/// |---|---|---|
/// | 0 | 4 | `metacell_count`: metacell **slots** owned, a multiple of 16 (0 when the block has no active cell) |
/// | 4 | 4 | `metacell_pointer`: index of the block's first slot (blocks without slots point where the next one starts) |
/// | 8 | 4 | `min`: smallest corner value of the block's cells, in data units (NaN ignored) |
/// | 12 | 4 | `max`: largest corner value, in data units |
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct Block {
    pub metacell_count: u32,
    pub metacell_pointer: u32,
    pub min: f32,
    pub max: f32,
}
const _: () = assert!(size_of::<Block>() == 16);

impl Block {
    /// Clusters in this block.
    pub fn cluster_count(&self) -> usize {
        self.metacell_count as usize / CLUSTER_SLOTS
    }
    /// Range of slot indices this block owns.
    #[inline]
    pub fn slots(&self) -> std::ops::Range<usize> {
        let start = self.metacell_pointer as usize;
        start..start + self.metacell_count as usize
    }
}

/// One 2×2×2 metacell. 12 bytes, little-endian:
///
/// | offset | size | field |
/// |---|---|---|
/// | 0 | 6 | `position`: 3×u16, metacell units (cell index / 2) over the whole grid |
/// | 6 | 2 | `cell_mask`: bit b set when cell b is active; bits 8–15 reserved (zero) |
/// | 8 | 4 | `cell_pointer`: index of the corner record of its first active cell; the others follow in bit order |
///
/// Padding slots are all zero (mask 0).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct Metacell {
    pub position: [u16; 3],
    pub cell_mask: u16,
    pub cell_pointer: u32,
}
const _: () = assert!(size_of::<Metacell>() == 12);

impl Metacell {
    // Called per traced cell by the CPU tracer in `isogrid-trace`: inlined across the crate boundary.
    #[inline]
    pub fn active_cells(&self) -> u32 {
        (self.cell_mask & 0xff).count_ones()
    }
    pub fn is_empty(&self) -> bool {
        self.cell_mask == 0
    }
    /// Reads slot 15 of a cluster as its bound.
    pub fn as_bound(&self) -> ClusterBound {
        bytemuck::cast(*self)
    }
    /// The box of its active cells in cell indices, `[lo, hi)` per axis (an empty metacell's is
    /// meaningless). From the mask alone: along x, cells 0, 2, 4, 6 are the low half.
    #[inline]
    pub fn cell_box(&self) -> ([u32; 3], [u32; 3]) {
        const LOW: [u16; 3] = [0x55, 0x33, 0x0f];
        let m = self.cell_mask & 0xff;
        let lo = [0, 1, 2].map(|a| 2 * self.position[a] as u32 + (m & LOW[a] == 0) as u32);
        let hi =
            [0, 1, 2].map(|a| 2 * self.position[a] as u32 + 1 + (m & !LOW[a] & 0xff != 0) as u32);
        (lo, hi)
    }
    /// Grid index of cell `bit` of this metacell.
    #[inline]
    pub fn cell_position(&self, bit: u32) -> [u32; 3] {
        let p = self.position;
        [
            2 * p[0] as u32 + (bit & 1),
            2 * p[1] as u32 + (bit >> 1 & 1),
            2 * p[2] as u32 + (bit >> 2 & 1),
        ]
    }
}

/// Axis-aligned bound of a cluster's metacells, stored in its slot 15. 12 bytes, little-endian:
///
/// | offset | size | field |
/// |---|---|---|
/// | 0 | 6 | `lo`: 3×u16, smallest metacell position of the cluster (metacell units) |
/// | 6 | 6 | `hi`: 3×u16, largest metacell position, **inclusive** |
///
/// The box in cell (= sample) units is `[2·lo, 2·hi + 2]` on each axis, which addresses the whole
/// 128K³ grid with 16-bit fields.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Pod, Zeroable)]
pub struct ClusterBound {
    pub lo: [u16; 3],
    pub hi: [u16; 3],
}
const _: () = assert!(size_of::<ClusterBound>() == size_of::<Metacell>());

impl ClusterBound {
    pub fn into_slot(self) -> Metacell {
        bytemuck::cast(self)
    }
    /// The box in cell units, `[lo, hi)` per axis.
    pub fn cell_box(&self) -> ([u32; 3], [u32; 3]) {
        (
            self.lo.map(|v| 2 * v as u32),
            self.hi.map(|v| 2 * v as u32 + 2),
        )
    }
}

/// Bits per stored corner value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Precision {
    /// 1-bit codes, the corners' sides alone (corner c in bit c of one byte): 1 byte per cell.
    /// Enough for a binary indicator, a label's membership, whose surface crosses every edge at
    /// its midpoint.
    Bits1,
    /// 4-bit codes, two per byte (corner c in nibble c, low nibble first): 4 bytes per cell.
    Bits4,
    /// 8-bit codes: 8 bytes per cell.
    Bits8,
    /// 16-bit little-endian codes: 16 bytes per cell.
    Bits16,
    /// 32-bit little-endian IEEE floats in data units: 32 bytes per cell.
    Float32,
}

impl Precision {
    pub const ALL: [Precision; 5] = [
        Precision::Bits1,
        Precision::Bits4,
        Precision::Bits8,
        Precision::Bits16,
        Precision::Float32,
    ];

    pub fn bits(self) -> u32 {
        match self {
            Precision::Bits1 => 1,
            Precision::Bits4 => 4,
            Precision::Bits8 => 8,
            Precision::Bits16 => 16,
            Precision::Float32 => 32,
        }
    }
    pub fn from_bits(bits: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.bits() == bits)
    }
    /// The precision of `bits` given as text (a flag, a keyword argument), or the one-line message
    /// listing the precisions there are.
    pub fn parse_bits(bits: &str) -> Result<Self, String> {
        bits.trim()
            .parse::<u32>()
            .ok()
            .and_then(Self::from_bits)
            .ok_or_else(|| {
                let names: Vec<String> = Self::ALL.iter().map(|p| p.bits().to_string()).collect();
                let (last, rest) = names.split_last().expect("precisions");
                format!(
                    "precision must be {} or {last}, not {bits}",
                    rest.join(", ")
                )
            })
    }
    /// Bytes of one corner record (8 corners).
    pub fn bytes_per_cell(self) -> usize {
        self.bits() as usize
    }
    /// Largest integer code, or `None` for floats.
    pub fn max_code(self) -> Option<u32> {
        match self {
            Precision::Bits1 => Some(1),
            Precision::Bits4 => Some(15),
            Precision::Bits8 => Some(255),
            Precision::Bits16 => Some(65535),
            Precision::Float32 => None,
        }
    }
    /// The default for a volume type: its own precision for u8 and u16, 16-bit for i16 and f32.
    pub fn default_for(scalar: crate::ScalarType) -> Self {
        match scalar {
            crate::ScalarType::U8 => Precision::Bits8,
            _ => Precision::Bits16,
        }
    }
}

/// Reads corner `c` (0..8) of a packed corner record as a code (or, for floats, the value).
pub fn read_corner(record: &[u8], precision: Precision, c: usize) -> f32 {
    match precision {
        Precision::Bits1 => ((record[0] >> c) & 1) as f32,
        Precision::Bits4 => ((record[c / 2] >> (4 * (c % 2))) & 0xf) as f32,
        Precision::Bits8 => record[c] as f32,
        Precision::Bits16 => u16::from_le_bytes([record[2 * c], record[2 * c + 1]]) as f32,
        Precision::Float32 => f32::from_le_bytes(record[4 * c..4 * c + 4].try_into().unwrap()),
    }
}

/// Eight u16 lanes as f32 (`zero`: all bits clear).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn widen_u16x8(words: std::arch::x86_64::__m128i, zero: std::arch::x86_64::__m128i) -> [f32; 8] {
    use std::arch::x86_64::*;
    let mut out = [0f32; 8];
    // SAFETY: SSE2 is part of the x86-64 baseline; the stores write the 8 lanes of `out`.
    unsafe {
        _mm_storeu_ps(
            out.as_mut_ptr(),
            _mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero)),
        );
        _mm_storeu_ps(
            out.as_mut_ptr().add(4),
            _mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero)),
        );
    }
    out
}

/// All eight corners of a packed record, in corner order. One branch on the precision for all
/// eight (the ray tracer reads a record per candidate cell).
///
/// # Panics
/// When `record` is shorter than [`Precision::bytes_per_cell`].
#[inline(always)]
pub fn read_corners(record: &[u8], precision: Precision) -> [f32; 8] {
    match precision {
        Precision::Bits1 => std::array::from_fn(|c| ((record[0] >> c) & 1) as f32),
        Precision::Bits4 => {
            let r: [u8; 4] = record[..4].try_into().unwrap();
            std::array::from_fn(|c| ((r[c / 2] >> (4 * (c % 2))) & 0xf) as f32)
        }
        Precision::Bits8 => {
            let r: [u8; 8] = record[..8].try_into().unwrap();
            #[cfg(target_arch = "x86_64")]
            {
                // Widened in two steps and converted four at a time: LLVM's own code for the
                // map below took some 35 instructions, a tenth of a traced cell.
                use std::arch::x86_64::*;
                // SAFETY: SSE2 is part of the x86-64 baseline; the load reads the 8 bytes of `r`,
                // the stores write the 8 lanes of `out`.
                unsafe {
                    let zero = _mm_setzero_si128();
                    let words = _mm_unpacklo_epi8(_mm_loadl_epi64(r.as_ptr().cast()), zero);
                    widen_u16x8(words, zero)
                }
            }
            #[cfg(not(target_arch = "x86_64"))]
            r.map(|v| v as f32)
        }
        Precision::Bits16 => {
            let r: [u8; 16] = record[..16].try_into().unwrap();
            #[cfg(target_arch = "x86_64")]
            {
                use std::arch::x86_64::*;
                // SAFETY: as above; the load reads the 16 bytes of `r` (x86-64 is little-endian,
                // as the record is).
                unsafe { widen_u16x8(_mm_loadu_si128(r.as_ptr().cast()), _mm_setzero_si128()) }
            }
            #[cfg(not(target_arch = "x86_64"))]
            std::array::from_fn(|c| u16::from_le_bytes([r[2 * c], r[2 * c + 1]]) as f32)
        }
        Precision::Float32 => {
            let r: [u8; 32] = record[..32].try_into().unwrap();
            std::array::from_fn(|c| f32::from_le_bytes(r[4 * c..4 * c + 4].try_into().unwrap()))
        }
    }
}

//! The entropy coder of the packed form's block stream ([`super::pack`]): an adaptive binary range
//! coder and the symbol models the packer codes each field of a block with. `web/src/rangecoder.ts`
//! decodes the same models; its test rebuilds files this side packed, so the two cannot drift.
//!
//! The coder is the LZMA kind: 32-bit range, 12-bit probabilities that move 1/32 of the way
//! towards each bit coded, a byte out whenever the range falls below 2^24, and carries resolved
//! through a cached byte. A flush ends a *chunk* (its last five bytes); the models live on across
//! chunks, so a chunk costs its flush only, and a reader decodes each chunk once it has all of it.
//!
//! Symbols are coded as bits through binary trees of probabilities (a symbol of `n` bits: `n`
//! decisions, each under the probability of the path so far), and integers that span many sizes
//! by their bit length (a tree) then the bits below the leading one (one probability per length
//! and position). Contexts pick the tree: the field's previous value, and for a sample residual
//! the length of the block's previous residual and the spread of its known neighbours.

/// Bits of a probability (of a 0 bit): `1 << PROB_BITS` is certainty.
const PROB_BITS: u32 = 12;
/// How far a probability moves towards each bit coded: 1/2^MOVE_BITS of the way.
const MOVE_BITS: u32 = 5;
const PROB_HALF: u16 = 1 << (PROB_BITS - 1);
/// The range is kept at or above this, shifting out a byte whenever it falls below.
const TOP: u32 = 1 << 24;

/// Writes bits under adaptive probabilities into a byte buffer, chunk by chunk.
pub(crate) struct RangeEncoder {
    low: u64,
    range: u32,
    cache: u8,
    cache_size: u64,
    out: Vec<u8>,
}

impl RangeEncoder {
    pub(crate) fn new() -> RangeEncoder {
        RangeEncoder {
            low: 0,
            range: u32::MAX,
            cache: 0,
            cache_size: 1,
            out: Vec::new(),
        }
    }

    /// Bytes written in this chunk so far.
    pub(crate) fn len(&self) -> usize {
        self.out.len()
    }

    pub(crate) fn bit(&mut self, p: &mut u16, bit: bool) {
        let bound = (self.range >> PROB_BITS) * *p as u32;
        if bit {
            self.low += bound as u64;
            self.range -= bound;
            *p -= *p >> MOVE_BITS;
        } else {
            self.range = bound;
            *p += ((1 << PROB_BITS) - *p) >> MOVE_BITS;
        }
        while self.range < TOP {
            self.range <<= 8;
            self.shift_low();
        }
    }

    fn shift_low(&mut self) {
        if self.low < 0xFF00_0000 || self.low >= 1 << 32 {
            let carry = (self.low >> 32) as u8;
            let mut byte = self.cache;
            loop {
                self.out.push(byte.wrapping_add(carry));
                byte = 0xFF;
                self.cache_size -= 1;
                if self.cache_size == 0 {
                    break;
                }
            }
            self.cache = (self.low >> 24) as u8;
        }
        self.cache_size += 1;
        self.low = (self.low & 0x00FF_FFFF) << 8;
    }

    /// Ends the chunk: its bytes, and a coder ready for the next (the models stay as they are).
    pub(crate) fn finish_chunk(&mut self) -> Vec<u8> {
        for _ in 0..5 {
            self.shift_low();
        }
        let out = std::mem::take(&mut self.out);
        *self = RangeEncoder::new();
        out
    }
}

/// Probabilities of the symbols of `bits` bits under each of `contexts` contexts.
pub(crate) struct BitTree {
    bits: u32,
    probs: Vec<u16>,
}

impl BitTree {
    pub(crate) fn new(bits: u32, contexts: usize) -> BitTree {
        BitTree {
            bits,
            probs: vec![PROB_HALF; contexts << bits],
        }
    }

    pub(crate) fn encode(&mut self, e: &mut RangeEncoder, context: usize, symbol: u32) {
        let base = context << self.bits;
        let mut node = 1usize;
        for i in (0..self.bits).rev() {
            let bit = symbol >> i & 1;
            e.bit(&mut self.probs[base + node], bit == 1);
            node = 2 * node + bit as usize;
        }
    }
}

/// Bit length of `u`: 0 for 0, else the position of its leading one, plus one.
pub(crate) fn bit_length(u: u64) -> u32 {
    64 - u.leading_zeros()
}

/// Integers of up to `max_length` bits (lengths `0..=max_length`): the length under a context,
/// then the bits below the leading one, each under the probability of its length and position.
pub(crate) struct LengthCoded {
    lengths: BitTree,
    max_length: u32,
    mantissa: Vec<u16>,
}

impl LengthCoded {
    pub(crate) fn new(max_length: u32, contexts: usize) -> LengthCoded {
        let tree_bits = bit_length(max_length as u64);
        LengthCoded {
            lengths: BitTree::new(tree_bits, contexts),
            max_length,
            mantissa: vec![PROB_HALF; ((max_length + 1) * max_length.max(1)) as usize],
        }
    }

    pub(crate) fn encode(&mut self, e: &mut RangeEncoder, context: usize, u: u64) {
        let length = bit_length(u);
        debug_assert!(length <= self.max_length);
        self.lengths.encode(e, context, length);
        for i in (0..length.saturating_sub(1)).rev() {
            let p = &mut self.mantissa[(length * self.max_length + i) as usize];
            e.bit(p, u >> i & 1 == 1);
        }
    }
}

/// Contexts of a residual's length: the block's previous residual length and its neighbours'
/// spread, each as a bit length capped at 15.
pub(crate) const RESIDUAL_CONTEXTS: usize = 16 * 16;

/// The context of a residual from the previous residual's length and the spread (largest minus
/// smallest) of the sample's known neighbours at −1 along x, y and z (0 with fewer than two).
pub(crate) fn residual_context(previous_length: u32, spread: u64) -> usize {
    (previous_length.min(15) * 16 + bit_length(spread).min(15)) as usize
}

/// A residual `r` in `0..=max` (modulo `max + 1`) as a small unsigned number: the nearer of
/// `r` and `r − (max + 1)`, zigzagged (0, −1, 1, −2, … → 0, 1, 2, 3, …).
pub(crate) fn fold_residual(r: u64, max: u64) -> u64 {
    let half = max.div_ceil(2);
    if r < half {
        2 * r
    } else {
        2 * (max + 1 - r) - 1
    }
}

/// The models of the packed form's block stream, one per field, in the order `pack.rs` codes.
pub(crate) struct BlockModels {
    pub counts: BitTree,
    pub steps: LengthCoded,
    pub masks: BitTree,
    pub modes: BitTree,
    pub residuals: LengthCoded,
    pub attribute: BitTree,
}

/// Contexts of a Morton step's length: the block's first step, or the previous step's length.
pub(crate) const STEP_CONTEXTS: usize = 13;

impl BlockModels {
    /// For corner codes of `bits` bits and attribute values of `attribute_width` bytes.
    pub(crate) fn new(bits: u32, attribute_width: usize) -> BlockModels {
        BlockModels {
            counts: BitTree::new(4, 1),
            steps: LengthCoded::new(11, STEP_CONTEXTS),
            masks: BitTree::new(8, 256),
            modes: BitTree::new(1, 2),
            residuals: LengthCoded::new(bits, RESIDUAL_CONTEXTS),
            attribute: BitTree::new(8, 256 * attribute_width.max(1)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folding_maps_residuals_one_to_one() {
        for bits in [1u32, 4, 8] {
            let max = (1u64 << bits) - 1;
            let mut seen: Vec<u64> = (0..=max).map(|r| fold_residual(r, max)).collect();
            seen.sort_unstable();
            assert_eq!(seen, (0..=max).collect::<Vec<_>>(), "{bits} bits");
        }
        assert_eq!(fold_residual(u32::MAX as u64, u32::MAX as u64), 1);
        assert_eq!(fold_residual(0, 255), 0);
        assert_eq!(fold_residual(255, 255), 1);
        assert_eq!(fold_residual(1, 255), 2);
    }
}

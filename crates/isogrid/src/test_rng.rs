//! A seeded xorshift64 generator for the unit tests' random cases: reproducible, no dependency.

/// Successive 64-bit values from a non-zero `seed`.
pub(crate) fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    }
}

//! A label's indicator smoothed by a separable Gaussian on one block's gathered samples (the
//! `--smooth` of label extraction), computed only within the kernel's reach of that label's own
//! samples. Coordinates are sample indices: "region" ones inside the block's gathered samples
//! (the block and its halo, x fastest), "cube" ones inside the block's own 17³ samples.
//!
//! Every output is `Σₖ wₖ·vₖ` summed in kernel order from 0 in f32 over the indicator `vₖ` of
//! the samples under the kernel (samples beyond the region repeat its border). Terms whose sample
//! is 0 add +0 and change nothing, so the passes leave them out: outside the label's box widened
//! by the kernel's radius every output is 0, and inside it rows and planes of zeros are skipped.
//! Where a block holds many labels (supervoxels: some twenty in reach of a 16³ block), each label
//! costs its own box rather than the whole region.

/// The smoothing kernel's weights, and for short kernels the x pass's table: the sum of the
/// weights under every pattern of the label's samples along a row.
pub(super) struct SmoothingKernel {
    weights: Vec<f32>,
    /// Entry `m`: `Σₖ wₖ·bitₖ(m)` in kernel order from 0 (adding +0 for a clear bit changes
    /// nothing), so a lookup gives what the sum over the row would.
    row_sums: Option<Vec<f32>>,
}

/// Longest kernel whose row patterns are tabulated (2¹¹ entries, 8 KiB): radius 5, σ ≤ 5/3.
const TABULATED_TAPS: usize = 11;

impl SmoothingKernel {
    pub(super) fn new(weights: Vec<f32>) -> Self {
        let row_sums = (weights.len() <= TABULATED_TAPS).then(|| {
            (0..1usize << weights.len())
                .map(|m| {
                    let mut s = 0.0f32;
                    for (k, &w) in weights.iter().enumerate() {
                        if m >> k & 1 != 0 {
                            s += w;
                        }
                    }
                    s
                })
                .collect()
        });
        SmoothingKernel { weights, row_sums }
    }

    /// Samples read beyond a block's on each side.
    pub(super) fn radius(&self) -> usize {
        self.weights.len() / 2
    }
}

/// An inclusive box of samples of the gathered region.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SampleBox {
    pub lo: [usize; 3],
    pub hi: [usize; 3],
}

/// Buffers reused from label to label and block to block.
#[derive(Default)]
pub(super) struct SmoothScratch {
    /// Each present label's [`SampleBox`], in the order of the `present` list.
    pub boxes: Vec<SampleBox>,
    padded: Vec<f32>,
    pass_x: Vec<f32>,
    pass_y: Vec<f32>,
    /// Which rows of `pass_x` and planes of `pass_y` are all zero.
    zero_x: Vec<bool>,
    zero_y: Vec<bool>,
    /// The smoothed indicator on the block's cube of samples (x fastest).
    pub smooth: Vec<f32>,
}

/// The box of each of `present` (sorted, distinct, every one occurring) among `keys`, the
/// gathered region of `region` samples (x fastest), into `boxes` in the order of `present`.
pub(super) fn label_boxes(
    keys: &[u64],
    region: [usize; 3],
    present: &[u64],
    boxes: &mut Vec<SampleBox>,
) {
    boxes.clear();
    boxes.resize(
        present.len(),
        SampleBox {
            lo: [usize::MAX; 3],
            hi: [0; 3],
        },
    );
    let [rx, ry, _] = region;
    for (r, row) in keys.chunks_exact(rx).enumerate() {
        let (y, z) = (r % ry, r / ry);
        let mut x = 0;
        while x < rx {
            // A run of one label: its first and last sample widen the label's box.
            let key = row[x];
            let end = x + row[x..].iter().take_while(|&&k| k == key).count();
            let i = present
                .binary_search(&key)
                .expect("every gathered key is in the present list");
            let b = &mut boxes[i];
            b.lo = [b.lo[0].min(x), b.lo[1].min(y), b.lo[2].min(z)];
            b.hi = [b.hi[0].max(end - 1), b.hi[1].max(y), b.hi[2].max(z)];
            x = end;
        }
    }
}

/// One block's gathered samples, as the label pass holds them.
#[derive(Clone, Copy)]
pub(super) struct GatheredBlock<'a> {
    /// The samples' label keys, `region` of them, x fastest.
    pub keys: &'a [u64],
    pub region: [usize; 3],
    /// The block's own samples, a `cube` starting at `at` inside the region.
    pub at: [usize; 3],
    pub cube: [usize; 3],
}

/// Label `key`'s indicator on `block`'s samples, whose samples equal to `key` all lie in
/// `support`, smoothed by `kernel` along x, y and z, into `scratch.smooth` on the block's cube.
/// Returns the smallest and largest value on the cube.
///
/// Built twice from one body: for the x86-64 baseline, and with AVX2 where the processor has it
/// (eight lanes to SSE's four). Neither contracts a multiply and an add into an FMA, so both give
/// the same bits, and a file does not depend on the machine that wrote it.
pub(super) fn smooth_indicator(
    block: GatheredBlock,
    key: u64,
    support: SampleBox,
    kernel: &SmoothingKernel,
    scratch: &mut SmoothScratch,
) -> [f32; 2] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2, which is all the function enables.
        return unsafe { smooth_indicator_avx2(block, key, support, kernel, scratch) };
    }
    smooth_indicator_body(block, key, support, kernel, scratch)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn smooth_indicator_avx2(
    block: GatheredBlock,
    key: u64,
    support: SampleBox,
    kernel: &SmoothingKernel,
    scratch: &mut SmoothScratch,
) -> [f32; 2] {
    smooth_indicator_body(block, key, support, kernel, scratch)
}

#[inline(always)]
fn smooth_indicator_body(
    block: GatheredBlock,
    key: u64,
    support: SampleBox,
    kernel: &SmoothingKernel,
    scratch: &mut SmoothScratch,
) -> [f32; 2] {
    let GatheredBlock {
        keys,
        region,
        at,
        cube,
    } = block;
    let (r, weights) = (kernel.radius(), &kernel.weights[..]);
    let [cx, cy, cz] = cube;
    scratch.smooth.clear();
    scratch.smooth.resize(cx * cy * cz, 0.0);
    // The outputs the label's samples reach, in cube coordinates: its box widened by the radius.
    let reach = |a: usize| {
        let lo = (support.lo[a].saturating_sub(r)).max(at[a]) - at[a];
        let hi = (support.hi[a] + r).min(at[a] + cube[a] - 1);
        (lo + at[a] <= hi).then(|| lo..hi - at[a] + 1)
    };
    let (Some(ox), Some(oy), Some(oz)) = (reach(0), reach(1), reach(2)) else {
        return [0.0, 0.0];
    };
    let [sy, sz] = [1, 2].map(|a| support.hi[a] - support.lo[a] + 1);
    let (wx, wy) = (ox.len(), oy.len());
    // The region index under kernel tap `k` of output `c` (region coordinates) along y or z, the
    // border repeated, as its offset inside the support where it falls there.
    let tap = |a: usize, c: usize, k: usize| -> Option<usize> {
        let j = (c + k).saturating_sub(r).min(region[a] - 1);
        (support.lo[a]..=support.hi[a])
            .contains(&j)
            .then(|| j - support.lo[a])
    };

    // Along x: reached x × support y × support z. Each region row is first laid out as the
    // indicator of the samples under the kernel of every output (samples beyond the support are
    // other labels'), so the sum runs over a plain slice.
    let [rx, ry, _] = region;
    scratch.pass_x.clear();
    scratch.pass_x.resize(wx * sy * sz, 0.0);
    scratch.zero_x.clear();
    let first_tap = at[0] + ox.start;
    for (i, out) in scratch.pass_x.chunks_exact_mut(wx).enumerate() {
        let (y, z) = (support.lo[1] + i % sy, support.lo[2] + i / sy);
        let row = &keys[rx * (y + ry * z)..][..rx];
        let taps = (0..wx + 2 * r).map(|t| {
            let j = (first_tap + t).saturating_sub(r).min(rx - 1);
            row[j] == key
        });
        if let Some(table) = &kernel.row_sums {
            // The row's pattern as bits (at most 16 + 2·5 + 1 of them), one lookup per output.
            let bits = taps
                .enumerate()
                .fold(0u64, |b, (t, on)| b | (on as u64) << t);
            scratch.zero_x.push(bits == 0);
            let mask = (1u64 << weights.len()) - 1;
            for (x, o) in out.iter_mut().enumerate() {
                *o = table[(bits >> x & mask) as usize];
            }
            continue;
        }
        scratch.padded.clear();
        scratch
            .padded
            .extend(taps.map(|on| f32::from(u8::from(on))));
        let zero = scratch.padded.iter().all(|&v| v == 0.0);
        scratch.zero_x.push(zero);
        if zero {
            continue;
        }
        // Tap by tap over the whole row (each output still sums its taps in kernel order), so
        // the loop runs across x and vectorises.
        for (k, &w) in weights.iter().enumerate() {
            for (o, &v) in out.iter_mut().zip(&scratch.padded[k..]) {
                *o += w * v;
            }
        }
    }

    // Along y: reached x × reached y × support z.
    scratch.pass_y.clear();
    scratch.pass_y.resize(wx * wy * sz, 0.0);
    scratch.zero_y.clear();
    for z in 0..sz {
        let mut plane_zero = true;
        for (y, c) in oy.clone().map(|y| at[1] + y).enumerate() {
            let out = &mut scratch.pass_y[wx * (y + wy * z)..][..wx];
            for (k, &w) in weights.iter().enumerate() {
                let Some(row) = tap(1, c, k).map(|j| j + sy * z) else {
                    continue;
                };
                if scratch.zero_x[row] {
                    continue;
                }
                plane_zero = false;
                let input = &scratch.pass_x[wx * row..][..wx];
                for (o, &v) in out.iter_mut().zip(input) {
                    *o += w * v;
                }
            }
        }
        scratch.zero_y.push(plane_zero);
    }

    // Along z: the reached part of the cube.
    let mut range = [f32::INFINITY, f32::NEG_INFINITY];
    let mut plane = vec![0.0f32; 0];
    std::mem::swap(&mut plane, &mut scratch.padded);
    for (z, c) in oz.clone().map(|z| (z, at[2] + z)) {
        plane.clear();
        plane.resize(wx * wy, 0.0);
        for (k, &w) in weights.iter().enumerate() {
            let Some(p) = tap(2, c, k) else { continue };
            if scratch.zero_y[p] {
                continue;
            }
            let input = &scratch.pass_y[wx * wy * p..][..wx * wy];
            for (o, &v) in plane.iter_mut().zip(input) {
                *o += w * v;
            }
        }
        for (y, row) in oy.clone().zip(plane.chunks_exact(wx)) {
            scratch.smooth[cx * (y + cy * z)..][ox.clone()].copy_from_slice(row);
        }
        range = value_range(&plane, range);
    }
    std::mem::swap(&mut plane, &mut scratch.padded);
    if wx * wy * oz.len() < cx * cy * cz {
        // Outputs beyond the label's reach are 0.
        range = [range[0].min(0.0), range[1].max(0.0)];
    }
    range
}

/// The smallest and largest of `values` and `range`, which are never NaN (sums of non-negative
/// weights). Eight lanes of compare-and-select rather than `f32::min`, whose NaN rule keeps a
/// loop scalar.
#[inline(always)]
fn value_range(values: &[f32], range: [f32; 2]) -> [f32; 2] {
    let (mut lo, mut hi) = ([range[0]; 8], [range[1]; 8]);
    let lanes = values.chunks_exact(8);
    let rest = lanes.remainder();
    for chunk in lanes {
        for i in 0..8 {
            lo[i] = if chunk[i] < lo[i] { chunk[i] } else { lo[i] };
            hi[i] = if chunk[i] > hi[i] { chunk[i] } else { hi[i] };
        }
    }
    for (i, &v) in rest.iter().enumerate() {
        lo[i] = if v < lo[i] { v } else { lo[i] };
        hi[i] = if v > hi[i] { v } else { hi[i] };
    }
    let fold = |a: [f32; 8], pick: fn(f32, f32) -> f32| a.into_iter().reduce(pick).unwrap();
    [fold(lo, f32::min), fold(hi, f32::max)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::extract::labels::gaussian_kernel;
    use crate::test_rng::xorshift;

    /// The definition, every output summed over every tap in kernel order from 0, samples beyond
    /// the region repeating its border.
    fn dense(
        keys: &[u64],
        key: u64,
        region: [usize; 3],
        at: [usize; 3],
        cube: [usize; 3],
        kernel: &[f32],
    ) -> Vec<f32> {
        let r = (kernel.len() / 2) as isize;
        let clamp = |i: isize, n: usize| i.clamp(0, n as isize - 1) as usize;
        let [rx, ry, rz] = region;
        let v = |x: usize, y: usize, z: usize| (keys[x + rx * (y + ry * z)] == key) as u8 as f32;
        let mut px = vec![0.0f32; cube[0] * ry * rz];
        for z in 0..rz {
            for y in 0..ry {
                for x in 0..cube[0] {
                    let mut s = 0.0f32;
                    for (k, w) in kernel.iter().enumerate() {
                        s += w * v(clamp((at[0] + x) as isize + k as isize - r, rx), y, z);
                    }
                    px[x + cube[0] * (y + ry * z)] = s;
                }
            }
        }
        let mut py = vec![0.0f32; cube[0] * cube[1] * rz];
        for z in 0..rz {
            for y in 0..cube[1] {
                for x in 0..cube[0] {
                    let mut s = 0.0f32;
                    for (k, w) in kernel.iter().enumerate() {
                        let j = clamp((at[1] + y) as isize + k as isize - r, ry);
                        s += w * px[x + cube[0] * (j + ry * z)];
                    }
                    py[x + cube[0] * (y + cube[1] * z)] = s;
                }
            }
        }
        let mut out = vec![0.0f32; cube[0] * cube[1] * cube[2]];
        for z in 0..cube[2] {
            for y in 0..cube[1] {
                for x in 0..cube[0] {
                    let mut s = 0.0f32;
                    for (k, w) in kernel.iter().enumerate() {
                        let j = clamp((at[2] + z) as isize + k as isize - r, rz);
                        s += w * py[x + cube[0] * (y + cube[1] * j)];
                    }
                    out[x + cube[0] * (y + cube[1] * z)] = s;
                }
            }
        }
        out
    }

    /// Bit for bit the definition, for blobs of labels of every size (one sample to the whole
    /// region), regions clipped by the volume's border on either side, several σ (the x pass
    /// tabulated up to σ 1.6, summed at σ 2).
    #[test]
    fn smoothing_within_reach_is_the_dense_sum_bit_for_bit() {
        let mut next = xorshift(40);
        let mut below = |n: u64| next() % n;
        let mut scratch = SmoothScratch::default();
        for case in 0..300 {
            let sigma = [0.5, 1.0, 1.6, 2.0][case % 4];
            let kernel = gaussian_kernel(sigma);
            let smoothing = SmoothingKernel::new(kernel.clone());
            let r = kernel.len() / 2;
            let cube = [0, 1, 2].map(|_| 2 + below(16) as usize);
            // Clipped below and/or above by the volume on some axes.
            let before = [0, 1, 2].map(|_| if below(3) == 0 { 0 } else { r });
            let after = [0, 1, 2].map(|_| if below(3) == 0 { 0 } else { r });
            let region = [0, 1, 2].map(|a| before[a] + cube[a] + after[a]);
            // A few labels as boxes painted over a background, some of one sample.
            let mut keys = vec![0u64; region.iter().product()];
            for label in 1..=1 + below(5) {
                let lo = region.map(|n| below(n as u64) as usize);
                let size = [0, 1, 2].map(|_| {
                    1 + {
                        let m = 1 + below(12);
                        below(m)
                    } as usize
                });
                for z in lo[2]..(lo[2] + size[2]).min(region[2]) {
                    for y in lo[1]..(lo[1] + size[1]).min(region[1]) {
                        for x in lo[0]..(lo[0] + size[0]).min(region[0]) {
                            keys[x + region[0] * (y + region[1] * z)] = label;
                        }
                    }
                }
            }
            let mut present = keys.clone();
            present.sort_unstable();
            present.dedup();
            label_boxes(&keys, region, &present, &mut scratch.boxes);
            for (i, &key) in present.iter().enumerate() {
                let support = scratch.boxes[i];
                let want = dense(&keys, key, region, before, cube, &kernel);
                let block = GatheredBlock {
                    keys: &keys,
                    region,
                    at: before,
                    cube,
                };
                let range = smooth_indicator(block, key, support, &smoothing, &mut scratch);
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(&scratch.smooth),
                    bits(&want),
                    "case {case}, label {key}"
                );
                let lo = want.iter().fold(f32::INFINITY, |m, &v| m.min(v));
                let hi = want.iter().fold(f32::NEG_INFINITY, |m, &v| m.max(v));
                assert_eq!(range, [lo, hi], "case {case}, label {key}");
            }
        }
    }

    /// The baseline and AVX2 builds give the same bits (where the processor has AVX2).
    #[test]
    fn both_builds_agree_bit_for_bit() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let mut next = xorshift(3);
            let region = [29, 23, 25];
            // Patches of four labels, so rows mix labels at every x.
            let keys: Vec<u64> = (0..region.iter().product::<usize>())
                .map(|i| (i / 3 + i / 87 + (next() % 4) as usize / 3) as u64 % 4)
                .collect();
            let (at, cube) = ([6, 3, 4], [17, 17, 17]);
            let mut present = keys.clone();
            present.sort_unstable();
            present.dedup();
            let (mut a, mut b) = (SmoothScratch::default(), SmoothScratch::default());
            label_boxes(&keys, region, &present, &mut a.boxes);
            for sigma in [0.7, 1.0, 2.0] {
                let kernel = SmoothingKernel::new(gaussian_kernel(sigma));
                for (i, &key) in present.iter().enumerate() {
                    let s = a.boxes[i];
                    let block = GatheredBlock {
                        keys: &keys,
                        region,
                        at,
                        cube,
                    };
                    let ra = smooth_indicator_body(block, key, s, &kernel, &mut a);
                    // SAFETY: AVX2 is present (checked above).
                    let rb = unsafe { smooth_indicator_avx2(block, key, s, &kernel, &mut b) };
                    assert_eq!(ra, rb);
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&a.smooth), bits(&b.smooth), "σ {sigma}, label {key}");
                }
            }
        }
    }

    #[test]
    fn boxes_hold_exactly_each_labels_samples() {
        let region = [5, 4, 3];
        let mut keys = vec![7u64; 60];
        keys[1 + 5 * (2 + 4)] = 3; // (1, 2, 1)
        keys[4 + 5 * (4 * 2)] = 3; // (4, 0, 2)
        keys[0] = 9;
        let mut boxes = Vec::new();
        label_boxes(&keys, region, &[3, 7, 9], &mut boxes);
        let b = |lo, hi| SampleBox { lo, hi };
        assert_eq!(boxes[0], b([1, 0, 1], [4, 2, 2]));
        assert_eq!(boxes[1], b([0, 0, 0], [4, 3, 2]));
        assert_eq!(boxes[2], b([0, 0, 0], [0, 0, 0]));
    }
}

//! Streaming extraction: the file written slab by slab must be byte-identical to the in-memory
//! extraction written with `cgc::to_bytes`, for any slab size, output group size, thread count,
//! isovalue form and precision; failures must leave no file behind.

use crate::common::{field, random_u8, Rng};
use isogrid::extract::stream::{
    self, extract_planned, extract_to_file, MemoryPlan, RegionSource, SlabMut,
};
use isogrid::{
    cgc, extract, ErrorKind, ExtractOptions, Iso, Precision, Progress, Volume, VolumeData,
};
use std::ops::Range;
use std::path::PathBuf;

pub(crate) struct TempDir(pub PathBuf);

impl TempDir {
    pub(crate) fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("isogrid-stream-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
    pub(crate) fn entries(&self) -> Vec<String> {
        let mut names: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Volumes of every type with shapes that are not multiples of 16, including degenerate ones.
pub(crate) fn volumes() -> Vec<(&'static str, Volume)> {
    let mut rng = Rng::new(7);
    let wave = |dims: [usize; 3]| {
        field(dims, |x, y, z| {
            (x * 0.31).sin() * (y * 0.23).cos() + (z * 0.17).sin() + 0.1 * (x + y) / 7.0
        })
    };
    let f32_dims = [19, 40, 35];
    let mut f32_values: Vec<f32> = wave(f32_dims).into_iter().map(|v| v as f32).collect();
    for _ in 0..40 {
        let i = rng.below(f32_values.len() as u64) as usize;
        f32_values[i] = f32::NAN;
    }
    let u16_dims = [17, 17, 50];
    let i16_dims = [40, 3, 65];
    vec![
        ("u8 random", random_u8([37, 21, 50], 3, 3)),
        (
            "f32 wave with NaN",
            Volume::new(f32_dims, VolumeData::F32(f32_values)).unwrap(),
        ),
        (
            "u16 wave",
            Volume::new(
                u16_dims,
                VolumeData::U16(
                    wave(u16_dims)
                        .into_iter()
                        .map(|v| (v * 9000.0 + 30000.0) as u16)
                        .collect(),
                ),
            )
            .unwrap()
            .with_spacing([0.5, 0.7, 1.25])
            .unwrap()
            .with_origin([-3.0, 4.0, 10.0])
            .unwrap(),
        ),
        (
            "i16 wave",
            Volume::new(
                i16_dims,
                VolumeData::I16(
                    wave(i16_dims)
                        .into_iter()
                        .map(|v| (v * 1000.0) as i16)
                        .collect(),
                ),
            )
            .unwrap(),
        ),
        ("u8 thin", random_u8([9, 2, 33], 5, 2)),
        ("u8 2x2x2", random_u8([2, 2, 2], 11, 2)),
        ("u8 single plane", random_u8([8, 8, 1], 13, 4)),
        // Two values an f32 cannot tell apart, and 64-bit values beyond f64's integers.
        (
            "u32 near 2^24",
            Volume::new(
                [21, 18, 19],
                VolumeData::U32(two_levels(&mut rng, 21 * 18 * 19, 16_777_216, 16_777_217)),
            )
            .unwrap(),
        ),
        (
            "i64 beyond 2^53",
            Volume::new(
                [18, 33, 17],
                VolumeData::I64(
                    (0..18 * 33 * 17)
                        .map(|_| (1i64 << 53) + rng.below(5) as i64)
                        .collect(),
                ),
            )
            .unwrap(),
        ),
        (
            "f64 1e-12 apart",
            Volume::new(
                [17, 20, 22],
                VolumeData::F64(two_levels(&mut rng, 17 * 20 * 22, 1.0, 1.0 + 1e-12)),
            )
            .unwrap(),
        ),
    ]
}

/// `n` samples, each `lo` or `hi` at random.
pub(crate) fn two_levels<T: Copy>(rng: &mut Rng, n: usize, lo: T, hi: T) -> Vec<T> {
    (0..n)
        .map(|_| if rng.below(2) == 0 { lo } else { hi })
        .collect()
}

pub(crate) fn option_sets() -> Vec<ExtractOptions> {
    vec![
        ExtractOptions::new(Iso::Normalized(0.5)),
        ExtractOptions::new(Iso::Normalized(0.3)).with_precision(Precision::Bits4),
        ExtractOptions::new(Iso::Value(0.4)).with_precision(Precision::Bits16),
        ExtractOptions::new(Iso::Value(128.0)).with_precision(Precision::Float32),
    ]
}

pub(crate) fn plan(layers: usize, output_buffer: u64) -> MemoryPlan {
    MemoryPlan {
        max_memory: u64::MAX,
        slab_layers: layers,
        slab_bytes: 0,
        output_buffer,
        fixed: 0,
        minimum: 0,
    }
}

#[test]
fn streamed_files_are_byte_identical_to_in_memory_ones() {
    let dir = TempDir::new("identical");
    let out = dir.0.join("out.cgc");
    let mut compared = 0;
    for (name, volume) in volumes() {
        for options in option_sets() {
            let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
            // One-layer slabs with one-block groups, mid-sized slabs, and the whole volume at once.
            for (layers, buffer) in [(1, 1), (2, 1 << 20), (3, 5000), (100, 64 << 20)] {
                for threads in [1, 3] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let mut source = volume.view();
                    let summary = pool
                        .install(|| {
                            extract_planned(
                                &mut source,
                                &options,
                                &plan(layers, buffer),
                                &out,
                                &Progress::new(),
                            )
                        })
                        .unwrap();
                    let written = std::fs::read(&out).unwrap();
                    assert!(
                        written == expected,
                        "{name} {options:?} layers {layers} buffer {buffer} threads {threads}: \
                         {} streamed bytes differ from {} in-memory bytes",
                        written.len(),
                        expected.len()
                    );
                    let grid = cgc::read_bytes(&written).unwrap();
                    assert_eq!(summary.stats, isogrid::GridStats::of(&grid), "{name}");
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 10 * 4 * 4 * 2);
    assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
}

#[test]
fn budgets_from_the_least_that_works_upwards_give_the_same_bytes() {
    let dir = TempDir::new("budgets");
    let out = dir.0.join("out.cgc");
    let volume = random_u8([70, 50, 90], 17, 5);
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
    let minimum = stream::plan(&volume.view(), u64::MAX).unwrap().minimum;
    let layer_bytes = 70 * 50 * 16;
    let mut layer_counts = Vec::new();
    for budget in [
        minimum,
        minimum + layer_bytes,
        minimum + 3 * layer_bytes,
        1 << 40,
    ] {
        let mut source = volume.view();
        let summary =
            extract_to_file(&mut source, &options, budget, &out, &Progress::new()).unwrap();
        assert!(
            summary.plan.fixed + summary.plan.slab_bytes + summary.plan.output_buffer <= budget
        );
        layer_counts.push(summary.plan.slab_layers);
        assert!(std::fs::read(&out).unwrap() == expected, "budget {budget}");
    }
    // The budgets really did give different slabs: 1 layer at the minimum, all 6 at the top.
    assert_eq!(layer_counts.first(), Some(&1));
    assert_eq!(layer_counts.last(), Some(&6));
    assert!(
        layer_counts.windows(2).all(|w| w[0] <= w[1]),
        "{layer_counts:?}"
    );
}

#[test]
fn a_budget_below_one_slab_names_the_least_that_works_and_writes_nothing() {
    let dir = TempDir::new("small-budget");
    let out = dir.0.join("out.cgc");
    let volume = random_u8([64, 64, 40], 1, 2);
    let minimum = stream::plan(&volume.view(), u64::MAX).unwrap().minimum;
    let err = extract_to_file(
        &mut volume.view(),
        &ExtractOptions::new(Iso::Value(100.0)),
        minimum - 1,
        &out,
        &Progress::new(),
    )
    .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::TooLarge);
    let least = stream::format_bytes_at_least(minimum.next_multiple_of(1 << 20));
    assert!(
        err.to_string()
            .contains(&format!("the least that works is {least}")),
        "{err}"
    );
    assert!(dir.entries().is_empty());
}

/// A least budget is shown rounded up, so that the figure given is enough; other sizes to the
/// nearest figure.
#[test]
fn least_budgets_are_shown_rounded_up() {
    let gib = 1u64 << 30;
    let just_over_two = 2 * gib + 40 * (1 << 20);
    assert_eq!(stream::format_bytes(just_over_two), "2.0 GiB");
    assert_eq!(stream::format_bytes_at_least(just_over_two), "2.1 GiB");
    assert_eq!(stream::format_bytes_at_least(2 * gib), "2 GiB");
    assert_eq!(stream::format_bytes_at_least(gib - 1), "1024 MiB");
    assert_eq!(stream::format_bytes_at_least(1536 * (1 << 10)), "1.5 MiB");
    assert_eq!(stream::format_bytes_at_least(1537 * (1 << 10)), "1.6 MiB");
    assert_eq!(stream::format_bytes(3 * gib + gib / 5), "3.2 GiB");
}

/// A source that counts its reads, fails on its `fail_at`-th (to check that nothing is left
/// behind), and delivers no more than `read_planes_within` promises: there every u8 sample
/// outside the wanted blocks comes out inverted (inside turned outside), so an emit that read one
/// would write different bytes.
struct Failing<'a> {
    inner: isogrid::VolumeView<'a>,
    reads: usize,
    masked_reads: usize,
    fail_at: usize,
}

impl<'a> Failing<'a> {
    fn new(inner: isogrid::VolumeView<'a>, fail_at: usize) -> Self {
        Failing {
            inner,
            reads: 0,
            masked_reads: 0,
            fail_at,
        }
    }
}

impl RegionSource for Failing<'_> {
    fn geometry(&self) -> isogrid::Geometry {
        *self.inner.geometry()
    }
    fn scalar_type(&self) -> isogrid::ScalarType {
        self.inner.scalar_type()
    }
    fn read_planes(&mut self, z: Range<usize>, out: SlabMut<'_>) -> isogrid::Result<()> {
        self.reads += 1;
        if self.reads == self.fail_at {
            return Err(isogrid::Error::corrupt(format!("planes {z:?} unreadable")));
        }
        self.inner.read_planes(z, out)
    }
    fn read_planes_within(
        &mut self,
        z: Range<usize>,
        out: SlabMut<'_>,
        wanted: &stream::BlockMask,
    ) -> isogrid::Result<()> {
        self.masked_reads += 1;
        let SlabMut::U8(samples) = out else {
            return self.read_planes(z, out);
        };
        self.read_planes(z, SlabMut::U8(&mut *samples))?;
        let [nx, ny, _] = self.inner.dims();
        for (i, v) in samples.iter_mut().enumerate() {
            let (x, y) = (i % nx, i / nx % ny);
            if !wanted.touches(x..x + 1, y..y + 1) {
                *v ^= 0xff;
            }
        }
        Ok(())
    }
}

#[test]
fn a_read_error_in_any_pass_leaves_no_file_and_keeps_an_old_one() {
    let dir = TempDir::new("failing");
    let out = dir.0.join("out.cgc");
    std::fs::write(&out, b"old").unwrap();
    let volume = random_u8([20, 20, 50], 9, 2);
    // 4 one-layer slabs: reads 1-4 are the range pass, 5-8 the scan, 9-12 the emit.
    for fail_at in [2, 6, 11] {
        let mut source = Failing::new(volume.view(), fail_at);
        let err = extract_planned(
            &mut source,
            &ExtractOptions::new(Iso::Normalized(0.5)),
            &plan(1, 1),
            &out,
            &Progress::new(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("unreadable"), "{err}");
        assert_eq!(std::fs::read(&out).unwrap(), b"old");
        assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
    }
}

/// `done` reaches `total`: one step per block and pass (scan, emit, and the value-range pass of a
/// normalised isovalue), whatever the slab size.
#[test]
fn progress_counts_each_block_once_per_pass() {
    let dir = TempDir::new("progress");
    let volume = random_u8([40, 20, 50], 9, 2);
    // ceil(39/16)·ceil(19/16)·ceil(49/16) blocks.
    let blocks = 3 * 2 * 4;
    for (iso, passes) in [(Iso::Normalized(0.5), 3), (Iso::Value(100.0), 2)] {
        for layers in [1, 2, 64] {
            let progress = Progress::new();
            extract_planned(
                &mut volume.view(),
                &ExtractOptions::new(iso),
                &plan(layers, 1 << 20),
                &dir.0.join("out.cgc"),
                &progress,
            )
            .unwrap();
            let want = passes * blocks;
            assert_eq!(progress.counts(), (want, want), "{iso:?}, {layers} layers");
        }
    }
}

/// A source that cancels `progress` as its `cancel_at`-th read ends, and counts reads.
pub(crate) struct Cancelling<'a> {
    pub inner: isogrid::VolumeView<'a>,
    pub progress: &'a Progress,
    pub reads: usize,
    pub cancel_at: usize,
}

impl RegionSource for Cancelling<'_> {
    fn geometry(&self) -> isogrid::Geometry {
        *self.inner.geometry()
    }
    fn scalar_type(&self) -> isogrid::ScalarType {
        self.inner.scalar_type()
    }
    fn read_planes(&mut self, z: Range<usize>, out: SlabMut<'_>) -> isogrid::Result<()> {
        self.reads += 1;
        if self.reads == self.cancel_at {
            self.progress.cancel();
        }
        self.inner.read_planes(z, out)
    }
}

/// A cancel in any pass (the value range, the scan, the emit) stops the run before its next read
/// and before the slab's blocks count, fails with kind Cancelled, and leaves no file and no
/// temporary file: an old output stays as it was.
#[test]
fn a_cancelled_streamed_extraction_stops_at_once_and_leaves_no_file() {
    let dir = TempDir::new("cancel");
    let out = dir.0.join("out.cgc");
    std::fs::write(&out, b"old").unwrap();
    let volume = random_u8([40, 20, 50], 9, 2);
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    // One-layer slabs: reads 1-3 are the range pass (17 planes each), 4-7 the scan, 8-11 the emit.
    let uncancelled = Progress::new();
    let mut source = Cancelling {
        inner: volume.view(),
        progress: &uncancelled,
        reads: 0,
        cancel_at: usize::MAX,
    };
    extract_planned(&mut source, &options, &plan(1, 1 << 20), &out, &uncancelled).unwrap();
    assert_eq!(source.reads, 11);
    std::fs::write(&out, b"old").unwrap();
    let blocks_per_layer = 3 * 2;
    for cancel_at in [1, 3, 4, 6, 8, 10] {
        let progress = Progress::new();
        let mut source = Cancelling {
            inner: volume.view(),
            progress: &progress,
            reads: 0,
            cancel_at,
        };
        let err =
            extract_planned(&mut source, &options, &plan(1, 1 << 20), &out, &progress).unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
        assert_eq!(source.reads, cancel_at, "no read after the cancel");
        // Block layers counted: the range pass counts a layer once its 17 planes are read (the
        // cancelled read's chunk included: 1, 2, then all 4 layers), the scan and emit passes
        // the slabs before the cancelled one (one layer each), none of its own.
        let (done, total) = progress.counts();
        assert_eq!(total, 3 * 24);
        let before = if cancel_at == 3 { 4 } else { cancel_at };
        assert_eq!(
            done,
            (before * blocks_per_layer) as u64,
            "cancelled at read {cancel_at}"
        );
        assert_eq!(std::fs::read(&out).unwrap(), b"old");
        assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
    }
}

/// Streams `volume` through a [`Failing`] source that never fails, in slabs of `layers` layers:
/// the file's bytes, the reads and the masked reads.
fn stream_counted(
    volume: &Volume,
    options: &ExtractOptions,
    layers: usize,
    out: &std::path::Path,
) -> (Vec<u8>, usize, usize) {
    let mut source = Failing::new(volume.view(), usize::MAX);
    extract_planned(
        &mut source,
        options,
        &plan(layers, 1 << 20),
        out,
        &Progress::new(),
    )
    .unwrap();
    (
        std::fs::read(out).unwrap(),
        source.reads,
        source.masked_reads,
    )
}

/// Every pass reads its slabs, but a pass that starts on the planes the previous one ended on
/// takes them from the buffer: a volume in one slab is read once for the range, scan and emit
/// passes together.
#[test]
fn a_volume_in_one_slab_is_read_once_for_every_pass() {
    let dir = TempDir::new("read-once");
    let out = dir.0.join("out.cgc");
    let volume = random_u8([20, 20, 50], 9, 2);
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
    // One-layer slabs: 3 range reads of 17 planes, then 4 slabs each for scan and emit.
    for (layers, reads) in [(64, 1), (1, 3 + 4 + 4)] {
        let (bytes, counted, _) = stream_counted(&volume, &options, layers, &out);
        assert_eq!(counted, reads, "{layers}-layer slabs");
        assert!(bytes == expected);
    }
}

/// The emit pass reads only the samples of active blocks (and a chunked store may skip the
/// rest): balls in a larger volume, whose blocks are mostly empty, stream to the in-memory bytes
/// when every other sample of the emit reads is wrong.
#[test]
fn the_emit_pass_needs_only_the_samples_of_active_blocks() {
    let dir = TempDir::new("only-wanted");
    let out = dir.0.join("out.cgc");
    let dims = [70, 53, 60];
    let balls = field(dims, |x, y, z| {
        let d = |c: [f64; 3]| ((x - c[0]).powi(2) + (y - c[1]).powi(2) + (z - c[2]).powi(2)).sqrt();
        (30.0 - 3.0 * d([20.0, 15.0, 18.0]).min(d([50.0, 40.0, 44.0]))).clamp(0.0, 30.0) * 8.0
    });
    let volume = Volume::new(
        dims,
        VolumeData::U8(balls.into_iter().map(|v| v as u8).collect()),
    )
    .unwrap();
    for options in [
        ExtractOptions::new(Iso::Value(120.0)),
        ExtractOptions::new(Iso::Normalized(0.3)).with_precision(Precision::Bits4),
    ] {
        let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
        for layers in [1, 2, 64] {
            let (bytes, _, masked_reads) = stream_counted(&volume, &options, layers, &out);
            assert!(bytes == expected, "{options:?}, {layers}-layer slabs");
            let masked = if layers == 64 { 0 } else { 1 };
            assert!(masked_reads >= masked, "{layers}-layer slabs");
        }
    }
}

#[test]
fn a_block_mask_touches_the_samples_its_blocks_read() {
    let mut mask = stream::BlockMask::new([3, 2]);
    mask.want(1, 1);
    // Block (1, 1) reads samples 16..=32 along x and y.
    assert!(mask.touches(16..17, 16..17));
    assert!(mask.touches(32..33, 32..33));
    assert!(mask.touches(0..17, 0..17));
    assert!(!mask.touches(0..16, 0..40));
    assert!(!mask.touches(33..48, 16..20));
    assert!(!mask.touches(16..20, 33..40));
    assert!(!mask.touches(20..20, 20..30));
}

/// The scalar stream within a budget holds no more heap than its plan gives it, the budget less
/// the process's baseline, at the least budgets for 1, 4 and 12 slab layers (the slab leaves
/// nothing to spare), on 1 and 3 threads: a gyroid, whose surface fills every block. Measured by
/// the counting allocator in a process of its own ([`crate::heap::run_alone`]).
#[test]
fn streamed_extraction_holds_no_more_heap_than_its_plan() {
    crate::heap::run_alone("stream::streamed_extraction_heap_within_the_plan", &[]);
}

#[test]
#[ignore = "run alone by streamed_extraction_holds_no_more_heap_than_its_plan"]
fn streamed_extraction_heap_within_the_plan() {
    use isogrid::generate::{generate, Field};
    let volume = generate(Field::Gyroid, 224, 1);
    let dir = TempDir::new("heap");
    let out = dir.0.join("out.cgc");
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let budget_for = |layers| least_budget_for(layers, |b| stream::plan(&volume.view(), b));
            for budget in [1, 4, 12].map(budget_for) {
                let plan = stream::plan(&volume.view(), budget).unwrap();
                let start = crate::heap::reset_peak();
                extract_planned(&mut volume.view(), &options, &plan, &out, &Progress::new())
                    .unwrap();
                let grown = (crate::heap::peak() - start) as u64;
                let allowed = budget - stream::PROCESS_BASELINE;
                eprintln!(
                    "{threads} threads: budget {:.1} MiB, {} slab layers, output buffer {:.1} MiB: \
                     heap grew {:.1} MiB of {:.1} MiB allowed ({} B to spare)",
                    budget as f64 / 1048576.0,
                    plan.slab_layers,
                    plan.output_buffer as f64 / 1048576.0,
                    grown as f64 / 1048576.0,
                    allowed as f64 / 1048576.0,
                    allowed as i64 - grown as i64
                );
                assert!(
                    grown <= allowed,
                    "{threads} threads, budget {budget}: the heap grew by {grown} B, over the \
                     {allowed} B the plan allows"
                );
            }
        });
    }
}

/// The least budget whose plan (`plan(budget)`) has at least `layers` slab layers: the slab then
/// fills the budget, with no rounding to spare.
pub(crate) fn least_budget_for(
    layers: usize,
    plan: impl Fn(u64) -> isogrid::Result<MemoryPlan>,
) -> u64 {
    let (mut lo, mut hi) = (1u64, 1u64 << 40);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        match plan(mid) {
            Ok(p) if p.slab_layers >= layers => hi = mid,
            _ => lo = mid + 1,
        }
    }
    lo
}

//! Streamed and pieced label extraction: the file written slab by slab within a budget, or put
//! together from Dask-style fragments in any order, must be byte-identical to the in-memory label
//! extraction written with `cgc::to_bytes` (whose cells `labels.rs` checks against independent
//! references), for any slab size, run size, thread count, smoothing halo and selection; cancels
//! and failures leave no file behind.

use crate::common::Rng;
use crate::labels::{label_volume, DIMS};
use crate::stream::{least_budget_for, plan, Cancelling, TempDir};
use isogrid::extract::label_stream::{
    extract_labels_planned, extract_labels_to_file, fragment_box, label_fragment, plan_labels,
    LabelWriter,
};
use isogrid::extract::stream::MemoryPlan;
use isogrid::labels::Label;
use isogrid::{
    cgc, extract_labels, ErrorKind, LabelOptions, LabelSelection, Progress, Volume, VolumeData,
};
use std::ops::Range;

/// Supervoxel-like labels: each sample takes the label of its nearest of `seeds` random points
/// (Voronoi cells: every label touches several others, and most cross several block layers).
fn voronoi(dims: [usize; 3], seeds: usize, seed: u64) -> Vec<u32> {
    let mut rng = Rng::new(seed);
    let points: Vec<[f64; 3]> = (0..seeds)
        .map(|_| [0, 1, 2].map(|a| rng.unit() * dims[a] as f64))
        .collect();
    let [nx, ny, nz] = dims;
    let mut out = Vec::with_capacity(nx * ny * nz);
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let p = [x as f64, y as f64, z as f64];
                let nearest = (0..seeds)
                    .min_by(|&a, &b| {
                        let d = |q: [f64; 3]| (0..3).map(|i| (q[i] - p[i]).powi(2)).sum::<f64>();
                        d(points[a]).total_cmp(&d(points[b]))
                    })
                    .unwrap();
                // Values spread out, and 0 (background) for some cells.
                out.push(if nearest % 7 == 0 {
                    0
                } else {
                    1000 + 3 * nearest as u32
                });
            }
        }
    }
    out
}

fn volumes() -> Vec<(&'static str, Volume)> {
    let tall = [29, 23, 83];
    vec![
        (
            "touching",
            Volume::new(DIMS, VolumeData::U16(label_volume())).unwrap(),
        ),
        (
            "voronoi",
            Volume::new(tall, VolumeData::U32(voronoi(tall, 60, 3))).unwrap(),
        ),
    ]
}

fn options(selection: LabelSelection, smooth: f64) -> LabelOptions {
    let mut o = LabelOptions::new(selection);
    o.smooth = smooth;
    o
}

fn option_sets() -> Vec<LabelOptions> {
    vec![
        options(LabelSelection::All, 0.0),
        // Halo of 3 and of 5 planes (⌈3σ⌉).
        options(LabelSelection::All, 1.0),
        options(LabelSelection::parse("0-2,7,1000-1100,65535").unwrap(), 1.6),
    ]
}

/// Names one label and recolours another, as a colour table would.
fn rename(table: &mut [Label]) {
    if let Some(first) = table.first_mut() {
        first.name = "first one".into();
    }
    if let Some(last) = table.last_mut() {
        last.rgba = [1, 2, 3, 4];
    }
}

fn in_memory_bytes(volume: &Volume, options: &LabelOptions) -> Vec<u8> {
    let mut grid = extract_labels(&volume.view(), options).unwrap();
    let labels = grid.labels_mut().unwrap();
    let mut table = labels.table().to_vec();
    rename(&mut table);
    labels.set_table(table).unwrap();
    cgc::to_bytes(&grid)
}

#[test]
fn streamed_label_files_are_byte_identical_to_in_memory_ones() {
    let dir = TempDir::new("labels-identical");
    let out = dir.0.join("out.cgc");
    let mut compared = 0;
    for (name, volume) in volumes() {
        for options in option_sets() {
            let expected = in_memory_bytes(&volume, &options);
            // One-layer slabs with runs cut as small as they go (many slabs and runs), two
            // layers, and the whole volume at once.
            for (layers, buffer) in [(1, 1), (2, 1 << 16), (100, 64 << 20)] {
                for threads in [1, 3] {
                    let pool = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .unwrap();
                    let progress = Progress::new();
                    let summary = pool
                        .install(|| {
                            extract_labels_planned(
                                &mut volume.view(),
                                &options,
                                &plan(layers, buffer),
                                &out,
                                &progress,
                                &mut rename,
                            )
                        })
                        .unwrap();
                    let bytes = std::fs::read(&out).unwrap();
                    assert!(
                        bytes == expected,
                        "{name}, {options:?}, {layers} layers, {threads} threads"
                    );
                    let (done, total) = progress.counts();
                    assert_eq!(done, total);
                    let grid = cgc::read_bytes(&bytes).unwrap();
                    assert_eq!(total, 2 * grid.blocks().len() as u64);
                    let labels = grid.labels().unwrap();
                    assert_eq!(summary.table, labels.table());
                    assert_eq!(summary.index, labels.index());
                    assert_eq!(summary.stats, isogrid::GridStats::of(&grid));
                    assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 2 * 3 * 3 * 2);
}

/// The touching-labels volume has labels crossing every block layer boundary, and the Voronoi
/// volume has dozens of labels per block; both must actually reach the cases the test is for.
#[test]
fn the_test_volumes_cross_slab_boundaries_with_touching_labels() {
    for (name, volume) in volumes() {
        let grid = extract_labels(&volume.view(), &options(LabelSelection::All, 0.0)).unwrap();
        let labels = grid.labels().unwrap();
        let crossing = labels
            .index()
            .iter()
            .filter(|e| e.lo[2] / 16 != (e.hi[2] - 1) / 16)
            .count();
        assert!(
            crossing >= 3,
            "{name}: {crossing} labels cross a layer boundary"
        );
    }
}

/// Dask's path: fragments of any cut into block layers, added in any order, give the same file;
/// a fragment given twice, one missing, or one of other options is refused.
#[test]
fn fragments_in_any_order_give_the_in_memory_file() {
    let dir = TempDir::new("labels-fragments");
    let out = dir.0.join("out.cgc");
    for (name, volume) in volumes() {
        let dims = volume.dims();
        let layers = (dims[2] - 1).div_ceil(16);
        for options in option_sets() {
            let expected = in_memory_bytes(&volume, &options);
            // Runs of one block row (each reading its rows of the planes only), of one block
            // layer, two, and all.
            let all = layer_blocks(dims, 0..layers);
            let per_layer = all.len() / layers;
            let row = (dims[0] - 1).div_ceil(16);
            for cut in [row, per_layer, 2 * per_layer, all.len()] {
                let mut fragments: Vec<Vec<u8>> = all
                    .clone()
                    .step_by(cut)
                    .map(|b0| {
                        let blocks = b0..(b0 + cut).min(all.end);
                        fragment(&volume, blocks, &options, u64::MAX).encode()
                    })
                    .collect();
                fragments.reverse();
                if fragments.len() > 2 {
                    fragments.swap(0, 1);
                }
                let mut writer =
                    LabelWriter::new(*volume.geometry(), volume.scalar_type(), &options, &dir.0)
                        .unwrap();
                for f in &fragments {
                    writer.add_fragment(f).unwrap();
                }
                if fragments.len() > 1 {
                    let err = writer.add_fragment(&fragments[1]).unwrap_err();
                    assert!(err.to_string().contains("already given"), "{err}");
                }
                writer.write(&out, &Progress::new(), &mut rename).unwrap();
                assert!(
                    std::fs::read(&out).unwrap() == expected,
                    "{name}, {options:?}, {cut} layers a fragment"
                );
                assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
            }
            // One fragment missing: nothing written.
            if layers > 1 {
                std::fs::remove_file(&out).unwrap();
                let mut writer =
                    LabelWriter::new(*volume.geometry(), volume.scalar_type(), &options, &dir.0)
                        .unwrap();
                let f = fragment(&volume, layer_blocks(dims, 0..1), &options, u64::MAX);
                writer.add_fragment(&f.encode()).unwrap();
                let err = writer
                    .write(&out, &Progress::new(), &mut |_| {})
                    .unwrap_err();
                assert!(err.to_string().contains("blocks given"), "{err}");
                assert!(dir.entries().is_empty());
            }
        }
        // A fragment of other options (another smoothing) is refused.
        let a = options(LabelSelection::All, 0.0);
        let b = options(LabelSelection::All, 1.0);
        let first_layer = layer_blocks(dims, 0..1);
        let f = fragment(&volume, first_layer.clone(), &b, u64::MAX).encode();
        let mut writer =
            LabelWriter::new(*volume.geometry(), volume.scalar_type(), &a, &dir.0).unwrap();
        assert!(writer.add_fragment(&f).is_err());
        // A slab without its halo is refused.
        let short = slab_of(&volume, 0..dims[1], 0..17);
        let err = label_fragment(
            &short.view(),
            dims,
            first_layer.clone(),
            &b,
            u64::MAX,
            &Progress::new(),
        )
        .err()
        .unwrap();
        assert!(err.to_string().contains("is not the rows"), "{err}");
        // Truncated fragments are refused, never a panic.
        let f = fragment(&volume, first_layer.clone(), &b, u64::MAX).encode();
        for cut in [0, 3, 20, f.len() / 2, f.len() - 1] {
            let mut writer =
                LabelWriter::new(*volume.geometry(), volume.scalar_type(), &b, &dir.0).unwrap();
            assert!(
                writer.add_fragment(&f[..cut]).is_err(),
                "{name}: cut at {cut}"
            );
        }
    }
}

/// The blocks of the block layers `layers` of a volume of `dims` samples.
fn layer_blocks(dims: [usize; 3], layers: Range<usize>) -> Range<usize> {
    let per_layer = (dims[0] - 1).div_ceil(16) * (dims[1] - 1).div_ceil(16);
    layers.start * per_layer..layers.end * per_layer
}

/// The fragment of `blocks` of `volume`, its task given the planes it reads and `cap` bytes of
/// output.
fn fragment(
    volume: &Volume,
    blocks: Range<usize>,
    options: &LabelOptions,
    cap: u64,
) -> isogrid::extract::label_stream::LabelFragment {
    let dims = volume.dims();
    let [rows, planes] = fragment_box(dims, blocks.clone(), options).unwrap();
    let slab = slab_of(volume, rows, planes);
    label_fragment(&slab.view(), dims, blocks, options, cap, &Progress::new()).unwrap()
}

/// A task whose output reaches its cap stops there and covers a first part of its blocks; its
/// rest, given to further tasks (each starting mid-layer), completes the same file. The output a
/// task holds stays near its cap, and every task covers at least one block.
#[test]
fn capped_fragments_continue_where_they_stop_and_give_the_in_memory_file() {
    let dir = TempDir::new("labels-capped");
    let out = dir.0.join("out.cgc");
    for (name, volume) in volumes() {
        let dims = volume.dims();
        let layers = (dims[2] - 1).div_ceil(16);
        let all = layer_blocks(dims, 0..layers);
        for options in option_sets() {
            let expected = in_memory_bytes(&volume, &options);
            let whole = fragment(&volume, all.clone(), &options, u64::MAX).encoded_len() as u64;
            for cap in [0, whole / 7, whole / 2] {
                let mut writer =
                    LabelWriter::new(*volume.geometry(), volume.scalar_type(), &options, &dir.0)
                        .unwrap();
                let (mut pending, mut tasks) = (vec![all.clone()], 0);
                while let Some(asked) = pending.pop() {
                    let f = fragment(&volume, asked.clone(), &options, cap);
                    let got = f.blocks();
                    assert!(got.start == asked.start && !got.is_empty() && got.end <= asked.end);
                    let bytes = f.encode();
                    writer.add_fragment(&bytes).unwrap();
                    tasks += 1;
                    if got.end < asked.end {
                        // Stopped at its cap: its output reached it.
                        assert!(
                            bytes.len() as u64 >= cap / 2,
                            "{name}: {} of {cap}",
                            bytes.len()
                        );
                        pending.push(got.end..asked.end);
                    }
                }
                writer.write(&out, &Progress::new(), &mut rename).unwrap();
                assert!(
                    std::fs::read(&out).unwrap() == expected,
                    "{name}, {options:?}, cap {cap}"
                );
                let least = rayon::current_num_threads();
                if cap == 0 {
                    assert_eq!(tasks, all.len().div_ceil(least), "{name}: one run a task");
                } else {
                    assert!(tasks > 1 && tasks < all.len(), "{name}: {tasks} tasks");
                }
            }
        }
    }
}

/// The rows `y` of the planes `z` of `volume` (whole in x), as a volume.
fn slab_of(volume: &Volume, y: Range<usize>, z: Range<usize>) -> Volume {
    let [nx, ny, _] = volume.dims();
    fn cut<T: Copy>(s: &[T], nx: usize, ny: usize, y: &Range<usize>, z: &Range<usize>) -> Vec<T> {
        z.clone()
            .flat_map(|p| {
                s[nx * (y.start + ny * p)..nx * (y.end + ny * p)]
                    .iter()
                    .copied()
            })
            .collect()
    }
    let data = match volume.view().samples() {
        isogrid::Samples::U16(s) => VolumeData::U16(cut(s, nx, ny, &y, &z)),
        isogrid::Samples::U32(s) => VolumeData::U32(cut(s, nx, ny, &y, &z)),
        _ => unreachable!(),
    };
    Volume::new([nx, y.len(), z.len()], data).unwrap()
}

/// The budget decides the slabs: a budget below one slab (with its halo) is refused with the
/// least that works, and the halo's planes are counted in the slab.
#[test]
fn label_plans_count_the_halo_and_refuse_budgets_below_one_slab() {
    let volume = Volume::new([64, 64, 200], VolumeData::U32(vec![0; 64 * 64 * 200])).unwrap();
    let plain = plan_labels(&volume.view(), &options(LabelSelection::All, 0.0), 1 << 30).unwrap();
    let smooth = plan_labels(&volume.view(), &options(LabelSelection::All, 2.0), 1 << 30).unwrap();
    // σ = 2: 6 planes more on each side.
    let plane = 64 * 64 * 4;
    let slab = |p: &MemoryPlan| (16 * p.slab_layers as u64 + 1).min(200);
    assert!(plain.slab_bytes >= slab(&plain) * plane);
    assert!(smooth.slab_bytes >= ((slab(&smooth) + 12).min(200)) * plane);
    assert!(smooth.minimum > plain.minimum);
    let err = plan_labels(
        &volume.view(),
        &options(LabelSelection::All, 2.0),
        smooth.minimum - 1,
    )
    .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::TooLarge);
    assert!(err.to_string().contains("the least that works"), "{err}");
    assert!(err.to_string().contains("64x64x29"), "{err}");
    let tight = plan_labels(
        &volume.view(),
        &options(LabelSelection::All, 2.0),
        smooth.minimum,
    )
    .unwrap();
    assert_eq!(tight.slab_layers, 1);
}

/// A float volume that is not a label volume is refused streamed as in memory, with the same
/// line, and leaves no file.
#[test]
fn streamed_float_volumes_must_hold_integers() {
    let dir = TempDir::new("labels-float");
    let out = dir.0.join("out.cgc");
    let mut data: Vec<f32> = label_volume().iter().map(|&v| v as f32).collect();
    let volume = Volume::new(DIMS, VolumeData::F32(data.clone())).unwrap();
    let o = options(LabelSelection::All, 0.0);
    let expected = in_memory_bytes(&volume, &o);
    extract_labels_to_file(
        &mut volume.view(),
        &o,
        1 << 30,
        &out,
        &Progress::new(),
        &mut rename,
    )
    .unwrap();
    assert!(std::fs::read(&out).unwrap() == expected);
    std::fs::remove_file(&out).unwrap();
    data[DIMS[0] * DIMS[1] * 30 + 5] = 2.5;
    let volume = Volume::new(DIMS, VolumeData::F32(data)).unwrap();
    let memory = extract_labels(&volume.view(), &o).unwrap_err();
    let streamed = extract_labels_planned(
        &mut volume.view(),
        &o,
        &plan(1, 1 << 20),
        &out,
        &Progress::new(),
        &mut |_| {},
    )
    .unwrap_err();
    assert_eq!(memory.to_string(), streamed.to_string());
    assert!(streamed.to_string().contains("2.5"), "{streamed}");
    assert!(dir.entries().is_empty());
}

/// A cancel stops the run before its next read, fails with kind Cancelled, and leaves no file,
/// no temporary file and no scratch file: an old output stays as it was.
#[test]
fn a_cancelled_streamed_label_extraction_stops_at_once_and_leaves_no_file() {
    let dir = TempDir::new("labels-cancel");
    let out = dir.0.join("out.cgc");
    std::fs::write(&out, b"old").unwrap();
    let volume = &volumes()[1].1;
    let o = options(LabelSelection::All, 1.0);
    // One-layer slabs: one read per slab, 6 slabs.
    let slabs = (volume.dims()[2] - 1).div_ceil(16);
    for cancel_at in 1..=slabs {
        let progress = Progress::new();
        let mut source = Cancelling {
            inner: volume.view(),
            progress: &progress,
            reads: 0,
            cancel_at,
        };
        let err = extract_labels_planned(
            &mut source,
            &o,
            &plan(1, 1 << 20),
            &out,
            &progress,
            &mut |_| {},
        )
        .unwrap_err();
        assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
        assert_eq!(source.reads, cancel_at, "no read after the cancel");
        let (done, total) = progress.counts();
        assert!(done < total);
        assert_eq!(std::fs::read(&out).unwrap(), b"old");
        assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
    }
    // Cancelled while the file is written: after every block is made.
    let progress = Progress::new();
    let mut calls = 0;
    let err = extract_labels_planned(
        &mut volume.view(),
        &o,
        &plan(1, 1 << 20),
        &out,
        &progress,
        &mut |_| {
            calls += 1;
            progress.cancel();
        },
    )
    .unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Cancelled, "{err}");
    assert_eq!(calls, 1);
    assert_eq!(std::fs::read(&out).unwrap(), b"old");
    assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
}

/// Labels of Voronoi cells around one jittered seed per `cell`³ samples (the nearest of the 27
/// seeds around a sample's own): supervoxels as dense as the (about 14 labels a block
/// at `cell` 11), made in linear time.
fn jittered_voronoi(dims: [usize; 3], cell: usize, seed: u64) -> Vec<u32> {
    let mut rng = Rng::new(seed);
    let g = dims.map(|d| d.div_ceil(cell) + 2);
    let seeds: Vec<[f64; 3]> = (0..g[0] * g[1] * g[2])
        .map(|i| {
            let at = [i % g[0], i / g[0] % g[1], i / (g[0] * g[1])];
            [0, 1, 2].map(|a| (at[a] as f64 - 1.0 + rng.unit()) * cell as f64)
        })
        .collect();
    let mut out = Vec::with_capacity(dims.iter().product());
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let p = [x, y, z];
                let home = p.map(|c| c / cell + 1);
                let mut best = (f64::INFINITY, 0);
                for d in 0..27 {
                    let q = [
                        home[0] + d % 3 - 1,
                        home[1] + d / 3 % 3 - 1,
                        home[2] + d / 9 - 1,
                    ];
                    let i = q[0] + g[0] * (q[1] + g[1] * q[2]);
                    let s = seeds[i];
                    let dist = (0..3).map(|a| (s[a] - p[a] as f64).powi(2)).sum::<f64>();
                    if dist < best.0 {
                        best = (dist, i);
                    }
                }
                out.push(1 + best.1 as u32);
            }
        }
    }
    out
}

/// The label pass within a budget holds no more heap than its plan gives it, the budget less the
/// process's baseline: slab, halo, runs of output and the labels' records, at budgets from the
/// least to one near the volume's size, with and without smoothing, on 1 and 3 threads. Measured
/// by the counting allocator in a process of its own ([`crate::heap::run_alone`]). What it holds
/// the pass to includes the runs' output (one copy, at the capacity its buffers hold) and a slab
/// longer than the one before it (the first slab's halo is clipped by the volume's edge).
#[test]
fn streamed_labels_hold_no_more_heap_than_their_plan() {
    crate::heap::run_alone("label_stream::streamed_labels_heap_within_the_plan", &[]);
}

#[test]
#[ignore = "run alone by streamed_labels_hold_no_more_heap_than_their_plan"]
fn streamed_labels_heap_within_the_plan() {
    use isogrid::extract::stream::PROCESS_BASELINE;
    let dims = [256, 224, 176];
    let volume = Volume::new(dims, VolumeData::U32(jittered_voronoi(dims, 11, 7))).unwrap();
    let dir = TempDir::new("labels-heap");
    let out = dir.0.join("out.cgc");
    for (threads, smooth) in [(1, 0.0), (3, 0.0), (1, 1.0), (3, 1.0)] {
        // The plan counts each thread's scratch: it is made on the pool that runs the pass.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
        let o = options(LabelSelection::All, smooth);
        let budget_for = |layers| least_budget_for(layers, |b| plan_labels(&volume.view(), &o, b));
        for budget in [1, 3, 6].map(budget_for) {
            let plan = plan_labels(&volume.view(), &o, budget).unwrap();
            let start = crate::heap::reset_peak();
            extract_labels_planned(
                &mut volume.view(),
                &o,
                &plan,
                &out,
                &Progress::new(),
                &mut |_| {},
            )
            .unwrap();
            let grown = (crate::heap::peak() - start) as u64;
            // Beyond the plan, as docs/design/labels.md counts what it cannot know ahead: 24 B
            // for each (block, label) pair past 16 a block, 4 B per cluster and 36 B per label,
            // twice over, as the vectors and the map that hold them grow by doubling.
            let grid = cgc::open(&out).unwrap();
            let labels = grid.labels().unwrap();
            let pairs: u64 = labels.index().iter().map(|e| e.run_count).sum();
            let unplanned = 2
                * (24 * pairs.saturating_sub(16 * grid.blocks().len() as u64)
                    + 4 * labels.cluster_labels().len() as u64
                    + 36 * labels.table().len() as u64);
            drop(grid);
            let allowed = budget - PROCESS_BASELINE + unplanned;
            eprintln!(
                "{threads} threads, σ {smooth}: budget {:.1} MiB, {} slab layers, output buffer {:.1} MiB: heap grew \
                 {:.1} MiB of {:.1} MiB allowed ({:.1} MiB beyond the plan)",
                budget as f64 / 1048576.0,
                plan.slab_layers,
                plan.output_buffer as f64 / 1048576.0,
                grown as f64 / 1048576.0,
                allowed as f64 / 1048576.0,
                unplanned as f64 / 1048576.0
            );
            assert!(
                grown <= allowed,
                "{threads} threads, σ {smooth}, budget {budget}: the heap grew by {grown} B, over \
                 the {allowed} B the plan allows"
            );
        }
        });
    }
}

//! Tiled extraction (the distributed split): scanning boxes of whole blocks in any order, planning
//! emit jobs and writing their fragments in any order must give the bytes of the in-memory
//! extraction written with `cgc::to_bytes`, for any tiling along x, y and z and any job size; a
//! missing, foreign, overlapping or conflicting fragment must leave no file behind.

use crate::stream::{option_sets, volumes, TempDir};
use isogrid::extract::tiles::{
    block_dims, emit_tile, extract_tile, scan_tile, tile_samples, tiles, EmitJob, TileExtraction,
    TileSummary,
};
use isogrid::{cgc, extract, ExtractOptions, Iso, Progress, Samples, Volume, VolumeData};
use std::ops::Range;
use std::path::Path;

/// The samples `x`, `y`, `z` of `volume` copied into a volume of their own (what a task receives).
fn box_of(volume: &Volume, [x, y, z]: [Range<usize>; 3]) -> Volume {
    let [nx, ny, _] = volume.geometry().dims;
    fn pick<T: Copy>(s: &[T], nx: usize, ny: usize, b: &[Range<usize>; 3]) -> Vec<T> {
        let mut out = Vec::with_capacity(b.iter().map(|r| r.len()).product());
        for z in b[2].clone() {
            for y in b[1].clone() {
                let row = nx * (y + ny * z);
                out.extend_from_slice(&s[row + b[0].start..row + b[0].end]);
            }
        }
        out
    }
    let b = [x.clone(), y.clone(), z.clone()];
    let data = match volume.view().samples() {
        Samples::U8(s) => VolumeData::U8(pick(s, nx, ny, &b)),
        Samples::U16(s) => VolumeData::U16(pick(s, nx, ny, &b)),
        Samples::I16(s) => VolumeData::I16(pick(s, nx, ny, &b)),
        Samples::F32(s) => VolumeData::F32(pick(s, nx, ny, &b)),
        Samples::U32(s) => VolumeData::U32(pick(s, nx, ny, &b)),
        Samples::I32(s) => VolumeData::I32(pick(s, nx, ny, &b)),
        Samples::U64(s) => VolumeData::U64(pick(s, nx, ny, &b)),
        Samples::I64(s) => VolumeData::I64(pick(s, nx, ny, &b)),
        Samples::F64(s) => VolumeData::F64(pick(s, nx, ny, &b)),
    };
    Volume::new([x.len(), y.len(), z.len()], data).unwrap()
}

/// Scans `volume` in tiles of `scan_blocks` blocks (x, y, z), last tile first, and plans jobs
/// from tiles of `job_blocks` within `job_bytes`.
fn scanned(
    volume: &Volume,
    options: &ExtractOptions,
    scan_blocks: [usize; 3],
    job_blocks: [usize; 3],
    job_bytes: u64,
) -> (TileExtraction, Vec<EmitJob>) {
    let geometry = *volume.geometry();
    let dims = geometry.dims;
    let mut run = TileExtraction::new(
        geometry,
        volume.scalar_type(),
        options,
        Some(volume.value_range()),
    )
    .unwrap();
    for tile in tiles(dims, scan_blocks).unwrap().into_iter().rev() {
        let samples = box_of(volume, tile_samples(&tile, dims));
        let first = tile.map(|b| b.start);
        run.add_scan(
            &scan_tile(&samples.view(), dims, first, run.iso(), &Progress::new()).unwrap(),
        )
        .unwrap();
    }
    let jobs = run.plan_emits(job_blocks, job_bytes).unwrap();
    (run, jobs)
}

fn fragments(volume: &Volume, jobs: &[EmitJob]) -> Vec<Vec<u8>> {
    jobs.iter()
        .enumerate()
        .map(|(i, job)| {
            let samples = box_of(volume, job.samples.clone());
            emit_tile(&samples.view(), &job.bytes, i as u32, &Progress::new()).unwrap()
        })
        .collect()
}

fn write(
    run: &TileExtraction,
    jobs: &[EmitJob],
    fragments: Vec<Vec<u8>>,
    out: &Path,
) -> isogrid::Result<TileSummary> {
    let mut arriving = fragments.into_iter();
    run.write(out, jobs, &mut || Ok(arriving.next()))
}

#[test]
fn tiled_files_are_byte_identical_to_in_memory_ones() {
    let dir = TempDir::new("tiles-identical");
    let out = dir.0.join("out.cgc");
    let mut compared = 0;
    let mut job_counts = Vec::new();
    // (scan tiles, job tiles, job budget), tiles in blocks (x, y, z): single blocks; layers split
    // along y only; uneven boxes split along every axis, scanned and emitted differently; whole
    // layers; everything at once.
    let tilings: [([usize; 3], [usize; 3], u64); 6] = [
        ([1, 1, 1], [1, 1, 1], 1),
        ([100, 1, 2], [100, 2, 1], 20_000),
        ([2, 3, 1], [3, 2, 2], 1),
        ([1, 2, 3], [2, 1, 100], 9_000),
        ([100, 100, 1], [100, 100, 3], 1),
        ([100, 100, 100], [100, 100, 100], u64::MAX),
    ];
    for (name, volume) in volumes() {
        for options in option_sets() {
            let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
            for (scan_blocks, job_blocks, job_bytes) in tilings {
                let (run, jobs) = scanned(&volume, &options, scan_blocks, job_blocks, job_bytes);
                job_counts.push(jobs.len());
                // Finished out of order, one delivered twice (a retried task).
                let mut arriving = fragments(&volume, &jobs);
                arriving.reverse();
                if let Some(first) = arriving.first().cloned() {
                    arriving.push(first);
                }
                let summary = write(&run, &jobs, arriving, &out).unwrap();
                let written = std::fs::read(&out).unwrap();
                assert!(
                    written == expected,
                    "{name} {options:?} scan tiles of {scan_blocks:?} blocks, jobs of \
                     {job_blocks:?} within {job_bytes} bytes: {} tiled bytes differ from {} \
                     in-memory bytes",
                    written.len(),
                    expected.len()
                );
                let grid = cgc::read_bytes(&written).unwrap();
                assert_eq!(summary.stats, isogrid::GridStats::of(&grid), "{name}");
                compared += 1;
            }
        }
    }
    // A volume one sample wide has layers but no blocks: nothing to scan or emit.
    let line = Volume::new([1, 5, 40], VolumeData::U8(vec![7; 200])).unwrap();
    for options in option_sets() {
        let expected = cgc::to_bytes(&extract(&line.view(), &options).unwrap());
        let (run, jobs) = scanned(&line, &options, [1, 1, 1], [1, 1, 1], 1);
        assert!(jobs.is_empty());
        write(&run, &jobs, Vec::new(), &out).unwrap();
        assert!(std::fs::read(&out).unwrap() == expected, "{options:?}");
    }
    assert_eq!(compared, 10 * 4 * 6);
    // The budgets did cut some volumes into many jobs, and some jobs into several runs.
    assert!(job_counts.iter().any(|&n| n >= 10), "{job_counts:?}");
    assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
}

#[test]
fn jobs_of_partial_rows_write_several_runs() {
    // A job narrower than the volume and more than one row high holds one run per block row.
    let (_, volume) = volumes().remove(0); // 37 x 21 x 50: 3 x 2 x 4 blocks
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let (_, jobs) = scanned(&volume, &options, [1, 2, 2], [2, 2, 2], u64::MAX);
    assert_eq!(block_dims(volume.geometry().dims), [3, 2, 4]);
    assert_eq!(jobs.len(), 4, "{jobs:?}");
    assert!(jobs.iter().any(|job| job.runs.len() == 4), "{jobs:?}");
    assert_eq!(jobs[0].samples, [0..33, 0..21, 0..33]);
    assert_eq!(jobs[1].samples, [32..37, 0..21, 0..33]);
}

#[test]
fn missing_foreign_or_conflicting_fragments_leave_no_file() {
    let dir = TempDir::new("tiles-errors");
    let out = dir.0.join("out.cgc");
    let (_, volume) = volumes().remove(0);
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let (run, jobs) = scanned(&volume, &options, [1, 1, 1], [2, 1, 1], 1);
    assert!(jobs.len() >= 3);
    let good = fragments(&volume, &jobs);

    let mut missing = good.clone();
    missing.remove(1);
    let err = write(&run, &jobs, missing, &out).unwrap_err();
    assert!(err.to_string().contains("job 1 never arrived"), "{err}");

    let mut conflicting = good.clone();
    let mut changed = good[0].clone();
    *changed.last_mut().unwrap() ^= 1;
    conflicting.push(changed);
    let err = write(&run, &jobs, conflicting, &out).unwrap_err();
    assert!(
        err.to_string().contains("twice with different bytes"),
        "{err}"
    );

    let mut truncated = good.clone();
    truncated[2].pop();
    let err = write(&run, &jobs, truncated, &out).unwrap_err();
    assert!(err.to_string().contains("output fragment"), "{err}");

    let mut foreign = good.clone();
    foreign[0][4] = 200; // job index 200
    let err = write(&run, &jobs, foreign, &out).unwrap_err();
    assert!(err.to_string().contains("beyond the plan"), "{err}");

    let err = write(&run, &jobs, vec![b"not a fragment".to_vec()], &out).unwrap_err();
    assert!(
        err.to_string().contains("not a valid output fragment"),
        "{err}"
    );

    // A plan that leaves a job out does not cover the output.
    let last = jobs.len() - 1;
    let err = write(&run, &jobs[..last], good[..last].to_vec(), &out).unwrap_err();
    assert!(err.to_string().contains("exactly once"), "{err}");

    assert!(dir.entries().is_empty(), "{:?}", dir.entries());
}

#[test]
fn tiles_not_of_whole_blocks_or_overlapping_are_refused() {
    let (_, volume) = volumes().remove(0); // 37 x 21 x 50: 3 x 2 x 4 blocks
    let options = ExtractOptions::new(Iso::Value(1.0));
    let geometry = *volume.geometry();
    let dims = geometry.dims;
    let mut run = TileExtraction::new(geometry, volume.scalar_type(), &options, None).unwrap();
    // 16 planes is one layer without its halo; 16 rows one block row without its halo.
    for samples in [
        [0..37, 0..21, 0..16],
        [0..37, 0..16, 0..17],
        [16..32, 0..21, 0..17],
    ] {
        let first = [samples[0].start / 16, 0, 0];
        let err = scan_tile(
            &box_of(&volume, samples).view(),
            dims,
            first,
            1.0,
            &Progress::new(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("not whole blocks"), "{err}");
    }
    // Layer 1 before layer 0 is fine; the same blocks twice are not.
    let second = box_of(&volume, [0..37, 0..21, 16..33]);
    run.add_scan(&scan_tile(&second.view(), dims, [0, 0, 1], 1.0, &Progress::new()).unwrap())
        .unwrap();
    let overlapping = box_of(&volume, [16..37, 16..21, 16..49]);
    let fragment = scan_tile(&overlapping.view(), dims, [1, 1, 1], 1.0, &Progress::new()).unwrap();
    let err = run.add_scan(&fragment).unwrap_err();
    assert!(
        err.to_string().contains("overlaps blocks already scanned"),
        "{err}"
    );
    // Jobs need every block scanned.
    let err = run.plan_emits([1, 1, 1], u64::MAX).unwrap_err();
    assert!(err.to_string().contains("6 of 24 blocks scanned"), "{err}");
    // A normalised isovalue cannot start without the value range.
    let err = TileExtraction::new(
        geometry,
        volume.scalar_type(),
        &ExtractOptions::new(Iso::Normalized(0.5)),
        None,
    )
    .unwrap_err();
    assert!(err.to_string().contains("value range"), "{err}");
}

/// One pass over `volume` in tiles of `tile_blocks` blocks (x, y, z), last tile first, each
/// giving its output when it fits `output_bytes`; then the jobs for the tiles that did not, within
/// `job_bytes`. `None` when the run cannot be one pass.
fn one_pass(
    volume: &Volume,
    options: &ExtractOptions,
    tile_blocks: [usize; 3],
    output_bytes: u64,
    job_bytes: u64,
    spool: &Path,
) -> Option<(TileExtraction, Vec<EmitJob>, usize)> {
    let geometry = *volume.geometry();
    let dims = geometry.dims;
    let mut run = TileExtraction::new(
        geometry,
        volume.scalar_type(),
        options,
        Some(volume.value_range()),
    )
    .unwrap();
    let task = run.one_pass_task()?;
    run.spool_in(spool);
    let mut with_output = 0;
    for tile in tiles(dims, tile_blocks).unwrap().into_iter().rev() {
        let samples = box_of(volume, tile_samples(&tile, dims));
        let first = tile.map(|b| b.start);
        let fragment = extract_tile(
            &samples.view(),
            &task,
            first,
            output_bytes,
            &Progress::new(),
        )
        .unwrap();
        let scan_only =
            scan_tile(&samples.view(), dims, first, run.iso(), &Progress::new()).unwrap();
        // The same scan records as a scan fragment, then the output flag.
        assert_eq!(fragment[4..scan_only.len()], scan_only[4..]);
        with_output += (fragment[scan_only.len()] == 1) as usize;
        run.add_tile(&fragment).unwrap();
    }
    let jobs = run.plan_emits(tile_blocks, job_bytes).unwrap();
    Some((run, jobs, with_output))
}

#[test]
fn one_pass_tiles_give_the_bytes_of_the_in_memory_extraction() {
    let dir = TempDir::new("tiles-one-pass");
    let out = dir.0.join("out.cgc");
    let spool = TempDir::new("tiles-one-pass-spool");
    let (mut one_pass_runs, mut two_pass_runs, mut mixed) = (0, 0, 0);
    // (tiles, output budget, job budget): every tile gives its output; none does (all emitted in
    // a second pass); some do, and the rest are split into jobs.
    let tilings: [([usize; 3], u64, u64); 4] = [
        ([1, 1, 1], u64::MAX, 1),
        ([2, 3, 1], 0, 1),
        ([100, 1, 2], 3_000, 9_000),
        ([1, 2, 3], 20_000, u64::MAX),
    ];
    for (name, volume) in volumes() {
        for options in option_sets() {
            let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
            let integer = volume.scalar_type().is_integer();
            for (tile_blocks, output_bytes, job_bytes) in tilings {
                let Some((run, jobs, with_output)) = one_pass(
                    &volume,
                    &options,
                    tile_blocks,
                    output_bytes,
                    job_bytes,
                    &spool.0,
                ) else {
                    // Only a quantiser that depends on a range not yet known needs two passes.
                    assert!(matches!(options.iso, Iso::Value(_)), "{name} {options:?}");
                    assert!(
                        !integer || options.precision == Some(isogrid::Precision::Bits16),
                        "{name} {options:?}"
                    );
                    two_pass_runs += 1;
                    continue;
                };
                let tiles = tiles(volume.geometry().dims, tile_blocks).unwrap().len();
                if with_output > 0 && with_output < tiles && !jobs.is_empty() {
                    mixed += 1;
                }
                let mut arriving = fragments(&volume, &jobs);
                arriving.reverse();
                let summary = write(&run, &jobs, arriving, &out).unwrap();
                let written = std::fs::read(&out).unwrap();
                assert!(
                    written == expected,
                    "{name} {options:?} one-pass tiles of {tile_blocks:?} blocks, output within \
                     {output_bytes} bytes ({with_output} of {tiles} tiles gave theirs): {} bytes \
                     differ from {} in-memory bytes",
                    written.len(),
                    expected.len()
                );
                assert_eq!(
                    summary.stats,
                    isogrid::GridStats::of(&cgc::read_bytes(&written).unwrap())
                );
                one_pass_runs += 1;
            }
        }
    }
    assert!(one_pass_runs >= 4 * 20, "{one_pass_runs}");
    assert!(two_pass_runs > 0 && mixed > 0, "{two_pass_runs} {mixed}");
    // The spool is unlinked as soon as it is made.
    assert!(spool.entries().is_empty(), "{:?}", spool.entries());
    assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
}

#[test]
fn one_pass_plans_must_use_the_extracted_tiles() {
    let dir = TempDir::new("tiles-one-pass-plan");
    let (_, volume) = volumes().remove(0); // 37 x 21 x 50: 3 x 2 x 4 blocks
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let geometry = *volume.geometry();
    let dims = geometry.dims;
    let new_run = || {
        TileExtraction::new(
            geometry,
            volume.scalar_type(),
            &options,
            Some(volume.value_range()),
        )
        .unwrap()
    };
    let mut run = new_run();
    let task = run.one_pass_task().unwrap();
    let tile = [0..3, 0..2, 1..2];
    let samples = box_of(&volume, tile_samples(&tile, dims));
    let fragment = extract_tile(
        &samples.view(),
        &task,
        [0, 0, 1],
        u64::MAX,
        &Progress::new(),
    )
    .unwrap();
    // Output with nowhere to keep it is refused, and changes nothing.
    let err = run.add_tile(&fragment).unwrap_err();
    assert!(err.to_string().contains("no spool folder"), "{err}");
    run.spool_in(&dir.0);
    run.add_tile(&fragment).unwrap();
    let err = run.add_tile(&fragment).unwrap_err();
    assert!(
        err.to_string().contains("overlaps blocks already scanned"),
        "{err}"
    );
    let mut truncated = fragment.clone();
    truncated.pop();
    let err = new_run().add_tile(&truncated).unwrap_err();
    assert!(err.to_string().contains("tile fragment"), "{err}");
    // Another tile's samples, or another volume's task.
    let err = extract_tile(
        &samples.view(),
        &task,
        [0, 0, 3],
        u64::MAX,
        &Progress::new(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("not whole blocks"), "{err}");
    let err = extract_tile(
        &samples.view(),
        b"IGTS",
        [0, 0, 1],
        u64::MAX,
        &Progress::new(),
    )
    .unwrap_err();
    assert!(err.to_string().contains("not a valid tile task"), "{err}");
    for layer in [0, 2, 3] {
        let tile = [0..3, 0..2, layer..layer + 1];
        let samples = box_of(&volume, tile_samples(&tile, dims));
        let first = tile.map(|b| b.start);
        run.add_tile(
            &extract_tile(&samples.view(), &task, first, u64::MAX, &Progress::new()).unwrap(),
        )
        .unwrap();
    }
    // Planned with other tiles than those extracted.
    let err = run.plan_emits([1, 1, 1], u64::MAX).unwrap_err();
    assert!(err.to_string().contains("not tiles of the plan"), "{err}");
    assert!(dir.entries().is_empty(), "{:?}", dir.entries());
}

/// A tile's scan and emit count one step per block and pass, and a cancel stops them before any
/// block is scanned or emitted, with kind Cancelled and no fragment.
#[test]
fn tile_tasks_count_their_blocks_and_stop_when_cancelled() {
    let (_, volume) = volumes().remove(0); // 37 x 21 x 50: 3 x 2 x 4 blocks
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let geometry = *volume.geometry();
    let dims = geometry.dims;
    let run = TileExtraction::new(
        geometry,
        volume.scalar_type(),
        &options,
        Some(volume.value_range()),
    )
    .unwrap();
    let task = run.one_pass_task().unwrap();
    let tile = [0..3, 0..2, 1..3];
    let blocks = 3 * 2 * 2;
    let samples = box_of(&volume, tile_samples(&tile, dims));
    let cancelled = || {
        let p = Progress::new();
        p.cancel();
        p
    };

    let progress = Progress::new();
    extract_tile(&samples.view(), &task, [0, 0, 1], u64::MAX, &progress).unwrap();
    assert_eq!(progress.counts().0, 2 * blocks);
    let progress = cancelled();
    let err = extract_tile(&samples.view(), &task, [0, 0, 1], u64::MAX, &progress).unwrap_err();
    assert_eq!(err.kind(), isogrid::ErrorKind::Cancelled, "{err}");
    assert_eq!(progress.counts().0, 0);

    let progress = Progress::new();
    scan_tile(&samples.view(), dims, [0, 0, 1], run.iso(), &progress).unwrap();
    assert_eq!(progress.counts().0, blocks);
    let progress = cancelled();
    let err = scan_tile(&samples.view(), dims, [0, 0, 1], run.iso(), &progress).unwrap_err();
    assert_eq!(err.kind(), isogrid::ErrorKind::Cancelled, "{err}");
    assert_eq!(progress.counts().0, 0);

    // An emit job counts its blocks without cells at once, and no other once cancelled.
    let (_, jobs) = scanned(&volume, &options, [3, 2, 4], [3, 2, 4], u64::MAX);
    let job = &jobs[0];
    let samples = box_of(&volume, job.samples.clone());
    let job_blocks: u64 = job
        .samples
        .iter()
        .map(|r| (r.len() as u64 - 1).div_ceil(16))
        .product();
    let progress = Progress::new();
    emit_tile(&samples.view(), &job.bytes, 0, &progress).unwrap();
    assert_eq!(progress.counts().0, job_blocks);
    let progress = cancelled();
    let err = emit_tile(&samples.view(), &job.bytes, 0, &progress).unwrap_err();
    assert_eq!(err.kind(), isogrid::ErrorKind::Cancelled, "{err}");
    let idle = volume_blocks_without_cells(&volume, &options);
    assert_eq!(progress.counts().0, idle);
}

/// Blocks of `volume` without active cells, from the in-memory extraction.
fn volume_blocks_without_cells(volume: &Volume, options: &ExtractOptions) -> u64 {
    let grid = extract(&volume.view(), options).unwrap();
    grid.blocks()
        .iter()
        .filter(|b| b.metacell_count == 0)
        .count() as u64
}

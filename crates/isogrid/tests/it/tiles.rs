//! Tiled extraction (the distributed split): scanning tiles of whole block layers, planning emit
//! jobs and writing their fragments in any order must give the bytes of the in-memory extraction
//! written with `cgc::to_bytes`, for any tiling and job size; a missing, foreign or conflicting
//! fragment must leave no file behind.

use crate::stream::{option_sets, volumes, TempDir};
use isogrid::extract::tiles::{
    block_layers, emit_tile, scan_tile, tile_planes, EmitJob, TileExtraction, TileSummary,
};
use isogrid::{cgc, extract, ExtractOptions, Geometry, Iso, Samples, Volume, VolumeView};
use std::ops::Range;
use std::path::Path;

/// The sample planes `planes` of `volume` as a volume of their own (what a task receives).
fn planes_of<'a>(volume: &'a Volume, planes: Range<usize>) -> VolumeView<'a> {
    let [nx, ny, _] = volume.geometry().dims;
    let span = nx * ny * planes.start..nx * ny * planes.end;
    let samples = match volume.view().samples() {
        Samples::U8(s) => Samples::U8(&s[span]),
        Samples::U16(s) => Samples::U16(&s[span]),
        Samples::I16(s) => Samples::I16(&s[span]),
        Samples::F32(s) => Samples::F32(&s[span]),
    };
    VolumeView::new(Geometry::new([nx, ny, planes.len()]), samples).unwrap()
}

/// Scans `volume` in tiles of `tile_layers` block layers and plans jobs of `job_bytes`.
fn scanned(
    volume: &Volume,
    options: &ExtractOptions,
    tile_layers: usize,
    job_bytes: u64,
) -> (TileExtraction, Vec<EmitJob>) {
    let geometry = *volume.geometry();
    let nz = geometry.dims[2];
    let mut run = TileExtraction::new(
        geometry,
        volume.scalar_type(),
        options,
        Some(volume.value_range()),
    )
    .unwrap();
    let blocks: usize = geometry
        .cell_dims()
        .iter()
        .map(|c| c.div_ceil(16))
        .product();
    let nbz = if blocks == 0 { 0 } else { block_layers(nz) };
    for first in (0..nbz).step_by(tile_layers) {
        let layers = first..(first + tile_layers).min(nbz);
        let tile = planes_of(volume, tile_planes(&layers, nz));
        run.add_scan(&scan_tile(&tile, geometry.dims, first, run.iso()).unwrap())
            .unwrap();
    }
    let jobs = run.plan_emits(job_bytes).unwrap();
    (run, jobs)
}

fn fragments(volume: &Volume, jobs: &[EmitJob]) -> Vec<Vec<u8>> {
    jobs.iter()
        .enumerate()
        .map(|(i, job)| {
            emit_tile(&planes_of(volume, job.planes.clone()), &job.bytes, i as u32).unwrap()
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
    for (name, volume) in volumes() {
        for options in option_sets() {
            let expected = cgc::to_bytes(&extract(&volume.view(), &options).unwrap());
            // One-layer tiles with one-layer jobs, uneven tiles, and everything at once.
            for (tile_layers, job_bytes) in [(1, 1), (2, 20_000), (3, 1), (100, u64::MAX)] {
                let (run, jobs) = scanned(&volume, &options, tile_layers, job_bytes);
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
                    "{name} {options:?} tiles of {tile_layers} layers, jobs of {job_bytes} \
                     bytes: {} tiled bytes differ from {} in-memory bytes",
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
    let line = isogrid::Volume::new([1, 5, 40], isogrid::VolumeData::U8(vec![7; 200])).unwrap();
    for options in option_sets() {
        let expected = cgc::to_bytes(&extract(&line.view(), &options).unwrap());
        let (run, jobs) = scanned(&line, &options, 1, 1);
        assert!(jobs.is_empty());
        write(&run, &jobs, Vec::new(), &out).unwrap();
        assert!(std::fs::read(&out).unwrap() == expected, "{options:?}");
    }
    assert_eq!(compared, 7 * 4 * 4);
    // The budgets did cut some volumes into several jobs.
    assert!(job_counts.iter().any(|&n| n >= 3), "{job_counts:?}");
    assert_eq!(dir.entries(), vec!["out.cgc".to_string()]);
}

#[test]
fn missing_foreign_or_conflicting_fragments_leave_no_file() {
    let dir = TempDir::new("tiles-errors");
    let out = dir.0.join("out.cgc");
    let (_, volume) = volumes().remove(0);
    let options = ExtractOptions::new(Iso::Normalized(0.5));
    let (run, jobs) = scanned(&volume, &options, 1, 1);
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

    assert!(dir.entries().is_empty(), "{:?}", dir.entries());
}

#[test]
fn tiles_out_of_order_or_not_of_whole_layers_are_refused() {
    let (_, volume) = volumes().remove(0); // 37 x 21 x 50: layers 0..4
    let options = ExtractOptions::new(Iso::Value(1.0));
    let geometry = *volume.geometry();
    let mut run = TileExtraction::new(geometry, volume.scalar_type(), &options, None).unwrap();
    // 16 planes is one layer without its halo.
    let err = scan_tile(&planes_of(&volume, 0..16), geometry.dims, 0, 1.0).unwrap_err();
    assert!(err.to_string().contains("not whole block layers"), "{err}");
    // Layer 1 before layer 0.
    let second = scan_tile(&planes_of(&volume, 16..33), geometry.dims, 1, 1.0).unwrap();
    let err = run.add_scan(&second).unwrap_err();
    assert!(err.to_string().contains("layer 0 of 4 is next"), "{err}");
    // Jobs need every layer scanned.
    let first = scan_tile(&planes_of(&volume, 0..17), geometry.dims, 0, 1.0).unwrap();
    run.add_scan(&first).unwrap();
    let err = run.plan_emits(u64::MAX).unwrap_err();
    assert!(
        err.to_string().contains("1 of 4 block layers scanned"),
        "{err}"
    );
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

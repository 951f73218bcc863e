//! Extraction throughput (paper §3.1, Table 3) on synthetic 8-bit volumes: a smooth blob field
//! whose surface density is close to the paper's Dragon (about 0.5 % of cells active at 512³).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use isogrid::extract::attribute::sample_attribute_in_memory;
use isogrid::{extract, AttributePrecision, ExtractOptions, Iso, Precision, Volume, VolumeData};

/// A sum of sinusoids thresholded into a few big blobs, as 8-bit coverage-like values.
pub fn blob_volume(n: usize) -> Volume {
    let s = 6.0 / n as f32;
    let mut data = vec![0u8; n * n * n];
    for (idx, v) in data.iter_mut().enumerate() {
        let (x, y, z) = (
            (idx % n) as f32 * s,
            (idx / n % n) as f32 * s,
            (idx / (n * n)) as f32 * s,
        );
        let f = x.sin() * y.cos() + y.sin() * z.cos() + z.sin() * x.cos();
        *v = (127.5 + 300.0 * f).clamp(0.0, 255.0) as u8;
    }
    Volume::new([n, n, n], VolumeData::U8(data)).unwrap()
}

fn bench_extract(c: &mut Criterion) {
    let mut group = c.benchmark_group("extract");
    group.sample_size(10);
    for n in [128usize, 256] {
        let volume = blob_volume(n);
        group.throughput(Throughput::Elements((n * n * n) as u64));
        for precision in [Precision::Bits8, Precision::Bits4] {
            let options = ExtractOptions::new(Iso::Value(127.5)).with_precision(precision);
            group.bench_with_input(
                BenchmarkId::new(format!("u8_{}bit", precision.bits()), n),
                &volume,
                |b, v| b.iter(|| extract(&v.view(), &options).unwrap()),
            );
        }
    }
    group.finish();
}

/// The attribute pass (paper §3.4's "other attributes") against extraction itself: the blob
/// surface coloured by an f32 distance field on the same grid, at the default 16-bit codes.
fn bench_attribute(c: &mut Criterion) {
    let mut group = c.benchmark_group("attribute");
    group.sample_size(10);
    let n = 256usize;
    let surface = blob_volume(n);
    let distance: Vec<f32> = (0..n * n * n)
        .map(|i| {
            let (x, y, z) = (i % n, i / n % n, i / (n * n));
            let d = |a: usize, c: f32| a as f32 - c * n as f32;
            (d(x, 0.3).powi(2) + d(y, 0.6).powi(2) + d(z, 0.5).powi(2)).sqrt()
        })
        .collect();
    let attribute = Volume::new([n; 3], VolumeData::F32(distance)).unwrap();
    let options = ExtractOptions::new(Iso::Value(127.5));
    let grid = extract(&surface.view(), &options).unwrap();
    group.throughput(Throughput::Elements(grid.active_cells() as u64));
    group.bench_function(BenchmarkId::new("extract_u8", n), |b| {
        b.iter(|| extract(&surface.view(), &options).unwrap())
    });
    let bits16 = AttributePrecision::from_bits(16).unwrap();
    group.bench_function(BenchmarkId::new("sample_f32_same_grid", n), |b| {
        b.iter(|| sample_attribute_in_memory(&grid, &attribute.view(), "d", bits16).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench_extract, bench_attribute);
criterion_main!(benches);

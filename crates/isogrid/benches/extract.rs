//! Extraction throughput (paper §3.1, Table 3) on synthetic 8-bit volumes: a smooth blob field
//! whose surface density is close to the paper's Dragon (about 0.5 % of cells active at 512³).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use isogrid::{extract, ExtractOptions, Iso, Precision, Volume, VolumeData};

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

criterion_group!(benches, bench_extract);
criterion_main!(benches);

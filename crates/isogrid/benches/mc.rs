//! Marching Cubes extraction speed on procedural u8 volumes: a wobbly sphere with a little noise,
//! about the surface-to-volume ratio of the paper's scanned datasets (Table 3).
//!
//! `cargo bench -p isogrid --bench mc`; set `RAYON_NUM_THREADS=1` for single-threaded numbers.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use isogrid::mc::marching_cubes;
use isogrid::{Volume, VolumeData};
use std::hint::black_box;

/// A u8 volume of side `n`: 128 + 8·(signed distance to a wobbly sphere of radius 0.4·n) + noise.
fn wobbly_sphere(n: usize) -> Volume {
    let c = n as f64 / 2.0;
    let radius = 0.4 * n as f64;
    let freq = 12.0 / n as f64;
    let mut data = Vec::with_capacity(n * n * n);
    let mut hash = 0x2545_f491_4f6c_dd1du64;
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let (x, y, z) = (i as f64 - c, j as f64 - c, k as f64 - c);
                let wobble = 1.0 + 0.1 * (x * freq).sin() * (y * freq).sin() * (z * freq).sin();
                let d = radius * wobble - (x * x + y * y + z * z).sqrt();
                hash ^= hash << 13;
                hash ^= hash >> 7;
                hash ^= hash << 17;
                let noise = (hash % 7) as f64 - 3.0;
                data.push((128.0 + 8.0 * d + noise).clamp(0.0, 255.0) as u8);
            }
        }
    }
    Volume::new([n, n, n], VolumeData::U8(data)).expect("cube dims are valid")
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("marching_cubes_u8");
    for n in [128, 256] {
        let volume = wobbly_sphere(n);
        let mesh = marching_cubes(&volume.view(), 127.5);
        eprintln!(
            "{n}^3: {} vertices, {} triangles",
            mesh.vertex_count(),
            mesh.triangle_count()
        );
        group.throughput(Throughput::Elements((n * n * n) as u64));
        group.bench_function(format!("{n}^3"), |b| {
            b.iter(|| marching_cubes(black_box(&volume.view()), 127.5))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);

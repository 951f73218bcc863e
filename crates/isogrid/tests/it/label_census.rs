//! `label_census` against a count made voxel by voxel: every label's voxels and index box, on the
//! touching labels, holes and one-voxel labels of `labels::label_volume`, in every integer type
//! and as integral floats, signed values included; a float volume that is not one is refused.

use crate::labels::{label_volume, DIMS};
use isogrid::label_census::{label_census, LabelCount};
use isogrid::{ErrorKind, Volume, VolumeData};
use std::collections::BTreeMap;

/// Counted one voxel at a time, by key.
fn brute_force(keys: &[u64]) -> Vec<LabelCount> {
    let [nx, ny, _] = DIMS;
    let mut counts = BTreeMap::<u64, LabelCount>::new();
    for (i, &key) in keys.iter().enumerate() {
        let p = [i % nx, i / nx % ny, i / (nx * ny)].map(|c| c as u64);
        let c = counts.entry(key).or_insert(LabelCount {
            value: key,
            voxels: 0,
            lo: [u64::MAX; 3],
            hi: [0; 3],
        });
        c.voxels += 1;
        for a in 0..3 {
            c.lo[a] = c.lo[a].min(p[a]);
            c.hi[a] = c.hi[a].max(p[a] + 1);
        }
    }
    counts.into_values().collect()
}

#[test]
fn every_label_is_counted_with_its_box_in_every_type() {
    let labels = label_volume();
    // Negative values in the signed types: label v becomes v − 3.
    let signed: Vec<i64> = labels.iter().map(|&v| v as i64 - 3).collect();
    let scaled = |scale: u64| {
        labels
            .iter()
            .map(|&v| v as u64 * scale)
            .collect::<Vec<u64>>()
    };
    let (u8s, u32s, u64s): (Vec<u8>, Vec<u32>, Vec<u64>) = (
        labels.iter().map(|&v| v as u8).collect(),
        scaled(70_001).iter().map(|&v| v as u32).collect(),
        // Past 2^53: keys that no f64 holds.
        scaled(1_000_000_007_919),
    );
    let (i16s, i32s): (Vec<i16>, Vec<i32>) = (
        signed.iter().map(|&v| v as i16).collect(),
        signed.iter().map(|&v| v as i32).collect(),
    );
    let keys = |v: Vec<i64>| v.into_iter().map(|v| v as u64).collect::<Vec<u64>>();
    let volumes = [
        (
            VolumeData::U8(u8s.clone()),
            keys(u8s.iter().map(|&v| v as i64).collect()),
        ),
        (VolumeData::U16(labels.clone()), scaled(1)),
        (
            VolumeData::U32(u32s.clone()),
            u32s.iter().map(|&v| v as u64).collect(),
        ),
        (VolumeData::U64(u64s.clone()), u64s),
        (
            VolumeData::I16(i16s.clone()),
            keys(i16s.iter().map(|&v| v as i64).collect()),
        ),
        (
            VolumeData::I32(i32s.clone()),
            keys(i32s.iter().map(|&v| v as i64).collect()),
        ),
        (VolumeData::I64(signed.clone()), keys(signed.clone())),
        (
            VolumeData::F32(i32s.iter().map(|&v| v as f32).collect()),
            keys(i32s.iter().map(|&v| v as i64).collect()),
        ),
        (
            VolumeData::F64(labels.iter().map(|&v| v as f64).collect()),
            scaled(1),
        ),
    ];
    for (data, keys) in volumes {
        let name = data.scalar_type().name();
        let volume = Volume::new(DIMS, data).unwrap();
        let census = label_census(&volume.view()).unwrap();
        let expected = brute_force(&keys);
        assert!(expected.len() >= 8, "{name}: {} labels", expected.len());
        assert!(
            expected.iter().any(|c| c.voxels == 1),
            "{name}: a one-voxel label"
        );
        assert_eq!(census, expected, "{name}");
    }
}

#[test]
fn a_float_volume_that_is_not_labels_is_refused() {
    let mut data: Vec<f32> = label_volume().iter().map(|&v| v as f32).collect();
    data[1234] = 2.5;
    let volume = Volume::new(DIMS, VolumeData::F32(data)).unwrap();
    let e = label_census(&volume.view()).unwrap_err();
    assert_eq!(e.kind(), ErrorKind::InvalidInput);
    assert!(e.to_string().contains("holds 2.5"), "{e}");
}

#[test]
fn the_census_read_slab_by_slab_is_the_census_of_the_whole() {
    use isogrid::extract::stream::{plan, source_label_census};
    // Labels repeated along z so that slabs share them, and one each slab's own.
    let [nx, ny, nz] = [29, 23, 70];
    let labels = label_volume();
    let data: Vec<u32> = (0..nx * ny * nz)
        .map(|i| {
            let [x, y, z] = [i % nx, i / nx % ny, i / (nx * ny)];
            let [dx, dy, dz] = DIMS;
            let v = labels[x % dx + dx * (y % dy + dy * (z % dz))] as u32;
            if (x, y) == (3, 4) {
                1000 + z as u32 / 20
            } else {
                v
            }
        })
        .collect();
    let volume = Volume::new([nx, ny, nz], VolumeData::U32(data)).unwrap();
    let whole = label_census(&volume.view()).unwrap();
    let minimum = plan(&volume.view(), u64::MAX).unwrap().minimum;
    for budget in [minimum, minimum + (nx * ny * 4 * 16) as u64, u64::MAX] {
        let mut source = volume.view();
        let streamed = source_label_census(&mut source, budget, &isogrid::Progress::new()).unwrap();
        assert_eq!(streamed, whole, "budget {budget}");
    }
    assert!(whole.iter().any(|c| c.value == 1003));
}

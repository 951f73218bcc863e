//! `write_nrrd` round trips through `read_volume` for every scalar type and keeps geometry.

use crate::common::{assert_close, TempDir};
use isogrid::{Geometry, Volume, VolumeData};
use isogrid_io::{read_volume, write_nrrd, ReadOptions};

fn volume(data: VolumeData) -> Volume {
    let mut g = Geometry::new([4, 3, 2]);
    g.spacing = [0.5, 1.25, 3.0];
    g.origin = [-10.5, 0.125, 1e3];
    g.direction = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
    Volume::with_geometry(g, data).unwrap()
}

#[test]
fn round_trip_every_type_and_geometry() {
    let dir = TempDir::new("write-nrrd");
    let n = 24;
    let cases = [
        VolumeData::U8((0..n).map(|x| (x * 10) as u8).collect()),
        VolumeData::U16((0..n).map(|x| (x * 2700) as u16).collect()),
        VolumeData::I16((0..n).map(|x| (x as i16 - 12) * 1000).collect()),
        VolumeData::F32((0..n).map(|x| x as f32 * -0.1 + f32::EPSILON).collect()),
    ];
    for data in cases {
        let original = volume(data);
        let path = dir.path("out.nrrd");
        write_nrrd(&path, &original).unwrap();
        let back = read_volume(&path, &ReadOptions::default()).unwrap();
        assert_eq!(back.data(), original.data());
        assert_eq!(back.dims(), original.dims());
        assert_close(back.spacing(), original.spacing());
        assert_eq!(back.origin(), original.origin());
        for axis in 0..3 {
            assert_close(
                back.geometry().direction[axis],
                original.geometry().direction[axis],
            );
        }
    }
    assert_eq!(
        std::fs::read_dir(&dir.0).unwrap().count(),
        1,
        "temporary files left behind"
    );
}

#[test]
fn header_is_plain_nrrd_with_space_fields() {
    let dir = TempDir::new("write-nrrd-header");
    let path = dir.path("h.nrrd");
    write_nrrd(&path, &volume(VolumeData::U16(vec![7; 24]))).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let end = bytes.windows(2).position(|w| w == b"\n\n").unwrap();
    let header = std::str::from_utf8(&bytes[..end]).unwrap();
    for line in [
        "NRRD0004",
        "type: uint16",
        "sizes: 4 3 2",
        "endian: little",
        "encoding: raw",
        "space origin: (-10.5,0.125,1000)",
    ] {
        assert!(
            header.lines().any(|l| l == line),
            "missing '{line}' in\n{header}"
        );
    }
    assert_eq!(
        bytes.len() - end - 2,
        48,
        "data is 24 u16 samples right after the blank line"
    );
}

#[test]
fn write_into_a_missing_folder_fails_with_the_path() {
    let dir = TempDir::new("write-nrrd-missing");
    let path = dir.path("no/such/dir/x.nrrd");
    let err = write_nrrd(&path, &volume(VolumeData::U8(vec![0; 24]))).unwrap_err();
    assert_eq!(err.kind(), isogrid::ErrorKind::Io);
    assert!(err.to_string().contains("x.nrrd"), "{err}");
}

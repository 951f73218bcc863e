//! The packed transfer form from the writer's side: its head, the preamble it inflates to and the
//! chunks of its block stream hold what the module doc's byte table says, the same grid packs to the same bytes wherever the output
//! starts, and a cancel stops it. (Rebuilding the `.cgc` from it, byte for byte, is the web
//! viewer's job, tested there: web/test/packed.test.mjs.)

use crate::common::blobs_u8;
use crate::labels::{label_volume, DIMS};
use isogrid::{
    cgc, extract, extract_labels, CellGrid, ErrorKind, ExtractOptions, Iso, LabelOptions,
    LabelSelection, Progress, Volume, VolumeData, WorldFrame,
};
use std::io::{Cursor, Read, Seek, SeekFrom, Write};

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

fn grids() -> Vec<(&'static str, CellGrid)> {
    let volume = blobs_u8([50, 41, 37]);
    let surface = extract(&volume.view(), &ExtractOptions::new(Iso::Value(127.5))).unwrap();
    let labels = Volume::new(DIMS, VolumeData::U16(label_volume())).unwrap();
    let labels = extract_labels(&labels.view(), &LabelOptions::new(LabelSelection::All)).unwrap();
    // A volume placed in patient space (RAS, mirrored axes): the file has a world frame section.
    let mut geometry = *volume.geometry();
    geometry.frame = WorldFrame::Ras;
    geometry.direction = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let placed = Volume::with_geometry(geometry, volume.into_data()).unwrap();
    let placed = extract(&placed.view(), &ExtractOptions::new(Iso::Value(127.5))).unwrap();
    vec![
        ("surface", surface),
        ("labels", labels),
        ("surface in RAS", placed),
    ]
}

#[test]
fn head_and_body_are_as_the_byte_table_says() {
    for (name, grid) in grids() {
        let file = cgc::to_bytes(&grid);
        let packed = cgc::pack(&grid).unwrap();
        let head = u32_at(&packed, 12) as usize;
        assert_eq!(&packed[..8], &cgc::PACKED_MAGIC, "{name}");
        assert_eq!(u32_at(&packed, 8), cgc::PACKED_VERSION, "{name}");
        assert_eq!(head, 320 + 32 * u32_at(&file, 168) as usize, "{name}");
        assert_eq!(u64_at(&packed, 16), file.len() as u64, "{name}");
        let h = cgc::PACKED_HEAD_SIZE;
        assert_eq!(h, 56);
        assert_eq!(&packed[h..h + head], &file[..head], "{name}");
        let mut crc = crc32fast::Hasher::new();
        crc.update(&packed[..48]);
        crc.update(&packed[h..h + head]);
        assert_eq!(u32_at(&packed, 48), crc.finalize(), "{name}");
        assert_eq!(u32_at(&packed, 52), 0, "{name}");
        // The deflate stream of the preamble, then the block stream, which ends the file.
        let (deflated, coded) = (u64_at(&packed, 24) as usize, u64_at(&packed, 40) as usize);
        assert_eq!(packed.len(), h + head + deflated + coded, "{name}");
        let stream = &packed[h + head..h + head + deflated];
        let mut body = Vec::new();
        flate2::read::DeflateDecoder::new(stream)
            .read_to_end(&mut body)
            .unwrap();
        assert_eq!(body.len() as u64, u64_at(&packed, 32), "{name}");
        // The block stream: chunks of (block count, length, coded bytes) that cover every block
        // with clusters, each coded chunk starting with the coder's zero byte.
        let mut chunks = &packed[h + head + deflated..];
        let mut blocks_coded = 0;
        let varint = |b: &mut &[u8]| {
            let mut v = 0u64;
            for shift in (0..).step_by(7) {
                let byte = b[0];
                *b = &b[1..];
                v |= ((byte & 0x7f) as u64) << shift;
                if byte < 0x80 {
                    break;
                }
            }
            v
        };
        while !chunks.is_empty() {
            let n = varint(&mut chunks);
            let length = varint(&mut chunks) as usize;
            assert!(n >= 1 && length >= 5 && chunks[0] == 0, "{name}");
            chunks = &chunks[length..];
            blocks_coded += n as usize;
        }
        let with_clusters = grid
            .blocks()
            .iter()
            .filter(|b| b.cluster_count() > 0)
            .count();
        assert_eq!(blocks_coded, with_clusters, "{name}");
        // It opens with every block's bounds and cluster count.
        let blocks = grid.blocks();
        for (i, b) in blocks.iter().enumerate() {
            assert_eq!(
                &body[8 * i..8 * i + 4],
                &b.min.to_le_bytes(),
                "{name} block {i}"
            );
            assert_eq!(
                &body[8 * i + 4..8 * i + 8],
                &b.max.to_le_bytes(),
                "{name} block {i}"
            );
        }
        let counts: Vec<u8> = blocks.iter().map(|b| b.cluster_count() as u8).collect();
        let at = 8 * blocks.len();
        assert!(
            blocks.iter().all(|b| b.cluster_count() < 128),
            "{name}: one-byte varints"
        );
        assert_eq!(&body[at..at + blocks.len()], &counts[..], "{name}");
        // It closes with the world frame section as it is, when the file has one.
        let frame = cgc::read_bytes(&file).unwrap().info().frame;
        assert_eq!(frame, grid.info().frame, "{name}");
        if frame != WorldFrame::Unknown {
            let code = if frame == WorldFrame::Lps { 1u8 } else { 2 };
            assert_eq!(
                &body[body.len() - 8..],
                &[code, 0, 0, 0, 0, 0, 0, 0],
                "{name}"
            );
        }
        // Far smaller than the file.
        assert!(
            packed.len() * 3 < file.len(),
            "{name}: {} of {}",
            packed.len(),
            file.len()
        );
    }
}

#[test]
fn packing_into_a_stream_at_any_offset_gives_the_same_bytes() {
    for (name, grid) in grids() {
        let packed = cgc::pack(&grid).unwrap();
        let mut out = Cursor::new(Vec::new());
        out.write_all(b"before").unwrap();
        let sizes = cgc::pack_into(&grid, &mut out).unwrap();
        assert_eq!(
            out.stream_position().unwrap(),
            6 + packed.len() as u64,
            "{name}"
        );
        assert_eq!(sizes.packed, packed.len() as u64, "{name}");
        assert_eq!(sizes.cgc, cgc::to_bytes(&grid).len() as u64, "{name}");
        out.seek(SeekFrom::Start(0)).unwrap();
        let out = out.into_inner();
        assert_eq!(&out[..6], b"before");
        assert!(out[6..] == packed[..], "{name}");
        assert!(
            cgc::pack(&grid).unwrap() == packed,
            "{name}: not deterministic"
        );
    }
}

#[test]
fn a_cancel_stops_packing() {
    let (_, grid) = grids().remove(0);
    let progress = Progress::new();
    progress.cancel();
    let err =
        cgc::pack_into_with_progress(&grid, &mut Cursor::new(Vec::new()), &progress).unwrap_err();
    assert_eq!(err.kind(), ErrorKind::Cancelled);
    // Uncancelled, it counts every block.
    let progress = Progress::new();
    cgc::pack_into_with_progress(&grid, &mut Cursor::new(Vec::new()), &progress).unwrap();
    assert_eq!(
        progress.counts(),
        (grid.blocks().len() as u64, grid.blocks().len() as u64)
    );
}

// Decoding of clustered grid cells (paper §3.1, Table 1), byte for byte the core's packed layout
// (`isogrid::layout`): metacell slot = 3 words (x | y << 16, z | mask << 16, cell_pointer), corner
// records at the grid's precision. Every shader that reads cells decodes them here.
//
// The words come from `slot_word(page, i)` and `record_word(page, i)` (word i of a page's metacell
// slots / corner records, then the records' attribute codes), which the prepended storage file defines: cell_data.wgsl for one page
// per bind group (the raster passes and the single-page tracer), trace_pages.wgsl for the tracer
// binding several pages at once. `page` is the page's index among the bound ones.
//
// Prepended after common.wgsl, before the storage file.

@group(0) @binding(0) var<uniform> frame: FrameUniforms;

struct Metacell {
    origin: vec3<u32>, // cell index of its cell 0 (cell units)
    mask: u32,         // active cells, bit b = cell (b&1, b>>1&1, b>>2&1)
    cell_pointer: u32, // global index of the record of its first active cell
}

fn metacell_in(page: u32, local_slot: u32) -> Metacell {
    let w0 = slot_word(page, 3u * local_slot);
    let w1 = slot_word(page, 3u * local_slot + 1u);
    let w2 = slot_word(page, 3u * local_slot + 2u);
    let position = vec3<u32>(w0 & 0xffffu, w0 >> 16u, w1 & 0xffffu);
    return Metacell(2u * position, (w1 >> 16u) & 0xffu, w2);
}

fn cell_offset(bit: u32) -> vec3<u32> {
    return vec3<u32>(bit & 1u, (bit >> 1u) & 1u, (bit >> 2u) & 1u);
}

// Corner c of a page's packed record, exactly `isogrid::layout::read_corner`.
fn record_corner_in(page: u32, local_record: u32, c: u32) -> f32 {
    switch frame.params.x {
        case 1u: {
            // One byte per record, four records per word: corner c is bit c of the byte.
            let word = record_word(page, local_record / 4u);
            return f32((word >> (8u * (local_record % 4u) + c)) & 1u);
        }
        case 4u: {
            return f32((record_word(page, local_record) >> (4u * c)) & 0xfu);
        }
        case 8u: {
            return f32((record_word(page, 2u * local_record + c / 4u) >> (8u * (c % 4u))) & 0xffu);
        }
        case 16u: {
            return f32((record_word(page, 4u * local_record + c / 2u) >> (16u * (c % 2u))) & 0xffffu);
        }
        default: {
            return bitcast<f32>(record_word(page, 8u * local_record + c));
        }
    }
}

// The 8 corner values of a cell as two vec4 (corners 0-3, 4-7), in the units of `frame.cell_to_world.w`.
struct Corners {
    lo: vec4<f32>,
    hi: vec4<f32>,
}

// The 16-bit attribute code of a page's record (`isogrid::CellAttribute::codes16`), where the
// page's buffer holds codes from word `codes_word` on: after the records, two per word, the first
// in the low half (`RecordLayout` in src/upload.rs). So a code is paged with its record, by the
// same record → page rule. 0 where the page holds none (codes_word 0: no attribute uploaded).
fn record_code_in(page: u32, codes_word: u32, local_record: u32) -> u32 {
    if codes_word == 0u {
        return 0u;
    }
    return (record_word(page, codes_word + local_record / 2u) >> (16u * (local_record % 2u))) & 0xffffu;
}

fn record_corners_in(page: u32, local_record: u32) -> Corners {
    var v: array<f32, 8>;
    for (var c = 0u; c < 8u; c++) {
        v[c] = record_corner_in(page, local_record, c);
    }
    return Corners(vec4<f32>(v[0], v[1], v[2], v[3]), vec4<f32>(v[4], v[5], v[6], v[7]));
}

// A group of up to TRACE_PAGES consecutive pages of a grid bound at once for the path tracer
// (paper §3.6 on grids larger than one storage binding): the storage behind cell_decode.wgsl when
// the grid was split into several pages. Grids of more pages are traced one group per pass. WGSL cannot index an array of buffer bindings (that needs binding arrays, which
// not every backend has), so each page's metacell slots and corner records are their own binding
// and `slot_word` / `record_word` switch on the page index. Unused bindings hold a small dummy.
// cell_data.wgsl is the one-page twin of this file's functions; keep their signatures in sync.
//
// Prepended after common.wgsl and cell_decode.wgsl, instead of cell_data.wgsl.

// Keep in sync with `TRACE_PAGES` in src/gpu_types.rs (and with the bindings below).
const TRACE_PAGES: u32 = 6u;

// Keep in sync with `TracePages` in src/gpu_types.rs.
struct TracePages {
    count: vec4<u32>,                 // x: pages bound (1..=TRACE_PAGES); y: global slot just past the last bound page
    first_slot: array<vec4<u32>, 2>,  // global index of each page's first metacell slot, page p at [p / 4][p % 4]
    first_cell: array<vec4<u32>, 2>,  // global index of each page's first corner record, likewise
    codes_word: array<vec4<u32>, 2>,  // each page's `PageUniforms.codes_word`, likewise
}

@group(1) @binding(0) var<uniform> pages: TracePages;

@group(1) @binding(1) var<storage, read> metacells_0: array<u32>;
@group(1) @binding(2) var<storage, read> metacells_1: array<u32>;
@group(1) @binding(3) var<storage, read> metacells_2: array<u32>;
@group(1) @binding(4) var<storage, read> metacells_3: array<u32>;
@group(1) @binding(5) var<storage, read> metacells_4: array<u32>;
@group(1) @binding(6) var<storage, read> metacells_5: array<u32>;
@group(1) @binding(7) var<storage, read> cells_0: array<u32>;
@group(1) @binding(8) var<storage, read> cells_1: array<u32>;
@group(1) @binding(9) var<storage, read> cells_2: array<u32>;
@group(1) @binding(10) var<storage, read> cells_3: array<u32>;
@group(1) @binding(11) var<storage, read> cells_4: array<u32>;
@group(1) @binding(12) var<storage, read> cells_5: array<u32>;

// Word i of page p's metacell slots.
fn slot_word(p: u32, i: u32) -> u32 {
    switch p {
        case 0u: {
            return metacells_0[i];
        }
        case 1u: {
            return metacells_1[i];
        }
        case 2u: {
            return metacells_2[i];
        }
        case 3u: {
            return metacells_3[i];
        }
        case 4u: {
            return metacells_4[i];
        }
        case 5u, default: {
            return metacells_5[i];
        }
    }
}

// Word i of page p's corner records.
fn record_word(p: u32, i: u32) -> u32 {
    switch p {
        case 0u: {
            return cells_0[i];
        }
        case 1u: {
            return cells_1[i];
        }
        case 2u: {
            return cells_2[i];
        }
        case 3u: {
            return cells_3[i];
        }
        case 4u: {
            return cells_4[i];
        }
        case 5u, default: {
            return cells_5[i];
        }
    }
}

fn trace_page_first_slot(p: u32) -> u32 {
    return pages.first_slot[p / 4u][p % 4u];
}

fn trace_page_first_cell(p: u32) -> u32 {
    return pages.first_cell[p / 4u][p % 4u];
}

fn trace_page_codes_word(p: u32) -> u32 {
    return pages.codes_word[p / 4u][p % 4u];
}

// The page holding a global metacell slot: pages are contiguous, ascending runs of whole
// clusters, so the last page starting at or before the slot.
fn trace_page_of_slot(global_slot: u32) -> u32 {
    var p = 0u;
    for (var q = 1u; q < pages.count.x; q++) {
        if global_slot >= trace_page_first_slot(q) {
            p = q;
        }
    }
    return p;
}

// Whether a global metacell slot lies in the bound pages; the traversal sees the others' clusters
// as empty space.
fn trace_slot_is_bound(global_slot: u32) -> bool {
    return global_slot >= trace_page_first_slot(0u) && global_slot < pages.count.y;
}

// Whether any of `count` slots from a global slot on lies in the bound pages.
fn trace_slots_are_bound(first_global_slot: u32, count: u32) -> bool {
    return first_global_slot < pages.count.y && first_global_slot + count > trace_page_first_slot(0u);
}

// Hierarchical ray traversal of the clustered grid cells (paper §3.6): a 3D DDA over the dense
// 16³-cell block grid visits blocks front to back, leaping across the largest cube of empty
// blocks that starts at the current block and grows towards the ray's octant
// (`isogrid::skip::octant_space`, as the CPU tracer does) and skipping blocks without slots; inside a block, a second DDA visits its occupied
// metacells front to back (`isogrid::skip::occupancy`; where the paper slab-tests each cluster
// bound and then each metacell box), then each active cell's unit box is slab-tested, and
// finally the cell's trilinear interpolant of its 8 stored corner codes is sampled three times
// along the segment and refined like the cell raster (`cells.wgsl`). The first metacell with a
// hit holds the nearest one: its cells lie inside its box, and later metacells and blocks start
// where it ends.
//
// Grids split into pages (a contiguous run of whole clusters each) are traced with a group of up
// to TRACE_PAGES pages bound at once: a block's clusters may straddle a page boundary, so the
// page is looked up per metacell (`trace_page_of_slot`), and slots and records are read
// page-locally through cell_decode.wgsl. Clusters outside the bound group are empty space to the
// traversal (`trace_slot_is_bound`); a grid of more groups is traced in one pass per group, each
// keeping the nearer crossing (`trace_ray_until`, src/pathtrace/mod.rs).
//
// Prepended: common.wgsl, cell_decode.wgsl, then cell_data.wgsl (one page) or trace_pages.wgsl
// (several), which provide `trace_page_of_slot`, `trace_page_first_slot`, `trace_page_first_cell`,
// `trace_slot_is_bound` and `trace_slots_are_bound`.
// Rays are in world space (unit direction, t = world distance); traversal runs in cell space
// (world / spacing), where the same t applies to the scaled direction.

// Keep in sync with `TraceUniforms` in src/gpu_types.rs.
struct TraceUniforms {
    block_dims: vec4<u32>, // blocks per axis (0 when the grid has none); w = bounces
    cell_dims: vec4<f32>,  // cells per axis (the grid box in cell units); w = ray offset (world units)
    albedo: vec4<f32>,     // diffuse albedo rgb
    sample: vec4<u32>,     // x: sample index; y: 1 = environment texture, 0 = built-in sky; z: ray count
}

@group(0) @binding(1) var<uniform> trace: TraceUniforms;
// Dense block records, 4 words each: slot count, first slot, min, max (`isogrid::layout::Block`),
// followed by the octant empty-space map, one byte per block for each of the 8 octants in turn
// (keep in sync with `tracer_block_words` in upload.rs).
@group(0) @binding(3) var<storage, read> blocks: array<u32>;

// Side (blocks) of the largest cube of empty blocks with block `index` at its corner, growing
// towards `octant` (bit a set for rays running towards +axis a); 0 for a block with slots.
fn block_side(octant: u32, index: u32) -> u32 {
    let count = trace.block_dims.x * trace.block_dims.y * trace.block_dims.z;
    let byte = octant * count + index;
    let word = blocks[4u * count + byte / 4u];
    return (word >> (8u * (byte % 4u))) & 0xffu;
}

const NO_HIT: f32 = 3.0e38;
const BLOCK_CELLS: f32 = 16.0;
const TRACE_SAMPLES: u32 = 3u;

struct TraceHit {
    t: f32,              // world distance, NO_HIT on a miss
    normal: vec3<f32>,   // unit world −∇f at the hit (out of the solid)
    cluster: u32,        // global cluster index (slot / 16) of the hit cell, NO_CLUSTER on a miss
    record: u32,         // global corner record index of the hit cell
    code: u32,           // its attribute code (`record_code_in`; 0 without an attribute)
}

// Entry and exit t of the box [lo, hi] (cell units) for a ray with origin o and 1/direction inv.
fn box_span(o: vec3<f32>, inv: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec2<f32> {
    let t0 = (lo - o) * inv;
    let t1 = (hi - o) * inv;
    let a = min(t0, t1);
    let b = max(t0, t1);
    return vec2<f32>(max(max(a.x, a.y), a.z), min(min(b.x, b.y), b.z));
}

// The first sample interval [ta, tb] of the three along [t_enter, t_exit] inside one cell (o is
// cell-local) whose ends lie on opposite sides of the isovalue, as fs_cell finds it; x = NO_HIT
// when the samples find none; z = 1 when the entry point is inside.
fn cell_bracket(k: Corners, o: vec3<f32>, d: vec3<f32>, t_enter: f32, t_exit: f32) -> vec3<f32> {
    let iso = frame.cell_to_world.w;
    let inside_at_entry = trilinear(k.lo, k.hi, o + t_enter * d) >= iso;
    var ta = t_enter;
    var tb = t_enter;
    for (var s = 1u; s <= TRACE_SAMPLES; s++) {
        ta = tb;
        tb = mix(t_enter, t_exit, f32(s) / f32(TRACE_SAMPLES));
        if (trilinear(k.lo, k.hi, o + tb * d) >= iso) != inside_at_entry {
            return vec3<f32>(ta, tb, select(0.0, 1.0, inside_at_entry));
        }
    }
    return vec3<f32>(NO_HIT, NO_HIT, 0.0);
}

// Nearest crossing so far, as the bracket that holds it (cells along a ray are disjoint intervals,
// so the cell with the nearest bracket holds the nearest crossing, and only that one is refined,
// after the traversal), and the cell, page, page-local record and global cluster it lies in.
struct Nearest {
    bracket: vec3<f32>, // ta (NO_HIT until found), tb, inside at entry (1) or not (0)
    cell: vec3<u32>,
    page: u32,
    record: u32,
    cluster: u32,
}

// Where the metacell occupancy starts in `blocks`: one word per block, the word offset of the
// block's occupancy record (keep in sync with upload.rs). A record is 25 words: the 512-bit
// Morton-order mask of the block's occupied metacells (words 0–15, code c at word c / 32, bit
// c % 32), the number of occupied metacells before each mask word (words 16–23, two 16-bit
// counts each, word w's in half w % 2 of word 16 + w / 2), and the box of the occupied metacells
// (word 24: lowest x, y, z at bits 0, 3, 6, highest at bits 9, 12, 15; metacells within the block;
// bit 18 (OCCUPANCY_LISTED) set when the block is listed). A listed block (a label grid's block
// holding several labels' runs, which may repeat positions) follows its record with the slots at
// each occupied position: words OCCUPANCY_WORDS + rank and + rank + 1 are the offsets, from the
// record's start, of the first slot at that rank and past its last.
const OCCUPANCY_WORDS: u32 = 25u;
const OCCUPANCY_LISTED: u32 = 0x40000u;
fn occupancy_index(index: u32) -> u32 {
    let count = trace.block_dims.x * trace.block_dims.y * trace.block_dims.z;
    return blocks[4u * count + (8u * count + 3u) / 4u + index];
}

// Morton code of a metacell position (0–7 per axis) within its block, `isogrid::morton`.
fn spread_bits3(v: u32) -> u32 {
    return (v & 1u) | ((v & 2u) << 2u) | ((v & 4u) << 4u);
}

// How far (metacells) the walk's start point moves back along the ray, so that rounding can only
// start it one metacell early (it then leaves that one at once, one wasted move), never one late
// (which would skip a metacell). f32 cell positions near the 128K-cell grid edge are 1/64 cell
// apart; 0.05 metacell leaves several times that.
const METACELL_NUDGE: f32 = 0.05;

// Tests the active cells of the metacell in global slot `slot` on [t_lo, t_hi].
fn trace_metacell(slot: u32, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, t_lo: f32, t_hi: f32, best_in: Nearest) -> Nearest {
    var best = best_in;
    let p = trace_page_of_slot(slot);
    let m = metacell_in(p, slot - trace_page_first_slot(p));
    for (var bit = 0u; bit < 8u; bit++) {
        if (m.mask & (1u << bit)) == 0u {
            continue;
        }
        let cell = m.origin + cell_offset(bit);
        let co = vec3<f32>(cell);
        let span = box_span(o, inv, co, co + 1.0);
        let enter = max(span.x, t_lo);
        let exit = min(span.y, t_hi);
        if enter > exit || enter >= best.bracket.y {
            continue;
        }
        let record = m.cell_pointer + countOneBits(m.mask & ((1u << bit) - 1u)) - trace_page_first_cell(p);
        let bracket = cell_bracket(record_corners_in(p, record), o - co, d, enter, exit);
        let found = Nearest(bracket, cell, p, record, slot / 16u);
        if bracket.x < best.bracket.x {
            best = found;
        } else if bracket.x == best.bracket.x && bracket.x < NO_HIT && wins_tie(found, best, o, d) {
            best = found;
        }
    }
    return best;
}

// The refined crossing t of a bracket found by `trace_metacell`, and whether the ray enters the
// solid there (∇f along the ray: the surface's front face).
fn refined_crossing(n: Nearest, o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let k = record_corners_in(n.page, n.record);
    let local = o - vec3<f32>(n.cell);
    let t = refine_crossing(k.lo, k.hi, local, d, n.bracket.x, n.bracket.y, frame.cell_to_world.w, n.bracket.z > 0.5);
    let g = trilinear_gradient(k.lo, k.hi, clamp(local + t * d, vec3<f32>(0.0), vec3<f32>(1.0)));
    return vec2<f32>(t, select(0.0, 1.0, dot(g, d) > 0.0));
}

// Whether `found` replaces `best` when both brackets start at the same t: two metacells at one
// position, i.e. two labels' cells in one cell of a label grid (cells along a ray are otherwise
// disjoint intervals). The nearer crossing wins; where touching labels share a boundary both
// surfaces cross at the same point (to rounding), and the one the ray enters (its front face, as
// the CPU tracer's `wins_tie` judges it) wins, then the first in slot order (the lower label), so
// the boundary shows one label without speckle, and the label beyond it when the one before it
// is hidden.
fn wins_tie(found: Nearest, best: Nearest, o: vec3<f32>, d: vec3<f32>) -> bool {
    let f = refined_crossing(found, o, d);
    let b = refined_crossing(best, o, d);
    let tie = 1e-3 * (found.bracket.y - found.bracket.x);
    if abs(f.x - b.x) > tie {
        return f.x < b.x;
    }
    return f.y > 0.5 && b.y < 0.5;
}

// Nearest crossing in block `index` (at block position `block`) on [t_lo, t_hi]: a 3D DDA
// (Amanatides & Woo 1987) over the box of the block's occupied metacells visits them front to
// back, each found at slot `first + k + k / 15` by its rank k in the Morton-order mask (the
// extraction's order, paper §3.1) or, in a listed block, at the slots listed for rank k, and the
// first position with a crossing holds the block's nearest one. This replaces the paper's tests of every cluster bound and metacell box (§3.6):
// in a dense block those read and test dozens of boxes a ray never comes near.
fn trace_block(index: u32, block: vec3<i32>, o: vec3<f32>, d: vec3<f32>, inv: vec3<f32>, positive: vec3<bool>, t_lo: f32, t_hi: f32, best_in: Nearest) -> Nearest {
    var best = best_in;
    let first = blocks[4u * index + 1u];
    let record = occupancy_index(index);
    let packed = blocks[record + 24u];
    let listed = (packed & OCCUPANCY_LISTED) != 0u;
    let lowest = vec3<i32>(vec3<u32>(packed, packed >> 3u, packed >> 6u) & vec3<u32>(7u));
    let highest = vec3<i32>(vec3<u32>(packed >> 9u, packed >> 12u, packed >> 15u) & vec3<u32>(7u));
    if any(lowest > highest) {
        return best; // no metacell kept its layout (a corrupt grid): nothing to walk
    }
    let c0 = vec3<f32>(block) * BLOCK_CELLS;
    let span = box_span(o, inv, c0 + 2.0 * vec3<f32>(lowest), c0 + 2.0 * vec3<f32>(highest + 1));
    let t_in = max(span.x, t_lo);
    let t_out = min(span.y, t_hi);
    if t_in > t_out {
        return best;
    }
    let back = select(vec3<f32>(METACELL_NUDGE), vec3<f32>(-METACELL_NUDGE), positive);
    var m = clamp(vec3<i32>(floor((o + t_in * d - c0) * 0.5 + back)), lowest, highest);
    let step = select(vec3<i32>(-1), vec3<i32>(1), positive);
    let upper = select(vec3<i32>(0), vec3<i32>(1), positive);
    // At most 22 moves cross an 8³ box; the bound also ends the loop on NaN input.
    for (var moves = 0; moves < 24; moves++) {
        let code = spread_bits3(u32(m.x)) | (spread_bits3(u32(m.y)) << 1u) | (spread_bits3(u32(m.z)) << 2u);
        let word = blocks[record + (code >> 5u)];
        let bit = code & 31u;
        if ((word >> bit) & 1u) != 0u {
            let before = (blocks[record + 16u + (code >> 6u)] >> (16u * ((code >> 5u) & 1u))) & 0xffffu;
            let rank = before + countOneBits(word & ((1u << bit) - 1u));
            if !listed {
                let slot = first + rank + rank / 15u;
                if trace_slot_is_bound(slot) {
                    best = trace_metacell(slot, o, d, inv, t_lo, t_hi, best);
                }
            } else {
                // A label grid's position held by several labels: test every slot there.
                let end = record + blocks[record + OCCUPANCY_WORDS + rank + 1u];
                for (var e = record + blocks[record + OCCUPANCY_WORDS + rank]; e < end; e++) {
                    let slot = blocks[e];
                    if trace_slot_is_bound(slot) {
                        best = trace_metacell(slot, o, d, inv, t_lo, t_hi, best);
                    }
                }
            }
            if best.bracket.x < NO_HIT {
                break;
            }
        }
        // Face times afresh from the planes (no accumulated increments), so that one metacell's
        // exit is exactly the next one's entry.
        let t_next = (c0 + 2.0 * vec3<f32>(m + upper) - o) * inv;
        if !(min(min(t_next.x, t_next.y), t_next.z) < t_out) {
            break;
        }
        if t_next.x <= t_next.y && t_next.x <= t_next.z {
            m.x += step.x;
        } else if t_next.y <= t_next.z {
            m.y += step.y;
        } else {
            m.z += step.z;
        }
        if any(m < lowest) || any(m > highest) {
            break;
        }
    }
    return best;
}

// Nearest crossing of the world ray origin + t·dir (unit dir) with t in [t_min, t_max].
fn trace_ray(origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32) -> TraceHit {
    return trace_ray_until(origin, dir, t_min, t_max, t_max);
}

// Like `trace_ray`, in the bound pages only (the clusters of other pages are seen as empty
// space), and visiting no block that starts beyond t_stop: a pass over one group of pages that
// knows a crossing at t_stop from earlier groups. Cells are still clipped to [t_min, t_max]
// only, so a crossing found here is computed exactly as a trace of the whole grid computes it.
fn trace_ray_until(origin: vec3<f32>, dir: vec3<f32>, t_min: f32, t_max: f32, t_stop: f32) -> TraceHit {
    let miss = TraceHit(NO_HIT, vec3<f32>(0.0), NO_CLUSTER, 0u, 0u);
    if trace.block_dims.x == 0u {
        return miss;
    }
    let s = frame.cell_to_world.xyz;
    let o = origin / s;
    let d = dir / s;
    // Tiny components keep their sign so that the DDA steps and boundary times agree.
    let safe = select(d, select(vec3<f32>(-1e-30), vec3<f32>(1e-30), d >= vec3<f32>(0.0)), abs(d) < vec3<f32>(1e-30));
    let inv = 1.0 / safe;
    let grid = box_span(o, inv, vec3<f32>(0.0), trace.cell_dims.xyz);
    let t_start = max(grid.x, t_min);
    let t_end = min(grid.y, min(t_max, t_stop));
    if t_start > t_end {
        return miss;
    }
    let nb = vec3<i32>(trace.block_dims.xyz);
    let p = o + t_start * d;
    var b = clamp(vec3<i32>(floor(p / BLOCK_CELLS)), vec3<i32>(0), nb - vec3<i32>(1));
    let positive = safe >= vec3<f32>(0.0);
    let dda_step = select(vec3<i32>(-1), vec3<i32>(1), positive);
    let boundary = vec3<f32>(b + select(vec3<i32>(0), vec3<i32>(1), positive)) * BLOCK_CELLS;
    var t_next = (boundary - o) * inv;
    let t_delta = abs(BLOCK_CELLS * inv);
    var best = Nearest(vec3<f32>(NO_HIT, NO_HIT, 0.0), vec3<u32>(0u), 0u, 0u, NO_CLUSTER);
    let max_steps = nb.x + nb.y + nb.z + 3;
    let upper = select(vec3<i32>(0), vec3<i32>(1), positive);
    let octant = dot(vec3<u32>(upper), vec3<u32>(1u, 2u, 4u));
    for (var i = 0; i < max_steps; i++) {
        let index = u32(b.x) + trace.block_dims.x * (u32(b.y) + trace.block_dims.y * u32(b.z));
        let count = blocks[4u * index];
        if count > 0u {
            if trace_slots_are_bound(blocks[4u * index + 1u], count) {
                best = trace_block(index, b, o, d, inv, positive, t_min, t_max, best);
                if best.bracket.x < NO_HIT {
                    break;
                }
            }
        } else {
            let side = i32(block_side(octant, index));
            if side > 1 {
                // Leave the cube of empty blocks ahead at once, entering the block past its far
                // side on the axis the ray leaves through (inside it, up to rounding, on the
                // others, and never backwards).
                let far_side = b + dda_step * (side - 1);
                let leaves = (vec3<f32>(far_side + upper) * BLOCK_CELLS - o) * inv;
                let t = min(min(leaves.x, leaves.y), leaves.z);
                if t >= t_end {
                    break;
                }
                var next = clamp(
                    vec3<i32>(floor((o + t * d) / BLOCK_CELLS)),
                    select(far_side, b, positive),
                    select(b, far_side, positive),
                );
                if leaves.x <= leaves.y && leaves.x <= leaves.z {
                    next.x = far_side.x + dda_step.x;
                } else if leaves.y <= leaves.z {
                    next.y = far_side.y + dda_step.y;
                } else {
                    next.z = far_side.z + dda_step.z;
                }
                b = next;
                if any(b < vec3<i32>(0)) || any(b >= nb) {
                    break;
                }
                t_next = (vec3<f32>(b + upper) * BLOCK_CELLS - o) * inv;
                continue;
            }
        }
        let t_leave = min(min(t_next.x, t_next.y), t_next.z);
        if t_leave >= t_end {
            break;
        }
        if t_next.x <= t_next.y && t_next.x <= t_next.z {
            b.x += dda_step.x;
            t_next.x += t_delta.x;
        } else if t_next.y <= t_next.z {
            b.y += dda_step.y;
            t_next.y += t_delta.y;
        } else {
            b.z += dda_step.z;
            t_next.z += t_delta.z;
        }
        if any(b < vec3<i32>(0)) || any(b >= nb) {
            break;
        }
    }
    if best.bracket.x >= NO_HIT {
        return miss;
    }
    let k = record_corners_in(best.page, best.record);
    let co = vec3<f32>(best.cell);
    let inside = best.bracket.z > 0.5;
    let t = refine_crossing(k.lo, k.hi, o - co, d, best.bracket.x, best.bracket.y, frame.cell_to_world.w, inside);
    let local = clamp(o + t * d - co, vec3<f32>(0.0), vec3<f32>(1.0));
    var n = -trilinear_gradient(k.lo, k.hi, local) / s;
    let len = length(n);
    n = select(-dir, n / len, len > 0.0);
    let code = record_code_in(best.page, trace_page_codes_word(best.page), best.record);
    return TraceHit(t, n, best.cluster, trace_page_first_cell(best.page) + best.record, code);
}

// Test entry point: one thread per ray. Rays: origin (xyz, w = t_min), direction (xyz, unit;
// w = t_max). Hits, two vec4 per ray: normal (xyz), t (w; NO_HIT on a miss), then the hit's
// cluster and record (bits of x and y); the nearest crossing so far: the
// caller starts them at NO_HIT and runs one dispatch per group of bound pages, each keeping the
// nearer crossing (ties keep the earlier group's).
@group(2) @binding(4) var<storage, read> rays: array<vec4<f32>>;
@group(2) @binding(5) var<storage, read_write> hits: array<vec4<f32>>;

@compute @workgroup_size(64)
fn trace_rays(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.x + gid.y * groups.x * 64u;
    if i >= trace.sample.z {
        return;
    }
    let o = rays[2u * i];
    let d = rays[2u * i + 1u];
    let nearest = hits[2u * i].w;
    let h = trace_ray_until(o.xyz, d.xyz, o.w, d.w, nearest);
    if h.t < nearest {
        hits[2u * i] = vec4<f32>(h.normal, h.t);
        hits[2u * i + 1u] = vec4<f32>(bitcast<f32>(h.cluster), bitcast<f32>(h.record), 0.0, 0.0);
    }
}

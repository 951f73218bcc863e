// Cluster expansion and culling (paper §3.2–3.3), the compute replacement for the paper's
// tessellation shader: one thread per metacell slot of a page appends the slot's drawable cells to
// instance lists that indirect draws consume (an instance is `local_slot * 8 + bit`).
//
// `expand_visible`: clusters visible last frame (or all, without occlusion culling) append their
// cells that survive back-face and frustum culling to the full list; other clusters append at most
// one cell per metacell per frame (cell bit (frame + slot) mod 8: each cell every 8th frame) to the
// probe list. `expand_new`: clusters that the probes found visible this frame append their cells
// to the new list, drawn fully in the second raster pass of the same frame.

@group(0) @binding(1) var<storage, read_write> visible_last_frame: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> visible_new: array<atomic<u32>>;

@group(1) @binding(3) var<storage, read_write> full_list: array<u32>;
@group(1) @binding(4) var<storage, read_write> probe_list: array<u32>;
@group(1) @binding(5) var<storage, read_write> new_list: array<u32>;
// Three DrawIndirectArgs (vertex_count, instance_count, first_vertex, first_instance): full, probe, new.
@group(1) @binding(6) var<storage, read_write> draw_args: array<atomic<u32>, 12>;

// Keep in sync with `PageDispatchArgs` in src/gpu_types.rs: DispatchIndirectArgs (x, y, z) of the
// compute raster (cells_compute.wgsl) over the full, probe and new lists.
@group(2) @binding(0) var<storage, read_write> dispatch_args: array<u32, 9>;

// Threads per workgroup of the compute raster and splats; keep in sync with compute_lists.wgsl.
const RASTER_GROUP_SIZE: u32 = 64u;
const MAX_GROUPS_X: u32 = 65535u;

fn cluster_bit(bits_index: u32) -> vec2<u32> {
    return vec2<u32>(bits_index >> 5u, 1u << (bits_index & 31u));
}

// Whether a cell can show a surface point to the eye. Cells wholly on the clipped side of the clip
// plane cannot. Back faces: the first crossing seen from
// outside the solid has f increasing along the ray, ∇f·(x − eye) ≥ 0; the cell is dropped only
// when an interval bound of that product over the whole cell is negative (conservative: the
// gradient's components are bilinear, so their extremes are edge differences).
fn cell_is_drawable(cell: vec3<u32>, record: u32) -> bool {
    let box = cell_box_world(cell);
    let rect = project_box(box[0], box[1]);
    if any(rect.hi < vec2<f32>(-1.0)) || any(rect.lo > vec2<f32>(1.0)) {
        return false;
    }
    if clip_removes_box(frame, box[0], box[1]) {
        return false;
    }
    // Through a cut the eye sees the inside of the solid, so back faces are drawable then.
    if (frame.params.z & FLAG_BACKFACE) == 0u || clip_enabled(frame) {
        return true;
    }
    let k = cell_corners(cell, record);
    let a = k.lo;
    let b = k.hi;
    let gx = vec4<f32>(a.y - a.x, a.w - a.z, b.y - b.x, b.w - b.z);
    let gy = vec4<f32>(a.z - a.x, a.w - a.y, b.z - b.x, b.w - b.y);
    let gz = vec4<f32>(b.x - a.x, b.y - a.y, b.z - a.z, b.w - a.w);
    let g_lo = vec3<f32>(min(min(gx.x, gx.y), min(gx.z, gx.w)), min(min(gy.x, gy.y), min(gy.z, gy.w)), min(min(gz.x, gz.y), min(gz.z, gz.w))) / frame.cell_to_world.xyz;
    let g_hi = vec3<f32>(max(max(gx.x, gx.y), max(gx.z, gx.w)), max(max(gy.x, gy.y), max(gy.z, gy.w)), max(max(gz.x, gz.y), max(gz.z, gz.w))) / frame.cell_to_world.xyz;
    let d_lo = box[0] - frame.eye.xyz;
    let d_hi = box[1] - frame.eye.xyz;
    let upper = max(max(g_lo * d_lo, g_lo * d_hi), max(g_hi * d_lo, g_hi * d_hi));
    return upper.x + upper.y + upper.z >= 0.0;
}

fn append(list_kind: u32, count: u32) -> u32 {
    return atomicAdd(&draw_args[4u * list_kind + 1u], count);
}

// The instances (local slot · 8 + cell bit) of a metacell's cells that pass `cell_is_drawable`,
// for the full list and for the list of newly visible clusters alike.
struct DrawableCells {
    instances: array<u32, 8>,
    count: u32,
}

fn drawable_cells(m: Metacell, local_slot: u32) -> DrawableCells {
    var drawn: DrawableCells;
    var record = m.cell_pointer;
    for (var bit = 0u; bit < 8u; bit++) {
        if (m.mask & (1u << bit)) != 0u {
            if cell_is_drawable(m.origin + cell_offset(bit), record) {
                drawn.instances[drawn.count] = local_slot * 8u + bit;
                drawn.count++;
            }
            record++;
        }
    }
    return drawn;
}

@compute @workgroup_size(64)
fn expand_visible(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local_slot = gid.x + gid.y * groups.x * 64u;
    if local_slot >= page.slot_count || (local_slot & 15u) == 15u {
        return;
    }
    let m = read_metacell(local_slot);
    if m.mask == 0u {
        return;
    }
    let global_slot = page.first_slot + local_slot;
    let cluster = cluster_bit(global_slot / 16u);
    let occlusion = (frame.params.z & FLAG_OCCLUSION) != 0u;
    if !occlusion || (atomicLoad(&visible_last_frame[cluster.x]) & cluster.y) != 0u {
        let drawn = drawable_cells(m, local_slot);
        if drawn.count > 0u {
            let at = append(0u, drawn.count);
            for (var i = 0u; i < drawn.count; i++) {
                full_list[at + i] = drawn.instances[i];
            }
        }
    } else {
        let bit = (frame.params.w + global_slot) & 7u;
        if (m.mask & (1u << bit)) != 0u {
            let record = m.cell_pointer + countOneBits(m.mask & ((1u << bit) - 1u));
            if cell_is_drawable(m.origin + cell_offset(bit), record) {
                probe_list[append(1u, 1u)] = local_slot * 8u + bit;
            }
        }
    }
}

@compute @workgroup_size(64)
fn expand_new(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let local_slot = gid.x + gid.y * groups.x * 64u;
    if local_slot >= page.slot_count || (local_slot & 15u) == 15u {
        return;
    }
    let cluster = cluster_bit((page.first_slot + local_slot) / 16u);
    if (atomicLoad(&visible_new[cluster.x]) & cluster.y) == 0u {
        return;
    }
    let drawn = drawable_cells(read_metacell(local_slot), local_slot);
    if drawn.count > 0u {
        let at = append(2u, drawn.count);
        for (var i = 0u; i < drawn.count; i++) {
            new_list[at + i] = drawn.instances[i];
        }
    }
}

// Workgroup counts of the compute raster from the instance counts of the lists, split over y beyond
// the 65535 workgroups allowed per dimension; run after each expansion.
@compute @workgroup_size(1)
fn size_dispatches() {
    for (var list = 0u; list < 3u; list++) {
        let groups = (atomicLoad(&draw_args[4u * list + 1u]) + RASTER_GROUP_SIZE - 1u) / RASTER_GROUP_SIZE;
        dispatch_args[3u * list] = min(groups, MAX_GROUPS_X);
        dispatch_args[3u * list + 1u] = max((groups + MAX_GROUPS_X - 1u) / MAX_GROUPS_X, 1u);
        dispatch_args[3u * list + 2u] = 1u;
    }
}

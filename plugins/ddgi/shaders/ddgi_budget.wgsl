// DDGI pass `ddgi_budget`: how many rays each probe traces this frame (its temporal error, resting,
// pins, re-checks, an optional frame budget), packed into one array by a prefix sum, with the
// indirect dispatches of `ddgi_trace` and `ddgi_probe_update` and the list of probes with rays.
#include "ddgi_common.inc.wgsl"

// ---------------------------------------------------------------------------------------------
// Budget

var<workgroup> wg_scan: array<u32, DDGI_BUDGET_BLOCK>;
var<workgroup> wg_max: array<f32, DDGI_BUDGET_BLOCK>;

// This frame's ray count of probe p, before any frame budget.
fn ddgi_probe_budget(p: u32) -> u32 {
    let v = ddgi_volume;
    let data = ddgi_probes[p];
    let max_rays = v.rays_per_probe;
    let min_rays = clamp(v.min_rays, 1u, max_rays);
    if data.pinned_state == DDGI_PIN_INACTIVE {
        return 0u;
    }
    if data.pinned_rays != DDGI_NO_PIN {
        return min(data.pinned_rays, max_rays);
    }
    if (data.state & DDGI_PROBE_INACTIVE) != 0u && data.pinned_state != DDGI_PIN_ACTIVE {
        // Switched off: a few rays on re-check frames, so that a change can wake it (and at the
        // next frame after relocation moved it out of geometry, or after the camera's view came to
        // depend on it).
        let seen = DDGI_PROBE_EMPTY | DDGI_PROBE_SEEN;
        let recheck = v.recheck != 0u || (data.state & DDGI_PROBE_RECHECK) != 0u || (data.state & seen) == seen
            || (v.wake_boxes > 0u && ddgi_near_mover(ddgi_probe_position(p)));
        return select(0u, clamp(v.recheck_rays, 1u, max_rays), recheck);
    }
    if !ddgi_has(DDGI_ADAPTIVE) || (data.state & DDGI_PROBE_FRESH) != 0u {
        return max_rays;
    }
    // The error asks for rays in proportion; a rising error gets them at once, a falling one
    // gives them back gradually.
    let wanted = f32(min_rays) + f32(max_rays - min_rays) * clamp(data.error / max(v.error_target, 1e-6), 0.0, 1.0);
    let decayed = f32(data.ray_count) * clamp(v.error_decay, 0.0, 1.0);
    return clamp(u32(ceil(max(wanted, decayed))), min_rays, max_rays);
}

// Exclusive prefix sum of `value` over the workgroup (Hillis–Steele); returns (offset, total).
fn ddgi_scan(value: u32, local: u32) -> vec2<u32> {
    wg_scan[local] = value;
    workgroupBarrier();
    for (var step = 1u; step < DDGI_BUDGET_BLOCK; step *= 2u) {
        var add = 0u;
        if local >= step {
            add = wg_scan[local - step];
        }
        workgroupBarrier();
        wg_scan[local] += add;
        workgroupBarrier();
    }
    let inclusive = wg_scan[local];
    let total = wg_scan[DDGI_BUDGET_BLOCK - 1u];
    workgroupBarrier();
    return vec2<u32>(inclusive - value, total);
}

// The largest `value` of the workgroup's threads, by a tree of halving steps (every thread calls
// it: it holds barriers).
fn ddgi_workgroup_max(value: f32, local: u32) -> f32 {
    wg_max[local] = value;
    workgroupBarrier();
    for (var stride = DDGI_BUDGET_BLOCK / 2u; stride > 0u; stride /= 2u) {
        if local < stride {
            wg_max[local] = max(wg_max[local], wg_max[local + stride]);
        }
        workgroupBarrier();
    }
    return wg_max[0];
}

// Resting (adaptive budgets). A probe whose error at its last update was under
// rest_error × error_target is quiet (with rest_smoothing ≥ 0: its settled error under that, and its
// error under the target): its maps have converged and further rays would only stir their noise,
// so it rests — keeps its maps, traces nothing, costs no per-probe pass — for a period
// that doubles at each quiet update (up to max_rest_frames) and falls back to every frame at the
// first update that is not quiet. A resting probe wakes at once when one of its six neighbours
// sees its lighting change (error over the target), when an instance moved near it (wake boxes),
// and on a frame whose light the CPU saw change everywhere (wake_resting): a change anywhere in
// the scene is caught within a frame or two by the probes that are awake or due. Returns (rays,
// new rest word).
fn ddgi_rest(p: u32, data: DdgiProbeData, rays: u32) -> vec2<u32> {
    let v = ddgi_volume;
    let quiet_allowed = ddgi_has(DDGI_ADAPTIVE) && v.max_rest_frames > 1u && rays > 0u
        && (data.state & (DDGI_PROBE_INACTIVE | DDGI_PROBE_FRESH)) == 0u && data.pinned_rays == DDGI_NO_PIN;
    if !quiet_allowed {
        return vec2<u32>(rays, 1u);
    }
    let period = clamp(data.rest & 0xffffu, 1u, v.max_rest_frames);
    let left = data.rest >> 16u;
    if left > 0u {
        if v.wake_resting == 0u && !ddgi_neighbour_changing(p) && !(v.wake_boxes > 0u && ddgi_near_mover(ddgi_probe_position(p))) {
            return vec2<u32>(0u, period | ((left - 1u) << 16u));
        }
        return vec2<u32>(rays, 1u);
    }
    // Due: the last update's errors decide the next rest (with rest_smoothing ≥ 0, the settled one,
    // whose slower average keeps little of the noise, whether the maps have converged, and the
    // other that the lighting is not changing now).
    let quiet_level = v.rest_error * v.error_target;
    var quiet = data.error < quiet_level;
    if v.rest_smoothing >= 0.0 {
        quiet = data.settled_error < quiet_level && data.error < v.error_target;
    }
    if !quiet {
        return vec2<u32>(rays, 1u);
    }
    let next = min(period * 2u, v.max_rest_frames);
    // A first rest of random length in [0, next), so that probes that settle together do not all
    // update on the same frames afterwards.
    var wait = next - 1u;
    if next > period {
        wait = hash_lowbias32(p ^ (next * 0x9e3779b9u)) % next;
    }
    return vec2<u32>(rays, next | (wait << 16u));
}

// Whether one of probe p's six neighbours (active, updated at some point) is over the error target.
fn ddgi_neighbour_changing(p: u32) -> bool {
    for (var k = 0u; k < 6u; k++) {
        let q = ddgi_neighbour(p, ddgi_face_step(k));
        if q != DDGI_NO_PROBE {
            let n = ddgi_probes[q];
            if (n.state & (DDGI_PROBE_INACTIVE | DDGI_PROBE_FRESH)) == 0u && n.error > ddgi_volume.error_target {
                return true;
            }
        }
    }
    return false;
}

// The budget pass, in three dispatches (a prefix sum over blocks of 256 probes), five under a
// frame budget:
// 1. plan_rays: each probe's rays as its state, error and rest ask (ray_count), their offsets
//    within the block, and each block's sums (rays, probes with rays) and brightest probe;
// 2. (frame budget) plan_budget_scale: one workgroup sums the blocks: the share of its rays each
//    probe keeps under the frame budget;
// 3. (frame budget) scale_rays: each probe's rays under that share, their offsets within the
//    block, the block's sums;
// 4. plan_ray_blocks: one workgroup scans the blocks' sums, writes the indirect dispatches of the
//    ray passes and of the per-probe passes, and the brightest probe's luma;
// 5. place_rays: each probe's offset plus its block's, and the list of probes with rays.
@compute @workgroup_size(DDGI_BUDGET_BLOCK)
fn plan_rays(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let p = group.x * DDGI_BUDGET_BLOCK + local;
    var count = 0u;
    var luma = 0.0;
    if p < ddgi_volume.probe_count {
        let data = ddgi_probes[p];
        let rest = ddgi_rest(p, data, ddgi_probe_budget(p));
        count = rest.x;
        ddgi_probes[p].ray_count = count;
        ddgi_probes[p].rest = rest.y;
        luma = data.luma;
        ddgi_lit[p] = select(-1.0, luma, (data.state & DDGI_PROBE_INACTIVE) == 0u);
    }
    // Offsets within the block, as if no frame budget applied (scale_rays redoes them when one does).
    let sums = ddgi_place_in_block(p, count, local);
    let m = ddgi_workgroup_max(luma, local);
    if local == 0u {
        ddgi_blocks[group.x] = DdgiBlock(sums.x, sums.x, m, 0u, sums.y, 0u);
    }
}

// Probe p's rays (`count`) within its block of the prefix sum: writes its offset among the
// block's rays; returns the block's rays and its probes with rays (every thread of the block calls
// it: it holds barriers).
fn ddgi_place_in_block(p: u32, count: u32, local: u32) -> vec2<u32> {
    let scan = ddgi_scan(count, local);
    if p < ddgi_volume.probe_count {
        ddgi_probes[p].ray_offset = scan.x;
    }
    return vec2<u32>(scan.y, ddgi_scan(u32(count > 0u), local).y);
}

fn ddgi_block_count() -> u32 {
    return (ddgi_volume.probe_count + DDGI_BUDGET_BLOCK - 1u) / DDGI_BUDGET_BLOCK;
}

@compute @workgroup_size(DDGI_BUDGET_BLOCK)
fn plan_budget_scale(@builtin(local_invocation_index) local: u32) {
    let blocks = ddgi_block_count();
    var wanted = 0u;
    for (var first = 0u; first < blocks; first += DDGI_BUDGET_BLOCK) {
        let b = first + local;
        var rays = 0u;
        if b < blocks {
            rays = ddgi_blocks[b].unscaled_rays;
        }
        wanted += ddgi_scan(rays, local).y;
    }
    if local == 0u {
        let budget = ddgi_volume.frame_budget;
        ddgi_counters.budget_scale = select(1.0, f32(budget) / f32(max(wanted, 1u)), budget != 0u && wanted > budget);
    }
}

@compute @workgroup_size(DDGI_BUDGET_BLOCK)
fn scale_rays(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let p = group.x * DDGI_BUDGET_BLOCK + local;
    let scale = ddgi_counters.budget_scale;
    var count = 0u;
    if p < ddgi_volume.probe_count {
        count = ddgi_probes[p].ray_count;
        if scale < 1.0 && count > 0u {
            // Over the frame budget: every probe's share shrinks in proportion (keeping one ray for
            // probes that had any), so the budget goes where the error asked for it.
            count = max(1u, u32(f32(count) * scale));
        }
    }
    if p < ddgi_volume.probe_count {
        ddgi_probes[p].ray_count = count;
    }
    let sums = ddgi_place_in_block(p, count, local);
    if local == 0u {
        ddgi_blocks[group.x].rays = sums.x;
        ddgi_blocks[group.x].probes = sums.y;
    }
}

@compute @workgroup_size(DDGI_BUDGET_BLOCK)
fn plan_ray_blocks(@builtin(local_invocation_index) local: u32) {
    let blocks = ddgi_block_count();
    var offset = 0u;
    var probes = 0u;
    var brightest = 0.0;
    for (var first = 0u; first < blocks; first += DDGI_BUDGET_BLOCK) {
        let b = first + local;
        var block = DdgiBlock(0u, 0u, 0.0, 0u, 0u, 0u);
        if b < blocks {
            block = ddgi_blocks[b];
        }
        brightest = max(brightest, block.max_luma);
        let scan = ddgi_scan(block.rays, local);
        let probe_scan = ddgi_scan(block.probes, local);
        if b < blocks {
            ddgi_blocks[b].offset = offset + scan.x;
            ddgi_blocks[b].probe_offset = probes + probe_scan.x;
        }
        offset += scan.y;
        probes += probe_scan.y;
    }
    let m = ddgi_workgroup_max(brightest, local);
    if local == 0u {
        let groups = (offset + DDGI_RAY_GROUP - 1u) / DDGI_RAY_GROUP;
        ddgi_counters.dispatch = vec3<u32>(min(groups, 65535u), max((groups + 65534u) / 65535u, 1u), 1u);
        ddgi_counters.total_rays = offset;
        let persistent = (offset + DDGI_PERSISTENT_TRACE_GROUP - 1u) / DDGI_PERSISTENT_TRACE_GROUP;
        ddgi_counters.persistent_dispatch = vec3<u32>(min(persistent, DDGI_PERSISTENT_TRACE_GROUPS), 1u, 1u);
        ddgi_counters.probe_dispatch = vec3<u32>(min(probes, 65535u), max((probes + 65534u) / 65535u, 1u), 1u);
        ddgi_counters.updated_probes = probes;
        ddgi_counters.max_luma = m;
    }
}

@compute @workgroup_size(DDGI_BUDGET_BLOCK)
fn place_rays(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let p = group.x * DDGI_BUDGET_BLOCK + local;
    var traced = false;
    if p < ddgi_volume.probe_count {
        ddgi_probes[p].ray_offset += ddgi_blocks[group.x].offset;
        traced = ddgi_probes[p].ray_count > 0u;
    }
    // The probes with rays, listed for the per-probe passes.
    let slot = ddgi_scan(u32(traced), local).x;
    if traced {
        ddgi_updated[ddgi_blocks[group.x].probe_offset + slot] = p;
    }
}

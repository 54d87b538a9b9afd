// The trace benchmark's kernels (bench_trace.inc.wgsl) for any device: no subgroup operations, so
// triangle tests are never postponed (BENCH_POSTPONE_SHARE must stay 0).
#include "bench_trace.inc.wgsl"

// Without subgroup operations a lane cannot see what the others want.
fn bench_postpone_triangles(wants: bool) -> bool {
    return false;
}

// The offset of a lane's next ray when `done`: one atomic add a lane (BENCH_SUBGROUP_FETCH is for
// bench_trace_subgroup.wgsl).
fn bench_fetch(done: bool) -> u32 {
    if done {
        return atomicAdd(&bench_next, 1u);
    }
    return 0u;
}

// The packet kernel's packet is the workgroup: the lanes' hit masks meet in workgroup memory, and
// lane 0 unites them (slow: for counting the walk of packets of any size, e.g. on lavapipe, whose
// subgroups are narrower than a warp).
var<workgroup> bench_packet_masks: array<u32, BENCH_GROUP>;
var<workgroup> bench_packet_union: u32;
fn bench_packet_or(m: u32) -> u32 {
    bench_packet_masks[bench_lane] = m;
    workgroupBarrier();
    if bench_lane == 0u {
        var u = 0u;
        for (var k = 0u; k < BENCH_GROUP; k++) {
            u |= bench_packet_masks[k];
        }
        bench_packet_union = u;
    }
    return workgroupUniformLoad(&bench_packet_union);
}

// The direction of the workgroup's first ray (`first`), whose octant orders the packet's walk.
fn bench_packet_lead(dir: vec3<f32>, first: u32) -> vec3<f32> {
    return rt_safe_direction(bench_ray(min(first, bench.ray_count - 1u)).direction);
}

@compute @workgroup_size(BENCH_GROUP)
fn packet(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    bench_packet_main(id, lane);
}

@compute @workgroup_size(BENCH_GROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    bench_main(id, lane);
}

@compute @workgroup_size(BENCH_GROUP)
fn persistent(@builtin(workgroup_id) group_id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    bench_persistent(group_id, lane);
}

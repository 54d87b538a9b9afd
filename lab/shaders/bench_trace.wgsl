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

@compute @workgroup_size(BENCH_GROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    bench_main(id, lane);
}

@compute @workgroup_size(BENCH_GROUP)
fn persistent(@builtin(workgroup_id) group_id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    bench_persistent(group_id, lane);
}

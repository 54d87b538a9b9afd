// The trace benchmark's kernels (bench_trace.inc.wgsl) with subgroup operations, for postponed
// triangle tests (`bench trace --subgroup-postpone`): a device with wgpu::Features::SUBGROUP only.
// (naga 30 takes subgroup built-ins without `enable subgroups;`, which it does not implement yet,
// and validates them when the device has the feature.)
#include "bench_trace.inc.wgsl"

// Lanes of the subgroup, among those here now, for which `p` holds.
fn bench_subgroup_count(p: bool) -> u32 {
    let b = subgroupBallot(p);
    return countOneBits(b.x) + countOneBits(b.y) + countOneBits(b.z) + countOneBits(b.w);
}

// Whether a lane that `wants` triangle tests puts them off: fewer than BENCH_POSTPONE_SHARE of the
// subgroup's lanes here want theirs. Every lane at the step calls it (two ballots).
fn bench_postpone_triangles(wants: bool) -> bool {
    let wanting = bench_subgroup_count(wants);
    let here = bench_subgroup_count(true);
    return wants && f32(wanting) < BENCH_POSTPONE_SHARE * f32(here);
}

// The offset of a lane's next ray when `done` (BENCH_SUBGROUP_FETCH): the subgroup's lowest lane
// here adds the number of lanes done to the workgroup's counter, once for all of them, and each
// lane done takes the offset after those of the done lanes below it. Every lane here calls it.
fn bench_fetch(done: bool) -> u32 {
    let count = bench_subgroup_count(done);
    let lowest = subgroupExclusiveAdd(1u) == 0u;
    var base = 0u;
    if count > 0u && lowest {
        base = atomicAdd(&bench_next, count);
    }
    // The other lanes hold 0.
    base = subgroupMax(base);
    return base + subgroupExclusiveAdd(select(0u, 1u, done));
}

// The packet kernel's packet is the subgroup (a warp of 32 on NVIDIA).
fn bench_packet_or(m: u32) -> u32 {
    return subgroupOr(m);
}

// The direction of the subgroup's first active lane's ray, whose octant orders the packet's walk.
fn bench_packet_lead(dir: vec3<f32>, first: u32) -> vec3<f32> {
    return subgroupBroadcastFirst(dir);
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

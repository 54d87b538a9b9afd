// Probe-like rays for the trace benchmark: from every point of a probe grid, `rays_per_probe`
// spherical Fibonacci directions under a random rotation, traced for the closest hit. The kernels'
// bodies (bench_main, bench_persistent); their entry points are in bench_trace.wgsl and, with
// subgroup operations, bench_trace_subgroup.wgsl, which each define bench_postpone_triangles.
#include "rt_alpha.inc.wgsl"

struct BenchParams {
    // Rotation applied to every direction (columns).
    rotation: mat4x4<f32>,
    grid_origin: vec3<f32>,
    rays_per_probe: u32,
    grid_spacing: vec3<f32>,
    ray_count: u32,
    grid_counts: vec3<u32>,
    max_distance: f32,
    // Where this ray count's coherent order starts in bench_order; 0xffffffff: Fibonacci order.
    order_offset: u32,
}

@group(1) @binding(0) var<uniform> bench: BenchParams;
// One value a ray (the hit distance), so the traversal cannot be optimized away.
@group(1) @binding(1) var<storage, read_write> bench_hits: array<f32>;
// Traversal work summed over all rays, when the pipeline counts it (RT_COUNT_WORK).
// Then (RT_COUNT_WORK): the traversal steps summed over all rays, and 32 × each warp's most steps
// summed over the warps (lanes 32k … 32k + 31 of a workgroup), whose ratio is the SIMT efficiency;
// the stack entries moved from workgroup to function memory summed over all rays
// (RT_SHARED_STACK_ENTRIES), and the deepest any ray's stack got.
// Last (RT_COUNT_WORK, postponed triangle tests): the steps in which a lane put off its triangle
// tests, and of those the steps in which it did nothing but wait with them (bench_step), summed
// over all rays.
@group(1) @binding(2) var<storage, read_write> bench_work: array<atomic<u32>, 10>;
// Coherent orders (lab::bench::coherent_ray_order) of each ray count, one after another.
@group(1) @binding(3) var<storage, read> bench_order: array<u32>;
// Each ray's hit instance and mesh triangle (RT_NO_HIT, 0 for a miss), when the pipeline sets
// BENCH_HIT_IDS (tests: the same hits, not only the same distances); off, nothing is written.
override BENCH_HIT_IDS: bool = false;
@group(1) @binding(4) var<storage, read_write> bench_hit_ids: array<vec2<u32>>;

// Postponed triangle tests (bench_trace_subgroup.wgsl only; 0: off): a lane tests its triangles
// only when at least this share of its subgroup's active lanes want to test theirs; otherwise they
// wait (rt_walk_postpone_triangles) while the lane walks nodes (Ylitie, Karras and Laine 2017).
override BENCH_POSTPONE_SHARE: f32 = 0.0;

// One step of a walk for the closest hit: rt_walk_step, or with BENCH_POSTPONE_SHARE its triangle
// tests put off while too few of the subgroup's lanes want theirs (bench_postpone_triangles, which
// every lane reaching the step calls, as a ballot needs).
fn bench_step(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>) -> bool {
    if BENCH_POSTPONE_SHARE <= 0.0 {
        return rt_walk_step(w, stack, false);
    }
    // Triangles waiting from the last step, and no node to test before them.
    let waiting = rt_walk_wants_triangles(w);
    rt_walk_node(w, stack);
    if bench_postpone_triangles(rt_walk_wants_triangles(w)) {
        if RT_COUNT_WORK {
            bench_postponed += 1u;
            if waiting && ((*w).group.y & 0xff000000u) == 0u {
                bench_waits += 1u;
            }
        }
        rt_walk_postpone_triangles(w, stack);
        return false;
    }
    return rt_walk_prims(w, stack, false);
}

// Steps of this thread's rays that put off their triangle tests, and that did nothing but wait
// (RT_COUNT_WORK).
var<private> bench_postponed: u32;
var<private> bench_waits: u32;

// Keeps ray `i`'s hit: its distance, and with BENCH_HIT_IDS what it hit.
fn bench_keep_hit(i: u32, w: ptr<function, RtWalk>) {
    bench_hits[i] = (*w).best.t;
    if BENCH_HIT_IDS {
        let hit = rt_walk_hit(w);
        bench_hit_ids[i] = vec2<u32>(hit.instance, hit.primitive);
    }
}

const GOLDEN_ANGLE: f32 = 2.39996322972865;

// Direction i of n spherical Fibonacci points.
fn spherical_fibonacci(i: u32, n: u32) -> vec3<f32> {
    let z = 1.0 - (2.0 * f32(i) + 1.0) / f32(n);
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = f32(i) * GOLDEN_ANGLE;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// Threads a workgroup (lab::bench::TraceKernel sets it; 64 by default).
override BENCH_GROUP: u32 = 64u;

// Lanes in lockstep on the GPUs we tune for (an NVIDIA warp), for the SIMT efficiency.
const BENCH_WARP: u32 = 32u;
// Each thread's traversal steps (RT_COUNT_WORK), for its warp's most.
var<workgroup> bench_steps: array<u32, 1024>;

// The thread-a-ray kernel: thread `id` traces ray `id` (`lane`: its local_invocation_index).
fn bench_main(id: vec3<u32>, lane: u32) {
    rt_stack_lane = lane;
    let i = id.x + id.y * 65535u * BENCH_GROUP;
    if i < bench.ray_count {
        trace_one(i);
    }
    if RT_COUNT_WORK {
        bench_add_warp_steps(lane, rt_steps);
    }
}

// Adds 32 × each warp's most steps to bench_work (RT_COUNT_WORK): `steps` is this thread's, and
// every thread of the workgroup calls it (a barrier).
fn bench_add_warp_steps(lane: u32, steps: u32) {
    bench_steps[lane] = steps;
    workgroupBarrier();
    if lane % BENCH_WARP == 0u {
        var most = 0u;
        for (var k = lane; k < min(lane + BENCH_WARP, BENCH_GROUP); k++) {
            most = max(most, bench_steps[k]);
        }
        atomicAdd(&bench_work[5], most * BENCH_WARP);
    }
}

// Adds this thread's counted traversal work to bench_work (RT_COUNT_WORK).
fn bench_add_work() {
    atomicAdd(&bench_work[0], rt_work.x);
    atomicAdd(&bench_work[1], rt_work.y);
    atomicAdd(&bench_work[2], rt_work.z);
    atomicAdd(&bench_work[3], rt_work.w);
    atomicAdd(&bench_work[4], rt_steps);
    atomicAdd(&bench_work[6], rt_stack_work.x);
    atomicMax(&bench_work[7], rt_stack_work.y);
    atomicAdd(&bench_work[8], bench_postponed);
    atomicAdd(&bench_work[9], bench_waits);
}

fn trace_one(i: u32) {
    var walk = rt_walk_start(bench_ray(i));
    var stack: array<vec2<u32>, RT_STACK_SIZE>;
    loop {
        if bench_step(&walk, &stack) {
            break;
        }
    }
    bench_keep_hit(i, &walk);
    if RT_COUNT_WORK {
        bench_add_work();
    }
}

// ---- Persistent variant (`bench trace --persistent-groups N`): each workgroup walks its share of the rays,
// and a lane whose ray is done takes the next one at once, inside the traversal loop, instead of
// idling until the slowest lane of its warp is done (Aila and Laine 2009, "Understanding the
// efficiency of ray traversal on GPUs": persistent threads with ray replacement). The loop steps
// rt_trace's walk (rt_walk_step, closest hit) and starts the next ray's walk where one ends.

// Workgroups the persistent variant runs (lab::bench::TraceKernel sets it).
override BENCH_PERSISTENT_GROUPS: u32 = 1024u;
// The workgroup's next ray, as an offset into its share.
var<workgroup> bench_next: atomic<u32>;
// Dynamic fetch (bench_trace_subgroup.wgsl only; `bench trace --subgroup-fetch`): the lanes of a
// subgroup whose rays ended in the same step take their next rays with one atomic add
// (bench_fetch), not one each (Aila and Laine 2009).
override BENCH_SUBGROUP_FETCH: bool = false;

// Ray `i` of the dispatch: probe i / rays_per_probe, its direction in the bench's ray order.
fn bench_ray(i: u32) -> Ray {
    let probe = i / bench.rays_per_probe;
    var ray_index = i % bench.rays_per_probe;
    if bench.order_offset != 0xffffffffu {
        ray_index = bench_order[bench.order_offset + ray_index];
    }
    let nx = bench.grid_counts.x;
    let ny = bench.grid_counts.y;
    let cell = vec3<u32>(probe % nx, (probe / nx) % ny, probe / (nx * ny));
    let origin = bench.grid_origin + vec3<f32>(cell) * bench.grid_spacing;
    let dir = (bench.rotation * vec4<f32>(spherical_fibonacci(ray_index, bench.rays_per_probe), 0.0)).xyz;
    return Ray(origin, 0.0, dir, bench.max_distance);
}

// The persistent kernel's workgroup `group_id` (`lane`: local_invocation_index).
fn bench_persistent(group_id: vec3<u32>, lane: u32) {
    rt_stack_lane = lane;
    if lane == 0u {
        atomicStore(&bench_next, 0u);
    }
    workgroupBarrier();
    // This workgroup's rays: a contiguous share, so that a warp's rays stay neighbours.
    let share = (bench.ray_count + BENCH_PERSISTENT_GROUPS - 1u) / BENCH_PERSISTENT_GROUPS;
    let first = group_id.x * share;
    let end = min(first + share, bench.ray_count);
    var slot = first + atomicAdd(&bench_next, 1u);
    if slot >= end {
        return;
    }
    var walk = rt_walk_start(bench_ray(slot));
    var stack: array<vec2<u32>, RT_STACK_SIZE>;
    loop {
        if BENCH_SUBGROUP_FETCH {
            // Every lane here takes part in the fetch (ballots), done or not.
            let done = bench_step(&walk, &stack);
            if done {
                bench_keep_hit(slot, &walk);
            }
            let next = bench_fetch(done);
            if done {
                slot = first + next;
                if slot >= end {
                    break;
                }
                walk = rt_walk_start(bench_ray(slot));
            }
        } else if bench_step(&walk, &stack) {
            // This ray is done: keep its hit and take the next one.
            bench_keep_hit(slot, &walk);
            slot = first + atomicAdd(&bench_next, 1u);
            if slot >= end {
                break;
            }
            walk = rt_walk_start(bench_ray(slot));
        }
    }
}

// ---- Packet variant (`bench trace --packet subgroup|workgroup`): the rays of a packet (a
// subgroup, or the whole workgroup) walk as one: one walk state for all of them, and every node
// that any of their rays hits is visited by all (packet traversal; a probe's rays share their
// origin, so neighbouring rays of the coherent order cross the same nodes near it). Each lane tests
// its own ray against a node's children, with its own closest hit so far; the packet's hit mask is
// the union of the lanes' (bench_packet_or, from the entry point's file), and the children are
// visited in the order of the packet's lead ray's octant, so that the walk stays the same in every
// lane. A lane tests the triangles any lane's ray reached (a miss of its own box only costs the
// test). Lanes without a ray take part with an empty one (tmax < 0: it hits nothing).

// One step's node test of a packet's walk: rt_walk_node with the lanes' hit masks united.
fn bench_packet_node(w: ptr<function, RtWalk>, stack: ptr<function, array<vec2<u32>, RT_STACK_SIZE>>) {
    if RT_COUNT_WORK {
        rt_steps += 1u;
    }
    if rt_walk_has_node(w) {
        let node = rt_walk_next_node(w, stack);
        rt_walk_enter_node(w, node, bench_packet_or(rt_walk_node_hits(w, node)));
    } else {
        // Every lane takes part in every union (a workgroup's needs its barriers in step).
        bench_packet_or(0u);
    }
}

// The packet kernel: thread `id` traces ray `id` with its packet (`lane`: local_invocation_index).
fn bench_packet_main(id: vec3<u32>, lane: u32) {
    rt_stack_lane = lane;
    bench_lane = lane;
    let i = id.x + id.y * 65535u * BENCH_GROUP;
    let has_ray = i < bench.ray_count;
    var ray = bench_ray(min(i, bench.ray_count - 1u));
    if !has_ray {
        ray.tmax = -1.0;
    }
    var walk = rt_walk_start(ray);
    // The packet's child order: its lead ray's octant, in world space and in each instance.
    let lead = bench_packet_lead(walk.world_dir, i - lane);
    walk.world_oct = rt_octant_inv4(lead);
    walk.oct_inv4 = walk.world_oct;
    var stack: array<vec2<u32>, RT_STACK_SIZE>;
    loop {
        let was_in_blas = walk.in_blas;
        bench_packet_node(&walk, &stack);
        if rt_walk_prims(&walk, &stack, false) {
            break;
        }
        if walk.in_blas && !was_in_blas {
            let local_from_world = instances[walk.instance].local_from_world;
            walk.oct_inv4 = rt_octant_inv4(rt_safe_direction((local_from_world * vec4<f32>(lead, 0.0)).xyz));
        }
    }
    if has_ray {
        bench_keep_hit(i, &walk);
        if RT_COUNT_WORK {
            bench_add_work();
        }
    }
    if RT_COUNT_WORK {
        bench_add_warp_steps(lane, select(0u, rt_steps, has_ray));
    }
}

// This thread's local_invocation_index (the packet kernel).
var<private> bench_lane: u32;

// Probe-like rays for the trace benchmark: from every point of a probe grid, `rays_per_probe`
// spherical Fibonacci directions under a random rotation, traced for the closest hit.
#include "ray_tracing.inc.wgsl"

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
@group(1) @binding(2) var<storage, read_write> bench_work: array<atomic<u32>, 8>;
// Coherent orders (lab::bench::coherent_ray_order) of each ray count, one after another.
@group(1) @binding(3) var<storage, read> bench_order: array<u32>;

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

@compute @workgroup_size(BENCH_GROUP)
fn main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    rt_stack_lane = lane;
    let i = id.x + id.y * 65535u * BENCH_GROUP;
    if i < bench.ray_count {
        trace_one(i);
    }
    if RT_COUNT_WORK {
        bench_steps[lane] = rt_steps;
        workgroupBarrier();
        if lane % BENCH_WARP == 0u {
            var most = 0u;
            for (var k = lane; k < min(lane + BENCH_WARP, BENCH_GROUP); k++) {
                most = max(most, bench_steps[k]);
            }
            atomicAdd(&bench_work[5], most * BENCH_WARP);
        }
    }
}

fn trace_one(i: u32) {
    let hit = trace_closest(bench_ray(i));
    bench_hits[i] = hit.t;
    if RT_COUNT_WORK {
        atomicAdd(&bench_work[0], rt_work.x);
        atomicAdd(&bench_work[1], rt_work.y);
        atomicAdd(&bench_work[2], rt_work.z);
        atomicAdd(&bench_work[3], rt_work.w);
        atomicAdd(&bench_work[4], rt_steps);
        atomicAdd(&bench_work[6], rt_stack_work.x);
        atomicMax(&bench_work[7], rt_stack_work.y);
    }
}

// ---- Persistent variant (`bench trace --persistent-groups N`): each workgroup walks its share of the rays,
// and a lane whose ray is done takes the next one at once, inside the traversal loop, instead of
// idling until the slowest lane of its warp is done (Aila and Laine 2009, "Understanding the
// efficiency of ray traversal on GPUs": persistent threads with ray replacement). The loop steps
// rt_trace's walk (rt_walk_step, closest hit) and starts the next ray's walk where one ends.

// Workgroups the persistent variant runs (lab::bench::TraceKernel sets it).
override BENCH_PERSISTENT_GROUPS: u32 = 1024u;
var<workgroup> bench_next: atomic<u32>;

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

@compute @workgroup_size(BENCH_GROUP)
fn persistent(@builtin(workgroup_id) group_id: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
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
        if rt_walk_step(&walk, &stack, false) {
            // This ray is done: keep its hit and take the next one.
            bench_hits[slot] = walk.best.t;
            slot = first + atomicAdd(&bench_next, 1u);
            if slot >= end {
                break;
            }
            walk = rt_walk_start(bench_ray(slot));
        }
    }
}

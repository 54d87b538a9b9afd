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
// efficiency of ray traversal on GPUs": persistent threads with ray replacement). The loop is
// rt_trace's (closest hit), with the ray fetched where rt_trace returns.

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
    var ray = bench_ray(slot);
    var best_t = ray.tmax;
    var world_dir = rt_safe_direction(ray.direction);
    var world_oct = rt_octant_inv4(world_dir);
    var origin = ray.origin;
    var dir = world_dir;
    var tri_dir = ray.direction;
    var oct_inv4 = world_oct;
    var in_blas = false;
    var node_offset = 0u;
    var triangle_offset = 0u;
    var stack: array<vec2<u32>, RT_STACK_SIZE>;
    var sp = 0u;
    var spilled = 0u;
    var tlas_sp = 0u;
    var group = vec2<u32>(0u, 0x80000000u);
    var prims = vec2<u32>(0u, 0u);
    loop {
        if (group.y & 0xff000000u) != 0u && prims.y == 0u {
            let hits = group.y;
            let child_bit = firstLeadingBit(hits);
            group.y &= ~(1u << child_bit);
            if (group.y & 0xff000000u) != 0u && sp < RT_STACK_SIZE {
                rt_stack_push(&stack, &spilled, sp, group);
                sp += 1u;
            }
            let slot_bits = (child_bit - 24u) ^ (oct_inv4 & 0xffu);
            let node = group.x + countOneBits(hits & ~(0xffffffffu << slot_bits));
            var b = node * 5u;
            if in_blas {
                b = (node_offset + node) * 5u;
            }
            var n0: vec4<u32>;
            var n1: vec4<u32>;
            var n2: vec4<u32>;
            var n3: vec4<u32>;
            var n4: vec4<u32>;
            if in_blas {
                n0 = blas_nodes[b];
                n1 = blas_nodes[b + 1u];
                n2 = blas_nodes[b + 2u];
                n3 = blas_nodes[b + 3u];
                n4 = blas_nodes[b + 4u];
            } else {
                n0 = tlas_nodes[b];
                n1 = tlas_nodes[b + 1u];
                n2 = tlas_nodes[b + 2u];
                n3 = tlas_nodes[b + 3u];
                n4 = tlas_nodes[b + 4u];
            }
            let hit_mask = rt_cwbvh_node_hits(n0, n1, n2, n3, n4, origin, dir, oct_inv4, ray.tmin, best_t);
            group = vec2<u32>(n1.x, (hit_mask & 0xff000000u) | (n0.w >> 24u));
            prims = vec2<u32>(n1.y, select(rt_xor_permute8(hit_mask & 0xffu, oct_inv4 & 7u), hit_mask & 0x00ffffffu, in_blas));
        }
        if in_blas {
            while prims.y != 0u {
                let local = firstLeadingBit(prims.y);
                prims.y &= ~(1u << local);
                let h = rt_intersect_triangle(triangle_offset + prims.x + local, origin, tri_dir, ray.tmin, best_t);
                if h.hit {
                    best_t = h.t;
                }
            }
        } else if prims.y != 0u {
            let bit = firstLeadingBit(prims.y);
            prims.y &= ~(1u << bit);
            let entry = rt_tlas_entry(prims.x + (bit ^ (oct_inv4 & 7u)));
            if (group.y & 0xff000000u) != 0u && sp < RT_STACK_SIZE {
                rt_stack_push(&stack, &spilled, sp, group);
                sp += 1u;
            }
            if prims.y != 0u && sp < RT_STACK_SIZE {
                rt_stack_push(&stack, &spilled, sp, prims);
                sp += 1u;
            }
            tlas_sp = sp;
            in_blas = true;
            node_offset = entry.node_offset;
            triangle_offset = entry.triangle_offset;
            let local_from_world = instances[entry.instance].local_from_world;
            origin = (local_from_world * vec4<f32>(ray.origin, 1.0)).xyz;
            tri_dir = (local_from_world * vec4<f32>(ray.direction, 0.0)).xyz;
            dir = rt_safe_direction(tri_dir);
            oct_inv4 = rt_octant_inv4(dir);
            group = vec2<u32>(entry.start_node, 0x80000000u);
            prims = vec2<u32>(0u, 0u);
            continue;
        }
        if (group.y & 0xff000000u) == 0u && prims.y == 0u {
            if in_blas && sp == tlas_sp {
                in_blas = false;
                origin = ray.origin;
                dir = world_dir;
                oct_inv4 = world_oct;
            }
            if sp == 0u {
                // This ray is done: keep its hit and take the next one.
                bench_hits[slot] = best_t;
                slot = first + atomicAdd(&bench_next, 1u);
                if slot >= end {
                    break;
                }
                ray = bench_ray(slot);
                best_t = ray.tmax;
                world_dir = rt_safe_direction(ray.direction);
                world_oct = rt_octant_inv4(world_dir);
                origin = ray.origin;
                dir = world_dir;
                tri_dir = ray.direction;
                oct_inv4 = world_oct;
                in_blas = false;
                tlas_sp = 0u;
                group = vec2<u32>(0u, 0x80000000u);
                prims = vec2<u32>(0u, 0u);
                continue;
            }
            sp -= 1u;
            let e = rt_stack_pop(&stack, &spilled, sp);
            if (e.y & 0xff000000u) != 0u {
                group = e;
            } else {
                group = vec2<u32>(0u, 0u);
                prims = e;
            }
        }
    }
}

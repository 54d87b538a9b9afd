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
@group(1) @binding(2) var<storage, read_write> bench_work: array<atomic<u32>, 4>;
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

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if i >= bench.ray_count {
        return;
    }
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
    let hit = trace_closest(Ray(origin, 0.0, dir, bench.max_distance));
    bench_hits[i] = hit.t;
    if RT_COUNT_WORK {
        atomicAdd(&bench_work[0], rt_work.x);
        atomicAdd(&bench_work[1], rt_work.y);
        atomicAdd(&bench_work[2], rt_work.z);
        atomicAdd(&bench_work[3], rt_work.w);
    }
}

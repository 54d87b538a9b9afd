// Traces a buffer of rays against the scene (tests against the CPU reference, the trace benchmark).
#include "rt_alpha.inc.wgsl"

// Mirrors RayHit with the flags packed: front_face in bit 0.
struct TraceResult {
    t: f32,
    instance: u32,
    primitive: u32,
    flags: u32,
    barycentrics: vec2<f32>,
    any_hit: u32,
    _pad: u32,
    // Material at the hit (zero for misses).
    albedo: vec4<f32>,
    emissive: vec4<f32>,
}

struct TraceParams {
    ray_count: u32,
    // 1: closest hit and any hit; 0: closest hit only.
    with_any_hit: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(1) @binding(0) var<uniform> trace_params: TraceParams;
@group(1) @binding(1) var<storage, read> trace_rays: array<Ray>;
@group(1) @binding(2) var<storage, read_write> trace_results: array<TraceResult>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x + id.y * 65535u * 64u;
    if i >= trace_params.ray_count {
        return;
    }
    let ray = trace_rays[i];
    let h = trace_closest(ray);
    var any = 0u;
    if trace_params.with_any_hit != 0u && trace_any(ray) {
        any = 1u;
    }
    var albedo = vec3<f32>(0.0);
    var emissive = vec3<f32>(0.0);
    if h.instance != RT_NO_HIT {
        let surface = hit_surface(ray, h);
        albedo = surface.albedo;
        emissive = surface.emissive;
    }
    trace_results[i] = TraceResult(h.t, h.instance, h.primitive, select(0u, 1u, h.front_face), h.barycentrics, any, 0u, vec4<f32>(albedo, 0.0), vec4<f32>(emissive, 0.0));
}

// DDGI pass `ddgi_trace`: generation and trace of the probe rays packed by `ddgi_budget`, in one of
// two ways. `trace_rays` (the default): one thread per ray, dispatched indirectly with the ray
// count (two-dimensional beyond 65,535 workgroups), which also shades its ray. With
// DdgiVolume::persistent_trace, `trace_rays_persistent`: persistent threads that find each ray's
// closest hit only (into ddgi_hits), then the pass `ddgi_shade` (ddgi_shade.wgsl) shades them.
#include "ddgi_shading.inc.wgsl"

// The probe whose packed rays hold ray i: the last probe whose offset is at most i (probes with no
// rays share the offset of the next one, so the search lands on the probe that has rays).
fn ddgi_probe_of_ray(i: u32) -> u32 {
    var lo = 0u;
    var hi = ddgi_volume.probe_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if ddgi_probes[mid].ray_offset <= i {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Ray i of the frame: its probe, and its direction — one of the spherical Fibonacci directions for
// the probe's own ray count, under this frame's random rotation.
fn ddgi_generate_ray(i: u32) -> DdgiRay {
    let probe = ddgi_probe_of_ray(i);
    let data = ddgi_probes[probe];
    let direction = ddgi_volume.ray_rotation * ddgi_spherical_fibonacci(i - data.ray_offset, max(data.ray_count, 1u));
    return DdgiRay(safe_normalize(direction, vec3<f32>(0.0, 0.0, 1.0)), probe);
}

// Trace and shading in one thread: generates ray i (kept in ddgi_rays for the probe update), traces
// its closest hit and shades it (ddgi_shade_ray). One pass, not two: a separate shading pass costs
// its own launch and a round trip of every hit through memory, which at the published grids took
// longer than the shading itself when the trace was a thread a ray too.
@compute @workgroup_size(DDGI_RAY_GROUP)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let ray_info = ddgi_generate_ray(i);
    ddgi_rays[i] = ray_info;
    ddgi_shade_ray(i, ray_info, trace_closest(ddgi_ray(ray_info)));
}

// The next ray of a persistent workgroup's share.
var<workgroup> ddgi_next_ray: atomic<u32>;

// The persistent trace (DdgiVolume::persistent_trace; Aila and Laine 2009, "Understanding the
// efficiency of ray traversal on GPUs": persistent threads with ray replacement). The budget pass
// dispatches a workgroup per DDGI_PERSISTENT_TRACE_GROUP rays, at most DDGI_PERSISTENT_TRACE_GROUPS
// (ddgi_counters.persistent_dispatch); each walks a contiguous share of the frame's rays (a probe's
// rays are neighbours), and a lane whose ray is done takes the workgroup's next one at once, inside
// the traversal loop (rt_walk_step, the loop rt_trace runs), instead of idling until the slowest
// lane of its warp is done. Each ray's ray (ddgi_rays) and closest hit (ddgi_hits) go to memory;
// `shade_rays` shades them.
@compute @workgroup_size(DDGI_PERSISTENT_TRACE_GROUP)
fn trace_rays_persistent(
    @builtin(workgroup_id) group_id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_index) lane: u32,
) {
    if lane == 0u {
        atomicStore(&ddgi_next_ray, 0u);
    }
    workgroupBarrier();
    let total = ddgi_ray_total();
    let share = (total + groups.x - 1u) / groups.x;
    let first = group_id.x * share;
    let end = min(first + share, total);
    var i = first + atomicAdd(&ddgi_next_ray, 1u);
    if i >= end {
        return;
    }
    var ray_info = ddgi_generate_ray(i);
    var walk = rt_walk_start(ddgi_ray(ray_info));
    var stack: array<vec2<u32>, RT_STACK_SIZE>;
    loop {
        if rt_walk_step(&walk, &stack, false) {
            // This ray is done: keep it and its hit, and take the next one.
            let hit = rt_walk_hit(&walk);
            ddgi_rays[i] = ray_info;
            ddgi_hits[i] = DdgiHit(hit.t, hit.instance, hit.primitive, u32(hit.front_face), hit.barycentrics);
            i = first + atomicAdd(&ddgi_next_ray, 1u);
            if i >= end {
                break;
            }
            ray_info = ddgi_generate_ray(i);
            walk = rt_walk_start(ddgi_ray(ray_info));
        }
    }
}

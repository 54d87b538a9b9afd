// DDGI pass `ddgi_shade`, after the persistent trace (DdgiVolume::persistent_trace): shades each
// packed ray at the closest hit that `trace_rays_persistent` found (ddgi_rays, ddgi_hits), one
// thread per ray, dispatched indirectly with the ray count as `trace_rays` is.
#include "ddgi_shading.inc.wgsl"

@compute @workgroup_size(DDGI_RAY_GROUP)
fn shade_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let h = ddgi_hits[i];
    ddgi_shade_ray(i, ddgi_rays[i], RayHit(h.t, h.instance, h.primitive, h.barycentrics, h.front_face != 0u));
}

// DDGI pass `ddgi_gather`: the camera's pixels take irradiance from the probes with the same
// sampling function as the probe rays' shading, volume by volume, accumulated in ddgi_indirect.
#include "ddgi_sampling.inc.wgsl"
#include "ddgi_camera.inc.wgsl"

// A fixed volume: 1 inside its bounds (half a cell beyond the outer probes), fading to 0 one cell
// outside. A cascade (cascade_blend > 0): 1 more than cascade_blend cells inside its outer probes,
// falling to 0 at them, so that the next cascade out takes over while this one still has probes
// on both sides of the point — except the coarsest, which nothing takes over from: it is weighted
// as a fixed volume (a band inside it would darken every point there).
fn ddgi_volume_weight(p: vec3<f32>) -> f32 {
    let v = ddgi_volume;
    let cell = max(v.spacing, vec3<f32>(1e-30));
    if v.cascade_blend > 0.0 && v.cascade_outermost == 0u {
        let lo = v.origin;
        let hi = v.origin + v.spacing * (vec3<f32>(v.counts) - 1.0);
        let inside = min(p - lo, hi - p) / cell;
        let w = clamp(inside / v.cascade_blend, vec3<f32>(0.0), vec3<f32>(1.0));
        return w.x * w.y * w.z;
    }
    let lo = v.origin - v.spacing * 0.5;
    let hi = v.origin + v.spacing * (vec3<f32>(v.counts) - 0.5);
    let outside = max(max(lo - p, p - hi), vec3<f32>(0.0)) / cell;
    let w = clamp(vec3<f32>(1.0) - outside, vec3<f32>(0.0), vec3<f32>(1.0));
    return w.x * w.y * w.z;
}

// Adds this volume's irradiance `e` with weight `w` to a pixel's accumulation (Σ w·E, Σ w). Fixed
// volumes add up (the composite divides by the total when it exceeds 1); the host gathers them
// first, then the cascades from the finest out, each of which fills only the share the volumes
// before it left: its weight is w · (1 − Σ w so far), so the weights of a point in a blend band sum
// to 1 and the finest cascade that covers a point decides it.
fn ddgi_accumulate(acc_in: vec4<f32>, e: vec3<f32>, w: f32) -> vec4<f32> {
    if ddgi_volume.cascade_blend <= 0.0 {
        return acc_in + vec4<f32>(w * e, w);
    }
    var acc = acc_in;
    if acc.w > 1.0 {
        acc = acc / acc.w;
    }
    let share = w * max(1.0 - acc.w, 0.0);
    return acc + vec4<f32>(share * e, share);
}

// Marks (DDGI_PROBE_SEEN) the probes of the cage around surface point p, normal n, that face it and
// are switched off for an empty region or counting towards it: the view depends on them. Only
// those few probes are written, each once (every pixel writes the same value).
fn ddgi_mark_seen_probes(p: vec3<f32>, n: vec3<f32>) {
    let base = ddgi_cage_base(ddgi_grid_coords(p));
    for (var i = 0u; i < 8u; i++) {
        let probe = ddgi_cage_probe(base, ddgi_cage_step(i));
        let data = ddgi_probes[probe];
        let off_empty = (data.state & (DDGI_PROBE_INACTIVE | DDGI_PROBE_EMPTY)) == (DDGI_PROBE_INACTIVE | DDGI_PROBE_EMPTY);
        let at_risk = (data.state & DDGI_PROBE_INACTIVE) == 0u && data.empty_rays > 0u;
        if (off_empty || at_risk) && (data.state & DDGI_PROBE_SEEN) == 0u && dot(ddgi_probe_position(probe) - p, n) > 0.0 {
            ddgi_probes[probe].state = data.state | DDGI_PROBE_SEEN;
        }
    }
}

@compute @workgroup_size(8, 8)
fn gather_irradiance(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let index = id.y * view.size.x + id.x;
    let glossy_index = index + view.size.x * view.size.y;
    let first = ddgi_gather_params.first_volume != 0u;
    var acc = vec4<f32>(0.0);
    if !first {
        acc = ddgi_indirect[index];
        // A point the volumes gathered before this cascade already cover takes nothing from it:
        // the pixel is left as it is (no depth read, no write), so that a cascade costs the
        // camera little more than one read per pixel beyond the ones it lights — most pixels
        // belong to one cascade, and 8 cascades' gathers would otherwise each pay for the frame.
        if ddgi_volume.cascade_blend > 0.0 && acc.w >= 1.0 {
            return;
        }
    }
    let depth = textureLoad(gbuffer_depth, id.xy, 0);
    var lit = false;
    if depth > 0.0 {
        let p = view_world_position(id.xy, depth);
        let w = ddgi_volume_weight(p);
        let surface = ddgi_pixel_surface(id.xy);
        let glossy = brdf_has_specular(surface);
        if w > 0.0 {
            let n = safe_normalize(textureLoad(gbuffer_normal, id.xy, 0).xyz, vec3<f32>(0.0, 1.0, 0.0));
            let to_viewer = safe_normalize(view.camera_position - p, n);
            // A glossy pixel also takes the irradiance along its reflection, with the same weights.
            let r = select(n, ddgi_specular_direction(n, to_viewer, surface), glossy);
            let e = ddgi_sample_irradiance_pair(p, n, to_viewer, r, glossy);
            if glossy {
                var reflected = vec4<f32>(0.0);
                if !first {
                    reflected = ddgi_indirect[glossy_index];
                }
                ddgi_indirect[glossy_index] = ddgi_accumulate(reflected, e.reflected, w);
            }
            acc = ddgi_accumulate(acc, e.normal, w);
            ddgi_mark_seen_probes(p, n);
            lit = true;
        } else if glossy && first {
            ddgi_indirect[glossy_index] = vec4<f32>(0.0);
        }
    }
    // The first volume starts every pixel's accumulation; the others write only what they added.
    if first || lit {
        ddgi_indirect[index] = acc;
    }
}

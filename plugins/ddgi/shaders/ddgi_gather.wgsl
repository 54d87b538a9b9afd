// DDGI pass `ddgi_gather`: the camera's pixels take irradiance from the probes with the same
// sampling function as the probe rays' shading, volume by volume, accumulated in ddgi_indirect.
#include "ddgi_sampling.inc.wgsl"
#include "ddgi_camera.inc.wgsl"

// 1 inside the volume's bounds (half a cell beyond the outer probes), fading to 0 one cell outside.
fn ddgi_volume_weight(p: vec3<f32>) -> f32 {
    let v = ddgi_volume;
    let lo = v.origin - v.spacing * 0.5;
    let hi = v.origin + v.spacing * (vec3<f32>(v.counts) - 0.5);
    let outside = max(max(lo - p, p - hi), vec3<f32>(0.0)) / max(v.spacing, vec3<f32>(1e-30));
    let w = clamp(vec3<f32>(1.0) - outside, vec3<f32>(0.0), vec3<f32>(1.0));
    return w.x * w.y * w.z;
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
    var acc = vec4<f32>(0.0);
    if ddgi_gather_params.first_volume == 0u {
        acc = ddgi_indirect[index];
    }
    let depth = textureLoad(gbuffer_depth, id.xy, 0);
    if depth > 0.0 {
        let p = view_world_position(id.xy, depth);
        let w = ddgi_volume_weight(p);
        if w > 0.0 {
            let n = safe_normalize(textureLoad(gbuffer_normal, id.xy, 0).xyz, vec3<f32>(0.0, 1.0, 0.0));
            let to_viewer = safe_normalize(view.camera_position - p, n);
            acc += vec4<f32>(w * ddgi_sample_irradiance(p, n, to_viewer), w);
            ddgi_mark_seen_probes(p, n);
        }
    }
    ddgi_indirect[index] = acc;
}

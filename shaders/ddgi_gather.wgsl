// DDGI final gather: the camera's pixels take irradiance from the probes with the same sampling
// function as the probe rays' shading, volume by volume, then the composite adds it to the direct light.
#include "ddgi.inc.wgsl"

struct DdgiGatherParams {
    // 1 for the first volume of the frame: the accumulation starts from zero.
    first_volume: u32,
    // composite_debug: 1 direct light only, 2 albedo, 3 normals.
    debug_view: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(2) @binding(0) var<uniform> ddgi_gather_params: DdgiGatherParams;
@group(2) @binding(1) var gbuffer_depth: texture_depth_2d;
@group(2) @binding(2) var gbuffer_normal: texture_2d<f32>;
@group(2) @binding(3) var gbuffer_albedo: texture_2d<f32>;
@group(2) @binding(4) var direct_in: texture_2d<f32>;
// Per pixel: (Σ volume weight · irradiance, Σ volume weight).
@group(2) @binding(5) var<storage, read_write> ddgi_indirect: array<vec4<f32>>;
@group(2) @binding(6) var radiance_out: texture_storage_2d<rgba32float, write>;

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

// albedo / π × the irradiance of the volumes at a pixel (0 where there is no surface).
fn ddgi_indirect_radiance(id: vec2<u32>) -> vec3<f32> {
    let depth = textureLoad(gbuffer_depth, id, 0);
    if depth <= 0.0 {
        return vec3<f32>(0.0);
    }
    let acc = ddgi_indirect[id.y * view.size.x + id.x];
    // Outside every volume the indirect light fades out (the weights sum to less than 1).
    let irradiance = acc.rgb / max(acc.w, 1.0);
    let albedo = textureLoad(gbuffer_albedo, id, 0).rgb;
    return albedo * INV_PI * irradiance;
}

// Direct light + indirect light.
@compute @workgroup_size(8, 8)
fn composite(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let radiance = textureLoad(direct_in, id.xy, 0).rgb + ddgi_indirect_radiance(id.xy);
    textureStore(radiance_out, id.xy, vec4<f32>(sanitize_radiance(radiance), 1.0));
}

// Indirect light alone (`--mode indirect`).
@compute @workgroup_size(8, 8)
fn composite_indirect(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    textureStore(radiance_out, id.xy, vec4<f32>(sanitize_radiance(ddgi_indirect_radiance(id.xy)), 1.0));
}

// Debug views (`DdgiOutput::Direct`, `Albedo`, `Normals`): direct light alone, or the G-buffer's
// albedo or normals (0.5 + 0.5 n), the last two display-referred: divided by the exposure, they
// leave the tonemapper near their own value.
@compute @workgroup_size(8, 8)
fn composite_debug(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let display = 1.0 / max(view.exposure, 1e-6);
    var radiance = textureLoad(direct_in, id.xy, 0).rgb;
    let surface = textureLoad(gbuffer_depth, id.xy, 0) > 0.0;
    if ddgi_gather_params.debug_view == 2u {
        radiance = select(vec3<f32>(0.0), textureLoad(gbuffer_albedo, id.xy, 0).rgb * display, surface);
    } else if ddgi_gather_params.debug_view == 3u {
        let n = safe_normalize(textureLoad(gbuffer_normal, id.xy, 0).xyz, vec3<f32>(0.0, 1.0, 0.0));
        radiance = select(vec3<f32>(0.0), (n * 0.5 + 0.5) * display, surface);
    }
    textureStore(radiance_out, id.xy, vec4<f32>(sanitize_radiance(radiance), 1.0));
}

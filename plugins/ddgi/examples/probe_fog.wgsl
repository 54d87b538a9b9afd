// The custom_pass example's own pass, `probe_fog`: height-less fog lit by the DDGI probes. Each
// pixel marches from the camera to its surface (or a fixed distance for the sky); at each step
// the fog scatters the light the probes hold there (isotropic: the mean of the irradiance over
// six axis directions, / π) and absorbs what lies behind it.
#include "ddgi_sampling.inc.wgsl"

struct FogParams {
    // Extinction per world unit (scattering albedo 1).
    density: f32,
    // March steps per pixel.
    steps: u32,
    // How far a pixel that sees no surface marches.
    sky_distance: f32,
    _pad: u32,
}

@group(2) @binding(0) var<uniform> fog: FogParams;
@group(2) @binding(1) var fog_depth: texture_depth_2d;
@group(2) @binding(2) var fog_lit: texture_2d<f32>;
@group(2) @binding(3) var fog_out: texture_storage_2d<rgba32float, write>;

// The fog's in-scattered radiance at x: the probes' irradiance, averaged over the six axes, / π.
fn fog_in_scattering(x: vec3<f32>, to_viewer: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var axis = 0u; axis < 6u; axis++) {
        var n = vec3<f32>(0.0);
        n[axis % 3u] = select(1.0, -1.0, axis >= 3u);
        sum += ddgi_sample_irradiance(x, n, to_viewer);
    }
    return sum / 6.0 * INV_PI;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let depth = textureLoad(fog_depth, id.xy, 0);
    let far = view_world_position(id.xy, max(depth, 1e-7));
    var length_to = fog.sky_distance;
    if depth > 0.0 {
        length_to = distance(far, view.camera_position);
    }
    let dir = safe_normalize(far - view.camera_position, vec3<f32>(0.0, 0.0, -1.0));
    let steps = max(fog.steps, 1u);
    let dt = length_to / f32(steps);
    var transmittance = 1.0;
    var scattered = vec3<f32>(0.0);
    for (var i = 0u; i < steps; i++) {
        let x = view.camera_position + dir * ((f32(i) + 0.5) * dt);
        let step_transmittance = exp(-fog.density * dt);
        // Light scattered towards the camera over this step, dimmed by the fog before it.
        scattered += transmittance * (1.0 - step_transmittance) * fog_in_scattering(x, -dir);
        transmittance *= step_transmittance;
    }
    let behind = textureLoad(fog_lit, id.xy, 0).rgb;
    textureStore(fog_out, id.xy, vec4<f32>(sanitize_radiance(behind * transmittance + scattered), 1.0));
}

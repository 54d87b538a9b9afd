// DDGI pass `ddgi_composite`: the gathered indirect light (albedo / π × irradiance) added to the
// direct light, or one of the debug views.
#include "ddgi_camera.inc.wgsl"

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

// Direct lighting of the G-buffer: emission + Lambertian reflection of every punctual light, each
// tested for occlusion with a shadow ray (hard shadows). Pixels with no surface take the sky radiance.
#include "ray_tracing.inc.wgsl"

@group(1) @binding(0) var gbuffer_depth: texture_depth_2d;
@group(1) @binding(1) var gbuffer_normal: texture_2d<f32>;
@group(1) @binding(2) var gbuffer_albedo: texture_2d<f32>;
@group(1) @binding(3) var gbuffer_emissive: texture_2d<f32>;
@group(1) @binding(4) var radiance_out: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let depth = textureLoad(gbuffer_depth, id.xy, 0);
    if depth <= 0.0 {
        textureStore(radiance_out, id.xy, vec4<f32>(view.sky_radiance, 1.0));
        return;
    }
    let p = view_world_position(id.xy, depth);
    let n = textureLoad(gbuffer_normal, id.xy, 0).xyz;
    let albedo = textureLoad(gbuffer_albedo, id.xy, 0).rgb;
    var radiance = textureLoad(gbuffer_emissive, id.xy, 0).rgb;
    // A position rebuilt from depth carries an error that grows with distance (and with the
    // driver's math): push the shadow-ray origin off the surface by a small fraction of the view
    // distance before the float-exact offset, or grazing-lit faces shadow themselves in bands.
    let view_distance = length(p - view.camera_position);
    let origin = offset_ray_origin(p + n * (1e-4 * view_distance), n);
    for (var i = 0u; i < view.light_count; i++) {
        let s = sample_light(lights[i], p, n);
        if all(s.irradiance <= vec3<f32>(0.0)) {
            continue;
        }
        // Shadow ray towards the light, stopping just short of it.
        let shadow = Ray(origin, 0.0, s.to_light, s.distance * (1.0 - 1e-4));
        if !trace_any(shadow) {
            radiance += albedo * INV_PI * s.irradiance;
        }
    }
    textureStore(radiance_out, id.xy, vec4<f32>(sanitize_radiance(radiance), 1.0));
}

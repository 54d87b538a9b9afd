// Direct lighting of the G-buffer: emission + the BRDF's reflection (engine::brdf: Lambertian, and
// GGX where the material has a specular lobe) of every punctual light, each tested for occlusion
// with a shadow ray (hard shadows). Pixels with no surface show the sky (and
// the sun's disk) along their view ray.
#include "rt_alpha.inc.wgsl"

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
        textureStore(radiance_out, id.xy, vec4<f32>(sky_background(view_pixel_direction(id.xy)), 1.0));
        return;
    }
    let p = view_world_position(id.xy, depth);
    let normal = textureLoad(gbuffer_normal, id.xy, 0);
    let n = normal.xyz;
    let albedo = textureLoad(gbuffer_albedo, id.xy, 0);
    let emissive = textureLoad(gbuffer_emissive, id.xy, 0);
    let surface = BrdfSurface(albedo.rgb, albedo.a, normal.w, emissive.a);
    let to_viewer = safe_normalize(view.camera_position - p, n);
    var radiance = emissive.rgb;
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
            radiance += brdf_eval(surface, n, to_viewer, s.to_light) * s.irradiance;
        }
    }
    textureStore(radiance_out, id.xy, vec4<f32>(sanitize_radiance(radiance), 1.0));
}

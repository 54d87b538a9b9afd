// DDGI pass `ddgi_composite`: the gathered indirect light (albedo / π × irradiance) added to the
// direct light, or one of the debug views. Where no volume covers a pixel's surface (or covers it
// only in part), the sky's irradiance times a short-range visibility fills the rest; contact
// occlusion (ddgi::DdgiContactOcclusion, traced here or by `ddgi_contact_occlusion` at reduced
// resolution) darkens the probes' light at small scales.
#include "ddgi_visibility.inc.wgsl"

// The sky's irradiance at surface point p (normal n) through its visibility: π × the mean sky
// radiance along `sky_rays` rays of reach sky_distance, those that hit counting as black.
fn ddgi_sky_irradiance(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let count = ddgi_gather_params.sky_rays;
    let uniform = view.sky.uniform.rgb;
    if count == 0u || (view.sky.zenith.w == 0.0 && !(max(uniform.x, max(uniform.y, uniform.z)) > 0.0)) {
        return vec3<f32>(0.0);
    }
    return PI * ddgi_open_rays(pixel, p, n, count, ddgi_gather_params.sky_distance, true).yzw;
}

// The indirect light a pixel reflects (0 where there is no surface): albedo / π × the volumes'
// irradiance; a glossy pixel's specular lobe reflects, by its albedo, the irradiance along its
// reflection instead, and its diffuse lobe what the specular one leaves.
fn ddgi_indirect_radiance(id: vec2<u32>) -> vec3<f32> {
    let depth = textureLoad(gbuffer_depth, id, 0);
    if depth <= 0.0 {
        return vec3<f32>(0.0);
    }
    let index = id.y * view.size.x + id.x;
    let acc = ddgi_indirect[index];
    let surface = ddgi_pixel_surface(id);
    let glossy = brdf_has_specular(surface);
    // Outside every volume the probes' light fades out (the weights sum to less than 1), and the
    // sky light fills the share they leave. Contact occlusion darkens the probes' share only: the
    // sky light has its own visibility.
    var irradiance = acc.rgb / max(acc.w, 1.0);
    var reflected = vec3<f32>(0.0);
    if glossy {
        let r = ddgi_indirect[index + view.size.x * view.size.y];
        reflected = r.rgb / max(r.w, 1.0);
    }
    let uncovered = 1.0 - clamp(acc.w, 0.0, 1.0);
    let occluded = acc.w > 0.0 && ddgi_contact_occlusion_on();
    // The surface point is needed only for rays and for glossy pixels: most pixels of a covered
    // view trace none.
    if occluded || uncovered > 0.0 || glossy {
        let p = view_world_position(id, depth);
        let n = ddgi_pixel_normal(id);
        if occluded {
            let open = ddgi_contact_occlusion(id, p, n);
            irradiance *= open;
            reflected *= open;
        }
        if uncovered > 0.0 {
            let sky = uncovered * ddgi_sky_irradiance(id, p, n);
            irradiance += sky;
            reflected += sky;
        }
        if glossy {
            let to_viewer = safe_normalize(view.camera_position - p, n);
            let specular = brdf_specular_albedo(surface, max(dot(n, to_viewer), 1e-4));
            return (brdf_diffuse_color(surface) * (vec3<f32>(1.0) - specular) * irradiance + specular * reflected) * INV_PI;
        }
    }
    return surface.base_color * INV_PI * irradiance;
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

// Debug views (`DdgiOutput::Direct`, `Albedo`, `Normals`, `Occlusion`): direct light alone, or the
// G-buffer's albedo, normals (0.5 + 0.5 n) or contact occlusion, the last three display-referred:
// divided by the exposure, they leave the tonemapper near their own value.
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
    } else if ddgi_gather_params.debug_view == 4u {
        radiance = vec3<f32>(0.0);
        if surface {
            let depth = textureLoad(gbuffer_depth, id.xy, 0);
            let n = safe_normalize(textureLoad(gbuffer_normal, id.xy, 0).xyz, vec3<f32>(0.0, 1.0, 0.0));
            radiance = vec3<f32>(ddgi_contact_occlusion(id.xy, view_world_position(id.xy, depth), n) * display);
        }
    }
    textureStore(radiance_out, id.xy, vec4<f32>(sanitize_radiance(radiance), 1.0));
}

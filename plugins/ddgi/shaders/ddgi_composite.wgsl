// DDGI pass `ddgi_composite`: the gathered indirect light (albedo / π × irradiance) added to the
// direct light, or one of the debug views. Where no volume covers a pixel's surface (or covers it
// only in part), the sky's irradiance times a short-range visibility fills the rest; contact
// occlusion (ddgi::DdgiContactOcclusion) darkens the probes' light at small scales.
#include "ddgi_camera.inc.wgsl"
#include "ray_tracing.inc.wgsl"

// The cosine-weighted share of `count` stratified rays from surface point p (normal n) that travel
// `reach` without a hit: spherical Fibonacci over the hemisphere, turned by a per-pixel angle.
fn ddgi_open_fraction(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>, count: u32, reach: f32) -> f32 {
    let view_distance = length(p - view.camera_position);
    let origin = offset_ray_origin(p + n * (1e-4 * view_distance), n);
    let tangent = safe_normalize(cross(select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9), n), vec3<f32>(1.0, 0.0, 0.0));
    let bitangent = cross(n, tangent);
    let turn = f32(hash_lowbias32(pixel.x * 7919u + pixel.y * 104729u)) / 4294967296.0;
    var open = 0u;
    for (var k = 0u; k < count; k++) {
        // Cosine-distributed: uniform over the unit disc, lifted onto the hemisphere.
        let u = (f32(k) + 0.5) / f32(count);
        let phi = 2.0 * PI * fract(f32(k) * 0.618033988749895 + turn);
        let r = sqrt(u);
        let d = tangent * (r * cos(phi)) + bitangent * (r * sin(phi)) + n * sqrt(max(1.0 - u, 0.0));
        if !trace_any(Ray(origin, 0.0, d, reach)) {
            open += 1u;
        }
    }
    return f32(open) / f32(max(count, 1u));
}

// The sky's irradiance at surface point p (normal n) times its visibility (the open share of
// `sky_rays` rays of reach sky_distance).
fn ddgi_sky_irradiance(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let count = ddgi_gather_params.sky_rays;
    let sky = sanitize_radiance(view.sky_radiance);
    if count == 0u || !(max(sky.x, max(sky.y, sky.z)) > 0.0) {
        return vec3<f32>(0.0);
    }
    return PI * sky * ddgi_open_fraction(pixel, p, n, count, ddgi_gather_params.sky_distance);
}

// Contact occlusion at surface point p (normal n): the open share of ao_rays rays of ao_radius, 1
// when it is off.
fn ddgi_contact_occlusion(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>) -> f32 {
    let count = ddgi_gather_params.ao_rays;
    if count == 0u || !(ddgi_gather_params.ao_radius > 0.0) {
        return 1.0;
    }
    return ddgi_open_fraction(pixel, p, n, count, ddgi_gather_params.ao_radius);
}

// albedo / π × the irradiance of the volumes at a pixel (0 where there is no surface).
fn ddgi_indirect_radiance(id: vec2<u32>) -> vec3<f32> {
    let depth = textureLoad(gbuffer_depth, id, 0);
    if depth <= 0.0 {
        return vec3<f32>(0.0);
    }
    let acc = ddgi_indirect[id.y * view.size.x + id.x];
    // Outside every volume the probes' light fades out (the weights sum to less than 1), and the
    // sky light fills the share they leave. Contact occlusion darkens the probes' share only: the
    // sky light has its own visibility.
    var irradiance = acc.rgb / max(acc.w, 1.0);
    let uncovered = 1.0 - clamp(acc.w, 0.0, 1.0);
    let occluded = acc.w > 0.0 && ddgi_gather_params.ao_rays > 0u;
    // The surface point is needed only for rays: most pixels of a covered view trace none.
    if occluded || uncovered > 0.0 {
        let p = view_world_position(id, depth);
        let n = safe_normalize(textureLoad(gbuffer_normal, id, 0).xyz, vec3<f32>(0.0, 1.0, 0.0));
        if occluded {
            irradiance *= ddgi_contact_occlusion(id, p, n);
        }
        if uncovered > 0.0 {
            irradiance += uncovered * ddgi_sky_irradiance(id, p, n);
        }
    }
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

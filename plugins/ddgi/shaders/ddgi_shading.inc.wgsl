// The shading of the probe rays, shared by the trace's two ways: `trace_rays` (ddgi_trace.wgsl)
// traces and shades each ray in one thread; with DdgiVolume::persistent_trace, the persistent
// kernel (`trace_rays_persistent`) only finds the closest hits and `shade_rays` (ddgi_shade.wgsl)
// shades them here, a thread a ray.
#include "ddgi_sampling.inc.wgsl"

// Thread `id` of a pass that runs a thread per packed ray (two-dimensional beyond 65,535
// workgroups of DDGI_RAY_GROUP): its ray.
fn ddgi_ray_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * 65535u * DDGI_RAY_GROUP;
}

// The rays the budget pass packed this frame.
fn ddgi_ray_total() -> u32 {
    return ddgi_counters_in.total_rays;
}

// The ray a probe ray traces: from its probe, at most max_ray_distance long.
fn ddgi_ray(info: DdgiRay) -> Ray {
    return Ray(ddgi_probe_position(info.probe), 0.0, info.direction, ddgi_volume.max_ray_distance);
}

// The open share of the hemisphere over a probe ray's hit (origin already lifted off the surface,
// unit normal n): hit_occlusion_rays cosine-distributed rays of hit_occlusion_reach, stratified and
// turned by a hash of the ray and the frame (the maps' blending averages the turns).
fn ddgi_hit_open_share(i: u32, origin: vec3<f32>, n: vec3<f32>) -> f32 {
    let count = ddgi_volume.hit_occlusion_rays;
    let tangent = safe_normalize(cross(select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9), n), vec3<f32>(1.0, 0.0, 0.0));
    let bitangent = cross(n, tangent);
    let turn = f32(hash_lowbias32(i * 2654435769u + view.frame * 40503u + 12345u)) / 4294967296.0;
    var open = 0u;
    for (var k = 0u; k < count; k++) {
        let u = (f32(k) + 0.5) / f32(count);
        let phi = 2.0 * PI * fract(f32(k) * 0.618033988749895 + turn);
        let r = sqrt(u);
        let d = tangent * (r * cos(phi)) + bitangent * (r * sin(phi)) + n * sqrt(max(1.0 - u, 0.0));
        if !trace_any(Ray(origin, 0.0, d, ddgi_volume.hit_occlusion_reach)) {
            open += 1u;
        }
    }
    return f32(open) / f32(max(count, 1u));
}

// Shades ray i (`ray_info`, traced as ddgi_ray(ray_info)) at its closest hit, back faces included
// (they mark probes inside geometry; masked materials' are shaded as front faces): its emission, direct light (a shadow ray per light, through
// the BRDF) and indirect light from the previous frame's probes, into ddgi_radiance[i].
fn ddgi_shade_ray(i: u32, ray_info: DdgiRay, hit: RayHit) {
    let ray = ddgi_ray(ray_info);
    let origin = ray.origin;
    if hit.instance == RT_NO_HIT {
        // Misses see the sky (the scene's along the ray, or the volume's own), never its sun disk:
        // the directional light already lights what the probes see.
        var sky = sky_radiance(ray_info.direction);
        if ddgi_has(DDGI_SKY_OVERRIDE) {
            sky = ddgi_volume.sky_radiance;
        }
        ddgi_radiance[i] = vec4<f32>(min(sanitize_radiance(sky), vec3<f32>(DDGI_MAX_IRRADIANCE)), DDGI_MISS);
        return;
    }
    if !hit.front_face && !material_is_masked(instances[hit.instance].material) {
        // Back faces are black: they mark probes inside closed geometry. A masked material's
        // surface (a leaf card, a fence) is one sheet seen from both sides, shaded on either.
        ddgi_radiance[i] = vec4<f32>(0.0, 0.0, 0.0, -hit.t * DDGI_BACKFACE_SCALE);
        return;
    }
    let surface = hit_surface(ray, hit);
    let t = hit.t;
    let position = origin + ray_info.direction * t;
    let normal = surface.normal;
    // `position` comes from origin + direction · t, which is only as exact as the larger of the two
    // magnitudes: at large scales (10^4 units) that error dwarfs the float-step offset of a hit near
    // a coordinate plane, and the shadow ray would start under the surface (the floor goes dark).
    // Lift it by a few ulps of that magnitude first.
    let magnitude = max(t, max(abs(origin.x), max(abs(origin.y), abs(origin.z))));
    let shadow_origin = offset_ray_origin(position + normal * (1e-5 * magnitude), normal);
    let brdf = hit_brdf_surface(surface);
    let to_probe = -ray_info.direction;
    var irradiance = vec3<f32>(0.0);
    var direct = vec3<f32>(0.0);
    for (var l = 0u; l < view.light_count; l++) {
        let s = sample_light(lights[l], position, normal);
        if any(s.irradiance > vec3<f32>(0.0)) && !trace_any(Ray(shadow_origin, 0.0, s.to_light, s.distance * (1.0 - 1e-4))) {
            irradiance += s.irradiance;
            direct += brdf_eval(brdf, normal, to_probe, s.to_light) * s.irradiance;
        }
    }
    var probes = ddgi_sample_irradiance(position, normal, to_probe);
    if ddgi_volume.hit_occlusion_rays > 0u {
        // A blocked share of the hemisphere sees a nearby surface, taken to reflect like this one.
        let open = ddgi_hit_open_share(i, shadow_origin, normal);
        probes = probes * (open + (1.0 - open) * surface.albedo) + (1.0 - open) * PI * surface.emissive;
    }
    var radiance = surface.emissive + surface.albedo * INV_PI * (irradiance + probes);
    if brdf_has_specular(brdf) {
        // Direct light through the whole BRDF; the probes' light (irradiance, which cannot resolve
        // a glossy reflection) reflected as by a diffuse surface of the lobes' albedo, so that
        // metals seen by the probes are not black.
        let specular = brdf_specular_albedo(brdf, max(dot(normal, to_probe), 1e-4));
        let albedo = brdf_diffuse_color(brdf) * (vec3<f32>(1.0) - specular) + specular;
        radiance = surface.emissive + direct + albedo * INV_PI * probes;
    }
    ddgi_radiance[i] = vec4<f32>(min(sanitize_radiance(radiance), vec3<f32>(DDGI_MAX_IRRADIANCE)), t);
}

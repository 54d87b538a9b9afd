// DDGI pass `ddgi_trace`: generation, trace and shading of the probe rays in one pass, one thread per
// ray packed by `ddgi_budget`, dispatched indirectly with its count (two-dimensional beyond 65,535
// workgroups).
#include "ddgi_sampling.inc.wgsl"

fn ddgi_ray_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * 65535u * DDGI_RAY_GROUP;
}

fn ddgi_ray_total() -> u32 {
    return ddgi_counters_in.total_rays;
}

// The probe whose packed rays hold ray i: the last probe whose offset is at most i (probes with no
// rays share the offset of the next one, so the search lands on the probe that has rays).
fn ddgi_probe_of_ray(i: u32) -> u32 {
    var lo = 0u;
    var hi = ddgi_volume.probe_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if ddgi_probes[mid].ray_offset <= i {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Ray i of the frame: its probe, and its direction — one of the spherical Fibonacci directions for
// the probe's own ray count, under this frame's random rotation.
fn ddgi_generate_ray(i: u32) -> DdgiRay {
    let probe = ddgi_probe_of_ray(i);
    let data = ddgi_probes[probe];
    let direction = ddgi_volume.ray_rotation * ddgi_spherical_fibonacci(i - data.ray_offset, max(data.ray_count, 1u));
    return DdgiRay(safe_normalize(direction, vec3<f32>(0.0, 0.0, 1.0)), probe);
}

// Trace and shading: generates ray i (kept in ddgi_rays for the probe update), traces its closest
// hit, back faces included (they mark probes inside geometry), and shades the hit: its emission,
// direct light (a shadow ray per light, through the BRDF) and indirect light from the previous
// frame's probes. One pass, not two: a separate shading pass cost its own launch and a round trip of every
// hit through memory, which at the published grids took longer than the shading itself.
@compute @workgroup_size(DDGI_RAY_GROUP)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let ray_info = ddgi_generate_ray(i);
    ddgi_rays[i] = ray_info;
    let origin = ddgi_probe_position(ray_info.probe);
    let ray = Ray(origin, 0.0, ray_info.direction, ddgi_volume.max_ray_distance);
    let hit = trace_closest(ray);
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
    if !hit.front_face {
        // Back faces are black.
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
    let probes = ddgi_sample_irradiance(position, normal, to_probe);
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

// DDGI probe rays: generation, trace, shading. One thread per ray; ray i belongs to probe
// i / rays_per_probe. The dispatch is two-dimensional when it exceeds 65,535 workgroups.
#include "ddgi.inc.wgsl"

const DDGI_RAY_GROUP: u32 = 64u;

fn ddgi_ray_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * 65535u * DDGI_RAY_GROUP;
}

fn ddgi_ray_total() -> u32 {
    return ddgi_volume.probe_count * ddgi_volume.rays_per_probe;
}

// Ray generation: spherical Fibonacci directions under this frame's random rotation. Probes that
// trace nothing this frame (inactive, outside a re-check) get DDGI_RAY_SKIP.
@compute @workgroup_size(64)
fn generate_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let m = ddgi_volume.rays_per_probe;
    let probe = i / m;
    let direction = ddgi_volume.ray_rotation * ddgi_spherical_fibonacci(i % m, m);
    var tag = probe;
    if !ddgi_probe_traces(probe) {
        tag = probe | DDGI_RAY_SKIP;
    }
    ddgi_rays[i] = DdgiRay(safe_normalize(direction, vec3<f32>(0.0, 0.0, 1.0)), tag);
}

// Trace: closest hit, back faces included (they mark probes inside geometry). Writes the surfel.
@compute @workgroup_size(64)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let ray_info = ddgi_rays[i];
    if (ray_info.probe & DDGI_RAY_SKIP) != 0u {
        return;
    }
    let ray = Ray(ddgi_probe_position(ray_info.probe), 0.0, ray_info.direction, ddgi_volume.max_ray_distance);
    let hit = trace_closest(ray);
    if hit.instance == RT_NO_HIT {
        ddgi_surfels[i] = vec4<u32>(bitcast<u32>(DDGI_MISS), 0u, 0u, 0u);
        return;
    }
    if !hit.front_face {
        ddgi_surfels[i] = vec4<u32>(bitcast<u32>(-hit.t), 0u, 0u, 0u);
        return;
    }
    let surface = hit_surface(ray, hit);
    ddgi_surfels[i] = vec4<u32>(
        bitcast<u32>(hit.t),
        pack2x16snorm(ddgi_oct_encode(surface.normal)),
        pack4x8unorm(vec4<f32>(surface.albedo, 1.0)),
        ddgi_pack_rgb9e5(surface.emissive),
    );
}

// Shading: emission + direct light (a shadow ray per light) + indirect light from the probes of the
// previous frame, all Lambertian. Misses see the sky; back faces are black.
@compute @workgroup_size(64)
fn shade_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let ray_info = ddgi_rays[i];
    if (ray_info.probe & DDGI_RAY_SKIP) != 0u {
        return;
    }
    let surfel = ddgi_surfels[i];
    let t = bitcast<f32>(surfel.x);
    if t >= DDGI_MISS {
        ddgi_radiance[i] = vec4<f32>(sanitize_radiance(ddgi_volume.sky_radiance), DDGI_MISS);
        return;
    }
    if t < 0.0 {
        ddgi_radiance[i] = vec4<f32>(0.0, 0.0, 0.0, t * DDGI_BACKFACE_SCALE);
        return;
    }
    let origin = ddgi_probe_position(ray_info.probe);
    let position = origin + ray_info.direction * t;
    let normal = ddgi_oct_decode(unpack2x16snorm(surfel.y));
    let albedo = unpack4x8unorm(surfel.z).rgb;
    var radiance = ddgi_unpack_rgb9e5(surfel.w);
    var irradiance = vec3<f32>(0.0);
    let shadow_origin = offset_ray_origin(position, normal);
    for (var l = 0u; l < view.light_count; l++) {
        let s = sample_light(lights[l], position, normal);
        if any(s.irradiance > vec3<f32>(0.0)) && !trace_any(Ray(shadow_origin, 0.0, s.to_light, s.distance * (1.0 - 1e-4))) {
            irradiance += s.irradiance;
        }
    }
    irradiance += ddgi_sample_irradiance(position, normal, -ray_info.direction);
    radiance += albedo * INV_PI * irradiance;
    ddgi_radiance[i] = vec4<f32>(sanitize_radiance(radiance), t);
}

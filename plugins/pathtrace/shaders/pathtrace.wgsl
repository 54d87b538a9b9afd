// Progressive reference path tracer: the engine's BRDF (engine::brdf: Lambertian, and glTF's GGX
// lobe where a material has one, sampled from its visible normals) with base-colour,
// metallic-roughness and normal textures, emissive surfaces (found by the paths), punctual lights
// by next-event estimation with shadow rays, the sky along escaping paths, Russian roulette after
// a few bounces, an optional bounce cap. Each dispatch adds `samples` paths
// per pixel to a float accumulation buffer; the output is their mean.
#include "rt_alpha.inc.wgsl"

struct PathTraceParams {
    // Index of the first sample of this dispatch (samples already accumulated).
    sample_offset: u32,
    samples: u32,
    // 0: unbounded (Russian roulette ends paths).
    max_bounces: u32,
    seed: u32,
}

@group(1) @binding(0) var<uniform> path_params: PathTraceParams;
@group(1) @binding(1) var<storage, read_write> path_accumulation: array<vec4<f32>>;
@group(1) @binding(2) var path_radiance_out: texture_storage_2d<rgba32float, write>;

// Bounces before Russian roulette may end a path.
const RR_START_BOUNCE: u32 = 3u;

// PCG hash (Jarzynski and Olano 2020).
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

struct Rng {
    state: u32,
}

fn rng_next(rng: ptr<function, Rng>) -> f32 {
    (*rng).state = pcg((*rng).state);
    // 24 random bits: uniform in [0, 1).
    return f32((*rng).state >> 8u) * (1.0 / 16777216.0);
}

// Cosine-weighted direction around n (pdf cosθ/π).
fn sample_cosine(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    let local = vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u.x)));
    let basis = brdf_basis(n);
    return safe_normalize(basis[0] * local.x + basis[1] * local.y + basis[2] * local.z, n);
}

fn camera_ray(pixel: vec2<u32>, jitter: vec2<f32>) -> Ray {
    let uv = (vec2<f32>(pixel) + jitter) / vec2<f32>(view.size);
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    // Reverse-Z: depth 1 is the near plane.
    let near = view.world_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    let target_point = near.xyz / select(near.w, 1e-30, abs(near.w) < 1e-30);
    let dir = safe_normalize(target_point - view.camera_position, vec3<f32>(0.0, 0.0, -1.0));
    return Ray(view.camera_position, 0.0, dir, 3.0e38);
}

// Russian roulette from RR_START_BOUNCE on: false ends the path; a survivor's throughput is
// divided by its chance to survive.
fn russian_roulette(throughput: ptr<function, vec3<f32>>, bounce: u32, rng: ptr<function, Rng>) -> bool {
    if bounce < RR_START_BOUNCE {
        return true;
    }
    let t = *throughput;
    let survive = clamp(max(t.x, max(t.y, t.z)), 0.05, 0.95);
    if rng_next(rng) >= survive {
        return false;
    }
    *throughput = t / survive;
    return true;
}

fn trace_path(first: Ray, rng: ptr<function, Rng>) -> vec3<f32> {
    var ray = first;
    var throughput = vec3<f32>(1.0);
    var radiance = vec3<f32>(0.0);
    var bounce = 0u;
    loop {
        let hit = trace_closest(ray);
        if hit.instance == RT_NO_HIT {
            // The sun's disk only for camera rays: bounced paths get the sun from its light.
            radiance += throughput * sky_radiance_along(ray.direction, bounce == 0u);
            break;
        }
        let surface = hit_surface(ray, hit);
        // Emission is found by the paths only (lights are punctual), so nothing is counted twice.
        radiance += throughput * surface.emissive;
        let origin = offset_ray_origin(surface.position, surface.geometric_normal);
        let brdf = hit_brdf_surface(surface);
        let to_viewer = -ray.direction;
        for (var i = 0u; i < view.light_count; i++) {
            let s = sample_light(lights[i], surface.position, surface.normal);
            if any(s.irradiance > vec3<f32>(0.0)) && !trace_any(Ray(origin, 0.0, s.to_light, s.distance * (1.0 - 1e-4))) {
                radiance += throughput * brdf_eval(brdf, surface.normal, to_viewer, s.to_light) * s.irradiance;
            }
        }
        bounce += 1u;
        if path_params.max_bounces != 0u && bounce >= path_params.max_bounces {
            break;
        }
        var dir: vec3<f32>;
        if brdf_has_specular(brdf) {
            // One of the two lobes, chosen by their share of the reflected light; the weight is
            // f · cos over the density of the mixture of both.
            let n = surface.normal;
            let specular = luminance(brdf_specular_albedo(brdf, max(dot(n, to_viewer), 1e-4)));
            let diffuse = luminance(brdf_diffuse_color(brdf));
            let p_specular = select(clamp(specular / max(specular + diffuse, 1e-6), 0.1, 0.9), 1.0, diffuse <= 0.0);
            let alpha = brdf_alpha(brdf);
            let choice = rng_next(rng);
            let u = vec2<f32>(rng_next(rng), rng_next(rng));
            if choice < p_specular {
                dir = reflect(ray.direction, brdf_sample_visible_normal(n, to_viewer, alpha, u));
            } else {
                dir = sample_cosine(n, u);
            }
            let n_l = dot(n, dir);
            if n_l <= 0.0 || dot(dir, surface.geometric_normal) <= 0.0 {
                break;
            }
            let pdf = p_specular * brdf_visible_normal_pdf(n, to_viewer, dir, alpha) + (1.0 - p_specular) * n_l * INV_PI;
            throughput *= brdf_eval(brdf, n, to_viewer, dir) * (n_l / max(pdf, 1e-30));
            if !russian_roulette(&throughput, bounce, rng) {
                break;
            }
        } else {
            // Lambertian, cosine-sampled: BRDF · cos / pdf = albedo.
            throughput *= surface.albedo;
            if !russian_roulette(&throughput, bounce, rng) {
                break;
            }
            dir = sample_cosine(surface.normal, vec2<f32>(rng_next(rng), rng_next(rng)));
        }
        if all(throughput <= vec3<f32>(0.0)) {
            break;
        }
        ray = Ray(origin, 0.0, dir, 3.0e38);
    }
    return sanitize_radiance(radiance);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let index = id.y * view.size.x + id.x;
    var sum = vec3<f32>(0.0);
    for (var s = 0u; s < path_params.samples; s++) {
        let sample = path_params.sample_offset + s;
        var rng = Rng(pcg(index ^ pcg(sample ^ pcg(path_params.seed))));
        let jitter = vec2<f32>(rng_next(&rng), rng_next(&rng));
        sum += trace_path(camera_ray(id.xy, jitter), &rng);
    }
    var acc = vec4<f32>(0.0);
    if path_params.sample_offset != 0u {
        acc = path_accumulation[index];
    }
    acc += vec4<f32>(sum, f32(path_params.samples));
    path_accumulation[index] = acc;
    textureStore(path_radiance_out, id.xy, vec4<f32>(acc.rgb / max(acc.w, 1.0), 1.0));
}

// Short visibility rays from the camera's surfaces, shared by the passes `ddgi_contact_occlusion`
// and `ddgi_composite`: the sky light's visibility where no volume reaches (ddgi::DdgiSkyLight) and
// the contact occlusion of the probes' light (ddgi::DdgiContactOcclusion), traced at every pixel
// or at one pixel of each 2×2 block and brought back to full resolution by depth and normal.
#include "ddgi_camera.inc.wgsl"
#include "rt_alpha.inc.wgsl"

// `count` stratified cosine-distributed rays from surface point p (normal n), of reach `reach`,
// turned by a per-pixel angle: the share that escapes (x) and the mean over all of the sky's
// radiance along those that escape (yzw), which times π is the sky's irradiance through them.
fn ddgi_open_rays(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>, count: u32, reach: f32, with_sky: bool) -> vec4<f32> {
    let view_distance = length(p - view.camera_position);
    let origin = offset_ray_origin(p + n * (1e-4 * view_distance), n);
    let tangent = safe_normalize(cross(select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), abs(n.x) > 0.9), n), vec3<f32>(1.0, 0.0, 0.0));
    let bitangent = cross(n, tangent);
    // A new turn every frame: the temporal anti-aliasing averages the rays of many frames.
    let turn = f32(hash_lowbias32(pixel.x * 7919u + pixel.y * 104729u + view.frame * 2654435769u)) / 4294967296.0;
    var open = 0u;
    var sky = vec3<f32>(0.0);
    for (var k = 0u; k < count; k++) {
        // Cosine-distributed: uniform over the unit disc, lifted onto the hemisphere.
        let u = (f32(k) + 0.5) / f32(count);
        let phi = 2.0 * PI * fract(f32(k) * 0.618033988749895 + turn);
        let r = sqrt(u);
        let d = tangent * (r * cos(phi)) + bitangent * (r * sin(phi)) + n * sqrt(max(1.0 - u, 0.0));
        if !trace_any(Ray(origin, 0.0, d, reach)) {
            open += 1u;
            if with_sky {
                sky += sky_radiance(d);
            }
        }
    }
    let total = f32(max(count, 1u));
    return vec4<f32>(f32(open) / total, sky / total);
}

// Whether contact occlusion is on (rays and a radius).
fn ddgi_contact_occlusion_on() -> bool {
    return ddgi_gather_params.ao_rays > 0u && ddgi_gather_params.ao_radius > 0.0;
}

// Contact occlusion traced at surface point p (normal n) of `pixel`: the open share of ao_rays rays
// of ao_radius.
fn ddgi_contact_occlusion_traced(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>) -> f32 {
    return ddgi_open_rays(pixel, p, n, ddgi_gather_params.ao_rays, ddgi_gather_params.ao_radius, false).x;
}

// The blocks of the reduced-resolution occlusion: ao_scale × ao_scale pixels each (2: half
// resolution), the image's edge blocks cut short.
fn ddgi_occlusion_blocks() -> vec2<u32> {
    let scale = max(ddgi_gather_params.ao_scale, 1u);
    return (view.size + vec2<u32>(scale - 1u)) / scale;
}

// The pixel of `block` that the reduced-resolution pass traces this frame: another of the block's
// pixels each frame, in an order that differs between neighbouring blocks, so that the temporal
// anti-aliasing sees every pixel's rays over ao_scale² frames.
fn ddgi_occlusion_sample_pixel(block: vec2<u32>) -> vec2<u32> {
    let scale = max(ddgi_gather_params.ao_scale, 1u);
    let k = (hash_lowbias32(block.x * 7919u + block.y * 104729u) + view.frame) % (scale * scale);
    return min(block * scale + vec2<u32>(k % scale, k / scale), view.size - vec2<u32>(1u));
}

// The G-buffer's surface normal at `pixel`.
fn ddgi_pixel_normal(pixel: vec2<u32>) -> vec3<f32> {
    return safe_normalize(textureLoad(gbuffer_normal, pixel, 0).xyz, vec3<f32>(0.0, 1.0, 0.0));
}

// Contact occlusion at surface point p (normal n) of `pixel`, 1 when it is off. At reduced
// resolution: the traced values of the four blocks nearest the pixel, each weighted by how close
// its traced pixel lies on screen, on the pixel's tangent plane and in normal (a joint bilateral
// upsampling); where none of them lies on the pixel's surface (a thin object, a silhouette), the
// pixel traces its own rays.
fn ddgi_contact_occlusion(pixel: vec2<u32>, p: vec3<f32>, n: vec3<f32>) -> f32 {
    if !ddgi_contact_occlusion_on() {
        return 1.0;
    }
    let scale = ddgi_gather_params.ao_scale;
    if scale < 2u {
        return ddgi_contact_occlusion_traced(pixel, p, n);
    }
    let blocks = vec2<i32>(ddgi_occlusion_blocks());
    let block = vec2<i32>(pixel / scale);
    // The neighbouring blocks on the side of the block's centre the pixel lies on.
    let centre2 = vec2<i32>(pixel % scale) * 2 + 1;
    let step = select(vec2<i32>(-1), vec2<i32>(1), centre2 >= vec2<i32>(i32(scale)));
    // Planes within a tenth of the radius (and a few pixels' footprint far away) count as one.
    let tolerance = 0.1 * ddgi_gather_params.ao_radius + 2e-3 * length(p - view.camera_position);
    var sum = 0.0;
    var weight = 0.0;
    for (var j = 0; j < 4; j++) {
        let c = block + vec2<i32>(j & 1, j >> 1u) * step;
        if any(c < vec2<i32>(0)) || any(c >= blocks) {
            continue;
        }
        let value = ddgi_occlusion[u32(c.y * blocks.x + c.x)];
        if !(value >= 0.0) {
            continue;
        }
        let s = ddgi_occlusion_sample_pixel(vec2<u32>(c));
        let depth = textureLoad(gbuffer_depth, s, 0);
        let plane = dot(view_world_position(s, depth) - p, n) / tolerance;
        let facing = max(dot(ddgi_pixel_normal(s), n), 0.0);
        let facing8 = facing * facing * facing * facing * facing * facing * facing * facing;
        let d = vec2<f32>(s) - vec2<f32>(pixel);
        let w = facing8 * exp(-plane * plane) / (1.0 + dot(d, d));
        sum += w * value;
        weight += w;
    }
    if !(weight > 1e-3) {
        return ddgi_contact_occlusion_traced(pixel, p, n);
    }
    return clamp(sum / weight, 0.0, 1.0);
}

// Pass `taa` (temporal anti-aliasing): this frame's radiance, rendered with a sub-pixel jitter, is
// blended into the history of the frames before it. The history is reprojected by the G-buffer's
// motion vectors (camera and moving instances) and clipped to the colours of this frame's 3×3
// neighbourhood (in YCoCg), so that what moved or was uncovered leaves no trail; a still camera's
// pixel becomes the running mean of up to `max_samples` jittered samples: the box-filtered,
// anti-aliased image the path tracer also converges to. Alpha of the history: its sample count.
#include "scene.inc.wgsl"
#include "taa.inc.wgsl"

@group(1) @binding(0) var<uniform> taa: TaaParams;
@group(1) @binding(1) var taa_current: texture_2d<f32>;
@group(1) @binding(2) var taa_history: texture_2d<f32>;
@group(1) @binding(3) var gbuffer_motion: texture_2d<f32>;
@group(1) @binding(4) var taa_history_out: texture_storage_2d<rgba32float, write>;

fn rgb_to_ycocg(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.25 * c.r + 0.5 * c.g + 0.25 * c.b, 0.5 * c.r - 0.5 * c.b, -0.25 * c.r + 0.5 * c.g - 0.25 * c.b);
}

fn ycocg_to_rgb(c: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(c.x + c.y - c.z, c.x + c.z, c.x - c.y - c.z);
}

fn load_clamped(t: texture_2d<f32>, p: vec2<i32>) -> vec4<f32> {
    return textureLoad(t, clamp(p, vec2<i32>(0), vec2<i32>(view.size) - 1), 0);
}

// The history at `pos` (pixel units, texel centres at +0.5) through a Catmull-Rom filter, sharper
// than bilinear under motion; its negative lobes are clamped away.
fn sample_history(pos: vec2<f32>) -> vec3<f32> {
    let t = pos - 0.5;
    let base = vec2<i32>(floor(t));
    let f = t - floor(t);
    let w = array<vec2<f32>, 4>(
        f * (-0.5 + f * (1.0 - 0.5 * f)),
        1.0 + f * f * (-2.5 + 1.5 * f),
        f * (0.5 + f * (2.0 - 1.5 * f)),
        f * f * (-0.5 + 0.5 * f),
    );
    var sum = vec3<f32>(0.0);
    var total = 0.0;
    for (var j = 0; j < 4; j++) {
        for (var i = 0; i < 4; i++) {
            let weight = w[i].x * w[j].y;
            sum += weight * sanitize_radiance(load_clamped(taa_history, base + vec2<i32>(i - 1, j - 1)).rgb);
            total += weight;
        }
    }
    return sanitize_radiance(sum / max(total, 1e-6));
}

// `c` moved towards the centre of the box [lo, hi] until it lies inside (clipping keeps the
// history's hue better than clamping each channel).
fn clip_to_box(c: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec3<f32> {
    let center = 0.5 * (lo + hi);
    let extent = max(0.5 * (hi - lo), vec3<f32>(1e-7));
    let d = c - center;
    let t = abs(d) / extent;
    let m = max(t.x, max(t.y, t.z));
    if m > 1.0 {
        // Inside the box exactly, also where it is flat (a uniform neighbourhood).
        return clamp(center + d / m, lo, hi);
    }
    return c;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let p = vec2<i32>(id.xy);
    let current = sanitize_radiance(textureLoad(taa_current, p, 0).rgb);
    var count = 0.0;
    var history = vec3<f32>(0.0);
    if taa.history_valid != 0u {
        let motion = textureLoad(gbuffer_motion, p, 0).xy;
        let size = vec2<f32>(view.size);
        let pos = vec2<f32>(p) + 0.5 - select(vec2<f32>(0.0), motion, motion == motion) * size;
        if all(pos >= vec2<f32>(0.0)) && all(pos <= size) {
            var lo = vec3<f32>(3.0e38);
            var hi = vec3<f32>(-3.0e38);
            for (var dy = -1; dy <= 1; dy++) {
                for (var dx = -1; dx <= 1; dx++) {
                    let c = rgb_to_ycocg(sanitize_radiance(load_clamped(taa_current, p + vec2<i32>(dx, dy)).rgb));
                    lo = min(lo, c);
                    hi = max(hi, c);
                }
            }
            // A still pixel reads its own texel (no filtering: nothing blurs); a moving one the
            // filtered history where its surface was.
            let nearest = load_clamped(taa_history, vec2<i32>(floor(pos)));
            var h = sanitize_radiance(nearest.rgb);
            if any(motion != vec2<f32>(0.0)) {
                h = sample_history(pos);
            }
            history = sanitize_radiance(ycocg_to_rgb(clip_to_box(rgb_to_ycocg(h), lo, hi)));
            count = select(0.0, clamp(nearest.a, 0.0, taa.max_samples), nearest.a == nearest.a);
        }
    }
    let n = min(count + 1.0, max(taa.max_samples, 1.0));
    let resolved = mix(history, current, 1.0 / n);
    textureStore(taa_history_out, id.xy, vec4<f32>(sanitize_radiance(resolved), n));
}

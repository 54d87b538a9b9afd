// Pass `taa_output`: the temporal anti-aliasing's resolved history into the frame's radiance (what
// the tonemapper shows and image.exr holds), sharpened when asked: an unsharp mask over the four
// direct neighbours, limited to their range so that it cannot ring or go negative.
#include "scene.inc.wgsl"
#include "taa.inc.wgsl"

@group(1) @binding(0) var<uniform> taa: TaaParams;
@group(1) @binding(1) var taa_resolved: texture_2d<f32>;
@group(1) @binding(2) var radiance_out: texture_storage_2d<rgba32float, write>;

fn load_resolved(p: vec2<i32>) -> vec3<f32> {
    return sanitize_radiance(textureLoad(taa_resolved, clamp(p, vec2<i32>(0), vec2<i32>(view.size) - 1), 0).rgb);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let p = vec2<i32>(id.xy);
    var c = load_resolved(p);
    let k = clamp(taa.sharpness, 0.0, 1.0);
    if k > 0.0 {
        let a = load_resolved(p + vec2<i32>(-1, 0));
        let b = load_resolved(p + vec2<i32>(1, 0));
        let d = load_resolved(p + vec2<i32>(0, -1));
        let e = load_resolved(p + vec2<i32>(0, 1));
        let lo = min(c, min(min(a, b), min(d, e)));
        let hi = max(c, max(max(a, b), max(d, e)));
        c = clamp(c + k * (c - 0.25 * (a + b + d + e)), lo, hi);
    }
    textureStore(radiance_out, id.xy, vec4<f32>(c, 1.0));
}

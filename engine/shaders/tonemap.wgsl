// Exposure, clamp to [0, 1], sRGB encoding: linear radiance -> displayable 8-bit.
#include "scene.inc.wgsl"

@group(1) @binding(0) var hdr_in: texture_2d<f32>;
@group(1) @binding(1) var ldr_out: texture_storage_2d<rgba8unorm, write>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    let c = sanitize_radiance(textureLoad(hdr_in, id.xy, 0).rgb) * view.exposure;
    textureStore(ldr_out, id.xy, vec4<f32>(srgb_encode(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0))), 1.0));
}

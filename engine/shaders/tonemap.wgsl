// Pass `tonemap`: exposure, the display transform, sRGB encoding: linear radiance -> displayable
// 8-bit. The transform is a pipeline constant (engine::render::DisplayTransform): 0 clamps to
// [0, 1] (the radiometric default, which eval's metrics assume), 1 is AgX (engine::color::agx is
// its CPU mirror, checked against this shader by tests/camera_path.rs). The exposure is the
// camera's, or with AUTO_EXPOSURE the auto-exposure's (engine::render::exposure).
#include "scene.inc.wgsl"

override DISPLAY_TRANSFORM: u32 = 0u;
override AUTO_EXPOSURE: bool = false;

@group(1) @binding(0) var hdr_in: texture_2d<f32>;
@group(1) @binding(1) var ldr_out: texture_storage_2d<rgba8unorm, write>;
// (EV100, exposure, valid, _) of the auto-exposure.
@group(1) @binding(2) var<storage, read> tonemap_exposure: vec4<f32>;

const AGX_MIN_EV: f32 = -12.47393;
const AGX_MAX_EV: f32 = 4.026069;

// AgX's sigmoid on the log-encoded value (a 6th-order fit of its contrast curve).
fn agx_contrast(x: vec3<f32>) -> vec3<f32> {
    let x2 = x * x;
    let x4 = x2 * x2;
    return 15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x - 0.00232;
}

// AgX (Troy Sobotka; the minimal form of Benjamin Wrensch): exposed linear Rec. 709 radiance to
// display-linear RGB in [0, 1]. Input already sanitized (finite, non-negative).
fn agx(c: vec3<f32>) -> vec3<f32> {
    let inset = mat3x3<f32>(
        vec3<f32>(0.842479062253094, 0.0423282422610123, 0.0423756549057051),
        vec3<f32>(0.0784335999999992, 0.878468636469772, 0.0784336),
        vec3<f32>(0.0792237451477643, 0.0791661274605434, 0.879142973793104),
    );
    let outset = mat3x3<f32>(
        vec3<f32>(1.19687900512017, -0.0528968517574562, -0.0529716355144438),
        vec3<f32>(-0.0980208811401368, 1.15190312990417, -0.0980434501171241),
        vec3<f32>(-0.0990297440797205, -0.0989611768448433, 1.15107367264116),
    );
    let logged = clamp(log2(max(inset * c, vec3<f32>(1e-10))), vec3<f32>(AGX_MIN_EV), vec3<f32>(AGX_MAX_EV));
    let curved = agx_contrast((logged - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV));
    return pow(clamp(outset * curved, vec3<f32>(0.0), vec3<f32>(1.0)), vec3<f32>(2.2));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id.xy >= view.size) {
        return;
    }
    var exposure = view.exposure;
    if AUTO_EXPOSURE && tonemap_exposure.z > 0.5 && tonemap_exposure.y == tonemap_exposure.y {
        exposure = tonemap_exposure.y;
    }
    let c = sanitize_radiance(sanitize_radiance(textureLoad(hdr_in, id.xy, 0).rgb) * exposure);
    var display = clamp(c, vec3<f32>(0.0), vec3<f32>(1.0));
    if DISPLAY_TRANSFORM == 1u {
        display = agx(c);
    }
    textureStore(ldr_out, id.xy, vec4<f32>(srgb_encode(display), 1.0));
}

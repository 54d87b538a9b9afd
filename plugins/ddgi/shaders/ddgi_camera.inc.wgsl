// DDGI on the camera: the parameters and G-buffer bindings (group 2) that the passes `ddgi_gather`,
// `ddgi_contact_occlusion` and `ddgi_composite` share.
#include "scene.inc.wgsl"

struct DdgiGatherParams {
    // 1 for the first volume of the frame: the accumulation starts from zero.
    first_volume: u32,
    // composite_debug: 1 direct light only, 2 albedo, 3 normals, 4 contact occlusion.
    debug_view: u32,
    // Sky light at pixels no volume covers (ddgi::DdgiSkyLight): visibility rays (0: off) and reach.
    sky_rays: u32,
    sky_distance: f32,
    // Contact occlusion of the probes' light (ddgi::DdgiContactOcclusion): rays (0: off), radius,
    // and the side of the blocks it is traced at one pixel of (1: every pixel, 2: half resolution).
    ao_rays: u32,
    ao_radius: f32,
    ao_scale: u32,
    _pad1: u32,
}

@group(2) @binding(0) var<uniform> ddgi_gather_params: DdgiGatherParams;
@group(2) @binding(1) var gbuffer_depth: texture_depth_2d;
@group(2) @binding(2) var gbuffer_normal: texture_2d<f32>;
@group(2) @binding(3) var gbuffer_albedo: texture_2d<f32>;
@group(2) @binding(4) var direct_in: texture_2d<f32>;
// Per pixel: (Σ volume weight · irradiance, Σ volume weight); then, at pixel + the pixel count, the
// same for the irradiance along a glossy pixel's reflection (written only at such pixels).
@group(2) @binding(5) var<storage, read_write> ddgi_indirect: array<vec4<f32>>;
@group(2) @binding(6) var radiance_out: texture_storage_2d<rgba32float, write>;
@group(2) @binding(7) var gbuffer_emissive: texture_2d<f32>;
// Contact occlusion at reduced resolution (pass `ddgi_contact_occlusion`), one value per block of
// ao_scale × ao_scale pixels, row-major; −1 where the block's traced pixel shows no surface.
@group(2) @binding(8) var<storage, read_write> ddgi_occlusion: array<f32>;

// The material of a G-buffer pixel as the BRDF sees it (base colour and metallic, roughness in the
// normal's w, specular weight in the emission's).
fn ddgi_pixel_surface(id: vec2<u32>) -> BrdfSurface {
    let albedo = textureLoad(gbuffer_albedo, id, 0);
    return BrdfSurface(albedo.rgb, albedo.a, textureLoad(gbuffer_normal, id, 0).w, textureLoad(gbuffer_emissive, id, 0).a);
}

// The direction a glossy lobe gathers most of its light from: the mirror direction, drawn towards
// the normal as the surface roughens (Lagarde and de Rousiers 2014).
fn ddgi_specular_direction(n: vec3<f32>, to_viewer: vec3<f32>, s: BrdfSurface) -> vec3<f32> {
    let a = brdf_alpha(s);
    let r = reflect(-to_viewer, n);
    return safe_normalize(mix(n, r, (1.0 - a) * (sqrt(1.0 - a) + a)), n);
}

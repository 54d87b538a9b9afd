// The scene as the GPU sees it: bind group 0, shared by every pass that looks at the scene
// (bindings 0–6 and 12–14 here, 7–11 in ray_tracing.inc.wgsl).
// Host mirrors of these structs live in engine/src/render/gpu_types.rs (a test compares sizes).
#include "common.inc.wgsl"

// The sky (engine::sky): Preetham's analytic daylight sky, or one uniform radiance.
struct GpuSky {
    // Perez coefficients A–E: x for luminance Y, y and z for the chromaticities x and y.
    perez_a: vec4<f32>,
    perez_b: vec4<f32>,
    perez_c: vec4<f32>,
    perez_d: vec4<f32>,
    perez_e: vec4<f32>,
    // Zenith Y (radiance units), x, y; w: 1 for the physical sky, 0 for the uniform one.
    zenith: vec4<f32>,
    // 1 / F(0, θs) for Y, x, y.
    normalization: vec4<f32>,
    // Towards the sun; w: cosine of the disk's angular radius (2: no disk).
    sun_direction: vec4<f32>,
    sun_radiance: vec4<f32>,
    // The uniform sky's radiance, or the physical sky's night floor.
    uniform: vec4<f32>,
    ground_albedo: vec4<f32>,
}

struct ViewUniform {
    // Unjittered; rasterizing passes add `jitter` (view_raster_position).
    clip_from_world: mat4x4<f32>,
    world_from_clip: mat4x4<f32>,
    previous_clip_from_world: mat4x4<f32>,
    camera_position: vec3<f32>,
    exposure: f32,
    size: vec2<u32>,
    // Sub-pixel offset of this frame's raster in pixels (x right, y down): temporal anti-aliasing.
    jitter: vec2<f32>,
    light_count: u32,
    frame: u32,
    _pad0: u32,
    _pad1: u32,
    sky: GpuSky,
}

struct GpuVertex {
    position: vec3<f32>,
    u: f32,
    normal: vec3<f32>,
    v: f32,
    // Tangent (xyz) and handedness (w) for normal maps; zero when the mesh has none.
    tangent: vec4<f32>,
}

struct GpuInstance {
    world_from_local: mat4x4<f32>,
    // Inverse of world_from_local (zero when singular): rays go into instance space with it, and
    // the transpose of its linear part takes normals to the world.
    local_from_world: mat4x4<f32>,
    material: u32,
    mesh: u32,
    _pad0: u32,
    _pad1: u32,
}

// A texture inside the atlas: uv' = (dot(uv_x.xy, uv) + uv_x.z, dot(uv_y.xy, uv) + uv_y.z), wrapped,
// then mapped to rect (x, y, width, height in atlas coordinates). rect.z <= 0: no texture.
// (uv_x.w, uv_y.w): the image's size in texels when it is sampled nearest (uv' snapped to the
// centre of its texel), 0 for bilinear sampling.
struct TextureSlot {
    uv_x: vec4<f32>,
    uv_y: vec4<f32>,
    rect: vec4<f32>,
}

struct GpuMaterial {
    base_color: vec4<f32>,
    // Emitted radiance factor, emissive strength included; w: the alpha below which a texel is cut
    // (0 for opaque materials: none is).
    emissive: vec4<f32>,
    // metallic, roughness, specular (0: Lambertian), normal map scale.
    pbr: vec4<f32>,
    base_color_texture: TextureSlot,
    emissive_texture: TextureSlot,
    // Linear textures, in data_atlas: roughness in G, metallic in B; a tangent-space normal map.
    metallic_roughness_texture: TextureSlot,
    normal_texture: TextureSlot,
}

const LIGHT_DIRECTIONAL: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;

struct GpuLight {
    position: vec3<f32>,
    kind: u32,
    // Direction the light travels (directional and spot).
    direction: vec3<f32>,
    // Range window (glTF); 0 means unlimited.
    range: f32,
    // color * intensity: irradiance (directional) or radiant intensity (point, spot).
    radiance: vec3<f32>,
    spot_scale: f32,
    spot_offset: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Pipeline constants: a pipeline built for a scene without spot lights, without emissive
// materials or without alpha-masked ones sets these to false, and the spot cone, the emission
// lookup or the alpha test (the G-buffer's discard, the traversal's any-hit test) is compiled out.
override SCENE_HAS_SPOT_LIGHTS: bool = true;
override SCENE_HAS_EMISSIVE: bool = true;
override SCENE_HAS_ALPHA_TEST: bool = true;

@group(0) @binding(0) var<uniform> view: ViewUniform;
@group(0) @binding(1) var<storage, read> lights: array<GpuLight>;
@group(0) @binding(2) var<storage, read> materials: array<GpuMaterial>;
@group(0) @binding(3) var texture_atlas: texture_2d<f32>;
@group(0) @binding(4) var atlas_sampler: sampler;
@group(0) @binding(5) var<storage, read> vertices: array<GpuVertex>;
@group(0) @binding(6) var<storage, read> instances: array<GpuInstance>;
// Each instance's world_from_local of the previous frame (motion vectors).
@group(0) @binding(12) var<storage, read> instance_history: array<mat4x4<f32>>;
// The images again, in linear 8-bit (same rectangles): metallic-roughness and normal maps.
@group(0) @binding(13) var data_atlas: texture_2d<f32>;
// The specular lobe's split-sum table (engine::brdf::dfg_table).
@group(0) @binding(14) var<storage, read> brdf_dfg_table: array<vec2<f32>>;

#include "brdf.inc.wgsl"

// Clip position of world point `world` in this frame's raster: the view's projection shifted by
// the sub-pixel jitter. Every pass that rasterizes against the G-buffer uses it.
fn view_raster_position(world: vec4<f32>) -> vec4<f32> {
    var clip = view.clip_from_world * world;
    let shift = 2.0 * view.jitter / vec2<f32>(max(view.size, vec2<u32>(1u)));
    clip.x += shift.x * clip.w;
    clip.y -= shift.y * clip.w;
    return clip;
}

// Unit direction from the camera through a pixel centre of the (jittered) raster.
fn view_pixel_direction(pixel: vec2<u32>) -> vec3<f32> {
    let uv = (vec2<f32>(pixel) + 0.5 - view.jitter) / vec2<f32>(view.size);
    let h = view.world_from_clip * vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 1.0, 1.0);
    return safe_normalize(h.xyz / select(h.w, 1e-30, abs(h.w) < 1e-30) - view.camera_position, vec3<f32>(0.0, 0.0, -1.0));
}

fn sky_smoothstep(lo: f32, hi: f32, x: f32) -> f32 {
    let t = clamp((x - lo) / (hi - lo), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// The Perez function F(θ, γ) of coefficient set k (0: Y, 1: x, 2: y).
fn sky_perez(k: u32, cos_theta: f32, gamma: f32, cos_gamma: f32) -> f32 {
    let s = view.sky;
    return (1.0 + s.perez_a[k] * exp(s.perez_b[k] / max(cos_theta, 0.01)))
        * (1.0 + s.perez_c[k] * exp(s.perez_d[k] * gamma) + s.perez_e[k] * cos_gamma * cos_gamma)
        * s.normalization[k];
}

// Radiance of the sky along unit direction `dir` (engine::sky::radiance is its CPU mirror): what
// probe rays and bounced paths that escape see. `with_disk`: the sun's disk too (camera rays).
fn sky_radiance_along(dir_in: vec3<f32>, with_disk: bool) -> vec3<f32> {
    let s = view.sky;
    if s.zenith.w == 0.0 {
        return s.uniform.rgb;
    }
    let dir = safe_normalize(dir_in, vec3<f32>(0.0, 1.0, 0.0));
    let horizon = safe_normalize(vec3<f32>(dir.x, 0.0, dir.z), vec3<f32>(1.0, 0.0, 0.0));
    let up = safe_normalize(vec3<f32>(dir.x, max(dir.y, 0.0), dir.z), horizon);
    let cos_gamma = clamp(dot(up, s.sun_direction.xyz), -1.0, 1.0);
    let gamma = acos(cos_gamma);
    let cos_theta = max(up.y, 0.0);
    let luminance = s.zenith.x * sky_perez(0u, cos_theta, gamma, cos_gamma);
    let x = s.zenith.y * sky_perez(1u, cos_theta, gamma, cos_gamma);
    let y = max(s.zenith.z * sky_perez(2u, cos_theta, gamma, cos_gamma), 1e-4);
    let xyz = vec3<f32>(x / y * luminance, luminance, (1.0 - x - y) / y * luminance);
    let rgb = vec3<f32>(
        3.240454 * xyz.x - 1.5371385 * xyz.y - 0.4985314 * xyz.z,
        -0.969266 * xyz.x + 1.8760108 * xyz.y + 0.041556 * xyz.z,
        0.0556434 * xyz.x - 0.2040259 * xyz.y + 1.0572252 * xyz.z,
    );
    let below = sky_smoothstep(0.0, 0.034899497, -dir.y);
    var out = sanitize_radiance(rgb) * (vec3<f32>(1.0) + (s.ground_albedo.rgb - vec3<f32>(1.0)) * below);
    if with_disk && dot(dir, s.sun_direction.xyz) >= s.sun_direction.w {
        out += s.sun_radiance.rgb;
    }
    return max(sanitize_radiance(out), s.uniform.rgb);
}

fn sky_radiance(dir: vec3<f32>) -> vec3<f32> {
    return sky_radiance_along(dir, false);
}

// What a camera ray that escapes sees: the sky and the sun's disk.
fn sky_background(dir: vec3<f32>) -> vec3<f32> {
    return sky_radiance_along(dir, true);
}

// World position of a pixel centre of the (jittered) raster at a reverse-Z depth.
fn view_world_position(pixel: vec2<u32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(pixel) + 0.5 - view.jitter) / vec2<f32>(view.size);
    let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    let h = view.world_from_clip * ndc;
    return h.xyz / max(abs(h.w), 1e-30) * sign(h.w);
}

// A local-space normal direction in world space (not normalized): the inverse transpose of the
// instance's linear part.
fn instance_normal_to_world(instance: u32, n: vec3<f32>) -> vec3<f32> {
    let m = instances[instance].local_from_world;
    return transpose(mat3x3<f32>(m[0].xyz, m[1].xyz, m[2].xyz)) * n;
}

// Where a texture slot puts `uv` in the atlas (the same in both atlases).
fn slot_atlas_position(slot: TextureSlot, uv: vec2<f32>) -> vec2<f32> {
    let t = vec2<f32>(dot(slot.uv_x.xy, uv) + slot.uv_x.z, dot(slot.uv_y.xy, uv) + slot.uv_y.z);
    var wrapped = fract(t);
    let texels = vec2<f32>(slot.uv_x.w, slot.uv_y.w);
    if texels.x > 0.0 && texels.y > 0.0 {
        wrapped = (min(floor(wrapped * texels), texels - 1.0) + 0.5) / texels;
    }
    let half_texel = 0.5 / vec2<f32>(textureDimensions(texture_atlas));
    return slot.rect.xy + clamp(wrapped * slot.rect.zw, half_texel, max(slot.rect.zw - half_texel, half_texel));
}

// A colour texture (sRGB-encoded, decoded by the sampler); 1 without one.
fn sample_slot(slot: TextureSlot, uv: vec2<f32>) -> vec4<f32> {
    if slot.rect.z <= 0.0 {
        return vec4<f32>(1.0);
    }
    return textureSampleLevel(texture_atlas, atlas_sampler, slot_atlas_position(slot, uv), 0.0);
}

// A data texture (linear); `fallback` without one.
fn sample_data_slot(slot: TextureSlot, uv: vec2<f32>, fallback: vec4<f32>) -> vec4<f32> {
    if slot.rect.z <= 0.0 {
        return fallback;
    }
    return textureSampleLevel(data_atlas, atlas_sampler, slot_atlas_position(slot, uv), 0.0);
}

// Whether material `index` is alpha-masked (its cutoff above 0): a card, a leaf, a fence — a
// single surface seen from both sides, never the skin of a closed solid.
fn material_is_masked(index: u32) -> bool {
    return SCENE_HAS_ALPHA_TEST && materials[index].emissive.w > 0.0;
}

// Whether material `index` cuts the texel at uv out (alpha-masked materials: the base colour's
// alpha, factor × texture, below the material's cutoff). Opaque materials cut nothing and sample no
// texture.
fn material_cuts(index: u32, uv: vec2<f32>) -> bool {
    if !SCENE_HAS_ALPHA_TEST {
        return false;
    }
    if !material_is_masked(index) {
        return false;
    }
    let m = materials[index];
    return m.base_color.a * sample_slot(m.base_color_texture, uv).a < m.emissive.w;
}

struct SurfaceMaterial {
    albedo: vec3<f32>,
    emissive: vec3<f32>,
    metallic: f32,
    roughness: f32,
    specular: f32,
    // The normal map's tangent-space normal (0, 0, 1 without one), its xy scaled.
    tangent_normal: vec3<f32>,
}

fn eval_material(index: u32, uv: vec2<f32>) -> SurfaceMaterial {
    let m = materials[index];
    var out: SurfaceMaterial;
    out.albedo = clamp(m.base_color.rgb * sample_slot(m.base_color_texture, uv).rgb, vec3<f32>(0.0), vec3<f32>(1.0));
    out.emissive = vec3<f32>(0.0);
    if SCENE_HAS_EMISSIVE {
        out.emissive = sanitize_radiance(m.emissive.rgb * sample_slot(m.emissive_texture, uv).rgb);
    }
    let mr = sample_data_slot(m.metallic_roughness_texture, uv, vec4<f32>(1.0));
    out.metallic = clamp(m.pbr.x * mr.b, 0.0, 1.0);
    out.roughness = clamp(m.pbr.y * mr.g, 0.0, 1.0);
    out.specular = clamp(m.pbr.z, 0.0, 1.0);
    out.tangent_normal = vec3<f32>(0.0, 0.0, 1.0);
    if m.normal_texture.rect.z > 0.0 {
        let t = sample_data_slot(m.normal_texture, uv, vec4<f32>(0.5, 0.5, 1.0, 1.0)).xyz * 2.0 - 1.0;
        out.tangent_normal = vec3<f32>(t.xy * m.pbr.w, t.z);
    }
    return out;
}

// The shading normal: unit normal n bent by a tangent-space normal (tangent t, handedness in w);
// n itself without a tangent or a map.
fn apply_normal_map(n: vec3<f32>, tangent: vec4<f32>, tangent_normal: vec3<f32>) -> vec3<f32> {
    if all(tangent_normal.xy == vec2<f32>(0.0)) {
        return n;
    }
    let t = tangent.xyz - n * dot(n, tangent.xyz);
    if !(dot(t, t) > 1e-12) {
        return n;
    }
    let tu = normalize(t);
    let b = cross(n, tu) * select(1.0, -1.0, tangent.w < 0.0);
    return safe_normalize(tu * tangent_normal.x + b * tangent_normal.y + n * tangent_normal.z, n);
}

// A tangent in world space (the linear part of the instance's transform; w kept).
fn instance_tangent_to_world(instance: u32, t: vec4<f32>) -> vec4<f32> {
    let m = instances[instance].world_from_local;
    return vec4<f32>(mat3x3<f32>(m[0].xyz, m[1].xyz, m[2].xyz) * t.xyz, t.w);
}

// The BRDF's view of a surface's material.
fn brdf_surface(m: SurfaceMaterial) -> BrdfSurface {
    return BrdfSurface(m.albedo, m.metallic, m.roughness, m.specular);
}

// Irradiance that light `l` delivers at point p with normal n, ignoring occlusion, and the unit
// direction towards the light with its distance (for shadow rays).
struct LightSample {
    irradiance: vec3<f32>,
    to_light: vec3<f32>,
    distance: f32,
}

fn sample_light(l: GpuLight, p: vec3<f32>, n: vec3<f32>) -> LightSample {
    var s: LightSample;
    if l.kind == LIGHT_DIRECTIONAL {
        s.to_light = safe_normalize(-l.direction, vec3<f32>(0.0, 1.0, 0.0));
        s.distance = 3.0e38;
        s.irradiance = l.radiance * max(dot(n, s.to_light), 0.0);
        return s;
    }
    let d = l.position - p;
    let dist2 = max(dot(d, d), 1e-8);
    s.distance = sqrt(dist2);
    s.to_light = d / s.distance;
    var attenuation = 1.0 / dist2;
    if l.range > 0.0 {
        let ratio = s.distance / l.range;
        let window = clamp(1.0 - ratio * ratio * ratio * ratio, 0.0, 1.0);
        attenuation *= window;
    }
    if SCENE_HAS_SPOT_LIGHTS && l.kind == LIGHT_SPOT {
        let cd = dot(safe_normalize(l.direction, vec3<f32>(0.0, -1.0, 0.0)), -s.to_light);
        let a = clamp(cd * l.spot_scale + l.spot_offset, 0.0, 1.0);
        attenuation *= a * a;
    }
    s.irradiance = l.radiance * attenuation * max(dot(n, s.to_light), 0.0);
    return s;
}

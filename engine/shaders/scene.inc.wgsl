// The scene as the GPU sees it: bind group 0, shared by every pass that looks at the scene.
// Host mirrors of these structs live in engine/src/render/gpu_types.rs (a test compares sizes).
#include "common.inc.wgsl"

struct ViewUniform {
    clip_from_world: mat4x4<f32>,
    world_from_clip: mat4x4<f32>,
    camera_position: vec3<f32>,
    exposure: f32,
    sky_radiance: vec3<f32>,
    light_count: u32,
    size: vec2<u32>,
    frame: u32,
    _pad: u32,
}

struct GpuVertex {
    position: vec3<f32>,
    u: f32,
    normal: vec3<f32>,
    v: f32,
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
struct TextureSlot {
    uv_x: vec4<f32>,
    uv_y: vec4<f32>,
    rect: vec4<f32>,
}

struct GpuMaterial {
    base_color: vec4<f32>,
    // Emitted radiance factor, emissive strength included.
    emissive: vec4<f32>,
    base_color_texture: TextureSlot,
    emissive_texture: TextureSlot,
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

// Pipeline constants: a pipeline built for a scene without spot lights or without emissive
// materials sets these to false, and the spot cone or the emission lookup is compiled out.
override SCENE_HAS_SPOT_LIGHTS: bool = true;
override SCENE_HAS_EMISSIVE: bool = true;

@group(0) @binding(0) var<uniform> view: ViewUniform;
@group(0) @binding(1) var<storage, read> lights: array<GpuLight>;
@group(0) @binding(2) var<storage, read> materials: array<GpuMaterial>;
@group(0) @binding(3) var texture_atlas: texture_2d<f32>;
@group(0) @binding(4) var atlas_sampler: sampler;
@group(0) @binding(5) var<storage, read> vertices: array<GpuVertex>;
@group(0) @binding(6) var<storage, read> instances: array<GpuInstance>;

// World position of a pixel centre at a reverse-Z depth.
fn view_world_position(pixel: vec2<u32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(pixel) + 0.5) / vec2<f32>(view.size);
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

fn sample_slot(slot: TextureSlot, uv: vec2<f32>) -> vec4<f32> {
    if slot.rect.z <= 0.0 {
        return vec4<f32>(1.0);
    }
    let t = vec2<f32>(dot(slot.uv_x.xy, uv) + slot.uv_x.z, dot(slot.uv_y.xy, uv) + slot.uv_y.z);
    let wrapped = fract(t);
    let half_texel = 0.5 / vec2<f32>(textureDimensions(texture_atlas));
    let p = slot.rect.xy + clamp(wrapped * slot.rect.zw, half_texel, max(slot.rect.zw - half_texel, half_texel));
    return textureSampleLevel(texture_atlas, atlas_sampler, p, 0.0);
}

struct SurfaceMaterial {
    albedo: vec3<f32>,
    emissive: vec3<f32>,
}

fn eval_material(index: u32, uv: vec2<f32>) -> SurfaceMaterial {
    let m = materials[index];
    var out: SurfaceMaterial;
    out.albedo = clamp(m.base_color.rgb * sample_slot(m.base_color_texture, uv).rgb, vec3<f32>(0.0), vec3<f32>(1.0));
    out.emissive = vec3<f32>(0.0);
    if SCENE_HAS_EMISSIVE {
        out.emissive = sanitize_radiance(m.emissive.rgb * sample_slot(m.emissive_texture, uv).rgb);
    }
    return out;
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

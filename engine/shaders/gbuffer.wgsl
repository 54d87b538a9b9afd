// G-buffer raster pass, per pixel for the nearest surface: the shading normal (normal map applied)
// and roughness, base colour and metallic, emission and specular weight, and screen motion.
#include "scene.inc.wgsl"

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) @interpolate(flat) material: u32,
    // Unjittered clip positions of this frame and of the previous one (motion vectors).
    @location(3) current: vec4<f32>,
    @location(4) previous: vec4<f32>,
    @location(5) tangent: vec4<f32>,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> VertexOut {
    let instance = instances[instance_index];
    let v = vertices[vertex_index];
    var out: VertexOut;
    let local = vec4<f32>(v.position, 1.0);
    let world = instance.world_from_local * local;
    out.clip = view_raster_position(world);
    out.current = view.clip_from_world * world;
    out.previous = view.previous_clip_from_world * (instance_history[instance_index] * local);
    out.normal = instance_normal_to_world(instance_index, v.normal);
    out.tangent = instance_tangent_to_world(instance_index, v.tangent);
    out.uv = vec2<f32>(v.u, v.v);
    out.material = instance.material;
    return out;
}

struct GBufferOut {
    // Shading normal, roughness.
    @location(0) normal: vec4<f32>,
    // Base colour, metallic.
    @location(1) albedo: vec4<f32>,
    // Emitted radiance, specular weight.
    @location(2) emissive: vec4<f32>,
    @location(3) motion: vec4<f32>,
}

// Screen position (0–1, y down) of a clip position; the centre for a point at or behind the eye.
fn clip_to_uv(clip: vec4<f32>) -> vec2<f32> {
    if !(clip.w > 1e-30) {
        return vec2<f32>(0.5);
    }
    let ndc = clip.xy / clip.w;
    return vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> GBufferOut {
    // Alpha-masked texels are not there.
    if material_cuts(in.material, in.uv) {
        discard;
    }
    // Surfaces are two-sided: the normal faces the viewer.
    var n = safe_normalize(in.normal, vec3<f32>(0.0, 1.0, 0.0));
    if !front_facing {
        n = -n;
    }
    let m = eval_material(in.material, in.uv);
    n = apply_normal_map(n, in.tangent, m.tangent_normal);
    var out: GBufferOut;
    out.normal = vec4<f32>(n, m.roughness);
    out.albedo = vec4<f32>(m.albedo, m.metallic);
    out.emissive = vec4<f32>(min(m.emissive, vec3<f32>(HALF_MAX)), m.specular);
    // Where the surface point was on the screen in the previous frame, as an offset from where it
    // is now (screen units; the temporal anti-aliasing reprojects its history by it).
    let motion = clip_to_uv(in.current) - clip_to_uv(in.previous);
    out.motion = vec4<f32>(clamp(motion, vec2<f32>(-HALF_MAX), vec2<f32>(HALF_MAX)), 0.0, 1.0);
    return out;
}

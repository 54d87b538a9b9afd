// G-buffer raster pass: world normal, albedo and emission of the nearest surface per pixel.
#include "scene.inc.wgsl"

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) uv: vec2<f32>,
    @location(2) @interpolate(flat) material: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex_index: u32, @builtin(instance_index) instance_index: u32) -> VertexOut {
    let instance = instances[instance_index];
    let v = vertices[vertex_index];
    var out: VertexOut;
    let world = instance.world_from_local * vec4<f32>(v.position, 1.0);
    out.clip = view.clip_from_world * world;
    out.normal = instance_normal_to_world(instance_index, v.normal);
    out.uv = vec2<f32>(v.u, v.v);
    out.material = instance.material;
    return out;
}

struct GBufferOut {
    @location(0) normal: vec4<f32>,
    @location(1) albedo: vec4<f32>,
    @location(2) emissive: vec4<f32>,
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> GBufferOut {
    // Surfaces are two-sided: the normal faces the viewer.
    var n = safe_normalize(in.normal, vec3<f32>(0.0, 1.0, 0.0));
    if !front_facing {
        n = -n;
    }
    let m = eval_material(in.material, in.uv);
    var out: GBufferOut;
    out.normal = vec4<f32>(n, 1.0);
    out.albedo = vec4<f32>(m.albedo, 1.0);
    out.emissive = vec4<f32>(min(m.emissive, vec3<f32>(HALF_MAX)), 1.0);
    return out;
}

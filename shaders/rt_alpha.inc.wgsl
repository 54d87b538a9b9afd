// The traversal's alpha test (any-hit) for masked materials (engine::scene::AlphaMode): what
// ray_tracing.inc.wgsl calls when a ray enters an instance and at each of its candidate hits.
// Reads the materials, vertices and indices; rt_opaque.inc.wgsl is the variant without.
#include "ray_tracing.inc.wgsl"

// Whether the instance is drawn with a material that cuts texels (read once as a ray enters it).
fn rt_instance_alpha_tested(instance: u32) -> bool {
    return material_is_masked(instances[instance].material);
}

// Whether the candidate hit at `barycentrics` of the triangle stored at `index` of blas_triangles,
// in `instance`, falls on a texel its alpha-masked material cuts out (any-hit alpha test). Static
// groups hold no alpha-tested instance (engine/src/rt/groups.rs), so the instance is the triangle's.
fn rt_alpha_cuts(instance: u32, index: u32, barycentrics: vec2<f32>) -> bool {
    let inst = instances[instance];
    let blas = blas_info[inst.mesh];
    let base = blas.first_index + 3u * bitcast<u32>(blas_triangles[index * 3u].w);
    let a = vertices[indices[base] + blas.base_vertex];
    let b = vertices[indices[base + 1u] + blas.base_vertex];
    let c = vertices[indices[base + 2u] + blas.base_vertex];
    let w = vec3<f32>(1.0 - barycentrics.x - barycentrics.y, barycentrics.x, barycentrics.y);
    let uv = vec2<f32>(a.u, a.v) * w.x + vec2<f32>(b.u, b.v) * w.y + vec2<f32>(c.u, c.v) * w.z;
    return material_cuts(inst.material, uv);
}


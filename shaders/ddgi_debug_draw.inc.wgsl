// What DDGI's debug draws share: the probe sphere's tessellation and the false-colour ramp. Included
// by the probe spheres (`ddgi_probe_spheres.wgsl`) and by any crate's debug view of the probes
// (e.g. `ddgi_overlay`'s distance spheres), so that all of them draw the same sphere.
#include "common.inc.wgsl"

// The sphere's tessellation: a draw takes 6 · rings · segments vertices per sphere (two triangles
// per ring × segment), read from here by the plugins through naga (ddgi::debug_view::probe_sphere_vertices).
const SPHERE_RINGS: u32 = 8u;
const SPHERE_SEGMENTS: u32 = 12u;

// The unit normal of vertex `vertex` (0 to 6 · rings · segments − 1) of the tessellated sphere:
// the point on the unit sphere it stands at.
fn ddgi_sphere_normal(vertex: u32) -> vec3<f32> {
    let du = array<u32, 6>(0u, 1u, 1u, 0u, 1u, 0u);
    let dv = array<u32, 6>(0u, 0u, 1u, 0u, 1u, 1u);
    let quad = vertex / 6u;
    let corner = vertex % 6u;
    let ring = quad / SPHERE_SEGMENTS + dv[corner];
    let segment = quad % SPHERE_SEGMENTS + du[corner];
    let theta = PI * f32(ring) / f32(SPHERE_RINGS);
    let phi = 2.0 * PI * f32(segment) / f32(SPHERE_SEGMENTS);
    return vec3<f32>(sin(theta) * cos(phi), cos(theta), sin(theta) * sin(phi));
}

// Blue → green → yellow → red as t goes 0 → 1.
fn ddgi_heat(t_in: f32) -> vec3<f32> {
    let t = clamp(t_in, 0.0, 1.0);
    return clamp(vec3<f32>(1.5 * t - 0.25, 1.0 - abs(2.0 * t - 1.0) * 0.8, 1.0 - 2.0 * t), vec3<f32>(0.0), vec3<f32>(1.0));
}

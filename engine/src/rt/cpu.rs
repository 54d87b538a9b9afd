//! A brute-force CPU reference for the GPU traversal: every triangle of every instance, in world space.

use glam::{Affine3A, Vec3};

use crate::scene::Mesh;

/// A ray as the GPU reads it (mirrors WGSL `Ray`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable, PartialEq)]
pub struct GpuRay {
    /// Origin in world space (world units).
    pub origin: [f32; 3],
    /// Distance along `direction` where the ray starts (in lengths of `direction`).
    pub tmin: f32,
    /// Direction in world space; need not be normalized (`t` is measured in its lengths).
    pub direction: [f32; 3],
    /// Distance along `direction` where the ray ends.
    pub tmax: f32,
}

/// A hit as the GPU writes it (mirrors WGSL `TraceResult` in `trace_rays.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable, PartialEq)]
pub struct TraceResult {
    /// Hit distance along the ray, in lengths of its direction (meaningless for a miss).
    pub t: f32,
    /// Instance slot, or `u32::MAX` for a miss.
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
    /// Bit 0: front face.
    pub flags: u32,
    /// Barycentric weights of the triangle's second and third vertices at the hit (the first gets
    /// 1 − x − y).
    pub barycentrics: [f32; 2],
    /// 1 when any-hit reported an occluder.
    pub any_hit: u32,
    /// Padding to the WGSL layout.
    pub _pad: u32,
    /// Base colour at the hit (RGB, w unused), textures applied.
    pub albedo: [f32; 4],
    /// Emitted radiance at the hit (RGB, w unused).
    pub emissive: [f32; 4],
}

/// The closest hit found by the CPU reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuHit {
    /// Hit distance along the ray, in lengths of its direction.
    pub t: f32,
    /// Instance slot of the hit.
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
    /// Whether the ray hit the triangle's front face (counter-clockwise winding).
    pub front_face: bool,
}

/// World-space triangles of a set of instances, tagged with (instance slot, triangle index).
pub struct CpuScene {
    triangles: Vec<([Vec3; 3], u32, u32)>,
}

impl CpuScene {
    /// `instances`: (slot, mesh, world transform); `meshes`: by mesh index.
    pub fn new(instances: &[(u32, u32, Affine3A)], meshes: &[&Mesh]) -> Self {
        let mut triangles = Vec::new();
        for &(slot, mesh, world) in instances {
            let Some(mesh) = meshes.get(mesh as usize) else { continue };
            for (prim, tri) in mesh.indices.chunks_exact(3).enumerate() {
                let v = [tri[0], tri[1], tri[2]].map(|i| world.transform_point3(mesh.positions[i as usize]));
                triangles.push((v, slot, prim as u32));
            }
        }
        Self { triangles }
    }

    /// Closest hit with t in [tmin, tmax), in f64 so that it is a trustworthy reference.
    pub fn closest_hit(&self, ray: &GpuRay) -> Option<CpuHit> {
        let mut best: Option<CpuHit> = None;
        let mut best_t = f64::from(ray.tmax);
        for (v, slot, prim) in &self.triangles {
            if let Some((t, det)) = intersect(ray, v)
                && t < best_t
            {
                best_t = t;
                best = Some(CpuHit { t: t as f32, instance: *slot, primitive: *prim, front_face: det > 0.0 });
            }
        }
        best
    }

    /// Distance at which the ray meets one given triangle, if it does.
    pub fn hit_t(&self, ray: &GpuRay, instance: u32, primitive: u32) -> Option<f32> {
        let (v, ..) = self.triangles.iter().find(|(_, s, p)| *s == instance && *p == primitive)?;
        intersect(ray, v).filter(|&(t, _)| t < f64::from(ray.tmax)).map(|(t, _)| t as f32)
    }
}

/// Möller–Trumbore in f64: (t, determinant) when the ray meets the triangle at t ≥ tmin.
fn intersect(ray: &GpuRay, v: &[Vec3; 3]) -> Option<(f64, f64)> {
    let o = Vec3::from(ray.origin).as_dvec3();
    let d = Vec3::from(ray.direction).as_dvec3();
    let [v0, v1, v2] = v.map(|p| p.as_dvec3());
    let (e1, e2) = (v1 - v0, v2 - v0);
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tvec = o - v0;
    let u = tvec.dot(pvec) * inv;
    let qvec = tvec.cross(e1);
    let w = d.dot(qvec) * inv;
    let t = e2.dot(qvec) * inv;
    (u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t >= f64::from(ray.tmin)).then_some((t, det))
}

/// `count` unit directions covering the sphere evenly (spherical Fibonacci, y up): CPU-side ray
/// sets for tests and checks.
pub fn fibonacci_directions(count: usize) -> Vec<Vec3> {
    let golden_angle = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    (0..count)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / count as f32;
            let r = (1.0 - y * y).max(0.0).sqrt();
            let phi = golden_angle * i as f32;
            Vec3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect()
}

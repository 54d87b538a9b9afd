//! Support for the workspace tests: CPU ray geometry and mesh invariants. GPU access, FLIP and
//! golden images are the shared `testkit`'s.

/// Geometry helpers shared by the CPU-side ray tests.
pub mod cpu_rays {
    use glam::Vec3;

    /// Hits within this distance of the ray origin are ignored (the origin may sit on a surface).
    pub const RAY_EPSILON: f32 = 1e-4;
    /// Barycentric tolerance, so rays through shared edges do not slip between two triangles.
    pub const BARYCENTRIC_SLACK: f32 = 1e-5;

    /// Möller–Trumbore, two-sided: the distance along `dir` to triangle `abc`, if it is hit beyond
    /// [`RAY_EPSILON`].
    pub fn intersect(origin: Vec3, dir: Vec3, [a, b, c]: [Vec3; 3]) -> Option<f32> {
        let e1 = b - a;
        let e2 = c - a;
        let p = dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = origin - a;
        let u = s.dot(p) * inv;
        if !(-BARYCENTRIC_SLACK..=1.0 + BARYCENTRIC_SLACK).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = dir.dot(q) * inv;
        if v < -BARYCENTRIC_SLACK || u + v > 1.0 + BARYCENTRIC_SLACK {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > RAY_EPSILON).then_some(t)
    }

    pub use engine::rt::cpu::fibonacci_directions;
}

/// How far from 1 a unit normal's length may be.
pub const MESH_UNIT_TOLERANCE: f32 = 1e-4;

/// Asserts the mesh invariants of [`engine::scene::Mesh`] and that every triangle is wound
/// counter-clockwise seen from the side its vertex normals face.
pub fn assert_valid_mesh(scene: &str, mesh: &engine::scene::Mesh) {
    let name = &mesh.name;
    assert!(!mesh.positions.is_empty(), "{scene}/{name}: empty mesh");
    assert_eq!(mesh.normals.len(), mesh.positions.len(), "{scene}/{name}: one normal per vertex");
    assert!(mesh.uvs.is_empty() || mesh.uvs.len() == mesh.positions.len(), "{scene}/{name}: uvs either absent or one per vertex");
    assert!(mesh.positions.iter().all(|p| p.is_finite()), "{scene}/{name}: non-finite position");
    assert!(mesh.uvs.iter().all(|uv| uv.is_finite()), "{scene}/{name}: non-finite uv");
    for n in &mesh.normals {
        assert!(n.is_finite() && (n.length() - 1.0).abs() < MESH_UNIT_TOLERANCE, "{scene}/{name}: normal {n} is not unit length");
    }
    assert!(!mesh.indices.is_empty(), "{scene}/{name}: no triangles");
    assert_eq!(mesh.indices.len() % 3, 0, "{scene}/{name}: index count not a multiple of 3");
    let count = mesh.positions.len() as u32;
    assert!(mesh.indices.iter().all(|&i| i < count), "{scene}/{name}: index out of range");
    for tri in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let face = (b - a).cross(c - a);
        assert!(face.length() > 1e-8, "{scene}/{name}: degenerate triangle {tri:?}");
        for &i in tri {
            assert!(face.dot(mesh.normals[i as usize]) > 0.0, "{scene}/{name}: triangle {tri:?} is wound against its normals");
        }
    }
}

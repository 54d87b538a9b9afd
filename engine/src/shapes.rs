//! Mesh primitives for building geometry in code: a [`quad`], a [`cuboid`], several meshes
//! [`merge`]d into one, boxes by their corners ([`box_part`]), slabs with a hole cut through
//! ([`box_with_hole`]) and closed rooms of thick slabs ([`Shell`], [`closed_shell`]).
//!
//! The built-in scenes (the `scenes` crate), tests and apps build their geometry from these. Every
//! mesh has one unit normal per vertex and counter-clockwise triangles seen from the side the
//! normals face; boxes are closed solids. Conventions: Y is up, one unit is a metre. Building costs
//! time and memory linear in the vertices produced, nothing on the GPU.

use glam::{Affine3A, Vec2, Vec3};

use crate::scene::Mesh;

/// A `size.x` × `size.y` rectangle in the XZ plane, centred on the origin and facing +Y (counter-
/// clockwise seen from above), with texture coordinates from 0 to 1 (u along +X, v along +Z).
pub fn quad(name: &str, size: Vec2) -> Mesh {
    let h = size * 0.5;
    Mesh {
        name: name.into(),
        positions: vec![Vec3::new(-h.x, 0.0, -h.y), Vec3::new(h.x, 0.0, -h.y), Vec3::new(h.x, 0.0, h.y), Vec3::new(-h.x, 0.0, h.y)],
        normals: vec![Vec3::Y; 4],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![0, 3, 2, 0, 2, 1],
        ..Default::default()
    }
}

/// The six faces of a box as (outward normal, tangent u, tangent v), with `u × v = normal` so that
/// corners listed counter-clockwise in (u, v) are counter-clockwise seen from outside.
const CUBOID_FACES: [(Vec3, Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::NEG_Z, Vec3::Y),
    (Vec3::NEG_X, Vec3::Z, Vec3::Y),
    (Vec3::Y, Vec3::X, Vec3::NEG_Z),
    (Vec3::NEG_Y, Vec3::X, Vec3::Z),
    (Vec3::Z, Vec3::X, Vec3::Y),
    (Vec3::NEG_Z, Vec3::NEG_X, Vec3::Y),
];

/// A face's corners as signs along (u, v), counter-clockwise, with their texture coordinates (v
/// grows downwards, as image rows do, so textures stand upright on the side faces).
const FACE_CORNERS: [(f32, f32, Vec2); 4] = [
    (-1.0, -1.0, Vec2::new(0.0, 1.0)),
    (1.0, -1.0, Vec2::new(1.0, 1.0)),
    (1.0, 1.0, Vec2::new(1.0, 0.0)),
    (-1.0, 1.0, Vec2::new(0.0, 0.0)),
];

/// An axis-aligned box centred on the origin: 24 vertices (4 per face, so that every face has its
/// own flat outward normal and 0–1 texture coordinates) and 12 counter-clockwise triangles.
pub fn cuboid(name: &str, half_extents: Vec3) -> Mesh {
    let mut mesh = Mesh { name: name.into(), ..Default::default() };
    for (normal, u, v) in CUBOID_FACES {
        let base = mesh.positions.len() as u32;
        for (su, sv, uv) in FACE_CORNERS {
            mesh.positions.push((normal + u * su + v * sv) * half_extents);
            mesh.normals.push(normal);
            mesh.uvs.push(uv);
        }
        mesh.indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
    mesh
}

/// One mesh made of several, each placed by its transform: positions are transformed as points,
/// normals by the inverse transpose (then renormalised), and mirroring transforms get their winding
/// reversed so that triangles stay counter-clockwise seen from the side their normals face. The
/// transforms must be invertible. Texture coordinates are kept when any part has them (parts
/// without get zeros); parts without normals get area-weighted ones.
pub fn merge(name: &str, parts: &[(Mesh, Affine3A)]) -> Mesh {
    let any_uvs = parts.iter().any(|(mesh, _)| !mesh.uvs.is_empty());
    let mut out = Mesh { name: name.into(), ..Default::default() };
    for (mesh, transform) in parts {
        let base = out.positions.len() as u32;
        let normal_matrix = transform.matrix3.inverse().transpose();
        let mirrored = transform.matrix3.determinant() < 0.0;
        let normals = if mesh.normals.len() == mesh.positions.len() {
            mesh.normals.clone()
        } else {
            let mut with_normals = mesh.clone();
            with_normals.compute_normals();
            with_normals.normals
        };
        out.positions.extend(mesh.positions.iter().map(|&p| transform.transform_point3(p)));
        out.normals.extend(normals.iter().map(|&n| (normal_matrix * n).normalize_or(n)));
        if any_uvs {
            if mesh.uvs.len() == mesh.positions.len() {
                out.uvs.extend_from_slice(&mesh.uvs);
            } else {
                out.uvs.extend(std::iter::repeat_n(Vec2::ZERO, mesh.positions.len()));
            }
        }
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| base + i);
            out.indices.extend(if mirrored { [a, c, b] } else { [a, b, c] });
        }
    }
    out
}

/// The box spanning `min`..`max` as a [`merge`] part: a [`cuboid`] and the translation to its centre.
pub fn box_part(min: Vec3, max: Vec3) -> (Mesh, Affine3A) {
    (cuboid("", (max - min) * 0.5), Affine3A::from_translation((min + max) * 0.5))
}

/// The slab `min`..`max` with a rectangular hole `hole_min`..`hole_max` cut right through its
/// thinnest axis, as up to four [`merge`] parts. The pieces beside the hole and those above and
/// below it overlap, so the slab stays watertight around the hole. A hole that misses the slab
/// leaves it whole.
pub fn box_with_hole(min: Vec3, max: Vec3, hole_min: Vec3, hole_max: Vec3) -> Vec<(Mesh, Affine3A)> {
    let size = max - min;
    let normal_axis = if size.x <= size.y && size.x <= size.z {
        0
    } else if size.y <= size.z {
        1
    } else {
        2
    };
    let (hole_min, hole_max) = (hole_min.max(min), hole_max.min(max));
    let in_plane = [(normal_axis + 1) % 3, (normal_axis + 2) % 3];
    if in_plane.iter().any(|&axis| hole_min[axis] >= hole_max[axis]) {
        return vec![box_part(min, max)];
    }
    let mut parts = Vec::new();
    // For each in-plane axis, the strips before and after the hole span the slab's whole extent
    // along the other axis, so the strips of the two axes overlap at the hole's corners.
    for axis in in_plane {
        if hole_min[axis] > min[axis] {
            let mut upper = max;
            upper[axis] = hole_min[axis];
            parts.push(box_part(min, upper));
        }
        if hole_max[axis] < max[axis] {
            let mut lower = min;
            lower[axis] = hole_max[axis];
            parts.push(box_part(lower, max));
        }
    }
    parts
}

/// The slabs around an interior box. Every slab spans the whole outer box along the two axes it does
/// not close, so neighbouring slabs overlap along the room's edges and corners.
pub struct Shell {
    /// The interior's lowest corner (world units).
    pub inner_min: Vec3,
    /// The interior's highest corner (world units).
    pub inner_max: Vec3,
    /// The outer box's lowest corner: `inner_min` less the thickness.
    pub outer_min: Vec3,
    /// The outer box's highest corner: `inner_max` plus the thickness.
    pub outer_max: Vec3,
}

impl Shell {
    /// The shell `thickness` thick on every side of the interior `inner_min..inner_max`.
    pub fn around(inner_min: Vec3, inner_max: Vec3, thickness: f32) -> Self {
        Self { inner_min, inner_max, outer_min: inner_min - thickness, outer_max: inner_max + thickness }
    }

    /// The slab closing the interior on the `positive` or negative side of `axis`, as (min, max).
    pub fn slab(&self, axis: usize, positive: bool) -> (Vec3, Vec3) {
        let (mut min, mut max) = (self.outer_min, self.outer_max);
        if positive {
            min[axis] = self.inner_max[axis];
        } else {
            max[axis] = self.inner_min[axis];
        }
        (min, max)
    }

    /// The slab as a single [`merge`] part.
    pub fn slab_part(&self, axis: usize, positive: bool) -> (Mesh, Affine3A) {
        let (min, max) = self.slab(axis, positive);
        box_part(min, max)
    }

    /// The slab with the hole `hole_min..hole_max` cut through it, as [`box_with_hole`] parts.
    pub fn slab_with_hole(&self, axis: usize, positive: bool, hole_min: Vec3, hole_max: Vec3) -> Vec<(Mesh, Affine3A)> {
        let (min, max) = self.slab(axis, positive);
        box_with_hole(min, max, hole_min, hole_max)
    }
}

/// A closed box of solid slabs `thickness` thick around the interior `inner_min..inner_max` (every
/// slab spans the whole outer box along the two axes it does not close).
pub fn closed_shell(name: &str, inner_min: Vec3, inner_max: Vec3, thickness: f32) -> Mesh {
    let shell = Shell::around(inner_min, inner_max, thickness);
    let parts: Vec<_> = [X, Y, Z].into_iter().flat_map(|axis| [shell.slab_part(axis, false), shell.slab_part(axis, true)]).collect();
    merge(name, &parts)
}

/// The X axis: axis indices for [`Shell::slab`] and its kin.
pub const X: usize = 0;
/// The Y axis (up).
pub const Y: usize = 1;
/// The Z axis.
pub const Z: usize = 2;

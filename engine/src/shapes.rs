//! Mesh primitives for building geometry in code: a [`quad`], a [`cuboid`], several meshes
//! [`merge`]d into one, boxes by their corners ([`box_part`]), slabs with a hole cut through
//! ([`box_with_hole`]), closed rooms of thick slabs ([`Shell`], [`closed_shell`]) and faceted
//! convex solids for low-poly props: a [`prism`] of any convex outline, a [`pyramid`] and an
//! [`icosphere`]. [`is_closed`] checks that a mesh is watertight.
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

/// A mesh of flat-shaded convex polygons (each face its own vertices and normal): the low-poly
/// solids below.
struct Faceted(Mesh);

impl Faceted {
    fn new(name: &str) -> Self {
        Self(Mesh { name: name.into(), ..Default::default() })
    }

    /// The planar convex polygon `corners` (in order around it, either way) as a fan of triangles,
    /// wound counter-clockwise seen from the side `outward` points to.
    fn face(&mut self, corners: &[Vec3], outward: Vec3) {
        if corners.len() < 3 {
            return;
        }
        let mut normal = Vec3::ZERO;
        for i in 1..corners.len() - 1 {
            normal += (corners[i] - corners[0]).cross(corners[i + 1] - corners[0]);
        }
        let flip = normal.dot(outward) < 0.0;
        let normal = if flip { -normal } else { normal }.normalize_or(outward.normalize_or(Vec3::Y));
        let base = self.0.positions.len() as u32;
        self.0.positions.extend_from_slice(corners);
        self.0.normals.extend(std::iter::repeat_n(normal, corners.len()));
        for i in 1..corners.len() as u32 - 1 {
            let (b, c) = if flip { (i + 1, i) } else { (i, i + 1) };
            self.0.indices.extend([base, base + b, base + c]);
        }
    }
}

/// The convex polygon `outline` (corners in the XZ plane as (x, z), in order around it, either way)
/// extruded from height `y0` to `y1`: a closed solid with flat faces (a box, a hexagonal column, a
/// chamfered slab), `2 (n − 2) + 2 n` triangles for `n` corners. Transform it with [`merge`] to
/// lay it along another axis.
pub fn prism(name: &str, outline: &[Vec2], y0: f32, y1: f32) -> Mesh {
    let (y0, y1) = (y0.min(y1), y0.max(y1));
    let mut out = Faceted::new(name);
    let center = outline.iter().copied().sum::<Vec2>() / outline.len().max(1) as f32;
    let at = |p: Vec2, y: f32| Vec3::new(p.x, y, p.y);
    out.face(&outline.iter().map(|&p| at(p, y1)).collect::<Vec<_>>(), Vec3::Y);
    out.face(&outline.iter().map(|&p| at(p, y0)).collect::<Vec<_>>(), Vec3::NEG_Y);
    for (i, &a) in outline.iter().enumerate() {
        let b = outline[(i + 1) % outline.len()];
        let outward = (a + b) * 0.5 - center;
        out.face(&[at(a, y0), at(b, y0), at(b, y1), at(a, y1)], Vec3::new(outward.x, 0.0, outward.y));
    }
    out.0
}

/// A pyramid: the convex polygon `base` (corners as (x, z), in order around it) at height `y0` and
/// its sides meeting at `apex` (anywhere above or below the base's plane, leaning as it likes: a
/// blade of grass, a horn, a spike). Closed, flat faces, `2n − 2` triangles for `n` corners.
pub fn pyramid(name: &str, base: &[Vec2], y0: f32, apex: Vec3) -> Mesh {
    let mut out = Faceted::new(name);
    let corners: Vec<Vec3> = base.iter().map(|p| Vec3::new(p.x, y0, p.y)).collect();
    let base_center = corners.iter().copied().sum::<Vec3>() / corners.len().max(1) as f32;
    let inside = base_center.lerp(apex, 0.25);
    let down = if apex.y >= y0 { Vec3::NEG_Y } else { Vec3::Y };
    out.face(&corners, down);
    for (i, &a) in corners.iter().enumerate() {
        let b = corners[(i + 1) % corners.len()];
        out.face(&[a, b, apex], (a + b + apex) / 3.0 - inside);
    }
    out.0
}

/// The regular icosahedron inscribed in the unit sphere: its 12 corners and its 20 faces (corner
/// indices, counter-clockwise seen from outside). The start of every geodesic sphere ([`icosphere`],
/// and the smooth ones the built-in scenes make).
pub fn icosahedron() -> ([Vec3; 12], [[u32; 3]; 20]) {
    let t = (1.0 + 5f32.sqrt()) * 0.5;
    let corners = [
        Vec3::new(-1.0, t, 0.0),
        Vec3::new(1.0, t, 0.0),
        Vec3::new(-1.0, -t, 0.0),
        Vec3::new(1.0, -t, 0.0),
        Vec3::new(0.0, -1.0, t),
        Vec3::new(0.0, 1.0, t),
        Vec3::new(0.0, -1.0, -t),
        Vec3::new(0.0, 1.0, -t),
        Vec3::new(t, 0.0, -1.0),
        Vec3::new(t, 0.0, 1.0),
        Vec3::new(-t, 0.0, -1.0),
        Vec3::new(-t, 0.0, 1.0),
    ]
    .map(Vec3::normalize);
    let faces = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (corners, faces)
}

/// A sphere of `radius` about the origin made of an icosahedron whose triangles are split in four
/// `subdivisions` times (20 · 4ⁿ flat triangles: 20, 80, 320, …), the corners on the sphere.
/// Scale it with [`merge`] for an ellipsoid. At most 4 subdivisions (5,120 triangles).
pub fn icosphere(name: &str, radius: f32, subdivisions: u32) -> Mesh {
    let (corners, faces) = icosahedron();
    let mut triangles: Vec<[Vec3; 3]> = faces.iter().map(|f| f.map(|i| corners[i as usize])).collect();
    for _ in 0..subdivisions.min(4) {
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let [ab, bc, ca] = [(a + b), (b + c), (c + a)].map(Vec3::normalize);
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    let mut out = Faceted::new(name);
    for tri in triangles {
        let tri = tri.map(|p| p * radius);
        out.face(&tri, tri[0] + tri[1] + tri[2]);
    }
    out.0
}

/// Whether the mesh is watertight: every edge, with vertices matched by position (to 1e-5 of the
/// mesh's size), is shared by triangles that run along it as often in one direction as in the
/// other. Closed solids let probes tell inside from outside; a mesh of several closed parts
/// (overlapping or not) is closed too.
pub fn is_closed(mesh: &Mesh) -> bool {
    let Some((lo, hi)) = mesh.bounds() else { return true };
    let step = ((hi - lo).max_element() * 1e-5).max(f32::MIN_POSITIVE);
    let key = |i: u32| {
        let p = (mesh.positions[i as usize] - lo) / step;
        (p.x.round() as i64, p.y.round() as i64, p.z.round() as i64)
    };
    let mut edges: std::collections::HashMap<_, i64> = std::collections::HashMap::new();
    for tri in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(key);
        for (from, to) in [(a, b), (b, c), (c, a)] {
            if from == to {
                continue;
            }
            let (edge, sign) = if from < to { ((from, to), 1) } else { ((to, from), -1) };
            *edges.entry(edge).or_default() += sign;
        }
    }
    edges.values().all(|&n| n == 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed, with every triangle's winding agreeing with its vertices' normals and facing away
    /// from `inside`, a point inside the convex solid.
    fn assert_convex_solid(mesh: &Mesh, inside: Vec3) {
        assert!(is_closed(mesh), "{} is not closed", mesh.name);
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
            let geometric = (b - a).cross(c - a);
            assert!(geometric.length() > 0.0, "{}: degenerate triangle", mesh.name);
            assert!(geometric.dot(mesh.normals[tri[0] as usize]) > 0.0, "{}: winding against the normal", mesh.name);
            assert!(geometric.dot((a + b + c) / 3.0 - inside) > 0.0, "{}: a face turned inwards", mesh.name);
        }
    }

    #[test]
    fn prisms_pyramids_and_icospheres_are_closed_outward_facing_solids() {
        let hexagon: Vec<Vec2> = (0..6).map(|i| Vec2::from_angle(i as f32 * std::f32::consts::TAU / 6.0) * 0.5).collect();
        let clockwise: Vec<Vec2> = hexagon.iter().rev().copied().collect();
        for outline in [&hexagon, &clockwise] {
            let column = prism("column", outline, 0.0, 2.0);
            assert_convex_solid(&column, Vec3::Y);
            assert_eq!(column.triangle_count(), 2 * 4 + 2 * 6);
            let (lo, hi) = column.bounds().unwrap();
            assert!((lo - Vec3::new(-0.5, 0.0, -0.5 * 3f32.sqrt() / 2.0)).length() < 1e-5 && (hi.y - 2.0).abs() < 1e-6);
        }
        let blade = pyramid("blade", &hexagon[..3], 0.0, Vec3::new(0.4, 1.0, -0.2));
        let centroid = (hexagon[..3].iter().map(|p| Vec3::new(p.x, 0.0, p.y)).sum::<Vec3>() + Vec3::new(0.4, 1.0, -0.2)) / 4.0;
        assert_convex_solid(&blade, centroid);
        assert_eq!(blade.triangle_count(), 4);
        let spike = pyramid("spike", &clockwise, 1.0, Vec3::new(0.0, 0.0, 0.0));
        assert_convex_solid(&spike, Vec3::new(0.0, 0.8, 0.0));
        for n in 0..3 {
            let sphere = icosphere("sphere", 2.0, n);
            assert_convex_solid(&sphere, Vec3::ZERO);
            assert_eq!(sphere.triangle_count(), 20 * 4usize.pow(n));
            assert!(sphere.positions.iter().all(|p| (p.length() - 2.0).abs() < 1e-5));
        }
    }

    #[test]
    fn merged_solids_stay_closed_and_an_open_mesh_is_caught() {
        let parts = [box_part(Vec3::ZERO, Vec3::ONE), (icosphere("", 0.5, 1), Affine3A::from_scale(Vec3::new(1.0, -2.0, 1.0)))];
        assert!(is_closed(&merge("parts", &parts)));
        assert!(is_closed(&closed_shell("room", Vec3::ZERO, Vec3::ONE, 0.1)));
        assert!(!is_closed(&quad("quad", Vec2::ONE)));
        let mut open = cuboid("open", Vec3::ONE);
        open.indices.truncate(open.indices.len() - 3);
        assert!(!is_closed(&open));
    }
}

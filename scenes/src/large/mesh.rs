//! The mesh builders the large scenes share: grids of quads, thick curved shells, solids of
//! revolution (plain or fluted), geodesic spheres, and appending one mesh or [`merge`] parts to
//! another.

use std::collections::HashMap;
use std::f32::consts::TAU;

use engine::scene::Mesh;
use engine::shapes::merge;
use glam::{Affine3A, Vec3};

/// Triangles whose cross product `(b - a) × (c - a)` is shorter than this are left out (they only
/// occur where a surface pinches to a point: caps on an axis, the pole of a dome).
const MIN_DOUBLE_AREA: f32 = 1e-7;

/// Appends a grid of quads (two triangles each) as one smooth surface with its own vertices.
///
/// `point(i, j)` gives the position of grid node `i` in `0..rows`, `j` in `0..cols` and a vector
/// pointing out of the solid there; each triangle is wound so that its normal agrees with the sum of
/// its corners' outward vectors. With `wrap`, column `cols - 1` connects back to column 0 (a closed
/// ring). Vertex normals are area-weighted within the grid, so the surface is smooth across its own
/// triangles and sharp where it meets other grids. Degenerate triangles are skipped.
fn add_grid(mesh: &mut Mesh, rows: usize, cols: usize, wrap: bool, point: impl Fn(usize, usize) -> (Vec3, Vec3)) {
    if rows < 2 || cols < 2 {
        return;
    }
    let base = mesh.positions.len();
    let nodes: Vec<(Vec3, Vec3)> = (0..rows).flat_map(|i| (0..cols).map(move |j| (i, j))).map(|(i, j)| point(i, j)).collect();
    let mut normals = vec![Vec3::ZERO; nodes.len()];
    let mut indices = Vec::with_capacity((rows - 1) * cols * 6);
    let quads_per_row = if wrap { cols } else { cols - 1 };
    for i in 0..rows - 1 {
        for j in 0..quads_per_row {
            let j1 = (j + 1) % cols;
            let [n00, n01, n10, n11] = [i * cols + j, i * cols + j1, (i + 1) * cols + j, (i + 1) * cols + j1];
            for [a, b, c] in [[n00, n10, n11], [n00, n11, n01]] {
                let (pa, pb, pc) = (nodes[a].0, nodes[b].0, nodes[c].0);
                let mut face = (pb - pa).cross(pc - pa);
                if face.length() <= MIN_DOUBLE_AREA {
                    continue;
                }
                let outward = nodes[a].1 + nodes[b].1 + nodes[c].1;
                let (b, c) = if face.dot(outward) < 0.0 {
                    face = -face;
                    (c, b)
                } else {
                    (b, c)
                };
                for k in [a, b, c] {
                    normals[k] += face;
                }
                indices.extend([a, b, c].map(|k| (base + k) as u32));
            }
        }
    }
    mesh.positions.extend(nodes.iter().map(|n| n.0));
    mesh.normals.extend(normals.iter().zip(&nodes).map(|(&n, node)| n.try_normalize().unwrap_or(node.1.normalize_or(Vec3::Y))));
    mesh.indices.extend(indices);
}

/// Appends a closed solid shell patch: the surfaces `inner(u, v)` and `outer(u, v)` over
/// `u, v ∈ [0, 1]` (a `u_segments` × `v_segments` grid each), joined along their four borders.
/// Used for vaults, domes, curved walls and arches, which are thick curved slabs.
pub(super) fn add_shell(
    mesh: &mut Mesh,
    u_segments: usize,
    v_segments: usize,
    inner: impl Fn(f32, f32) -> Vec3,
    outer: impl Fn(f32, f32) -> Vec3,
) {
    let (nu, nv) = (u_segments.max(1), v_segments.max(1));
    let u = |i: usize| i as f32 / nu as f32;
    let v = |j: usize| j as f32 / nv as f32;
    add_grid(mesh, nu + 1, nv + 1, false, |i, j| {
        let p = inner(u(i), v(j));
        (p, p - outer(u(i), v(j)))
    });
    add_grid(mesh, nu + 1, nv + 1, false, |i, j| {
        let p = outer(u(i), v(j));
        (p, p - inner(u(i), v(j)))
    });
    // The four borders: each joins the inner and outer edge; its outward direction leads away from
    // the neighbouring grid line.
    // `fixed` is the border's index along u (when `fixed_u`) or along v; `k` runs along the border.
    for (fixed, fixed_u) in [(0, true), (nu, true), (0, false), (nv, false)] {
        let (count, step_in) = if fixed_u { (nv, if fixed == 0 { 1 } else { nu - 1 }) } else { (nu, if fixed == 0 { 1 } else { nv - 1 }) };
        let at = |k: usize, surface: &dyn Fn(f32, f32) -> Vec3, across: usize| {
            if fixed_u { surface(u(across), v(k)) } else { surface(u(k), v(across)) }
        };
        add_grid(mesh, 2, count + 1, false, |side, k| {
            let (edge, neighbour) =
                if side == 0 { (at(k, &inner, fixed), at(k, &inner, step_in)) } else { (at(k, &outer, fixed), at(k, &outer, step_in)) };
            (edge, edge - neighbour)
        });
    }
}

/// A ring of a solid of revolution: its radius and height, and whether it is fluted.
#[derive(Clone, Copy)]
pub(super) struct Ring {
    radius: f32,
    y: f32,
    fluted: bool,
}

pub(super) const fn ring(radius: f32, y: f32) -> Ring {
    Ring { radius, y, fluted: false }
}

pub(super) const fn fluted(radius: f32, y: f32) -> Ring {
    Ring { radius, y, fluted: true }
}

/// Flutes (grooves) of a fluted ring: their number and their depth as a fraction of the radius.
#[derive(Clone, Copy)]
pub(super) struct Flutes {
    pub(super) count: usize,
    pub(super) depth: f32,
}

pub(super) const NO_FLUTES: Flutes = Flutes { count: 0, depth: 0.0 };

/// Appends a closed solid of revolution about the vertical axis through `origin`: the profile runs
/// from bottom to top; missing caps (first or last ring off the axis) are closed with flat discs.
/// Each band between two rings is smooth around the axis and sharp along the profile.
pub(super) fn add_lathe(mesh: &mut Mesh, origin: Vec3, profile: &[Ring], segments: usize, flutes: Flutes) {
    let segments = segments.max(3);
    let mut rings = Vec::with_capacity(profile.len() + 2);
    if let Some(first) = profile.first().filter(|r| r.radius > 0.0) {
        rings.push(ring(0.0, first.y));
    }
    rings.extend_from_slice(profile);
    if let Some(last) = profile.last().filter(|r| r.radius > 0.0) {
        rings.push(ring(0.0, last.y));
    }
    let directions: Vec<Vec3> = (0..segments)
        .map(|j| {
            let (s, c) = (TAU * j as f32 / segments as f32).sin_cos();
            Vec3::new(c, 0.0, s)
        })
        .collect();
    let groove: Vec<f32> = (0..segments)
        .map(|j| {
            let phase = (flutes.count * j) as f32 / segments as f32;
            1.0 - flutes.depth * (0.5 - 0.5 * (TAU * phase).cos())
        })
        .collect();
    let position = |r: &Ring, j: usize| {
        let radius = if r.fluted { r.radius * groove[j] } else { r.radius };
        origin + directions[j] * radius + Vec3::Y * r.y
    };
    for pair in rings.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        // The profile's outward normal in the (radial, up) plane.
        let (out_radial, out_up) = (b.y - a.y, a.radius - b.radius);
        add_grid(mesh, 2, segments, true, |i, j| {
            let r = if i == 0 { &a } else { &b };
            (position(r, j), directions[j] * out_radial + Vec3::Y * out_up)
        });
    }
}

/// A geodesic sphere of unit radius: an icosahedron whose faces are split in four `subdivisions`
/// times (20·4ⁿ triangles), with normals along the positions.
pub(super) fn icosphere(name: &str, subdivisions: u32) -> Mesh {
    let (corners, faces) = engine::shapes::icosahedron();
    let mut positions: Vec<Vec3> = corners.to_vec();
    let mut faces: Vec<[u32; 3]> = faces.to_vec();
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| -> u32 {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut positions);
                let bc = midpoint(b, c, &mut positions);
                let ca = midpoint(c, a, &mut positions);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    Mesh {
        name: name.into(),
        normals: positions.clone(),
        positions,
        uvs: Vec::new(),
        indices: faces.into_iter().flatten().collect(),
        tangents: Vec::new(),
    }
}

/// Appends `part` to `out` (positions, normals and indices; texture coordinates are dropped).
pub(super) fn append(out: &mut Mesh, part: &Mesh) {
    let base = out.positions.len() as u32;
    out.positions.extend_from_slice(&part.positions);
    out.normals.extend_from_slice(&part.normals);
    out.indices.extend(part.indices.iter().map(|&i| base + i));
}

/// Appends the boxes of [`merge`] parts (see [`box_part`], [`box_with_hole`]) to `out`.
///
/// [`box_part`]: engine::shapes::box_part
/// [`box_with_hole`]: engine::shapes::box_with_hole
pub(super) fn append_parts(out: &mut Mesh, parts: &[(Mesh, Affine3A)]) {
    append(out, &merge("", parts));
}

/// An empty mesh called `name`.
pub(super) fn named_mesh(name: &str) -> Mesh {
    Mesh { name: name.into(), ..Default::default() }
}

//! Large procedural benchmark scenes, built in code (no files), for measuring how rendering and
//! dynamic diffuse global illumination (DDGI) scale with scene size.
//!
//! | scene         | what it measures                                                             |
//! |---------------|------------------------------------------------------------------------------|
//! | [`cathedral`] | a closed stone interior of ≈73,000 static triangles lit by the sun through   |
//! |               | its windows, in the spirit of the Sibenik cathedral of the DDGI literature   |
//! | [`forest`]    | ≈21.6 million instanced triangles: 11,400 instances of six unique meshes     |
//!
//! Both are entries of [`crate::ALL`]. Everything here is deterministic: building a scene twice
//! gives equal descriptions (the forest uses a small inline SplitMix64 generator with a fixed seed).
//!
//! Conventions as in [`crate::rooms`]: Y is up, one unit is a metre, cameras and lights look along
//! their local -Z, a [`DirectionalLight`]'s intensity is irradiance (W/m²). Every generated mesh but
//! the forest's terrain (an open heightfield) is a union of closed solids whose triangles are wound
//! counter-clockwise seen from outside, with unit vertex normals pointing out of the solid; no
//! triangle is degenerate.

use std::collections::HashMap;
use std::f32::consts::{FRAC_PI_2, PI, TAU};
use std::sync::LazyLock;

use engine::rng::SplitMix64;
use engine::scene::{DirectionalLight, Material, Mesh, NodeContent, SceneDescription, Transform};
use engine::shapes::{box_part, box_with_hole, merge};
use glam::{Affine3A, Quat, Vec2, Vec3};

use crate::{Opening, SUN_COLOR, add_camera};

// ---------------------------------------------------------------------------------------------
// Mesh building
// ---------------------------------------------------------------------------------------------

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
fn add_shell(mesh: &mut Mesh, u_segments: usize, v_segments: usize, inner: impl Fn(f32, f32) -> Vec3, outer: impl Fn(f32, f32) -> Vec3) {
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
struct Ring {
    radius: f32,
    y: f32,
    fluted: bool,
}

const fn ring(radius: f32, y: f32) -> Ring {
    Ring { radius, y, fluted: false }
}

const fn fluted(radius: f32, y: f32) -> Ring {
    Ring { radius, y, fluted: true }
}

/// Flutes (grooves) of a fluted ring: their number and their depth as a fraction of the radius.
#[derive(Clone, Copy)]
struct Flutes {
    count: usize,
    depth: f32,
}

const NO_FLUTES: Flutes = Flutes { count: 0, depth: 0.0 };

/// Appends a closed solid of revolution about the vertical axis through `origin`: the profile runs
/// from bottom to top; missing caps (first or last ring off the axis) are closed with flat discs.
/// Each band between two rings is smooth around the axis and sharp along the profile.
fn add_lathe(mesh: &mut Mesh, origin: Vec3, profile: &[Ring], segments: usize, flutes: Flutes) {
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
fn icosphere(name: &str, subdivisions: u32) -> Mesh {
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
fn append(out: &mut Mesh, part: &Mesh) {
    let base = out.positions.len() as u32;
    out.positions.extend_from_slice(&part.positions);
    out.normals.extend_from_slice(&part.normals);
    out.indices.extend(part.indices.iter().map(|&i| base + i));
}

/// Appends the boxes of [`merge`] parts (see [`box_part`], [`box_with_hole`]) to `out`.
fn append_parts(out: &mut Mesh, parts: &[(Mesh, Affine3A)]) {
    append(out, &merge("", parts));
}

/// An empty mesh called `name`.
fn named_mesh(name: &str) -> Mesh {
    Mesh { name: name.into(), ..Default::default() }
}

/// Direction sunlight travels: `elevation` radians below the horizon, its horizontal part turned
/// `azimuth` radians from -X towards -Z.
pub(crate) fn sun_direction(elevation: f32, azimuth: f32) -> Vec3 {
    let (sin_el, cos_el) = elevation.sin_cos();
    let (sin_az, cos_az) = azimuth.sin_cos();
    Vec3::new(-cos_el * cos_az, -sin_el, -cos_el * sin_az)
}

/// How far up-sun of its target the sun's node is placed (for editors; no effect on the light).
const SUN_GIZMO_DISTANCE: f32 = 20.0;

/// Adds a directional light travelling along `direction`, its node placed up-sun of `target`.
pub(crate) fn add_sun(desc: &mut SceneDescription, target: Vec3, direction: Vec3, intensity: f32) {
    let transform = Transform::from_translation(target - direction * SUN_GIZMO_DISTANCE).looking_at(target, Vec3::Y);
    let sun = DirectionalLight { color: SUN_COLOR, intensity };
    desc.add_node("sun", transform, None, vec![NodeContent::DirectionalLight(sun)]);
}

// ---------------------------------------------------------------------------------------------
// cathedral
// ---------------------------------------------------------------------------------------------

/// Inner half-width of the nave (metres): the arcades stand at |x| = 6, the nave is 12 m wide.
const NAVE_HALF_WIDTH: f32 = 6.0;
/// Half the length of the nave (metres): from the apse at z = -20 to the façade at z = +20.
const NAVE_HALF_LENGTH: f32 = 20.0;
/// Inner height of the nave at the crown of its barrel vault (metres).
const NAVE_HEIGHT: f32 = 18.0;
/// Height where the barrel vault (radius = the nave's half-width) springs from the walls.
const VAULT_SPRING: f32 = NAVE_HEIGHT - NAVE_HALF_WIDTH;
/// Thickness of every wall, of the vault and of the apse (metres): thick enough that a probe inside
/// the masonry is detectable.
const WALL_THICKNESS: f32 = 0.8;
/// Thickness of the aisle roofs and of the floor slab (metres).
const ROOF_THICKNESS: f32 = 0.6;
const FLOOR_THICKNESS: f32 = 0.5;
/// Number of bays along the nave: columns stand between them, one window per bay and wall.
const BAY_COUNT: usize = 8;
const BAY_LENGTH: f32 = 2.0 * NAVE_HALF_LENGTH / BAY_COUNT as f32;
/// Inner width of each side aisle (from the arcade wall to the outer wall) and its ceiling height.
const AISLE_WIDTH: f32 = 4.2;
const AISLE_HEIGHT: f32 = 9.0;
/// The arcade wall between nave and aisle spans |x| ∈ [ARCADE_X, ARCADE_X + WALL_THICKNESS]; the
/// columns stand on its centre line.
const ARCADE_X: f32 = NAVE_HALF_WIDTH;
const COLUMN_X: f32 = ARCADE_X + 0.5 * WALL_THICKNESS;
/// Inner face of the aisles' outer walls.
const OUTER_WALL_X: f32 = ARCADE_X + WALL_THICKNESS + AISLE_WIDTH;
/// Outer half-extents of the building's main block (outer walls).
const OUTER_HALF_WIDTH: f32 = OUTER_WALL_X + WALL_THICKNESS;
const OUTER_HALF_LENGTH: f32 = NAVE_HALF_LENGTH + WALL_THICKNESS;
/// Top of the aisle roofs and of the aisles' outer walls.
const AISLE_ROOF_TOP: f32 = AISLE_HEIGHT + ROOF_THICKNESS;
/// Top of the façade (above the vault's outer crown, 18.8 m).
const FACADE_TOP: f32 = NAVE_HEIGHT + WALL_THICKNESS + 0.2;
/// How far pieces that join reach into each other so that no ray can pass between them.
const OVERLAP: f32 = 0.4;

/// The columns: where the arches spring (top of the capital) and the profile of each column, a
/// fluted shaft with a round plinth and torus mouldings below and a flared capital and abacus above.
const ARCH_SPRING: f32 = 5.8;
const COLUMN_PROFILE: [Ring; 27] = [
    ring(0.75, -0.1), // plinth, sunk 10 cm into the floor
    ring(0.75, 0.25),
    ring(0.62, 0.25), // lower torus
    ring(0.66, 0.29),
    ring(0.68, 0.35),
    ring(0.66, 0.41),
    ring(0.60, 0.45),
    ring(0.52, 0.47), // scotia
    ring(0.50, 0.53),
    ring(0.54, 0.57), // upper torus
    ring(0.53, 0.62),
    ring(0.46, 0.66),
    fluted(0.44, 0.66), // fluted shaft with a slight entasis
    fluted(0.435, 2.0),
    fluted(0.42, 3.5),
    fluted(0.40, 5.05),
    ring(0.46, 5.05), // astragal
    ring(0.47, 5.1),
    ring(0.46, 5.15),
    ring(0.42, 5.15), // capital bell
    ring(0.43, 5.25),
    ring(0.47, 5.38),
    ring(0.55, 5.5),
    ring(0.64, 5.6),
    ring(0.70, 5.65),
    ring(0.78, 5.65), // abacus
    ring(0.78, ARCH_SPRING),
];
/// Segments around each column: the knob that sets the scene's triangle budget (each column has
/// 2 × 26 + 2 = 54 triangles per segment).
const COLUMN_SEGMENTS: usize = 72;
const COLUMN_FLUTES: Flutes = Flutes { count: 12, depth: 0.05 };

/// The arcade arches: semicircular rings centred on each bay, springing from the capitals (their
/// feet overlap the abacus), standing slightly proud of the wall above them.
const ARCH_INNER_RADIUS: f32 = 0.5 * BAY_LENGTH - 0.3;
const ARCH_OUTER_RADIUS: f32 = 0.5 * BAY_LENGTH + 0.2;
const ARCH_PROUD: f32 = 0.05;
const ARCH_SEGMENTS: usize = 32;
/// The wall above the arcade (the clerestory) starts here, inside the crowns of the arches; the
/// spandrels between neighbouring arches are filled with this many stepped blocks.
const CLERESTORY_BOTTOM: f32 = 8.2;
const SPANDREL_STEPS: usize = 10;
/// How far the pilasters at both ends of each arcade stand out from the apse wall and the façade.
const RESPOND_DEPTH: f32 = 0.4;

/// Barrel vault and apse: segments along the vault's half circle and along the nave, around the
/// apse (and its half-dome), and up the apse wall and the half-dome.
const VAULT_ARC_SEGMENTS: usize = 64;
const VAULT_LENGTH_SEGMENTS: usize = BAY_COUNT;
const APSE_SEGMENTS: usize = 32;
const APSE_WALL_SEGMENTS: usize = 4;
const DOME_SEGMENTS: usize = VAULT_ARC_SEGMENTS / 2;

/// Transverse ribs under the vault above each pair of columns, on corbels.
const RIB_DEPTH: f32 = 0.5;
const RIB_INNER_RADIUS: f32 = NAVE_HALF_WIDTH - 0.4;
const RIB_SEGMENTS: usize = 64;
const CORBEL_HEIGHT: f32 = 0.6;

/// Windows: one per bay in each aisle's outer wall (tall), one per bay in each clerestory wall
/// (above the aisle roofs), and one in the façade above the vault's springing.
const AISLE_WINDOW_WIDTH: f32 = 1.8;
const AISLE_WINDOW_BOTTOM: f32 = 2.5;
const AISLE_WINDOW_TOP: f32 = 7.0;
const CLERESTORY_WINDOW_WIDTH: f32 = 1.6;
const CLERESTORY_WINDOW_BOTTOM: f32 = 10.0;
const CLERESTORY_WINDOW_TOP: f32 = 11.6;
const FACADE_WINDOW_HALF_WIDTH: f32 = 2.0;
const FACADE_WINDOW_BOTTOM: f32 = 12.5;
const FACADE_WINDOW_TOP: f32 = 16.5;

/// Stone albedo of walls, vaults and columns, and the slightly darker, warmer floor.
const STONE_ALBEDO: Vec3 = Vec3::new(0.66, 0.64, 0.6);
const FLOOR_ALBEDO: Vec3 = Vec3::new(0.56, 0.5, 0.44);

/// The sun stands 50° high, shining towards -X turned 20° towards -Z, so that it enters through the
/// +X clerestory windows onto the nave floor and through the +X aisle windows onto that aisle's floor.
const CATHEDRAL_SUN_ELEVATION_DEGREES: f32 = 50.0;
const CATHEDRAL_SUN_AZIMUTH_DEGREES: f32 = 20.0;
/// Irradiance (W/m²) on a surface facing the sun; the nave floor's sun patches get 6 · sin 50° ≈ 4.6.
const CATHEDRAL_SUN_INTENSITY: f32 = 6.0;
/// The bay whose +X clerestory window casts the `sun_patch` marker's patch on the nave floor.
const SUN_PATCH_BAY: usize = 4;

/// The camera stands at eye height near the façade, looking down the nave towards the apse.
const CATHEDRAL_CAMERA_EYE: Vec3 = Vec3::new(0.0, 1.7, NAVE_HALF_LENGTH - 1.5);
const CATHEDRAL_CAMERA_TARGET: Vec3 = Vec3::new(0.0, 6.0, -NAVE_HALF_LENGTH);
const CATHEDRAL_CAMERA_YFOV_DEGREES: f32 = 60.0;
const CATHEDRAL_CAMERA_EXPOSURE: f32 = 2.0;

/// The nave's interior as an axis-aligned box (x between the arcades, y from the floor to the crown
/// of the vault, z from the apse to the façade). The apse extends it towards -Z, the aisles on both
/// sides.
pub const CATHEDRAL_NAVE_MIN: Vec3 = Vec3::new(-NAVE_HALF_WIDTH, 0.0, -NAVE_HALF_LENGTH);
pub const CATHEDRAL_NAVE_MAX: Vec3 = Vec3::new(NAVE_HALF_WIDTH, NAVE_HEIGHT, NAVE_HALF_LENGTH);

/// The centre of bay `bay` along the nave (z).
fn bay_center(bay: usize) -> f32 {
    -NAVE_HALF_LENGTH + (bay as f32 + 0.5) * BAY_LENGTH
}

/// The z of the column between bays `k` and `k + 1`.
fn column_z(k: usize) -> f32 {
    -NAVE_HALF_LENGTH + (k + 1) as f32 * BAY_LENGTH
}

/// The range `a..b` on the +X side of the nave's axis, mirrored to the side `side` (±1), as (min, max).
fn sided(side: f32, a: f32, b: f32) -> (f32, f32) {
    if side > 0.0 { (a, b) } else { (-b, -a) }
}

/// The window openings of the cathedral, as boxes through their walls.
fn cathedral_window_list() -> Vec<Opening> {
    let mut out = Vec::new();
    for side in [1.0, -1.0] {
        for bay in 0..BAY_COUNT {
            let z = bay_center(bay);
            let (x0, x1) = sided(side, OUTER_WALL_X, OUTER_HALF_WIDTH);
            out.push(Opening {
                name: "aisle_window",
                min: Vec3::new(x0, AISLE_WINDOW_BOTTOM, z - 0.5 * AISLE_WINDOW_WIDTH),
                max: Vec3::new(x1, AISLE_WINDOW_TOP, z + 0.5 * AISLE_WINDOW_WIDTH),
            });
            let (x0, x1) = sided(side, ARCADE_X, ARCADE_X + WALL_THICKNESS);
            out.push(Opening {
                name: "clerestory_window",
                min: Vec3::new(x0, CLERESTORY_WINDOW_BOTTOM, z - 0.5 * CLERESTORY_WINDOW_WIDTH),
                max: Vec3::new(x1, CLERESTORY_WINDOW_TOP, z + 0.5 * CLERESTORY_WINDOW_WIDTH),
            });
        }
    }
    out.push(Opening {
        name: "facade_window",
        min: Vec3::new(-FACADE_WINDOW_HALF_WIDTH, FACADE_WINDOW_BOTTOM, NAVE_HALF_LENGTH),
        max: Vec3::new(FACADE_WINDOW_HALF_WIDTH, FACADE_WINDOW_TOP, OUTER_HALF_LENGTH),
    });
    out
}

static CATHEDRAL_WINDOWS: LazyLock<Vec<Opening>> = LazyLock::new(cathedral_window_list);

/// The windows of [`cathedral`]: 16 aisle windows, 16 clerestory windows and one façade window, each
/// the box its hole sweeps through its wall. They are the building's only openings: a ray from
/// inside that leaves the building passes through one of them.
pub fn cathedral_openings() -> &'static [Opening] {
    &CATHEDRAL_WINDOWS
}

/// Appends the wall `min`..`max` (running along z over the nave's bays), split into one panel per
/// bay with that bay's window from `windows` (the one whose box lies in the panel) cut through.
fn wall_with_windows(out: &mut Mesh, min: Vec3, max: Vec3, windows: &[Opening]) {
    // The end panels reach to the wall's ends.
    for bay in 0..BAY_COUNT {
        let z0 = if bay == 0 { min.z } else { -NAVE_HALF_LENGTH + bay as f32 * BAY_LENGTH };
        let z1 = if bay + 1 == BAY_COUNT { max.z } else { -NAVE_HALF_LENGTH + (bay + 1) as f32 * BAY_LENGTH };
        let (panel_min, panel_max) = (Vec3::new(min.x, min.y, z0), Vec3::new(max.x, max.y, z1));
        let window = windows.iter().find(|w| {
            w.min.x >= min.x - 1e-4 && w.max.x <= max.x + 1e-4 && w.min.y >= min.y && w.max.y <= max.y && w.min.z > z0 && w.max.z < z1
        });
        match window {
            Some(w) => append_parts(out, &box_with_hole(panel_min, panel_max, w.min, w.max)),
            None => append_parts(out, &[box_part(panel_min, panel_max)]),
        }
    }
}

/// The flat walls, roofs and blocks: aisle walls with their windows, clerestory walls with theirs,
/// aisle roofs, the aisles' end walls, the façade, the spandrels above the arcades and the corbels
/// under the ribs.
fn cathedral_walls() -> Mesh {
    let mut out = named_mesh("cathedral_walls");
    let windows = cathedral_openings();
    let bottom = -FLOOR_THICKNESS;
    for side in [1.0, -1.0] {
        // The aisle's outer wall, from the floor slab's underside to the aisle roof's top.
        let (x0, x1) = sided(side, OUTER_WALL_X, OUTER_HALF_WIDTH);
        wall_with_windows(&mut out, Vec3::new(x0, bottom, -OUTER_HALF_LENGTH), Vec3::new(x1, AISLE_ROOF_TOP, OUTER_HALF_LENGTH), windows);
        // The clerestory wall, from inside the arch crowns up into the vault's springing, from the
        // apse (which closes it at z = -20) into the façade.
        let (x0, x1) = sided(side, ARCADE_X, ARCADE_X + WALL_THICKNESS);
        let clerestory_top = VAULT_SPRING + OVERLAP;
        wall_with_windows(
            &mut out,
            Vec3::new(x0, CLERESTORY_BOTTOM, -NAVE_HALF_LENGTH),
            Vec3::new(x1, clerestory_top, OUTER_HALF_LENGTH),
            windows,
        );
        // The aisle roof reaches into the clerestory wall and over the outer wall.
        let (x0, x1) = sided(side, COLUMN_X, OUTER_HALF_WIDTH);
        append_parts(
            &mut out,
            &[box_part(Vec3::new(x0, AISLE_HEIGHT, -OUTER_HALF_LENGTH), Vec3::new(x1, AISLE_ROOF_TOP, OUTER_HALF_LENGTH))],
        );
        // The aisle's end wall at the apse end, overlapping the apse wall's end.
        let (x0, x1) = sided(side, COLUMN_X, OUTER_HALF_WIDTH);
        append_parts(&mut out, &[box_part(Vec3::new(x0, bottom, -OUTER_HALF_LENGTH), Vec3::new(x1, AISLE_ROOF_TOP, -NAVE_HALF_LENGTH))]);
        // Spandrels: stepped blocks between neighbouring arches, above every column and against both
        // end walls. Each step reaches into the arch rings on both sides (its inner edge lies inside
        // the ring's outer radius at the step's top) and into the next step and the wall above.
        let (x0, x1) = sided(side, ARCADE_X, ARCADE_X + WALL_THICKNESS);
        let step_height = (CLERESTORY_BOTTOM - ARCH_SPRING) / SPANDREL_STEPS as f32;
        for step in 0..SPANDREL_STEPS {
            let y0 = ARCH_SPRING + step as f32 * step_height;
            let y1 = y0 + step_height + 0.05;
            let rise = y1 - ARCH_SPRING;
            let reach = ARCH_OUTER_RADIUS * ARCH_OUTER_RADIUS - rise * rise;
            let half = 0.5 * BAY_LENGTH - reach.max(0.0).sqrt();
            if half <= 0.0 {
                continue;
            }
            let piers = (0..BAY_COUNT - 1).map(|k| (column_z(k) - half, column_z(k) + half));
            let ends = [(-NAVE_HALF_LENGTH - OVERLAP, -NAVE_HALF_LENGTH + half), (NAVE_HALF_LENGTH - half, NAVE_HALF_LENGTH + OVERLAP)];
            for (z0, z1) in piers.chain(ends) {
                append_parts(&mut out, &[box_part(Vec3::new(x0, y0, z0), Vec3::new(x1, y1, z1))]);
            }
        }
        // Responds: flat pilasters against the apse wall's end and the façade, carrying the feet of
        // the end bays' arches.
        let (x0, x1) = sided(side, ARCADE_X, ARCADE_X + WALL_THICKNESS);
        for (z0, z1) in [
            (-NAVE_HALF_LENGTH - OVERLAP, -NAVE_HALF_LENGTH + RESPOND_DEPTH),
            (NAVE_HALF_LENGTH - RESPOND_DEPTH, NAVE_HALF_LENGTH + OVERLAP),
        ] {
            append_parts(&mut out, &[box_part(Vec3::new(x0, bottom, z0), Vec3::new(x1, ARCH_SPRING, z1))]);
        }
        // Corbels under the ribs' feet.
        let (x0, x1) = sided(side, RIB_INNER_RADIUS - 0.05, ARCADE_X + 0.1);
        for k in 0..BAY_COUNT - 1 {
            let z = column_z(k);
            append_parts(
                &mut out,
                &[box_part(
                    Vec3::new(x0, VAULT_SPRING - CORBEL_HEIGHT, z - 0.5 * RIB_DEPTH - 0.05),
                    Vec3::new(x1, VAULT_SPRING + 0.05, z + 0.5 * RIB_DEPTH + 0.05),
                )],
            );
        }
    }
    // The façade spans the whole width, from under the floor to above the vault, with one window.
    let facade = box_with_hole(
        Vec3::new(-OUTER_HALF_WIDTH, bottom, NAVE_HALF_LENGTH),
        Vec3::new(OUTER_HALF_WIDTH, FACADE_TOP, OUTER_HALF_LENGTH),
        Vec3::new(-FACADE_WINDOW_HALF_WIDTH, FACADE_WINDOW_BOTTOM, NAVE_HALF_LENGTH),
        Vec3::new(FACADE_WINDOW_HALF_WIDTH, FACADE_WINDOW_TOP, OUTER_HALF_LENGTH),
    );
    append_parts(&mut out, &facade);
    out
}

/// The curved masonry: the nave's barrel vault with its ribs, the arcade arches, and the apse (a
/// half-cylinder wall under a quarter-sphere half-dome, continuing the nave's cross-section).
fn cathedral_vaults() -> Mesh {
    let mut out = named_mesh("cathedral_vaults");
    let (r_in, r_out) = (NAVE_HALF_WIDTH, NAVE_HALF_WIDTH + WALL_THICKNESS);
    // Barrel vault: u runs over the half circle from +X to -X, v along the nave into the façade.
    let vault = |r: f32| {
        move |u: f32, v: f32| {
            let (s, c) = (PI * u).sin_cos();
            Vec3::new(r * c, VAULT_SPRING + r * s, -NAVE_HALF_LENGTH + v * (2.0 * NAVE_HALF_LENGTH + WALL_THICKNESS))
        }
    };
    add_shell(&mut out, VAULT_ARC_SEGMENTS, VAULT_LENGTH_SEGMENTS, vault(r_in), vault(r_out));
    // Ribs above each pair of columns, reaching into the vault.
    for k in 0..BAY_COUNT - 1 {
        let z = column_z(k);
        let rib = move |r: f32| {
            move |u: f32, v: f32| {
                let (s, c) = (PI * u).sin_cos();
                Vec3::new(r * c, VAULT_SPRING + r * s, z + (v - 0.5) * RIB_DEPTH)
            }
        };
        add_shell(&mut out, RIB_SEGMENTS, 1, rib(RIB_INNER_RADIUS), rib(r_in + 0.05));
    }
    // Apse: the wall, a half-cylinder behind z = -20, from under the floor to the springing ...
    let apse_wall = |r: f32| {
        move |u: f32, v: f32| {
            let (s, c) = (PI * u).sin_cos();
            Vec3::new(r * c, -FLOOR_THICKNESS + v * (VAULT_SPRING + FLOOR_THICKNESS), -NAVE_HALF_LENGTH - r * s)
        }
    };
    add_shell(&mut out, APSE_SEGMENTS, APSE_WALL_SEGMENTS, apse_wall(r_in), apse_wall(r_out));
    // ... and the half-dome on it: u around (as the wall), v from the springing up to the pole.
    let dome = |r: f32| {
        move |u: f32, v: f32| {
            let (s, c) = (PI * u).sin_cos();
            let (sin_up, cos_up) = if v >= 1.0 { (1.0, 0.0) } else { (FRAC_PI_2 * v).sin_cos() };
            Vec3::new(r * cos_up * c, VAULT_SPRING + r * sin_up, -NAVE_HALF_LENGTH - r * cos_up * s)
        }
    };
    add_shell(&mut out, APSE_SEGMENTS, DOME_SEGMENTS, dome(r_in), dome(r_out));
    // Arcade arches, centred on each bay, on both sides.
    for side in [1.0, -1.0] {
        let (x0, x1) = sided(side, ARCADE_X - ARCH_PROUD, ARCADE_X + WALL_THICKNESS + ARCH_PROUD);
        for bay in 0..BAY_COUNT {
            let z = bay_center(bay);
            let arch = move |r: f32| {
                move |u: f32, v: f32| {
                    let (s, c) = (PI * u).sin_cos();
                    Vec3::new(x0 + v * (x1 - x0), ARCH_SPRING + r * s, z + r * c)
                }
            };
            add_shell(&mut out, ARCH_SEGMENTS, 1, arch(ARCH_INNER_RADIUS), arch(ARCH_OUTER_RADIUS));
        }
    }
    out
}

/// The two rows of columns between the nave and the aisles.
fn cathedral_columns() -> Mesh {
    let mut out = named_mesh("cathedral_columns");
    for side in [1.0, -1.0] {
        for k in 0..BAY_COUNT - 1 {
            add_lathe(&mut out, Vec3::new(side * COLUMN_X, 0.0, column_z(k)), &COLUMN_PROFILE, COLUMN_SEGMENTS, COLUMN_FLUTES);
        }
    }
    out
}

/// The floor slab under the whole building, apse included.
fn cathedral_floor() -> Mesh {
    let mut out = named_mesh("cathedral_floor");
    let apse_back = -NAVE_HALF_LENGTH - NAVE_HALF_WIDTH - WALL_THICKNESS - OVERLAP;
    append_parts(
        &mut out,
        &[box_part(Vec3::new(-OUTER_HALF_WIDTH, -FLOOR_THICKNESS, apse_back), Vec3::new(OUTER_HALF_WIDTH, 0.0, OUTER_HALF_LENGTH))],
    );
    out
}

/// A stone basilica of ≈73,000 triangles for DDGI benchmarks, in the spirit of the Sibenik cathedral:
/// a 40 m nave, 12 m wide under an 18 m barrel vault with transverse ribs, between two rows of seven
/// fluted columns carrying semicircular arches; 4.2 m side aisles under flat roofs at 9 m; a
/// semicircular apse under a half-dome at the -Z end and a flat façade at the +Z end.
///
/// The building is closed (thick walls, vaults and slabs that overlap or meet exactly at every join;
/// every wall and column is a closed solid) except for its 33 windows ([`cathedral_openings`]): one
/// per bay in each aisle wall and each clerestory wall, and one in the façade. A 6 W/m² sun, 50° high,
/// shines through the +X windows; the camera stands near the façade looking down the nave.
///
/// Meshes: walls, vaults (vault, ribs, arches, apse), columns (stone) and floor (a slightly darker
/// stone), one node each. Empty node: `sun_patch`, a nave floor point lit by the sun through a
/// clerestory window.
pub fn cathedral() -> SceneDescription {
    let mut desc = SceneDescription { name: "cathedral".into(), ..Default::default() };
    let stone = desc.add_material(Material::diffuse("stone", STONE_ALBEDO));
    let floor = desc.add_material(Material::diffuse("floor", FLOOR_ALBEDO));
    desc.add_mesh_node("walls", Transform::IDENTITY, cathedral_walls(), stone);
    desc.add_mesh_node("vaults", Transform::IDENTITY, cathedral_vaults(), stone);
    desc.add_mesh_node("columns", Transform::IDENTITY, cathedral_columns(), stone);
    desc.add_mesh_node("floor", Transform::IDENTITY, cathedral_floor(), floor);

    let direction = sun_direction(CATHEDRAL_SUN_ELEVATION_DEGREES.to_radians(), CATHEDRAL_SUN_AZIMUTH_DEGREES.to_radians());
    // The sun patch: where the ray through the middle of a +X clerestory window meets the floor.
    let window = Vec3::new(COLUMN_X, 0.5 * (CLERESTORY_WINDOW_BOTTOM + CLERESTORY_WINDOW_TOP), bay_center(SUN_PATCH_BAY));
    let sun_patch = window + direction * (window.y / -direction.y);
    desc.add_node("sun_patch", Transform::from_translation(sun_patch), None, vec![NodeContent::Empty]);
    add_sun(&mut desc, sun_patch, direction, CATHEDRAL_SUN_INTENSITY);

    add_camera(&mut desc, CATHEDRAL_CAMERA_EYE, CATHEDRAL_CAMERA_TARGET, CATHEDRAL_CAMERA_YFOV_DEGREES, CATHEDRAL_CAMERA_EXPOSURE);
    desc
}

// ---------------------------------------------------------------------------------------------
// forest
// ---------------------------------------------------------------------------------------------

/// Side of the square terrain (metres), centred on the origin.
pub const FOREST_SIZE: f32 = 200.0;
/// Terrain grid cells per side: 256² cells, 131,072 triangles.
const TERRAIN_CELLS: usize = 256;
/// Texture coordinates repeat every this many metres on the terrain.
const TERRAIN_UV_TILE: f32 = 10.0;
/// The hills: (amplitude in metres, wavelength along x, wavelength along z) of the product waves,
/// and a diagonal ripple; heights stay within ±6 m and slopes at most 31° (mostly far less).
const HILLS: [(f32, f32, f32); 2] = [(4.0, 110.0, 130.0), (1.5, 47.0, 61.0)];
const RIPPLE_AMPLITUDE: f32 = 0.6;
const RIPPLE_WAVELENGTH: f32 = 23.0;

/// Trees stand on a jittered grid of this many cells per side (4,900 trees); each is moved up to
/// this fraction of a cell from its cell's centre.
const TREE_GRID: usize = 70;
const TREE_JITTER: f32 = 0.4;
/// Bushes and ferns are scattered uniformly (6,500 plants).
const PLANT_COUNT: usize = 6500;
/// Instances keep this far (metres) from the terrain's edge.
const EDGE_MARGIN: f32 = 1.0;
/// Every instance gets a random turn about Y and a uniform scale in this range.
const SCALE_MIN: f32 = 0.7;
const SCALE_MAX: f32 = 1.3;
/// Seed of the placement generator.
const FOREST_SEED: u64 = 0x0F0E_5700_2024_0001;

/// Segments around trunks and foliage cones, and rings along each cone's side.
const TRUNK_SEGMENTS: usize = 24;
const CONE_SEGMENTS: usize = 64;
const CONE_RINGS: usize = 6;
/// Subdivisions of the geodesic spheres of broadleaf crowns (1,280 triangles each) and of bushes
/// (320 triangles).
const CROWN_SUBDIVISIONS: u32 = 3;
const BUSH_SUBDIVISIONS: u32 = 2;
/// Trunks reach this far below the instance's origin, so that they stay in the ground on slopes.
const TRUNK_SINK: f32 = 0.5;

/// Albedos.
pub(crate) const GROUND_ALBEDO: Vec3 = Vec3::new(0.28, 0.3, 0.16);
pub(crate) const PINE_ALBEDO: Vec3 = Vec3::new(0.07, 0.2, 0.08);
pub(crate) const OAK_ALBEDO: Vec3 = Vec3::new(0.14, 0.32, 0.08);
pub(crate) const BIRCH_ALBEDO: Vec3 = Vec3::new(0.3, 0.45, 0.15);
const BUSH_ALBEDO: Vec3 = Vec3::new(0.12, 0.3, 0.1);
const FERN_ALBEDO: Vec3 = Vec3::new(0.2, 0.42, 0.12);

/// The sun: 40° high, 7 W/m², shining mostly towards -Z and a little towards +X (the azimuth is
/// measured from -X towards -Z), so that it comes from behind the camera's right shoulder.
const FOREST_SUN_ELEVATION_DEGREES: f32 = 40.0;
const FOREST_SUN_AZIMUTH_DEGREES: f32 = 110.0;
const FOREST_SUN_INTENSITY: f32 = 7.0;

/// The camera stands above the terrain's -X, +Z corner, looking across the forest.
const FOREST_CAMERA_XZ: Vec2 = Vec2::new(-95.0, 95.0);
const FOREST_CAMERA_HEIGHT: f32 = 40.0;
const FOREST_CAMERA_TARGET_XZ: Vec2 = Vec2::new(15.0, -15.0);
const FOREST_CAMERA_YFOV_DEGREES: f32 = 55.0;
const FOREST_CAMERA_EXPOSURE: f32 = 1.0;

/// Height (metres) of the forest's terrain at (x, z): gentle hills of a few metres. The terrain mesh
/// samples it at its vertices, and every instance stands at this height.
pub fn forest_terrain_height(x: f32, z: f32) -> f32 {
    let hills: f32 = HILLS.iter().map(|&(a, lx, lz)| a * (TAU * x / lx).sin() * (TAU * z / lz).cos()).sum();
    hills + RIPPLE_AMPLITUDE * (TAU * (x + 0.6 * z) / RIPPLE_WAVELENGTH).sin()
}

/// The gradient (∂h/∂x, ∂h/∂z) of [`forest_terrain_height`].
fn forest_terrain_gradient(x: f32, z: f32) -> Vec2 {
    let mut g = Vec2::ZERO;
    for &(a, lx, lz) in &HILLS {
        let (kx, kz) = (TAU / lx, TAU / lz);
        g.x += a * kx * (kx * x).cos() * (kz * z).cos();
        g.y -= a * kz * (kx * x).sin() * (kz * z).sin();
    }
    let k = TAU / RIPPLE_WAVELENGTH;
    let ripple = RIPPLE_AMPLITUDE * k * (k * (x + 0.6 * z)).cos();
    g + Vec2::new(ripple, 0.6 * ripple)
}

/// The terrain: a `TERRAIN_CELLS`² grid over the square, heights from [`forest_terrain_height`],
/// analytic normals, texture coordinates tiling every `TERRAIN_UV_TILE` metres.
fn terrain_mesh() -> Mesh {
    heightfield("terrain", FOREST_SIZE, TERRAIN_CELLS, TERRAIN_UV_TILE, forest_terrain_height, |x, z| {
        let g = forest_terrain_gradient(x, z);
        Vec3::new(-g.x, 1.0, -g.y).normalize()
    })
}

/// A `cells`² grid of quads over the square of side `size` centred on the origin: heights from
/// `height(x, z)`, normals from `normal(x, z)`, texture coordinates tiling every `uv_tile` metres;
/// two triangles per quad, counter-clockwise seen from above.
pub(crate) fn heightfield(
    name: &str,
    size: f32,
    cells: usize,
    uv_tile: f32,
    height: impl Fn(f32, f32) -> f32,
    normal: impl Fn(f32, f32) -> Vec3,
) -> Mesh {
    let n = cells + 1;
    let coordinate = |i: usize| -0.5 * size + size * i as f32 / cells as f32;
    let mut mesh = named_mesh(name);
    mesh.positions.reserve(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, z) = (coordinate(i), coordinate(j));
            mesh.positions.push(Vec3::new(x, height(x, z), z));
            mesh.normals.push(normal(x, z));
            mesh.uvs.push(Vec2::new(x, z) / uv_tile);
        }
    }
    mesh.indices.reserve(cells * cells * 6);
    for j in 0..cells {
        for i in 0..cells {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
            // Counter-clockwise seen from above (+Y): a → d → c, a → c → b.
            mesh.indices.extend([a, d, c, a, c, b]);
        }
    }
    mesh
}

/// A trunk from `TRUNK_SINK` below the origin up to `height`, tapering from `r0` to `r1`.
fn add_trunk(mesh: &mut Mesh, r0: f32, r1: f32, height: f32) {
    add_lathe(mesh, Vec3::ZERO, &[ring(r0, -TRUNK_SINK), ring(r1, height)], TRUNK_SEGMENTS, NO_FLUTES);
}

/// A closed cone of foliage: base of `radius` at `y0`, tip at `y1`, its side split into rings.
fn add_cone(mesh: &mut Mesh, radius: f32, y0: f32, y1: f32) {
    let profile: Vec<Ring> = (0..=CONE_RINGS)
        .map(|k| {
            let t = k as f32 / CONE_RINGS as f32;
            ring(radius * (1.0 - t), y0 + (y1 - y0) * t)
        })
        .collect();
    add_lathe(mesh, Vec3::ZERO, &profile, CONE_SEGMENTS, NO_FLUTES);
}

/// Appends a geodesic sphere of `subdivisions`, scaled to the ellipsoid `radii` around `center`.
fn add_blob(mesh: &mut Mesh, sphere: &Mesh, center: Vec3, radii: Vec3) {
    append(mesh, &merge("", &[(sphere.clone(), Affine3A::from_scale_rotation_translation(radii, Quat::IDENTITY, center))]));
}

/// A pine: a 3.5 m trunk under five stacked cones of needles, about 11 m tall (≈3,900 triangles).
pub(crate) fn pine_mesh() -> Mesh {
    let mut mesh = named_mesh("pine");
    add_trunk(&mut mesh, 0.28, 0.12, 3.5);
    for (radius, y0, y1) in [(2.6, 2.0, 5.5), (2.2, 3.6, 7.0), (1.8, 5.2, 8.4), (1.35, 6.8, 9.7), (0.9, 8.3, 11.0)] {
        add_cone(&mut mesh, radius, y0, y1);
    }
    mesh
}

/// An oak: a stout 5 m trunk under a crown of four overlapping geodesic spheres, about 10 m tall
/// (≈5,200 triangles).
pub(crate) fn oak_mesh() -> Mesh {
    let mut mesh = named_mesh("oak");
    add_trunk(&mut mesh, 0.4, 0.25, 5.0);
    let sphere = icosphere("", CROWN_SUBDIVISIONS);
    for (center, radii) in [
        (Vec3::new(0.0, 7.0, 0.0), Vec3::new(3.2, 2.6, 3.2)),
        (Vec3::new(1.6, 6.0, 0.8), Vec3::new(2.2, 1.9, 2.2)),
        (Vec3::new(-1.4, 6.2, -1.0), Vec3::new(2.3, 2.0, 2.1)),
        (Vec3::new(0.2, 8.4, -0.4), Vec3::new(2.0, 1.6, 2.0)),
    ] {
        add_blob(&mut mesh, &sphere, center, radii);
    }
    mesh
}

/// A birch: a slender 7 m trunk under two narrow crowns, about 12 m tall (≈2,650 triangles).
pub(crate) fn birch_mesh() -> Mesh {
    let mut mesh = named_mesh("birch");
    add_trunk(&mut mesh, 0.18, 0.08, 7.0);
    let sphere = icosphere("", CROWN_SUBDIVISIONS);
    add_blob(&mut mesh, &sphere, Vec3::new(0.0, 7.5, 0.0), Vec3::new(1.8, 3.0, 1.8));
    add_blob(&mut mesh, &sphere, Vec3::new(0.3, 10.0, 0.2), Vec3::new(1.2, 2.0, 1.2));
    mesh
}

/// A bush: one squashed geodesic sphere, 1.6 m wide, sunk a little into the ground (320 triangles).
fn bush_mesh() -> Mesh {
    let mut mesh = named_mesh("bush");
    add_blob(&mut mesh, &icosphere("", BUSH_SUBDIVISIONS), Vec3::new(0.0, 0.35, 0.0), Vec3::new(0.8, 0.6, 0.8));
    mesh
}

/// Segments around each fern frond, and the fronds' number and tilt from the vertical.
const FERN_SEGMENTS: usize = 16;
const FERN_FRONDS: usize = 5;
const FERN_TILT: f32 = 0.9;

/// A fern: five thin cones leaning out from a common foot (320 triangles).
fn fern_mesh() -> Mesh {
    let mut frond = named_mesh("");
    add_lathe(&mut frond, Vec3::ZERO, &[ring(0.0, -0.1), ring(0.12, -0.1), ring(0.08, 0.5), ring(0.0, 1.1)], FERN_SEGMENTS, NO_FLUTES);
    let parts: Vec<(Mesh, Affine3A)> = (0..FERN_FRONDS)
        .map(|k| {
            let turn = Quat::from_rotation_y(TAU * k as f32 / FERN_FRONDS as f32) * Quat::from_rotation_x(FERN_TILT);
            (frond.clone(), Affine3A::from_quat(turn))
        })
        .collect();
    merge("fern", &parts)
}

/// The placement of one instance standing at (x, z) on the terrain: a random turn about Y and a
/// random uniform scale.
fn instance_transform(rng: &mut SplitMix64, x: f32, z: f32) -> Transform {
    let yaw = rng.range(0.0, TAU);
    let scale = rng.range(SCALE_MIN, SCALE_MAX);
    Transform::from_xyz(x, forest_terrain_height(x, z), z).with_rotation(Quat::from_rotation_y(yaw)).with_scale(Vec3::splat(scale))
}

/// A forest of ≈21.6 million instanced triangles on a 200 m × 200 m hilly terrain, for benchmarking
/// instancing, acceleration-structure builds and DDGI over large open scenes.
///
/// Six unique meshes (143,000 triangles together): the terrain (a 256² grid, 131,072 triangles) and
/// three tree variants (pine ≈3,900, oak ≈5,200, birch ≈2,650 triangles: trunks under cones or
/// geodesic spheres) and two plants (bush and fern, 320 each). 4,900 trees stand on a jittered
/// 70 × 70 grid and 6,500 plants are scattered uniformly: 11,400 instances, each its own node (a
/// child of the `trees` or `plants` group) drawing one mesh with one material, turned randomly
/// about Y, scaled by 0.7–1.3 and standing at [`forest_terrain_height`]. Placement is deterministic
/// (fixed seed). A 7 W/m² sun 40° high; the camera looks across the forest from above a corner.
pub fn forest() -> SceneDescription {
    let mut desc = SceneDescription { name: "forest".into(), ..Default::default() };
    let ground = desc.add_material(Material::diffuse("ground", GROUND_ALBEDO));
    let terrain = desc.add_mesh(terrain_mesh());
    desc.add_node("terrain", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(terrain, ground)])]);

    let kind = |desc: &mut SceneDescription, mesh: Mesh, albedo: Vec3| {
        let name = mesh.name.clone();
        let material = desc.add_material(Material::diffuse(&name, albedo));
        (name, desc.add_mesh(mesh), material)
    };
    let trees =
        [kind(&mut desc, pine_mesh(), PINE_ALBEDO), kind(&mut desc, oak_mesh(), OAK_ALBEDO), kind(&mut desc, birch_mesh(), BIRCH_ALBEDO)];
    let plants = [kind(&mut desc, bush_mesh(), BUSH_ALBEDO), kind(&mut desc, fern_mesh(), FERN_ALBEDO)];

    let mut rng = SplitMix64::new(FOREST_SEED);
    desc.nodes.reserve(TREE_GRID * TREE_GRID + PLANT_COUNT + 4);
    let tree_group = desc.add_node("trees", Transform::IDENTITY, None, vec![NodeContent::Empty]);
    let cell = FOREST_SIZE / TREE_GRID as f32;
    let limit = 0.5 * FOREST_SIZE - EDGE_MARGIN;
    for row in 0..TREE_GRID {
        for col in 0..TREE_GRID {
            let x = -0.5 * FOREST_SIZE + (col as f32 + 0.5 + rng.range(-TREE_JITTER, TREE_JITTER)) * cell;
            let z = -0.5 * FOREST_SIZE + (row as f32 + 0.5 + rng.range(-TREE_JITTER, TREE_JITTER)) * cell;
            let (name, mesh, material) = &trees[rng.below(trees.len())];
            let transform = instance_transform(&mut rng, x.clamp(-limit, limit), z.clamp(-limit, limit));
            let index = row * TREE_GRID + col;
            desc.add_node(&format!("{name}_{index}"), transform, Some(tree_group), vec![NodeContent::Meshes(vec![(*mesh, *material)])]);
        }
    }
    let plant_group = desc.add_node("plants", Transform::IDENTITY, None, vec![NodeContent::Empty]);
    for index in 0..PLANT_COUNT {
        let (x, z) = (rng.range(-limit, limit), rng.range(-limit, limit));
        let (name, mesh, material) = &plants[rng.below(plants.len())];
        let transform = instance_transform(&mut rng, x, z);
        desc.add_node(&format!("{name}_{index}"), transform, Some(plant_group), vec![NodeContent::Meshes(vec![(*mesh, *material)])]);
    }

    let direction = sun_direction(FOREST_SUN_ELEVATION_DEGREES.to_radians(), FOREST_SUN_AZIMUTH_DEGREES.to_radians());
    add_sun(&mut desc, Vec3::new(0.0, forest_terrain_height(0.0, 0.0), 0.0), direction, FOREST_SUN_INTENSITY);
    let ground_at = |p: Vec2| Vec3::new(p.x, forest_terrain_height(p.x, p.y), p.y);
    let eye = ground_at(FOREST_CAMERA_XZ) + Vec3::Y * FOREST_CAMERA_HEIGHT;
    add_camera(&mut desc, eye, ground_at(FOREST_CAMERA_TARGET_XZ), FOREST_CAMERA_YFOV_DEGREES, FOREST_CAMERA_EXPOSURE);
    desc
}

//! The [`cathedral`]: a closed stone basilica lit by the sun through its windows, its dimensions,
//! window list, and the builders of its walls, vaults, columns and floor.

use std::f32::consts::{FRAC_PI_2, PI};
use std::sync::LazyLock;

use engine::scene::{Material, Mesh, NodeContent, SceneDescription, Transform};
use engine::shapes::{box_part, box_with_hole};
use glam::Vec3;

use super::mesh::{Flutes, Ring, add_lathe, add_shell, append_parts, fluted, named_mesh, ring};
use super::{add_sun, sun_direction};
use crate::{Opening, add_camera};

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

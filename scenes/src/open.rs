//! `open_world`: a kilometre of open ground to walk through, for camera-following probe cascades
//! and large-world coordinates. A small house with a door and a window stands in a flat yard in
//! the middle of a 1 km × 1 km hilly terrain; the forest's instanced trees (pine, oak, birch) stand
//! all around it, thinning out towards the yard; a sun 35° high. [`OPEN_WORLD_TOUR`] walks from
//! the house's door into the forest and back.
//!
//! Conventions as in [`crate::large`]: Y up, metres, deterministic (fixed seed).

use std::f32::consts::TAU;

use engine::rng::SplitMix64;
use engine::scene::{Material, Mesh, NodeContent, SceneDescription, Transform};
use engine::shapes::{Shell, box_part, merge};
use glam::{Quat, Vec2, Vec3};

use crate::add_camera;
use crate::large::{
    BIRCH_ALBEDO, GROUND_ALBEDO, OAK_ALBEDO, PINE_ALBEDO, add_sun, birch_mesh, heightfield, oak_mesh, pine_mesh, sun_direction,
};

/// Side of the square terrain (metres).
pub const OPEN_WORLD_SIZE: f32 = 1000.0;
/// Terrain grid cells per side (≈3.9 m cells, 131,072 triangles).
const TERRAIN_CELLS: usize = 256;
/// The flat yard around the house: flat within this radius, blending into the hills over as much again.
pub const YARD_RADIUS: f32 = 30.0;
/// Trees stand on a jittered grid of this spacing, outside the yard (≈6,900 trees).
const TREE_SPACING: f32 = 12.0;
const TREE_JITTER: f32 = 0.4;
const TREE_SEED: u64 = 0x0BE2_0DD6_2026_1202;

/// The house: interior footprint (x, z) from `HOUSE_MIN` to `HOUSE_MAX`, walls `HOUSE_HEIGHT` high.
pub const HOUSE_MIN: Vec2 = Vec2::new(-4.0, -3.0);
pub const HOUSE_MAX: Vec2 = Vec2::new(4.0, 3.0);
const HOUSE_HEIGHT: f32 = 3.0;
const WALL: f32 = 0.25;
/// The door, in the +Z wall, and a window in the -X wall.
const DOOR_HALF_WIDTH: f32 = 0.7;
const DOOR_HEIGHT: f32 = 2.2;
const WINDOW: (Vec2, Vec2) = (Vec2::new(-1.0, 1.0), Vec2::new(1.0, 2.2));

const WALL_ALBEDO: Vec3 = Vec3::new(0.75, 0.7, 0.62);
const ROOF_ALBEDO: Vec3 = Vec3::new(0.45, 0.2, 0.15);

const SUN_ELEVATION_DEGREES: f32 = 35.0;
const SUN_AZIMUTH_DEGREES: f32 = 60.0;
const SUN_INTENSITY: f32 = 7.0;

/// Eye height of the tour (metres above the ground).
pub const EYE_HEIGHT: f32 = 1.7;

/// The tour's waypoints (x, z): out of the house's door, across the yard, 500 m into the forest
/// and back to the door — 983 m.
pub const OPEN_WORLD_TOUR: &[Vec2] = &[
    Vec2::new(0.0, 1.5),
    Vec2::new(0.0, 8.0),
    Vec2::new(30.0, 60.0),
    Vec2::new(120.0, 200.0),
    Vec2::new(260.0, 420.0),
    Vec2::new(160.0, 300.0),
    Vec2::new(20.0, 40.0),
    Vec2::new(0.0, 8.0),
];

/// Height of the terrain at (x, z): hills of up to ±8 m on wavelengths of 120–400 m, flat in the
/// yard.
pub fn open_world_height(x: f32, z: f32) -> f32 {
    let hills = 5.0 * (TAU * x / 400.0).sin() * (TAU * z / 330.0).cos()
        + 2.0 * (TAU * (x + 0.7 * z) / 170.0).sin()
        + 1.0 * (TAU * (0.4 * x - z) / 120.0).cos();
    let r = Vec2::new(x, z).length();
    let t = ((r - YARD_RADIUS) / YARD_RADIUS).clamp(0.0, 1.0);
    let blend = t * t * (3.0 - 2.0 * t);
    hills * blend
}

/// Where the tour stands after walking `distance` metres along [`OPEN_WORLD_TOUR`] (clamped to its
/// end), at eye height, and the direction it walks in.
pub fn tour_at(distance: f32) -> (Vec3, Vec3) {
    let mut left = distance.max(0.0);
    for pair in OPEN_WORLD_TOUR.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let length = a.distance(b);
        if left <= length || std::ptr::eq(pair, OPEN_WORLD_TOUR.windows(2).last().unwrap_or(pair)) {
            let p = a + (b - a) * (left / length.max(1e-6)).min(1.0);
            let dir = (b - a).normalize_or(Vec2::Y);
            return (Vec3::new(p.x, open_world_height(p.x, p.y) + EYE_HEIGHT, p.y), Vec3::new(dir.x, 0.0, dir.y));
        }
        left -= length;
    }
    let p = OPEN_WORLD_TOUR[0];
    (Vec3::new(p.x, EYE_HEIGHT, p.y), Vec3::Z)
}

/// The tour's length in metres.
pub fn tour_length() -> f32 {
    OPEN_WORLD_TOUR.windows(2).map(|p| p[0].distance(p[1])).sum()
}

fn terrain() -> Mesh {
    let h = 0.5;
    let normal = |x: f32, z: f32| {
        let gx = (open_world_height(x + h, z) - open_world_height(x - h, z)) / (2.0 * h);
        let gz = (open_world_height(x, z + h) - open_world_height(x, z - h)) / (2.0 * h);
        Vec3::new(-gx, 1.0, -gz).normalize()
    };
    heightfield("open_terrain", OPEN_WORLD_SIZE, TERRAIN_CELLS, 4.0, open_world_height, normal)
}

/// The house's walls (with the door and window holes) and its roof, closed solids.
fn house() -> (Mesh, Mesh) {
    let (lo, hi) = (Vec3::new(HOUSE_MIN.x, 0.0, HOUSE_MIN.y), Vec3::new(HOUSE_MAX.x, HOUSE_HEIGHT, HOUSE_MAX.y));
    let shell = Shell::around(lo, hi, WALL);
    let mut parts = vec![shell.slab_part(2, false), shell.slab_part(0, true)];
    let (o_lo, o_hi) = (shell.outer_min, shell.outer_max);
    // The door through the +Z wall (from the ground up), the window through the -X wall.
    parts.extend(shell.slab_with_hole(2, true, Vec3::new(-DOOR_HALF_WIDTH, 0.0, hi.z), Vec3::new(DOOR_HALF_WIDTH, DOOR_HEIGHT, o_hi.z)));
    parts.extend(shell.slab_with_hole(0, false, Vec3::new(o_lo.x, WINDOW.0.y, WINDOW.0.x), Vec3::new(lo.x, WINDOW.1.y, WINDOW.1.x)));
    let walls = merge("house_walls", &parts);
    let roof =
        merge("house_roof", &[box_part(Vec3::new(o_lo.x - 0.3, hi.y, o_lo.z - 0.3), Vec3::new(o_hi.x + 0.3, hi.y + 0.3, o_hi.z + 0.3))]);
    (walls, roof)
}

/// The open world (see the module's documentation): ≈27 million instanced triangles.
pub fn open_world() -> SceneDescription {
    let mut desc = SceneDescription { name: "open_world".into(), ..Default::default() };
    let ground = desc.add_material(Material::diffuse("ground", GROUND_ALBEDO));
    desc.add_mesh_node("terrain", Transform::IDENTITY, terrain(), ground);
    let (walls, roof) = house();
    let wall = desc.add_material(Material::diffuse("house_wall", WALL_ALBEDO));
    let roofing = desc.add_material(Material::diffuse("house_roof", ROOF_ALBEDO));
    desc.add_mesh_node("house_walls", Transform::IDENTITY, walls, wall);
    desc.add_mesh_node("house_roof", Transform::IDENTITY, roof, roofing);

    let kinds: Vec<(usize, usize, &str)> =
        [("pine", pine_mesh(), PINE_ALBEDO), ("oak", oak_mesh(), OAK_ALBEDO), ("birch", birch_mesh(), BIRCH_ALBEDO)]
            .into_iter()
            .map(|(name, mesh, albedo)| {
                let material = desc.add_material(Material::diffuse(name, albedo));
                (desc.add_mesh(mesh), material, name)
            })
            .collect();
    let trees = desc.add_node("trees", Transform::IDENTITY, None, vec![NodeContent::Empty]);
    let mut rng = SplitMix64::new(TREE_SEED);
    let cells = (OPEN_WORLD_SIZE / TREE_SPACING) as usize;
    let limit = 0.5 * OPEN_WORLD_SIZE - 2.0;
    for row in 0..cells {
        for col in 0..cells {
            let x = -0.5 * OPEN_WORLD_SIZE + (col as f32 + 0.5 + rng.range(-TREE_JITTER, TREE_JITTER)) * TREE_SPACING;
            let z = -0.5 * OPEN_WORLD_SIZE + (row as f32 + 0.5 + rng.range(-TREE_JITTER, TREE_JITTER)) * TREE_SPACING;
            let kind = rng.below(kinds.len());
            let (yaw, scale) = (rng.range(0.0, TAU), rng.range(0.7, 1.3));
            // None in the yard, fewer near it (and along the tour's first stretch, a path).
            let r = Vec2::new(x, z).length();
            let keep = ((r - YARD_RADIUS) / (2.0 * YARD_RADIUS)).clamp(0.0, 1.0);
            if rng.unit() >= keep || x.abs() > limit || z.abs() > limit || near_path(Vec2::new(x, z)) {
                continue;
            }
            let (mesh, material, name) = kinds[kind];
            let t =
                Transform::from_xyz(x, open_world_height(x, z), z).with_rotation(Quat::from_rotation_y(yaw)).with_scale(Vec3::splat(scale));
            desc.add_node(&format!("{name}_{row}_{col}"), t, Some(trees), vec![NodeContent::Meshes(vec![(mesh, material)])]);
        }
    }
    let direction = sun_direction(SUN_ELEVATION_DEGREES.to_radians(), SUN_AZIMUTH_DEGREES.to_radians());
    add_sun(&mut desc, Vec3::ZERO, direction, SUN_INTENSITY);
    // The tour's start, looking out of the door into the yard.
    let (eye, forward) = tour_at(0.0);
    add_camera(&mut desc, eye, eye + forward * 10.0 - Vec3::Y * 0.5, 70.0, 1.0);
    desc
}

/// Whether (x, z) lies within 3 m of the tour's path (kept free of trees, so the walk passes none).
fn near_path(p: Vec2) -> bool {
    OPEN_WORLD_TOUR.windows(2).any(|pair| {
        let (a, b) = (pair[0], pair[1]);
        let ab = b - a;
        let t = ((p - a).dot(ab) / ab.length_squared().max(1e-6)).clamp(0.0, 1.0);
        p.distance(a + ab * t) < 3.0
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_open_world_is_a_kilometre_of_forest_around_a_house_and_its_tour_is_clear() {
        let desc = open_world();
        let trees: Vec<_> = desc.nodes.iter().filter(|n| n.name.starts_with(['p', 'o', 'b']) && n.parent.is_some()).collect();
        let triangles = desc.instanced_triangle_count();
        assert!(trees.len() > 5_000, "{} trees", trees.len());
        assert!((15_000_000..40_000_000).contains(&triangles), "{triangles} instanced triangles");
        let (lo, hi) = desc.bounds().expect("geometry");
        assert!((hi - lo).x > 990.0 && (hi - lo).z > 990.0, "{lo}..{hi}");
        let length = tour_length();
        assert!((950.0..1050.0).contains(&length), "tour {length} m");
        for tree in &trees {
            let p = tree.transform.translation;
            // Every tree stands on the ground, none in the yard or on the tour's path.
            assert!((p.y - open_world_height(p.x, p.z)).abs() < 1e-3, "{} floats", tree.name);
            assert!(Vec2::new(p.x, p.z).length() > YARD_RADIUS, "{} stands in the yard", tree.name);
            assert!(!near_path(Vec2::new(p.x, p.z)), "{} stands on the path", tree.name);
        }
        // The tour starts and ends at the door and stays at eye height over the ground.
        for k in 0..=100 {
            let (eye, forward) = tour_at(length * k as f32 / 100.0);
            assert!((eye.y - open_world_height(eye.x, eye.z) - EYE_HEIGHT).abs() < 1e-3);
            assert!((forward.length() - 1.0).abs() < 1e-4);
        }
        assert!(tour_at(length).0.distance(tour_at(0.0).0) < 10.0, "the tour comes back to the door");
        assert_eq!(open_world_height(3.0, -4.0), 0.0, "the yard is flat");
        assert_eq!(open_world(), desc, "deterministic");
    }
}

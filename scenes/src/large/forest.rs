//! The [`forest`]: a hilly terrain with 11,400 instances of three trees and two plants, the
//! terrain's height function and heightfield mesh, and the tree and plant meshes (the open world
//! reuses the trees, the albedos and the heightfield).

use std::f32::consts::TAU;

use engine::rng::SplitMix64;
use engine::scene::{Material, Mesh, NodeContent, SceneDescription, Transform};
use engine::shapes::merge;
use glam::{Affine3A, Quat, Vec2, Vec3};

use super::mesh::{NO_FLUTES, Ring, add_lathe, append, icosphere, named_mesh, ring};
use super::{add_sun, sun_direction};
use crate::add_camera;

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

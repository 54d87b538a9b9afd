//! Large procedural benchmark scenes, built in code (no files), for measuring how rendering and
//! dynamic diffuse global illumination (DDGI) scale with scene size.
//!
//! | scene           | what it measures                                                             |
//! |-----------------|------------------------------------------------------------------------------|
//! | [`cathedral()`] | a closed stone interior of ≈73,000 static triangles lit by the sun through   |
//! |                 | its windows, in the spirit of the Sibenik cathedral of the DDGI literature   |
//! | [`forest()`]    | ≈21.6 million instanced triangles: 11,400 instances of six unique meshes     |
//!
//! Both are entries of [`crate::ALL`]. Everything here is deterministic: building a scene twice
//! gives equal descriptions (the forest uses a small inline SplitMix64 generator with a fixed seed).
//!
//! Conventions as in [`crate::rooms`]: Y is up, one unit is a metre, cameras and lights look along
//! their local -Z, a [`DirectionalLight`]'s intensity is irradiance (W/m²). Every generated mesh but
//! the forest's terrain (an open heightfield) is a union of closed solids whose triangles are wound
//! counter-clockwise seen from outside, with unit vertex normals pointing out of the solid; no
//! triangle is degenerate.
//!
//! Each scene has its own file (`cathedral.rs`, `forest.rs`); the mesh builders they share (grids,
//! shells, lathes, geodesic spheres) are in `mesh.rs`, and the sun they place (also used by the
//! open world and the scenes from files) is here.

mod cathedral;
mod forest;
mod mesh;

use engine::scene::{DirectionalLight, NodeContent, SceneDescription, Transform};
use glam::Vec3;

use crate::SUN_COLOR;

pub use cathedral::{CATHEDRAL_NAVE_MAX, CATHEDRAL_NAVE_MIN, cathedral, cathedral_openings};
pub(crate) use forest::{BIRCH_ALBEDO, GROUND_ALBEDO, OAK_ALBEDO, PINE_ALBEDO, birch_mesh, heightfield, oak_mesh, pine_mesh};
pub use forest::{FOREST_SIZE, forest, forest_terrain_height};

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

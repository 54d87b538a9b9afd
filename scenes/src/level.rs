//! The demo level's content: a grass field kit-bashed from Kenney's FPS kit (CC0, loaded from the
//! shared folder beside the checkout, [`kenney_assets_dir`]) or from the project's own low-poly
//! props ([`props`]) around a house built from thick procedural boxes, its lights, camera, sky and DDGI volume, and its floor plan
//! for a navigation mesh and a character controller. What animates it (the door, the lift, the
//! day–night cycle, the colour-cycling light) is the demo's (`game_demo`'s `play::level`); the
//! parameters of the sun's day and of the light's colour are here, since the scene is built from
//! their state at time 0. The evaluation, the demo and the peer benchmark find it by [`NAME`].
//!
//! Layout (Y up, metres; the plan is x to the east, z to the south):
//! - the field: 36 m × 36 m of grass (x, z in -18..18), fenced by Kenney low walls just outside;
//! - the house: interior 10 m × 8 m × 3.5 m (x -5..5, z -12..-4, floor 0.15 m above the grass),
//!   0.3 m walls, flat roof with an overhang; a 1.4 m × 2.3 m doorway in the south wall closed by a
//!   sliding door that disappears into the wall, two windows beside it; inside a saturated red west
//!   wall, a saturated green east wall, an emissive panel on the north wall, a crate, a pillar and a
//!   light orbiting under the ceiling whose hue cycles;
//! - outdoors: a ruined L-shaped wall, stepped grass terraces (0.3, 0.6, 0.9 m), grass tufts, clouds,
//!   a flying enemy circling the field and a lift platform east of the house moving between 0.3 m
//!   and 2.8 m.
//!
//! Every mesh is a closed solid (boxes, Kenney's closed models, the props' closed pieces) so that
//! probes can tell inside from outside. Without the Kenney folder each model is replaced by the
//! project's own prop of the same size, so the layout (and the tests) do not depend on the assets.
//!
//! Here are the level's public face (its plan's types, node names, probe grid, door views), its
//! dimensions and [`demo_level`]; the scene builder is in `level/builder.rs`, the Kenney models it
//! places in `level/kit.rs`, the house, outdoors and lift it builds in `level/sections.rs`, the sun's
//! day and the light's colour cycle in `level/cycles.rs`, the stand-in props in `level/props.rs`.

mod builder;
mod cycles;
mod kit;
pub mod props;
mod sections;
#[cfg(test)]
mod tests;

use std::f32::consts::TAU;
use std::path::{Path, PathBuf};

use engine::scene::{Camera, DirectionalLight, NodeContent, Orbit, PointLight, SceneDescription, Transform};
use glam::{UVec3, Vec2, Vec3};

use builder::Builder;
pub use cycles::{ColorCycle, DayNight, SunState, smoothstep};
pub use sections::door_transforms;
use sections::{build_house, build_lift, build_outdoors};

/// The level's name in `render`, `eval`, `bench` and `peer` (`--scene level`).
pub const NAME: &str = "level";

/// Spacing of the probes of the level's DDGI volume (metres): `play`'s volume and the
/// evaluation's grid ([`probe_counts`]).
pub const PROBE_SPACING: f32 = 1.5;

/// The probe grid of the level's DDGI volume: every [`PROBE_SPACING`] metres over
/// [`level_gi_bounds`].
pub fn probe_counts() -> UVec3 {
    level_probe_counts(PROBE_SPACING)
}

/// The level as `render`, `eval` and `peer` show it: with the Kenney models when they are there
/// ([`kenney_assets_or_note`]), with the project's own props otherwise.
pub fn scene() -> SceneDescription {
    demo_level(kenney_assets_or_note().as_deref()).scene
}

/// An axis-aligned rectangle of the floor plan: `min`/`max` are (x, z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub min: Vec2,
    pub max: Vec2,
}

impl Footprint {
    pub fn new(min: Vec2, max: Vec2) -> Self {
        Self { min, max }
    }

    /// The plan of the box `min`..`max`.
    pub fn of_box(min: Vec3, max: Vec3) -> Self {
        Self { min: Vec2::new(min.x, min.z), max: Vec2::new(max.x, max.z) }
    }

    /// Inclusive containment of the point (x, z).
    pub fn contains(&self, p: Vec2) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Grown by `by` on every side (shrunk when negative).
    pub fn inflate(&self, by: f32) -> Self {
        Self { min: self.min - Vec2::splat(by), max: self.max + Vec2::splat(by) }
    }

    /// The rectangle's centre.
    pub fn center(&self) -> Vec2 {
        (self.min + self.max) * 0.5
    }
}

/// A static walkable surface at `height`: the top of a solid that fills its footprint from below.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Floor {
    pub footprint: Footprint,
    pub height: f32,
}

/// The door: its node's name, and the doorway it blocks while closed.
#[derive(Clone, Debug, PartialEq)]
pub struct DoorSpec {
    pub node: String,
    pub footprint: Footprint,
}

/// The lift platform: its node's name, its footprint, and its top's height range and period.
#[derive(Clone, Debug, PartialEq)]
pub struct PlatformSpec {
    pub node: String,
    pub footprint: Footprint,
    pub low: f32,
    pub high: f32,
    pub period: f32,
}

impl PlatformSpec {
    /// Height of the platform's top at `t` seconds: a cosine ease from `low` (t = 0) to `high`
    /// (half a period) and back.
    pub fn height_at(&self, t: f64) -> f32 {
        let phase = (t / self.period.max(1e-3) as f64).fract() as f32;
        let s = 0.5 - 0.5 * (TAU * phase).cos();
        self.low + (self.high - self.low) * s
    }
}

/// The floor plan the navigation mesh and the controller use.
#[derive(Clone, Debug, PartialEq)]
pub struct LevelLayout {
    /// The walkable outer edge: nobody can leave it.
    pub bounds: Footprint,
    /// Blocking footprints (walls, large props), full height.
    pub walls: Vec<Footprint>,
    pub floors: Vec<Floor>,
    pub door: DoorSpec,
    pub platform: PlatformSpec,
    /// Feet position at the start, outdoors.
    pub spawn: Vec3,
    /// A feet position inside the house.
    pub indoor_point: Vec3,
    /// Feet waypoints of a scripted walk: outdoors, through the door into the house, back out, onto
    /// the platform.
    pub tour: Vec<Vec3>,
    pub gi_bounds: (Vec3, Vec3),
}

/// The level: its scene and its floor plan.
#[derive(Clone, Debug)]
pub struct DemoLevel {
    pub scene: SceneDescription,
    pub layout: LevelLayout,
}

/// Node names.
pub const SUN: &str = "sun";
pub const DOOR: &str = "door";
pub const PLATFORM: &str = "lift_platform";
pub const MOVING_LIGHT: &str = "moving_light";
pub const PLAYER_CAMERA: &str = "player_camera";
pub const ENEMY: &str = "enemy_flying";

/// The box the level's DDGI volume fills: the field and a metre around it, from under the ground to
/// over the roof.
pub fn level_gi_bounds() -> (Vec3, Vec3) {
    (Vec3::new(-FIELD_HALF - 1.0, -0.5, -FIELD_HALF - 1.0), Vec3::new(FIELD_HALF + 1.0, 7.0, FIELD_HALF + 1.0))
}

/// Probes along each axis of the level's DDGI volume at `spacing` metres (at least one).
pub fn level_probe_counts(spacing: f32) -> UVec3 {
    let (lo, hi) = level_gi_bounds();
    ((hi - lo) / spacing.max(0.05)).ceil().as_uvec3().max(UVec3::ONE)
}

/// The door's transform when open (the scene holds it closed).
pub fn door_open_transform() -> Transform {
    door_transforms().1
}

/// A camera standing in the back of the house, facing the door (eye height): the view in which
/// the door opening changes the most.
pub fn view_of_the_door_from_inside() -> Transform {
    let eye = Vec3::new(HOUSE_MAX.x - 1.5, HOUSE_MIN.y + 1.6, HOUSE_MIN.z + 1.5);
    let door = Vec3::new((DOOR_X.0 + DOOR_X.1) * 0.5, HOUSE_MIN.y + 1.2, HOUSE_MAX.z);
    Transform::from_translation(eye).looking_at(door, Vec3::Y)
}

/// [`kenney_assets_dir`], with a note on stderr when it is absent.
pub fn kenney_assets_or_note() -> Option<PathBuf> {
    let dir = kenney_assets_dir();
    if dir.is_none() {
        eprintln!("note: {}; the level uses its own procedural props", crate::shared::absent(crate::shared::KENNEY_FPS));
    }
    dir
}

/// Kenney's Starter Kit FPS (CC0, by Kenney) in the shared folder beside the checkout
/// (`../shared/assets/kenney_fps`, see [`crate::shared`]), if it is there with its texture folder.
/// The repository holds none of it.
pub fn kenney_assets_dir() -> Option<PathBuf> {
    crate::shared::path(crate::shared::KENNEY_FPS).filter(|d| d.join("Textures").is_dir())
}

// ---------------------------------------------------------------------------------------------
// Dimensions
// ---------------------------------------------------------------------------------------------

/// Half the side of the square field (walkable bounds).
const FIELD_HALF: f32 = 18.0;
/// Ground slab: its top is y = 0; it reaches this far down and past the field.
const GROUND_DEPTH: f32 = 3.0;
const GROUND_HALF: f32 = 22.0;

/// The house interior (its floor to its ceiling) and its wall thickness.
pub const HOUSE_MIN: Vec3 = Vec3::new(-5.0, 0.15, -12.0);
pub const HOUSE_MAX: Vec3 = Vec3::new(5.0, 3.65, -4.0);
const HOUSE_WALL: f32 = 0.3;
/// The doorway in the south wall (x range, top height).
const DOOR_X: (f32, f32) = (-0.7, 0.7);
const DOOR_TOP: f32 = 2.45;
/// How far the door slides east to open (into the wall).
const DOOR_SLIDE: f32 = 1.45;
const DOOR_THICKNESS: f32 = 0.1;
/// Windows in the south wall (x ranges) between these heights.
const WINDOWS_X: [(f32, f32); 2] = [(-4.2, -2.6), (2.6, 4.2)];
const WINDOW_Y: (f32, f32) = (1.0, 2.3);

/// The lift.
const LIFT_MIN: Vec2 = Vec2::new(12.0, -8.0);
const LIFT_MAX: Vec2 = Vec2::new(14.5, -5.5);
const LIFT_LOW: f32 = 0.3;
const LIFT_HIGH: f32 = 2.8;
const LIFT_PERIOD: f32 = 10.0;

/// Albedos (linear).
const GRASS: Vec3 = Vec3::new(0.22, 0.42, 0.12);
const PLASTER: Vec3 = Vec3::new(0.75, 0.72, 0.66);
const WOOD_FLOOR: Vec3 = Vec3::new(0.55, 0.42, 0.3);
const ROOF: Vec3 = Vec3::new(0.35, 0.12, 0.08);
const RED: Vec3 = Vec3::new(0.85, 0.04, 0.03);
const GREEN: Vec3 = Vec3::new(0.04, 0.7, 0.08);
const DOOR_WOOD: Vec3 = Vec3::new(0.45, 0.24, 0.1);
const STONE: Vec3 = Vec3::new(0.5, 0.5, 0.52);
const LIFT_PAINT: Vec3 = Vec3::new(0.9, 0.5, 0.08);

/// Builds the level; `assets` is the Kenney FPS kit folder (see [`kenney_assets_dir`]). Missing or
/// unreadable models are replaced by the level's own props of the same size ([`props`]).
pub fn demo_level(assets: Option<&Path>) -> DemoLevel {
    match assets {
        Some(dir) if dir.is_dir() => log::info!("demo level: Kenney models from {}", dir.display()),
        Some(dir) => log::warn!("demo level: {} is not a folder; the level's own props", dir.display()),
        None => log::info!("demo level: no Kenney assets; the level's own props"),
    }
    let mut b = Builder {
        desc: SceneDescription { name: "demo_level".into(), ..Default::default() },
        assets: assets.filter(|d| d.is_dir()).map(Path::to_path_buf),
        walls: Vec::new(),
        floors: Vec::new(),
        loaded: Vec::new(),
    };
    let bounds = Footprint::new(Vec2::splat(-FIELD_HALF), Vec2::splat(FIELD_HALF));

    // Ground.
    let grass = b.material("grass", GRASS);
    b.solid("ground", Vec3::new(-GROUND_HALF, -GROUND_DEPTH, -GROUND_HALF), Vec3::new(GROUND_HALF, 0.0, GROUND_HALF), grass);
    b.floors.push(Floor { footprint: bounds, height: 0.0 });

    build_house(&mut b);
    build_outdoors(&mut b);
    let platform = build_lift(&mut b);

    // Lights and camera.
    let day = DayNight::default();
    let sun = day.state(0.0);
    b.desc.add_node(
        SUN,
        sun.transform,
        None,
        vec![NodeContent::DirectionalLight(DirectionalLight { color: sun.color, intensity: sun.intensity })],
    );

    let orbit = Orbit { center: Vec3::new(0.0, 2.8, -8.0), radius: 2.5, period: 12.0, look_at: None };
    let cycle = ColorCycle::default();
    let light = PointLight { color: cycle.color_at(0.0), intensity: cycle.intensity, range: Some(12.0) };
    let node = b.desc.add_node(
        MOVING_LIGHT,
        Transform::from_translation(orbit.center + Vec3::X * orbit.radius),
        None,
        vec![NodeContent::PointLight(light)],
    );
    b.desc.nodes[node].orbit = Some(orbit);

    let spawn = Vec3::new(0.0, 0.0, 10.0);
    let camera = Camera { yfov: 70f32.to_radians(), znear: 0.05, exposure: 1.0 };
    b.desc.add_node(PLAYER_CAMERA, Transform::from_translation(spawn + Vec3::Y * 1.6), None, vec![NodeContent::Camera(camera)]);

    let floor_y = HOUSE_MIN.y;
    let tour = vec![
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::new(0.0, 0.0, -1.5),
        Vec3::new(0.0, floor_y, -6.0),
        Vec3::new(-3.0, floor_y, -7.5),
        Vec3::new(3.0, floor_y, -8.5),
        Vec3::new(0.0, floor_y, -5.5),
        Vec3::new(0.0, 0.0, -1.5),
        Vec3::new(8.0, 0.0, -2.0),
        Vec3::new((LIFT_MIN.x + LIFT_MAX.x) * 0.5, LIFT_LOW, (LIFT_MIN.y + LIFT_MAX.y) * 0.5),
    ];
    let door_footprint = Footprint::new(Vec2::new(DOOR_X.0, HOUSE_MAX.z), Vec2::new(DOOR_X.1, HOUSE_MAX.z + HOUSE_WALL));
    let layout = LevelLayout {
        bounds,
        walls: b.walls.clone(),
        floors: b.floors.clone(),
        door: DoorSpec { node: DOOR.into(), footprint: door_footprint },
        platform,
        spawn,
        indoor_point: Vec3::new(2.5, floor_y, -7.0),
        tour,
        gi_bounds: level_gi_bounds(),
    };
    DemoLevel { scene: b.desc, layout }
}

/// A small deterministic generator for decoration placement.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }

    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next()
    }
}

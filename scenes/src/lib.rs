//! Built-in scenes that need no files: small rooms that each isolate one phenomenon dynamic diffuse
//! global illumination (DDGI) has to get right ([`rooms`]) and large benchmark scenes ([`large`]).
//!
//! | scene             | what it tests                                                          |
//! |-------------------|------------------------------------------------------------------------|
//! | `cornell`         | colour bleeding and soft indirect light in the classic reference box   |
//! | `ceiling_opening` | a half lit only indirectly, behind a thick divider lit on one face     |
//! | `door_room`       | light leaking into a closed room whose only way in is a door           |
//! | `door_room_thin`  | the same with walls 1/25 of a scene-wide volume's spacing: any grid    |
//! | `color_bleed`     | indirect light that follows a moving spot light (probe update speed)   |
//! | `cathedral`       | ≈73,000 static triangles, a closed interior lit through its windows    |
//! | `forest`          | ≈21.6 million instanced triangles over a hilly terrain                 |
//! | `open_world`      | a house in a yard amid a 1 km² forest: camera-following cascades       |
//!
//! Scenes made by others, loaded from the shared folder and given the lights and camera they lack,
//! are in [`files`] (`sibenik`, the real Šibenik cathedral; `flight_helmet`, Khronos's FlightHelmet in a
//! sunlit corner; `meadow`, cut-out plant cards instanced on a meadow).
//!
//! The demo level ([`level`], found by [`level::NAME`]) is built here too, outside [`ALL`]: it uses
//! Kenney's models from the shared folder beside the checkout when they are there ([`shared`]) and
//! its own procedural props otherwise, and its plan and animations belong to the demo.
//!
//! [`ALL`] is the one table of them: each [`SceneEntry`] holds a scene's name, builder, probe
//! volume bounds and openings, and what the evaluation and the demo know of it (its published
//! probe grid, its change in a time series, its walk's sky, how `play` shows it), so adding a scene
//! is adding one entry. Look one up by name with
//! [`find`]. Building a scene costs CPU time and memory only, and every build starts afresh (only
//! the cathedral's window list is built once, on first use, and kept).

pub mod files;
pub mod large;
pub mod level;
pub mod open;
pub mod rooms;
pub mod shared;

use engine::scene::{Camera, NodeContent, SceneDescription, Transform};
use glam::Vec3;

/// One built-in scene: its name and everything looked up by it.
#[derive(Clone, Copy, Debug)]
pub struct SceneEntry {
    /// The name the scene is found by (and the built scene's [`SceneDescription::name`]).
    pub name: &'static str,
    /// Builds the scene; every call gives an equal description.
    pub build: fn() -> SceneDescription,
    /// Bounds for a global-illumination probe volume: the region the scene's camera and light care
    /// about (a room's interior, the surroundings of a door), or `None` for the scene's bounds.
    pub gi_bounds: fn() -> Option<(Vec3, Vec3)>,
    /// The holes designed into the scene's closed geometry: a ray from inside that leaves the
    /// scene's rooms must pass through one of them. Empty for a fully closed or an open scene.
    pub openings: fn() -> &'static [Opening],
    /// The scene's walk, for a camera that moves through it (`eval --time-series --walk`, `bench
    /// walk`): where it stands after walking a distance (world units along it; clamped to its
    /// end) and the direction it walks in. `None`: the scene has no tour.
    pub tour: Option<fn(f32) -> (Vec3, Vec3)>,
    /// The probe grid of the published experiment on the scene (Hvezda and Bittner), which the
    /// evaluation's DDGI configurations use (`lab::eval::ddgi_paper_grid`); `None`: none was
    /// published (the evaluation takes 8×8×8).
    pub paper_grid: Option<[u32; 3]>,
    /// What changes in the scene's time series (`eval --time-series`).
    pub change: TimeSeriesChange,
    /// The sky's radiance (W/(m²·sr)) while the scene is walked (`bench walk`, `play`'s tour);
    /// `None`: black.
    pub walk_sky: Option<Vec3>,
    /// How `game_demo play --scene` shows it.
    pub play: PlayMode,
}

/// What changes in a built-in scene's time series, carried out by `lab::eval::time_series`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeSeriesChange {
    /// Its first light moves: a point or spot light along X, towards the middle of the scene, a
    /// directional light turns about the vertical.
    FirstLight,
    /// The node `lamp` (the quad and its point light) moves towards the red (−X) wall.
    LampTowardsRedWall,
    /// The orbiting spot light `spot` jumps half a turn along its orbit.
    SpotHalfTurn,
    /// A door panel is added in the opening named `door`, closed, and swings open outwards.
    DoorSwingsOpen,
}

/// How `game_demo play --scene` shows a built-in scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlayMode {
    /// In a window, from its own camera.
    Window,
    /// Its tour, walked by the camera and lit by camera-following cascades, in a window or
    /// headless.
    Tour,
}

/// The sky's radiance over the open world while it is walked (a pale blue, W/(m²·sr)).
pub const OPEN_WORLD_SKY: Vec3 = Vec3::new(0.35, 0.45, 0.6);

impl SceneEntry {
    /// [`SceneEntry::gi_bounds`] in double precision: a probe volume's world box (as
    /// `ddgi::DdgiVolume::bounds` takes it).
    pub fn gi_box(&self) -> Option<(glam::DVec3, glam::DVec3)> {
        (self.gi_bounds)().map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3()))
    }
}

/// A hole designed into the closed geometry of a built-in scene: the world-space box that the hole
/// sweeps through its wall (flat along the wall's normal when the wall is simply left out).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Opening {
    pub name: &'static str,
    pub min: Vec3,
    pub max: Vec3,
}

/// Every built-in scene, in the order they are documented.
pub static ALL: &[SceneEntry] = &[
    SceneEntry {
        name: "cornell",
        build: rooms::cornell,
        // The box and the space in front of its open side, so that the walls' front edges, which
        // face away from the light, have probes that see their dark side.
        gi_bounds: || Some((rooms::CORNELL_MIN - Vec3::splat(0.2), rooms::CORNELL_MAX + Vec3::new(0.2, 0.2, 0.6))),
        openings: || &[rooms::CORNELL_FRONT],
        tour: None,
        paper_grid: None,
        change: TimeSeriesChange::LampTowardsRedWall,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "ceiling_opening",
        build: rooms::ceiling_opening,
        gi_bounds: || Some((rooms::SKY_ROOM_MIN, rooms::SKY_ROOM_MAX)),
        openings: || &[rooms::SKYLIGHT],
        tour: None,
        paper_grid: Some([16, 16, 15]),
        change: TimeSeriesChange::FirstLight,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "door_room",
        build: rooms::door_room,
        // The room and the ground in front of its door, where the camera stands.
        gi_bounds: || Some((Vec3::new(-3.5, 0.0, -3.0), Vec3::new(4.5, 4.0, 6.0))),
        openings: || &[rooms::DOOR],
        tour: None,
        paper_grid: Some([16, 8, 16]),
        change: TimeSeriesChange::DoorSwingsOpen,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "door_room_thin",
        build: rooms::door_room_thin,
        // One volume over the whole scene, as a new user's first volume is.
        gi_bounds: || None,
        openings: || &[rooms::THIN_DOOR],
        tour: None,
        paper_grid: None,
        change: TimeSeriesChange::FirstLight,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "color_bleed",
        build: rooms::color_bleed,
        gi_bounds: || Some((rooms::BLEED_ROOM_MIN, rooms::BLEED_ROOM_MAX)),
        openings: || &[],
        tour: None,
        paper_grid: Some([2, 2, 2]),
        change: TimeSeriesChange::SpotHalfTurn,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "cathedral",
        build: large::cathedral,
        gi_bounds: || None,
        openings: large::cathedral_openings,
        tour: None,
        // Šibenik's grid: the cathedral stands in for it.
        paper_grid: Some([16, 8, 12]),
        change: TimeSeriesChange::FirstLight,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "forest",
        build: large::forest,
        gi_bounds: || None,
        openings: || &[],
        tour: None,
        paper_grid: None,
        change: TimeSeriesChange::FirstLight,
        walk_sky: None,
        play: PlayMode::Window,
    },
    SceneEntry {
        name: "open_world",
        build: open::open_world,
        // One volume over the whole world (the alternative that cascades are measured against).
        gi_bounds: || None,
        openings: || &[],
        // Out of the house's door, across the yard, 500 m into the forest and back.
        tour: Some(open::tour_at),
        paper_grid: None,
        change: TimeSeriesChange::FirstLight,
        walk_sky: Some(OPEN_WORLD_SKY),
        play: PlayMode::Tour,
    },
];

/// The entry of the built-in scene called `name`, or `None` when no scene has that name.
pub fn find(name: &str) -> Option<&'static SceneEntry> {
    ALL.iter().find(|entry| entry.name == name)
}

/// The names of the built-in scenes, in the order of [`ALL`].
pub fn names() -> impl Iterator<Item = &'static str> {
    ALL.iter().map(|entry| entry.name)
}

// ---------------------------------------------------------------------------------------------
// Shared by the scenes
// ---------------------------------------------------------------------------------------------

/// Slightly warm sunlight (linear).
const SUN_COLOR: Vec3 = Vec3::new(1.0, 0.95, 0.85);

/// Near plane of every built-in camera (metres).
const ZNEAR: f32 = 0.05;

/// Adds a camera at `eye` looking at `target`.
fn add_camera(desc: &mut SceneDescription, eye: Vec3, target: Vec3, yfov_degrees: f32, exposure: f32) {
    let camera = Camera { yfov: yfov_degrees.to_radians(), znear: ZNEAR, exposure };
    let transform = Transform::from_translation(eye).looking_at(target, Vec3::Y);
    desc.add_node("camera", transform, None, vec![NodeContent::Camera(camera)]);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_scene_exists_and_only_those() {
        assert_eq!(
            names().collect::<Vec<_>>(),
            ["cornell", "ceiling_opening", "door_room", "door_room_thin", "color_bleed", "cathedral", "forest", "open_world"]
        );
        for entry in ALL {
            let desc = (entry.build)();
            assert_eq!(desc.name, entry.name);
            assert_eq!((entry.build)(), desc, "{}: building twice gives the same scene", entry.name);
            assert!(std::ptr::eq(find(entry.name).expect("listed"), entry));
        }
        assert!(find("no_such_scene").is_none());
    }
}

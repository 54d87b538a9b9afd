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

pub mod props;

use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};

use props::PropPiece;

use bevy_ecs::component::Component;
use engine::scene::{Camera, DirectionalLight, Material, NodeContent, Orbit, PointLight, SceneDescription, Transform};
use engine::shapes::{box_part, box_with_hole, merge};
use engine::sky::{PhysicalSky, Sky};
use glam::{Affine3A, Quat, UVec3, Vec2, Vec3};

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

/// Measured bounds of the Kenney models (used to place them, and filled by the props that stand in
/// for them).
struct KitModel {
    file: &'static str,
    min: Vec3,
    max: Vec3,
    /// The project's own prop of these bounds, used without the Kenney folder.
    prop: fn(Vec3, Vec3) -> Vec<PropPiece>,
}

const PLATFORM_SMALL: KitModel =
    KitModel { file: "platform.glb", min: Vec3::new(-1.1, 0.0, -1.1), max: Vec3::new(1.1, 0.5, 1.1), prop: props::grass_platform };
const PLATFORM_LARGE: KitModel = KitModel {
    file: "platform-large-grass.glb",
    min: Vec3::new(-2.6, 0.0, -2.6),
    max: Vec3::new(2.6, 0.5, 2.6),
    prop: props::grass_platform,
};
const WALL_HIGH: KitModel = KitModel {
    file: "wall-high.glb",
    min: Vec3::new(-0.75, 0.0, -0.35),
    max: Vec3::new(0.75, 1.7, 0.35),
    prop: |min, max| props::stone_wall(min, max, 4, 0x3a11),
};
const WALL_LOW: KitModel = KitModel {
    file: "wall-low.glb",
    min: Vec3::new(-1.1, 0.0, -0.35),
    max: Vec3::new(1.1, 0.8, 0.35),
    prop: |min, max| props::stone_wall(min, max, 2, 0x10e),
};
const GRASS_TUFT: KitModel = KitModel {
    file: "grass.glb",
    min: Vec3::new(-0.26, 0.0, -0.27),
    max: Vec3::new(0.26, 0.31, 0.27),
    prop: |min, max| props::grass_tuft(min, max, 8, true, 0x7af7),
};
const GRASS_SMALL: KitModel = KitModel {
    file: "grass-small.glb",
    min: Vec3::new(-0.12, 0.0, -0.16),
    max: Vec3::new(0.12, 0.26, 0.16),
    prop: |min, max| props::grass_tuft(min, max, 6, false, 0x5a11),
};
const CLOUD: KitModel = KitModel { file: "cloud.glb", min: Vec3::new(-0.5, 0.0, -0.5), max: Vec3::new(0.5, 1.0, 0.5), prop: props::cloud };
const ENEMY_FLYING: KitModel =
    KitModel { file: "enemy-flying.glb", min: Vec3::new(-0.6, 0.0, -0.32), max: Vec3::new(0.6, 0.875, 0.43), prop: props::flying_enemy };
const BLASTER: KitModel =
    KitModel { file: "blaster.glb", min: Vec3::new(-0.36, 0.0, -0.7), max: Vec3::new(0.52, 0.9, 0.9), prop: props::blaster };

// ---------------------------------------------------------------------------------------------
// Building
// ---------------------------------------------------------------------------------------------

/// Mesh parts of a loaded (or stand-in) model: (placement in the model, mesh, material).
type Parts = Vec<(Affine3A, usize, usize)>;

struct Builder {
    desc: SceneDescription,
    assets: Option<PathBuf>,
    walls: Vec<Footprint>,
    floors: Vec<Floor>,
    loaded: Vec<(&'static str, Parts)>,
}

impl Builder {
    fn material(&mut self, name: &str, color: Vec3) -> usize {
        self.material_once(Material::diffuse(name, color))
    }

    /// The material's index, adding it unless one of its name is there.
    fn material_once(&mut self, material: Material) -> usize {
        match self.desc.materials.iter().position(|m| m.name == material.name) {
            Some(i) => i,
            None => self.desc.add_material(material),
        }
    }

    /// A static box `min`..`max` in world space.
    fn solid(&mut self, name: &str, min: Vec3, max: Vec3, material: usize) -> usize {
        self.desc.add_mesh_node(name, Transform::IDENTITY, merge(name, &[box_part(min, max)]), material)
    }

    /// The model's parts, loading it (into the scene's lists) on first use: Kenney's file, or the
    /// project's own prop of the same bounds when the file is not there.
    fn model(&mut self, model: &KitModel) -> Parts {
        if let Some((_, parts)) = self.loaded.iter().find(|(f, _)| *f == model.file) {
            return parts.clone();
        }
        let parts = self.load(model).unwrap_or_else(|| {
            (model.prop)(model.min, model.max)
                .into_iter()
                .map(|piece| (Affine3A::IDENTITY, self.desc.add_mesh(piece.mesh), self.material_once(piece.material)))
                .collect()
        });
        self.loaded.push((model.file, parts.clone()));
        parts
    }

    fn load(&mut self, model: &KitModel) -> Option<Parts> {
        let path = self.assets.as_ref()?.join(model.file);
        let scene = match engine::import::load_scene(&path) {
            Ok(scene) => scene,
            Err(e) => {
                log::warn!("demo level: {e}; using the level's own prop");
                return None;
            }
        };
        Some(self.append(scene))
    }

    /// Moves a loaded scene's meshes, materials and images into the level (sharing identical images
    /// and materials) and returns its mesh parts, flattened.
    fn append(&mut self, scene: SceneDescription) -> Parts {
        let world = scene.world_transforms();
        let images: Vec<usize> = scene
            .images
            .into_iter()
            .map(|image| match self.desc.images.iter().position(|i| *i == image) {
                Some(i) => i,
                None => {
                    self.desc.images.push(image);
                    self.desc.images.len() - 1
                }
            })
            .collect();
        let remap = |t: Option<engine::scene::TextureRef>| {
            t.and_then(|t| {
                let image = *images.get(t.image.index() as usize)?;
                Some(engine::scene::TextureRef { image: engine::scene::Handle::from_index(image as u32), ..t })
            })
        };
        let materials: Vec<usize> = scene
            .materials
            .into_iter()
            .map(|mut m| {
                m.base_color_texture = remap(m.base_color_texture);
                m.emissive_texture = remap(m.emissive_texture);
                match self.desc.materials.iter().position(|x| *x == m) {
                    Some(i) => i,
                    None => self.desc.add_material(m),
                }
            })
            .collect();
        let meshes: Vec<usize> = scene.meshes.into_iter().map(|m| self.desc.add_mesh(m)).collect();
        let mut parts = Parts::new();
        for (node, xf) in scene.nodes.iter().zip(world) {
            for content in &node.content {
                if let NodeContent::Meshes(list) = content {
                    for &(mesh, material) in list {
                        if let (Some(&mesh), Some(&material)) = (meshes.get(mesh), materials.get(material)) {
                            parts.push((xf, mesh, material));
                        }
                    }
                }
            }
        }
        parts
    }

    /// Places a model as a node named `name` (children for parts that are not at the model's
    /// origin). Returns the node.
    fn place(&mut self, name: &str, model: &KitModel, transform: Transform) -> usize {
        self.place_with(name, model, transform, Affine3A::IDENTITY)
    }

    /// [`Builder::place`] with `pre` applied to the model inside its node.
    fn place_with(&mut self, name: &str, model: &KitModel, transform: Transform, pre: Affine3A) -> usize {
        let parts: Parts = self.model(model).into_iter().map(|(xf, mesh, material)| (pre * xf, mesh, material)).collect();
        let at_origin: Vec<(usize, usize)> =
            parts.iter().filter(|(xf, _, _)| *xf == Affine3A::IDENTITY).map(|&(_, m, mt)| (m, mt)).collect();
        let content = if at_origin.is_empty() { vec![NodeContent::Empty] } else { vec![NodeContent::Meshes(at_origin)] };
        let node = self.desc.add_node(name, transform, None, content);
        for (i, (xf, mesh, material)) in parts.iter().filter(|(xf, _, _)| *xf != Affine3A::IDENTITY).enumerate() {
            let (scale, rotation, translation) = xf.to_scale_rotation_translation();
            let local = Transform { translation, rotation, scale };
            self.desc.add_node(&format!("{name}_part{i}"), local, Some(node), vec![NodeContent::Meshes(vec![(*mesh, *material)])]);
        }
        node
    }

    /// Places a model standing on the ground at (x, y, z), turned `yaw` about Y, scaled, and
    /// returns its world footprint (axis-aligned; yaw must be a multiple of 90°).
    fn prop(&mut self, name: &str, model: &KitModel, at: Vec3, yaw: f32, scale: Vec3) -> Footprint {
        let transform = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(yaw)).with_scale(scale);
        self.place(name, model, transform);
        let affine = transform.to_affine();
        let (a, b) = (affine.transform_point3(model.min), affine.transform_point3(model.max));
        Footprint::of_box(a.min(b), a.max(b))
    }
}

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

/// The house: shell, coloured linings, emissive panel, door, roof and furniture.
fn build_house(b: &mut Builder) {
    let t = HOUSE_WALL;
    let (lo, hi) = (HOUSE_MIN - Vec3::splat(t), HOUSE_MAX + Vec3::splat(t));
    let plaster = b.material("plaster", PLASTER);
    let wood = b.material("wood_floor", WOOD_FLOOR);
    let roof = b.material("roof", ROOF);

    // Walls: west, east, north, and the south wall in strips around the doorway and windows. The
    // strips overlap their neighbours' ends, so the shell stays watertight.
    let mut parts = vec![
        box_part(Vec3::new(lo.x, lo.y, lo.z), Vec3::new(HOUSE_MIN.x, hi.y, hi.z)),
        box_part(Vec3::new(HOUSE_MAX.x, lo.y, lo.z), Vec3::new(hi.x, hi.y, hi.z)),
        box_part(Vec3::new(lo.x, lo.y, lo.z), Vec3::new(hi.x, hi.y, HOUSE_MIN.z)),
    ];
    let south = |x0: f32, x1: f32| (Vec3::new(x0, lo.y, HOUSE_MAX.z), Vec3::new(x1, hi.y, hi.z));
    let mut cuts: Vec<(f32, f32, f32, f32)> = WINDOWS_X.iter().map(|&(a, c)| (a, c, WINDOW_Y.0, WINDOW_Y.1)).collect();
    cuts.push((DOOR_X.0, DOOR_X.1, HOUSE_MIN.y, DOOR_TOP));
    cuts.sort_by(|a, c| a.0.total_cmp(&c.0));
    let mut x = lo.x;
    for (x0, x1, y0, y1) in cuts {
        let (min, max) = south(x, x0);
        parts.push(box_part(min, max));
        let (min, max) = south(x0, x1);
        parts.extend(box_with_hole(min, max, Vec3::new(x0, y0, min.z), Vec3::new(x1, y1, max.z)));
        x = x1;
    }
    let (min, max) = south(x, hi.x);
    parts.push(box_part(min, max));
    // Ceiling slab.
    parts.push(box_part(Vec3::new(lo.x, HOUSE_MAX.y, lo.z), hi));
    b.desc.add_mesh_node("house", Transform::IDENTITY, merge("house", &parts), plaster);
    b.solid("house_floor", lo, Vec3::new(hi.x, HOUSE_MIN.y, hi.z), wood);
    b.solid("roof", Vec3::new(lo.x - 0.4, hi.y, lo.z - 0.4), Vec3::new(hi.x + 0.4, hi.y + 0.25, hi.z + 0.4), roof);

    // Coloured linings on the inner faces of the west and east walls (closed boxes sunk into them).
    let red = b.material("red", RED);
    let green = b.material("green", GREEN);
    let lining = 0.05;
    b.solid(
        "red_wall",
        Vec3::new(HOUSE_MIN.x - lining, HOUSE_MIN.y, HOUSE_MIN.z),
        Vec3::new(HOUSE_MIN.x + lining, HOUSE_MAX.y, HOUSE_MAX.z),
        red,
    );
    b.solid(
        "green_wall",
        Vec3::new(HOUSE_MAX.x - lining, HOUSE_MIN.y, HOUSE_MIN.z),
        Vec3::new(HOUSE_MAX.x + lining, HOUSE_MAX.y, HOUSE_MAX.z),
        green,
    );
    // Emissive panel on the north wall.
    let panel = b.desc.add_material(Material::emissive("panel", Vec3::new(6.0, 5.4, 4.4)));
    b.solid("emissive_panel", Vec3::new(-1.5, 2.3, HOUSE_MIN.z - lining), Vec3::new(1.5, 3.0, HOUSE_MIN.z + lining), panel);

    // Walls on the plan (full height).
    b.walls.extend([
        Footprint::of_box(Vec3::new(lo.x, 0.0, lo.z), Vec3::new(hi.x, 0.0, HOUSE_MIN.z)), // north
        Footprint::of_box(Vec3::new(lo.x, 0.0, lo.z), Vec3::new(HOUSE_MIN.x, 0.0, hi.z)), // west
        Footprint::of_box(Vec3::new(HOUSE_MAX.x, 0.0, lo.z), Vec3::new(hi.x, 0.0, hi.z)), // east
        Footprint::of_box(Vec3::new(lo.x, 0.0, HOUSE_MAX.z), Vec3::new(DOOR_X.0, 0.0, hi.z)), // south, west of the door
        Footprint::of_box(Vec3::new(DOOR_X.1, 0.0, HOUSE_MAX.z), Vec3::new(hi.x, 0.0, hi.z)), // south, east of the door
    ]);
    b.floors.push(Floor { footprint: Footprint::of_box(lo, hi), height: HOUSE_MIN.y });

    // The door panel, closed: in the middle of the south wall, overlapping the doorway's sides.
    let door_wood = b.material("door", DOOR_WOOD);
    let half = Vec3::new((DOOR_X.1 - DOOR_X.0) * 0.5 + 0.05, (DOOR_TOP - HOUSE_MIN.y) * 0.5 + 0.01, DOOR_THICKNESS * 0.5);
    let center = Vec3::new((DOOR_X.0 + DOOR_X.1) * 0.5, (HOUSE_MIN.y + DOOR_TOP) * 0.5, HOUSE_MAX.z + t * 0.5);
    b.desc.add_mesh_node(DOOR, door_closed_transform(center), merge(DOOR, &[box_part(-half, half)]), door_wood);

    // Furniture: a crate with a blaster on it, and a pillar.
    let crate_wood = b.material("crate", Vec3::new(0.6, 0.45, 0.25));
    let (crate_min, crate_max) = (Vec3::new(-3.8, HOUSE_MIN.y, -10.8), Vec3::new(-2.2, HOUSE_MIN.y + 0.9, -9.2));
    b.solid("crate", crate_min, crate_max, crate_wood);
    b.walls.push(Footprint::of_box(crate_min, crate_max));
    let on_crate = Transform::from_xyz(-3.0, crate_max.y, -10.0).with_rotation(Quat::from_rotation_y(0.6)).with_scale(Vec3::splat(0.6));
    b.place("blaster", &BLASTER, on_crate);
    let (pillar_min, pillar_max) = (Vec3::new(2.5, HOUSE_MIN.y, -11.2), Vec3::new(3.3, HOUSE_MAX.y, -10.4));
    b.solid("pillar", pillar_min, pillar_max, plaster);
    b.walls.push(Footprint::of_box(pillar_min, pillar_max));
}

fn door_closed_transform(center: Vec3) -> Transform {
    Transform::from_translation(center)
}

/// Closed and open transforms of the door node of [`demo_level`]: it slides east into the wall.
pub fn door_transforms() -> (Transform, Transform) {
    let center = Vec3::new((DOOR_X.0 + DOOR_X.1) * 0.5, (HOUSE_MIN.y + DOOR_TOP) * 0.5, HOUSE_MAX.z + HOUSE_WALL * 0.5);
    let closed = door_closed_transform(center);
    (closed, Transform::from_translation(center + Vec3::X * DOOR_SLIDE))
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

fn build_outdoors(b: &mut Builder) {
    // Fence of low walls just outside the field, and high posts at the corners.
    let n = 17;
    let spacing = 2.0 * FIELD_HALF / n as f32;
    let off = FIELD_HALF + WALL_LOW.max.z;
    for i in 0..n {
        let s = -FIELD_HALF + spacing * (i as f32 + 0.5);
        let scale = Vec3::new(spacing / (WALL_LOW.max.x - WALL_LOW.min.x) + 0.02, 1.0, 1.0);
        b.prop(&format!("fence_n{i}"), &WALL_LOW, Vec3::new(s, 0.0, -off), 0.0, scale);
        b.prop(&format!("fence_s{i}"), &WALL_LOW, Vec3::new(s, 0.0, off), PI, scale);
        b.prop(&format!("fence_w{i}"), &WALL_LOW, Vec3::new(-off, 0.0, s), PI * 0.5, scale);
        b.prop(&format!("fence_e{i}"), &WALL_LOW, Vec3::new(off, 0.0, s), -PI * 0.5, scale);
    }
    for (i, (sx, sz)) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)].into_iter().enumerate() {
        b.prop(&format!("fence_post{i}"), &WALL_HIGH, Vec3::new(sx * off, 0.0, sz * off), 0.0, Vec3::new(0.5, 1.0, 1.0));
    }

    // A ruined L-shaped wall west of the path.
    let mut ruin = Vec::new();
    for (i, x) in [-12.25, -10.75, -9.25, -7.75].into_iter().enumerate() {
        ruin.push(b.prop(&format!("ruin_a{i}"), &WALL_HIGH, Vec3::new(x, 0.0, 6.0), 0.0, Vec3::ONE));
    }
    for (i, z) in [7.1, 8.6, 10.1].into_iter().enumerate() {
        let height = if i == 2 { 0.6 } else { 1.0 };
        ruin.push(b.prop(&format!("ruin_b{i}"), &WALL_HIGH, Vec3::new(-12.65, 0.0, z), PI * 0.5, Vec3::new(1.0, height, 1.0)));
    }
    b.walls.extend(ruin);

    // Stepped grass terraces east of the path: 0.3, 0.6 and 0.9 m.
    let large = b.prop("terrace", &PLATFORM_LARGE, Vec3::new(9.0, -0.2, 9.0), 0.0, Vec3::ONE);
    b.floors.push(Floor { footprint: large, height: 0.3 });
    let step1 = b.prop("terrace_step1", &PLATFORM_SMALL, Vec3::new(10.5, 0.1, 8.3), 0.0, Vec3::ONE);
    b.floors.push(Floor { footprint: step1, height: 0.6 });
    let step2 = b.prop("terrace_step2", &PLATFORM_SMALL, Vec3::new(10.5, 0.3, 10.5), 0.0, Vec3::new(1.0, 1.2, 1.0));
    b.floors.push(Floor { footprint: step2, height: 0.9 });

    // Grass tufts, away from the house, the path, the lift and the terraces.
    let mut rng = Lcg(0x5eed_1e7e1);
    let keep_out = [
        Footprint::new(Vec2::new(-6.5, -13.5), Vec2::new(6.5, -2.5)),
        Footprint::new(Vec2::new(-1.5, -3.0), Vec2::new(1.5, 18.0)),
        Footprint::new(LIFT_MIN - 0.5, LIFT_MAX + 0.5),
        Footprint::new(Vec2::new(6.0, 6.0), Vec2::new(12.0, 12.0)),
    ];
    let mut placed = 0;
    while placed < 60 {
        let p = Vec2::new(rng.range(-17.0, 17.0), rng.range(-17.0, 17.0));
        let (yaw, size) = (rng.range(0.0, TAU), rng.range(1.5, 3.0));
        if keep_out.iter().any(|k| k.contains(p)) {
            continue;
        }
        let model = if placed % 3 == 0 { &GRASS_SMALL } else { &GRASS_TUFT };
        let transform = Transform::from_xyz(p.x, 0.0, p.y).with_rotation(Quat::from_rotation_y(yaw)).with_scale(Vec3::splat(size));
        b.place(&format!("grass{placed}"), model, transform);
        placed += 1;
    }

    // Clouds (stretched cubes) high above, outside the GI volume.
    for i in 0..8 {
        let at = Vec3::new(rng.range(-30.0, 30.0), rng.range(14.0, 20.0), rng.range(-30.0, 30.0));
        let scale = Vec3::new(rng.range(4.0, 8.0), rng.range(1.0, 2.0), rng.range(3.0, 5.0));
        let transform = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(rng.range(0.0, PI))).with_scale(scale);
        b.place(&format!("cloud{i}"), &CLOUD, transform);
    }

    // The flying enemy circles the field, 5 m up, watching the house.
    let orbit = Orbit { center: Vec3::new(2.0, 5.0, 4.0), radius: 8.0, period: 20.0, look_at: Some(Vec3::new(0.0, 2.0, -8.0)) };
    // glTF models face +Z and the orbit points the node's -Z at its target: turn the model round.
    let start = Transform::from_translation(orbit.center + Vec3::X * orbit.radius);
    let pre = Affine3A::from_scale_rotation_translation(Vec3::splat(1.5), Quat::from_rotation_y(PI), Vec3::ZERO);
    let node = b.place_with(ENEMY, &ENEMY_FLYING, start, pre);
    b.desc.nodes[node].orbit = Some(orbit);
}

/// The lift: a painted column whose top is the platform, rising out of the ground.
fn build_lift(b: &mut Builder) -> PlatformSpec {
    let paint = b.material("lift", LIFT_PAINT);
    let depth = LIFT_HIGH - LIFT_LOW + 0.3;
    let half = Vec2::new(LIFT_MAX.x - LIFT_MIN.x, LIFT_MAX.y - LIFT_MIN.y) * 0.5;
    let mesh = merge(PLATFORM, &[box_part(Vec3::new(-half.x, -depth, -half.y), Vec3::new(half.x, 0.0, half.y))]);
    let center = (LIFT_MIN + LIFT_MAX) * 0.5;
    b.desc.add_mesh_node(PLATFORM, Transform::from_xyz(center.x, LIFT_LOW, center.y), mesh, paint);
    // A stone pit rim around the column.
    let stone = b.material("stone", STONE);
    let rim = 0.25;
    let (lo, hi) = (LIFT_MIN - rim - 0.02, LIFT_MAX + rim + 0.02);
    let inner = (LIFT_MIN - 0.02, LIFT_MAX + 0.02);
    let parts = [
        box_part(Vec3::new(lo.x, -0.2, lo.y), Vec3::new(hi.x, 0.05, inner.0.y)),
        box_part(Vec3::new(lo.x, -0.2, inner.1.y), Vec3::new(hi.x, 0.05, hi.y)),
        box_part(Vec3::new(lo.x, -0.2, lo.y), Vec3::new(inner.0.x, 0.05, hi.y)),
        box_part(Vec3::new(inner.1.x, -0.2, lo.y), Vec3::new(hi.x, 0.05, hi.y)),
    ];
    // Each strip's top is a 5 cm floor.
    let rims: Vec<Footprint> = [
        (Vec2::new(lo.x, lo.y), Vec2::new(hi.x, inner.0.y)),
        (Vec2::new(lo.x, inner.1.y), Vec2::new(hi.x, hi.y)),
        (Vec2::new(lo.x, lo.y), Vec2::new(inner.0.x, hi.y)),
        (Vec2::new(inner.1.x, lo.y), Vec2::new(hi.x, hi.y)),
    ]
    .into_iter()
    .map(|(min, max)| Footprint::new(min, max))
    .collect();
    b.floors.extend(rims.into_iter().map(|footprint| Floor { footprint, height: 0.05 }));
    b.desc.add_mesh_node("lift_rim", Transform::IDENTITY, merge("lift_rim", &parts), stone);
    PlatformSpec {
        node: PLATFORM.into(),
        footprint: Footprint::new(LIFT_MIN, LIFT_MAX),
        low: LIFT_LOW,
        high: LIFT_HIGH,
        period: LIFT_PERIOD,
    }
}

/// A day–night cycle on the sun.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct DayNight {
    /// Seconds per day.
    pub period: f32,
    /// Fraction of the day at t = 0 (0 sunrise, 0.25 noon, 0.5 sunset, 0.5..1 night).
    pub phase: f32,
    /// Irradiance (W/m²) of the sun at its highest.
    pub max_intensity: f32,
    /// Angle between the sun's path and the zenith (towards the south, +Z).
    pub tilt: f32,
}

impl Default for DayNight {
    fn default() -> Self {
        Self { period: 240.0, phase: 0.1, max_intensity: 6.0, tilt: 35f32.to_radians() }
    }
}

/// The sun and sky at one moment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunState {
    pub transform: Transform,
    pub color: Vec3,
    pub intensity: f32,
    /// Preetham's sky for this sun (its brightness that of the sun at its highest, fading through
    /// twilight by itself while the sun's light is already off).
    pub sky: Sky,
    /// Unit vector towards the sun.
    pub to_sun: Vec3,
}

/// Hermite interpolation from 0 at `e0` to 1 at `e1` (the sun's fades, the door's motion).
pub fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl DayNight {
    pub fn state(&self, t: f64) -> SunState {
        let day = ((t / self.period.max(1e-3) as f64) + self.phase as f64).rem_euclid(1.0) as f32;
        let a = TAU * day;
        let (sin_a, cos_a) = a.sin_cos();
        let (sin_t, cos_t) = self.tilt.sin_cos();
        // Rises in the east (+X), culminates towards the south (+Z), sets in the west.
        let to_sun = Vec3::new(cos_a, sin_a * cos_t, sin_a * sin_t).normalize_or(Vec3::Y);
        let elevation = to_sun.y;
        let intensity = self.max_intensity * smoothstep(0.0, 0.2, elevation);
        let noon = Vec3::new(1.0, 0.95, 0.85);
        let dusk = Vec3::new(1.0, 0.42, 0.15);
        let color = dusk.lerp(noon, smoothstep(0.0, 0.45, elevation));
        let sky = Sky::Physical(PhysicalSky {
            sun_direction: Some(to_sun),
            sun_irradiance: Some(self.max_intensity),
            night: Vec3::new(0.004, 0.006, 0.015),
            ..Default::default()
        });
        let transform = Transform::from_translation(to_sun * 30.0).looking_at(Vec3::ZERO, Vec3::Y);
        SunState { transform, color, intensity: if elevation > 0.0 { intensity } else { 0.0 }, sky, to_sun }
    }
}

/// Cycles a point light's hue.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct ColorCycle {
    /// Seconds per turn of the colour wheel.
    pub period: f32,
    pub saturation: f32,
    /// The light's intensity (W/sr).
    pub intensity: f32,
}

impl Default for ColorCycle {
    fn default() -> Self {
        Self { period: 15.0, saturation: 0.8, intensity: 8.0 }
    }
}

impl ColorCycle {
    /// A colour of maximum component 1 with the hue at `t` seconds.
    pub fn color_at(&self, t: f64) -> Vec3 {
        let hue = (t / self.period.max(1e-3) as f64).rem_euclid(1.0) as f32;
        let rgb = Vec3::new(hue, hue + 2.0 / 3.0, hue + 1.0 / 3.0).map(|h| {
            let x = (h.fract() * 6.0 - 3.0).abs() - 1.0;
            x.clamp(0.0, 1.0)
        });
        Vec3::ONE.lerp(rgb, self.saturation.clamp(0.0, 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(desc: &SceneDescription) -> Vec<&str> {
        desc.nodes.iter().map(|n| n.name.as_str()).collect()
    }

    #[test]
    fn builds_without_assets() {
        let level = demo_level(None);
        assert!(level.scene.images.is_empty(), "no textures without the kit");
        for mesh in &level.scene.meshes {
            assert!(mesh.positions.iter().all(|p| p.is_finite()), "mesh {} has a non-finite position", mesh.name);
            assert!(mesh.normals.iter().all(|n| n.is_finite()), "mesh {} has a non-finite normal", mesh.name);
            assert!(mesh.indices.iter().all(|&i| (i as usize) < mesh.positions.len()));
            assert!(mesh.triangle_count() > 0);
        }
        let names = names(&level.scene);
        for name in [SUN, DOOR, PLATFORM, MOVING_LIGHT, PLAYER_CAMERA, ENEMY, "house", "red_wall", "green_wall", "emissive_panel"] {
            assert_eq!(names.iter().filter(|n| **n == name).count(), 1, "node {name}");
        }
        let nodes = &level.scene.nodes;
        let node = |name: &str| nodes.iter().find(|n| n.name == name).unwrap();
        assert!(node(SUN).content.iter().any(|c| matches!(c, NodeContent::DirectionalLight(_))));
        assert!(node(MOVING_LIGHT).content.iter().any(|c| matches!(c, NodeContent::PointLight(_))) && node(MOVING_LIGHT).orbit.is_some());
        assert!(node(PLAYER_CAMERA).content.iter().any(|c| matches!(c, NodeContent::Camera(_))));
        assert!(node(ENEMY).orbit.is_some());
        assert!((node(PLAYER_CAMERA).transform.translation - level.layout.spawn - Vec3::Y * 1.6).length() < 1e-5);
        assert!(level.scene.materials.iter().any(|m| m.is_emissive()));
    }

    #[test]
    fn gi_bounds_contain_the_level() {
        let level = demo_level(None);
        let (lo, hi) = level.layout.gi_bounds;
        let b = level.layout.bounds;
        assert!(lo.x <= b.min.x && lo.z <= b.min.y && hi.x >= b.max.x && hi.z >= b.max.y);
        // Everything on the ground but the clouds (and the ground slab itself, which runs on past
        // the fence) is inside: house, roof, props, fence, enemy.
        let world = level.scene.world_transforms();
        let mut checked = 0;
        for (node, xf) in level.scene.nodes.iter().zip(&world) {
            if node.name.starts_with("cloud") || node.name == "ground" {
                continue;
            }
            for content in &node.content {
                let NodeContent::Meshes(list) = content else { continue };
                for &(mesh, _) in list {
                    for &p in &level.scene.meshes[mesh].positions {
                        let p = xf.transform_point3(p);
                        if p.y >= 0.0 {
                            assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{} vertex {p} outside {lo}..{hi}", node.name);
                            checked += 1;
                        }
                    }
                }
            }
        }
        assert!(checked > 100);
        // The lift at its top, with a person on it.
        assert!(hi.y >= LIFT_HIGH + 2.0 && lo.y <= 0.0);
        for f in &level.layout.floors {
            assert!(f.height >= lo.y && f.height <= hi.y);
        }
    }

    const MODELS: [&KitModel; 9] =
        [&PLATFORM_SMALL, &PLATFORM_LARGE, &WALL_HIGH, &WALL_LOW, &GRASS_TUFT, &GRASS_SMALL, &CLOUD, &ENEMY_FLYING, &BLASTER];

    #[test]
    fn the_levels_own_props_are_closed_solids_that_fill_their_models_boxes() {
        for model in MODELS {
            let pieces = (model.prop)(model.min, model.max);
            assert!(!pieces.is_empty(), "{}: no prop", model.file);
            let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
            for piece in &pieces {
                let mesh = &piece.mesh;
                assert!(engine::shapes::is_closed(mesh), "{}: {} is not a closed solid", model.file, mesh.name);
                assert!(piece.material.name.starts_with("prop_"), "{}: material {}", model.file, piece.material.name);
                assert!(mesh.normals.len() == mesh.positions.len() && mesh.positions.iter().chain(&mesh.normals).all(|v| v.is_finite()));
                let (a, b) = mesh.bounds().unwrap();
                (lo, hi) = (lo.min(a), hi.max(b));
            }
            // Inside the model's box, and filling most of it along every axis (walls and platforms,
            // which the plan's footprints and floors stand for, fill it exactly).
            let tolerance = 1e-4;
            assert!(lo.cmpge(model.min - tolerance).all() && hi.cmple(model.max + tolerance).all(), "{}: {lo}..{hi}", model.file);
            let filled = (hi - lo) / (model.max - model.min);
            assert!(filled.min_element() > 0.8, "{}: fills {filled} of its box", model.file);
        }
        for solid in [&WALL_HIGH, &WALL_LOW, &PLATFORM_SMALL, &PLATFORM_LARGE] {
            let (lo, hi) = (solid.prop)(solid.min, solid.max)
                .iter()
                .map(|p| p.mesh.bounds().unwrap())
                .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)));
            assert!((lo - solid.min).abs().max_element() < 1e-4 && (hi - solid.max).abs().max_element() < 1e-4, "{}", solid.file);
        }
    }

    #[test]
    fn without_the_kenney_models_every_prop_is_the_levels_own() {
        let level = demo_level(None);
        let own: Vec<&str> = level.scene.materials.iter().filter(|m| m.name.starts_with("prop_")).map(|m| m.name.as_str()).collect();
        for name in ["prop_stone_light", "prop_turf", "prop_blade_dark", "prop_petal", "prop_cloud", "prop_enemy_body", "prop_gun_metal"] {
            assert!(own.contains(&name), "no {name} among {own:?}");
        }
        // Every prop node is placed, the decoration (grass, the blaster) included.
        let names = names(&level.scene);
        assert_eq!(names.iter().filter(|n| n.starts_with("grass") && !n.contains("_part")).count(), 60);
        assert!(names.contains(&"blaster"));
        // The props' pieces are shared between their nodes, not copied: one mesh a material a model.
        assert!(level.scene.meshes.len() < 80, "{} meshes", level.scene.meshes.len());
    }

    #[test]
    fn loads_the_kenney_models_when_present() {
        let Some(dir) = kenney_assets_dir() else {
            eprintln!("loads_the_kenney_models_when_present: skipped: {}", crate::shared::absent(crate::shared::KENNEY_FPS));
            return;
        };
        let with = demo_level(Some(&dir));
        let without = demo_level(None);
        assert_eq!(with.layout, without.layout, "the plan must not depend on the assets");
        assert!(!with.scene.images.is_empty(), "the colormap texture was not loaded");
        assert_eq!(with.scene.images.len(), 1, "the shared colormap should be stored once");
        assert!(with.scene.triangle_count() > without.scene.triangle_count());
        assert!(with.scene.materials.iter().all(|m| !m.name.starts_with("prop_")), "a prop stood in for a Kenney model");
        for model in MODELS {
            let scene = engine::import::load_scene(&dir.join(model.file)).unwrap();
            let (lo, hi) = scene.bounds().unwrap();
            assert!(
                (lo - model.min).abs().max_element() < 0.02 && (hi - model.max).abs().max_element() < 0.02,
                "{}: bounds {lo}..{hi}, placed as {}..{}",
                model.file,
                model.min,
                model.max
            );
        }
        let missing = demo_level(Some(Path::new("/nonexistent/kenney")));
        assert_eq!(missing.scene.triangle_count(), without.scene.triangle_count());
    }
}

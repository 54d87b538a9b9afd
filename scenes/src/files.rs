//! Built-in scenes made by others: files of the shared folder ([`crate::shared`]) loaded as they
//! are and staged — the lights and the camera they lack are added here. [`FILES`] is the one
//! table of them; [`load`] loads one by name, or says that its file is absent.
//!
//! | scene     | what it is                                                                     |
//! |-----------|--------------------------------------------------------------------------------|
//! | `sibenik` | the Šibenik cathedral of the DDGI paper's Tables 2 and 3 and Figure 8 (73,564   |
//! |           | triangles; Marko Dabrović, holes fixed by Kenzie Lamar, textures and bump maps  |
//! |           | by Morgan McGuire)                                                              |
//! | `flight_helmet` | the Khronos FlightHelmet (94,722 triangles; normal maps, packed           |
//! |           | occlusion-roughness-metal, alpha-blended lenses; CC0, donated by Microsoft) in a |
//! |           | sunlit corner of a red and a white wall                                         |
//! | `meadow`  | the flower bushes' three cut-out plant cards (CC0, poly.pizza), 100 copies on a   |
//! |           | 60 m meadow: masked foliage, for the alpha test's cost and light (`--opaque`)     |

use engine::rng::SplitMix64;
use engine::scene::{DEFAULT_SUN_IRRADIANCE, Material, NodeContent, PointLight, SceneDescription, SceneNode, Transform};
use engine::shapes::{box_part, merge};
use engine::sky::{PhysicalSky, Sky};
use glam::{Quat, Vec3};

use crate::add_camera;
use crate::large::add_sun;

/// One scene of the shared folder.
#[derive(Clone, Copy, Debug)]
pub struct SceneFile {
    /// The name it is found by (and the loaded scene's name).
    pub name: &'static str,
    /// The file, relative to the shared folder.
    pub path: &'static str,
    /// Adds what the file lacks (lights, a camera) to the loaded scene.
    pub stage: fn(&mut SceneDescription),
    /// Its authors, to credit wherever it is shown.
    pub credit: &'static str,
    /// The probe grid of the published experiment on the scene, as [`crate::SceneEntry::paper_grid`].
    pub paper_grid: Option<[u32; 3]>,
}

/// Every scene file, in the order they are documented.
pub static FILES: &[SceneFile] = &[
    SceneFile {
        name: "sibenik",
        path: "scenes/sibenik/sibenik.obj",
        stage: stage_sibenik,
        credit: "Šibenik cathedral by Marko Dabrović (RNA studio), holes fixed by Kenzie Lamar, textures and bump maps by Morgan McGuire",
        paper_grid: Some([16, 8, 12]),
    },
    SceneFile {
        name: "flight_helmet",
        path: "scenes/flight-helmet/FlightHelmet.gltf",
        stage: stage_flight_helmet,
        credit: "FlightHelmet, Khronos glTF sample model, CC0 1.0 (donated by Microsoft)",
        paper_grid: None,
    },
    SceneFile {
        name: "meadow",
        path: "scenes/flower-bushes/flower_bushes.glb",
        stage: stage_meadow,
        credit: "flower bushes, CC0 (poly.pizza)",
        paper_grid: None,
    },
];

/// The entry called `name`, or `None`.
pub fn find(name: &str) -> Option<&'static SceneFile> {
    FILES.iter().find(|f| f.name == name)
}

/// The scene called `name`, loaded and staged: `None` when no scene file has that name, an error
/// naming the file when it is absent from the shared folder or cannot be loaded.
pub fn load(name: &str) -> Option<Result<SceneDescription, String>> {
    let file = find(name)?;
    Some(load_file(file))
}

fn load_file(file: &SceneFile) -> Result<SceneDescription, String> {
    let path = crate::shared::path(file.path).ok_or_else(|| format!("scene '{}': {}", file.name, crate::shared::absent(file.path)))?;
    let mut scene = engine::import::load_scene(&path).map_err(|e| format!("scene '{}': {e}", file.name))?;
    scene.name = file.name.into();
    (file.stage)(&mut scene);
    Ok(scene)
}

/// The nave's floor (the file's y at the floor of the nave; the model's units are metres, the nave
/// runs along x from the façade's rose window at x = −19.8 to the apse at x = +19).
pub const SIBENIK_FLOOR_Y: f32 = -15.3;

/// The camera of Figure 8's kind: in the nave near the façade, 1.7 m above the floor, looking
/// down the nave towards the apse and a little up, so that the floor, the left wall and the
/// columns fill the view.
pub const SIBENIK_CAMERA_EYE: Vec3 = Vec3::new(-16.0, SIBENIK_FLOOR_Y + 1.7, 2.5);
/// Where the camera looks.
pub const SIBENIK_CAMERA_TARGET: Vec3 = Vec3::new(6.0, SIBENIK_FLOOR_Y + 4.0, -1.0);

/// The sun: 6 W/m², 34° high, shining across the nave towards +z (and a little towards the apse)
/// through the −z aisle's windows onto the nave's floor.
const SIBENIK_SUN_INTENSITY: f32 = 6.0;
const SIBENIK_SUN_DIRECTION: Vec3 = Vec3::new(0.3, -0.7, 1.0);

/// The nave's light: a warm point light of 40 W/sr 6 m above the floor in the middle of the nave.
const SIBENIK_NAVE_LIGHT: Vec3 = Vec3::new(0.0, SIBENIK_FLOOR_Y + 6.0, 0.0);
const SIBENIK_NAVE_LIGHT_POWER: f32 = 40.0;

/// Šibenik has no lights and no camera: a sun through its side windows, a light in the nave and a
/// camera near the façade (its materials as the MTL gives them: colour textures, the rose window's
/// stained glass an opening, bump maps not used).
fn stage_sibenik(scene: &mut SceneDescription) {
    add_sun(scene, Vec3::new(0.0, SIBENIK_FLOOR_Y, 0.0), SIBENIK_SUN_DIRECTION.normalize(), SIBENIK_SUN_INTENSITY);
    let light = PointLight { color: Vec3::new(1.0, 0.85, 0.7), intensity: SIBENIK_NAVE_LIGHT_POWER, range: None };
    scene.add_node("nave_light", Transform::from_translation(SIBENIK_NAVE_LIGHT), None, vec![NodeContent::PointLight(light)]);
    add_camera(scene, SIBENIK_CAMERA_EYE, SIBENIK_CAMERA_TARGET, 60.0, 1.0);
}

/// The helmet's corner: a floor slab and two walls 1.6 m high meeting behind the helmet's left
/// (the helmet, 0.72 m tall, stands on its wooden base at the origin, facing +z).
const HELMET_FLOOR_MIN: Vec3 = Vec3::new(-0.9, -0.1, -0.7);
const HELMET_FLOOR_MAX: Vec3 = Vec3::new(1.5, 0.0, 1.7);
const HELMET_WALL_HEIGHT: f32 = 1.6;
const HELMET_WALL_THICKNESS: f32 = 0.1;
/// The left wall's red and the back wall's and floor's white (albedos).
const HELMET_RED: Vec3 = Vec3::new(0.63, 0.065, 0.05);
const HELMET_WHITE: Vec3 = Vec3::new(0.73, 0.73, 0.73);
/// The sun comes from the front right, 40° high, so that the helmet's right side and visor are
/// sunlit and its left side is lit by the red wall and the floor alone.
const HELMET_SUN_DIRECTION: Vec3 = Vec3::new(-0.55, -0.64, -0.55);
/// The camera: in front and a little to the right, at the visor's height.
const HELMET_CAMERA_EYE: Vec3 = Vec3::new(0.5, 0.48, 1.1);
const HELMET_CAMERA_TARGET: Vec3 = Vec3::new(-0.05, 0.36, 0.0);

/// FlightHelmet has no lights, no camera and nothing around it: it gets a white floor, a red wall
/// on its left and a white one behind it, the default sun from the front right with Preetham's
/// sky, and a camera at the visor's height (its materials as the file gives them: normal maps,
/// occlusion-roughness-metal, the lenses blended).
fn stage_flight_helmet(scene: &mut SceneDescription) {
    let white = scene.add_material(Material::diffuse("corner_white", HELMET_WHITE));
    let red = scene.add_material(Material::diffuse("corner_red", HELMET_RED));
    let (min, max, t, h) = (HELMET_FLOOR_MIN, HELMET_FLOOR_MAX, HELMET_WALL_THICKNESS, HELMET_WALL_HEIGHT);
    let floor_and_back = merge(
        "corner_floor_and_back_wall",
        &[box_part(min, max), box_part(Vec3::new(min.x, min.y, min.z), Vec3::new(max.x, h, min.z + t))],
    );
    let left = merge("corner_left_wall", &[box_part(Vec3::new(min.x, min.y, min.z), Vec3::new(min.x + t, h, max.z))]);
    scene.add_mesh_node("corner_floor_and_back_wall", Transform::IDENTITY, floor_and_back, white);
    scene.add_mesh_node("corner_left_wall", Transform::IDENTITY, left, red);
    scene.add_sun(HELMET_SUN_DIRECTION, DEFAULT_SUN_IRRADIANCE);
    scene.sky = Some(Sky::Physical(PhysicalSky::default()));
    add_camera(scene, HELMET_CAMERA_EYE, HELMET_CAMERA_TARGET, 40.0, 1.0);
}

/// The meadow: copies of the file's three plants on a grid of `MEADOW_COPIES` × `MEADOW_COPIES`
/// cells `MEADOW_CELL` m wide, each turned and shifted at random (a fixed seed: the same scene every
/// time), on a ground slab with a margin of one cell.
const MEADOW_COPIES: usize = 10;
const MEADOW_CELL: f32 = 6.0;
const MEADOW_SEED: u64 = 0x4D45_4144_4F57;
const MEADOW_GROUND: Vec3 = Vec3::new(0.3, 0.35, 0.12);

/// The flower bushes are three cut-out plant cards around x ≈ 153 (BLEND, drawn as a mask at 0.5):
/// they are recentred on their base and copied [`MEADOW_COPIES`]² times over a ground of soil,
/// under the default sun and Preetham's sky, with a camera at a child's height at the meadow's
/// edge looking across it. Every copy shares the file's meshes (one BLAS each, instanced).
fn stage_meadow(scene: &mut SceneDescription) {
    let Some((lo, hi)) = scene.bounds() else { return };
    let recentre = Vec3::new(-(lo.x + hi.x) * 0.5, -lo.y, -(lo.z + hi.z) * 0.5);
    let plants = std::mem::take(&mut scene.nodes);
    let mut rng = SplitMix64::new(MEADOW_SEED);
    let half = MEADOW_COPIES as f32 * MEADOW_CELL * 0.5;
    for i in 0..MEADOW_COPIES * MEADOW_COPIES {
        let cell = Vec3::new((i % MEADOW_COPIES) as f32, 0.0, (i / MEADOW_COPIES) as f32);
        let jitter = Vec3::new(rng.range(-0.25, 0.25), 0.0, rng.range(-0.25, 0.25)) * MEADOW_CELL;
        let at = (cell + Vec3::new(0.5, 0.0, 0.5)) * MEADOW_CELL - Vec3::new(half, 0.0, half) + jitter;
        let turn = Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU));
        let copy = Transform { translation: at, rotation: turn, scale: Vec3::ONE };
        let root = scene.add_node(&format!("plants_{i}"), copy, None, Vec::new());
        let recentred = scene.add_node("recentred", Transform::from_translation(recentre), Some(root), Vec::new());
        let base = scene.nodes.len();
        for node in &plants {
            let parent = Some(node.parent.map_or(recentred, |p| base + p));
            scene.nodes.push(SceneNode { parent, ..node.clone() });
        }
    }
    let ground = scene.add_material(Material::diffuse("soil", MEADOW_GROUND));
    let edge = half + MEADOW_CELL;
    let slab = merge("meadow_ground", &[box_part(Vec3::new(-edge, -0.2, -edge), Vec3::new(edge, 0.0, edge))]);
    scene.add_mesh_node("meadow_ground", Transform::IDENTITY, slab, ground);
    scene.add_sun(engine::scene::DEFAULT_SUN_DIRECTION, DEFAULT_SUN_IRRADIANCE);
    scene.sky = Some(Sky::Physical(PhysicalSky::default()));
    add_camera(scene, Vec3::new(-half - 2.0, 1.2, half * 0.4), Vec3::new(0.0, 0.2, 0.0), 60.0, 1.0);
}

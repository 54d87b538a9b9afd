//! Built-in scenes made by others: files of the shared folder ([`crate::shared`]) loaded as they
//! are and staged — the lights and the camera they lack are added here. [`FILES`] is the one
//! table of them; [`load`] loads one by name, or says that its file is absent.
//!
//! | scene     | what it is                                                                     |
//! |-----------|--------------------------------------------------------------------------------|
//! | `sibenik` | the Šibenik cathedral of the DDGI paper's Tables 2 and 3 and Figure 8 (73,564   |
//! |           | triangles; Marko Dabrović, holes fixed by Kenzie Lamar, textures and bump maps  |
//! |           | by Morgan McGuire)                                                              |

use engine::scene::{NodeContent, PointLight, SceneDescription, Transform};
use glam::Vec3;

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
}

/// Every scene file, in the order they are documented.
pub static FILES: &[SceneFile] = &[SceneFile {
    name: "sibenik",
    path: "scenes/sibenik/sibenik.obj",
    stage: stage_sibenik,
    credit: "Šibenik cathedral by Marko Dabrović (RNA studio), holes fixed by Kenzie Lamar, textures and bump maps by Morgan McGuire",
}];

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

//! The command line's subcommands, a module each with its arguments beside the code that runs
//! them, and what they share: [`load`] (with the global `--sun`, `--sky` and `--opaque` of
//! [`SceneOverrides`]), the replacement camera and the parsers of the flags' values.

use engine::scene::{Camera, NodeContent, SceneDescription, Transform};

pub mod bench;
pub mod eval;
pub mod eval_scenes;
pub mod play;
pub mod render;
#[cfg(test)]
mod tests;

/// The command line's `--sun`, `--sky` and `--opaque`, set once in `main` and applied to every
/// scene [`load`] gives (global flags, so every subcommand takes them).
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneOverrides {
    pub sun: Option<(glam::Vec3, f32)>,
    pub sky: Option<glam::Vec3>,
    pub opaque: bool,
}

pub static SCENE_OVERRIDES: std::sync::OnceLock<SceneOverrides> = std::sync::OnceLock::new();

impl SceneOverrides {
    pub fn get() -> SceneOverrides {
        SCENE_OVERRIDES.get().copied().unwrap_or_default()
    }

    /// Makes every material opaque if `--opaque`, puts the `--sun` and `--sky` into `scene`, then
    /// lights it with the default daylight if it has no light at all, saying so on standard error.
    pub fn apply(&self, scene: &mut SceneDescription, name: &str) {
        if self.opaque {
            for material in &mut scene.materials {
                material.alpha_mode = engine::scene::AlphaMode::Opaque;
            }
        }
        if let Some((direction, irradiance)) = self.sun {
            for node in &mut scene.nodes {
                node.content.retain(|c| !matches!(c, NodeContent::DirectionalLight(_)));
            }
            scene.add_sun(direction, irradiance);
        }
        if let Some(radiance) = self.sky {
            scene.sky = Some(engine::render::Sky::Uniform(radiance));
        }
        if scene.light_if_lightless() {
            let d = engine::scene::DEFAULT_SUN_DIRECTION;
            eprintln!(
                "note: '{name}' has no lights: lit by a default sun of {} W/m² (its light travelling {:.2},{:.2},{:.2}) and {} (--sun and --sky set others)",
                engine::scene::DEFAULT_SUN_IRRADIANCE,
                d.x,
                d.y,
                d.z,
                if self.sky.is_some() { "the --sky" } else { "Preetham's sky of that sun" }
            );
        }
    }
}

/// A camera that replaces the scene's (`render` and `eval`).
#[derive(clap::Args, Clone, Debug)]
pub struct CameraArgs {
    /// Replace the scene's camera: its position `x,y,z` (needs --camera-target).
    #[arg(long, value_parser = parse_vec3, requires = "camera_target")]
    camera_position: Option<glam::Vec3>,
    /// The point the replacement camera looks at `x,y,z`.
    #[arg(long, value_parser = parse_vec3, requires = "camera_position")]
    camera_target: Option<glam::Vec3>,
    /// Vertical field of view of the replacement camera, in degrees.
    #[arg(long, default_value_t = 50.0)]
    fov: f32,
}

impl CameraArgs {
    /// Replaces `scene`'s camera when a position and a target were given.
    pub fn apply(&self, scene: &mut SceneDescription) -> Result<(), String> {
        match (self.camera_position, self.camera_target) {
            (Some(position), Some(target)) => replace_camera(scene, position, target, self.fov),
            _ => Ok(()),
        }
    }
}

/// `x,y,z`; also glam's display form `[x, y, z]` (how clap shows a default).
pub fn parse_dvec3(text: &str) -> Result<glam::DVec3, String> {
    let v: Vec<f64> = text.split(',').map(|p| p.trim().parse::<f64>().map_err(|e| format!("'{p}': {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite() && c.abs() <= 1e15) => Ok(glam::DVec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers x,y,z of at most 1e15, got '{text}'")),
    }
}

/// `--sun x,y,z,irradiance`: a direction (not zero) and an irradiance (not negative).
pub fn parse_sun(text: &str) -> Result<(glam::Vec3, f32), String> {
    let v: Vec<f32> = text.split(',').map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z, e] if v.iter().all(|c| c.is_finite()) && glam::Vec3::new(x, y, z).length() > 1e-6 && e >= 0.0 => {
            Ok((glam::Vec3::new(x, y, z).normalize(), e))
        }
        _ => Err(format!("expected x,y,z,irradiance (a direction not zero, an irradiance ≥ 0, all finite), got '{text}'")),
    }
}

pub fn parse_vec3(text: &str) -> Result<glam::Vec3, String> {
    let v: Vec<f32> = text.split(',').map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(glam::Vec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers x,y,z, got '{text}'")),
    }
}

/// `render` and `eval`'s name for the demo level (`play`'s scene, still: nothing animates).
pub const LEVEL_SCENE: &str = scenes::level::NAME;

/// A built-in scene (of [`scenes::ALL`]) or the demo level by name, or a scene file by path, with
/// the command line's `--sun` and `--sky` and, if it has no lights at all, the default daylight
/// ([`SceneOverrides::apply`]).
pub fn load(scene: &str) -> Result<SceneDescription, String> {
    let mut description = match lab::eval::built_in_scene(scene) {
        Some(built_in) => built_in?,
        None => {
            let path = std::path::Path::new(scene);
            if path.extension().is_none() {
                let names = lab::eval::built_in_scene_names().collect::<Vec<_>>().join(", ");
                return Err(format!("'{scene}' is neither a built-in scene ({names}) nor a scene file"));
            }
            engine::import::load_scene(path).map_err(|e| e.to_string())?
        }
    };
    SceneOverrides::get().apply(&mut description, scene);
    Ok(description)
}

/// Replaces the scene's camera by one at `position` looking at `target` (`--camera-position`,
/// `--camera-target`, `--fov` in degrees).
pub fn replace_camera(scene: &mut SceneDescription, position: glam::Vec3, target: glam::Vec3, fov: f32) -> Result<(), String> {
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!("--fov must be between 0 and 180 degrees, got {fov}"));
    }
    for node in &mut scene.nodes {
        node.content.retain(|c| !matches!(c, NodeContent::Camera(_)));
    }
    let up = if (target - position).normalize_or_zero().y.abs() > 0.99 { glam::Vec3::Z } else { glam::Vec3::Y };
    let camera = Camera { yfov: fov.to_radians(), ..Default::default() };
    scene.add_node(
        "command_line_camera",
        Transform::from_translation(position).looking_at(target, up),
        None,
        vec![NodeContent::Camera(camera)],
    );
    Ok(())
}

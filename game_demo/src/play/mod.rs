//! `game_demo play`: the walkable demo level with DDGI, in a window (first-person controls and the
//! probe debug overlay) or headless (a scripted walk writing frames and per-frame GPU times).
//!
//! - [`level`]: the level (kit-bashed Kenney models and procedural rooms) and its animations;
//! - [`navmesh`]: where one can walk (spade's constrained Delaunay triangulation);
//! - [`controller`]: the first-person controller and the scripted tour;
//! - [`overlay`]: the demo's panels in the DDGI overlay (`ddgi_overlay`); [`window`]: its hooks into the engine's windowed runner; [`headless`]: the scripted
//!   walk without a window; [`soak`]: thousands of frames checked for NaN, memory growth and
//!   timing drift; [`tour`]: the open world's tour with camera-following cascades.

pub mod controller;
pub mod headless;
pub mod level;
pub mod navmesh;
pub mod overlay;
pub mod soak;
pub mod tour;
pub mod window;

use std::path::Path;

use bevy_app::App;
use ddgi::{DdgiOutput, DdgiProbeView, DdgiVolume};
use engine::gpu::GpuContext;
use engine::render::RenderOutputs;
use glam::Vec3Swizzles;

use controller::{PlayerPlugin, PlayerSettings, ScriptedTour};
use level::{DemoLevel, DemoLevelPlugin, LevelAnimations, demo_level};

/// The fixed clock of scripted runs (headless, and the windowed run the tests compare with it).
pub const STEP_SECONDS: f64 = 1.0 / 60.0;

/// The level's default probe spacing, in metres (the level's, in [`scenes::level`]).
pub use scenes::level::PROBE_SPACING;

/// What `play` renders and how.
#[derive(Clone, Debug)]
pub struct PlayOptions {
    pub width: u32,
    pub height: u32,
    /// Probes along x, y and z of the level's DDGI volume (default: every [`PROBE_SPACING`]
    /// metres, [`level::level_probe_counts`]).
    pub probe_counts: glam::UVec3,
    /// Probe spacing of the finest cascade in metres (with `cascades`).
    pub cascade_spacing: f32,
    pub rays_per_probe: u32,
    pub adaptive: bool,
    /// Load Kenney's models from the shared folder beside the checkout
    /// (`scenes::level::kenney_assets_dir`) when they are there; the level's own props otherwise.
    pub use_assets: bool,
    /// Camera-following cascades (0: one volume over the level): this many nested volumes of
    /// [`CASCADE_PROBES`] probes, the finest at `cascade_spacing`.
    pub cascades: u32,
    /// Temporal anti-aliasing ([`engine::render::TemporalAntiAliasing`]).
    pub taa: bool,
}

/// Probes of each cascade of `play --cascades N`.
pub const CASCADE_PROBES: glam::UVec3 = glam::UVec3::new(16, 8, 16);

impl Default for PlayOptions {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
            probe_counts: level::probe_counts(),
            cascade_spacing: PROBE_SPACING,
            rays_per_probe: ddgi::DdgiVolume::default().rays_per_probe,
            adaptive: true,
            use_assets: true,
            cascades: 0,
            taa: true,
        }
    }
}

/// Builds the level into `app` (which has the engine and render plugins): the scene and its
/// animations, the player on the navigation mesh, the level's DDGI volume and the overlay's
/// resources. `scripted`: the player follows the level's tour instead of input.
pub fn setup_play(app: &mut App, options: &PlayOptions, scripted: bool) -> Result<DemoLevel, String> {
    if !options.taa {
        app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
    }
    // What a player sees: the filmic transform and an exposure that follows day and night, indoors
    // and out (image files of the engine's own commands keep the radiometric clamp).
    app.insert_resource(engine::render::DisplayTransform::AgX).insert_resource(engine::render::DefaultAutoExposure::default());
    // A terminal bar while large scenes' BLASes build.
    lab::progress::show_blas_builds(app);
    let assets = if options.use_assets { level::kenney_assets_or_note() } else { None };
    let level = demo_level(assets.as_deref());
    let player = PlayerPlugin::new(level.layout.clone(), PlayerSettings::default()).map_err(|e| format!("navigation mesh: {e}"))?;
    let (outdoors, indoors) = (level.layout.spawn.xz(), level.layout.indoor_point.xz());
    if !player.navmesh.connected(outdoors, indoors, true) {
        return Err("the level's house cannot be reached from the spawn point, even with the door open".into());
    }
    let root = level.scene.clone().spawn(app.world_mut());
    level.attach_animations(app.world_mut(), root).map_err(|e| e.to_string())?;
    if scripted {
        app.insert_resource(ScriptedTour::new(level.layout.tour.clone(), true));
    }
    app.add_plugins((DemoLevelPlugin, player));

    let mut volume = DdgiVolume {
        bounds: Some((level.layout.gi_bounds.0.as_dvec3(), level.layout.gi_bounds.1.as_dvec3())),
        probe_counts: Some(options.probe_counts),
        rays_per_probe: options.rays_per_probe,
        ..Default::default()
    };
    volume.adaptive.enabled = options.adaptive;
    volume.validate().map_err(|e| format!("the level's DDGI volume: {e}"))?;
    if options.cascades > 0 {
        let cascades = ddgi::DdgiCascades {
            count: Some(options.cascades),
            probe_counts: CASCADE_PROBES,
            spacing: options.cascade_spacing,
            volume: DdgiVolume { bounds: None, probe_counts: Some(CASCADE_PROBES), warm_up: true, ..volume },
            ..Default::default()
        };
        cascades.validate().map_err(|e| format!("the level's DDGI cascades: {e}"))?;
        ddgi::use_ddgi_cascades(app, cascades, DdgiOutput::Full);
    } else {
        ddgi::use_ddgi(app, volume, DdgiOutput::Full);
    }
    app.init_resource::<DdgiProbeView>();
    Ok(level)
}

/// Adds the DDGI overlay (`ddgi_overlay`, hidden until F1 or [`ddgi_overlay::DdgiOverlay::visible`])
/// with the demo's own panels: the navigation mesh, the entity inspector, the screenshot button.
pub fn add_overlay(app: &mut App) {
    app.add_plugins(ddgi_overlay::DdgiOverlayPlugin);
    app.init_resource::<overlay::ScreenshotRequest>();
    app.world_mut().resource_mut::<ddgi_overlay::DdgiOverlayPanels>().add(overlay::DemoPanels::default());
}

/// Writes the last frame's tonemapped image as a PNG.
pub fn save_screenshot(gpu: &GpuContext, world: &bevy_ecs::world::World, path: &Path) -> Result<(), String> {
    let pixels = engine::headless::read_ldr(gpu, world);
    let size = world.resource::<RenderOutputs>().size;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    image::save_buffer(path, &pixels, size.width, size.height, image::ExtendedColorType::Rgba8)
        .map_err(|e| format!("{}: {e}", path.display()))
}

//! # Dynamic diffuse global illumination
//!
//! Diffuse light that has bounced off other surfaces changes slowly across space, so it can be
//! stored sparsely: in a grid of *probes*, each of which records the irradiance arriving from
//! every direction. DDGI (Majercik, Guertin, Nowrouzezahrai and McGuire, "Dynamic Diffuse Global
//! Illumination with Ray-Traced Irradiance Fields", JCGT 8(2), 2019) keeps such a grid up to date
//! every frame, for fully dynamic scenes, by tracing a few hundred rays from each probe:
//!
//! 1. **Ray generation**: `rays_per_probe` spherical Fibonacci directions (Keinert et al. 2015),
//!    turned by a new random rotation each frame so that successive frames see new directions.
//! 2. **Trace** against the scene's BVH (the engine's ray-tracing core). Back-face hits are kept:
//!    a probe that sees many of them sits inside geometry. Every ray of the update is traced here:
//!    at a front-face hit, a shadow ray per light gives the hit's direct light.
//! 3. **Shade** each hit as a Lambertian surface: emission, that direct light, and indirect light
//!    read from *last frame's* probes — so each frame adds one bounce, and the field converges to
//!    all bounces. Misses see the sky.
//! 4. **Update** each probe's two octahedral maps (Cigolle et al. 2014): irradiance (8×8 texels,
//!    the cosine-weighted mean of the rays' radiance over each texel's hemisphere) and distance
//!    (16×16 texels, the mean and mean square of the hit distance, with a sharp cosine-power
//!    weight), each blended with the old value by the *hysteresis*, then copy each map's border
//!    texels so that bilinear filtering wraps around the octahedron.
//!
//! A shaded point — a camera pixel or a probe ray's hit — reads the 8 probes of the grid cell
//! around it and blends them with four weights: a *wrap-shading* back-face weight, a *Chebyshev*
//! visibility test on the distance moments (as in variance shadow maps: a probe whose mean
//! distance in the point's direction is shorter than the point's distance is probably behind a
//! wall), a *log-perception crush* of small weights, and *trilinear* interpolation; the lookup
//! point is first pushed off the surface along the normal and towards the viewer (*normal and view
//! bias*) so that surfaces do not shadow themselves.
//!
//! Majercik, Müller, Keller, Nowrouzezahrai and McGuire ("Scaling Probe-Based Real-Time Dynamic
//! Global Illumination for Production", JCGT 10(2), 2021) add **relocation** — a probe stuck in a
//! wall moves out of it, within its cell — and **classification** — probes inside geometry or
//! with no surface within a cell of them are switched off: they trace no rays and get no weight.
//! Hvezda and Bittner ("Dynamic Diffuse Global Illumination: Implementation and Evaluation")
//! describe the implementation this plugin follows and its evaluation against a path tracer.
//!
//! Beyond the papers, [`DdgiAdaptive`] spends the rays where the lighting changes: each probe's
//! temporal error (SMAPE in YCoCg between its maps and what each frame's rays ask of them, smoothed
//! over frames) sets its ray count; a converged probe *rests*, updating only every few frames, once
//! a slower average of that error, which keeps less of the noise, has settled; and
//! the per-probe passes run only for the probes traced that frame; dark probes are switched off.
//! A volume whose probes read back calm updates only every few frames
//! ([`DdgiAdaptive::max_update_period`], the [`calm`] module), which also saves the passes' fixed
//! costs, and updates at once again when the CPU sees anything change.
//!
//! **Open worlds.** [`DdgiCascades`] keeps nested volumes centred on a camera, each twice as
//! coarse as the one inside it (RTXGI's scrolling volumes, G3D's and Flax's cascades): a volume
//! whose bounds move by whole cells *scrolls* — its probe indices shift toroidally, the probes that
//! stay keep their maps, the planes that enter restart and converge as a running mean
//! ([`DdgiVolume::warm_up`]) — and far cascades update only every few frames
//! ([`DdgiVolume::update_period`]). The gather takes the finest cascade that covers a point and
//! blends into the next across a band; where no volume reaches, [`DdgiSkyLight`] lights a point by
//! the sky times a short-range visibility. Probes near an instance that moves wake at once, the
//! others keep resting. Volumes live in world space in double precision and follow the engine's
//! render origin (large-world coordinates, [`engine::scene::RenderOrigin`]).
//!
//! ## In the ECS
//!
//! Add [`DdgiPlugin`], spawn an entity with a [`DdgiVolume`] (its settings), and select the
//! `"ddgi"` frame script ([`use_ddgi`] does both; [`use_ddgi_lighting`] with
//! `DdgiLighting::default()` picks one volume or cascades to fit the scene). Each probe becomes an entity with a
//! [`DdgiProbe`] mirroring its GPU state. The passes, each with its own timing span:
//! `ddgi_budget → ddgi_trace → ddgi_probe_update` (maps, atlas tiles, relocation
//! and classification in one pass) — each one pass over every volume that updates in the frame,
//! the volumes' dispatches side by side so that the GPU overlaps them — then per camera
//! `ddgi_gather` (one per volume) `→ ddgi_composite`. Shaders: `plugins/ddgi/shaders/`, one file
//! per pass ([`SHADERS`]).
//!
//! ## Minimal setup
//!
//! Load a scene, light it as fits its size (one volume over a room, a house or a cathedral;
//! cascades that follow the camera over a village: [`DdgiLighting`]), and write the last of 120
//! frames (`out/image.png`, `out/image.exr`, `out/timings.json`); [`prelude`] has what an app
//! needs:
//!
//! ```rust,no_run
//! use std::path::Path;
//! use ddgi::prelude::*;
//! use engine::gpu::{GpuContext, GpuOptions};
//! use engine::headless::{render_scene_with, HeadlessSettings};
//!
//! fn main() -> Result<(), Box<dyn std::error::Error>> {
//!     let scene = engine::import::load_scene(Path::new("level.glb"))?;
//!     let lighting = DdgiLighting::default();
//!     let gpu = GpuContext::new(GpuOptions::default())?;
//!     let settings = HeadlessSettings { width: 1280, height: 720, frames: 120, ..Default::default() };
//!     let frame = render_scene_with(&gpu, scene, &settings, |app| use_ddgi_lighting(app, lighting, DdgiOutput::Full))?;
//!     Ok(frame.write(Path::new("out"))?)
//! }
//! ```

#![warn(missing_docs)]

pub mod atlas;
pub mod buffers;
pub mod calm;
pub mod cascade_volume;
pub mod cascades;
pub mod contact_occlusion;
pub mod debug_view;
pub mod field_docs;
pub mod fit;
pub mod frame;
pub mod gpu;
pub mod inspect;
pub mod pipelines;
pub mod quality;
pub mod resources;
pub mod sky_light;
pub mod sync;
pub mod volume;

use bevy_app::{App, Plugin};
use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::render::gpu_scene::{flush_uploads, prepare_gpu_scene};
use engine::render::{FrameScript, frame_script_is};

pub use cascades::{DdgiCascade, DdgiCascades, DdgiFirstCameraCascades};
pub use debug_view::{DdgiContactOcclusion, DdgiDebugPass, DdgiDebugPasses, DdgiOutput, DdgiProbeColor, DdgiProbeView, DdgiSkyLight};
pub use fit::{DdgiLighting, MAX_FITTED_SPACING};
pub use frame::{DdgiFrame, PROBE_UPDATE_PASSES, VolumeHandles, is_probe_update_pass, render_ddgi_frame};
pub use inspect::{DdgiProbeStateCounts, DdgiUpdateControl};
pub use pipelines::DdgiPipelines;
pub use quality::DdgiQuality;
pub use resources::{DdgiGpuVolumes, VolumeGpu};
pub use sync::{rays_counter, rays_traced, volume_suffix};
pub use volume::{
    AUTO_PROBES_LONGEST, AUTO_PROBES_MIN, DdgiAdaptive, DdgiLayout, DdgiProbe, DdgiProbePin, DdgiProbeState, DdgiSettingsError, DdgiVolume,
    DdgiWeights, auto_probe_counts,
};

/// What an app needs to light a scene with DDGI: the plugin and its setup functions, the volume
/// and cascade settings, the output and lighting options, the probe components and the settings
/// error. `use ddgi::prelude::*;`
pub mod prelude {
    pub use crate::{
        DdgiAdaptive, DdgiCascades, DdgiContactOcclusion, DdgiLighting, DdgiOutput, DdgiPlugin, DdgiProbe, DdgiProbePin, DdgiProbeState,
        DdgiQuality, DdgiSettingsError, DdgiSkyLight, DdgiVolume, use_ddgi, use_ddgi_cascades, use_ddgi_lighting,
    };
}

/// DDGI's WGSL (`plugins/ddgi/shaders/`): one file per pass, named after the pass label, and the
/// modules only its passes share (`ddgi_camera.inc.wgsl`, `ddgi_shading.inc.wgsl`,
/// `ddgi_visibility.inc.wgsl`). The modules other crates include too live in the shared library
/// (`shaders/` at the top, always registered): `ddgi_common.inc.wgsl` (structs, bindings,
/// helpers), `ddgi_sampling.inc.wgsl` (the 8-probe sampling function) and
/// `ddgi_debug_draw.inc.wgsl` (the probe sphere and false colours of the debug views).
/// [`register_shaders`] adds these, with the generated `ddgi_constants.inc.wgsl` the library's
/// DDGI modules include.
pub const SHADERS: &[engine::shader::ShaderModule] = &[
    ("ddgi_camera.inc.wgsl", include_str!("../shaders/ddgi_camera.inc.wgsl")),
    ("ddgi_budget.wgsl", include_str!("../shaders/ddgi_budget.wgsl")),
    ("ddgi_shading.inc.wgsl", include_str!("../shaders/ddgi_shading.inc.wgsl")),
    ("ddgi_trace.wgsl", include_str!("../shaders/ddgi_trace.wgsl")),
    ("ddgi_shade.wgsl", include_str!("../shaders/ddgi_shade.wgsl")),
    ("ddgi_probe_update.wgsl", include_str!("../shaders/ddgi_probe_update.wgsl")),
    ("ddgi_gather.wgsl", include_str!("../shaders/ddgi_gather.wgsl")),
    ("ddgi_visibility.inc.wgsl", include_str!("../shaders/ddgi_visibility.inc.wgsl")),
    ("ddgi_contact_occlusion.wgsl", include_str!("../shaders/ddgi_contact_occlusion.wgsl")),
    ("ddgi_composite.wgsl", include_str!("../shaders/ddgi_composite.wgsl")),
    ("ddgi_probe_spheres.wgsl", include_str!("../shaders/ddgi_probe_spheres.wgsl")),
];

/// Adds DDGI's WGSL ([`SHADERS`] and the generated constants) to the engine's shader registry, so
/// that its pipelines build and any crate's WGSL can `#include "ddgi_sampling.inc.wgsl"`. The
/// plugin calls it; call it yourself to build your own pipelines that include DDGI modules before
/// the plugin is added. Idempotent.
pub fn register_shaders() -> Result<(), engine::shader::ShaderError> {
    engine::shader::register(SHADERS)?;
    engine::shader::register_generated("ddgi_constants.inc.wgsl", gpu::wgsl_constants())
}

/// The name of the DDGI frame script.
pub const FRAME_SCRIPT: &str = "ddgi";

/// Dynamic diffuse global illumination: probe volumes updated every frame and the `"ddgi"` frame
/// script. Needs the engine's `RenderPlugin`; without a GPU, or if the shaders fail to build, it
/// warns and stays off.
pub struct DdgiPlugin;

impl Plugin for DdgiPlugin {
    fn build(&self, app: &mut App) {
        let Some(gpu) = app.world().get_resource::<GpuContext>().cloned() else {
            log::warn!("DdgiPlugin needs the engine's RenderPlugin (a GPU); global illumination is off");
            return;
        };
        let pipelines = match DdgiPipelines::new(&gpu) {
            Ok(p) => p,
            Err(e) => {
                log::warn!("DDGI shaders failed, global illumination is off: {e}");
                return;
            }
        };
        app.insert_resource(pipelines)
            .init_resource::<DdgiGpuVolumes>()
            .init_resource::<DdgiOutput>()
            .init_resource::<DdgiSkyLight>()
            .init_resource::<DdgiContactOcclusion>()
            .init_resource::<DdgiUpdateControl>()
            .add_systems(
                engine::app::Prepare,
                (
                    sync::read_back_ddgi_probes,
                    fit::apply_ddgi_lighting,
                    cascades::follow_ddgi_cascades,
                    inspect::reset_ddgi_volumes,
                    resources::prepare_ddgi_volumes,
                    inspect::pause_ddgi_updates,
                    sync::upload_ddgi_probe_pins,
                )
                    .chain()
                    .after(prepare_gpu_scene),
            )
            .add_systems(engine::app::Render, frame::render_ddgi_frame.run_if(frame_script_is(FRAME_SCRIPT)).after(flush_uploads));
    }
}

/// Adds DDGI to `app` lit as `lighting` says and makes `"ddgi"` the frame script, writing
/// `output`. `DdgiLighting::default()` is the scene-fitted default: one volume over the scene, or
/// camera-following cascades when one volume's probes would be more than [`MAX_FITTED_SPACING`]
/// apart ([`DdgiLighting::fitted`]), decided on the first frame with geometry.
pub fn use_ddgi_lighting(app: &mut App, lighting: DdgiLighting, output: DdgiOutput) {
    app.insert_resource(FrameScript(FRAME_SCRIPT)).insert_resource(output).insert_resource(lighting).add_plugins(DdgiPlugin);
}

/// Adds DDGI to `app` with cascades that follow the first camera ([`DdgiCascades`] as a resource)
/// and makes `"ddgi"` the frame script, writing `output`.
pub fn use_ddgi_cascades(app: &mut App, cascades: DdgiCascades, output: DdgiOutput) {
    app.insert_resource(FrameScript(FRAME_SCRIPT))
        .insert_resource(output)
        .insert_resource(cascades::DdgiFirstCameraCascades(cascades))
        .add_plugins(DdgiPlugin);
}

/// Adds DDGI to `app`, spawns `volume` (one volume, whatever the scene's size: see
/// [`use_ddgi_lighting`] for the scene-fitted choice) and makes `"ddgi"` the frame script, writing `output`.
pub fn use_ddgi(app: &mut App, volume: DdgiVolume, output: DdgiOutput) {
    app.insert_resource(FrameScript(FRAME_SCRIPT)).insert_resource(output).add_plugins(DdgiPlugin);
    app.world_mut().spawn(volume);
}

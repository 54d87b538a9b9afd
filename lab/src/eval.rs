//! `game_demo eval`: error against a path-traced reference and GPU time, for every configuration of
//! a list. Writes `report.md`, `results.json`, `error_vs_time.png` and, per configuration, a strip
//! of four panels: direct only | the method | the reference | the FLIP error map (magma).
//! `--time-series` measures instead every frame after a change in the scene ([`time_series`]), and
//! `--time-series --walk` every frame of a walk through it ([`walk_series`]).
//!
//! The configurations and how each one renders are all in [`Config`].

pub mod grid_sweep;
pub mod time_series;
pub mod walk_series;

use std::path::{Path, PathBuf};

use engine::bevy_app::App;
use engine::glam::Vec3;
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, RenderedFrame, add_default_camera, render_scene_with};
use engine::render::FrameTiming;
use engine::scene::{NodeContent, SceneDescription};
use serde::Serialize;

use crate::metrics::{ErrorMetrics, compare, flip_rgb8, magma, tonemap_to_srgb8};
use crate::plot;
use time_series::SceneChange;

/// Paths per pixel of the path tracer configurations compared with the reference: the ladder on
/// which [`spp_at_equal_flip`] finds each DDGI configuration's equal.
pub const PATH_TRACE_LADDER: [u32; 4] = [1, 4, 16, 64];
/// Paths per pixel of the path tracer timed at [`EvalOptions::timing_size`] (two frames of 16):
/// its GPU ms per path per pixel there.
pub const TIMING_SPP: u32 = 32;
/// The size at which `game_demo eval` times the path tracer and DDGI besides the evaluation's own.
pub const DISPLAY_SIZE: [u32; 2] = [1920, 1080];
/// Most paths per pixel the path tracer adds in one frame; more take several frames.
const SAMPLES_PER_FRAME: u32 = 16;
/// Paths per pixel per frame of the path tracer in the time series.
const TIME_SERIES_SPP: u32 = 4;
/// Seed of the reference: another than the configurations', so that their noise is not the reference's.
const REFERENCE_SEED: u32 = 0xC0DE;
/// Exposure at which FLIP compares images.
const EXPOSURE: f32 = 1.0;

/// One thing to evaluate. A new method is a new variant with its arms in the `match`es of this
/// `impl` and an entry in [`Config::still_list`] and/or [`Config::time_series_list`]; nothing else
/// in the evaluation needs to know it.
#[derive(Clone, Debug, PartialEq)]
pub enum Config {
    /// Direct light with hard shadows: the engine's default frame script, one frame.
    Direct,
    /// The progressive path tracer with `spp` paths per pixel, at most [`SAMPLES_PER_FRAME`] per
    /// frame. In a time series it adds `spp` (at most [`SAMPLES_PER_FRAME`]) every frame and
    /// starts over when the scene changes.
    PathTrace { spp: u32 },
    /// Direct light + DDGI's indirect light from one probe volume, after [`DDGI_FRAMES`] frames (in
    /// a time series: frame after frame, the probes following the change at their hysteresis).
    /// `occlusion`: the contact occlusion of its indirect light (off unless the configuration is
    /// about it); `taa`: the camera's temporal anti-aliasing (on, as by default, unless the
    /// configuration is about it).
    Ddgi { name: String, volume: Box<ddgi::DdgiVolume>, occlusion: ddgi::DdgiContactOcclusion, taa: bool },
    /// DDGI's camera-following cascades instead of one volume.
    DdgiCascades { name: String, cascades: Box<ddgi::DdgiCascades> },
}

/// Frames DDGI runs before a still image is taken (the probes converge over many frames: each
/// adds a bounce, and the hysteresis smooths them).
pub const DDGI_FRAMES: u32 = 120;

/// The probe grids of the quality experiment (densities) and the irradiance map sides
/// (resolutions; the distance maps are twice as fine, as in the literature).
pub const DDGI_DENSITIES: [[u32; 3]; 3] = [[8, 4, 8], [16, 8, 16], [32, 16, 32]];
pub const DDGI_RESOLUTIONS: [u32; 3] = [4, 8, 16];

/// The probe grid of the published experiment on each built-in scene (Hvezda and Bittner), as its
/// entry gives it ([`scenes::SceneEntry::paper_grid`], [`scenes::files::SceneFile::paper_grid`]):
/// 16×8×16 for the door room, 16×16×15 for the room under a skylight, 2×2×2 for the colour
/// bleeding box, 16×8×12 for Šibenik (`sibenik`, and its stand-in `cathedral`); 8×8×8 elsewhere.
pub fn ddgi_paper_grid(scene: &str) -> [u32; 3] {
    let entry = scenes::find(scene).and_then(|entry| entry.paper_grid);
    entry.or_else(|| scenes::files::find(scene).and_then(|file| file.paper_grid)).unwrap_or([8, 8, 8])
}

/// What the evaluation knows of a scene beyond its description: its name, the probe grid and the
/// box of its DDGI configurations, and the change of its time series. [`SceneFacts::named`] gives
/// a built-in scene's (or a scene file's); an application describes its own scenes (the demo its
/// level) with their own values.
#[derive(Clone, Debug)]
pub struct SceneFacts {
    /// The scene's name: in reports, reference cache keys and output names.
    pub name: String,
    /// The probe grid of the DDGI configurations ([`ddgi_paper_grid`] for the built-in scenes).
    pub paper_grid: [u32; 3],
    /// The box DDGI's probes fill; `None`: the bounds of the scene's instances.
    pub gi_bounds: Option<(Vec3, Vec3)>,
    /// The time series' change, prepared in the scene; `None`: the built-in change for the scene's
    /// name ([`time_series::scene_change`]).
    pub change: Option<PrepareChange>,
}

/// Prepares a time series' change in a scene (it may add the node that changes, or move the
/// camera to where the change shows).
pub type PrepareChange = fn(&mut SceneDescription) -> Result<SceneChange, String>;

/// A built-in scene by name: one of [`scenes::ALL`], a scene file of the shared folder
/// ([`scenes::files::FILES`]: an error when it is absent) or the demo level
/// ([`scenes::level::NAME`]); `None` for any other name.
pub fn built_in_scene(name: &str) -> Option<Result<SceneDescription, String>> {
    if let Some(entry) = scenes::find(name) {
        return Some(Ok((entry.build)()));
    }
    if let Some(loaded) = scenes::files::load(name) {
        return Some(loaded);
    }
    (name == scenes::level::NAME).then(|| Ok(scenes::level::scene()))
}

/// The names [`built_in_scene`] knows: [`scenes::names`], the shared scene files, then the demo
/// level's.
pub fn built_in_scene_names() -> impl Iterator<Item = &'static str> {
    scenes::names().chain(scenes::files::FILES.iter().map(|f| f.name)).chain([scenes::level::NAME])
}

impl SceneFacts {
    /// The facts of the built-in scene `name` (its published grid and its own GI box), of the demo
    /// level ([`scenes::level::NAME`]: `play`'s grid and box, its change left to the demo), or of a
    /// scene file (8×8×8 probes over its instances' bounds, the first light moves).
    pub fn named(name: &str) -> SceneFacts {
        if name == scenes::level::NAME {
            let (paper_grid, gi_bounds) = (scenes::level::probe_counts().to_array(), Some(scenes::level::level_gi_bounds()));
            return SceneFacts { name: name.into(), paper_grid, gi_bounds, change: None };
        }
        SceneFacts {
            name: name.into(),
            paper_grid: ddgi_paper_grid(name),
            gi_bounds: scenes::find(name).and_then(|entry| (entry.gi_bounds)()),
            change: None,
        }
    }
}

impl Config {
    /// A DDGI configuration on `scene` (its volume bounds from [`SceneFacts::gi_bounds`] unless
    /// `volume` has its own).
    pub fn ddgi(name: String, scene: &SceneFacts, volume: ddgi::DdgiVolume) -> Config {
        let bounds = volume.bounds.or(scene.gi_bounds.map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3())));
        Config::Ddgi { name, volume: Box::new(ddgi::DdgiVolume { bounds, ..volume }), occlusion: Default::default(), taa: true }
    }

    /// DDGI with `grid` (default: the published grid for `scene`), the fixed ray budget and the
    /// default settings otherwise.
    pub fn ddgi_default(scene: &SceneFacts, grid: Option<[u32; 3]>) -> Config {
        let probes = grid.unwrap_or(scene.paper_grid);
        let volume = ddgi::DdgiVolume { probe_counts: Some(probes.into()), adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() };
        Config::ddgi(format!("ddgi_{}x{}x{}", probes[0], probes[1], probes[2]), scene, volume)
    }

    /// [`Config::ddgi_default`] with adaptive ray budgets.
    pub fn ddgi_adaptive(scene: &SceneFacts, grid: Option<[u32; 3]>, adaptive: &ddgi::DdgiAdaptive) -> Config {
        let probes = grid.unwrap_or(scene.paper_grid);
        let adaptive = ddgi::DdgiAdaptive { enabled: true, ..adaptive.clone() };
        let volume = ddgi::DdgiVolume { probe_counts: Some(probes.into()), adaptive, ..Default::default() };
        Config::ddgi(format!("ddgi_{}x{}x{}_adaptive", probes[0], probes[1], probes[2]), scene, volume)
    }

    /// The quality table (every density × resolution) and the ablation of the visibility weights
    /// (none → back-face → Chebyshev → normal bias → contact occlusion), in report order.
    pub fn ddgi_experiments(scene: &SceneFacts) -> Vec<Config> {
        let mut list = Vec::new();
        for grid in DDGI_DENSITIES {
            for texels in DDGI_RESOLUTIONS {
                let volume = ddgi::DdgiVolume {
                    probe_counts: Some(grid.into()),
                    adaptive: ddgi::DdgiAdaptive::off(),
                    irradiance_texels: texels,
                    distance_texels: 2 * texels,
                    ..Default::default()
                };
                list.push(Config::ddgi(format!("ddgi_{}x{}x{}_{texels}px", grid[0], grid[1], grid[2]), scene, volume));
            }
        }
        let none = ddgi::DdgiWeights::NONE;
        let steps = [
            ("none", none),
            ("backface", ddgi::DdgiWeights { backface: true, ..none }),
            ("chebyshev", ddgi::DdgiWeights { backface: true, chebyshev: true, ..none }),
            ("normal_bias", ddgi::DdgiWeights::ALL),
        ];
        for (step, weights) in steps {
            let grid = scene.paper_grid;
            let volume =
                ddgi::DdgiVolume { probe_counts: Some(grid.into()), weights, adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() };
            list.push(Config::ddgi(format!("ddgi_weights_{step}"), scene, volume));
        }
        // The last step of the ablation: every weight, and contact occlusion of the indirect light
        // (8 rays a pixel reaching the probe spacing).
        let volume =
            ddgi::DdgiVolume { probe_counts: Some(scene.paper_grid.into()), adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() };
        if let Config::Ddgi { name, volume, .. } = Config::ddgi("ddgi_weights_contact_occlusion".into(), scene, volume) {
            list.push(Config::Ddgi { name, volume, occlusion: ddgi::DdgiContactOcclusion { rays: 8, ..Default::default() }, taa: true });
        }
        list.extend(Config::ddgi_contributions(scene));
        list
    }

    /// DDGI at the plugin's defaults ([`ddgi::DdgiVolume::default`]: the grid fitted to the box,
    /// temporal anti-aliasing on): what a new user's first render gets.
    pub fn ddgi_defaults(scene: &SceneFacts) -> Config {
        Config::ddgi("ddgi_defaults".into(), scene, ddgi::DdgiVolume::default())
    }

    /// What each default contributes, one step at a time from the published grid with the fixed
    /// budget and without temporal anti-aliasing (the defaults before them): + temporal
    /// anti-aliasing (the published grid's own row), + the grid fitted to the box (the fixed
    /// budget still), + adaptive budgets ([`Config::ddgi_defaults`], in the main list), + contact
    /// occlusion.
    pub fn ddgi_contributions(scene: &SceneFacts) -> Vec<Config> {
        let published = |name: &str, taa| match Config::ddgi_default(scene, None) {
            Config::Ddgi { volume, occlusion, .. } => Config::Ddgi { name: name.into(), volume, occlusion, taa },
            other => other,
        };
        let occluded = match Config::ddgi_defaults(scene) {
            Config::Ddgi { volume, .. } => Config::Ddgi {
                name: "ddgi_defaults_contact_occlusion".into(),
                volume,
                occlusion: ddgi::DdgiContactOcclusion { rays: 4, ..Default::default() },
                taa: true,
            },
            other => other,
        };
        let fitted = Config::ddgi(
            "ddgi_defaults_fixed_budget".into(),
            scene,
            ddgi::DdgiVolume { adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() },
        );
        vec![published("ddgi_published_grid_no_taa", false), fitted, occluded]
    }
}

impl Config {
    /// The configurations of the still-image evaluation of `scene`, in report order; with
    /// `experiments`, DDGI's quality table and weight ablation too.
    pub fn still_list(scene: &SceneFacts, experiments: bool, grid: Option<[u32; 3]>, adaptive: &ddgi::DdgiAdaptive) -> Vec<Config> {
        let mut list = vec![Config::Direct];
        list.extend(PATH_TRACE_LADDER.iter().map(|&spp| Config::PathTrace { spp }));
        list.push(Config::ddgi_defaults(scene));
        list.push(Config::ddgi_default(scene, grid));
        list.push(Config::ddgi_adaptive(scene, grid, adaptive));
        if experiments {
            list.extend(Config::ddgi_experiments(scene));
        }
        list
    }

    /// The methods of the time series: each renders frame after frame and every frame is measured.
    pub fn time_series_list(scene: &SceneFacts, grid: Option<[u32; 3]>, adaptive: &ddgi::DdgiAdaptive) -> Vec<Config> {
        vec![
            Config::Direct,
            Config::PathTrace { spp: TIME_SERIES_SPP },
            Config::ddgi_default(scene, grid),
            Config::ddgi_adaptive(scene, grid, adaptive),
        ]
    }

    pub fn name(&self) -> String {
        match self {
            Config::Direct => "direct".into(),
            Config::PathTrace { spp } => format!("pathtrace_{spp}spp"),
            Config::Ddgi { name, .. } | Config::DdgiCascades { name, .. } => name.clone(),
        }
    }

    /// The method: configurations of one method form one series in the plots.
    pub fn method(&self) -> &'static str {
        match self {
            Config::Direct => "direct light",
            Config::PathTrace { .. } => "path tracer",
            Config::Ddgi { .. } | Config::DdgiCascades { .. } => "DDGI",
        }
    }

    /// Frames to render: a still image is the last of them; a time series runs them before the
    /// change, so that the method has settled.
    pub fn frames(&self) -> u32 {
        match self {
            Config::Direct => 1,
            Config::PathTrace { spp } => spp.div_ceil(self.samples_per_frame()),
            Config::Ddgi { .. } | Config::DdgiCascades { .. } => DDGI_FRAMES,
        }
    }

    fn samples_per_frame(&self) -> u32 {
        match self {
            Config::PathTrace { spp } => (*spp).clamp(1, SAMPLES_PER_FRAME),
            _ => 1,
        }
    }

    /// Sets `app` up to render this configuration (its frame script and settings); `seed` seeds
    /// the random sequences of the methods that have any. Large scenes' BLAS builds show a bar on
    /// a terminal ([`crate::progress::show_blas_builds`]).
    pub fn configure(&self, app: &mut App, seed: u32) {
        crate::progress::show_blas_builds(app);
        match self {
            Config::Direct => {}
            Config::PathTrace { .. } => {
                let settings = pathtrace::PathTraceSettings { samples_per_frame: self.samples_per_frame(), seed, ..Default::default() };
                pathtrace::use_path_tracer(app, settings);
            }
            Config::Ddgi { volume, occlusion, taa, .. } => {
                app.insert_resource(*occlusion);
                if !taa {
                    app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
                }
                ddgi::use_ddgi(app, (**volume).clone(), ddgi::DdgiOutput::Full)
            }
            Config::DdgiCascades { cascades, .. } => ddgi::use_ddgi_cascades(app, (**cascades).clone(), ddgi::DdgiOutput::Full),
        }
    }
}

/// A configuration's result.
#[derive(Serialize)]
pub struct EvalRow {
    pub config: String,
    pub method: String,
    pub frames: u32,
    /// Mean GPU milliseconds per frame (all passes that ran), or absent without timestamps.
    pub gpu_ms_per_frame: Option<f64>,
    /// GPU milliseconds for the whole image (all frames).
    pub gpu_ms_total: Option<f64>,
    /// DDGI's rays traced per frame, every volume together: the mean over the frames whose count
    /// came back (absent for the other methods).
    pub rays_per_frame: Option<f64>,
    pub error: ErrorMetrics,
    /// A DDGI configuration's cost against the path tracer's at equal error (absent for the
    /// other methods).
    pub equal_flip: Option<EqualFlip>,
}

/// Where a FLIP falls on the path tracer's ladder ([`spp_at_equal_flip`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LadderPosition {
    /// Between the first and the last rung (or on one): interpolated.
    Within,
    /// Worse than the path tracer's fewest paths per pixel: its equal is at most that rung's.
    Below,
    /// Better than the path tracer's most paths per pixel: its equal is at least that rung's.
    Above,
}

/// A DDGI configuration against the path tracer at the same mean FLIP.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EqualFlip {
    /// The path tracer's paths per pixel at this configuration's mean FLIP, interpolated on the
    /// ladder ([`spp_at_equal_flip`]); clamped to its ends outside it (see `position`).
    pub pathtrace_spp: f64,
    pub position: LadderPosition,
    /// The path tracer's GPU ms for `pathtrace_spp` paths per pixel over this configuration's GPU
    /// ms per frame, at the evaluation's size: how many of its frames the path tracer's image of
    /// the same error costs.
    pub gpu_time_ratio: Option<f64>,
    /// The same at [`EvalOptions::timing_size`], both timed there.
    pub gpu_time_ratio_at_timing_size: Option<f64>,
    /// This configuration's GPU ms per frame at [`EvalOptions::timing_size`].
    pub gpu_ms_per_frame_at_timing_size: Option<f64>,
}

/// The path tracer's paths per pixel at `flip`, on `ladder` (paths per pixel and mean FLIP of each
/// rung), and whether `flip` was within it. FLIP falls as paths are added (as about spp^-½: a line
/// in log-log), so the interpolation is linear between neighbouring rungs in ln spp against ln FLIP,
/// exact at the rungs. A rung noisier than the one before it is taken at the one before's FLIP, so
/// that the result never falls as `flip` does. Outside the ladder: its end, and
/// [`LadderPosition::Below`] or [`LadderPosition::Above`]. `None` for an empty ladder or a FLIP
/// that is not finite.
pub fn spp_at_equal_flip(ladder: &[(f64, f64)], flip: f64) -> Option<(f64, LadderPosition)> {
    if !flip.is_finite() || ladder.iter().any(|&(spp, f)| !(spp > 0.0 && f.is_finite())) {
        return None;
    }
    let mut rungs = ladder.to_vec();
    rungs.sort_by(|a, b| a.0.total_cmp(&b.0));
    for i in 1..rungs.len() {
        rungs[i].1 = rungs[i].1.min(rungs[i - 1].1);
    }
    let (&(first_spp, first), &(last_spp, last)) = (rungs.first()?, rungs.last()?);
    if flip > first {
        return Some((first_spp, LadderPosition::Below));
    }
    if flip < last {
        return Some((last_spp, LadderPosition::Above));
    }
    // The first rung at or under `flip`: the fewest paths that reach it.
    let i = rungs.iter().position(|&(_, f)| f <= flip)?;
    let (spp, f) = rungs[i];
    if f == flip || i == 0 {
        return Some((spp, LadderPosition::Within));
    }
    let (spp0, f0) = rungs[i - 1];
    let ln = |v: f64| v.max(f64::MIN_POSITIVE).ln();
    let t = (ln(flip) - ln(f0)) / (ln(f) - ln(f0));
    Some(((ln(spp0) + t * (ln(spp) - ln(spp0))).exp().clamp(spp0, spp), LadderPosition::Within))
}

/// `config` on `scene`, `frames` frames (usually [`Config::frames`]), the last one returned.
fn render(
    gpu: &GpuContext,
    scene: &SceneDescription,
    config: &Config,
    width: u32,
    height: u32,
    seed: u32,
    frames: u32,
) -> Result<RenderedFrame, String> {
    let settings = HeadlessSettings { width, height, frames, ..Default::default() };
    let bar = crate::progress::bar(u64::from(settings.frames), config.name(), "frames");
    let frame = render_scene_with(gpu, scene.clone(), &settings, |app| {
        config.configure(app, seed);
        crate::progress::tick_every_frame(app, &bar);
    });
    bar.finish_and_clear();
    frame.map_err(|e| e.to_string())
}

/// GPU milliseconds of one frame: the sum over the passes that ran; `None` without timestamps.
fn frame_gpu_ms(frame: &FrameTiming) -> Option<f64> {
    frame.passes.iter().filter(|p| p.ran).map(|p| p.gpu_ms).sum()
}

/// DDGI's mean rays per frame over `frame`'s timings ([`ddgi::rays_traced`]: every volume's), or
/// `None` when no frame has a count.
fn rays_per_frame(frame: &RenderedFrame) -> Option<f64> {
    let per_frame: Vec<f64> = frame.timings.iter().filter_map(ddgi::rays_traced).collect();
    (!per_frame.is_empty()).then(|| per_frame.iter().sum::<f64>() / per_frame.len() as f64)
}

fn gpu_ms(frame: &RenderedFrame) -> (Option<f64>, Option<f64>) {
    let per_frame: Vec<f64> = frame.timings.iter().filter_map(frame_gpu_ms).collect();
    if per_frame.is_empty() {
        return (None, None);
    }
    let total: f64 = per_frame.iter().sum();
    (Some(total / per_frame.len() as f64), Some(total))
}

/// What the evaluation renders of `scene`: with a camera (the default one if it has none), and
/// animations stopped where they start, so that every configuration and the reference see the
/// same still scene.
pub fn still(mut scene: SceneDescription) -> SceneDescription {
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    for node in &mut scene.nodes {
        node.orbit = None;
    }
    scene
}

/// FNV-1a, 64 bits: a hash that stays the same across builds and Rust versions (a disk cache key).
fn fnv1a(words: impl IntoIterator<Item = u32>) -> u64 {
    words.into_iter().flat_map(u32::to_le_bytes).fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The cache file of a reference: by `label` (the scene's name), size, paths per pixel and a hash
/// of the view and the scene's layout — every camera's world transform and field of view, every
/// node's world transform, a directional light's colour and irradiance, and the scene's sky when it
/// has one — so that another camera, a moved or brighter sun, a moved object or another sky gets
/// another reference.
pub fn reference_path(cache: &Path, label: &str, scene: &SceneDescription, width: u32, height: u32, spp: u32) -> PathBuf {
    let mut words = Vec::new();
    for (node, world) in scene.nodes.iter().zip(scene.world_transforms()) {
        words.extend(world.to_cols_array().map(f32::to_bits));
        for content in &node.content {
            match content {
                NodeContent::Camera(camera) => words.push(camera.yfov.to_bits()),
                // Added to the key only where it differs from the white light of irradiance 1 that
                // the built-in scenes' keys were made without.
                NodeContent::DirectionalLight(light) if (light.color, light.intensity) != (Vec3::ONE, 1.0) => {
                    words.extend(light.color.to_array().map(f32::to_bits));
                    words.push(light.intensity.to_bits());
                }
                _ => {}
            }
        }
    }
    if let Some(sky) = &scene.sky {
        words.extend(format!("{sky:?}").bytes().map(u32::from));
    }
    let label = label.replace(['/', '\\', '.'], "_");
    cache.join(format!("{label}-{width}x{height}-{spp}spp-{:016x}.exr", fnv1a(words)))
}

/// The reference image (linear RGBA) of `scene` as given (see [`still`]), rendered once and
/// cached as EXR ([`reference_path`]): the path tracer at `spp` paths per pixel.
pub fn reference(
    gpu: &GpuContext,
    label: &str,
    scene: &SceneDescription,
    width: u32,
    height: u32,
    spp: u32,
    cache: &Path,
) -> Result<Vec<f32>, String> {
    let key = reference_path(cache, label, scene, width, height, spp);
    let (image, cached) = cached_image(&key, width, height, || {
        println!("reference: path tracing {spp} paths per pixel…");
        let config = Config::PathTrace { spp };
        Ok(render(gpu, scene, &config, width, height, REFERENCE_SEED, config.frames())?.hdr)
    })?;
    if cached {
        println!("reference: cached {}", key.display());
    }
    Ok(image)
}

/// The linear RGBA image cached at `key` (an EXR of `width` × `height`) and `true`, or `render`'s,
/// which is then cached there, and `false`.
pub(crate) fn cached_image(
    key: &Path,
    width: u32,
    height: u32,
    render: impl FnOnce() -> Result<Vec<f32>, String>,
) -> Result<(Vec<f32>, bool), String> {
    if let Ok(img) = image::open(key) {
        let rgb = img.to_rgb32f();
        if (rgb.width(), rgb.height()) == (width, height) {
            return Ok((rgb.pixels().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect(), true));
        }
    }
    let hdr = render()?;
    if let Some(dir) = key.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    save_exr(key, &hdr, width, height)?;
    Ok((hdr, false))
}

/// Writes the linear RGBA image `rgba` (`width` × `height`) to `path` as an RGB EXR.
pub fn save_exr(path: &Path, rgba: &[f32], width: u32, height: u32) -> Result<(), String> {
    let rgb: Vec<f32> = rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    image::Rgb32FImage::from_raw(width, height, rgb)
        .ok_or_else(|| format!("{}: the pixel count does not match {width}×{height}", path.display()))?
        .save(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes `panels` (sRGB8 RGB images of `width` × `height`) side by side, left to right, to `path`
/// as one PNG.
pub fn save_strip(path: &Path, panels: &[Vec<u8>], width: u32, height: u32) -> Result<(), String> {
    let mut strip = image::RgbImage::new(width * panels.len() as u32, height);
    for (k, panel) in panels.iter().enumerate() {
        for y in 0..height {
            for x in 0..width {
                let i = ((y * width + x) * 3) as usize;
                strip.put_pixel(k as u32 * width + x, y, image::Rgb([panel[i], panel[i + 1], panel[i + 2]]));
            }
        }
    }
    strip.save(path).map_err(|e| format!("{}: {e}", path.display()))
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// What to evaluate and where to write it.
pub struct EvalOptions {
    pub width: u32,
    pub height: u32,
    /// Paths per pixel of the reference.
    pub reference_spp: u32,
    /// Folder of the report.
    pub out: PathBuf,
    /// Folder of cached references.
    pub cache: PathBuf,
    /// Also DDGI's quality table (probe densities × map resolutions) and weight ablation.
    pub experiments: bool,
    /// The parameters of the adaptive-budget configuration (switched on whatever `enabled` says).
    pub adaptive: ddgi::DdgiAdaptive,
    /// The probe grid of the fixed- and adaptive-budget configurations (default: the published grid).
    pub grid: Option<[u32; 3]>,
    /// Time series: frames DDGI runs before the change (it must have settled: the static phase is
    /// measured at their end).
    pub settle_frames: u32,
    /// Also DDGI with these camera-following cascades (`--cascades N`).
    pub cascades: Option<ddgi::DdgiCascades>,
    /// Width and height at which the still evaluation also times the path tracer
    /// ([`TIMING_SPP`]) and each DDGI configuration, for their GPU-time ratio at equal FLIP at a
    /// display's size ([`DISPLAY_SIZE`] in `game_demo eval`); `None`: only at `width × height`.
    pub timing_size: Option<[u32; 2]>,
    /// Hit occlusion rays of every DDGI configuration's probe rays
    /// ([`ddgi::DdgiVolume::hit_occlusion_rays`]; 0: off, the default).
    pub hit_occlusion_rays: u32,
    /// Their reach, a share of the smallest probe spacing
    /// ([`ddgi::DdgiVolume::hit_occlusion_reach`]; the volume's default, 0.5, unless set).
    pub hit_occlusion_reach: f32,
}

impl Config {
    /// This configuration for the scene placed at `origin` ([`SceneDescription::origin`]): a DDGI
    /// volume's bounds (world coordinates, from [`SceneFacts::gi_bounds`] at the origin) move with
    /// the scene.
    pub fn placed_at(self, origin: glam::DVec3) -> Config {
        match self {
            Config::Ddgi { name, volume, occlusion, taa } if origin != glam::DVec3::ZERO => {
                let shift = |p: glam::DVec3| p + origin;
                let bounds = volume.bounds.map(|(lo, hi)| (shift(lo), shift(hi)));
                Config::Ddgi { name, volume: Box::new(ddgi::DdgiVolume { bounds, ..*volume }), occlusion, taa }
            }
            other => other,
        }
    }

    /// This configuration with `rays` hit occlusion rays of `reach`
    /// ([`ddgi::DdgiVolume::hit_occlusion_rays`], [`ddgi::DdgiVolume::hit_occlusion_reach`]) if it
    /// is a DDGI volume.
    pub fn with_hit_occlusion(self, rays: u32, reach: f32) -> Config {
        match self {
            Config::Ddgi { name, volume, occlusion, taa } => Config::Ddgi {
                name,
                volume: Box::new(ddgi::DdgiVolume { hit_occlusion_rays: rays, hit_occlusion_reach: reach, ..*volume }),
                occlusion,
                taa,
            },
            other => other,
        }
    }

    /// The configurations of `list` for `scene` (placed where it is), with `cascades` added. A DDGI
    /// volume without a grid of its own is the scene-fitted default, and follows its rule
    /// ([`ddgi::DdgiLighting::fitted`], over the volume's bounds or the scene's): over a large
    /// scene it becomes cascades, under the same name.
    pub fn for_scene(list: Vec<Config>, scene: &SceneDescription, cascades: Option<&ddgi::DdgiCascades>) -> Vec<Config> {
        let scene_box = scene.bounds().map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3()));
        list.into_iter()
            .map(|c| match (c, scene_box) {
                (Config::Ddgi { name, volume, occlusion, taa }, Some(b)) if volume.probe_counts.is_none() => {
                    match ddgi::DdgiLighting::Fitted((*volume).clone()).resolve(b) {
                        ddgi::DdgiLighting::Cascades(c) => Config::DdgiCascades { name, cascades: Box::new(c) },
                        _ => Config::Ddgi { name, volume, occlusion, taa },
                    }
                }
                (c, _) => c,
            })
            .chain(cascades.map(Config::ddgi_cascades))
            .map(|c| c.placed_at(scene.origin))
            .collect()
    }

    /// The cascaded configuration of `cascades`, named by its count and grid.
    pub fn ddgi_cascades(cascades: &ddgi::DdgiCascades) -> Config {
        let (n, c) = (cascades.count.unwrap_or(0), cascades.probe_counts);
        let name = format!("ddgi_cascades_{n}x{}x{}x{}", c.x, c.y, c.z);
        Config::DdgiCascades { name, cascades: Box::new(cascades.clone()) }
    }
}

/// Runs the evaluation of `scene` (described by `facts`) and writes the report.
pub fn run(gpu: &GpuContext, facts: &SceneFacts, scene: SceneDescription, options: &EvalOptions) -> Result<Vec<EvalRow>, String> {
    let name = facts.name.as_str();
    let EvalOptions { width, height, reference_spp, ref out, ref cache, experiments, ref adaptive, grid, .. } = *options;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let scene = still(scene);
    let reference = reference(gpu, name, &scene, width, height, reference_spp, cache)?;
    let reference_ldr = tonemap_to_srgb8(&reference, EXPOSURE);
    let mut rows = Vec::new();
    let mut direct_ldr: Option<Vec<u8>> = None;
    let list: Vec<Config> = Config::for_scene(Config::still_list(facts, experiments, grid, adaptive), &scene, options.cascades.as_ref())
        .into_iter()
        .map(|c| c.with_hit_occlusion(options.hit_occlusion_rays, options.hit_occlusion_reach))
        .collect();
    let seed = pathtrace::PathTraceSettings::default().seed;
    // The path tracer's GPU ms per path per pixel at the timing size, timed once the first DDGI
    // configuration needs it.
    let mut timing_ms_per_spp: Option<Option<f64>> = None;
    for config in list {
        let frame = render(gpu, &scene, &config, width, height, seed, config.frames())?;
        let error = compare(&reference, &frame.hdr, width, height, EXPOSURE);
        let (per_frame, total) = gpu_ms(&frame);
        let ldr = tonemap_to_srgb8(&frame.hdr, EXPOSURE);
        let direct = direct_ldr.get_or_insert_with(|| ldr.clone()).clone();
        let (_, map) = flip_rgb8(&reference_ldr, &ldr, width, height);
        save_strip(&out.join(format!("{}.png", config.name())), &[direct, ldr, reference_ldr.clone(), magma(&map)], width, height)?;
        let equal_flip = if config.method() == "DDGI" {
            let timed = match (options.timing_size, timing_ms_per_spp) {
                (Some(size), None) => *timing_ms_per_spp.insert(time_path_tracer(gpu, &scene, size, seed)?),
                (_, known) => known.flatten(),
            };
            let large = match options.timing_size {
                Some([w, h]) => gpu_ms(&render(gpu, &scene, &config, w, h, seed, config.frames())?).0,
                None => None,
            };
            equal_flip(&rows, f64::from(error.mean_flip), per_frame, timed, large)
        } else {
            None
        };
        let equal = equal_flip.map_or(String::new(), |e| {
            let ratio = |r: Option<f64>| r.map_or("n/a".to_string(), |r| format!("{r:.3}×"));
            format!(
                ", path tracer at equal FLIP {}, GPU-time ratio {} ({width}×{height}), {} ({})",
                spp_text(&e),
                ratio(e.gpu_time_ratio),
                ratio(e.gpu_time_ratio_at_timing_size),
                options.timing_size.map_or("untimed".into(), |[w, h]| format!("{w}×{h}"))
            )
        });
        println!(
            "{:>18}: FLIP {:.4}, RMSE {:.4}, relative MSE {:.4}{equal}",
            config.name(),
            error.mean_flip,
            error.rmse,
            error.relative_mse
        );
        rows.push(EvalRow {
            config: config.name(),
            method: config.method().into(),
            frames: frame.timings.len() as u32,
            gpu_ms_per_frame: per_frame,
            gpu_ms_total: total,
            rays_per_frame: rays_per_frame(&frame),
            error,
            equal_flip,
        });
    }
    let plot_note = plot_error_vs_time(&out.join("error_vs_time.png"), &rows)?;
    write_report(out, name, &gpu.adapter_name(), options, &rows, &plot_note)?;
    Ok(rows)
}

/// The path tracer's GPU ms per path per pixel at `[width, height]`: [`TIMING_SPP`] paths per
/// pixel timed there, over [`TIMING_SPP`] (every path costs the same).
fn time_path_tracer(gpu: &GpuContext, scene: &SceneDescription, [width, height]: [u32; 2], seed: u32) -> Result<Option<f64>, String> {
    let config = Config::PathTrace { spp: TIMING_SPP };
    let frame = render(gpu, scene, &config, width, height, seed, config.frames())?;
    Ok(gpu_ms(&frame).1.map(|total| total / f64::from(TIMING_SPP)))
}

/// The path tracer's GPU ms per path per pixel on the ladder of `rows`: its rung of the most paths
/// (the first frame's fixed costs spread the thinnest), its GPU ms in total over its paths.
fn ladder_ms_per_spp(rows: &[EvalRow]) -> Option<f64> {
    PATH_TRACE_LADDER.iter().rev().find_map(|&spp| {
        let name = Config::PathTrace { spp }.name();
        rows.iter().find(|r| r.config == name).and_then(|r| r.gpu_ms_total).map(|ms| ms / f64::from(spp))
    })
}

/// A DDGI configuration of mean FLIP `flip` and `ms_per_frame` (`large_ms_per_frame` at the timing
/// size) against the path tracer's ladder in `rows` (`timing_ms_per_spp`: its GPU ms per path per
/// pixel at the timing size). `None` without a ladder.
fn equal_flip(
    rows: &[EvalRow],
    flip: f64,
    ms_per_frame: Option<f64>,
    timing_ms_per_spp: Option<f64>,
    large_ms_per_frame: Option<f64>,
) -> Option<EqualFlip> {
    let ladder: Vec<(f64, f64)> = PATH_TRACE_LADDER
        .iter()
        .filter_map(|&spp| {
            let name = Config::PathTrace { spp }.name();
            rows.iter().find(|r| r.config == name).map(|r| (f64::from(spp), f64::from(r.error.mean_flip)))
        })
        .collect();
    let (pathtrace_spp, position) = spp_at_equal_flip(&ladder, flip)?;
    let ratio = |ms_per_spp: Option<f64>, ms_per_frame: Option<f64>| {
        let (per_spp, per_frame) = (ms_per_spp?, ms_per_frame?);
        (per_frame > 0.0).then(|| pathtrace_spp * per_spp / per_frame)
    };
    Some(EqualFlip {
        pathtrace_spp,
        position,
        gpu_time_ratio: ratio(ladder_ms_per_spp(rows), ms_per_frame),
        gpu_time_ratio_at_timing_size: ratio(timing_ms_per_spp, large_ms_per_frame),
        gpu_ms_per_frame_at_timing_size: large_ms_per_frame,
    })
}

/// The path tracer's paths per pixel at equal FLIP as the report shows it: "≤ 1" and "≥ 64"
/// outside the ladder.
fn spp_text(e: &EqualFlip) -> String {
    match e.position {
        LadderPosition::Within => format!("{:.1} spp", e.pathtrace_spp),
        LadderPosition::Below => format!("≤ {} spp", e.pathtrace_spp),
        LadderPosition::Above => format!("≥ {} spp", e.pathtrace_spp),
    }
}

/// One series per method through its configurations: mean FLIP against GPU ms per frame and in
/// total. Returns a note for the report on what the plot leaves out or clamps.
fn plot_error_vs_time(path: &Path, rows: &[EvalRow]) -> Result<String, String> {
    let mut methods: Vec<&str> = Vec::new();
    for row in rows {
        if !methods.contains(&row.method.as_str()) {
            methods.push(&row.method);
        }
    }
    let series = |ms: fn(&EvalRow) -> Option<f64>| -> Vec<plot::Series> {
        methods
            .iter()
            .map(|&method| {
                let mut points: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.method == method)
                    .filter_map(|r| Some((plot::floor_for_log(ms(r)?), plot::floor_for_log(f64::from(r.error.mean_flip)))))
                    .collect();
                // A method's configurations in order of cost, so that its line reads left to right.
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
                plot::Series { name: method.to_string(), points }
            })
            .collect()
    };
    plot::error_vs_time(path, &series(|r| r.gpu_ms_per_frame), &series(|r| r.gpu_ms_total))?;
    let mut notes = Vec::new();
    let untimed: Vec<&str> = rows.iter().filter(|r| r.gpu_ms_total.is_none()).map(|r| r.config.as_str()).collect();
    if !untimed.is_empty() {
        notes.push(format!("left out for want of GPU timestamps: {}", untimed.join(", ")));
    }
    let values = rows.iter().flat_map(|r| [r.gpu_ms_per_frame, r.gpu_ms_total, Some(f64::from(r.error.mean_flip))]).flatten();
    let zeros = plot::floored(values);
    if zeros > 0 {
        notes.push(format!("{zeros} values below {} drawn at {} on the log axes", plot::LOG_FLOOR, plot::LOG_FLOOR));
    }
    Ok(if notes.is_empty() { String::new() } else { format!(" ({})", notes.join("; ")) })
}

fn write_report(out: &Path, name: &str, adapter: &str, options: &EvalOptions, rows: &[EvalRow], plot_note: &str) -> Result<(), String> {
    let EvalOptions { width, height, reference_spp, timing_size, .. } = *options;
    let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
    // A scene made by others names its authors wherever it is shown.
    let credit = scenes::files::find(name).map_or(String::new(), |file| format!("The scene: {}.\n\n", file.credit));
    let mut md = format!(
        "# Evaluation: {name}\n\n{credit}{width}×{height} on {adapter}; reference: the path tracer at {reference_spp} paths per pixel (another seed).\n\
         FLIP on sRGB tonemapped at exposure 1; RMSE and relative MSE on linear radiance.\n\
         Each strip `<configuration>.png`: direct only | the configuration | the reference | FLIP map (magma).\n\n\
         | configuration | frames | GPU ms per frame | GPU ms total | DDGI rays per frame | mean FLIP | RMSE | relative MSE | path tracer at equal FLIP | GPU-time ratio | GPU-time ratio at {timing} |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        timing = timing_size.map_or("the timing size (not timed)".into(), |[w, h]| format!("{w}×{h}"))
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.5} | {} | {} | {} |\n",
            r.config,
            r.frames,
            ms(r.gpu_ms_per_frame),
            ms(r.gpu_ms_total),
            r.rays_per_frame.map_or("-".to_string(), |v| format!("{v:.0}")),
            r.error.mean_flip,
            r.error.rmse,
            r.error.relative_mse,
            r.equal_flip.map_or("-".into(), |e| spp_text(&e)),
            r.equal_flip.map_or("-".into(), |e| e.gpu_time_ratio.map_or("n/a".into(), |v| format!("{v:.3}"))),
            r.equal_flip.map_or("-".into(), |e| e.gpu_time_ratio_at_timing_size.map_or("n/a".into(), |v| format!("{v:.3}"))),
        );
    }
    let timed = timing_size.map_or(String::new(), |[w, h]| {
        format!(
            " At {w}×{h} both are timed there: the path tracer at {TIMING_SPP} paths per pixel ({} frames), its GPU ms in total \
             over {TIMING_SPP}, and each DDGI configuration over its {DDGI_FRAMES} frames, GPU ms per frame.",
            TIMING_SPP.div_ceil(SAMPLES_PER_FRAME)
        )
    });
    md += &format!(
        "\nPath tracer at equal FLIP (DDGI configurations): the path tracer's paths per pixel at the configuration's mean FLIP, \
         interpolated on its ladder ({ladder} spp) linearly in ln spp against ln FLIP between the two rungs around it (exact at a \
         rung; a rung noisier than the one before it counts at the one before's FLIP); \"≤ {first} spp\" or \"≥ {last} spp\": the FLIP is \
         outside the ladder, and the ratio is computed at that end (then a bound). GPU-time ratio: the path tracer's GPU ms for those \
         paths per pixel over the configuration's GPU ms per frame: how many DDGI frames the path-traced image of the same error \
         costs. The path tracer's cost is linear in paths per pixel: at {width}×{height} the ladder's {last}-spp rung's GPU ms in total \
         over {last}, times the paths per pixel.{timed}\n",
        ladder = PATH_TRACE_LADDER.map(|s| s.to_string()).join(", "),
        first = PATH_TRACE_LADDER[0],
        last = PATH_TRACE_LADDER[PATH_TRACE_LADDER.len() - 1],
    );
    md += &format!(
        "\nMean FLIP against GPU time, one series per method, per frame (left) and in total for the image (right), log scales{plot_note}:\n\n\
         ![error against GPU time](error_vs_time.png)\n"
    );
    write(&out.join("report.md"), &md)?;
    let text = serde_json::to_string_pretty(rows).map_err(|e| e.to_string())?;
    write(&out.join("results.json"), &text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::glam::Vec3;
    use engine::scene::{Camera, NodeContent};

    #[test]
    fn equal_flip_is_exact_at_the_rungs_monotone_between_them_and_marked_outside() {
        // FLIP = 0.4 / √spp: a straight line in log-log, which the interpolation follows exactly.
        let law = |spp: f64| 0.4 / spp.sqrt();
        let ladder: Vec<(f64, f64)> = PATH_TRACE_LADDER.iter().map(|&s| (f64::from(s), law(f64::from(s)))).collect();
        for &(spp, flip) in &ladder {
            assert_eq!(spp_at_equal_flip(&ladder, flip), Some((spp, LadderPosition::Within)), "exact at the rung of {spp} spp");
        }
        for spp in [2.0, 10.0, 40.0] {
            let (found, position) = spp_at_equal_flip(&ladder, law(spp)).expect("within");
            assert!((found - spp).abs() < 1e-9 * spp && position == LadderPosition::Within, "{spp}: {found}");
        }
        // Less error needs more paths, never fewer, across the whole ladder (a noisy rung too).
        let noisy = [(1.0, 0.4), (4.0, 0.2), (16.0, 0.21), (64.0, 0.05)];
        for ladder in [ladder.as_slice(), &noisy] {
            let mut last = 0.0;
            for k in 0..=400 {
                let flip = 0.45 * (0.04f64 / 0.45).powf(f64::from(k) / 400.0);
                let (spp, _) = spp_at_equal_flip(ladder, flip).expect("finite");
                assert!(spp >= last && (1.0..=64.0).contains(&spp), "FLIP {flip}: {spp} spp after {last}");
                last = spp;
            }
        }
        // The noisy 16-spp rung counts at 4 spp's FLIP, 0.2: half way from 0.2 to 0.05 in ln FLIP is
        // half way from 16 to 64 spp in ln spp.
        let (spp, _) = spp_at_equal_flip(&noisy, 0.1).expect("within");
        assert!((spp - 32.0).abs() < 1e-9, "{spp}");
        assert_eq!(spp_at_equal_flip(&ladder, 0.5), Some((1.0, LadderPosition::Below)));
        assert_eq!(spp_at_equal_flip(&ladder, 0.01), Some((64.0, LadderPosition::Above)));
        // The order of the rungs does not matter; nothing to interpolate on is no answer.
        let reversed: Vec<(f64, f64)> = ladder.iter().rev().copied().collect();
        assert_eq!(spp_at_equal_flip(&reversed, law(10.0)), spp_at_equal_flip(&ladder, law(10.0)));
        assert_eq!(spp_at_equal_flip(&[], 0.1), None);
        assert_eq!(spp_at_equal_flip(&ladder, f64::NAN), None);
    }

    #[test]
    fn reference_cache_key_changes_with_the_camera_and_only_with_what_the_reference_sees() {
        let cache = Path::new("cache");
        let scene = (scenes::find("cornell").expect("cornell").build)();
        let key = |s: &SceneDescription| reference_path(cache, "cornell", s, 64, 48, 256);
        assert_eq!(key(&scene), key(&scene.clone()), "same scene and camera, same key");
        let camera = scene.nodes.iter().position(|n| n.content.iter().any(|c| matches!(c, NodeContent::Camera(_)))).expect("camera");

        let mut moved = scene.clone();
        moved.nodes[camera].transform.translation += Vec3::new(0.0, 0.0, 0.01);
        assert_ne!(key(&scene), key(&moved), "a moved camera needs another reference");

        let mut zoomed = scene.clone();
        for c in &mut zoomed.nodes[camera].content {
            if let NodeContent::Camera(Camera { yfov, .. }) = c {
                *yfov *= 0.9;
            }
        }
        assert_ne!(key(&scene), key(&zoomed), "another field of view needs another reference");

        let mut sky = scene.clone();
        sky.sky = Some(engine::render::Sky::Uniform(Vec3::splat(0.5)));
        assert_ne!(key(&scene), key(&sky), "another sky needs another reference");
        let mut sun = scene.clone();
        sun.add_sun(Vec3::NEG_Y, 2.0);
        let mut brighter = scene.clone();
        brighter.add_sun(Vec3::NEG_Y, 3.0);
        assert_ne!(key(&sun), key(&brighter), "a brighter sun needs another reference");
        assert_ne!(key(&scene), reference_path(cache, "cornell", &scene, 64, 48, 512), "spp is in the key");
        assert_ne!(key(&scene), reference_path(cache, "cornell", &scene, 48, 64, 256), "size is in the key");
    }
}

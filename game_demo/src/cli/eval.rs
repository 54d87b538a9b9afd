//! `eval`: error against a path-traced reference and run time.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};
use lab::eval;

use super::{CameraArgs, SceneOverrides, eval_scenes, load, parse_dvec3};

/// `eval`'s examples (its long help).
pub const EXAMPLES: &str = "Examples:
  game_demo eval --scene cornell                                     # report.md, strips, error_vs_time.png
  game_demo eval --scene cathedral --experiments                     # densities and the weight ablation
  game_demo eval --scene door_room --time-series                     # error per frame after the door opens
  game_demo eval --scene door_room_thin --grid-sweep                 # FLIP and leaks at every probe grid
  game_demo eval --scene open_world --time-series --walk --cascades 8 --sky 0.35,0.45,0.6
  game_demo eval --scene cornell --offset 1e5,1e5,1e5                # large-world coordinates";

#[derive(clap::Args)]
pub struct EvalArgs {
    /// A built-in scene name, `level` (the demo level) or a scene file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Image width in pixels (every configuration and the reference).
    #[arg(long, default_value_t = 256)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Paths per pixel of the reference (cached on disk by scene, camera, size and this number).
    #[arg(long, default_value_t = 4096, value_parser = clap::value_parser!(u32).range(1..))]
    reference_spp: u32,
    /// Measure every frame after a change in the scene instead (cornell: the lamp moves;
    /// color_bleed: the spot light jumps along its orbit; door_room: the door opens; other
    /// scenes: the first light moves).
    #[arg(long)]
    time_series: bool,
    /// Frames after the change (with --time-series). The default lets DDGI at hysteresis 0.97
    /// settle (0.97^240 ≈ 0.07% of the change left), so that "settled" means settled.
    #[arg(long, default_value_t = 240, requires = "time_series", value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Frames DDGI runs before the change (with --time-series); its static phase is measured
    /// at their end.
    #[arg(long, default_value_t = 240, requires = "time_series", value_parser = clap::value_parser!(u32).range(1..))]
    settle_frames: u32,
    /// Probes along x, y and z of the fixed- and adaptive-budget DDGI configurations (default: the
    /// published grid of the scene).
    #[arg(long, value_parser = lab::parse_uvec3)]
    probes: Option<glam::UVec3>,
    /// Adaptive configuration: the longest rest of a quiet probe in frames (DdgiAdaptive::max_rest_frames).
    #[arg(long)]
    rest_frames: Option<u32>,
    /// Adaptive configuration: the share of the error target under which a probe rests
    /// (DdgiAdaptive::rest_error).
    #[arg(long)]
    rest_error: Option<f32>,
    /// Adaptive configuration: how a probe's hysteresis follows its share of the rays
    /// (DdgiAdaptive::hysteresis_exponent).
    #[arg(long)]
    hysteresis_exponent: Option<f32>,
    /// Adaptive configuration: the share of the brightest probe's luma under which a probe
    /// and its neighbours are dark and switched off (DdgiAdaptive::dark_fraction).
    #[arg(long)]
    dark_fraction: Option<f32>,
    /// Adaptive configuration: the weight of the old value in the slow average that decides
    /// resting (DdgiAdaptive::rest_smoothing), or `off` (the error itself decides).
    #[arg(long, value_parser = parse_rest_smoothing)]
    rest_smoothing: Option<RestSmoothing>,
    /// Adaptive configuration: the longest volume update period of calm phases, in frames
    /// (DdgiAdaptive::max_update_period; 1: the volume updates every frame).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=64))]
    max_update_period: Option<u32>,
    /// Adaptive configuration: the share of the error target under which a volume counts as
    /// calm (DdgiAdaptive::calm_error).
    #[arg(long)]
    calm_error: Option<f32>,
    /// Adaptive configuration: how much faster a drifting probe blends, ≥ 1
    /// (DdgiAdaptive::drift_rate; 1: off).
    #[arg(long)]
    drift_rate: Option<f32>,
    /// Hit occlusion rays of every DDGI configuration's probe rays (DdgiVolume::hit_occlusion_rays;
    /// 0: off).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=64))]
    hit_occlusion: u32,
    /// Reach of those rays, a share of the smallest probe spacing
    /// (DdgiVolume::hit_occlusion_reach).
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hit_occlusion_reach)]
    hit_occlusion_reach: f32,
    /// Also DDGI's experiments: quality for probe densities 8×4×8, 16×8×16, 32×16×32 × irradiance
    /// maps of 4, 8, 16 texels, and the ablation of the visibility weights (none → back-face →
    /// Chebyshev → normal bias → contact occlusion).
    #[arg(long, conflicts_with = "time_series")]
    experiments: bool,
    /// Instead: DDGI at its defaults at every probe grid from 4×2×4 to 32×16×32 (and the grid
    /// it fits itself), each against the reference: mean FLIP and the dark-region ratio (the
    /// image's dark part against the reference's: a leak through a wall raises it), in
    /// grid_sweep.md with a plot.
    #[arg(long, conflicts_with_all = ["time_series", "experiments"])]
    grid_sweep: bool,
    /// With --grid-sweep: the settings of the first volume of a settings file as the overlay
    /// saves them (`{"volumes": [{…DdgiVolume fields…}]}`, missing fields at their defaults)
    /// instead of the defaults; the grid still comes from the sweep.
    #[arg(long, requires = "grid_sweep")]
    volume_settings: Option<PathBuf>,
    /// Output folder (default: out/eval/<scene>, or out/eval/<scene>/time_series).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Folder of cached references.
    #[arg(long, default_value = "out/eval/cache")]
    cache: PathBuf,
    /// Place the scene this far from the world's origin, `x,y,z` (double precision; e.g.
    /// 1e5,0,0): large-world coordinates keep every method's error as at the origin.
    #[arg(long, value_parser = parse_dvec3)]
    offset: Option<glam::DVec3>,
    /// Also DDGI with N camera-following cascades (0: none) of --cascade-probes probes each,
    /// at the fixed configuration's rays per probe.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=8))]
    cascades: u32,
    /// Probes of each cascade.
    #[arg(long, value_parser = lab::parse_uvec3, default_value = "16,8,16")]
    cascade_probes: glam::UVec3,
    /// Probe spacing of the finest cascade (default: the coarsest as wide as the scene).
    #[arg(long)]
    cascade_spacing: Option<f32>,
    /// Width of the cascades' blend bands, in cells (DdgiCascades::blend_cells).
    #[arg(long, default_value_t = ddgi::DdgiCascades::default().blend_cells)]
    cascade_blend: f32,
    /// Longest update period of a cascade in frames (DdgiCascades::max_update_period; 1: every
    /// cascade updates every frame, as many rays per frame as one volume of all their probes).
    #[arg(long, default_value_t = ddgi::DdgiCascades::default().max_update_period, value_parser = clap::value_parser!(u32).range(1..))]
    cascade_period: u32,
    /// Rays per frame shared by the cascades that update in a frame, in proportion to what their
    /// probes ask for (DdgiCascades::frame_budget; default: no shared budget).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frame_budget: Option<u32>,
    /// With --time-series: walk the camera through the scene instead of changing it (the
    /// built-in scene's tour, e.g. open_world's out of the house and into the forest; otherwise
    /// the scene's camera carried sideways), measuring every frame's error and flicker against
    /// a path-traced reference of its view, with the frames where a cascade scrolled marked.
    #[arg(long, requires = "time_series")]
    walk: bool,
    /// Where on the tour the walk starts (scene units along it).
    #[arg(long, default_value_t = 0.0, requires = "walk")]
    walk_from: f32,
    /// Walking speed (scene units per second, 60 frames a second).
    #[arg(long, default_value_t = 1.5, requires = "walk")]
    walk_speed: f32,
    /// Leave out the timing at 1920×1080 (the path tracer and each DDGI configuration, for
    /// their GPU-time ratio at equal FLIP at a display's size): slow on a CPU adapter.
    #[arg(long, conflicts_with = "time_series")]
    no_display_timing: bool,
    #[command(flatten)]
    camera: CameraArgs,
}

/// `--rest-smoothing`: a weight, or `off`.
#[derive(Clone, Copy, Debug)]
pub struct RestSmoothing(pub Option<f32>);

pub fn parse_rest_smoothing(text: &str) -> Result<RestSmoothing, String> {
    if text.trim().eq_ignore_ascii_case("off") {
        return Ok(RestSmoothing(None));
    }
    // The range is checked with the rest of the settings (DdgiVolume::validate).
    text.trim()
        .parse::<f32>()
        .map(|s| RestSmoothing(Some(s)))
        .map_err(|e| format!("expected a weight in [0, 1) or 'off', got '{text}': {e}"))
}

pub fn run(args: EvalArgs) -> Result<(), String> {
    let scene = args.scene.as_str();
    let mut description = load(scene)?;
    description.origin = args.offset.unwrap_or_default();
    args.camera.apply(&mut description)?;
    let extent = description.bounds().map_or(1.0, |(lo, hi)| (hi - lo).x.max((hi - lo).z));
    let cascades = cascades(&args, extent);
    if let Some(c) = &cascades {
        c.validate().map_err(|e| e.to_string())?;
    }
    let adaptive = adaptive(&args);
    // Bad adaptive settings are named here, before any GPU work (the plugin would
    // otherwise leave the volume off and the evaluation measure nothing).
    ddgi::DdgiVolume { adaptive: adaptive.clone(), ..Default::default() }.validate().map_err(|e| e.to_string())?;
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    let default_out = PathBuf::from("out/eval").join(scene.replace(['/', '\\', '.'], "_"));
    let (width, height) = (args.width, args.height);
    let out = args.out.clone().unwrap_or_else(|| if args.time_series { default_out.join("time_series") } else { default_out });
    let options = eval::EvalOptions {
        width,
        height,
        reference_spp: args.reference_spp,
        out,
        cache: args.cache.clone(),
        experiments: args.experiments,
        adaptive,
        settle_frames: args.settle_frames,
        grid: args.probes.map(|g| g.to_array()),
        cascades,
        timing_size: (!args.no_display_timing && [width, height] != eval::DISPLAY_SIZE).then_some(eval::DISPLAY_SIZE),
        hit_occlusion_rays: args.hit_occlusion,
        hit_occlusion_reach: args.hit_occlusion_reach,
    };
    if args.walk {
        let series = eval::walk_series::WalkSeries {
            start: args.walk_from,
            speed: args.walk_speed,
            sky: SceneOverrides::get().sky.unwrap_or_default(),
        };
        eval::walk_series::run(&gpu, &eval_scenes::scene_facts(scene), description, &options, args.frames, series)?;
    } else if args.time_series {
        eval::time_series::run(&gpu, &eval_scenes::scene_facts(scene), description, &options, args.frames)?;
    } else if args.grid_sweep {
        let base = match &args.volume_settings {
            Some(path) => ddgi_overlay::settings::load(path)
                .map_err(|e| e.to_string())?
                .volumes
                .into_iter()
                .next()
                .ok_or_else(|| format!("{}: the settings hold no volume (`volumes` is empty)", path.display()))?,
            None => ddgi::DdgiVolume::default(),
        };
        eval::grid_sweep::run(&gpu, &eval_scenes::scene_facts(scene), description, &options, &base)?;
        println!("report: {}", options.out.join("grid_sweep.md").display());
        return Ok(());
    } else {
        eval::run(&gpu, &eval_scenes::scene_facts(scene), description, &options)?;
    }
    println!("report: {}", options.out.join("report.md").display());
    Ok(())
}

/// `--cascades N` (none for 0): N cascades fitted to the scene's largest horizontal `extent`, with
/// the `--cascade-…` settings and `--frame-budget`.
fn cascades(args: &EvalArgs, extent: f32) -> Option<ddgi::DdgiCascades> {
    (args.cascades > 0).then(|| {
        let fitted = ddgi::DdgiCascades::fitted(args.cascades, args.cascade_probes, extent, ddgi::DdgiVolume::default());
        ddgi::DdgiCascades {
            spacing: args.cascade_spacing.unwrap_or(fitted.spacing),
            blend_cells: args.cascade_blend,
            max_update_period: args.cascade_period,
            frame_budget: args.frame_budget,
            ..fitted
        }
    })
}

/// The adaptive configuration: [`ddgi::DdgiAdaptive::on`] with the `--rest-…`, `--calm-error`, … given.
fn adaptive(args: &EvalArgs) -> ddgi::DdgiAdaptive {
    let defaults = ddgi::DdgiAdaptive::on();
    ddgi::DdgiAdaptive {
        max_rest_frames: args.rest_frames.unwrap_or(defaults.max_rest_frames),
        rest_error: args.rest_error.unwrap_or(defaults.rest_error),
        hysteresis_exponent: args.hysteresis_exponent.unwrap_or(defaults.hysteresis_exponent),
        dark_fraction: args.dark_fraction.unwrap_or(defaults.dark_fraction),
        rest_smoothing: args.rest_smoothing.map_or(defaults.rest_smoothing, |RestSmoothing(s)| s),
        max_update_period: args.max_update_period.unwrap_or(defaults.max_update_period),
        calm_error: args.calm_error.unwrap_or(defaults.calm_error),
        drift_rate: args.drift_rate.unwrap_or(defaults.drift_rate),
        ..defaults
    }
}

//! `game_demo`: the project's binary. `render` renders a scene headless to files; `play` walks the
//! demo level (in a window, or headless along a scripted path); `eval` measures error against a
//! path-traced reference and run time; `bench` times the ray tracing and DDGI passes.

use std::path::PathBuf;
use std::process::ExitCode;

mod eval_scenes;
mod play;

use clap::{Parser, Subcommand};
use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::HeadlessSettings;
use engine::scene::{Camera, NodeContent, SceneDescription, Transform};
use lab::{bench, eval};

const RENDER_EXAMPLES: &str = "Examples:
  game_demo render --scene cornell --mode ddgi                       # direct light + DDGI
  game_demo render --scene cornell --mode pathtrace --spp 1024       # the reference
  game_demo render --scene level --mode ddgi --display-transform agx --auto-exposure --width 1920 --height 1080
  game_demo render --scene scene.glb --mode ddgi --probes 16,8,16 --no-adaptive --dump-atlases
  game_demo render --scene open_world --mode ddgi --cascades 8       # camera-following cascades
  game_demo render --scene cornell --offset 1e5,0,0                  # far from the origin
  game_demo render --scene cornell --mode ddgi --frames 10 --trace out/trace.json   # CPU and GPU on one timeline
  game_demo render --list-scenes";

const EVAL_EXAMPLES: &str = "Examples:
  game_demo eval --scene cornell                                     # report.md, strips, error_vs_time.png
  game_demo eval --scene cathedral --experiments                     # densities and the weight ablation
  game_demo eval --scene door_room --time-series                     # error per frame after the door opens
  game_demo eval --scene door_room_thin --grid-sweep                 # FLIP and leaks at every probe grid
  game_demo eval --scene open_world --time-series --walk --cascades 8 --sky 0.35,0.45,0.6
  game_demo eval --scene cornell --offset 1e5,1e5,1e5                # large-world coordinates";

const PLAY_EXAMPLES: &str = "Examples:
  game_demo play                                                     # the demo level in a window
  game_demo play --headless --frames 600 --every 60 --out out/play   # its scripted walk to PNGs
  game_demo play --headless --overlay --frames 120 --every 0         # the same, with the DDGI overlay drawn in
  game_demo play --headless --soak --frames 10000                    # the soak test
  game_demo play --headless --frames 120 --trace out/play/trace.json # a Chrome trace of the walk
  game_demo play --scene open_world                                  # the open world's tour
  game_demo play --scene cornell                                     # any scene in a window";

/// Counts the heap the program holds (the soak test bounds its growth).
#[global_allocator]
static ALLOCATOR: engine::memory::CountingAllocator = engine::memory::CountingAllocator;

#[derive(Parser)]
#[command(version, about = "Dynamic diffuse global illumination demo: headless renders and a windowed viewer")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Write a Chrome trace of the run to FILE (open it in https://ui.perfetto.dev or
    /// chrome://tracing): CPU spans of every frame's schedules and systems, the render graph's
    /// recording and the waits for the GPU, and every render pass's GPU time on a track of its
    /// own, on one timeline. Without it no tracing subscriber is installed.
    #[arg(long, global = true, value_name = "FILE")]
    trace: Option<PathBuf>,
    /// The scene's sun instead of its own directional lights: `x,y,z` the direction its light
    /// travels, then its irradiance in W/m² on a surface facing it (e.g. `--sun=0.4,-1,0.3,3`). A
    /// scene with no lights at all gets a default sun (and Preetham's sky of it) without this.
    #[arg(long, global = true, value_parser = parse_sun, value_name = "X,Y,Z,IRRADIANCE", allow_hyphen_values = true)]
    sun: Option<(glam::Vec3, f32)>,
    /// What rays that leave the scene see, the same in every mode (the background, probe rays,
    /// the path tracer's paths): a uniform radiance `r,g,b` in W/(m²·sr). Default: black, or
    /// Preetham's sky of the default sun for a scene with no lights at all.
    #[arg(long, global = true, value_parser = parse_vec3, value_name = "R,G,B")]
    sky: Option<glam::Vec3>,
    /// Every material opaque: alpha masks and blending ignored, for the camera and every ray. The
    /// same scene without its alpha test, to measure what the masks cost (`bench`) or what they
    /// change in the light (`eval`, `render`).
    #[arg(long, global = true)]
    opaque: bool,
}

/// The command line's `--sun`, `--sky` and `--opaque`, set once in `main` and applied to every
/// scene [`load`] gives (global flags, so every subcommand takes them).
#[derive(Clone, Copy, Debug, Default)]
struct Lighting {
    sun: Option<(glam::Vec3, f32)>,
    sky: Option<glam::Vec3>,
    opaque: bool,
}

static LIGHTING: std::sync::OnceLock<Lighting> = std::sync::OnceLock::new();

impl Lighting {
    fn get() -> Lighting {
        LIGHTING.get().copied().unwrap_or_default()
    }

    /// Makes every material opaque if `--opaque`, puts the `--sun` and `--sky` into `scene`, then lights it with the default daylight if it
    /// has no light at all, saying so on standard error.
    fn apply(&self, scene: &mut SceneDescription, name: &str) {
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

#[derive(Subcommand)]
enum Command {
    /// Render a scene without a window: writes image.png (tonemapped sRGB), image.exr (linear
    /// radiance) and timings.json (GPU milliseconds per pass and frame) into --out.
    #[command(after_long_help = RENDER_EXAMPLES)]
    Render(RenderArgs),
    /// Error against a path-traced reference and GPU time for a list of configurations (direct
    /// light, the path tracer at 1, 4, 16, 64 paths per pixel): report.md, results.json,
    /// error_vs_time.png and strips. With --time-series: the error of every frame after a change
    /// in the scene (time_series.csv, time_series.png, report.md).
    #[command(after_long_help = EVAL_EXAMPLES)]
    Eval {
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
    },
    /// Benchmarks (results as Markdown tables on standard output; with --json FILE, as JSON too).
    #[command(subcommand)]
    Bench(BenchCommand),
    /// The walkable demo level with DDGI. In a window: click to grab the mouse, WASD walk, Shift
    /// run, Space jump, E door, F1 probe overlay, F12 screenshot, Esc release/quit. With
    /// --headless: a scripted walk writing frames and a per-frame timing CSV. With --scene: a
    /// viewer of any scene (no level, no player).
    #[command(after_long_help = PLAY_EXAMPLES)]
    Play(PlayArgs),
}

#[derive(clap::Args)]
struct PlayArgs {
    /// Run the scripted walk without a window.
    #[arg(long)]
    headless: bool,
    /// Frames of the scripted walk (--headless, --script).
    #[arg(long, default_value_t = 600, value_parser = clap::value_parser!(u32).range(1..))]
    frames: u32,
    /// Headless: write a PNG every this many frames (0: only the last).
    #[arg(long, default_value_t = 60)]
    every: u32,
    /// Headless: output folder of the frames and frames.csv.
    #[arg(long, default_value = "out/play")]
    out: PathBuf,
    /// Headless: draw the DDGI overlay into the frames (its windows, the probes shaded by their
    /// irradiance, the volume's bounds), as F1 shows it in the window (at 1.25 pixels per point, the probe spheres at 0.06 of a cell).
    #[arg(long, requires = "headless")]
    overlay: bool,
    /// Windowed: run the scripted walk on the fixed clock for --frames frames, save the last
    /// frame to this PNG and exit (what the Xvfb test compares with --headless).
    #[arg(long)]
    script: Option<PathBuf>,
    /// With --script: on the way, minimize the window, shrink it to two pixels and back, lose
    /// the surface and lose the GPU device; each must be survived (the fault-injection test).
    #[arg(long, requires = "script")]
    inject_faults: bool,
    /// Window (or headless image) width in pixels.
    #[arg(long, default_value_t = play::PlayOptions::default().width, value_parser = clap::value_parser!(u32).range(1..=16384))]
    width: u32,
    /// Window (or headless image) height in pixels.
    #[arg(long, default_value_t = play::PlayOptions::default().height, value_parser = clap::value_parser!(u32).range(1..=16384))]
    height: u32,
    /// Probes along x, y and z of the level's DDGI volume, `X,Y,Z` (default: every 1.5 m over the
    /// level, play::level::level_probe_counts).
    #[arg(long, value_parser = lab::parse_uvec3)]
    probes: Option<glam::UVec3>,
    /// With --cascades: probe spacing of the finest cascade, in metres.
    #[arg(long, default_value_t = play::PROBE_SPACING)]
    cascade_spacing: f32,
    /// Rays per probe per frame.
    #[arg(long, default_value_t = play::PlayOptions::default().rays_per_probe, value_parser = clap::value_parser!(u32).range(1..=1024))]
    rays: u32,
    /// Fixed ray budgets instead of adaptive ones.
    #[arg(long)]
    no_adaptive: bool,
    /// Camera-following cascades instead of one volume over the level (0): N nested volumes of
    /// 16×8×16 probes, the finest at --cascade-spacing, each next twice as coarse.
    #[arg(long, default_value_t = play::PlayOptions::default().cascades, value_parser = clap::value_parser!(u32).range(0..=8))]
    cascades: u32,
    /// Build the level from its own procedural props, without Kenney's models (which it loads from
    /// ../shared/assets/kenney_fps, or $DDGI_SHARED_DIR/assets/kenney_fps, when they are there).
    #[arg(long)]
    no_assets: bool,
    /// Without temporal anti-aliasing: every frame as rendered (aliased edges, no jitter).
    #[arg(long)]
    no_taa: bool,
    /// Headless: a soak test instead of the walk. Every --check-every frames the image and the
    /// probe atlases must be finite; after the warm-up, resident and GPU memory may not grow and
    /// frame times may not rise beyond their bounds. Writes soak.csv into --out; fails (exit 1)
    /// naming each broken bound.
    #[arg(long, requires = "headless")]
    soak: bool,
    /// Soak: check and sample every this many frames.
    #[arg(long, default_value_t = 250, requires = "soak", value_parser = clap::value_parser!(u32).range(1..))]
    check_every: u32,
    /// Soak: frames before the baselines of memory and time are taken (default: a tenth of the
    /// frames, at least one check).
    #[arg(long, requires = "soak")]
    warmup: Option<u32>,
    /// Show this scene in a window instead of the level (a built-in name or a scene file).
    /// `open_world`: its tour, out of the house and into the forest and back, walked by the camera
    /// with --cascades camera-following cascades (default play::tour::TOUR_CASCADES, 8: they reach the
    /// whole world, and take 1.48 ms a frame on an H200 at 1920×1080), in a window or --headless.
    #[arg(long, conflicts_with_all = ["script", "soak"])]
    scene: Option<String>,
}

fn play(args: PlayArgs) -> Result<(), String> {
    if args.scene.as_deref() == Some("open_world") {
        let scene = load("open_world")?;
        let cascades = play::tour::tour_cascades(
            if args.cascades == 0 { play::tour::TOUR_CASCADES } else { args.cascades },
            args.rays,
            !args.no_adaptive,
        );
        cascades.validate().map_err(|e| e.to_string())?;
        if args.headless {
            let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
            let size = engine::render::RenderSize { width: args.width, height: args.height };
            let report = play::tour::run_tour_headless(&gpu, scene, cascades, size, args.frames, args.every, &args.out)?;
            println!(
                "open world tour: {} frames ({:.0} m walked), DDGI median {:.3} ms per frame on {}; frames and walk.csv in {}",
                report.frames.len(),
                report.frames.last().map_or(0.0, |f| f.distance),
                report.median_ddgi_ms(),
                gpu.adapter_name(),
                args.out.display()
            );
            return Ok(());
        }
        return engine::window::run_window(play::tour::TourWindow { scene, cascades }).map_err(|e| e.to_string());
    }
    if args.headless && args.scene.is_some() {
        return Err("--headless with --scene: only the open world (--scene open_world) has a scripted tour".into());
    }
    if let Some(scene) = &args.scene {
        return load(scene).and_then(|s| engine::window::run_windowed(s).map_err(|e| e.to_string()));
    }
    if !(args.cascade_spacing.is_finite() && args.cascade_spacing >= 0.1) {
        return Err(format!("--cascade-spacing {} must be at least 0.1 m", args.cascade_spacing));
    }
    let lighting = Lighting::get();
    if lighting.sun.is_some() || lighting.sky.is_some() {
        return Err(
            "--sun and --sky light the scenes that `play --scene` shows; the demo level's day–night cycle sets its own sun and sky".into(),
        );
    }
    let options = play::PlayOptions {
        width: args.width,
        height: args.height,
        probe_counts: args.probes.unwrap_or(play::PlayOptions::default().probe_counts),
        cascade_spacing: args.cascade_spacing,
        rays_per_probe: args.rays,
        adaptive: !args.no_adaptive,
        use_assets: !args.no_assets,
        cascades: args.cascades,
        taa: !args.no_taa,
    };
    if args.soak {
        let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
        let soak = play::soak::SoakOptions {
            frames: args.frames,
            check_every: args.check_every,
            warmup: args.warmup.unwrap_or((args.frames / 10).max(args.check_every)),
            limits: lab::soak::SoakLimits::for_adapter(&gpu),
            out: args.out,
        };
        let report = play::soak::run_soak(&gpu, &options, &soak)?;
        println!("soak of {} frames on {}: {} checks, in {}", args.frames, gpu.adapter_name(), report.samples.len(), report.csv.display());
        println!("{}", std::fs::read_to_string(&report.csv).unwrap_or_default());
        if report.failures.is_empty() {
            println!("soak passed: no NaN or Inf, memory and frame times within bounds ({:?})", soak.limits);
            return Ok(());
        }
        return Err(format!("soak failed:\n  {}", report.failures.join("\n  ")));
    }
    if args.headless {
        let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
        let run = play::headless::HeadlessPlay { frames: args.frames, every: args.every, out: args.out, overlay: args.overlay };
        let report = play::headless::run_headless_play(&gpu, &options, &run)?;
        println!("frames: {} PNGs in {}; per-frame timings: {}", report.images.len(), run.out.display(), report.csv.display());
        if let Some(ms) = report.mean_gpu_ms {
            println!("mean GPU time per frame: {ms:.3} ms ({})", gpu.adapter_name());
        }
        return Ok(());
    }
    let script = args.script.map(|screenshot| play::window::WindowScript { frames: args.frames, screenshot, faults: args.inject_faults });
    play::window::run_window(options, script)
}

#[derive(Subcommand)]
enum BenchCommand {
    /// DDGI's GPU time per frame while the camera walks the open world's tour (out of the house,
    /// 500 m into the forest and back): median, slowest frame and frames over twice the median,
    /// per-cascade times, scrolls and rebases; every frame in --out/walk.csv.
    #[command(
        after_long_help = "Examples:\n  game_demo bench walk --cascades 8 --cascade-probes 16,8,16 --frames 1200 --speed 30\n  game_demo bench walk --cascades 0 --probes 32,8,32   # one scene-wide volume\n  game_demo bench walk --width 256 --height 256 --error-every 100   # and FLIP every 100th frame"
    )]
    Walk {
        /// A built-in scene with a tour (open_world) or any scene (its camera carried sideways).
        #[arg(long, default_value = "open_world")]
        scene: String,
        /// Camera-following cascades (0: one volume over the scene's GI bounds with --probes).
        #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=8))]
        cascades: u32,
        /// Probes of the one volume with --cascades 0, `X,Y,Z`.
        #[arg(long, value_parser = lab::parse_uvec3, default_value = "32,8,32")]
        probes: glam::UVec3,
        /// Probes of each cascade, `X,Y,Z`.
        #[arg(long, value_parser = lab::parse_uvec3, default_value = "16,8,16")]
        cascade_probes: glam::UVec3,
        /// Probe spacing of the finest cascade (metres).
        #[arg(long, default_value_t = 1.5)]
        cascade_spacing: f32,
        /// Width of the cascades' blend bands, in cells (DdgiCascades::blend_cells).
        #[arg(long, default_value_t = ddgi::DdgiCascades::default().blend_cells)]
        cascade_blend: f32,
        /// Longest update period of a cascade in frames (DdgiCascades::max_update_period).
        #[arg(long, default_value_t = ddgi::DdgiCascades::default().max_update_period, value_parser = clap::value_parser!(u32).range(1..))]
        cascade_period: u32,
        /// Rays per frame shared by the cascades that update in a frame, in proportion to what their
        /// probes ask for (DdgiCascades::frame_budget), or, with --cascades 0, the one volume's
        /// (DdgiAdaptive::frame_budget): the same budget compares both at one ray count. Default:
        /// no budget.
        #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
        frame_budget: Option<u32>,
        /// Rays per probe per frame.
        #[arg(long, default_value_t = ddgi::DdgiVolume::default().rays_per_probe)]
        rays: u32,
        /// Fixed ray budgets instead of adaptive ones.
        #[arg(long)]
        no_adaptive: bool,
        /// Frames of the walk (60 per second).
        #[arg(long, default_value_t = 600)]
        frames: u32,
        /// Frames the camera stands at the door first.
        #[arg(long, default_value_t = 60)]
        warmup: u32,
        /// Walking speed, metres per second.
        #[arg(long, default_value_t = 1.5)]
        speed: f32,
        /// Image width in pixels.
        #[arg(long, default_value_t = 1920)]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 1080)]
        height: u32,
        /// Place the scene this far from the world's origin, `x,y,z`.
        #[arg(long, value_parser = parse_dvec3)]
        offset: Option<glam::DVec3>,
        /// Output folder of walk.csv.
        #[arg(long, default_value = "out/walk")]
        out: PathBuf,
        /// Visibility rays of the sky light per pixel no volume covers (DdgiSkyLight::rays; 0: off).
        #[arg(long, default_value_t = ddgi::DdgiSkyLight::default().rays)]
        sky_rays: u32,
        /// Reach of those rays in metres (default: a tenth of the scene's extent).
        #[arg(long)]
        sky_reach: Option<f32>,
        /// Every N frames, the frame's mean FLIP against a path-traced reference of its view
        /// (walk.csv's `flip`), and the mean change of that error from one measured frame to the next.
        #[arg(long)]
        error_every: Option<u32>,
        /// Paths per pixel of those references.
        #[arg(long, default_value_t = 1024)]
        reference_spp: u32,
        /// Also write the results as JSON to this file (the same figures as the Markdown).
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Closest-hit throughput of probe-like rays (grids 16×8×16 … 32×32×32, 32 … 256 rays per probe;
    /// GPU timestamps of the trace pass alone) and the CPU cost of TLAS updates when instances move.
    #[command(
        after_long_help = "Examples:\n  game_demo bench trace --scene cathedral --iterations 15 --no-flat-rebuild\n  game_demo bench trace --scene forest --cpu-only   # the TLAS refit for moving instances only\n  game_demo bench trace --scene forest --iterations 15 --no-flat-rebuild --cpu-only --gpu-refit   # CPU refit against GPU refit (CPU ms)\n  game_demo bench trace --scene forest --rebraid 4   # a re-braided TLAS (up to 4 primitives an instance)\n  game_demo bench trace --scene cathedral --no-flat-rebuild --static-groups off   # each instance entered on its own, no static groups\n  game_demo bench trace --scene cathedral --work-only --no-flat-rebuild --blas-build medium   # BLASes built as before 2026-12-05\n  game_demo bench trace --scene forest --work-only --no-flat-rebuild   # traversal work per ray, no timing\n  game_demo bench trace --scene cathedral --no-flat-rebuild --shared-stack 8   # the stack's top 8 entries in workgroup memory against function memory\n  game_demo bench trace --scene cathedral --no-flat-rebuild --persistent-groups 4224 --workgroup-size 128 --ray-order coherent --subgroup-postpone 0.2,0.35,0.5   # postponed triangle tests at three thresholds against tests at once\n  game_demo bench trace --scene cathedral --work-only --no-flat-rebuild --ray-order coherent --workgroup-size 32 --packet workgroup   # packets of 32 rays walking as one: their work a lane against a ray a lane"
    )]
    Trace {
        /// A built-in scene or a scene file.
        #[arg(long, default_value = "cathedral")]
        scene: String,
        /// Timed dispatches per cell (after 3 warm-up dispatches); the median is reported.
        #[arg(long, default_value_t = 10)]
        iterations: u32,
        /// Skip the flat full-rebuild comparison (slow for very large scenes).
        #[arg(long)]
        no_flat_rebuild: bool,
        /// Skip the GPU throughput table.
        #[arg(long)]
        cpu_only: bool,
        /// TLAS re-braiding budget: the TLAS may have up to this many times as many primitives as
        /// instances, opening static instances' BLAS nodes (0 or 1: off). Default: the engine's
        /// (engine::rt::TLAS_REBRAID_BUDGET).
        #[arg(long)]
        rebraid: Option<f32>,
        /// Static groups (engine::rt::StaticGrouping): `estimated` (the engine's default) traces
        /// static instances that overlap through a shared BLAS where a CPU estimate says rays do
        /// less work that way, `always` wherever they overlap, `off` enters each instance on its own.
        #[arg(long, value_enum, default_value = "estimated")]
        static_groups: StaticGroupsArg,
        /// How thoroughly the BLASes are built (engine::rt::BlasBuildQuality): `fast`, `medium`
        /// (obvhs's presets) or `high` (the engine's default).
        #[arg(long, value_enum, default_value = "high")]
        blas_build: BlasBuildArg,
        /// Which direction each thread of a probe traces: `fibonacci` (thread k, direction k) or
        /// `coherent` (directions sorted so that a warp's rays cover one patch of the sphere).
        #[arg(long, value_enum, default_value = "fibonacci")]
        ray_order: RayOrderArg,
        /// Threads a workgroup of the bench kernel.
        #[arg(long, default_value_t = 64)]
        workgroup_size: u32,
        /// Time the persistent kernel with this many workgroups (each walks its share of the rays; a
        /// thread takes the next ray as soon as its own is done) instead of a thread a ray.
        #[arg(long)]
        persistent_groups: Option<u32>,
        /// Also time the same kernel with the top K entries of each thread's traversal stack in
        /// workgroup memory (older entries moved to function memory), in the same run: both tables,
        /// their ratio, and the stack entries moved per ray.
        #[arg(long, value_name = "K")]
        shared_stack: Option<u32>,
        /// Also time the same kernel with postponed triangle tests (Ylitie, Karras and Laine 2017),
        /// once for each SHARE given (comma separated, each in (0, 1]), in the same run: a thread
        /// tests the triangles a node hit only when at least SHARE of its subgroup's active threads
        /// want to test theirs, and otherwise walks its next nodes first. Needs a GPU with subgroup
        /// operations (wgpu::Features::SUBGROUP).
        #[arg(long, value_name = "SHARE", value_delimiter = ',')]
        subgroup_postpone: Vec<f32>,
        /// With --persistent-groups: also time the kernel (and each --subgroup-postpone variant)
        /// with dynamic fetch, in the same run: the threads of a subgroup whose rays ended in the
        /// same step take their next rays with one atomic add, not one each. Needs a GPU with
        /// subgroup operations.
        #[arg(long, requires = "persistent_groups")]
        subgroup_fetch: bool,
        /// Also time packet traversal, a thread a ray, once for each scope given (comma separated:
        /// `subgroup`, `workgroup`), in the same run: the rays of a subgroup (or of a workgroup)
        /// walk as one, every node any of them hits visited by all. `subgroup` needs a GPU with
        /// subgroup operations; `workgroup` unites the lanes' hits slowly, for counting the walk of
        /// packets of --workgroup-size rays (--work-only).
        #[arg(long, value_enum, value_delimiter = ',', conflicts_with = "persistent_groups")]
        packet: Vec<PacketArg>,
        /// Only the traversal work per ray (no timings): the counts do not depend on the GPU, so
        /// lavapipe gives the same as any other.
        #[arg(long, conflicts_with = "cpu_only")]
        work_only: bool,
        /// Also time the TLAS refit on the GPU (engine::rt::TlasRefit::Gpu) for each count of moving
        /// instances: its CPU ms (median, and the slowest frame, which refits the CPU's copy for the
        /// rebuild test) beside the CPU refit's, and without --cpu-only the refit's GPU ms
        /// (timestamps around its four dispatches, median of --iterations).
        #[arg(long)]
        gpu_refit: bool,
        /// Also write the results as JSON to this file (the same figures as the Markdown).
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Full DDGI update throughput (rays per second of the budget, generation, trace, shading, map
    /// updates, borders, relocation and classification; every probe active) for grids 16×8×16 … 32×32×32
    /// and 32 … 256 rays per probe, the per-pass times, and the final gather at the camera's size.
    #[command(
        after_long_help = "Examples:\n  game_demo bench ddgi --scene cathedral\n  game_demo bench ddgi --scene level --probes 16,8,16 --probes 32,8,32 --rays 128\n  game_demo bench ddgi --scene cornell --probes 8,4,8 --rays 64 --json out/bench_ddgi.json --trace out/bench_ddgi_trace.json\n  game_demo bench ddgi --scene cathedral --probes 32,32,32 --rays 256 --persistent-trace"
    )]
    Ddgi {
        /// A built-in scene or a scene file.
        #[arg(long, default_value = "cathedral")]
        scene: String,
        /// Timed frames per cell (after 3 warm-up frames); medians are reported.
        #[arg(long, default_value_t = 10)]
        iterations: u32,
        /// Camera resolution (the final gather's cost).
        #[arg(long, default_value_t = 1920)]
        width: u32,
        /// Camera height in pixels.
        #[arg(long, default_value_t = 1080)]
        height: u32,
        /// Probe grids `X,Y,Z` to measure instead of the published four (repeatable).
        #[arg(long, value_parser = lab::parse_uvec3)]
        probes: Vec<glam::UVec3>,
        /// Rays per probe to measure instead of 32, 64, 128, 256 (repeatable).
        #[arg(long)]
        rays: Vec<u32>,
        /// Also time every cell with the persistent trace (`DdgiVolume::persistent_trace`: closest
        /// hits by persistent threads, then the pass `ddgi_shade`), right after the thread-a-ray
        /// trace in the same run, and print the ratio of their update times.
        #[arg(long)]
        persistent_trace: bool,
        /// Also write the results as JSON to this file (the same figures as the Markdown).
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// DDGI's classification (adaptive budgets on) against an independent test with GPU rays: how
    /// many probes inside solid geometry are switched off, and how many probes that a visible
    /// surface depends on are.
    #[command(
        after_long_help = "Examples:\n  game_demo bench classify --scene cathedral\n  game_demo bench classify --scene cathedral --probes 32,16,32"
    )]
    Classify {
        /// A built-in scene or a scene file.
        #[arg(long, default_value = "cathedral")]
        scene: String,
        /// Probes along x, y and z (default: the published grid of the scene).
        #[arg(long, value_parser = lab::parse_uvec3)]
        probes: Option<glam::UVec3>,
        /// Frames DDGI runs (classifying its probes) before the check.
        #[arg(long, default_value_t = 60)]
        frames: u32,
        /// Also write the results as JSON to this file (the same figures as the Markdown).
        #[arg(long)]
        json: Option<PathBuf>,
    },
}

/// `render --mode`.
/// `bench trace --ray-order`: see `lab::bench::RayOrder`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, clap::ValueEnum)]
enum RayOrderArg {
    Fibonacci,
    Coherent,
}

/// `bench trace --static-groups`: see `engine::rt::StaticGrouping`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, clap::ValueEnum)]
enum StaticGroupsArg {
    Off,
    Estimated,
    Always,
}

impl From<StaticGroupsArg> for engine::rt::StaticGrouping {
    fn from(arg: StaticGroupsArg) -> Self {
        match arg {
            StaticGroupsArg::Off => Self::Off,
            StaticGroupsArg::Estimated => Self::Estimated,
            StaticGroupsArg::Always => Self::Always,
        }
    }
}

/// `bench trace --blas-build`: see `engine::rt::BlasBuildQuality`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, clap::ValueEnum)]
enum BlasBuildArg {
    Fast,
    Medium,
    High,
}

impl From<BlasBuildArg> for engine::rt::BlasBuildQuality {
    fn from(arg: BlasBuildArg) -> Self {
        match arg {
            BlasBuildArg::Fast => Self::Fast,
            BlasBuildArg::Medium => Self::Medium,
            BlasBuildArg::High => Self::High,
        }
    }
}

/// `bench trace --packet`: see `lab::bench::PacketScope`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, clap::ValueEnum)]
enum PacketArg {
    Subgroup,
    Workgroup,
}

#[derive(Clone, Copy, PartialEq, Eq, Debug, clap::ValueEnum)]
enum ModeArg {
    /// Direct light with hard shadows.
    Direct,
    /// Direct light and DDGI's indirect light.
    Ddgi,
    /// DDGI's indirect light alone.
    Indirect,
    /// The reference path tracer (--spp paths per pixel).
    Pathtrace,
}

/// `render --display-transform`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum DisplayArg {
    /// The radiometric values clipped at 1 (what the golden images and eval use).
    Clamp,
    /// AgX: a filmic roll-off of highlights into white.
    Agx,
}

impl From<DisplayArg> for engine::render::DisplayTransform {
    fn from(d: DisplayArg) -> Self {
        match d {
            DisplayArg::Clamp => Self::Clamp,
            DisplayArg::Agx => Self::AgX,
        }
    }
}

#[derive(clap::Args)]
struct RenderArgs {
    /// A built-in scene name (see --list-scenes; `level` is the demo level) or a .gltf, .glb or .obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Frames to run with a fixed 1/60 s step; the image is the last frame (default: 120 with
    /// `--mode ddgi` and `indirect`, for the probes to converge; 32 for `direct`, for the temporal
    /// anti-aliasing to converge, 1 with --no-taa). With `--mode pathtrace` the frames needed for
    /// `--spp` are added.
    #[arg(long)]
    frames: Option<u32>,
    /// What renders the image.
    #[arg(long, value_enum, default_value = "direct")]
    mode: ModeArg,
    #[command(flatten)]
    ddgi: DdgiArgs,
    /// Paths per pixel for `--mode pathtrace`.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Bounce cap for `--mode pathtrace` (0: unbounded, ended by Russian roulette).
    #[arg(long, default_value_t = 0)]
    max_bounces: u32,
    /// Output folder.
    #[arg(long, default_value = "out/render")]
    out: PathBuf,
    #[command(flatten)]
    camera: CameraArgs,
    /// How image.png shows the radiance: `clamp` (the radiometric values, clipped at 1: what the
    /// golden images and eval use) or `agx` (a filmic roll-off of highlights). image.exr is the
    /// linear radiance either way.
    #[arg(long, value_enum, default_value = "clamp")]
    display_transform: DisplayArg,
    /// The camera's exposure as a photographic exposure value at ISO 100 (one more EV: half the
    /// exposure); default: the scene camera's own exposure.
    #[arg(long, conflicts_with = "auto_exposure")]
    ev100: Option<f32>,
    /// image.png's exposure from the image's own luminance histogram (engine::render::AutoExposure);
    /// image.exr stays linear radiance.
    #[arg(long)]
    auto_exposure: bool,
    /// Without temporal anti-aliasing (every frame as rasterized: aliased edges).
    #[arg(long)]
    no_taa: bool,
    /// Print the built-in scene names and exit.
    #[arg(long)]
    list_scenes: bool,
    /// Place the scene (and its camera) this far from the world's origin, `x,y,z` (double
    /// precision; e.g. 1e5,0,0): large-world coordinates render it as at the origin.
    #[arg(long, value_parser = parse_dvec3)]
    offset: Option<glam::DVec3>,
}

/// A camera that replaces the scene's (`render` and `eval`).
#[derive(clap::Args, Clone, Debug)]
struct CameraArgs {
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
    fn apply(&self, scene: &mut SceneDescription) -> Result<(), String> {
        match (self.camera_position, self.camera_target) {
            (Some(position), Some(target)) => replace_camera(scene, position, target, self.fov),
            _ => Ok(()),
        }
    }
}

/// DDGI volume settings from the command line (the volume fills the scene's bounds).
#[derive(clap::Args, Clone, Debug)]
struct DdgiArgs {
    /// Probes along x, y and z of the volume, `X,Y,Z` (default: fitted to the volume's box,
    /// ddgi::auto_probe_counts: 16 along its longest side, at least 8 along any side an eighth as
    /// long).
    #[arg(long, value_parser = lab::parse_uvec3)]
    probes: Option<glam::UVec3>,
    /// With --cascades: probes of each cascade, `X,Y,Z`.
    #[arg(long, value_parser = lab::parse_uvec3, default_value = "16,8,16")]
    cascade_probes: glam::UVec3,
    /// Rays per probe per frame.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().rays_per_probe)]
    rays: u32,
    /// Side of each probe's irradiance map, in texels.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().irradiance_texels)]
    irradiance_texels: u32,
    /// Side of each probe's distance map, in texels.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().distance_texels)]
    distance_texels: u32,
    /// Weight of the old probe value per frame, in [0, 1].
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hysteresis)]
    hysteresis: f32,
    /// Write the irradiance and distance atlases and the ray directions as images beside the output.
    #[arg(long)]
    dump_atlases: bool,
    /// Contact occlusion of the indirect light: rays per pixel (DdgiContactOcclusion::rays; 0: off),
    /// their reach the finest probe spacing.
    #[arg(long, default_value_t = ddgi::DdgiContactOcclusion::default().rays, value_parser = clap::value_parser!(u32).range(0..=64))]
    contact_occlusion: u32,
    /// Trace the contact occlusion at every pixel instead of at one pixel of each 2×2 block a frame
    /// (DdgiContactOcclusion::half_resolution; four times the rays).
    #[arg(long)]
    contact_occlusion_full_resolution: bool,
    /// The fixed ray budget (every probe --rays rays a frame) instead of the default adaptive one,
    /// where each probe's rays follow its temporal error (between DdgiAdaptive's min_rays and
    /// --rays) and dark probes are switched off. `timings.json` records the rays traced per frame.
    #[arg(long)]
    no_adaptive: bool,
    /// Adaptive budgets: the longest volume update period of calm phases, in frames
    /// (DdgiAdaptive::max_update_period; 1: the volume updates every frame).
    #[arg(long, default_value_t = ddgi::DdgiAdaptive::default().max_update_period, value_parser = clap::value_parser!(u32).range(1..=64))]
    max_update_period: u32,
    /// Near-field occlusion rays at each probe ray's hit (DdgiVolume::hit_occlusion_rays; 0: off).
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hit_occlusion_rays, value_parser = clap::value_parser!(u32).range(0..=64))]
    hit_occlusion: u32,
    /// Reach of those rays, a share of the smallest probe spacing (DdgiVolume::hit_occlusion_reach).
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hit_occlusion_reach)]
    hit_occlusion_reach: f32,
    /// Camera-following cascades instead of one volume over the scene: N nested volumes of
    /// --cascade-probes probes each, centred on the camera, each with twice the spacing of the one
    /// inside it, the coarsest as wide as the scene; 0: one volume. Default (and without
    /// --probes): fitted to the scene (ddgi::DdgiLighting::fitted): one volume, unless its probes
    /// would be more than ddgi::MAX_FITTED_SPACING (4 m) apart, then cascades whose finest
    /// spacing is at most 1 m. --probes X,Y,Z alone means one volume of that grid.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=8))]
    cascades: Option<u32>,
}

impl DdgiArgs {
    /// How to light `scene`: `--cascades N` ([`ddgi::DdgiCascades::fitted`] to its largest
    /// horizontal extent), one volume (`--cascades 0` or `--probes`), else the scene-fitted rule.
    fn lighting(&self, scene: &SceneDescription) -> ddgi::DdgiLighting {
        let bounds = scene.bounds().map(|(lo, hi)| (scene.origin + lo.as_dvec3(), scene.origin + hi.as_dvec3()));
        match self.cascades {
            Some(n) if n > 0 => {
                let extent = bounds.map_or(1.0, |(lo, hi)| (hi - lo).x.max((hi - lo).z) as f32);
                ddgi::DdgiLighting::Cascades(ddgi::DdgiCascades::fitted(n, self.cascade_probes, extent, self.volume()))
            }
            Some(_) => ddgi::DdgiLighting::Volume(self.volume()),
            None => match bounds {
                Some(b) => {
                    let lighting = ddgi::DdgiLighting::Fitted(self.volume()).resolve(b);
                    if matches!(lighting, ddgi::DdgiLighting::Cascades(_)) {
                        eprintln!(
                            "DDGI fitted to the scene: one volume's probes would be {:.1} apart (over {} m), so {} (--cascades 0 for one volume)",
                            ddgi::fit::fitted_spacing(b),
                            ddgi::MAX_FITTED_SPACING,
                            lighting.describe()
                        );
                    }
                    lighting
                }
                None => ddgi::DdgiLighting::Volume(self.volume()),
            },
        }
    }

    fn volume(&self) -> ddgi::DdgiVolume {
        ddgi::DdgiVolume {
            probe_counts: self.probes,
            rays_per_probe: self.rays,
            irradiance_texels: self.irradiance_texels,
            distance_texels: self.distance_texels,
            hysteresis: self.hysteresis,
            hit_occlusion_rays: self.hit_occlusion,
            hit_occlusion_reach: self.hit_occlusion_reach,
            adaptive: ddgi::DdgiAdaptive {
                enabled: !self.no_adaptive,
                min_rays: ddgi::DdgiAdaptive::default().min_rays.min(self.rays.max(1)),
                max_update_period: self.max_update_period,
                ..Default::default()
            },
            ..Default::default()
        }
    }
}

/// `--rest-smoothing`: a weight, or `off`.
#[derive(Clone, Copy, Debug)]
struct RestSmoothing(Option<f32>);

fn parse_rest_smoothing(text: &str) -> Result<RestSmoothing, String> {
    if text.trim().eq_ignore_ascii_case("off") {
        return Ok(RestSmoothing(None));
    }
    // The range is checked with the rest of the settings (DdgiVolume::validate).
    text.trim()
        .parse::<f32>()
        .map(|s| RestSmoothing(Some(s)))
        .map_err(|e| format!("expected a weight in [0, 1) or 'off', got '{text}': {e}"))
}

/// `x,y,z`; also glam's display form `[x, y, z]` (how clap shows a default).
fn parse_dvec3(text: &str) -> Result<glam::DVec3, String> {
    let v: Vec<f64> = text.split(',').map(|p| p.trim().parse::<f64>().map_err(|e| format!("'{p}': {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite() && c.abs() <= 1e15) => Ok(glam::DVec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers x,y,z of at most 1e15, got '{text}'")),
    }
}

/// `--sun x,y,z,irradiance`: a direction (not zero) and an irradiance (not negative).
fn parse_sun(text: &str) -> Result<(glam::Vec3, f32), String> {
    let v: Vec<f32> = text.split(',').map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}"))).collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z, e] if v.iter().all(|c| c.is_finite()) && glam::Vec3::new(x, y, z).length() > 1e-6 && e >= 0.0 => {
            Ok((glam::Vec3::new(x, y, z).normalize(), e))
        }
        _ => Err(format!("expected x,y,z,irradiance (a direction not zero, an irradiance ≥ 0, all finite), got '{text}'")),
    }
}

fn parse_vec3(text: &str) -> Result<glam::Vec3, String> {
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
/// ([`Lighting::apply`]).
fn load(scene: &str) -> Result<SceneDescription, String> {
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
    Lighting::get().apply(&mut description, scene);
    Ok(description)
}

/// Replaces the scene's camera by one at `position` looking at `target` (`--camera-position`,
/// `--camera-target`, `--fov` in degrees).
fn replace_camera(scene: &mut SceneDescription, position: glam::Vec3, target: glam::Vec3, fov: f32) -> Result<(), String> {
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

fn render(args: RenderArgs) -> Result<(), String> {
    if args.list_scenes {
        for name in lab::eval::built_in_scene_names() {
            println!("{name}");
        }
        return Ok(());
    }
    let mut scene = load(&args.scene)?;
    scene.origin = args.offset.unwrap_or_default();
    args.camera.apply(&mut scene)?;
    if let Some(ev) = args.ev100 {
        if !ev.is_finite() {
            return Err(format!("--ev100: {ev} is not a finite exposure value"));
        }
        for node in &mut scene.nodes {
            for content in &mut node.content {
                if let engine::scene::NodeContent::Camera(camera) = content {
                    camera.exposure = engine::color::exposure_from_ev100(ev);
                }
            }
        }
    }
    let display = engine::render::DisplayTransform::from(args.display_transform);
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    let ddgi_mode = matches!(args.mode, ModeArg::Ddgi | ModeArg::Indirect);
    let default_frames = match (ddgi_mode, args.mode, args.no_taa) {
        (true, _, _) => 120,
        (false, ModeArg::Direct, false) => 32,
        _ => 1,
    };
    let frames = args.frames.unwrap_or(default_frames);
    let camera_settings = move |app: &mut engine::bevy_app::App| {
        lab::progress::show_blas_builds(app);
        if args.no_taa {
            app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
        }
        if args.auto_exposure {
            app.insert_resource(engine::render::DefaultAutoExposure::default());
        }
    };
    let mut settings = HeadlessSettings { width: args.width, height: args.height, frames, ..Default::default() };
    let frame = if ddgi_mode {
        let volume = args.ddgi.volume();
        volume.validate().map_err(|e| e.to_string())?;
        let lighting = args.ddgi.lighting(&scene);
        if let ddgi::DdgiLighting::Cascades(c) = &lighting {
            c.validate().map_err(|e| e.to_string())?;
        }
        let output = if args.mode == ModeArg::Indirect { ddgi::DdgiOutput::Indirect } else { ddgi::DdgiOutput::Full };
        let mut dumped: Result<Vec<PathBuf>, String> = Ok(Vec::new());
        let dump = args.ddgi.dump_atlases;
        let occlusion = ddgi::DdgiContactOcclusion {
            rays: args.ddgi.contact_occlusion,
            half_resolution: !args.ddgi.contact_occlusion_full_resolution,
            ..Default::default()
        };
        let out = args.out.clone();
        let frame = engine::headless::render_scene_and_inspect(
            &gpu,
            scene,
            &settings,
            |app| {
                app.insert_resource(display).insert_resource(occlusion);
                camera_settings(app);
                ddgi::use_ddgi_lighting(app, lighting, output);
            },
            |world| {
                let volumes = world.resource::<ddgi::DdgiGpuVolumes>();
                if let Some(error) = volumes.volumes.is_empty().then(|| volumes.first_error()).flatten() {
                    dumped = Err(format!("the DDGI volume is off: {error}"));
                } else if dump && let Some((_, v)) = volumes.volumes.first() {
                    dumped = ddgi::atlas::write_atlas_images(&gpu, v, &out);
                }
            },
        )
        .map_err(|e| e.to_string())?;
        for path in dumped? {
            println!("  {}", path.display());
        }
        Ok(frame)
    } else if args.mode == ModeArg::Pathtrace {
        let per_frame = args.spp.clamp(1, 16);
        // The last frame of the run holds all the samples: earlier frames are only for animation.
        settings.frames = frames.max(1) + args.spp.max(1).div_ceil(per_frame) - 1;
        let path = pathtrace::PathTraceSettings { samples_per_frame: per_frame, max_bounces: args.max_bounces, ..Default::default() };
        // A progress bar on standard error for long renders (hidden when it is not a terminal).
        let bar = indicatif::ProgressBar::new(u64::from(settings.frames));
        bar.set_style(
            indicatif::ProgressStyle::with_template("path tracing {bar:40} {pos}/{len} frames, {elapsed} elapsed, {eta} left")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let tick = bar.clone();
        let frame = engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
            app.insert_resource(display);
            camera_settings(app);
            pathtrace::use_path_tracer(app, path);
            app.add_systems(engine::bevy_app::Last, move || tick.inc(1));
        });
        bar.finish_and_clear();
        frame
    } else {
        engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
            app.insert_resource(display);
            camera_settings(app);
        })
    }
    .map_err(|e| e.to_string())?;
    frame.write(&args.out).map_err(|e| e.to_string())?;
    let spp = if args.mode == ModeArg::Pathtrace { format!(", {} paths per pixel", args.spp) } else { String::new() };
    println!(
        "rendered '{}' ({:?}) on {} ({}×{}, {} frames{spp})",
        args.scene, args.mode, frame.adapter, args.width, args.height, settings.frames
    );
    if let Some(file) = scenes::files::find(&args.scene) {
        println!("  the scene: {} (credit them wherever the image is shown)", file.credit);
    }
    println!("  {}", args.out.join("image.png").display());
    println!("  {}", args.out.join("image.exr").display());
    println!("  {}", args.out.join("timings.json").display());
    Ok(())
}

/// A probe grid as the bench tables name it: `32×8×32`.
fn grid_name(g: &[u32; 3]) -> String {
    format!("{}×{}×{}", g[0], g[1], g[2])
}

/// Prints a Markdown table with a row per ray count and a column per probe grid, each cell from
/// `cell` ("-" where it gives nothing).
fn print_grid_table(grids: &[[u32; 3]], ray_counts: &[u32], cell: impl Fn(&[u32; 3], u32) -> Option<String>) {
    println!("| rays/probe | {} |", grids.iter().map(grid_name).collect::<Vec<_>>().join(" | "));
    println!("|---|{}", "---:|".repeat(grids.len()));
    for &rays in ray_counts {
        let row: Vec<String> = grids.iter().map(|g| cell(g, rays).unwrap_or_else(|| "-".into())).collect();
        println!("| {rays} | {} |", row.join(" | "));
    }
}

fn bench_ddgi(
    name: &str,
    iterations: u32,
    size: engine::render::RenderSize,
    grids: &[glam::UVec3],
    rays: &[u32],
    persistent_trace: bool,
) -> Result<serde_json::Value, String> {
    let grids: Vec<[u32; 3]> = if grids.is_empty() { bench::GRIDS.to_vec() } else { grids.iter().map(|g| g.to_array()).collect() };
    let ray_counts: Vec<u32> = if rays.is_empty() { bench::RAYS.to_vec() } else { rays.to_vec() };
    let scene = load(name)?;
    let triangles = scene.instanced_triangle_count();
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    println!("# bench ddgi: {name} ({triangles} triangles) on {}, camera {}×{}", gpu.adapter_name(), size.width, size.height);
    let ways: &[bool] = if persistent_trace { &[false, true] } else { &[false] };
    let cells = bench::ddgi_throughput(&gpu, scene, size, iterations.max(1), &grids, &ray_counts, ways)?;
    let cell =
        |g: &[u32; 3], rays: u32, way: bool| cells.iter().find(|c| c.grid == *g && c.rays_per_probe == rays && c.persistent_trace == way);
    let way_name = |way: bool| if way { "persistent trace, then ddgi_shade" } else { "thread a ray, trace and shading in ddgi_trace" };
    let grid = if grids.contains(&[32, 8, 32]) { [32, 8, 32] } else { grids[0] };
    for &way in ways {
        println!("\n## Full probe update, MRays/s ({}; median of {iterations} frames; the rays the GPU counted)\n", way_name(way));
        print_grid_table(&grids, &ray_counts, |g, rays| {
            cell(g, rays, way).map(|c| format!("{:.0} ({:.3} ms)", c.mrays_per_second(), c.update_ms))
        });
        let skipped: Vec<String> = cells
            .iter()
            .filter(|c| c.persistent_trace == way && c.traced_share() < 0.999)
            .map(|c| {
                let (grid, rays, nominal) = (grid_name(&c.grid), c.rays, c.nominal_rays);
                format!("- {grid} × {}: {rays} of {nominal} rays traced ({:.1}%)", c.rays_per_probe, 100.0 * c.traced_share())
            })
            .collect();
        if !skipped.is_empty() {
            println!("\nProbes were skipped (switched off as dark or inside geometry, or resting): MRays/s count only the rays traced.\n");
            println!("{}", skipped.join("\n"));
        }
        println!("\n## GPU ms per pass at {} probes ({}; median)\n", grid_name(&grid), way_name(way));
        let mut labels: Vec<String> = bench::DDGI_UPDATE_PASSES.iter().map(|s| s.to_string()).collect();
        labels.extend(["ddgi_gather".to_string(), "ddgi_composite".to_string(), "gbuffer".to_string(), "direct_lighting".to_string()]);
        println!("| pass | {} |", ray_counts.iter().map(|r| format!("{r} rays")).collect::<Vec<_>>().join(" | "));
        println!("|---|{}", "---:|".repeat(ray_counts.len()));
        for label in &labels {
            let row: Vec<String> = ray_counts
                .iter()
                .map(|&r| cell(&grid, r, way).and_then(|c| c.pass_ms(label)).map_or("-".into(), |ms| format!("{ms:.3}")))
                .collect();
            println!("| {label} | {} |", row.join(" | "));
        }
        // The trace and the shading of its rays, whichever passes they ran in.
        let non_trace = |c: &bench::DdgiCell| c.update_ms - c.pass_ms("ddgi_trace").unwrap_or(0.0) - c.pass_ms("ddgi_shade").unwrap_or(0.0);
        let row: Vec<String> =
            ray_counts.iter().map(|&r| cell(&grid, r, way).map_or("-".into(), |c| format!("{:.3}", non_trace(c)))).collect();
        println!("| all update passes but ddgi_trace and ddgi_shade | {} |", row.join(" | "));
    }
    if persistent_trace {
        println!("\n## Persistent trace against a thread a ray: the full probe update's time, thread a ray / persistent (same run)\n");
        print_grid_table(&grids, &ray_counts, |g, rays| {
            let (a, b) = (cell(g, rays, false)?, cell(g, rays, true)?);
            Some(format!("{:.2}×", a.update_ms / b.update_ms))
        });
    }
    let cells: Vec<serde_json::Value> = cells
        .iter()
        .map(|c| {
            let passes: serde_json::Map<String, serde_json::Value> = c.passes.iter().map(|(l, ms)| (l.clone(), (*ms).into())).collect();
            serde_json::json!({
                "probes": c.grid, "rays_per_probe": c.rays_per_probe, "persistent_trace": c.persistent_trace, "rays": c.rays,
                "nominal_rays": c.nominal_rays, "update_ms": c.update_ms,
                "mrays_per_second": c.mrays_per_second(), "pass_ms": passes,
            })
        })
        .collect();
    Ok(serde_json::json!({
        "bench": "ddgi", "scene": name, "adapter": gpu.adapter_name(), "camera": [size.width, size.height], "iterations": iterations,
        "cells": cells,
    }))
}

#[allow(clippy::too_many_arguments)]
fn bench_walk(
    name: &str,
    (cascades, probes, spacing, blend, cascade_period, frame_budget): (u32, glam::UVec3, f32, f32, u32, Option<u32>),
    rays: u32,
    adaptive: bool,
    (frames, warmup, speed): (u32, u32, f32),
    (width, height): (u32, u32),
    offset: Option<glam::DVec3>,
    sky_light: ddgi::DdgiSkyLight,
    (error_every, reference_spp): (Option<u32>, u32),
    out: &std::path::Path,
) -> Result<serde_json::Value, String> {
    let scene = load(name)?;
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    let volume = ddgi::DdgiVolume {
        bounds: scenes::find(name).and_then(|e| (e.gi_bounds)()).map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3())),
        probe_counts: Some(probes),
        rays_per_probe: rays,
        adaptive: ddgi::DdgiAdaptive {
            enabled: adaptive,
            min_rays: ddgi::DdgiAdaptive::default().min_rays.min(rays),
            // One volume takes the budget itself; cascades share theirs (below).
            frame_budget: if cascades == 0 { frame_budget } else { None },
            ..Default::default()
        },
        ..Default::default()
    };
    volume.validate().map_err(|e| e.to_string())?;
    let cascades = (cascades > 0).then(|| ddgi::DdgiCascades {
        count: Some(cascades),
        probe_counts: probes,
        spacing,
        blend_cells: blend,
        max_update_period: cascade_period,
        frame_budget,
        volume: ddgi::DdgiVolume { bounds: None, warm_up: true, ..volume.clone() },
    });
    if let Some(c) = &cascades {
        c.validate().map_err(|e| e.to_string())?;
    }
    let what = cascades
        .as_ref()
        .map_or(format!("one volume of {probes}"), |c| format!("{} cascades of {probes}, finest {spacing} m", c.count.unwrap_or(0)));
    let config = match &cascades {
        Some(c) => lab::eval::Config::ddgi_cascades(c),
        None => lab::eval::Config::Ddgi { name: "ddgi".into(), volume: Box::new(volume), occlusion: Default::default(), taa: true },
    };
    let path = lab::walk::WalkPath::for_scene(name, &scene);
    let options = lab::walk::WalkOptions {
        speed,
        warmup,
        offset: offset.unwrap_or_default(),
        sky: if name == "open_world" { play::tour::OPEN_SKY } else { glam::Vec3::ZERO },
        sky_light,
        error_every,
        reference_spp,
        ..lab::walk::WalkOptions::new(config, path, engine::render::RenderSize { width, height }, frames)
    };
    let report = lab::walk::walk(&gpu, scene, &options, Some(out))?;
    println!(
        "# bench walk: {name}, {what}, {rays} rays (adaptive: {adaptive}), {width}×{height}, {frames} frames at {speed} m/s, on {}",
        gpu.adapter_name()
    );
    println!(
        "DDGI GPU ms per frame: median {:.3}, slowest {:.3}; frames over 2× the median: {}",
        report.median_ddgi_ms(),
        report.max_ddgi_ms(),
        report.frames_over(2.0)
    );
    for k in 0..report.volumes {
        let rays = report.mean_volume_rays(k).map_or("n/a".to_string(), |r| format!("{r:.0}"));
        println!("  volume {k}: gather median {:.3} ms, rays per frame mean {rays}", report.median_volume_ms(k));
    }
    println!(
        "  all gathers: median {:.3} ms; composite (with the sky light): median {:.3} ms",
        report.median_of(|f| f.gather_ms),
        report.median_of(|f| f.composite_ms)
    );
    let scrolls = report.frames.iter().filter(|f| f.scrolled > 0).count();
    let over: Vec<u32> = report.frames.iter().filter(|f| f.ddgi_ms > 2.0 * report.median_ddgi_ms()).map(|f| f.frame).collect();
    println!("frames with a scroll: {scrolls}; frames over 2× the median: {over:?}");
    if let Some((mean, change)) = report.flip_summary() {
        println!(
            "FLIP against path-traced references ({reference_spp} spp) of every {}th frame: mean {mean:.4}, mean change between them {change:.4}",
            error_every.unwrap_or(0)
        );
    }
    println!("median GPU ms of each pass (over the frames it ran in):");
    for (label, ms, frames) in report.pass_medians() {
        println!("  {label}: {ms:.4} ({frames} frames)");
    }
    if let Some(rays) = report.mean_rays() {
        println!("rays traced per frame (every volume): mean {rays:.0}");
    }
    let rebases = report.frames.iter().filter(|f| f.rebased).count();
    println!("rebases: {rebases}; every frame in {}", out.join("walk.csv").display());
    let passes: serde_json::Map<String, serde_json::Value> = report
        .pass_medians()
        .into_iter()
        .map(|(label, ms, frames)| (label, serde_json::json!({"median_ms": ms, "frames": frames})))
        .collect();
    let volumes: Vec<serde_json::Value> = (0..report.volumes)
        .map(|k| serde_json::json!({"gather_median_ms": report.median_volume_ms(k), "mean_rays": report.mean_volume_rays(k)}))
        .collect();
    Ok(serde_json::json!({
        "bench": "walk", "scene": name, "configuration": what, "adapter": gpu.adapter_name(), "rays_per_probe": rays,
        "adaptive": adaptive, "size": [width, height], "frames": frames, "speed": speed,
        "ddgi_median_ms": report.median_ddgi_ms(), "ddgi_max_ms": report.max_ddgi_ms(), "frames_over_2x_median": report.frames_over(2.0),
        "frames_with_a_scroll": scrolls, "rebases": rebases, "mean_rays": report.mean_rays(),
        "flip": report.flip_summary().map(|(mean, change)| serde_json::json!({"mean": mean, "mean_change": change})),
        "volumes": volumes, "pass_median_ms": passes, "csv": out.join("walk.csv"),
    }))
}

fn bench(command: BenchCommand) -> Result<(), String> {
    let (name, iterations, no_flat_rebuild, cpu_only, work_only, gpu_refit, rebraid, variant, stack_and_subgroups, json) = match command {
        BenchCommand::Trace {
            scene,
            iterations,
            no_flat_rebuild,
            cpu_only,
            rebraid,
            static_groups,
            blas_build,
            ray_order,
            workgroup_size,
            persistent_groups,
            shared_stack,
            subgroup_postpone,
            subgroup_fetch,
            packet,
            work_only,
            gpu_refit,
            json,
        } => {
            let ray_order = match ray_order {
                RayOrderArg::Fibonacci => bench::RayOrder::Fibonacci,
                RayOrderArg::Coherent => bench::RayOrder::Coherent,
            };
            (
                scene,
                iterations,
                no_flat_rebuild,
                cpu_only,
                work_only,
                gpu_refit,
                (rebraid, engine::rt::BlasBuildQuality::from(blas_build), engine::rt::StaticGrouping::from(static_groups)),
                bench::TraceVariant { ray_order, workgroup_size, persistent_groups, ..Default::default() },
                (shared_stack, subgroup_postpone, subgroup_fetch, packet),
                json,
            )
        }
        BenchCommand::Classify { scene, probes: grid, frames, json } => {
            let description = load(&scene)?;
            let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
            let grid = grid.map_or(eval_scenes::scene_facts(&scene).paper_grid, |g| g.to_array());
            let c = bench::classification_check(&gpu, description, grid, frames)?;
            println!("# bench classify: {scene}, {}×{}×{} probes, {frames} frames, on {}", grid[0], grid[1], grid[2], gpu.adapter_name());
            let share = |a: usize, b: usize| if b == 0 { "n/a".to_string() } else { format!("{:.1}%", 100.0 * a as f64 / b as f64) };
            println!("probes: {}", c.probes);
            println!("inside solid geometry: {} — switched off: {} ({})", c.inside, c.inside_off, share(c.inside_off, c.inside));
            println!(
                "needed by a visible surface: {} — switched off: {} ({}), of which not dark: {} ({})",
                c.needed,
                c.needed_off,
                share(c.needed_off, c.needed),
                c.needed_off_lit,
                share(c.needed_off_lit, c.needed)
            );
            for (i, grid, offset, back, luma, empty) in &c.needed_off_probes {
                println!(
                    "  needed and off: probe {i} at {grid}, offset {offset:.2} cells, back faces {:.0}% of the checker's rays, \
                     luma {luma:.3e}, rays in a row that found no surface in its region {empty}",
                    100.0 * back
                );
            }
            return write_json(
                json.as_deref(),
                serde_json::json!({
                    "bench": "classify", "scene": scene, "adapter": gpu.adapter_name(), "probes": grid, "frames": frames,
                    "probe_count": c.probes, "inside": c.inside, "inside_off": c.inside_off,
                    "needed": c.needed, "needed_off": c.needed_off, "needed_off_lit": c.needed_off_lit,
                }),
            );
        }
        BenchCommand::Walk {
            scene,
            cascades,
            probes,
            cascade_probes,
            cascade_spacing: spacing,
            cascade_blend: blend,
            cascade_period,
            frame_budget,
            rays,
            no_adaptive,
            frames,
            warmup,
            speed,
            width,
            height,
            offset,
            out,
            sky_rays,
            sky_reach,
            error_every,
            reference_spp,
            json,
        } => {
            let sky = ddgi::DdgiSkyLight { rays: sky_rays, max_distance: sky_reach };
            let measure = (error_every, reference_spp);
            let probes = if cascades > 0 { cascade_probes } else { probes };
            let grid = (cascades, probes, spacing, blend, cascade_period, frame_budget);
            let report =
                bench_walk(&scene, grid, rays, !no_adaptive, (frames, warmup, speed), (width, height), offset, sky, measure, &out)?;
            return write_json(json.as_deref(), report);
        }
        BenchCommand::Ddgi { scene, iterations, width, height, probes, rays, persistent_trace, json } => {
            let report = bench_ddgi(&scene, iterations, engine::render::RenderSize { width, height }, &probes, &rays, persistent_trace)?;
            return write_json(json.as_deref(), report);
        }
    };
    let (shared_stack, postpone, fetch, packets) = stack_and_subgroups;
    let packets: Vec<bench::PacketScope> = packets
        .iter()
        .map(|p| match p {
            PacketArg::Subgroup => bench::PacketScope::Subgroup,
            PacketArg::Workgroup => bench::PacketScope::Workgroup,
        })
        .collect();
    let scene = load(&name)?;
    let bounds = bench::world_bounds(&scene).ok_or("the scene has no geometry")?;
    let triangles = scene.instanced_triangle_count();
    // Subgroup operations only where a variant uses them (the device is then the same for all).
    let subgroups = !postpone.is_empty() || fetch || packets.contains(&bench::PacketScope::Subgroup);
    let gpu = GpuContext::new(GpuOptions { subgroups, ..Default::default() }).map_err(|e| e.to_string())?;
    let started = std::time::Instant::now();
    let (rebraid, blas_build, static_groups) = rebraid;
    let mut app = bench::prepared_app_with(&gpu, scene, blas_build);
    println!("# bench trace: {name} ({triangles} triangles) on {}", gpu.adapter_name());
    println!("scene prepared (BLAS ({blas_build:?}) and TLAS built, uploaded) in {:.2?}", started.elapsed());
    let prepare_ms = started.elapsed().as_secs_f64() * 1e3;
    let build = bench::tlas_build(&mut app, rebraid, Some(static_groups));
    println!(
        "TLAS (re-braiding budget {}, static groups {:?}): {} primitives over {} instances ({} static groups of {} instances), built and uploaded in {:.2} ms",
        build.budget,
        build.static_grouping,
        build.primitives,
        build.instances,
        build.groups,
        build.grouped_instances,
        build.time.as_secs_f64() * 1e3
    );
    let mut report = serde_json::json!({
        "bench": "trace", "scene": name, "triangles": triangles, "adapter": gpu.adapter_name(), "iterations": iterations,
        "ray_order": format!("{:?}", variant.ray_order), "workgroup_size": variant.workgroup_size, "persistent_groups": variant.persistent_groups,
        "prepare_ms": prepare_ms, "blas_build": format!("{blas_build:?}"), "rebraid_budget": build.budget, "tlas_primitives": build.primitives,
        "tlas_instances": build.instances, "tlas_build_ms": build.time.as_secs_f64() * 1e3,
        "static_grouping": format!("{:?}", build.static_grouping), "static_group_count": build.groups, "grouped_instances": build.grouped_instances,
    });
    // The variants timed and counted: the one asked for, then the same with a shared stack, then
    // the same with triangle tests postponed at each share asked for.
    let mut variants = vec![variant];
    if let Some(k) = shared_stack {
        variants.push(bench::TraceVariant { shared_stack_entries: k, ..variant });
    }
    for &share in &postpone {
        variants.push(bench::TraceVariant { postpone_triangles: Some(share), ..variant });
    }
    // Then each of those without a shared stack again, with dynamic fetch.
    if fetch {
        let unfetched: Vec<_> = variants.iter().filter(|v| v.shared_stack_entries == 0).copied().collect();
        variants.extend(unfetched.into_iter().map(|v| bench::TraceVariant { subgroup_fetch: true, ..v }));
    }
    // Then packets of each scope asked for.
    for &scope in &packets {
        variants.push(bench::TraceVariant { packet: Some(scope), ..variant });
    }
    let variant_name = |v: &bench::TraceVariant| {
        let mut parts = Vec::new();
        if shared_stack.is_some() {
            parts.push(match v.shared_stack_entries {
                0 => "stack in function memory".to_string(),
                k => format!("top {k} stack entries in workgroup memory"),
            });
        }
        if !postpone.is_empty() {
            parts.push(match v.postpone_triangles {
                None => "triangle tests at once".to_string(),
                Some(share) => format!("triangle tests postponed below {:.0}% of a subgroup's lanes", 100.0 * share),
            });
        }
        if fetch {
            parts.push(if v.subgroup_fetch { "one fetch a subgroup" } else { "one fetch a lane" }.to_string());
        }
        if !packets.is_empty() {
            parts.push(match v.packet {
                None => "a walk a ray".to_string(),
                Some(bench::PacketScope::Subgroup) => "a walk a subgroup (packets)".to_string(),
                Some(bench::PacketScope::Workgroup) => format!("a walk a workgroup of {} (packets)", v.workgroup_size),
            });
        }
        parts.join(", ")
    };
    if !cpu_only && !work_only {
        let tables = bench::trace_throughput_compared(&gpu, &app, bounds, iterations.max(1), &variants)?;
        let json_cells = |cells: &[bench::TraceCell]| -> serde_json::Value {
            cells
                .iter()
                .map(|c| serde_json::json!({"probes": c.grid, "rays_per_probe": c.rays_per_probe, "rays": c.rays, "median_ms": c.median_ms, "mrays_per_second": c.mrays_per_second()}))
                .collect()
        };
        report["throughput"] = json_cells(&tables[0]);
        if let Some(k) = shared_stack {
            report["shared_stack_entries"] = serde_json::json!(k);
            report["throughput_shared_stack"] = json_cells(&tables[1]);
        }
        if !postpone.is_empty() || fetch {
            report["throughput_subgroup"] = variants
                .iter()
                .zip(&tables)
                .filter(|(v, _)| v.uses_subgroups())
                .map(|(v, cells)| {
                    serde_json::json!({"postpone_share": v.postpone_triangles, "subgroup_fetch": v.subgroup_fetch, "throughput": json_cells(cells)})
                })
                .collect();
        }
        let print_table = |cells: &[bench::TraceCell], cell: &dyn Fn(&bench::TraceCell) -> String| {
            print_grid_table(&bench::GRIDS, &bench::RAYS, |g, rays| {
                cells.iter().find(|c| c.grid == *g && c.rays_per_probe == rays).map(cell)
            });
        };
        for (v, cells) in variants.iter().zip(&tables) {
            let which = if variants.len() > 1 { format!(", {}", variant_name(v)) } else { String::new() };
            println!("\n## Closest-hit probe rays, MRays/s (median of {iterations} dispatches, trace pass GPU time{which})\n");
            print_table(cells, &|c| format!("{:.0} ({:.3} ms)", c.mrays_per_second(), c.median_ms));
        }
        if let [default, others @ ..] = tables.as_slice() {
            for (v, other) in variants[1..].iter().zip(others) {
                println!("\n## {} against {}, same run: throughput ratio\n", variant_name(v), variant_name(&variants[0]));
                print_table(other, &|c| {
                    default
                        .iter()
                        .find(|d| d.grid == c.grid && d.rays_per_probe == c.rays_per_probe)
                        .map_or("-".into(), |d| format!("{:.3}", d.median_ms / c.median_ms))
                });
            }
        }
    }
    if !cpu_only {
        let (grid, rays) = ([32, 8, 32], 128);
        let mut first: Option<bench::TraversalWork> = None;
        let mut postponed_work = Vec::new();
        // Work is counted by the thread-a-ray kernel: dynamic fetch (persistent) changes nothing.
        for v in variants.iter().filter(|v| !v.subgroup_fetch) {
            let w = bench::traversal_work(&gpu, &app, bounds, grid, rays, *v)?;
            let json = serde_json::json!({
                "probes": grid, "rays_per_probe": rays, "tlas_nodes": w.tlas_nodes, "instances_entered": w.instances,
                "blas_nodes": w.blas_nodes, "triangles": w.triangles, "steps": w.steps, "simt_efficiency": w.simt_efficiency,
                "stack_spills": w.stack_spills, "deepest_stack": w.deepest_stack, "postponed": w.postponed, "waits": w.waits,
            });
            match v.postpone_triangles {
                Some(share) => postponed_work.push(serde_json::json!({"share": share, "work": json})),
                None if v.shared_stack_entries > 0 => report["traversal_work_per_ray_shared_stack"] = json,
                None if v.packet == Some(bench::PacketScope::Subgroup) => report["traversal_work_per_ray_subgroup_packets"] = json,
                None if v.packet.is_some() => report["traversal_work_per_ray_workgroup_packets"] = json,
                None => report["traversal_work_per_ray"] = json,
            }
            match first {
                None => println!(
                    "\nTraversal work per ray at {}×{}×{} × {rays} rays: {:.1} TLAS nodes, {:.2} instances entered, {:.1} BLAS nodes, {:.1} triangles tested; \
                     {:.1} loop steps, SIMT efficiency {:.0}% (lanes' steps over 32 × their warp's most); deepest stack {} entries",
                    grid[0],
                    grid[1],
                    grid[2],
                    w.tlas_nodes,
                    w.instances,
                    w.blas_nodes,
                    w.triangles,
                    w.steps,
                    100.0 * w.simt_efficiency,
                    w.deepest_stack
                ),
                // A packet's lanes walk the same nodes: the SIMT efficiency is 100%, and its
                // steps a ray are a warp's steps (against the first's steps over its efficiency).
                Some(f) if v.packet.is_some() => println!(
                    "{}: {:.1} TLAS nodes, {:.2} instances entered, {:.1} BLAS nodes, {:.1} triangles tested; {:.1} loop steps a ray \
                     (a walk a ray: {:.1} steps a ray, {:.1} for its warp's slowest lane), SIMT efficiency {:.0}%",
                    variant_name(v),
                    w.tlas_nodes,
                    w.instances,
                    w.blas_nodes,
                    w.triangles,
                    w.steps,
                    f.steps,
                    f.steps / f.simt_efficiency.max(1e-9),
                    100.0 * w.simt_efficiency,
                ),
                // Postponed tests reorder the walk: a closer hit found later culls fewer nodes.
                Some(_) if v.postpone_triangles.is_some() => println!(
                    "{}: {:.1} TLAS nodes, {:.1} BLAS nodes, {:.1} triangles tested; {:.1} loop steps, {:.1} of which put triangle tests off \
                     and {:.1} only waited, SIMT efficiency {:.0}% (waits idle); deepest stack {} entries",
                    variant_name(v),
                    w.tlas_nodes,
                    w.blas_nodes,
                    w.triangles,
                    w.steps,
                    w.postponed,
                    w.waits,
                    100.0 * w.simt_efficiency,
                    w.deepest_stack
                ),
                Some(f) => println!(
                    "{}: {:.3} stack entries moved to function memory per ray; {}",
                    variant_name(v),
                    w.stack_spills,
                    if w.counts() == f.counts() && w.steps == f.steps { "the same walk" } else { "A DIFFERENT WALK (a bug)" }
                ),
            }
            first.get_or_insert(w);
        }
        if !postponed_work.is_empty() {
            report["traversal_work_per_ray_postponed"] = postponed_work.into();
        }
    }
    if work_only {
        return write_json(json.as_deref(), report);
    }
    println!("\n## CPU cost per frame of instance and TLAS updates and uploads (medians of 9 frames; 30 with the refit on the GPU)\n");
    let (gpu_header, gpu_rule) = if gpu_refit {
        (
            " CPU ms (total), refit on the GPU: median (slowest frame) | TLAS CPU ms, refit on the GPU: median (slowest frame) | of which leaf boxes / staging + dispatches | GPU ms of the GPU refit |",
            "---:|---:|---:|---:|",
        )
    } else {
        ("", "")
    };
    println!(
        "| moving instances | CPU ms (total) | of which TLAS refit/rebuild + upload | same, refit on one thread | of which refit / re-encode / upload staging | TLAS rebuilt |{gpu_header}"
    );
    println!("|---:|---:|---:|---:|---:|---|{gpu_rule}");
    let mut movers = Vec::new();
    for count in bench::MOVING {
        match bench::tlas_update_cost(&mut app, count, 9) {
            Some(c) => {
                let ms = |d: std::time::Duration| d.as_secs_f64() * 1e3;
                movers.push(serde_json::json!({
                    "moving_instances": count, "cpu_ms": ms(c.total), "tlas_ms": ms(c.tlas), "tlas_one_thread_ms": ms(c.tlas_one_thread),
                    "one_thread_refit_ms": ms(c.one_thread_steps[0]), "one_thread_encode_ms": ms(c.one_thread_steps[1]),
                    "one_thread_upload_ms": ms(c.one_thread_steps[2]), "tlas_rebuilt": c.rebuilt,
                }));
                let mut rebuilt = c.rebuilt;
                let mut gpu_cells = String::new();
                if gpu_refit {
                    let timed = if cpu_only { 0 } else { iterations.max(1) };
                    if let Some(g) = bench::tlas_gpu_refit_cost(&mut app, count, 30, timed) {
                        rebuilt |= g.rebuilt;
                        let gpu_ms = g.gpu.map(ms);
                        let [boxes, staging] = g.steps.map(ms);
                        gpu_cells = format!(
                            " {:.3} ({:.3}) | {:.3} ({:.3}) | {boxes:.3} / {staging:.3} | {} |",
                            ms(g.total),
                            ms(g.total_slowest),
                            ms(g.tlas),
                            ms(g.tlas_slowest),
                            gpu_ms.map_or("n/a".into(), |t| format!("{t:.3}"))
                        );
                        if let Some(last) = movers.last_mut() {
                            last["gpu_refit_cpu_ms"] = ms(g.total).into();
                            last["gpu_refit_cpu_slowest_ms"] = ms(g.total_slowest).into();
                            last["gpu_refit_tlas_ms"] = ms(g.tlas).into();
                            last["gpu_refit_tlas_slowest_ms"] = ms(g.tlas_slowest).into();
                            last["gpu_refit_boxes_ms"] = boxes.into();
                            last["gpu_refit_staging_ms"] = staging.into();
                            last["gpu_refit_gpu_ms"] = gpu_ms.into();
                            last["gpu_refit_rebuilt"] = g.rebuilt.into();
                        }
                    }
                }
                let rebuilt = if rebuilt { "yes" } else { "no (refit)" };
                let [refit, encode, upload] = c.one_thread_steps.map(ms);
                println!(
                    "| {count} | {:.3} | {:.3} | {:.3} | {refit:.3} / {encode:.3} / {upload:.3} | {rebuilt} |{gpu_cells}",
                    ms(c.total),
                    ms(c.tlas),
                    ms(c.tlas_one_thread)
                )
            }
            None => println!("| {count} | n/a (fewer instances) | | | | |"),
        }
    }
    report["tlas_updates"] = movers.into();
    if !no_flat_rebuild {
        let (t, n) = bench::flat_rebuild_cost(&mut app);
        println!("\nfull rebuild of one flat CWBVH over all {n} world-space triangles: {:.1} ms", t.as_secs_f64() * 1e3);
        report["flat_rebuild"] = serde_json::json!({"triangles": n, "ms": t.as_secs_f64() * 1e3});
    }
    write_json(json.as_deref(), report)
}

/// `bench … --json FILE`: writes `value` there (pretty-printed), or nothing without a file.
fn write_json(path: Option<&std::path::Path>, value: serde_json::Value) -> Result<(), String> {
    let Some(path) = path else { return Ok(()) };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(&value).map_err(|e| format!("{}: {e}", path.display()))?;
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    println!("JSON: {}", path.display());
    Ok(())
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let _ = LIGHTING.set(Lighting { sun: cli.sun, sky: cli.sky, opaque: cli.opaque });
    let trace = match cli.trace.as_deref().map(engine::trace::ChromeTrace::start).transpose() {
        Ok(trace) => trace,
        Err(e) => {
            eprintln!("error: --trace: {e}");
            return ExitCode::FAILURE;
        }
    };
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Bench(command) => bench(command),
        Command::Eval {
            scene,
            width,
            height,
            reference_spp,
            time_series,
            frames,
            settle_frames,
            probes,
            rest_frames,
            rest_error,
            hysteresis_exponent,
            dark_fraction,
            rest_smoothing,
            max_update_period,
            calm_error,
            drift_rate,
            hit_occlusion,
            hit_occlusion_reach,
            experiments,
            grid_sweep,
            volume_settings,
            out,
            cache,
            offset,
            cascades,
            cascade_probes,
            cascade_spacing,
            cascade_blend,
            cascade_period,
            frame_budget,
            walk,
            walk_from,
            walk_speed,
            no_display_timing,
            camera,
        } => load(&scene).and_then(|mut description| {
            description.origin = offset.unwrap_or_default();
            camera.apply(&mut description)?;
            let extent = description.bounds().map_or(1.0, |(lo, hi)| (hi - lo).x.max((hi - lo).z));
            let cascades = (cascades > 0).then(|| {
                let fitted = ddgi::DdgiCascades::fitted(cascades, cascade_probes, extent, ddgi::DdgiVolume::default());
                ddgi::DdgiCascades {
                    spacing: cascade_spacing.unwrap_or(fitted.spacing),
                    blend_cells: cascade_blend,
                    max_update_period: cascade_period,
                    frame_budget,
                    ..fitted
                }
            });
            if let Some(c) = &cascades {
                c.validate().map_err(|e| e.to_string())?;
            }
            let defaults = ddgi::DdgiAdaptive::on();
            let adaptive = ddgi::DdgiAdaptive {
                max_rest_frames: rest_frames.unwrap_or(defaults.max_rest_frames),
                rest_error: rest_error.unwrap_or(defaults.rest_error),
                hysteresis_exponent: hysteresis_exponent.unwrap_or(defaults.hysteresis_exponent),
                dark_fraction: dark_fraction.unwrap_or(defaults.dark_fraction),
                rest_smoothing: rest_smoothing.map_or(defaults.rest_smoothing, |RestSmoothing(s)| s),
                max_update_period: max_update_period.unwrap_or(defaults.max_update_period),
                calm_error: calm_error.unwrap_or(defaults.calm_error),
                drift_rate: drift_rate.unwrap_or(defaults.drift_rate),
                ..defaults
            };
            // Bad adaptive settings are named here, before any GPU work (the plugin would
            // otherwise leave the volume off and the evaluation measure nothing).
            ddgi::DdgiVolume { adaptive: adaptive.clone(), ..Default::default() }.validate().map_err(|e| e.to_string())?;
            let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
            let default_out = PathBuf::from("out/eval").join(scene.replace(['/', '\\', '.'], "_"));
            let out = out.unwrap_or_else(|| if time_series { default_out.join("time_series") } else { default_out });
            let options = eval::EvalOptions {
                width,
                height,
                reference_spp,
                out,
                cache,
                experiments,
                adaptive,
                settle_frames,
                grid: probes.map(|g| g.to_array()),
                cascades,
                timing_size: (!no_display_timing && [width, height] != eval::DISPLAY_SIZE).then_some(eval::DISPLAY_SIZE),
                hit_occlusion_rays: hit_occlusion,
                hit_occlusion_reach,
            };
            if walk {
                let series =
                    eval::walk_series::WalkSeries { start: walk_from, speed: walk_speed, sky: Lighting::get().sky.unwrap_or_default() };
                eval::walk_series::run(&gpu, &eval_scenes::scene_facts(&scene), description, &options, frames, series)?;
            } else if time_series {
                eval::time_series::run(&gpu, &eval_scenes::scene_facts(&scene), description, &options, frames)?;
            } else if grid_sweep {
                let base = match &volume_settings {
                    Some(path) => ddgi_overlay::settings::load(path)
                        .map_err(|e| e.to_string())?
                        .volumes
                        .into_iter()
                        .next()
                        .ok_or_else(|| format!("{}: the settings hold no volume (`volumes` is empty)", path.display()))?,
                    None => ddgi::DdgiVolume::default(),
                };
                eval::grid_sweep::run(&gpu, &eval_scenes::scene_facts(&scene), description, &options, &base)?;
                println!("report: {}", options.out.join("grid_sweep.md").display());
                return Ok(());
            } else {
                eval::run(&gpu, &eval_scenes::scene_facts(&scene), description, &options)?;
            }
            println!("report: {}", options.out.join("report.md").display());
            Ok(())
        }),
        Command::Play(args) => play(args),
    };
    let result = match trace.map(engine::trace::ChromeTrace::finish) {
        Some(Ok(t)) => {
            println!("trace: {} ({} CPU spans, {} GPU spans over {} frames)", t.path.display(), t.cpu_spans, t.gpu_spans, t.gpu_frames);
            result
        }
        Some(Err(e)) => result.and(Err(format!("--trace: {e}"))),
        None => result,
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::{CommandFactory, Parser};

    use super::Cli;

    /// Every argument of every subcommand, as `path --flag`, for which `f` holds.
    fn arguments(command: &clap::Command, path: &str, f: &impl Fn(&clap::Arg) -> bool, found: &mut Vec<String>) {
        for arg in command.get_arguments() {
            if !matches!(arg.get_id().as_str(), "help" | "version") && f(arg) {
                found.push(format!("{path} --{}", arg.get_long().unwrap_or(arg.get_id().as_str())));
            }
        }
        for sub in command.get_subcommands() {
            arguments(sub, &format!("{path} {}", sub.get_name()), f, found);
        }
    }

    /// `--help` explains every argument of every subcommand.
    #[test]
    fn every_argument_has_help() {
        Cli::command().debug_assert();
        let mut missing = Vec::new();
        arguments(&Cli::command(), "game_demo", &|arg| arg.get_help().is_none() && arg.get_long_help().is_none(), &mut missing);
        assert!(missing.is_empty(), "arguments without help text:\n  {}", missing.join("\n  "));
    }

    /// One concept, one flag: the probe grid is `--probes` (and `--cascade-probes` per cascade)
    /// wherever it is taken, never `--grid` or a spacing under another name.
    #[test]
    fn the_same_concept_has_the_same_flag_everywhere() {
        let mut found = Vec::new();
        let retired = ["grid", "spacing", "blend", "probe-spacing", "adaptive"];
        arguments(&Cli::command(), "game_demo", &|arg| arg.get_long().is_some_and(|l| retired.contains(&l)), &mut found);
        assert!(found.is_empty(), "retired flag names: {found:?}");
    }

    /// Every benchmark writes its results as JSON with `--json FILE`, and every subcommand takes
    /// `--trace FILE` under that one name.
    #[test]
    fn every_bench_takes_json_and_every_subcommand_takes_trace() {
        let command = Cli::command();
        let bench = command.find_subcommand("bench").expect("bench");
        let without: Vec<&str> =
            bench.get_subcommands().filter(|s| !s.get_arguments().any(|a| a.get_long() == Some("json"))).map(|s| s.get_name()).collect();
        assert!(without.is_empty(), "bench subcommands without --json: {without:?}");
        for args in [
            &["game_demo", "render", "--trace", "t.json"][..],
            &["game_demo", "play", "--headless", "--trace", "t.json"],
            &["game_demo", "bench", "ddgi", "--trace", "t.json"],
            &["game_demo", "bench", "trace", "--trace", "t.json"],
            &["game_demo", "bench", "walk", "--trace", "t.json"],
            &["game_demo", "bench", "classify", "--trace", "t.json"],
        ] {
            let cli = Cli::try_parse_from(args).unwrap_or_else(|e| panic!("{args:?}: {e}"));
            assert_eq!(cli.trace.as_deref(), Some(std::path::Path::new("t.json")), "{args:?}");
        }
    }

    /// `--rest-smoothing` takes a weight or `off` (the default is on, so off must be sayable).
    #[test]
    fn rest_smoothing_takes_a_weight_or_off() {
        for value in ["0.9", "off", "OFF"] {
            Cli::try_parse_from(["game_demo", "eval", "--rest-smoothing", value]).unwrap_or_else(|e| panic!("{value}: {e}"));
        }
        assert_eq!(super::parse_rest_smoothing("off").map(|s| s.0), Ok(None));
        assert_eq!(super::parse_rest_smoothing(" 0.5 ").map(|s| s.0), Ok(Some(0.5)));
        assert!(super::parse_rest_smoothing("often").is_err());
    }

    /// Each subcommand's long help carries examples.
    #[test]
    fn every_subcommand_has_examples() {
        let mut without = Vec::new();
        fn walk(command: &clap::Command, path: &str, without: &mut Vec<String>) {
            for sub in command.get_subcommands() {
                let path = format!("{path} {}", sub.get_name());
                if sub.get_subcommands().next().is_some() {
                    walk(sub, &path, without);
                } else if !sub.get_after_long_help().is_some_and(|h| h.to_string().contains("Examples")) {
                    without.push(path);
                }
            }
        }
        walk(&Cli::command(), "game_demo", &mut without);
        assert!(without.is_empty(), "subcommands without examples: {without:?}");
    }
}

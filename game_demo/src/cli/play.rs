//! `play`: the demo level (or any scene) in a window, or headless along a scripted path.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};

use super::{SceneOverrides, load};
use crate::play;

/// `play`'s examples (its long help).
pub const EXAMPLES: &str = "Examples:
  game_demo play                                                     # the demo level in a window
  game_demo play --headless --frames 600 --every 60 --out out/play   # its scripted walk to PNGs
  game_demo play --headless --overlay --frames 120 --every 0         # the same, with the DDGI overlay drawn in
  game_demo play --headless --soak --frames 10000                    # the soak test
  game_demo play --headless --frames 120 --trace out/play/trace.json # a Chrome trace of the walk
  game_demo play --scene open_world                                  # the open world's tour
  game_demo play --scene cornell                                     # any scene in a window";

#[derive(clap::Args)]
pub struct PlayArgs {
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

pub fn run(args: PlayArgs) -> Result<(), String> {
    let tour = args.scene.as_deref().and_then(scenes::find).filter(|entry| entry.play == scenes::PlayMode::Tour);
    if let Some(entry) = tour {
        let scene = load(entry.name)?;
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
    let overrides = SceneOverrides::get();
    if overrides.sun.is_some() || overrides.sky.is_some() {
        return Err(
            "--sun and --sky light the scenes that `play --scene` shows; the demo level's day–night cycle sets its own sun and sky".into(),
        );
    }
    if overrides.opaque {
        return Err("--opaque applies to the scenes that `play --scene` shows, not to the demo level".into());
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

//! `game_demo`: the project's binary. `render` renders a scene headless to files; `play` walks the
//! demo level (in a window, or headless along a scripted path); `eval` measures error against a
//! path-traced reference and run time; `bench` times the ray tracing and DDGI passes.

use std::path::PathBuf;
use std::process::ExitCode;

mod cli;
mod play;

use clap::{Parser, Subcommand};

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
    #[arg(long, global = true, value_parser = cli::parse_sun, value_name = "X,Y,Z,IRRADIANCE", allow_hyphen_values = true)]
    sun: Option<(glam::Vec3, f32)>,
    /// What rays that leave the scene see, the same in every mode (the background, probe rays,
    /// the path tracer's paths): a uniform radiance `r,g,b` in W/(m²·sr). Default: black, or
    /// Preetham's sky of the default sun for a scene with no lights at all.
    #[arg(long, global = true, value_parser = cli::parse_vec3, value_name = "R,G,B")]
    sky: Option<glam::Vec3>,
    /// Every material opaque: alpha masks and blending ignored, for the camera and every ray. The
    /// same scene without its alpha test, to measure what the masks cost (`bench`) or what they
    /// change in the light (`eval`, `render`).
    #[arg(long, global = true)]
    opaque: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene without a window: writes image.png (tonemapped sRGB), image.exr (linear
    /// radiance) and timings.json (GPU milliseconds per pass and frame) into --out.
    #[command(after_long_help = cli::render::EXAMPLES)]
    Render(cli::render::RenderArgs),
    /// Error against a path-traced reference and GPU time for a list of configurations (direct
    /// light, the path tracer at 1, 4, 16, 64 paths per pixel): report.md, results.json,
    /// error_vs_time.png and strips. With --time-series: the error of every frame after a change
    /// in the scene (time_series.csv, time_series.png, report.md).
    #[command(after_long_help = cli::eval::EXAMPLES)]
    Eval(cli::eval::EvalArgs),
    /// Benchmarks (results as Markdown tables on standard output; with --json FILE, as JSON too).
    #[command(subcommand)]
    Bench(cli::bench::BenchCommand),
    /// The walkable demo level with DDGI. In a window: click to grab the mouse, WASD walk, Shift
    /// run, Space jump, E door, F1 probe overlay, F12 screenshot, Esc release/quit. With
    /// --headless: a scripted walk writing frames and a per-frame timing CSV. With --scene: a
    /// viewer of any scene (no level, no player).
    #[command(after_long_help = cli::play::EXAMPLES)]
    Play(cli::play::PlayArgs),
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let _ = cli::SCENE_OVERRIDES.set(cli::SceneOverrides { sun: cli.sun, sky: cli.sky, opaque: cli.opaque });
    let trace = match cli.trace.as_deref().map(engine::trace::ChromeTrace::start).transpose() {
        Ok(trace) => trace,
        Err(e) => {
            eprintln!("error: --trace: {e}");
            return ExitCode::FAILURE;
        }
    };
    let result = match cli.command {
        Command::Render(args) => cli::render::run(args),
        Command::Eval(args) => cli::eval::run(args),
        Command::Bench(command) => cli::bench::run(command),
        Command::Play(args) => cli::play::run(args),
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

//! `game_demo`: the project's binary. `render` renders a scene headless to files; `play` opens a
//! window (later issues add the walkable level, `eval` and `bench`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::{HeadlessSettings, render_scene};
use engine::scene::SceneDescription;

#[derive(Parser)]
#[command(version, about = "Dynamic diffuse global illumination demo: headless renders and a windowed viewer")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene without a window: writes image.png (tonemapped sRGB), image.exr (linear
    /// radiance) and timings.json (GPU milliseconds per pass and frame) into --out.
    Render(RenderArgs),
    /// Open a window and show a scene (Esc quits).
    Play {
        /// A built-in scene name or a .gltf/.glb/.obj file.
        #[arg(long, default_value = "cornell")]
        scene: String,
    },
}

#[derive(clap::Args)]
struct RenderArgs {
    /// A built-in scene name (see --list-scenes) or a .gltf, .glb or .obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[arg(long, default_value_t = 640)]
    width: u32,
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Frames to run with a fixed 1/60 s step; the image is the last frame.
    #[arg(long, default_value_t = 1)]
    frames: u32,
    /// Output folder.
    #[arg(long, default_value = "out/render")]
    out: PathBuf,
    /// Print the built-in scene names and exit.
    #[arg(long)]
    list_scenes: bool,
}

/// A built-in scene by name, or a scene file by path.
fn load(scene: &str) -> Result<SceneDescription, String> {
    if let Some(builtin) = engine::builtin::builtin_scene(scene) {
        return Ok(builtin);
    }
    let path = std::path::Path::new(scene);
    if path.extension().is_none() {
        return Err(format!("'{scene}' is neither a built-in scene ({}) nor a scene file", engine::builtin::BUILTIN_SCENES.join(", ")));
    }
    engine::import::load_scene(path).map_err(|e| e.to_string())
}

fn render(args: RenderArgs) -> Result<(), String> {
    if args.list_scenes {
        println!("{}", engine::builtin::BUILTIN_SCENES.join("\n"));
        return Ok(());
    }
    let scene = load(&args.scene)?;
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    let settings = HeadlessSettings { width: args.width, height: args.height, frames: args.frames, ..Default::default() };
    let frame = render_scene(&gpu, scene, &settings).map_err(|e| e.to_string())?;
    frame.write(&args.out).map_err(|e| e.to_string())?;
    println!("rendered '{}' on {} ({}×{}, {} frames)", args.scene, frame.adapter, args.width, args.height, args.frames);
    println!("  {}", args.out.join("image.png").display());
    println!("  {}", args.out.join("image.exr").display());
    println!("  {}", args.out.join("timings.json").display());
    Ok(())
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let result = match Cli::parse().command {
        Command::Render(args) => render(args),
        Command::Play { scene } => load(&scene).and_then(|s| engine::window::run_windowed(s).map_err(|e| e.to_string())),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

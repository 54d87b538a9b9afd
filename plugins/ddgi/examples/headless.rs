//! A scene lit by DDGI, rendered for N frames without a window, into DIR/image.png (and .exr):
//! `cargo run --release -p ddgi --example headless -- --scene cornell --frames 60 --out DIR`.

use std::path::{Path, PathBuf};

use clap::Parser;
use ddgi::{DdgiLighting, DdgiOutput, DdgiVolume, use_ddgi_lighting};
use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::{HeadlessSettings, render_scene_with};

#[derive(Parser)]
pub struct Args {
    /// A built-in scene (cornell, door_room, …) or a .gltf, .glb or .obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[arg(long, default_value_t = 60)]
    frames: u32,
    #[arg(long, default_value = "out/headless")]
    out: PathBuf,
    /// Width and height of the image in pixels.
    #[arg(long, default_value_t = 512)]
    size: u32,
}

pub fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    let built_in = scenes::find(&args.scene);
    let scene = built_in.map_or_else(|| engine::import::load_scene(Path::new(&args.scene)), |entry| Ok((entry.build)()))?;
    // Fitted to the scene (a built-in scene's own GI bounds): one volume of the default grid, or
    // camera-following cascades where that grid's probes would be over 4 m apart.
    let bounds = built_in.and_then(|entry| (entry.gi_bounds)()).map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3()));
    let lighting = DdgiLighting::Fitted(DdgiVolume { bounds, ..Default::default() });
    let gpu = GpuContext::new(GpuOptions::default())?;
    let settings = HeadlessSettings { width: args.size, height: args.size, frames: args.frames, ..Default::default() };
    let frame = render_scene_with(&gpu, scene, &settings, |app| use_ddgi_lighting(app, lighting, DdgiOutput::Full))?;
    Ok(frame.write(&args.out)?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run(Args::parse())
}

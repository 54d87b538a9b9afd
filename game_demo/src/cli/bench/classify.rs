//! `bench classify`: DDGI's probe classification against an independent test with GPU rays.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};
use lab::bench;

use super::write_json;
use crate::cli::{eval_scenes, load};

#[derive(clap::Args)]
pub struct ClassifyArgs {
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
}

pub fn run(args: ClassifyArgs) -> Result<(), String> {
    let ClassifyArgs { scene, probes: grid, frames, json } = args;
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
    write_json(
        json.as_deref(),
        serde_json::json!({
            "bench": "classify", "scene": scene, "adapter": gpu.adapter_name(), "probes": grid, "frames": frames,
            "probe_count": c.probes, "inside": c.inside, "inside_off": c.inside_off,
            "needed": c.needed, "needed_off": c.needed_off, "needed_off_lit": c.needed_off_lit,
        }),
    )
}

//! `bench ddgi`: the full DDGI update's throughput and its passes' times.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};
use lab::bench;

use super::{grid_name, print_grid_table, write_json};
use crate::cli::load;

#[derive(clap::Args)]
pub struct DdgiArgs {
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
}

pub fn run(args: DdgiArgs) -> Result<(), String> {
    let size = engine::render::RenderSize { width: args.width, height: args.height };
    let report = bench_ddgi(&args.scene, args.iterations, size, &args.probes, &args.rays, args.persistent_trace)?;
    write_json(args.json.as_deref(), report)
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

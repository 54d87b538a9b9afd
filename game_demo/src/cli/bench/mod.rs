//! `bench`: timings of the ray tracing and DDGI passes, a module a benchmark (its arguments and its
//! run), and the tables and JSON they share.

use clap::Subcommand;

mod classify;
mod ddgi;
mod trace;
mod walk;

#[derive(Subcommand)]
pub enum BenchCommand {
    /// DDGI's GPU time per frame while the camera walks the open world's tour (out of the house,
    /// 500 m into the forest and back): median, slowest frame and frames over twice the median,
    /// per-cascade times, scrolls and rebases; every frame in --out/walk.csv.
    #[command(
        after_long_help = "Examples:\n  game_demo bench walk --cascades 8 --cascade-probes 16,8,16 --frames 1200 --speed 30\n  game_demo bench walk --cascades 0 --probes 32,8,32   # one scene-wide volume\n  game_demo bench walk --width 256 --height 256 --error-every 100   # and FLIP every 100th frame"
    )]
    Walk(walk::WalkArgs),
    /// Closest-hit throughput of probe-like rays (grids 16×8×16 … 32×32×32, 32 … 256 rays per probe;
    /// GPU timestamps of the trace pass alone) and the CPU cost of TLAS updates when instances move.
    #[command(
        after_long_help = "Examples:\n  game_demo bench trace --scene cathedral --iterations 15 --no-flat-rebuild\n  game_demo bench trace --scene forest --cpu-only   # the TLAS refit for moving instances only\n  game_demo bench trace --scene forest --iterations 15 --no-flat-rebuild --cpu-only --gpu-refit   # CPU refit against GPU refit (CPU ms)\n  game_demo bench trace --scene forest --rebraid 4   # a re-braided TLAS (up to 4 primitives an instance)\n  game_demo bench trace --scene cathedral --no-flat-rebuild --static-groups off   # each instance entered on its own, no static groups\n  game_demo bench trace --scene cathedral --work-only --no-flat-rebuild --blas-build medium   # BLASes built as before 2026-12-05\n  game_demo bench trace --scene forest --work-only --no-flat-rebuild   # traversal work per ray, no timing\n  game_demo bench trace --scene cathedral --no-flat-rebuild --shared-stack 8   # the stack's top 8 entries in workgroup memory against function memory\n  game_demo bench trace --scene cathedral --no-flat-rebuild --persistent-groups 4224 --workgroup-size 128 --ray-order coherent --subgroup-postpone 0.2,0.35,0.5   # postponed triangle tests at three thresholds against tests at once\n  game_demo bench trace --scene cathedral --work-only --no-flat-rebuild --ray-order coherent --workgroup-size 32 --packet workgroup   # packets of 32 rays walking as one: their work a lane against a ray a lane"
    )]
    Trace(trace::TraceArgs),
    /// Full DDGI update throughput (rays per second of the budget, generation, trace, shading, map
    /// updates, borders, relocation and classification; every probe active) for grids 16×8×16 … 32×32×32
    /// and 32 … 256 rays per probe, the per-pass times, and the final gather at the camera's size.
    #[command(
        after_long_help = "Examples:\n  game_demo bench ddgi --scene cathedral\n  game_demo bench ddgi --scene level --probes 16,8,16 --probes 32,8,32 --rays 128\n  game_demo bench ddgi --scene cornell --probes 8,4,8 --rays 64 --json out/bench_ddgi.json --trace out/bench_ddgi_trace.json\n  game_demo bench ddgi --scene cathedral --probes 32,32,32 --rays 256 --persistent-trace"
    )]
    Ddgi(ddgi::DdgiArgs),
    /// DDGI's classification (adaptive budgets on) against an independent test with GPU rays: how
    /// many probes inside solid geometry are switched off, and how many probes that a visible
    /// surface depends on are.
    #[command(
        after_long_help = "Examples:\n  game_demo bench classify --scene cathedral\n  game_demo bench classify --scene cathedral --probes 32,16,32"
    )]
    Classify(classify::ClassifyArgs),
}

/// Runs the benchmark `command` names.
pub fn run(command: BenchCommand) -> Result<(), String> {
    match command {
        BenchCommand::Walk(args) => walk::run(args),
        BenchCommand::Trace(args) => trace::run(args),
        BenchCommand::Ddgi(args) => ddgi::run(args),
        BenchCommand::Classify(args) => classify::run(args),
    }
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

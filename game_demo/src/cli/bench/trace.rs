//! `bench trace`: closest-hit throughput of probe-like rays, traversal work and the CPU cost of
//! TLAS updates.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};
use lab::bench;

use super::{print_grid_table, write_json};
use crate::cli::load;

#[derive(clap::Args)]
pub struct TraceArgs {
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
}

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

pub fn run(args: TraceArgs) -> Result<(), String> {
    let ray_order = match args.ray_order {
        RayOrderArg::Fibonacci => bench::RayOrder::Fibonacci,
        RayOrderArg::Coherent => bench::RayOrder::Coherent,
    };
    let variant = bench::TraceVariant {
        ray_order,
        workgroup_size: args.workgroup_size,
        persistent_groups: args.persistent_groups,
        ..Default::default()
    };
    let packets: Vec<bench::PacketScope> = args
        .packet
        .iter()
        .map(|p| match p {
            PacketArg::Subgroup => bench::PacketScope::Subgroup,
            PacketArg::Workgroup => bench::PacketScope::Workgroup,
        })
        .collect();
    let variants = Variants::new(variant, args.shared_stack, &args.subgroup_postpone, args.subgroup_fetch, &packets);
    let (name, iterations, rebraid) = (args.scene.as_str(), args.iterations, args.rebraid);
    let blas_build = engine::rt::BlasBuildQuality::from(args.blas_build);
    let static_groups = engine::rt::StaticGrouping::from(args.static_groups);
    let scene = load(name)?;
    let bounds = bench::world_bounds(&scene).ok_or("the scene has no geometry")?;
    let triangles = scene.instanced_triangle_count();
    // Subgroup operations only where a variant uses them (the device is then the same for all).
    let subgroups = !args.subgroup_postpone.is_empty() || args.subgroup_fetch || packets.contains(&bench::PacketScope::Subgroup);
    let gpu = GpuContext::new(GpuOptions { subgroups, ..Default::default() }).map_err(|e| e.to_string())?;
    let started = std::time::Instant::now();
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
    if !args.cpu_only && !args.work_only {
        throughput(&gpu, &app, bounds, iterations, &variants, &mut report)?;
    }
    if !args.cpu_only {
        traversal_work(&gpu, &app, bounds, &variants, &mut report)?;
    }
    if args.work_only {
        return write_json(args.json.as_deref(), report);
    }
    tlas_updates(&mut app, &args, &mut report);
    if !args.no_flat_rebuild {
        let (t, n) = bench::flat_rebuild_cost(&mut app);
        println!("\nfull rebuild of one flat CWBVH over all {n} world-space triangles: {:.1} ms", t.as_secs_f64() * 1e3);
        report["flat_rebuild"] = serde_json::json!({"triangles": n, "ms": t.as_secs_f64() * 1e3});
    }
    write_json(args.json.as_deref(), report)
}

/// The variants of the kernel timed and counted, and which of their differences the tables' titles name.
struct Variants {
    all: Vec<bench::TraceVariant>,
    shared_stack: Option<u32>,
    postpone: bool,
    fetch: bool,
    packets: bool,
}

impl Variants {
    fn new(variant: bench::TraceVariant, shared_stack: Option<u32>, postpone: &[f32], fetch: bool, packets: &[bench::PacketScope]) -> Self {
        // The variants timed and counted: the one asked for, then the same with a shared stack, then
        // the same with triangle tests postponed at each share asked for.
        let mut variants = vec![variant];
        if let Some(k) = shared_stack {
            variants.push(bench::TraceVariant { shared_stack_entries: k, ..variant });
        }
        for &share in postpone {
            variants.push(bench::TraceVariant { postpone_triangles: Some(share), ..variant });
        }
        // Then each of those without a shared stack again, with dynamic fetch.
        if fetch {
            let unfetched: Vec<_> = variants.iter().filter(|v| v.shared_stack_entries == 0).copied().collect();
            variants.extend(unfetched.into_iter().map(|v| bench::TraceVariant { subgroup_fetch: true, ..v }));
        }
        // Then packets of each scope asked for.
        for &scope in packets {
            variants.push(bench::TraceVariant { packet: Some(scope), ..variant });
        }
        Variants { all: variants, shared_stack, postpone: !postpone.is_empty(), fetch, packets: !packets.is_empty() }
    }

    /// What sets `v` apart from the others, as the tables' titles say it.
    fn name(&self, v: &bench::TraceVariant) -> String {
        let mut parts = Vec::new();
        if self.shared_stack.is_some() {
            parts.push(match v.shared_stack_entries {
                0 => "stack in function memory".to_string(),
                k => format!("top {k} stack entries in workgroup memory"),
            });
        }
        if self.postpone {
            parts.push(match v.postpone_triangles {
                None => "triangle tests at once".to_string(),
                Some(share) => format!("triangle tests postponed below {:.0}% of a subgroup's lanes", 100.0 * share),
            });
        }
        if self.fetch {
            parts.push(if v.subgroup_fetch { "one fetch a subgroup" } else { "one fetch a lane" }.to_string());
        }
        if self.packets {
            parts.push(match v.packet {
                None => "a walk a ray".to_string(),
                Some(bench::PacketScope::Subgroup) => "a walk a subgroup (packets)".to_string(),
                Some(bench::PacketScope::Workgroup) => format!("a walk a workgroup of {} (packets)", v.workgroup_size),
            });
        }
        parts.join(", ")
    }
}

type Bounds = (glam::DVec3, glam::DVec3);

/// The closest-hit throughput tables of every variant, and their ratios to the first's.
fn throughput(
    gpu: &GpuContext,
    app: &engine::bevy_app::App,
    bounds: Bounds,
    iterations: u32,
    variants: &Variants,
    report: &mut serde_json::Value,
) -> Result<(), String> {
    let tables = bench::trace_throughput_compared(gpu, app, bounds, iterations.max(1), &variants.all)?;
    let json_cells = |cells: &[bench::TraceCell]| -> serde_json::Value {
        cells
        .iter()
        .map(|c| serde_json::json!({"probes": c.grid, "rays_per_probe": c.rays_per_probe, "rays": c.rays, "median_ms": c.median_ms, "mrays_per_second": c.mrays_per_second()}))
        .collect()
    };
    report["throughput"] = json_cells(&tables[0]);
    if let Some(k) = variants.shared_stack {
        report["shared_stack_entries"] = serde_json::json!(k);
        report["throughput_shared_stack"] = json_cells(&tables[1]);
    }
    if variants.postpone || variants.fetch {
        report["throughput_subgroup"] = variants
        .all
        .iter()
        .zip(&tables)
        .filter(|(v, _)| v.uses_subgroups())
        .map(|(v, cells)| {
            serde_json::json!({"postpone_share": v.postpone_triangles, "subgroup_fetch": v.subgroup_fetch, "throughput": json_cells(cells)})
        })
        .collect();
    }
    let print_table = |cells: &[bench::TraceCell], cell: &dyn Fn(&bench::TraceCell) -> String| {
        print_grid_table(&bench::GRIDS, &bench::RAYS, |g, rays| cells.iter().find(|c| c.grid == *g && c.rays_per_probe == rays).map(cell));
    };
    for (v, cells) in variants.all.iter().zip(&tables) {
        let which = if variants.all.len() > 1 { format!(", {}", variants.name(v)) } else { String::new() };
        println!("\n## Closest-hit probe rays, MRays/s (median of {iterations} dispatches, trace pass GPU time{which})\n");
        print_table(cells, &|c| format!("{:.0} ({:.3} ms)", c.mrays_per_second(), c.median_ms));
    }
    if let [default, others @ ..] = tables.as_slice() {
        for (v, other) in variants.all[1..].iter().zip(others) {
            println!("\n## {} against {}, same run: throughput ratio\n", variants.name(v), variants.name(&variants.all[0]));
            print_table(other, &|c| {
                default
                    .iter()
                    .find(|d| d.grid == c.grid && d.rays_per_probe == c.rays_per_probe)
                    .map_or("-".into(), |d| format!("{:.3}", d.median_ms / c.median_ms))
            });
        }
    }
    Ok(())
}

/// The traversal work per ray of every variant (but dynamic fetch's) at 32×8×32 probes, 128 rays.
fn traversal_work(
    gpu: &GpuContext,
    app: &engine::bevy_app::App,
    bounds: Bounds,
    variants: &Variants,
    report: &mut serde_json::Value,
) -> Result<(), String> {
    let (grid, rays) = ([32, 8, 32], 128);
    let mut first: Option<bench::TraversalWork> = None;
    let mut postponed_work = Vec::new();
    // Work is counted by the thread-a-ray kernel: dynamic fetch (persistent) changes nothing.
    for v in variants.all.iter().filter(|v| !v.subgroup_fetch) {
        let w = bench::traversal_work(gpu, app, bounds, grid, rays, *v)?;
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
                variants.name(v),
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
                variants.name(v),
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
                variants.name(v),
                w.stack_spills,
                if w.counts() == f.counts() && w.steps == f.steps { "the same walk" } else { "A DIFFERENT WALK (a bug)" }
            ),
        }
        first.get_or_insert(w);
    }
    if !postponed_work.is_empty() {
        report["traversal_work_per_ray_postponed"] = postponed_work.into();
    }
    Ok(())
}

/// The CPU cost of instance and TLAS updates for each count of moving instances (and, with
/// --gpu-refit, of the refit on the GPU).
fn tlas_updates(app: &mut engine::bevy_app::App, args: &TraceArgs, report: &mut serde_json::Value) {
    let (gpu_refit, cpu_only, iterations) = (args.gpu_refit, args.cpu_only, args.iterations);
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
        match bench::tlas_update_cost(app, count, 9) {
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
                    if let Some(g) = bench::tlas_gpu_refit_cost(app, count, 30, timed) {
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
}

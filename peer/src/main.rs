//! `peer`: our DDGI against sgl-3d's dynamic GI (a WGSL port of Wicked Engine's DDGI with a
//! software two-level BVH), on one scene, the same probe grid, rays per probe, resolution and GPU,
//! in one process: each one's DDGI update time and frame time (GPU timestamps: ours from the
//! engine's timing spans, sgl-3d's from its own `GpuTiming`), and each one's final image against our
//! path-traced reference (FLIP, relative MSE, on linear radiance before exposure and tone mapping).
//!
//! The timed runs take turns frame by frame (one frame of every row, then the next frame of every
//! row), so that a change of the GPU's clocks during the run reaches every row alike.
//!
//! Prints a Markdown table, writes `--json` and, in `--out`, each image as EXR and a strip PNG
//! (sgl-3d | ours fixed | ours adaptive | reference). See docs/evaluation.md ("Peer benchmark") for
//! what could not be matched.

mod convert;
mod sgl;

use std::path::{Path, PathBuf};

use clap::Parser;
use engine::bevy_app::App;
use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::{HeadlessSettings, RenderedFrame, render_scene_with};
use lab::eval::{Config, SceneFacts};
use lab::metrics::{ErrorMetrics, compare, tonemap_to_srgb8};
use sgl_3d::settings::DynamicGiQuality;

/// Our DDGI against sgl-3d's dynamic GI: update and frame time, error against a path-traced reference.
#[derive(Parser, Debug)]
#[command(
    after_long_help = "Examples:\n  peer --scene cornell --width 256 --height 256\n  peer --scene level --width 1280 --height 720\n  peer --scene cathedral --width 1280 --height 720 --rays 256 --json out/peer/cathedral.json"
)]
struct Args {
    /// A built-in scene: cornell, cathedral, level (the demo level, with Kenney's models when
    /// ../shared/assets/kenney_fps is there, its own props otherwise), or any of `scenes::ALL`
    /// whose content converts.
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[arg(long, default_value_t = 256)]
    width: u32,
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Frames each renderer runs, the timed rows taking turns frame by frame; the image is the
    /// last one (the evaluation's 120 by default).
    #[arg(long, default_value_t = lab::eval::DDGI_FRAMES)]
    frames: u32,
    /// Frames left out of the medians at the start (probes starting, pipelines compiling).
    #[arg(long, default_value_t = 10)]
    skip: u32,
    /// Probes along x, y and z, `X,Y,Z` (default: the evaluation's grid for the scene).
    #[arg(long, value_parser = parse_grid)]
    probes: Option<[u32; 3]>,
    /// Rays per probe: 128 or 256, the two that sgl-3d offers (its Low and High most rays a turn).
    #[arg(long, default_value_t = 128)]
    rays: u32,
    /// Paths per pixel of the reference.
    #[arg(long, default_value_t = 4096)]
    reference_spp: u32,
    /// Folder of cached references (the evaluation's).
    #[arg(long, default_value = "out/eval/cache")]
    cache: PathBuf,
    /// Folder of the images.
    #[arg(long, default_value = "out/peer")]
    out: PathBuf,
    /// Also write the table and every frame's times as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Rows of ours with adaptive budgets capped at these shares of the rays sgl-3d traced per
    /// update, `S[,S…]` (1: at its count; each in (0, 16]). Below 1 they compare the two at equal
    /// or lower error with fewer rays than sgl-3d's; above 1, what more rays than sgl-3d's buy.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    ours_at_shares: Vec<f64>,
    /// Leave out the sgl-3d row whose volume is kept awake (a light changed by one part in a
    /// million every other frame, so it never pauses).
    #[arg(long)]
    no_awake: bool,
}

/// A probe grid ([`lab::parse_uvec3`]) of at least 2 probes along each axis (sgl-3d's least).
fn parse_grid(text: &str) -> Result<[u32; 3], String> {
    let grid = lab::parse_uvec3(text)?;
    if grid.cmplt(engine::glam::UVec3::splat(2)).any() {
        return Err(format!("expected X,Y,Z with each at least 2 (sgl-3d's least), got '{text}'"));
    }
    Ok(grid.to_array())
}

/// One row of the table.
#[derive(serde::Serialize)]
struct Row {
    renderer: String,
    /// Median GPU ms of the DDGI update over the frames (after `skip`) that ran it.
    update_ms: Option<f64>,
    /// Frames (after `skip`) that ran an update, of those measured.
    update_frames: usize,
    measured_frames: usize,
    /// Median GPU ms of the whole frame.
    frame_ms: Option<f64>,
    /// Median probe rays traced per frame over the frames that traced any.
    rays_per_update: Option<f64>,
    /// `update_ms / rays_per_update`, in nanoseconds.
    ns_per_ray: Option<f64>,
    error: ErrorMetrics,
    /// Ours only: the median GPU ms of each pass of the DDGI update, over the frames that ran it
    /// (where a small update's time goes: its fixed cost against its rays).
    update_passes: Vec<(String, f64)>,
}

#[derive(serde::Serialize)]
struct Report {
    scene: String,
    adapter: String,
    width: u32,
    height: u32,
    frames: u32,
    skip: u32,
    probes: [u32; 3],
    rays_per_probe: u32,
    bounds: ([f32; 3], [f32; 3]),
    reference_spp: u32,
    rows: Vec<Row>,
    /// Direct light alone, sgl-3d's against ours: how faithful the conversion is.
    conversion: ErrorMetrics,
    notes: Vec<String>,
    unmatched: Vec<String>,
    sgl_frames: Vec<(String, Vec<sgl::SglFrame>)>,
}

fn main() {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("peer: {e}");
        std::process::exit(1);
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    lab::median(&mut v)
}

fn run(args: &Args) -> Result<(), String> {
    if let Some(bad) = args.ours_at_shares.iter().find(|s| !(s.is_finite() && **s > 0.0 && **s <= 16.0)) {
        return Err(format!("--ours-at-shares: each share must be in (0, 16], got {bad}"));
    }
    let quality = match args.rays {
        128 => DynamicGiQuality::Low,
        256 => DynamicGiQuality::High,
        other => return Err(format!("--rays {other}: sgl-3d traces at most 128 (Low) or 256 (High) rays a probe; choose one of them")),
    };
    // The level as `game_demo eval --scene level` renders it: the same description, still, with
    // the sky of every still evaluation (black: `engine::render::Sky`'s default, which neither
    // sets), so that the reference is the evaluation's (the same cache entry).
    let scene = lab::eval::built_in_scene(&args.scene).ok_or_else(|| {
        let names: Vec<_> = lab::eval::built_in_scene_names().collect();
        format!("--scene '{}': not a built-in scene ({})", args.scene, names.join(", "))
    })??;
    let scene = lab::eval::still(scene);
    let facts = SceneFacts::named(&args.scene);
    let grid = args.probes.unwrap_or(facts.paper_grid);
    let bounds = facts.gi_bounds.or_else(|| scene.bounds()).ok_or("the scene has no geometry")?;
    let (w, h) = (args.width, args.height);
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;

    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    println!("GPU: {} (timestamps: {})", gpu.adapter_name(), gpu.timestamps);
    let reference = lab::eval::reference(&gpu, &args.scene, &scene, w, h, args.reference_spp, &args.cache)?;

    let mut rows = Vec::new();
    let mut images: Vec<(String, Vec<f32>)> = Vec::new();
    let mut unmatched = Vec::new();
    let mut sgl_frames = Vec::new();

    // sgl-3d: a timed run and a counted run (its observation adds work to the trace) per variant.
    let extent = (bounds.1 - bounds.0).length().max(scene.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length()));
    let converted = convert::convert(&scene, extent)?;
    unmatched.extend(converted.unmatched.iter().cloned());
    let volume = sgl::lattice(bounds, grid);
    // The conversion's check: both renderers' direct light alone (sgl-3d with its dynamic GI off),
    // which differ only by what docs/evaluation.md lists (shadow maps, Bevy's diffuse lobe).
    let (conversion, brightness) = direct_light_check(&gpu, &converted, &scene, volume, (w, h), &mut images)?;

    let tier = gpu.device.limits().max_sampled_textures_per_shader_stage;
    let in_effect = sgl::SglRenderer::new(
        &gpu,
        &sgl::SglRun { converted: &converted, width: w, height: h, frames: 1, quality, volume, keep_awake: false, observe: false },
    )?
    .dynamic_gi_in_effect();
    let sgl_gi = in_effect == quality;
    let mut notes = Vec::new();
    if !sgl_gi {
        notes.push(format!(
            "sgl-3d's dynamic GI is {:?} on {}: its Basic binding tier (the device has {tier} sampled textures a shader stage, \
             sgl-3d's Extended tier needs 48) runs none, so its rows are left out",
            in_effect,
            gpu.adapter_name()
        ));
    }
    let variants: &[(bool, &str)] = match (sgl_gi, args.no_awake) {
        (false, _) => &[],
        (true, true) => &[(false, "sgl-3d")],
        (true, false) => &[(false, "sgl-3d"), (true, "sgl-3d, kept awake")],
    };
    // sgl-3d's rays a probe per update, counted in runs of their own (its observation adds work to
    // the trace, so the timed runs are not observed), before the timed runs.
    let counted_rays = count_sgl_rays(&gpu, args, &converted, quality, volume, variants)?;

    let ours = ours_volumes(args, bounds, grid, counted_rays.first().copied().flatten());

    // The timed runs, interleaved: every row renders its frame 0, then every row its frame 1, and
    // so on, each frame waited for before the next row's.
    let mut runners = Vec::new();
    for &(keep_awake, name) in variants {
        let job =
            sgl::SglRun { converted: &converted, width: w, height: h, frames: args.frames, quality, volume, keep_awake, observe: false };
        runners.push((name.to_string(), Runner::Sgl(Box::new(sgl::SglRenderer::new(&gpu, &job)?))));
    }
    let configs = ours_apps(&gpu, args, &scene, ours, &mut runners)?;
    let names: Vec<String> = runners.iter().map(|(name, _)| name.clone()).collect();
    println!("timed runs, interleaved frame by frame: {} frames of {}…", args.frames, names.join(" | "));
    step_interleaved(&gpu, &mut runners, args.frames)?;
    let mut configs = configs.into_iter();
    for ((name, runner), rays) in runners.into_iter().zip(counted_rays.into_iter().map(Some).chain(std::iter::repeat(None))) {
        match runner {
            Runner::Sgl(sgl) => {
                let (row, hdr, frames) = sgl_row(&gpu, args, &reference, &name, *sgl, rays.flatten())?;
                rows.push(row);
                images.push((image_name(&name), hdr));
                sgl_frames.push((name, frames));
            }
            Runner::Ours(app) => {
                let config = configs.next().ok_or("a row of ours without its configuration")?;
                let frame = engine::headless::read_frame(&gpu, app.world());
                rows.push(ours_row(&config, frame, args, &reference, &mut images));
            }
        }
    }

    let failures = check(&rows, &images);
    notes.push(format!(
        "The timed rows ran interleaved, frame by frame ({}), each frame waited for before the next row's, so that the \
         GPU's clocks changing during the run reach every row alike.",
        names.join("; ")
    ));
    notes.push(format!(
        "Conversion check, direct light alone (sgl-3d's dynamic GI off) against ours: mean FLIP {:.4}, relative MSE {:.5}, \
         mean radiance sgl-3d / ours {brightness:.4}.",
        conversion.mean_flip, conversion.relative_mse
    ));
    let mut table = table(args, &gpu.adapter_name(), grid, &rows);
    for note in &notes {
        table += &format!("\n{note}\n");
    }
    println!("\n{table}");
    if !unmatched.is_empty() {
        println!("Not carried over to sgl-3d: {}", unmatched.join("; "));
    }
    images.push(("reference".into(), reference.clone()));
    write_images(&args.out, &args.scene, w, h, &images)?;
    std::fs::write(args.out.join(format!("{}.md", args.scene)), &table).map_err(|e| e.to_string())?;
    if let Some(path) = &args.json {
        let report = Report {
            scene: args.scene.clone(),
            adapter: gpu.adapter_name(),
            width: w,
            height: h,
            frames: args.frames,
            skip: args.skip,
            probes: grid,
            rays_per_probe: args.rays,
            bounds: (bounds.0.to_array(), bounds.1.to_array()),
            reference_spp: args.reference_spp,
            rows,
            conversion,
            notes,
            unmatched,
            sgl_frames,
        };
        write_json(path, &report)?;
    }
    if failures.is_empty() { Ok(()) } else { Err(format!("the comparison is not sound: {}", failures.join("; "))) }
}

/// The conversion's check: both renderers' direct light alone (sgl-3d with its dynamic GI off),
/// which differ only by what docs/evaluation.md lists (shadow maps, Bevy's diffuse lobe). Returns
/// the comparison and sgl-3d's mean radiance over ours; both images go to `images`.
fn direct_light_check(
    gpu: &GpuContext,
    converted: &convert::Converted,
    scene: &engine::scene::SceneDescription,
    volume: sgl_3d::DynamicGiVolume,
    (w, h): (u32, u32),
    images: &mut Vec<(String, Vec<f32>)>,
) -> Result<(ErrorMetrics, f64), String> {
    println!("direct light only: sgl-3d and ours…");
    let sgl_direct = sgl::run(
        gpu,
        &sgl::SglRun {
            converted,
            width: w,
            height: h,
            frames: 2,
            quality: DynamicGiQuality::Off,
            volume,
            keep_awake: false,
            observe: false,
        },
    )?;
    let ours_direct =
        render_scene_with(gpu, scene.clone(), &HeadlessSettings { width: w, height: h, frames: 1, ..Default::default() }, |_| {})
            .map_err(|e| e.to_string())?;
    let conversion = compare(&ours_direct.hdr, &sgl_direct.hdr, w, h, 1.0);
    let mean = |hdr: &[f32]| hdr.chunks_exact(4).map(|p| f64::from(p[0] + p[1] + p[2])).sum::<f64>() / (3 * hdr.len() / 4).max(1) as f64;
    let brightness = mean(&sgl_direct.hdr) / mean(&ours_direct.hdr);
    images.push(("sgl-3d_direct".into(), sgl_direct.hdr));
    images.push(("ours_direct".into(), ours_direct.hdr));
    Ok((conversion, brightness))
}

/// Our rows: the fixed budget and adaptive budgets on sgl-3d's grid, bounds, rays and map sizes, and
/// adaptive budgets capped at `--ours-at-shares` of the rays sgl-3d traced per update (`sgl_rays`).
fn ours_volumes(args: &Args, bounds: (glam::Vec3, glam::Vec3), grid: [u32; 3], sgl_rays: Option<f64>) -> Vec<(String, ddgi::DdgiVolume)> {
    // Ours: the fixed budget and adaptive budgets, on the same grid and bounds, rays and map sizes.
    let bounds_d = (bounds.0.as_dvec3(), bounds.1.as_dvec3());
    let base = ddgi::DdgiVolume {
        bounds: Some(bounds_d),
        probe_counts: Some(grid.into()),
        rays_per_probe: args.rays,
        // sgl-3d's maps: 6×6 irradiance texels and 16×16 depth texels a probe (plus borders).
        irradiance_texels: 6,
        distance_texels: 16,
        ..Default::default()
    };
    let mut ours = vec![
        ("ours, fixed".to_string(), ddgi::DdgiVolume { adaptive: ddgi::DdgiAdaptive::off(), ..base.clone() }),
        (
            "ours, adaptive".to_string(),
            ddgi::DdgiVolume { adaptive: ddgi::DdgiAdaptive { enabled: true, ..Default::default() }, ..base.clone() },
        ),
    ];
    // Ours at sgl-3d's ray count: adaptive budgets capped at the rays sgl-3d traced per update
    // (its own frame cap and update periods), so that both are compared per update at one count.
    if let Some(rays) = sgl_rays.filter(|r| r.is_finite() && *r >= 1.0) {
        for &share in &args.ours_at_shares {
            let budget = (rays * share).round().max(1.0) as u32;
            let adaptive = ddgi::DdgiAdaptive { enabled: true, frame_budget: Some(budget), ..Default::default() };
            let whose = if share == 1.0 { "sgl-3d's".to_string() } else { format!("{share} × sgl-3d's") };
            ours.push((format!("ours, adaptive, {budget} rays a frame ({whose})"), ddgi::DdgiVolume { adaptive, ..base.clone() }));
        }
    }
    ours
}

/// Every runner renders its frame 0, then every runner its frame 1, and so on, `frames` times.
fn step_interleaved(gpu: &GpuContext, runners: &mut [(String, Runner)], frames: u32) -> Result<(), String> {
    for _ in 0..frames {
        for (name, runner) in runners.iter_mut() {
            match runner {
                Runner::Sgl(sgl) => sgl.step(gpu)?,
                Runner::Ours(app) => {
                    app.update();
                    if let Some(exit) = app.should_exit() {
                        return Err(format!("{name}: the app exited ({exit:?})"));
                    }
                }
            }
        }
    }
    Ok(())
}

/// sgl-3d's row from its timed run, with its image and frames; `rays`: its rays per update, counted
/// in a run of its own.
fn sgl_row(
    gpu: &GpuContext,
    args: &Args,
    reference: &[f32],
    name: &str,
    sgl: sgl::SglRenderer,
    rays: Option<f64>,
) -> Result<(Row, Vec<f32>, Vec<sgl::SglFrame>), String> {
    let timed = sgl.finish(gpu)?;
    let (update_ms, frame_ms, update_frames, measured_frames) = sgl::summary(&timed.frames, u64::from(args.skip));
    let error = compare(reference, &timed.hdr, args.width, args.height, 1.0);
    let row = Row {
        renderer: name.to_string(),
        update_ms,
        update_frames,
        measured_frames,
        frame_ms,
        rays_per_update: rays,
        ns_per_ray: update_ms.zip(rays).map(|(ms, r)| ms * 1e6 / r),
        error,
        update_passes: Vec::new(),
    };
    Ok((row, timed.hdr, timed.frames))
}

/// Writes `report` as JSON to `path`, making its folder.
fn write_json(path: &Path, report: &Report) -> Result<(), String> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
    println!("wrote {}", path.display());
    Ok(())
}

/// Our rows' apps, one per volume, added to `runners`; returns their configurations in order.
fn ours_apps(
    gpu: &GpuContext,
    args: &Args,
    scene: &engine::scene::SceneDescription,
    ours: Vec<(String, ddgi::DdgiVolume)>,
    runners: &mut Vec<(String, Runner)>,
) -> Result<Vec<Config>, String> {
    let seed = pathtrace::PathTraceSettings::default().seed;
    let settings = HeadlessSettings { width: args.width, height: args.height, frames: args.frames, ..Default::default() };
    let mut configs = Vec::new();
    for (name, volume) in ours {
        let config = Config::Ddgi { name: name.clone(), volume: Box::new(volume), occlusion: Default::default(), taa: false };
        let mut app =
            engine::headless::scene_app(gpu, scene.clone(), &settings, |app| config.configure(app, seed)).map_err(|e| e.to_string())?;
        engine::app::finish_plugins(&mut app);
        runners.push((name, Runner::Ours(Box::new(app))));
        configs.push(config);
    }
    Ok(configs)
}

/// sgl-3d's median rays per update for each of `variants` (kept awake or not), counted in observed
/// runs of their own.
fn count_sgl_rays(
    gpu: &GpuContext,
    args: &Args,
    converted: &convert::Converted,
    quality: DynamicGiQuality,
    volume: sgl_3d::DynamicGiVolume,
    variants: &[(bool, &str)],
) -> Result<Vec<Option<f64>>, String> {
    let (width, height, frames) = (args.width, args.height, args.frames);
    let mut counted_rays = Vec::new();
    for &(keep_awake, name) in variants {
        println!("{name}: counting its rays, {frames} frames…");
        let counted = sgl::run(gpu, &sgl::SglRun { converted, width, height, frames, quality, volume, keep_awake, observe: true })?;
        counted_rays.push(median(
            counted.reports.iter().filter(|r| r.frame >= u64::from(args.skip) && r.rays > 0).map(|r| f64::from(r.rays)).collect(),
        ));
    }
    Ok(counted_rays)
}

/// What makes a run's figures meaningless: a non-finite or black image, or a renderer whose probes
/// never updated in the measured frames (written out all the same, for a look).
fn check(rows: &[Row], images: &[(String, Vec<f32>)]) -> Vec<String> {
    let mut failures = Vec::new();
    for (name, hdr) in images {
        let bad = hdr.iter().filter(|v| !v.is_finite()).count();
        if bad > 0 {
            failures.push(format!("{name}: {bad} non-finite values"));
        }
        let mean = hdr.chunks_exact(4).map(|p| f64::from(p[0] + p[1] + p[2])).sum::<f64>() / hdr.len().max(1) as f64;
        if mean.is_nan() || mean <= 0.0 {
            failures.push(format!("{name}: black image"));
        }
    }
    // sgl-3d on a still scene may pause for good before the measured frames: only its kept-awake
    // row must update.
    for r in rows.iter().filter(|r| r.update_frames == 0 && r.renderer != "sgl-3d") {
        if r.frame_ms.is_some() {
            failures.push(format!("{}: no DDGI update in the measured frames", r.renderer));
        }
    }
    failures
}

/// A timed run: sgl-3d's renderer, or our app, stepped a frame at a time.
enum Runner<'a> {
    Sgl(Box<sgl::SglRenderer<'a>>),
    Ours(Box<App>),
}

/// The row of our DDGI's `config` from its last frame and its frames' timings.
fn ours_row(config: &Config, frame: RenderedFrame, args: &Args, reference: &[f32], images: &mut Vec<(String, Vec<f32>)>) -> Row {
    let kept: Vec<_> = frame.timings.iter().filter(|t| t.frame >= u64::from(args.skip)).collect();
    let updates: Vec<f64> = kept
        .iter()
        .filter_map(|t| {
            let ms: Vec<f64> = t
                .passes
                .iter()
                .filter(|p| p.ran && lab::bench::DDGI_UPDATE_PASSES.contains(&p.label.as_str()))
                .filter_map(|p| p.gpu_ms)
                .collect();
            (!ms.is_empty()).then(|| ms.iter().sum())
        })
        .collect();
    let totals: Vec<f64> = kept
        .iter()
        .filter_map(|t| {
            let ms: Vec<f64> = t.passes.iter().filter(|p| p.ran).filter_map(|p| p.gpu_ms).collect();
            (!ms.is_empty()).then(|| ms.iter().sum())
        })
        .collect();
    let rays = median(kept.iter().filter_map(|t| ddgi::rays_traced(t)).filter(|&r| r > 0.0).collect());
    let update_passes = lab::bench::DDGI_UPDATE_PASSES
        .iter()
        .filter_map(|&label| {
            let ms = kept.iter().flat_map(|t| &t.passes).filter(|p| p.ran && p.label == label).filter_map(|p| p.gpu_ms).collect();
            median(ms).map(|ms| (label.to_string(), ms))
        })
        .collect();
    let update_frames = updates.len();
    let update_ms = median(updates);
    let error = compare(reference, &frame.hdr, args.width, args.height, 1.0);
    images.push((image_name(&config.name()), frame.hdr));
    Row {
        renderer: config.name(),
        update_ms,
        update_frames,
        measured_frames: kept.len(),
        frame_ms: median(totals),
        rays_per_update: rays,
        ns_per_ray: update_ms.zip(rays).map(|(ms, r)| ms * 1e6 / r),
        error,
        update_passes,
    }
}

fn table(args: &Args, adapter: &str, grid: [u32; 3], rows: &[Row]) -> String {
    let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
    let mut md = format!(
        "# Peer benchmark: {} at {}×{} on {adapter}\n\n{}×{}×{} probes, {} rays a probe (sgl-3d: its most a turn), {} frames, medians over frames {}–{}; \
         error against the path tracer at {} paths per pixel, on linear radiance before exposure (FLIP on both tonemapped at exposure 1).\n\n\
         | renderer | DDGI update ms | frames updating | frame ms | probe rays per update | ns per ray | mean FLIP | relative MSE |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|\n",
        args.scene,
        args.width,
        args.height,
        grid[0],
        grid[1],
        grid[2],
        args.rays,
        args.frames,
        args.skip,
        args.frames.saturating_sub(1),
        args.reference_spp
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {}/{} | {} | {} | {} | {:.4} | {:.5} |\n",
            r.renderer,
            ms(r.update_ms),
            r.update_frames,
            r.measured_frames,
            ms(r.frame_ms),
            r.rays_per_update.map_or("n/a".into(), |v| format!("{v:.0}")),
            r.ns_per_ray.map_or("n/a".into(), |v| format!("{v:.2}")),
            r.error.mean_flip,
            r.error.relative_mse
        );
    }
    for r in rows.iter().filter(|r| !r.update_passes.is_empty()) {
        let passes: Vec<String> = r.update_passes.iter().map(|(label, ms)| format!("{label} {ms:.3}")).collect();
        md += &format!("\n{}: median GPU ms of each update pass: {}.\n", r.renderer, passes.join(", "));
    }
    md
}

/// A row's name as a file name: commas and spaces as single underscores.
fn image_name(renderer: &str) -> String {
    renderer.replace([',', ' '], "_").replace("__", "_")
}

/// Each image as `<scene>_<name>.exr` (linear) and all of them side by side in `<scene>.png`
/// (tonemapped at exposure 1, sRGB), in the table's order with the reference last.
fn write_images(out: &Path, scene: &str, w: u32, h: u32, images: &[(String, Vec<f32>)]) -> Result<(), String> {
    let mut panels = Vec::new();
    for (name, hdr) in images {
        lab::eval::save_exr(&out.join(format!("{scene}_{name}.exr")), hdr, w, h)?;
        panels.push(tonemap_to_srgb8(hdr, 1.0));
    }
    let path = out.join(format!("{scene}.png"));
    lab::eval::save_strip(&path, &panels, w, h)?;
    println!("images: {} (sgl-3d rows, ours, reference)", path.display());
    Ok(())
}

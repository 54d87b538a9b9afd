//! `game_demo eval`: error against a path-traced reference and GPU time, for every configuration of
//! a list. Writes `report.md`, `results.json`, `error_vs_time.png` and, per configuration, a strip
//! of four panels: direct only | the method | the reference | the FLIP error map (magma).
//! `--time-series` measures instead every frame after a change in the scene ([`time_series`]), and
//! `--time-series --walk` every frame of a walk through it ([`walk_series`]).
//!
//! The configurations and how each one renders are all in [`Config`] (`eval/config.rs`); what the
//! evaluation knows of a scene is its [`SceneFacts`] (`eval/scene_facts.rs`); the cached
//! path-traced references are in `eval/references.rs` ([`reference`]) and the still evaluation's
//! results, its plot and its report in `eval/report.rs` ([`EvalRow`]).

mod config;
pub mod grid_sweep;
mod references;
mod report;
mod scene_facts;
pub mod time_series;
pub mod walk_series;

use std::path::PathBuf;

use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, RenderedFrame, add_default_camera, render_scene_with};
use engine::render::FrameTiming;
use engine::scene::SceneDescription;

use crate::metrics::{compare, flip_rgb8, magma, tonemap_to_srgb8};

pub use config::{Config, DDGI_DENSITIES, DDGI_FRAMES, DDGI_RESOLUTIONS};
pub(crate) use references::cached_image;
pub use references::{reference, reference_path, save_exr};
use report::write;
pub use report::{EqualFlip, EvalRow, LadderPosition, save_strip, spp_at_equal_flip};
use report::{equal_flip, plot_error_vs_time, spp_text, write_report};
pub use scene_facts::{PrepareChange, SceneFacts, built_in_scene, built_in_scene_names, ddgi_paper_grid};

/// Paths per pixel of the path tracer configurations compared with the reference: the ladder on
/// which [`spp_at_equal_flip`] finds each DDGI configuration's equal.
pub const PATH_TRACE_LADDER: [u32; 4] = [1, 4, 16, 64];
/// Paths per pixel of the path tracer timed at [`EvalOptions::timing_size`] (two frames of 16):
/// its GPU ms per path per pixel there.
pub const TIMING_SPP: u32 = 32;
/// The size at which `game_demo eval` times the path tracer and DDGI besides the evaluation's own.
pub const DISPLAY_SIZE: [u32; 2] = [1920, 1080];
/// Most paths per pixel the path tracer adds in one frame; more take several frames.
const SAMPLES_PER_FRAME: u32 = 16;
/// Paths per pixel per frame of the path tracer in the time series.
const TIME_SERIES_SPP: u32 = 4;
/// Seed of the reference: another than the configurations', so that their noise is not the reference's.
const REFERENCE_SEED: u32 = 0xC0DE;
/// Exposure at which FLIP compares images.
const EXPOSURE: f32 = 1.0;

/// What to evaluate and where to write it.
pub struct EvalOptions {
    pub width: u32,
    pub height: u32,
    /// Paths per pixel of the reference.
    pub reference_spp: u32,
    /// Folder of the report.
    pub out: PathBuf,
    /// Folder of cached references.
    pub cache: PathBuf,
    /// Also DDGI's quality table (probe densities × map resolutions) and weight ablation.
    pub experiments: bool,
    /// The parameters of the adaptive-budget configuration (switched on whatever `enabled` says).
    pub adaptive: ddgi::DdgiAdaptive,
    /// The probe grid of the fixed- and adaptive-budget configurations (default: the published grid).
    pub grid: Option<[u32; 3]>,
    /// Time series: frames DDGI runs before the change (it must have settled: the static phase is
    /// measured at their end).
    pub settle_frames: u32,
    /// Also DDGI with these camera-following cascades (`--cascades N`).
    pub cascades: Option<ddgi::DdgiCascades>,
    /// Width and height at which the still evaluation also times the path tracer
    /// ([`TIMING_SPP`]) and each DDGI configuration, for their GPU-time ratio at equal FLIP at a
    /// display's size ([`DISPLAY_SIZE`] in `game_demo eval`); `None`: only at `width × height`.
    pub timing_size: Option<[u32; 2]>,
    /// Hit occlusion rays of every DDGI configuration's probe rays
    /// ([`ddgi::DdgiVolume::hit_occlusion_rays`]; 0: off, the default).
    pub hit_occlusion_rays: u32,
    /// Their reach, a share of the smallest probe spacing
    /// ([`ddgi::DdgiVolume::hit_occlusion_reach`]; the volume's default, 0.5, unless set).
    pub hit_occlusion_reach: f32,
}

/// `config` on `scene`, `frames` frames (usually [`Config::frames`]), the last one returned.
fn render(
    gpu: &GpuContext,
    scene: &SceneDescription,
    config: &Config,
    width: u32,
    height: u32,
    seed: u32,
    frames: u32,
) -> Result<RenderedFrame, String> {
    let settings = HeadlessSettings { width, height, frames, ..Default::default() };
    let bar = crate::progress::bar(u64::from(settings.frames), config.name(), "frames");
    let frame = render_scene_with(gpu, scene.clone(), &settings, |app| {
        config.configure(app, seed);
        crate::progress::tick_every_frame(app, &bar);
    });
    bar.finish_and_clear();
    frame.map_err(|e| e.to_string())
}

/// GPU milliseconds of one frame: the sum over the passes that ran; `None` without timestamps.
fn frame_gpu_ms(frame: &FrameTiming) -> Option<f64> {
    frame.passes.iter().filter(|p| p.ran).map(|p| p.gpu_ms).sum()
}

/// DDGI's mean rays per frame over `frame`'s timings ([`ddgi::rays_traced`]: every volume's), or
/// `None` when no frame has a count.
fn rays_per_frame(frame: &RenderedFrame) -> Option<f64> {
    let per_frame: Vec<f64> = frame.timings.iter().filter_map(ddgi::rays_traced).collect();
    (!per_frame.is_empty()).then(|| per_frame.iter().sum::<f64>() / per_frame.len() as f64)
}

fn gpu_ms(frame: &RenderedFrame) -> (Option<f64>, Option<f64>) {
    let per_frame: Vec<f64> = frame.timings.iter().filter_map(frame_gpu_ms).collect();
    if per_frame.is_empty() {
        return (None, None);
    }
    let total: f64 = per_frame.iter().sum();
    (Some(total / per_frame.len() as f64), Some(total))
}

/// What the evaluation renders of `scene`: with a camera (the default one if it has none), and
/// animations stopped where they start, so that every configuration and the reference see the
/// same still scene.
pub fn still(mut scene: SceneDescription) -> SceneDescription {
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    for node in &mut scene.nodes {
        node.orbit = None;
    }
    scene
}

/// Runs the evaluation of `scene` (described by `facts`) and writes the report.
pub fn run(gpu: &GpuContext, facts: &SceneFacts, scene: SceneDescription, options: &EvalOptions) -> Result<Vec<EvalRow>, String> {
    let name = facts.name.as_str();
    let EvalOptions { width, height, reference_spp, ref out, ref cache, experiments, ref adaptive, grid, .. } = *options;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let scene = still(scene);
    let reference = reference(gpu, name, &scene, width, height, reference_spp, cache)?;
    let reference_ldr = tonemap_to_srgb8(&reference, EXPOSURE);
    let mut rows = Vec::new();
    let mut direct_ldr: Option<Vec<u8>> = None;
    let list: Vec<Config> = Config::for_scene(Config::still_list(facts, experiments, grid, adaptive), &scene, options.cascades.as_ref())
        .into_iter()
        .map(|c| c.with_hit_occlusion(options.hit_occlusion_rays, options.hit_occlusion_reach))
        .collect();
    let seed = pathtrace::PathTraceSettings::default().seed;
    // The path tracer's GPU ms per path per pixel at the timing size, timed once the first DDGI
    // configuration needs it.
    let mut timing_ms_per_spp: Option<Option<f64>> = None;
    for config in list {
        let frame = render(gpu, &scene, &config, width, height, seed, config.frames())?;
        let error = compare(&reference, &frame.hdr, width, height, EXPOSURE);
        let (per_frame, total) = gpu_ms(&frame);
        let ldr = tonemap_to_srgb8(&frame.hdr, EXPOSURE);
        let direct = direct_ldr.get_or_insert_with(|| ldr.clone()).clone();
        let (_, map) = flip_rgb8(&reference_ldr, &ldr, width, height);
        save_strip(&out.join(format!("{}.png", config.name())), &[direct, ldr, reference_ldr.clone(), magma(&map)], width, height)?;
        let equal_flip = if config.method() == "DDGI" {
            let timed = match (options.timing_size, timing_ms_per_spp) {
                (Some(size), None) => *timing_ms_per_spp.insert(time_path_tracer(gpu, &scene, size, seed)?),
                (_, known) => known.flatten(),
            };
            let large = match options.timing_size {
                Some([w, h]) => gpu_ms(&render(gpu, &scene, &config, w, h, seed, config.frames())?).0,
                None => None,
            };
            equal_flip(&rows, f64::from(error.mean_flip), per_frame, timed, large)
        } else {
            None
        };
        let equal = equal_flip.map_or(String::new(), |e| {
            let ratio = |r: Option<f64>| r.map_or("n/a".to_string(), |r| format!("{r:.3}×"));
            format!(
                ", path tracer at equal FLIP {}, GPU-time ratio {} ({width}×{height}), {} ({})",
                spp_text(&e),
                ratio(e.gpu_time_ratio),
                ratio(e.gpu_time_ratio_at_timing_size),
                options.timing_size.map_or("untimed".into(), |[w, h]| format!("{w}×{h}"))
            )
        });
        println!(
            "{:>18}: FLIP {:.4}, RMSE {:.4}, relative MSE {:.4}{equal}",
            config.name(),
            error.mean_flip,
            error.rmse,
            error.relative_mse
        );
        rows.push(EvalRow {
            config: config.name(),
            method: config.method().into(),
            frames: frame.timings.len() as u32,
            gpu_ms_per_frame: per_frame,
            gpu_ms_total: total,
            rays_per_frame: rays_per_frame(&frame),
            error,
            equal_flip,
        });
    }
    let plot_note = plot_error_vs_time(&out.join("error_vs_time.png"), &rows)?;
    write_report(out, name, &gpu.adapter_name(), options, &rows, &plot_note)?;
    Ok(rows)
}

/// The path tracer's GPU ms per path per pixel at `[width, height]`: [`TIMING_SPP`] paths per
/// pixel timed there, over [`TIMING_SPP`] (every path costs the same).
fn time_path_tracer(gpu: &GpuContext, scene: &SceneDescription, [width, height]: [u32; 2], seed: u32) -> Result<Option<f64>, String> {
    let config = Config::PathTrace { spp: TIMING_SPP };
    let frame = render(gpu, scene, &config, width, height, seed, config.frames())?;
    Ok(gpu_ms(&frame).1.map(|total| total / f64::from(TIMING_SPP)))
}

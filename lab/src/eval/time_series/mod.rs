//! `game_demo eval --time-series`: the error of every frame after a change in the scene, to show
//! how long each method takes to converge again.
//!
//! Each method of [`Config::time_series_list`] renders the scene before the change for its
//! [`Config::frames`] (so that it has settled), the change is applied, and the method goes on for
//! `--frames` frames. Every frame from the last one before the change (frame -1) on is compared with
//! a path-traced reference of the scene after the change. The methods run in lockstep, a frame of
//! each in turn, so that their GPU times are measured under the same clocks.

mod change;
mod report;

use engine::app::finish_plugins;
use engine::bevy_app::App;
use engine::bevy_ecs::prelude::{Entity, Without};
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, read_hdr, scene_app};
use engine::render::FrameTimings;
use engine::scene::{Name, SceneDescription, SceneRoot, Transform};

use super::{Config, EXPOSURE, EvalOptions, SceneFacts, frame_gpu_ms, reference, still};
use crate::median;
use crate::metrics::{compare, mean_frame, tonemap_to_srgb8, video_jod_against_still};

pub use change::{find_node, scene_change};
pub use report::{Trend, recovery, settling, trend};
use report::{jod_text, plot_series, plot_video, write_csv, write_report, write_video_csv};

/// What changes: one node of the scene takes another transform (relative to its parent).
#[derive(Clone, Debug)]
pub struct SceneChange {
    /// What happens, in words, for the report.
    pub description: String,
    /// The node that changes; its name is unique in the scene.
    pub node: usize,
    pub after: Transform,
}

impl SceneChange {
    fn applied(&self, scene: &SceneDescription) -> SceneDescription {
        let mut after = scene.clone();
        after.nodes[self.node].transform = self.after;
        after
    }
}

/// One frame of one method.
pub struct SeriesRow {
    /// Frames since the change: -1 is the last frame before it, 0 the first after.
    pub frame: i64,
    pub config: String,
    pub flip: f32,
    pub rmse: f64,
    pub gpu_ms: Option<f64>,
    /// GPU milliseconds of DDGI's probe update (its passes but the camera's gather and composite).
    pub update_ms: Option<f64>,
    /// Rays DDGI traced (read back a few frames late: absent for the last frames of a run).
    pub rays: Option<f64>,
}

/// Frames of the static phase: before the last frame before the change.
const STATIC_FRAMES: i64 = 30;

/// Frames whose probe update is timed, just before the static phase's measured frames: they run
/// back to back (nothing is read back or compared), so the GPU is as busy as the method keeps it.
/// The measured frames idle it for the readbacks and comparisons on the CPU, and a small workload
/// timed there runs at whatever clock the GPU has dropped to.
const TIMED_FRAMES: i64 = 60;

/// What a configuration costs once settled, before the change: means per frame of the rays and
/// of the probe-update GPU ms, a frame whose probe update the volume's calm update period left
/// out ([`ddgi::DdgiAdaptive::max_update_period`]) counting 0 in both (a median would hide such
/// frames, or report only them).
pub struct StaticPhase {
    pub config: String,
    /// Mean rays per frame over the timed and the measured frames.
    pub rays: Option<f64>,
    /// Mean probe-update GPU ms per frame over the timed frames.
    pub update_ms: Option<f64>,
    /// The median probe-update GPU ms of the timed frames that updated (what one update costs).
    pub update_ms_median: Option<f64>,
    /// The share of the timed frames that updated the probes.
    pub updating: Option<f64>,
    /// The mean GPU ms per frame of each pass of the probe update (0 where it was left out).
    pub passes: Vec<(String, f64)>,
    /// Mean FLIP against the reference of the scene before the change (the static phase's error).
    pub flip: Option<f64>,
    /// Mean flicker ([`flicker`]) between consecutive frames of the static phase: what noise in
    /// the probes shows on screen in a still scene.
    pub flicker: Option<f64>,
}

/// A configuration's sequences judged as video by ColorVideoVDP ([`crate::metrics::video_jod`]),
/// in JOD (10: no visible difference).
pub struct VideoQuality {
    pub config: String,
    /// The static phase's frames against the reference of the scene before the change, still:
    /// every visible difference, in each frame and from frame to frame.
    pub static_jod: Option<f32>,
    /// The static phase's frames against their own mean frame: only what changes from frame to
    /// frame (the method's temporal noise), whatever its error against the reference.
    pub static_temporal_jod: Option<f32>,
    /// The frames after the change (0 on) against the reference of the changed scene, still: the
    /// error and the flicker while the method follows the change and once it has.
    pub after_jod: Option<f32>,
    /// Seconds ColorVideoVDP took for the three, on the CPU.
    pub seconds: f64,
}

/// One configuration's run through the series: its app, and what its frames measured.
struct SeriesRun {
    config: Config,
    app: App,
    /// The node that changes.
    entity: Entity,
    /// Frames before the change.
    settle: u32,
    /// False once the app asked to exit.
    running: bool,
    /// Frames from the last one before the change on.
    rows: Vec<SeriesRow>,
    samples: StaticSamples,
    /// The frames after the change (0 on), tonemapped as FLIP sees them, for ColorVideoVDP.
    after_ldr: Vec<Vec<u8>>,
}

/// What the frames of a static phase measured, frame by frame.
#[derive(Default)]
struct StaticSamples {
    flips: Vec<f64>,
    flicker: Vec<f64>,
    previous_hdr: Option<Vec<f32>>,
    /// The measured frames, tonemapped as FLIP sees them, for ColorVideoVDP.
    ldr: Vec<Vec<u8>>,
}

/// Frames a configuration runs before the change: DDGI `settle_frames` (it must have converged
/// for its static phase to be static); direct light enough for a static phase (its temporal
/// anti-aliasing's flicker is its temporal noise); the path tracer as many as its still image
/// needs (it accumulates, so it has no static phase: its frames before the change converge).
fn settle_frames_of(config: &Config, settle_frames: u32) -> u32 {
    match config {
        Config::Ddgi { .. } | Config::DdgiCascades { .. } => settle_frames,
        Config::Direct => config.frames().max(1 + STATIC_FRAMES as u32),
        Config::PathTrace { .. } => config.frames(),
    }
}

fn mean(v: &[f64]) -> Option<f64> {
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// GPU milliseconds of DDGI's probe update in one frame: the sum of its passes that ran; 0 when the
/// frame left the update out (its `ddgi_budget` was left out: no volume's update period fell on
/// it); `None` for a frame without DDGI or without GPU times.
fn probe_update_ms(frame: &engine::render::FrameTiming) -> Option<f64> {
    let update: Vec<f64> = frame.passes.iter().filter(|p| p.ran && ddgi::is_probe_update_pass(&p.label)).filter_map(|p| p.gpu_ms).collect();
    if !update.is_empty() {
        return Some(update.iter().sum());
    }
    frame.passes.iter().any(|p| p.label == "ddgi_budget" && !p.ran).then_some(0.0)
}

/// The probe update over some frames ([`static_update`]).
struct UpdateCost {
    /// Mean GPU ms per frame, 0 for a frame that left the update out.
    mean_ms: Option<f64>,
    /// Median GPU ms of the frames that updated.
    median_ms: Option<f64>,
    /// The share of frames that updated.
    updating: Option<f64>,
    /// Each pass's mean GPU ms per frame.
    passes: Vec<(String, f64)>,
}

/// The probe update of the frames `frames` (app frame indices) of `timings`.
fn static_update(timings: &FrameTimings, frames: std::ops::Range<u64>) -> UpdateCost {
    let window: Vec<&engine::render::FrameTiming> = timings.frames.iter().filter(|t| frames.contains(&t.frame)).collect();
    let per_frame: Vec<(&engine::render::FrameTiming, f64)> = window.iter().filter_map(|t| probe_update_ms(t).map(|ms| (*t, ms))).collect();
    let all: Vec<f64> = per_frame.iter().map(|(_, ms)| *ms).collect();
    let mut updating: Vec<f64> =
        per_frame.iter().filter(|(t, _)| t.passes.iter().any(|p| p.ran && p.label == "ddgi_budget")).map(|(_, ms)| *ms).collect();
    let share = (!all.is_empty()).then(|| updating.len() as f64 / all.len() as f64);
    let mut passes: Vec<(String, f64)> = Vec::new();
    for (t, _) in &per_frame {
        for p in t.passes.iter().filter(|p| p.ran && ddgi::is_probe_update_pass(&p.label)) {
            let ms = p.gpu_ms.unwrap_or(0.0);
            match passes.iter_mut().find(|(l, _)| *l == p.label) {
                Some((_, sum)) => *sum += ms,
                None => passes.push((p.label.clone(), ms)),
            }
        }
    }
    let n = per_frame.len().max(1) as f64;
    let passes = passes.into_iter().map(|(l, sum)| (l, sum / n)).collect();
    UpdateCost { mean_ms: mean(&all), median_ms: median(&mut updating), updating: share, passes }
}

/// Flicker between two frames: the mean absolute change of each pixel's luminance over the mean
/// luminance (linear RGBA images of the same size; 0 for two black images).
pub fn flicker(previous: &[f32], current: &[f32]) -> f64 {
    let luminance = |p: &[f32]| 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
    let (mut change, mut total) = (0.0, 0.0);
    for (a, b) in previous.chunks_exact(4).zip(current.chunks_exact(4)) {
        let (a, b) = (luminance(a), luminance(b));
        if a.is_finite() && b.is_finite() {
            change += (b - a).abs();
            total += 0.5 * (a.abs() + b.abs());
        }
    }
    if total > 0.0 { change / total } else { 0.0 }
}

/// Runs the time series of `scene` (described by `facts`) for `frames` frames after the change and
/// writes `time_series.csv`, `time_series.png` and `report.md` into `options.out`.
pub fn run(
    gpu: &GpuContext,
    facts: &SceneFacts,
    mut scene: SceneDescription,
    options: &EvalOptions,
    frames: u32,
) -> Result<Vec<SeriesRow>, String> {
    let name = facts.name.as_str();
    let EvalOptions { width, height, reference_spp, ref out, ref cache, ref adaptive, settle_frames, grid, .. } = *options;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let change = scene_change(facts, &mut scene)?;
    println!("change: {}", change.description);
    let before = still(scene);
    let reference_before = reference(gpu, &format!("{name}-before"), &before, width, height, reference_spp, cache)?;
    let reference = reference(gpu, &format!("{name}-changed"), &change.applied(&before), width, height, reference_spp, cache)?;
    let changed = before.nodes[change.node].name.clone();
    let seed = pathtrace::PathTraceSettings::default().seed;
    let mut runs = Vec::new();
    let list: Vec<Config> = Config::for_scene(Config::time_series_list(facts, grid, adaptive), &before, options.cascades.as_ref())
        .into_iter()
        .map(|c| c.with_hit_occlusion(options.hit_occlusion_rays, options.hit_occlusion_reach))
        .collect();
    for config in list {
        let settle = settle_frames_of(&config, settle_frames);
        let settings = HeadlessSettings { width, height, frames: settle + frames, ..Default::default() };
        let mut app = scene_app(gpu, before.clone(), &settings, |app| config.configure(app, seed)).map_err(|e| e.to_string())?;
        let world = app.world_mut();
        let mut named = world.query_filtered::<(Entity, &Name), Without<SceneRoot>>();
        let entity = named
            .iter(world)
            .find(|(_, n)| n.0 == changed)
            .map(|(e, _)| e)
            .ok_or_else(|| format!("node '{changed}' is not in the world"))?;
        finish_plugins(&mut app);
        let samples = StaticSamples::default();
        runs.push(SeriesRun { config, app, entity, settle, running: true, rows: Vec::new(), samples, after_ldr: Vec::new() });
    }
    // The configurations run in lockstep, one frame of each in turn, aligned on the change (those
    // that settle in fewer frames join later): every frame of each is rendered, timed and read
    // back in the same state of the GPU, whose clocks follow the load. Run one after the other, a
    // configuration that followed the comparisons on the CPU of another (an idle GPU, which lowers
    // its clocks within a second) had its small probe update timed up to twice as slow.
    let longest = runs.iter().map(|r| r.settle).max().unwrap_or(0);
    let bar = crate::progress::bar(u64::from(longest + frames), format!("time series, {} methods", runs.len()), "frames");
    for step in 0..longest + frames {
        bar.inc(1);
        for run in runs.iter_mut().filter(|r| r.running) {
            let Some(local) = step.checked_sub(longest - run.settle) else { continue };
            run.app.update();
            if run.app.should_exit().is_some() {
                run.running = false;
                continue;
            }
            let world = run.app.world_mut();
            let frame = i64::from(local) - i64::from(run.settle);
            if frame < -1 {
                if frame >= -1 - STATIC_FRAMES {
                    let hdr = read_hdr(gpu, world);
                    run.samples.flips.push(f64::from(compare(&reference_before, &hdr, width, height, EXPOSURE).mean_flip));
                    if let Some(previous) = &run.samples.previous_hdr {
                        run.samples.flicker.push(flicker(previous, &hdr));
                    }
                    run.samples.ldr.push(tonemap_to_srgb8(&hdr, EXPOSURE));
                    run.samples.previous_hdr = Some(hdr);
                }
                continue;
            }
            let hdr = read_hdr(gpu, world);
            let error = compare(&reference, &hdr, width, height, EXPOSURE);
            if frame >= 0 {
                run.after_ldr.push(tonemap_to_srgb8(&hdr, EXPOSURE));
            }
            let last = world.resource::<FrameTimings>().frames.last();
            let (gpu_ms, update_ms) = (last.and_then(frame_gpu_ms), last.and_then(probe_update_ms));
            let config = run.config.name();
            run.rows.push(SeriesRow { frame, config, flip: error.mean_flip, rmse: error.rmse, gpu_ms, update_ms, rays: None });
            if frame == -1
                && let Some(mut transform) = world.get_mut::<Transform>(run.entity)
            {
                *transform = change.after;
            }
        }
    }
    bar.finish_and_clear();
    let mut rows = Vec::new();
    let mut statics = Vec::new();
    let mut videos = Vec::new();
    let (still_before, still_after) = (tonemap_to_srgb8(&reference_before, EXPOSURE), tonemap_to_srgb8(&reference, EXPOSURE));
    for run in runs {
        let SeriesRun { config, app, settle, rows: mut run_rows, samples, after_ldr, .. } = run;
        let video = video_quality(&config.name(), &samples.ldr, &after_ldr, &still_before, &still_after, width, height)?;
        println!(
            "{:>18}: ColorVideoVDP static {} JOD (temporal only {}), after the change {} JOD ({} frames in {:.1} s)",
            config.name(),
            jod_text(video.static_jod),
            jod_text(video.static_temporal_jod),
            jod_text(video.after_jod),
            2 * samples.ldr.len() + after_ldr.len(),
            video.seconds
        );
        videos.push(video);
        // Rays per frame come back a few frames late: match them to their rows now.
        let rays: Vec<(u64, f64)> =
            app.world().resource::<FrameTimings>().frames.iter().filter_map(|t| ddgi::rays_traced(t).map(|r| (t.frame, r))).collect();
        // The timed frames (back to back) and the measured ones after them, up to the last frame
        // before the change: the rays' mean over all of them (a volume whose calm update period is
        // 4 updates in about 23 of 91 frames, against 8 of 31), the update's over the timed ones.
        let first_static = u64::from(settle).saturating_sub(1 + STATIC_FRAMES as u64);
        let first_timed = first_static.saturating_sub(TIMED_FRAMES as u64);
        let static_rays: Vec<f64> = rays.iter().filter(|(f, _)| (first_timed..u64::from(settle)).contains(f)).map(|(_, r)| *r).collect();
        let cost = static_update(app.world().resource::<FrameTimings>(), first_timed..first_static);
        statics.push(StaticPhase {
            config: config.name(),
            rays: mean(&static_rays),
            update_ms: cost.mean_ms,
            update_ms_median: cost.median_ms,
            updating: cost.updating,
            passes: cost.passes,
            flip: mean(&samples.flips),
            flicker: mean(&samples.flicker),
        });
        for row in &mut run_rows {
            let app_frame = (row.frame + i64::from(settle)) as u64;
            row.rays = rays.iter().find(|(f, _)| *f == app_frame).map(|(_, v)| *v);
        }
        if let (Some(first), Some(second), Some(last)) = (run_rows.first(), run_rows.get(1), run_rows.last()) {
            println!(
                "{:>18}: FLIP before the change {:.4}, first frame after {:.4}, last {:.4}",
                config.name(),
                first.flip,
                second.flip,
                last.flip
            );
        }
        rows.append(&mut run_rows);
    }
    write_csv(&out.join("time_series.csv"), &rows)?;
    write_video_csv(&out.join("video_quality.csv"), &statics, &videos)?;
    let plot_note = plot_series(&out.join("time_series.png"), name, &change, &rows)?;
    plot_video(&out.join("video_quality.png"), name, &videos)?;
    write_report(out, facts, &gpu.adapter_name(), options, frames, &change, &rows, &statics, &videos, &plot_note)?;
    Ok(rows)
}

/// ColorVideoVDP's judgement of a configuration's static phase (`static_frames`) and of its frames
/// after the change (`after_frames`), against the stills of the reference before and after it.
fn video_quality(
    config: &str,
    static_frames: &[Vec<u8>],
    after_frames: &[Vec<u8>],
    still_before: &[u8],
    still_after: &[u8],
    width: u32,
    height: u32,
) -> Result<VideoQuality, String> {
    let start = std::time::Instant::now();
    let judge = |frames: &[Vec<u8>], still: &[u8]| -> Result<Option<f32>, String> {
        let frames: Vec<&[u8]> = frames.iter().map(Vec::as_slice).collect();
        if frames.is_empty() { Ok(None) } else { video_jod_against_still(&frames, still, width, height).map(Some) }
    };
    let in_context = |e: String| format!("{config}: {e}");
    let static_jod = judge(static_frames, still_before).map_err(in_context)?;
    let refs: Vec<&[u8]> = static_frames.iter().map(Vec::as_slice).collect();
    let static_temporal_jod = match mean_frame(&refs) {
        Some(mean) => judge(static_frames, &mean).map_err(in_context)?,
        None => None,
    };
    let after_jod = judge(after_frames, still_after).map_err(in_context)?;
    Ok(VideoQuality { config: config.into(), static_jod, static_temporal_jod, after_jod, seconds: start.elapsed().as_secs_f64() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flicker_is_the_relative_mean_change_of_luminance() {
        let grey = |v: f32, n: usize| [v, v, v, 1.0].repeat(n);
        assert_eq!(flicker(&grey(0.5, 4), &grey(0.5, 4)), 0.0, "a still image does not flicker");
        // Half the pixels go from 1 to 1.1: a mean change of 0.05 over a mean of 1.025.
        let mut brighter = grey(1.0, 4);
        brighter[..8].copy_from_slice(&grey(1.1, 2));
        let f = flicker(&grey(1.0, 4), &brighter);
        assert!((f - 0.05 / 1.025).abs() < 1e-6, "{f}");
        assert_eq!(flicker(&grey(1.0, 4), &brighter), flicker(&brighter, &grey(1.0, 4)), "symmetric");
        assert_eq!(flicker(&grey(0.0, 4), &grey(0.0, 4)), 0.0, "black frames: no NaN");
        assert_eq!(flicker(&grey(f32::NAN, 4), &grey(1.0, 4)), 0.0, "non-finite pixels are left out");
    }
}

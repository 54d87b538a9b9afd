//! `game_demo eval --time-series`: the error of every frame after a change in the scene, to show
//! how long each method takes to converge again.
//!
//! Each method of [`Config::time_series_list`] renders the scene before the change for its
//! [`Config::frames`] (so that it has settled), the change is applied, and the method goes on for
//! `--frames` frames. Every frame from the last one before the change (frame -1) on is compared with
//! a path-traced reference of the scene after the change. The methods run in lockstep, a frame of
//! each in turn, so that their GPU times are measured under the same clocks.

use std::f32::consts::FRAC_PI_2;
use std::path::Path;

use engine::app::finish_plugins;
use engine::bevy_app::App;
use engine::bevy_ecs::prelude::{Entity, Without};
use engine::glam::{Affine3A, Quat, Vec3};
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, read_hdr, scene_app};
use engine::render::FrameTimings;
use engine::scene::{Material, Name, NodeContent, SceneDescription, SceneRoot, Transform};
use engine::shapes::{cuboid, merge};
use scenes::TimeSeriesChange;

use super::{Config, EXPOSURE, EvalOptions, SceneFacts, frame_gpu_ms, reference, still, write};
use crate::metrics::{compare, mean_frame, tonemap_to_srgb8, video_jod_against_still};
use crate::{median, plot};

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

/// The cornell lamp (quad and point light) moves this far towards the red (-X) wall.
const CORNELL_LAMP_SHIFT: f32 = 0.5;
/// door_room's door: panel thickness, how far it overlaps the wall around the opening, and how far
/// its outer face stays behind the wall's (so that the two never fight for the same pixels).
const DOOR_THICKNESS: f32 = 0.05;
const DOOR_OVERLAP: f32 = 0.02;
const DOOR_RECESS: f32 = 0.01;
const DOOR_ALBEDO: Vec3 = Vec3::new(0.45, 0.3, 0.2);
/// Fallback: a point or spot light moves this fraction of the scene's width along X (towards the
/// middle); a directional light turns this many degrees about the vertical.
const FALLBACK_SHIFT: f32 = 0.2;
const FALLBACK_TURN_DEGREES: f32 = 20.0;

/// The change of the time series for the scene `facts` describes, prepared in `scene`: the scene's
/// own ([`SceneFacts::change`]) or the built-in scene's ([`scenes::SceneEntry::change`]),
/// - `cornell`: the lamp moves [`CORNELL_LAMP_SHIFT`] towards the red wall;
/// - `color_bleed`: the spot light jumps half a turn along its orbit, to the red cube's side;
/// - `door_room`: a door (added to the scene, closed: the room is dark) swings open outwards;
/// - any other scene: its first light moves (a point or spot light by [`FALLBACK_SHIFT`] of the
///   scene's width along X, a directional light turns by [`FALLBACK_TURN_DEGREES`] about Y).
pub fn scene_change(facts: &SceneFacts, scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let name = facts.name.as_str();
    let change = match facts.change {
        Some(change) => change(scene)?,
        None => built_in_change(name, scene)?,
    };
    let changed = scene.nodes[change.node].name.clone();
    if scene.nodes.iter().filter(|n| n.name == changed).count() > 1 {
        // The run finds the node's entity in the world by its name.
        scene.nodes[change.node].name = format!("{changed} (changed)");
    }
    Ok(change)
}

/// The change its entry in [`scenes::ALL`] gives the scene named `name`
/// ([`TimeSeriesChange::FirstLight`] for a scene outside it), prepared in `scene`.
fn built_in_change(name: &str, scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let entry = scenes::find(name);
    let find = |scene: &SceneDescription, node: &str| find_node(name, scene, node);
    Ok(match entry.map_or(TimeSeriesChange::FirstLight, |entry| entry.change) {
        TimeSeriesChange::LampTowardsRedWall => {
            let node = find(scene, "lamp")?;
            let mut after = scene.nodes[node].transform;
            after.translation.x -= CORNELL_LAMP_SHIFT;
            SceneChange { description: format!("the lamp moves {CORNELL_LAMP_SHIFT} m towards the red wall"), node, after }
        }
        TimeSeriesChange::SpotHalfTurn => {
            let node = find(scene, "spot")?;
            let orbit = scene.nodes[node].orbit.ok_or_else(|| format!("{name}'s spot light has no orbit"))?;
            // The orbit starts at +X from its centre (angle 0); half a turn is at -X.
            let after = Transform::from_translation(orbit.center - Vec3::X * orbit.radius);
            let after = orbit.look_at.map_or(after, |target| after.looking_at(target, Vec3::Y));
            SceneChange { description: "the spot light jumps half a turn along its orbit, to the red cube's side".into(), node, after }
        }
        TimeSeriesChange::DoorSwingsOpen => add_door(name, entry.map_or(&[], |entry| (entry.openings)()), scene)?,
        TimeSeriesChange::FirstLight => move_first_light(name, scene)?,
    })
}

/// The index of the node named `node` in `scene` (named `name`), or an error naming both.
pub fn find_node(name: &str, scene: &SceneDescription, node: &str) -> Result<usize, String> {
    scene.nodes.iter().position(|n| n.name == node).ok_or_else(|| format!("scene '{name}' has no node '{node}' to change"))
}

/// A door panel hinged on the -X side of the doorway of the scene `name` (its opening `door` of
/// `openings`: door_room's), closed; the change opens it outwards by a quarter turn.
fn add_door(name: &str, openings: &[scenes::Opening], scene: &mut SceneDescription) -> Result<SceneChange, String> {
    let door = openings.iter().find(|o| o.name == "door").ok_or_else(|| format!("{name} has no door opening"))?;
    let size = Vec3::new(door.max.x - door.min.x + 2.0 * DOOR_OVERLAP, door.max.y - door.min.y + 2.0 * DOOR_OVERLAP, DOOR_THICKNESS);
    // Local origin at the hinge, the panel's outer bottom corner: it extends along +X, +Y and -Z.
    let offset = Affine3A::from_translation(Vec3::new(size.x, size.y, -size.z) * 0.5);
    let mesh = scene.add_mesh(merge("door_panel", &[(cuboid("door_panel", size * 0.5), offset)]));
    let material = scene.add_material(Material::diffuse("door_panel", DOOR_ALBEDO));
    let hinge = Vec3::new(door.min.x - DOOR_OVERLAP, door.min.y - DOOR_OVERLAP, door.max.z - DOOR_RECESS);
    let node = scene.add_node("door_panel", Transform::from_translation(hinge), None, vec![NodeContent::Meshes(vec![(mesh, material)])]);
    let after = Transform::from_translation(hinge).with_rotation(Quat::from_rotation_y(-FRAC_PI_2));
    Ok(SceneChange {
        description: "the closed door swings open outwards (a quarter turn): sunlight enters the dark room".into(),
        node,
        after,
    })
}

fn move_first_light(name: &str, scene: &SceneDescription) -> Result<SceneChange, String> {
    let light = |c: &NodeContent| matches!(c, NodeContent::PointLight(_) | NodeContent::SpotLight(_) | NodeContent::DirectionalLight(_));
    let node = scene
        .nodes
        .iter()
        .position(|n| n.content.iter().any(light))
        .ok_or_else(|| format!("scene '{name}' has no light to move for --time-series"))?;
    let (before, light_name) = (scene.nodes[node].transform, &scene.nodes[node].name);
    if scene.nodes[node].content.iter().any(|c| matches!(c, NodeContent::DirectionalLight(_))) {
        let after = before.with_rotation(Quat::from_rotation_y(FALLBACK_TURN_DEGREES.to_radians()) * before.rotation);
        let description = format!("the directional light '{light_name}' turns {FALLBACK_TURN_DEGREES}° about the vertical");
        return Ok(SceneChange { description, node, after });
    }
    let (lo, hi) = scene.bounds().ok_or_else(|| format!("scene '{name}' has no geometry"))?;
    let position = scene.world_transforms()[node].translation;
    let towards_middle = if (lo.x + hi.x) * 0.5 >= position.x { 1.0 } else { -1.0 };
    let shift = towards_middle * FALLBACK_SHIFT * (hi.x - lo.x);
    let mut after = before;
    after.translation.x += shift;
    Ok(SceneChange { description: format!("the light '{light_name}' moves {shift:+.2} along X"), node, after })
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

/// Which way a series of errors was still moving at its end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Trend {
    Settled,
    Falling,
    Rising,
}

/// Whether a series of errors had settled by its end: the mean of its last tenth is within 2% of
/// the mean of the tenth before. A series still moving at its end has no settled value yet, and
/// the frames to within 10% of its last values would mislead: DDGI's error after a change can fall
/// under its settled value and then rise back for hundreds of frames while multi-bounce light
/// builds up (the cathedral: about 500 frames at hysteresis 0.97). Series of under 20 frames: unknown.
pub fn trend(errors: &[f32]) -> Option<Trend> {
    let tail = errors.len() / 10;
    if tail < 2 {
        return None;
    }
    let mean = |s: &[f32]| s.iter().sum::<f32>() / s.len() as f32;
    let last = mean(&errors[errors.len() - tail..]);
    let before = mean(&errors[errors.len() - 2 * tail..errors.len() - tail]);
    Some(if last < 0.98 * before {
        Trend::Falling
    } else if last > 1.02 * before {
        Trend::Rising
    } else {
        Trend::Settled
    })
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

/// The settled error of a series of errors (frames 0, 1, … after the change): the mean of its last
/// tenth (at least one frame); and the first frame from which every error is within 10% of it.
/// The first frame from which every error stays at most 10% above `settled` (the error has come
/// back down from the change; dipping under the settled value on the way does not count against it).
pub fn recovery(errors: &[f32], settled: f32) -> Option<usize> {
    let from = errors.iter().rposition(|&e| e > 1.1 * settled).map_or(0, |i| i + 1);
    (from < errors.len()).then_some(from)
}

pub fn settling(errors: &[f32]) -> (f32, Option<usize>) {
    let tail = (errors.len() / 10).max(1).min(errors.len());
    if tail == 0 {
        return (f32::NAN, None);
    }
    let settled = errors[errors.len() - tail..].iter().sum::<f32>() / tail as f32;
    let from = errors.iter().rposition(|&e| (e - settled).abs() > 0.1 * settled).map_or(0, |i| i + 1);
    (settled, (from < errors.len()).then_some(from))
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

fn jod_text(jod: Option<f32>) -> String {
    jod.map_or("n/a".into(), |j| format!("{j:.3}"))
}

fn write_video_csv(path: &Path, statics: &[StaticPhase], videos: &[VideoQuality]) -> Result<(), String> {
    let mut csv = String::from("config,static_flip,static_flicker,static_jod,static_temporal_jod,after_jod,cvvdp_seconds\n");
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
    for v in videos {
        let phase = statics.iter().find(|p| p.config == v.config);
        csv += &format!(
            "{},{},{},{},{},{},{:.2}\n",
            v.config,
            opt(phase.and_then(|p| p.flip)),
            opt(phase.and_then(|p| p.flicker)),
            opt(v.static_jod.map(f64::from)),
            opt(v.static_temporal_jod.map(f64::from)),
            opt(v.after_jod.map(f64::from)),
            v.seconds
        );
    }
    write(path, &csv)
}

/// ColorVideoVDP's JOD per configuration: static against the reference, static against its own
/// mean (temporal only), after the change.
fn plot_video(path: &Path, name: &str, videos: &[VideoQuality]) -> Result<(), String> {
    let configs: Vec<String> = videos.iter().map(|v| v.config.clone()).collect();
    let bars = |jod: fn(&VideoQuality) -> Option<f32>| videos.iter().map(|v| jod(v).map(f64::from)).collect::<Vec<_>>();
    let groups = [
        ("static, against the reference".to_string(), bars(|v| v.static_jod)),
        ("static, against its own mean (temporal only)".to_string(), bars(|v| v.static_temporal_jod)),
        ("after the change, against its reference".to_string(), bars(|v| v.after_jod)),
    ];
    plot::bars(
        path,
        &format!("{name}: ColorVideoVDP at {} fps on {}", crate::metrics::VIDEO_FPS, crate::metrics::VIDEO_DISPLAY),
        &configs,
        &groups,
        "JOD (10: no visible difference)",
    )
}

fn write_csv(path: &Path, rows: &[SeriesRow]) -> Result<(), String> {
    let mut csv = String::from("frame,config,flip,rmse,gpu_ms,update_ms,rays\n");
    let opt = |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
    for r in rows {
        csv += &format!(
            "{},{},{:.6},{:.6},{},{},{}\n",
            r.frame,
            r.config,
            r.flip,
            r.rmse,
            opt(r.gpu_ms, 4),
            opt(r.update_ms, 4),
            opt(r.rays, 0)
        );
    }
    write(path, &csv)
}

fn configs(rows: &[SeriesRow]) -> Vec<&str> {
    let mut names: Vec<&str> = Vec::new();
    for row in rows {
        if !names.contains(&row.config.as_str()) {
            names.push(&row.config);
        }
    }
    names
}

fn plot_series(path: &Path, name: &str, change: &SceneChange, rows: &[SeriesRow]) -> Result<String, String> {
    let series: Vec<plot::Series> = configs(rows)
        .into_iter()
        .map(|config| plot::Series {
            name: config.to_string(),
            points: rows.iter().filter(|r| r.config == config).map(|r| (r.frame as f64, plot::floor_for_log(f64::from(r.flip)))).collect(),
        })
        .collect();
    plot::time_series(path, &format!("{name}: {}", change.description), &series)?;
    let zeros = plot::floored(rows.iter().map(|r| f64::from(r.flip)));
    Ok(if zeros > 0 { format!(" ({zeros} errors below {} drawn at {})", plot::LOG_FLOOR, plot::LOG_FLOOR) } else { String::new() })
}

#[allow(clippy::too_many_arguments)]
fn write_report(
    out: &Path,
    facts: &SceneFacts,
    adapter: &str,
    options: &EvalOptions,
    frames: u32,
    change: &SceneChange,
    rows: &[SeriesRow],
    statics: &[StaticPhase],
    videos: &[VideoQuality],
    plot_note: &str,
) -> Result<(), String> {
    let name = facts.name.as_str();
    let list = Config::for_scene(
        Config::time_series_list(facts, options.grid, &options.adaptive),
        &SceneDescription::default(),
        options.cascades.as_ref(),
    );
    let settle: Vec<String> = list.iter().map(|c| format!("{} {}", c.name(), settle_frames_of(c, options.settle_frames))).collect();
    let mut md = format!(
        "# Time series: {name}\n\nBefore frame 0, {}.\n\n{}×{} on {adapter}, {frames} frames after the change. Reference: the scene after the change, \
         path traced at {} paths per pixel (another seed). Every frame is compared with it (mean FLIP on sRGB at exposure 1, RMSE on \
         linear radiance); frame -1 is the last one before the change, once the method has settled (frames before the change: {}). \
         A path tracer configuration adds its paths per pixel every frame and starts over when the scene changes.\n\n\
         | configuration | static FLIP | static flicker % | static JOD | static JOD, temporal only | JOD after the change | FLIP before (frame -1) | FLIP at frame 0 | settled FLIP | frames to within 10% of it | frames to at most 10% over it | rays/frame, static | probe update ms per frame, static | ms per update (median) | % of frames updating | rays/frame after |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        change.description,
        options.width,
        options.height,
        options.reference_spp,
        settle.join(", ")
    );
    for config in configs(rows) {
        let series: Vec<&SeriesRow> = rows.iter().filter(|r| r.config == config).collect();
        let after: Vec<f32> = series.iter().filter(|r| r.frame >= 0).map(|r| r.flip).collect();
        let (settled, from) = settling(&after);
        let recovered = recovery(&after, settled).map_or(format!("not within {frames} frames"), |f| f.to_string());
        let at = |frame: i64| series.iter().find(|r| r.frame == frame).map_or("n/a".into(), |r| format!("{:.4}", r.flip));
        let mut from = from.map_or(format!("not within {frames} frames"), |f| f.to_string());
        match trend(&after) {
            Some(Trend::Falling) => from += " (still falling at the end)",
            Some(Trend::Rising) => from += " (still rising at the end)",
            _ => {}
        }
        let shown = |v: Option<f64>, digits: usize| v.map_or("n/a".to_string(), |v| format!("{v:.digits$}"));
        let phase = statics.iter().find(|p| p.config == config);
        let rays_before = shown(phase.and_then(|p| p.rays), 0);
        let ms_before = shown(phase.and_then(|p| p.update_ms), 3);
        let per_update = shown(phase.and_then(|p| p.update_ms_median), 3);
        let updating = shown(phase.and_then(|p| p.updating).map(|u| 100.0 * u), 0);
        let after: Vec<f64> = series.iter().filter(|r| r.frame >= 0).filter_map(|r| r.rays).collect();
        let rays_after = shown(mean(&after), 0);
        let static_flip = shown(phase.and_then(|p| p.flip), 4);
        let static_flicker = shown(phase.and_then(|p| p.flicker).map(|f| 100.0 * f), 3);
        let video = videos.iter().find(|v| v.config == config);
        let jods =
            [video.and_then(|v| v.static_jod), video.and_then(|v| v.static_temporal_jod), video.and_then(|v| v.after_jod)].map(jod_text);
        md += &format!(
            "| {config} | {static_flip} | {static_flicker} | {} | {} | {} | {} | {} | {settled:.4} | {from} | {recovered} | {rays_before} | {ms_before} | {per_update} | {updating} | {rays_after} |\n",
            jods[0],
            jods[1],
            jods[2],
            at(-1),
            at(0)
        );
    }
    md += &format!(
        "\nSettled FLIP: the mean over the last tenth of the frames (at least one); the path tracer keeps converging, so its \
         settled value and frame count depend on `--frames`. Frames to within 10%: the first frame after the change from which \
         every frame's FLIP is within 10% of the settled value (\"still falling\" or \"rising\": the last tenth's mean is more than 2% under \
         the tenth before, or more than 2% over it, so the series had not settled and needs more `--frames`). Static: the 30 frames before the last one \
         before the change (static FLIP: their mean FLIP against a reference of the scene before the change; static flicker: the \
         mean change of a pixel's luminance from one of those frames to the next, over the mean luminance). Rays/frame, static: \
         the mean over those frames and the 60 before them, as read back from the GPU; probe update ms per frame (DDGI's \
         probe update, every DDGI pass but the gather and composite): the mean GPU ms of the 60 frames before the measured ones, \
         which run back to back, nothing read back. Both are means per frame in which a frame whose probe update the volume's \
         calm update period left out (`DdgiAdaptive::max_update_period`) counts 0; ms per update: the median over the frames \
         that updated, and the share of frames that did. The configurations run in lockstep, one frame \
         of each in turn, so that all are timed in the same state of the GPU's clocks. \
         Frames to at most 10% over it: the first frame from which no frame's FLIP is more than 10% above the settled value \
         (the error has come back down; a dip under the settled value on the way does not count against it).\n\n\
         JOD: ColorVideoVDP (the `colorvideovdp` crate, a Rust port of the calibrated model 0.5.7), the frames as FLIP sees \
         them (sRGB at exposure 1) played at {fps} frames per second on its `{display}` display (24-inch 1920×1080, 200 cd/m², 0.6 m, \
         office light); 10: no visible difference, 1 JOD less: 75% of observers see it as worse. Unlike FLIP, which judges \
         each frame alone, it weighs what changes from frame to frame by the eye's temporal sensitivity. Static JOD: the \
         static phase's frames against the still reference of the scene before the change (every visible difference, in each \
         frame and over time); temporal only: against the mean of those frames (only what changes from frame to frame: the \
         method's flicker and crawling noise, whatever its error); after the change: frames 0 on against the still reference \
         of the changed scene (the error and flicker while the method follows the change and once it has). \
         The path tracer, which accumulates from one frame before the change, has no static phase (n/a). \
         [video_quality.csv](video_quality.csv) has them with the CPU seconds each configuration's three took.\n\n\
         ![ColorVideoVDP JOD per configuration](video_quality.png)\n\n{}\
         Mean FLIP per frame, one series per configuration, log scale{plot_note}:\n\n![mean FLIP per frame](time_series.png)\n\n\
         Every frame: [time_series.csv](time_series.csv) (frame, config, flip, rmse, gpu_ms, update_ms: DDGI's probe update, rays: \
         DDGI's rays traced).\n",
        pass_table(statics),
        fps = crate::metrics::VIDEO_FPS,
        display = crate::metrics::VIDEO_DISPLAY,
    );
    write(&out.join("report.md"), &md)
}

/// The static phase's mean GPU ms per frame of each probe-update pass (0 on frames that left it
/// out), one column per DDGI configuration (empty when none ran DDGI).
fn pass_table(statics: &[StaticPhase]) -> String {
    let ddgi: Vec<&StaticPhase> = statics.iter().filter(|p| !p.passes.is_empty()).collect();
    let Some(first) = ddgi.first() else { return String::new() };
    let mut md =
        String::from("Static phase, mean GPU ms per frame of each pass of the probe update (0 on frames that left it out):\n\n| pass |");
    for p in &ddgi {
        md += &format!(" {} |", p.config);
    }
    md += &format!("\n|---|{}\n", "---:|".repeat(ddgi.len()));
    for (label, _) in &first.passes {
        md += &format!("| {label} |");
        for p in &ddgi {
            let ms = p.passes.iter().find(|(l, _)| l == label).map_or("not run".to_string(), |(_, ms)| format!("{ms:.3}"));
            md += &format!(" {ms} |");
        }
        md += "\n";
    }
    md + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovery_ignores_a_dip_under_the_settled_error() {
        let errors = [0.3, 0.2, 0.08, 0.06, 0.07, 0.1, 0.1];
        assert_eq!(settling(&errors).1, Some(5), "within ±10% only once the dip is over");
        assert_eq!(recovery(&errors, 0.1), Some(2), "at most 10% over from the third frame");
        assert_eq!(recovery(&[0.3, 0.3], 0.1), None);
    }

    #[test]
    fn a_series_still_moving_at_its_end_is_flagged() {
        let falling: Vec<f32> = (0..60).map(|i| 0.2 * 0.97f32.powi(i)).collect();
        assert_eq!(trend(&falling), Some(Trend::Falling), "an exponential at 3% a frame has not settled");
        let settled: Vec<f32> = (0..240).map(|i| 0.1 + 0.1 * 0.97f32.powi(i)).collect();
        assert_eq!(trend(&settled), Some(Trend::Settled));
        // The cathedral's shape over 240 frames: a quick fall, then a slow rise still going at the end.
        let rising: Vec<f32> = (0..240).map(|i| 0.06 + 0.03 * 0.8f32.powi(i) + 1e-4 * i as f32).collect();
        assert_eq!(trend(&rising), Some(Trend::Rising));
        assert_eq!(trend(&[0.3; 10]), None, "too short to tell");
    }

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

    #[test]
    fn settling_finds_the_first_frame_that_stays_within_ten_percent() {
        let (settled, from) = settling(&[1.0, 0.5, 0.2, 0.105, 0.12, 0.1]);
        assert_eq!(settled, 0.1);
        // 0.12 is 20% off: the error has settled only from the last frame on.
        assert_eq!(from, Some(5));
        assert_eq!(settling(&[0.3, 0.3, 0.3]), (0.3, Some(0)), "a constant error has settled at once");
        assert_eq!(settling(&[]).1, None);
    }

    fn assert_change_moves_a_uniquely_named_node(facts: &SceneFacts, scene: &mut SceneDescription) {
        let name = &facts.name;
        let change = scene_change(facts, scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_ne!(scene.nodes[change.node].transform, change.after, "{name}: {}", change.description);
        let changed = &scene.nodes[change.node].name;
        assert_eq!(scene.nodes.iter().filter(|n| &n.name == changed).count(), 1, "{name}: '{changed}' must be unique");
    }

    #[test]
    fn every_built_in_scene_has_a_change_that_moves_a_uniquely_named_node() {
        for entry in scenes::ALL {
            let mut scene = (entry.build)();
            assert_change_moves_a_uniquely_named_node(&SceneFacts::named(entry.name), &mut scene);
        }
        let mut dark = SceneDescription { name: "dark".into(), ..Default::default() };
        let error = scene_change(&SceneFacts::named("dark"), &mut dark).expect_err("a scene without lights has nothing to move");
        assert!(error.contains("'dark' has no light"), "{error}");
    }
}

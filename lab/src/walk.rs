//! `game_demo bench walk`: DDGI's GPU time, frame by frame, while the camera walks the open world's
//! tour ([`scenes::open::tour_at`]) — with camera-following cascades or one fixed volume — and
//! where the cascades scrolled and the render origin rebased, so that a spike can be traced to
//! what caused it. `eval --time-series --walk` walks the same way, measuring every frame against a
//! path-traced reference of its view: the error and the flicker per frame ([`WalkFrame`]).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, run_frames, scene_app};
use engine::render::{FrameTimings, RenderSize};
use engine::scene::{Camera, RenderOrigin, SceneDescription, Transform};
use glam::{DVec3, Vec3};

use crate::eval::Config;

/// Where the camera goes on a walk.
#[derive(Clone, Copy, Debug)]
pub enum WalkPath {
    /// A scene's tour ([`scenes::SceneEntry::tour`]): where it stands after walking a distance,
    /// and the direction it walks in; the camera looks ahead and a little down.
    Tour(fn(f32) -> (Vec3, Vec3)),
    /// The scene's own camera, carried sideways (along its right axis) without turning: for
    /// scenes that have no tour.
    Dolly { start: Transform },
}

impl WalkPath {
    /// The walk of `scene` (named `name`): its tour where the built-in scene has one, else its
    /// camera carried sideways.
    pub fn for_scene(name: &str, scene: &SceneDescription) -> WalkPath {
        if let Some(tour) = scenes::find(name).and_then(|e| e.tour) {
            return WalkPath::Tour(tour);
        }
        let camera = scene
            .nodes
            .iter()
            .zip(scene.world_transforms())
            .find(|(n, _)| n.content.iter().any(|c| matches!(c, engine::scene::NodeContent::Camera(_))));
        let start = camera.map_or(Transform::IDENTITY, |(_, world)| {
            let (scale, rotation, translation) = world.to_scale_rotation_translation();
            Transform { translation, rotation, scale }
        });
        WalkPath::Dolly { start }
    }

    /// The camera after walking `distance` (scene units, from the start of the walk).
    pub fn camera_at(&self, distance: f32) -> Transform {
        match *self {
            WalkPath::Tour(tour) => {
                let (eye, forward) = tour(distance);
                Transform::from_translation(eye).looking_at(eye + forward * 10.0 - Vec3::Y, Vec3::Y)
            }
            WalkPath::Dolly { start } => Transform { translation: start.translation + start.rotation * Vec3::X * distance, ..start },
        }
    }
}

/// What the walk renders.
#[derive(Clone, Debug)]
pub struct WalkOptions {
    pub size: RenderSize,
    /// Frames of the walk (at 60 per second of the tour).
    pub frames: u32,
    /// Walking speed in scene units (metres) per second (the walk advances `speed / 60` a frame).
    pub speed: f32,
    /// Where on the path the walk starts (scene units along it).
    pub start: f32,
    /// Frames before the walk starts (the camera stands at the start while the probes converge).
    pub warmup: u32,
    /// The method: DDGI with one volume or with cascades (the benchmarks), or any of `eval`'s.
    pub config: Config,
    pub path: WalkPath,
    /// The scene's placement in the world ([`SceneDescription::origin`]).
    pub offset: DVec3,
    /// The sky's radiance ([`engine::render::Sky::Uniform`]).
    pub sky: Vec3,
    /// Write the frame as `frame_NNNNN.png` into the output folder every this many frames.
    pub every: Option<u32>,
    /// The sky light beyond the volumes.
    pub sky_light: ddgi::DdgiSkyLight,
    /// Every this many frames, measure the frame against a path-traced reference of the same view
    /// (`reference_spp` paths per pixel); every frame (1): also the flicker ([`WalkFrame::flicker`]).
    pub error_every: Option<u32>,
    pub reference_spp: u32,
    /// Folder where the references are kept between runs (each view's once), or `None`.
    pub cache: Option<PathBuf>,
    /// Report progress on the terminal.
    pub progress: bool,
}

impl WalkOptions {
    /// A walk of `frames` frames at `size` with `config` along `path`, from its start at 1.5 m/s
    /// after 60 frames standing, under a black sky, measuring nothing.
    pub fn new(config: Config, path: WalkPath, size: RenderSize, frames: u32) -> Self {
        Self {
            size,
            frames,
            speed: 1.5,
            start: 0.0,
            warmup: 60,
            config,
            path,
            offset: DVec3::ZERO,
            sky: Vec3::ZERO,
            every: None,
            sky_light: ddgi::DdgiSkyLight::default(),
            error_every: None,
            reference_spp: 1024,
            cache: None,
            progress: true,
        }
    }
}

/// One frame of the walk.
#[derive(Clone, Debug, Default)]
pub struct WalkFrame {
    pub frame: u32,
    /// Metres walked.
    pub distance: f32,
    /// GPU ms of every DDGI pass, and of each volume's gather by volume index (the probe
    /// updates of all volumes share their passes: [`WalkReport::pass_medians`]).
    pub ddgi_ms: f64,
    pub volume_ms: Vec<f64>,
    /// GPU ms of every pass of the frame.
    pub frame_ms: f64,
    /// GPU ms of the gathers (every volume's) and of the composite (with the sky light).
    pub gather_ms: f64,
    pub composite_ms: f64,
    /// Volumes that scrolled in this frame, and whether the render origin rebased.
    pub scrolled: u32,
    pub rebased: bool,
    /// Mean FLIP against the path-traced reference of the frame's view (frames measured only).
    pub flip: Option<f32>,
    /// Flicker (when this frame and the one before were both measured): how far the image's change
    /// from the last frame strays from the reference's change between the same two views — the
    /// mean absolute difference of the two changes of each pixel's luminance, over the reference's
    /// mean luminance ([`temporal_error`]). 0 when the method changes exactly as the light does;
    /// noise in the probes, a popping cascade or a lagging update raise it.
    pub flicker: Option<f32>,
    /// Rays DDGI traced in the frame, over every volume (read back from the GPU; `None` where it
    /// had not come back when the walk ended), and by volume (`None`: it did not update).
    pub rays: Option<f64>,
    pub volume_rays: Vec<Option<f64>>,
}

/// The walk's frames and their summary.
#[derive(Clone, Debug, Default)]
pub struct WalkReport {
    pub frames: Vec<WalkFrame>,
    pub volumes: usize,
    /// Every pass's GPU ms, frame by frame (the frames in which it ran), by label.
    pub passes: std::collections::BTreeMap<String, Vec<f64>>,
}

impl WalkReport {
    fn ddgi(&self) -> Vec<f64> {
        self.frames.iter().map(|f| f.ddgi_ms).collect()
    }

    /// Median DDGI ms per frame.
    pub fn median_ddgi_ms(&self) -> f64 {
        crate::median(&mut self.ddgi()).unwrap_or(0.0)
    }

    /// The slowest frame's DDGI ms.
    pub fn max_ddgi_ms(&self) -> f64 {
        self.ddgi().into_iter().fold(0.0, f64::max)
    }

    /// Frames whose DDGI time is over `factor` × the median.
    pub fn frames_over(&self, factor: f64) -> usize {
        let limit = factor * self.median_ddgi_ms();
        self.frames.iter().filter(|f| f.ddgi_ms > limit).count()
    }

    /// Median of `f` over the frames.
    pub fn median_of(&self, f: impl Fn(&WalkFrame) -> f64) -> f64 {
        crate::median(&mut self.frames.iter().map(f).collect::<Vec<_>>()).unwrap_or(0.0)
    }

    /// Volume `k`'s mean rays per frame over the frames whose counts came back (0 for a frame in
    /// which it did not update).
    pub fn mean_volume_rays(&self, k: usize) -> Option<f64> {
        let counted: Vec<&WalkFrame> = self.frames.iter().filter(|f| f.rays.is_some()).collect();
        (!counted.is_empty())
            .then(|| counted.iter().map(|f| f.volume_rays.get(k).copied().flatten().unwrap_or(0.0)).sum::<f64>() / counted.len() as f64)
    }

    /// Each pass's median GPU ms over the frames in which it ran, and in how many it ran.
    pub fn pass_medians(&self) -> Vec<(String, f64, usize)> {
        self.passes.iter().map(|(label, ms)| (label.clone(), crate::median(&mut ms.clone()).unwrap_or(0.0), ms.len())).collect()
    }

    /// Mean rays traced per frame, over the frames whose count came back.
    pub fn mean_rays(&self) -> Option<f64> {
        let values: Vec<f64> = self.frames.iter().filter_map(|f| f.rays).collect();
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    }

    /// The mean flicker of the frames that have one.
    pub fn mean_flicker(&self) -> Option<f64> {
        let values: Vec<f64> = self.frames.iter().filter_map(|f| f.flicker).map(f64::from).collect();
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    }

    /// The measured frames' FLIP against their references: mean, and the mean change from one
    /// measured frame to the next.
    pub fn flip_summary(&self) -> Option<(f64, f64)> {
        let flips: Vec<f64> = self.frames.iter().filter_map(|f| f.flip).map(f64::from).collect();
        if flips.is_empty() {
            return None;
        }
        let mean = flips.iter().sum::<f64>() / flips.len() as f64;
        let change = flips.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>() / (flips.len().max(2) - 1) as f64;
        Some((mean, change))
    }

    /// Median ms of volume `k`'s gather.
    pub fn median_volume_ms(&self, k: usize) -> f64 {
        crate::median(&mut self.frames.iter().filter_map(|f| f.volume_ms.get(k).copied()).collect::<Vec<_>>()).unwrap_or(0.0)
    }

    /// Every frame as CSV.
    pub fn csv(&self) -> String {
        let mut out = String::from("frame,distance_m,ddgi_ms,frame_ms,gather_ms,composite_ms,scrolled_volumes,rebased,flip,flicker,rays");
        for k in 0..self.volumes {
            let _ = write!(out, ",gather_{k}_ms");
        }
        out.push('\n');
        for f in &self.frames {
            let _ = write!(
                out,
                "{},{:.2},{:.4},{:.4},{:.4},{:.4},{},{},{},{},{}",
                f.frame,
                f.distance,
                f.ddgi_ms,
                f.frame_ms,
                f.gather_ms,
                f.composite_ms,
                f.scrolled,
                u8::from(f.rebased),
                f.flip.map_or(String::new(), |v| format!("{v:.5}")),
                f.flicker.map_or(String::new(), |v| format!("{v:.5}")),
                f.rays.map_or(String::new(), |v| format!("{v:.0}"))
            );
            for ms in &f.volume_ms {
                let _ = write!(out, ",{ms:.4}");
            }
            out.push('\n');
        }
        out
    }
}

/// Whether a pass label is the gather of volume `k` of `n`.
fn of_volume(label: &str, k: usize, n: usize) -> bool {
    label.strip_prefix("ddgi_gather") == Some(ddgi::volume_suffix(k, n).as_str())
}

/// The temporal error of a frame: `(current − previous)` of the method against `(current −
/// previous)` of the reference, per pixel in luminance, the mean absolute difference over the
/// reference's mean luminance in the current frame (linear RGBA images of one size; 0 for black
/// references; non-finite pixels are left out). A still view that does not change scores 0 when the
/// method is still too; on a moving camera the reference's own change is taken out, so what is left
/// is what the method adds: noise, popping, lag.
pub fn temporal_error(previous: &[f32], current: &[f32], reference_previous: &[f32], reference: &[f32]) -> f64 {
    let luminance = |p: &[f32]| 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
    let (mut change, mut total, mut n) = (0.0, 0.0, 0usize);
    let pixels =
        previous.chunks_exact(4).zip(current.chunks_exact(4)).zip(reference_previous.chunks_exact(4).zip(reference.chunks_exact(4)));
    for ((a, b), (ra, rb)) in pixels {
        let (a, b, ra, rb) = (luminance(a), luminance(b), luminance(ra), luminance(rb));
        if a.is_finite() && b.is_finite() && ra.is_finite() && rb.is_finite() {
            change += ((b - a) - (rb - ra)).abs();
            total += rb.abs();
            n += 1;
        }
    }
    if n > 0 && total > 0.0 { change / total } else { 0.0 }
}

/// The path-traced image of `scene` seen from `camera` (linear RGBA), `spp` paths per pixel, from
/// the cache when it has this view.
fn reference_view(gpu: &GpuContext, scene: &SceneDescription, camera: Transform, options: &WalkOptions) -> Result<Vec<f32>, String> {
    let mut scene = scene.clone();
    for node in &mut scene.nodes {
        if node.content.iter().any(|c| matches!(c, engine::scene::NodeContent::Camera(_))) {
            node.transform = camera;
        }
    }
    let (width, height) = (options.size.width, options.size.height);
    let render = || -> Result<Vec<f32>, String> {
        let per_frame = options.reference_spp.clamp(1, 16);
        let frames = options.reference_spp.max(1).div_ceil(per_frame);
        let settings = HeadlessSettings { width, height, frames, ..Default::default() };
        let frame = engine::headless::render_scene_with(gpu, scene.clone(), &settings, |app| {
            crate::progress::show_blas_builds(app);
            app.insert_resource(engine::render::Sky::Uniform(options.sky));
            pathtrace::use_path_tracer(app, pathtrace::PathTraceSettings { samples_per_frame: per_frame, ..Default::default() });
        })
        .map_err(|e| e.to_string())?;
        Ok(frame.hdr)
    };
    match &options.cache {
        Some(cache) => {
            let sky = options.sky.to_array().map(|c| format!("{c:.4}")).join("_");
            let key =
                crate::eval::reference_path(cache, &format!("{}-walk-sky{sky}", scene.name), &scene, width, height, options.reference_spp);
            Ok(crate::eval::cached_image(&key, width, height, render)?.0)
        }
        None => render(),
    }
}

/// Walks `scene`'s camera along `options.path` and measures every frame.
pub fn walk(gpu: &GpuContext, mut scene: SceneDescription, options: &WalkOptions, out: Option<&Path>) -> Result<WalkReport, String> {
    scene.origin = options.offset;
    let camera_at = |walked: u32| options.path.camera_at(options.start + walked as f32 * options.speed / 60.0);
    // The camera stands at the start of the walk while the probes warm up.
    for node in &mut scene.nodes {
        if node.content.iter().any(|c| matches!(c, engine::scene::NodeContent::Camera(_))) {
            node.transform = camera_at(0);
        }
    }
    let described = scene.clone();
    let mut camera_now = camera_at(0);
    let mut measured: Result<(), String> = Ok(());
    let settings = HeadlessSettings { width: options.size.width, height: options.size.height, frames: 1, ..Default::default() };
    let seed = pathtrace::PathTraceSettings::default().seed;
    let mut app = scene_app(gpu, scene, &settings, |app| {
        app.insert_resource(engine::render::Sky::Uniform(options.sky)).insert_resource(options.sky_light);
        options.config.configure(app, seed);
    })
    .map_err(|e| e.to_string())?;
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let mut written: Result<(), String> = Ok(());
    let total = options.warmup + options.frames;
    let bar = if options.progress { indicatif::ProgressBar::new(u64::from(total)) } else { indicatif::ProgressBar::hidden() };
    let mut report = WalkReport::default();
    let mut scrolls_before: Vec<u64> = Vec::new();
    let mut rebases_before = 0;
    // The last measured frame's image and reference, for the flicker of the next one.
    let mut last_measured: Option<(u32, Vec<f32>, Vec<f32>)> = None;
    // The app's frame number of each walk frame, to find its ray counts when they have come back.
    let mut app_frames: Vec<u64> = Vec::new();
    let step = options.speed / 60.0;
    run_frames(&mut app, total, |frame, world| {
        bar.inc(1);
        let walked = frame.saturating_sub(options.warmup);
        let (scrolls, n): (Vec<u64>, usize) = match world.get_resource::<ddgi::DdgiGpuVolumes>() {
            Some(volumes) => {
                let s: Vec<u64> = volumes.volumes.iter().map(|(_, v)| v.scrolls).collect();
                let n = s.len();
                (s, n)
            }
            None => (Vec::new(), 0),
        };
        let scrolled = scrolls.iter().enumerate().filter(|(k, s)| scrolls_before.get(*k).is_some_and(|b| *s > b)).count() as u32;
        scrolls_before = scrolls;
        let rebases = world.resource::<RenderOrigin>().rebases;
        let rebased = rebases > rebases_before;
        rebases_before = rebases;
        if frame >= options.warmup
            && let Some(timing) = world.resource::<FrameTimings>().frames.last()
        {
            let ms = |f: &dyn Fn(&str) -> bool| timing.passes.iter().filter(|p| f(&p.label)).filter_map(|p| p.gpu_ms).sum::<f64>();
            report.frames.push(WalkFrame {
                frame: walked,
                distance: options.start + walked as f32 * step,
                ddgi_ms: ms(&|l| l.starts_with("ddgi_")),
                volume_ms: (0..n).map(|k| ms(&|l| of_volume(l, k, n))).collect(),
                frame_ms: ms(&|_| true),
                gather_ms: ms(&|l| l.starts_with("ddgi_gather")),
                composite_ms: ms(&|l| l == "ddgi_composite"),
                scrolled,
                rebased,
                flip: None,
                flicker: None,
                rays: None,
                volume_rays: Vec::new(),
            });
            app_frames.push(timing.frame);
            for p in &timing.passes {
                if let Some(ms) = p.gpu_ms {
                    report.passes.entry(p.label.clone()).or_default().push(ms);
                }
            }
            report.volumes = n;
            if let Some(every) = options.error_every
                && walked % every.max(1) == 0
                && measured.is_ok()
            {
                let image = engine::headless::read_hdr(gpu, world);
                match reference_view(gpu, &described, camera_now, options) {
                    Ok(reference) => {
                        let (w, h) = (options.size.width, options.size.height);
                        let error = crate::metrics::compare(&reference, &image, w, h, 1.0);
                        let flicker = match &last_measured {
                            Some((f, previous, reference_previous)) if f + 1 == walked => {
                                Some(temporal_error(previous, &image, reference_previous, &reference) as f32)
                            }
                            _ => None,
                        };
                        if let Some(last) = report.frames.last_mut() {
                            last.flip = Some(error.mean_flip);
                            last.flicker = flicker;
                        }
                        last_measured = Some((walked, image, reference));
                    }
                    Err(e) => measured = Err(e),
                }
            }
        }
        if let (Some(every), Some(dir)) = (options.every, out)
            && frame >= options.warmup
            && walked % every.max(1) == 0
            && written.is_ok()
        {
            let pixels = engine::headless::read_ldr(gpu, world);
            let path = dir.join(format!("frame_{walked:05}.png"));
            let (w, h) = (options.size.width, options.size.height);
            written =
                image::save_buffer(&path, &pixels, w, h, image::ExtendedColorType::Rgba8).map_err(|e| format!("{}: {e}", path.display()));
        }
        // The camera for the next frame.
        camera_now = camera_at((frame + 1).saturating_sub(options.warmup));
        let mut cameras = world.query_filtered::<&mut Transform, engine::bevy_ecs::query::With<Camera>>();
        for mut t in cameras.iter_mut(world) {
            *t = camera_now;
        }
    });
    bar.finish_and_clear();
    let by_frame: std::collections::HashMap<u64, &engine::render::FrameTiming> =
        app.world().resource::<FrameTimings>().frames.iter().map(|t| (t.frame, t)).collect();
    let n = report.volumes;
    let names: Vec<String> = (0..n).map(|k| ddgi::rays_counter(k, n)).collect();
    for (f, app_frame) in report.frames.iter_mut().zip(&app_frames) {
        let Some(timing) = by_frame.get(app_frame) else { continue };
        f.rays = ddgi::rays_traced(timing);
        f.volume_rays = names.iter().map(|name| timing.counters.iter().find(|(label, _)| label == name).map(|(_, v)| *v)).collect();
    }
    written?;
    measured?;
    if let Some(dir) = out {
        let path = dir.join("walk.csv");
        std::fs::write(&path, report.csv()).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey(v: f32, n: usize) -> Vec<f32> {
        (0..n).flat_map(|_| [v, v, v, 1.0]).collect()
    }

    #[test]
    fn flicker_is_what_the_method_changes_beyond_the_reference() {
        // Both brighten by the same amount: no flicker, however much the view changed.
        assert_eq!(temporal_error(&grey(0.5, 4), &grey(1.0, 4), &grey(0.5, 4), &grey(1.0, 4)), 0.0);
        // The reference stays, the method jumps by 0.1 of it.
        let f = temporal_error(&grey(1.0, 4), &grey(1.1, 4), &grey(1.0, 4), &grey(1.0, 4));
        assert!((f - 0.1).abs() < 1e-6, "{f}");
        // The method stays while the light changes: that lag counts too.
        let lag = temporal_error(&grey(1.0, 4), &grey(1.0, 4), &grey(1.0, 4), &grey(1.2, 4));
        assert!((lag - 0.2 / 1.2).abs() < 1e-6, "{lag}");
        // Black references and non-finite pixels give no NaN.
        assert_eq!(temporal_error(&grey(0.0, 4), &grey(1.0, 4), &grey(0.0, 4), &grey(0.0, 4)), 0.0);
        assert_eq!(temporal_error(&grey(f32::NAN, 4), &grey(1.0, 4), &grey(1.0, 4), &grey(1.0, 4)), 0.0);
    }

    #[test]
    fn a_dolly_carries_the_camera_sideways_without_turning() {
        let start = Transform::from_translation(Vec3::new(1.0, 2.0, 3.0)).looking_at(Vec3::new(1.0, 2.0, 0.0), Vec3::Y);
        let path = WalkPath::Dolly { start };
        let moved = path.camera_at(2.0);
        assert!((moved.translation - Vec3::new(3.0, 2.0, 3.0)).length() < 1e-5, "{:?}", moved.translation);
        assert_eq!(moved.rotation, start.rotation);
        assert_eq!(path.camera_at(0.0).translation, start.translation);
    }
}

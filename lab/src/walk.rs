//! `game_demo bench walk`: DDGI's GPU time, frame by frame, while the camera walks the open world's
//! tour ([`scenes::open::tour_at`]) — with camera-following cascades or one fixed volume — and
//! where the cascades scrolled and the render origin rebased, so that a spike can be traced to
//! what caused it.

use std::fmt::Write as _;
use std::path::Path;

use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, run_frames, scene_app};
use engine::render::{FrameTimings, RenderSize};
use engine::scene::{Camera, RenderOrigin, SceneDescription, Transform};
use glam::{DVec3, Vec3};

/// What the walk renders.
#[derive(Clone, Debug)]
pub struct WalkOptions {
    pub size: RenderSize,
    /// Frames of the walk (at 60 per second of the tour).
    pub frames: u32,
    /// Walking speed in metres per second (the tour advances `speed / 60` metres a frame).
    pub speed: f32,
    /// Frames before the walk starts (the camera stands at the door while the probes converge).
    pub warmup: u32,
    /// The cascades, or `None` for `volume`.
    pub cascades: Option<ddgi::DdgiCascades>,
    pub volume: ddgi::DdgiVolume,
    /// The scene's placement in the world ([`SceneDescription::origin`]).
    pub offset: DVec3,
    /// The sky's radiance ([`engine::render::SkyRadiance`]).
    pub sky: Vec3,
    /// Write the frame as `frame_NNNNN.png` into the output folder every this many frames.
    pub every: Option<u32>,
    /// The sky light beyond the volumes.
    pub sky_light: ddgi::DdgiSkyLight,
    /// Every this many frames, measure the frame against a path-traced reference of the same view
    /// (`reference_spp` paths per pixel) and against the previous measured frame's error (the
    /// error's change: flicker, where the view moves).
    pub error_every: Option<u32>,
    pub reference_spp: u32,
}

/// One frame of the walk.
#[derive(Clone, Debug, Default)]
pub struct WalkFrame {
    pub frame: u32,
    /// Metres walked.
    pub distance: f32,
    /// GPU ms of every DDGI pass, and of each volume's own passes (budget, trace, probe update,
    /// gather) by volume index.
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
}

/// The walk's frames and their summary.
#[derive(Clone, Debug, Default)]
pub struct WalkReport {
    pub frames: Vec<WalkFrame>,
    pub volumes: usize,
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

    /// Median ms of volume `k`'s passes.
    pub fn median_volume_ms(&self, k: usize) -> f64 {
        crate::median(&mut self.frames.iter().filter_map(|f| f.volume_ms.get(k).copied()).collect::<Vec<_>>()).unwrap_or(0.0)
    }

    /// Every frame as CSV.
    pub fn csv(&self) -> String {
        let mut out = String::from("frame,distance_m,ddgi_ms,frame_ms,gather_ms,composite_ms,scrolled_volumes,rebased,flip");
        for k in 0..self.volumes {
            let _ = write!(out, ",volume_{k}_ms");
        }
        out.push('\n');
        for f in &self.frames {
            let _ = write!(
                out,
                "{},{:.2},{:.4},{:.4},{:.4},{:.4},{},{},{}",
                f.frame,
                f.distance,
                f.ddgi_ms,
                f.frame_ms,
                f.gather_ms,
                f.composite_ms,
                f.scrolled,
                u8::from(f.rebased),
                f.flip.map_or(String::new(), |v| format!("{v:.5}"))
            );
            for ms in &f.volume_ms {
                let _ = write!(out, ",{ms:.4}");
            }
            out.push('\n');
        }
        out
    }
}

/// Whether a pass label belongs to volume `k` of `n` (its suffix `_k` when there are several).
fn of_volume(label: &str, k: usize, n: usize) -> bool {
    let base = ["ddgi_budget", "ddgi_trace", "ddgi_probe_update", "ddgi_gather"];
    base.iter().any(|b| if n > 1 { label == format!("{b}_{k}") } else { label == *b })
}

/// The path-traced image of `scene` seen from `camera` (linear RGBA), `spp` paths per pixel.
fn reference_view(gpu: &GpuContext, scene: &SceneDescription, camera: Transform, options: &WalkOptions) -> Result<Vec<f32>, String> {
    let mut scene = scene.clone();
    for node in &mut scene.nodes {
        if node.content.iter().any(|c| matches!(c, engine::scene::NodeContent::Camera(_))) {
            node.transform = camera;
        }
    }
    let per_frame = options.reference_spp.clamp(1, 16);
    let frames = options.reference_spp.max(1).div_ceil(per_frame);
    let settings = HeadlessSettings { width: options.size.width, height: options.size.height, frames, ..Default::default() };
    let frame = engine::headless::render_scene_with(gpu, scene, &settings, |app| {
        app.insert_resource(engine::render::SkyRadiance(options.sky));
        pathtrace::use_path_tracer(app, pathtrace::PathTraceSettings { samples_per_frame: per_frame, ..Default::default() });
    })
    .map_err(|e| e.to_string())?;
    Ok(frame.hdr)
}

/// Walks `scene`'s camera along the open world's tour and measures every frame.
pub fn walk(gpu: &GpuContext, mut scene: SceneDescription, options: &WalkOptions, out: Option<&Path>) -> Result<WalkReport, String> {
    scene.origin = options.offset;
    let described = scene.clone();
    let camera_node = described.nodes.iter().find(|n| n.content.iter().any(|c| matches!(c, engine::scene::NodeContent::Camera(_))));
    let mut camera_now = camera_node.map_or(Transform::IDENTITY, |n| n.transform);
    let mut measured: Result<(), String> = Ok(());
    let settings = HeadlessSettings { width: options.size.width, height: options.size.height, frames: 1, ..Default::default() };
    let mut app = scene_app(gpu, scene, &settings, |app| {
        app.insert_resource(engine::render::SkyRadiance(options.sky)).insert_resource(options.sky_light);
        match &options.cascades {
            Some(c) => ddgi::use_ddgi_cascades(app, c.clone(), ddgi::DdgiOutput::Full),
            None => ddgi::use_ddgi(app, options.volume.clone(), ddgi::DdgiOutput::Full),
        }
    })
    .map_err(|e| e.to_string())?;
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let mut written: Result<(), String> = Ok(());
    let total = options.warmup + options.frames;
    let bar = indicatif::ProgressBar::new(u64::from(total));
    let mut report = WalkReport::default();
    let mut scrolls_before: Vec<u64> = Vec::new();
    let mut rebases_before = 0;
    let step = options.speed / 60.0;
    run_frames(&mut app, total, |frame, world| {
        bar.inc(1);
        let walked = frame.saturating_sub(options.warmup);
        let volumes = world.resource::<ddgi::DdgiGpuVolumes>();
        let scrolls: Vec<u64> = volumes.volumes.iter().map(|(_, v)| v.scrolls).collect();
        let n = scrolls.len();
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
                distance: walked as f32 * step,
                ddgi_ms: ms(&|l| l.starts_with("ddgi_")),
                volume_ms: (0..n).map(|k| ms(&|l| of_volume(l, k, n))).collect(),
                frame_ms: ms(&|_| true),
                gather_ms: ms(&|l| l.starts_with("ddgi_gather")),
                composite_ms: ms(&|l| l == "ddgi_composite"),
                scrolled,
                rebased,
                flip: None,
            });
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
                        if let Some(last) = report.frames.last_mut() {
                            last.flip = Some(error.mean_flip);
                        }
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
        // The camera for the next frame: on the tour, looking ahead and a little down.
        let (eye, forward) = scenes::open::tour_at((walked + 1) as f32 * step);
        let mut cameras = world.query_filtered::<&mut Transform, engine::bevy_ecs::query::With<Camera>>();
        camera_now = Transform::from_translation(eye).looking_at(eye + forward * 10.0 - Vec3::Y, Vec3::Y);
        for mut t in cameras.iter_mut(world) {
            *t = camera_now;
        }
    });
    bar.finish_and_clear();
    written?;
    measured?;
    if let Some(dir) = out {
        let path = dir.join("walk.csv");
        std::fs::write(&path, report.csv()).map_err(|e| format!("{}: {e}", path.display()))?;
    }
    Ok(report)
}

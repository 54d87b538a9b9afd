//! `game_demo play --headless`: the level's scripted tour without a window, on the fixed clock.
//! Writes every `every`-th frame (and the last) as `frame_NNNNN.png` and one CSV row per frame:
//! the player's position, whether the door is open, the rays DDGI traced and the GPU time of each
//! pass.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use engine::app::GpuLost;
use engine::gpu::GpuContext;
use engine::headless::{headless_app, run_frames};
use engine::render::{FrameTimings, RenderSize};

use super::controller::Player;
use super::level::door_is_open;
use super::{PlayOptions, STEP_SECONDS, save_screenshot, setup_play};

pub struct HeadlessPlay {
    pub frames: u32,
    /// Write a PNG every this many frames (0: only the last).
    pub every: u32,
    pub out: PathBuf,
    /// Draw the DDGI overlay into the frames ([`overlay_views`]).
    pub overlay: bool,
}

/// What `play --headless --overlay` shows: the overlay's windows (at 1.25 pixels per point), the
/// probes as small spheres shaded by their irradiance and the volume's bounds as a wireframe.
pub fn overlay_views(app: &mut bevy_app::App) {
    super::add_overlay(app);
    let world = app.world_mut();
    let mut overlay = world.resource_mut::<ddgi_overlay::DdgiOverlay>();
    overlay.visible = true;
    overlay.headless_pixels_per_point = 1.25;
    let mut view = world.resource_mut::<ddgi::DdgiProbeView>();
    view.color = ddgi::DdgiProbeColor::Irradiance;
    view.radius = 0.06;
    world.resource_mut::<ddgi_overlay::DdgiVisualizerViews>().bounds = true;
}

/// What a headless run measured.
pub struct HeadlessReport {
    pub csv: PathBuf,
    pub images: Vec<PathBuf>,
    /// Mean GPU milliseconds per frame over the run.
    pub mean_gpu_ms: Option<f64>,
}

/// Runs the scripted tour for `run.frames` frames.
pub fn run_headless_play(gpu: &GpuContext, options: &PlayOptions, run: &HeadlessPlay) -> Result<HeadlessReport, String> {
    if run.frames == 0 {
        return Err("--frames must be at least 1".into());
    }
    std::fs::create_dir_all(&run.out).map_err(|e| format!("{}: {e}", run.out.display()))?;
    let mut app = headless_app(gpu, RenderSize { width: options.width, height: options.height }, STEP_SECONDS);
    setup_play(&mut app, options, true)?;
    if run.overlay {
        overlay_views(&mut app);
    }
    let mut players_per_frame = Vec::new();
    let mut images = Vec::new();
    let mut error = None;
    run_frames(&mut app, run.frames, |frame, world| {
        if error.is_some() {
            return;
        }
        if let Some(lost) = world.get_resource::<GpuLost>() {
            error = Some(format!("the GPU device was lost at frame {}: {}", lost.frame, lost.reason));
            return;
        }
        let door = door_is_open(world);
        let mut players = world.query::<&Player>();
        let feet = players.iter(world).next().map(|p| p.feet).unwrap_or_default();
        players_per_frame.push((feet, door));
        if (run.every > 0 && frame % run.every == 0) || frame + 1 == run.frames {
            let path = run.out.join(format!("frame_{frame:05}.png"));
            match save_screenshot(gpu, world, &path) {
                Ok(()) => images.push(path),
                Err(e) => error = Some(e),
            }
        }
    });
    if let Some(e) = error {
        return Err(e);
    }
    // The rays of a frame arrive a few frames late: the rows are written once the run is over.
    let timings = app.world().resource::<FrameTimings>();
    let columns: Vec<String> = timings.frames.iter().flat_map(|f| f.passes.iter().map(|p| p.label.clone())).fold(Vec::new(), |mut v, l| {
        if !v.contains(&l) {
            v.push(l);
        }
        v
    });
    let mut rows = Vec::new();
    let mut totals = Vec::new();
    for (frame, (feet, door)) in players_per_frame.iter().enumerate() {
        let mut row = format!("{frame},{:.4},{:.3},{:.3},{:.3},{}", frame as f64 * STEP_SECONDS, feet.x, feet.y, feet.z, u8::from(*door));
        let timing = timings.frames.iter().find(|f| f.frame == frame as u64);
        let rays = timing.and_then(|f| f.counters.iter().find(|(n, _)| n == "ddgi_rays")).map_or(String::new(), |(_, v)| format!("{v:.0}"));
        let times: Vec<Option<f64>> =
            columns.iter().map(|c| timing.and_then(|f| f.passes.iter().find(|p| &p.label == c)).and_then(|p| p.gpu_ms)).collect();
        let total = times.iter().any(Option::is_some).then(|| times.iter().flatten().sum::<f64>());
        let _ = write!(row, ",{rays},{}", total.map_or(String::new(), |t| format!("{t:.4}")));
        totals.extend(total);
        for ms in times {
            let _ = write!(row, ",{}", ms.map_or(String::new(), |m| format!("{m:.4}")));
        }
        rows.push(row);
    }
    let csv = run.out.join("frames.csv");
    write_csv(&csv, &columns, &rows)?;
    let mean_gpu_ms = (!totals.is_empty()).then(|| totals.iter().sum::<f64>() / totals.len() as f64);
    Ok(HeadlessReport { csv, images, mean_gpu_ms })
}

fn write_csv(path: &Path, columns: &[String], rows: &[String]) -> Result<(), String> {
    let mut text = String::from("frame,time_s,player_x,player_y,player_z,door_open,ddgi_rays,gpu_total_ms");
    for c in columns {
        let _ = write!(text, ",{c}_ms");
    }
    text.push('\n');
    for r in rows {
        text.push_str(r);
        text.push('\n');
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

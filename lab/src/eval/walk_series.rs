//! `game_demo eval --time-series --walk`: the error and the flicker of every frame while the camera
//! walks through the scene — the built-in scene's tour ([`scenes::SceneEntry::tour`]; the open
//! world's goes out of the house and into the forest) or, for a scene without one, its camera
//! carried sideways ([`WalkPath::for_scene`]).
//!
//! Each method walks the same frames from the same start (after [`EvalOptions::settle_frames`]
//! standing there, so that its probes have converged), and every frame is compared with a
//! path-traced reference of its own view: the mean FLIP, and the flicker — how far the image's
//! change from the frame before strays from the reference's change between the same two views
//! ([`crate::walk::temporal_error`]). Frames in which a cascade scrolled are marked, so that an error
//! or a flicker that scrolling causes shows against the frames around it. The references are
//! rendered once per view and kept in the cache, so the methods after the first read them.

use std::fmt::Write as _;
use std::path::Path;

use engine::glam::Vec3;
use engine::gpu::GpuContext;
use engine::render::RenderSize;
use engine::scene::SceneDescription;

use super::{Config, EvalOptions, SceneFacts, still, write};
use crate::plot;
use crate::walk::{WalkOptions, WalkPath, WalkReport, walk};

/// Where the walk goes and how fast.
#[derive(Clone, Copy, Debug)]
pub struct WalkSeries {
    /// Where along the path it starts (scene units).
    pub start: f32,
    /// Scene units per second (60 frames).
    pub speed: f32,
    /// The sky's radiance (W/(m²·sr)); `eval`'s still images use a black sky.
    pub sky: Vec3,
}

/// The methods of the walk: direct light, DDGI with the scene's grid (fixed and adaptive budgets)
/// and, with `--cascades`, DDGI's camera-following cascades.
pub fn walk_list(facts: &SceneFacts, options: &EvalOptions, scene: &SceneDescription) -> Vec<Config> {
    let list =
        vec![Config::Direct, Config::ddgi_default(facts, options.grid), Config::ddgi_adaptive(facts, options.grid, &options.adaptive)];
    Config::for_scene(list, scene, options.cascades.as_ref())
}

/// Walks every method of [`walk_list`] for `frames` frames and writes `time_series.csv`,
/// `time_series.png` and `report.md` into `options.out`. Returns each method's walk.
pub fn run(
    gpu: &GpuContext,
    facts: &SceneFacts,
    scene: SceneDescription,
    options: &EvalOptions,
    frames: u32,
    series: WalkSeries,
) -> Result<Vec<(String, WalkReport)>, String> {
    let out = &options.out;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let scene = still(scene);
    let path = WalkPath::for_scene(&facts.name, &scene);
    let size = RenderSize { width: options.width, height: options.height };
    let mut runs = Vec::new();
    let list = walk_list(facts, options, &scene);
    let count = list.len();
    for (k, config) in list.into_iter().enumerate() {
        let name = config.name();
        println!("walk {}/{count}: {name}", k + 1);
        let walk_options = WalkOptions {
            start: series.start,
            speed: series.speed,
            warmup: if matches!(config, Config::Direct) { 1 } else { options.settle_frames },
            offset: scene.origin,
            sky: series.sky,
            error_every: Some(1),
            reference_spp: options.reference_spp,
            cache: Some(options.cache.clone()),
            ..WalkOptions::new(config, path, size, frames)
        };
        runs.push((name, walk(gpu, scene.clone(), &walk_options, None)?));
    }
    write_csv(&out.join("time_series.csv"), &runs)?;
    let marks: Vec<f64> = runs
        .iter()
        .find(|(_, r)| r.volumes > 1)
        .map(|(_, r)| r.frames.iter().filter(|f| f.scrolled > 0).map(|f| f64::from(f.frame)).collect())
        .unwrap_or_default();
    let line = |pick: fn(&crate::walk::WalkFrame) -> Option<f32>| -> Vec<plot::Series> {
        runs.iter()
            .map(|(name, r)| plot::Series {
                name: name.clone(),
                points: r.frames.iter().filter_map(|f| pick(f).map(|v| (f64::from(f.frame), plot::floor_for_log(f64::from(v))))).collect(),
            })
            .collect()
    };
    let caption = format!("{}: walking {:.0} units from {:.0}", facts.name, frames as f32 * series.speed / 60.0, series.start);
    plot::walk_series(&out.join("time_series.png"), &caption, &line(|f| f.flip), &line(|f| f.flicker), &marks)?;
    write_report(out, facts, &gpu.adapter_name(), options, frames, series, &runs)?;
    Ok(runs)
}

fn write_csv(path: &Path, runs: &[(String, WalkReport)]) -> Result<(), String> {
    let mut csv = String::from("config,frame,distance,flip,flicker,scrolled_volumes,rebased,ddgi_ms\n");
    for (name, report) in runs {
        for f in &report.frames {
            let shown = |v: Option<f32>| v.map_or(String::new(), |v| format!("{v:.5}"));
            let _ = writeln!(
                csv,
                "{name},{},{:.3},{},{},{},{},{:.4}",
                f.frame,
                f.distance,
                shown(f.flip),
                shown(f.flicker),
                f.scrolled,
                u8::from(f.rebased),
                f.ddgi_ms
            );
        }
    }
    write(path, &csv)
}

/// Mean of `f` over the frames that have it, in the frames `which` picks.
fn mean_of(
    report: &WalkReport,
    f: fn(&crate::walk::WalkFrame) -> Option<f32>,
    which: impl Fn(&crate::walk::WalkFrame) -> bool,
) -> Option<f64> {
    let v: Vec<f64> = report.frames.iter().filter(|x| which(x)).filter_map(f).map(f64::from).collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn write_report(
    out: &Path,
    facts: &SceneFacts,
    adapter: &str,
    options: &EvalOptions,
    frames: u32,
    series: WalkSeries,
    runs: &[(String, WalkReport)],
) -> Result<(), String> {
    let mut md = format!(
        "# Walk: {}\n\n{}×{} on {adapter}: {frames} frames walking from {:.1} at {:.2} units per second (60 frames a second), each method \
         after {} frames standing at the start (direct light: 1); sky radiance {:?}. Every frame is compared with a path-traced \
         reference of its own view at {} paths per pixel (mean FLIP on sRGB at exposure 1). Flicker: the mean absolute difference \
         between the method's change of each pixel's luminance from the frame before and the reference's, over the reference's mean \
         luminance (0: the image changes exactly as the light does; the references' own noise sets a floor under it, the same for \
         every method). Scrolled: frames in which at least one cascade scrolled.\n\n\
         | configuration | mean FLIP | mean flicker | FLIP, frames that scrolled | FLIP, the others | flicker, frames that scrolled | flicker, the others | frames that scrolled | DDGI GPU ms, median | rays per frame |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        facts.name,
        options.width,
        options.height,
        series.start,
        series.speed,
        options.settle_frames,
        series.sky.to_array(),
        options.reference_spp,
    );
    let shown = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.4}"));
    for (name, r) in runs {
        let scrolled = r.frames.iter().filter(|f| f.scrolled > 0).count();
        let _ = writeln!(
            md,
            "| {name} | {} | {} | {} | {} | {} | {} | {scrolled} | {:.3} | {} |",
            shown(mean_of(r, |f| f.flip, |_| true)),
            shown(mean_of(r, |f| f.flicker, |_| true)),
            shown(mean_of(r, |f| f.flip, |f| f.scrolled > 0)),
            shown(mean_of(r, |f| f.flip, |f| f.scrolled == 0)),
            shown(mean_of(r, |f| f.flicker, |f| f.scrolled > 0)),
            shown(mean_of(r, |f| f.flicker, |f| f.scrolled == 0)),
            r.median_ddgi_ms(),
            r.mean_rays().map_or("n/a".to_string(), |v| format!("{v:.0}")),
        );
    }
    md += "\nMean FLIP and flicker per frame, one series per configuration, log scale; grey lines where a cascade scrolled:\n\n\
           ![error and flicker per frame](time_series.png)\n\n\
           Every frame: [time_series.csv](time_series.csv) (config, frame, distance walked, flip, flicker, scrolled volumes, rebased, \
           DDGI GPU ms).\n";
    write(&out.join("report.md"), &md)
}

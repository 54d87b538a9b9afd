//! The time series' report: how each configuration settled after the change ([`settling`],
//! [`recovery`], [`trend`]), `time_series.csv`, `video_quality.csv`, their plots and `report.md`.

use std::path::Path;

use engine::scene::SceneDescription;

use super::{SceneChange, SeriesRow, StaticPhase, VideoQuality, mean, settle_frames_of};
use crate::eval::{Config, EvalOptions, SceneFacts, write};
use crate::plot;

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

pub(super) fn jod_text(jod: Option<f32>) -> String {
    jod.map_or("n/a".into(), |j| format!("{j:.3}"))
}

pub(super) fn write_video_csv(path: &Path, statics: &[StaticPhase], videos: &[VideoQuality]) -> Result<(), String> {
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
pub(super) fn plot_video(path: &Path, name: &str, videos: &[VideoQuality]) -> Result<(), String> {
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

pub(super) fn write_csv(path: &Path, rows: &[SeriesRow]) -> Result<(), String> {
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

pub(super) fn plot_series(path: &Path, name: &str, change: &SceneChange, rows: &[SeriesRow]) -> Result<String, String> {
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
pub(super) fn write_report(
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
    fn settling_finds_the_first_frame_that_stays_within_ten_percent() {
        let (settled, from) = settling(&[1.0, 0.5, 0.2, 0.105, 0.12, 0.1]);
        assert_eq!(settled, 0.1);
        // 0.12 is 20% off: the error has settled only from the last frame on.
        assert_eq!(from, Some(5));
        assert_eq!(settling(&[0.3, 0.3, 0.3]), (0.3, Some(0)), "a constant error has settled at once");
        assert_eq!(settling(&[]).1, None);
    }
}

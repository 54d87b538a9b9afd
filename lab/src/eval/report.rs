//! The still evaluation's results ([`EvalRow`]): each DDGI configuration against the path
//! tracer's ladder at equal FLIP ([`spp_at_equal_flip`]), the plot of error against GPU time, the
//! strips of panels and `report.md` with `results.json`.

use std::path::Path;

use serde::Serialize;

use super::{Config, DDGI_FRAMES, EvalOptions, PATH_TRACE_LADDER, SAMPLES_PER_FRAME, TIMING_SPP};
use crate::metrics::ErrorMetrics;
use crate::plot;

/// A configuration's result.
#[derive(Serialize)]
pub struct EvalRow {
    pub config: String,
    pub method: String,
    pub frames: u32,
    /// Mean GPU milliseconds per frame (all passes that ran), or absent without timestamps.
    pub gpu_ms_per_frame: Option<f64>,
    /// GPU milliseconds for the whole image (all frames).
    pub gpu_ms_total: Option<f64>,
    /// DDGI's rays traced per frame, every volume together: the mean over the frames whose count
    /// came back (absent for the other methods).
    pub rays_per_frame: Option<f64>,
    pub error: ErrorMetrics,
    /// A DDGI configuration's cost against the path tracer's at equal error (absent for the
    /// other methods).
    pub equal_flip: Option<EqualFlip>,
}

/// Where a FLIP falls on the path tracer's ladder ([`spp_at_equal_flip`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LadderPosition {
    /// Between the first and the last rung (or on one): interpolated.
    Within,
    /// Worse than the path tracer's fewest paths per pixel: its equal is at most that rung's.
    Below,
    /// Better than the path tracer's most paths per pixel: its equal is at least that rung's.
    Above,
}

/// A DDGI configuration against the path tracer at the same mean FLIP.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EqualFlip {
    /// The path tracer's paths per pixel at this configuration's mean FLIP, interpolated on the
    /// ladder ([`spp_at_equal_flip`]); clamped to its ends outside it (see `position`).
    pub pathtrace_spp: f64,
    pub position: LadderPosition,
    /// The path tracer's GPU ms for `pathtrace_spp` paths per pixel over this configuration's GPU
    /// ms per frame, at the evaluation's size: how many of its frames the path tracer's image of
    /// the same error costs.
    pub gpu_time_ratio: Option<f64>,
    /// The same at [`EvalOptions::timing_size`], both timed there.
    pub gpu_time_ratio_at_timing_size: Option<f64>,
    /// This configuration's GPU ms per frame at [`EvalOptions::timing_size`].
    pub gpu_ms_per_frame_at_timing_size: Option<f64>,
}

/// The path tracer's paths per pixel at `flip`, on `ladder` (paths per pixel and mean FLIP of each
/// rung), and whether `flip` was within it. FLIP falls as paths are added (as about spp^-½: a line
/// in log-log), so the interpolation is linear between neighbouring rungs in ln spp against ln FLIP,
/// exact at the rungs. A rung noisier than the one before it is taken at the one before's FLIP, so
/// that the result never falls as `flip` does. Outside the ladder: its end, and
/// [`LadderPosition::Below`] or [`LadderPosition::Above`]. `None` for an empty ladder or a FLIP
/// that is not finite.
pub fn spp_at_equal_flip(ladder: &[(f64, f64)], flip: f64) -> Option<(f64, LadderPosition)> {
    if !flip.is_finite() || ladder.iter().any(|&(spp, f)| !(spp > 0.0 && f.is_finite())) {
        return None;
    }
    let mut rungs = ladder.to_vec();
    rungs.sort_by(|a, b| a.0.total_cmp(&b.0));
    for i in 1..rungs.len() {
        rungs[i].1 = rungs[i].1.min(rungs[i - 1].1);
    }
    let (&(first_spp, first), &(last_spp, last)) = (rungs.first()?, rungs.last()?);
    if flip > first {
        return Some((first_spp, LadderPosition::Below));
    }
    if flip < last {
        return Some((last_spp, LadderPosition::Above));
    }
    // The first rung at or under `flip`: the fewest paths that reach it.
    let i = rungs.iter().position(|&(_, f)| f <= flip)?;
    let (spp, f) = rungs[i];
    if f == flip || i == 0 {
        return Some((spp, LadderPosition::Within));
    }
    let (spp0, f0) = rungs[i - 1];
    let ln = |v: f64| v.max(f64::MIN_POSITIVE).ln();
    let t = (ln(flip) - ln(f0)) / (ln(f) - ln(f0));
    Some(((ln(spp0) + t * (ln(spp) - ln(spp0))).exp().clamp(spp0, spp), LadderPosition::Within))
}

/// The path tracer's GPU ms per path per pixel on the ladder of `rows`: its rung of the most paths
/// (the first frame's fixed costs spread the thinnest), its GPU ms in total over its paths.
fn ladder_ms_per_spp(rows: &[EvalRow]) -> Option<f64> {
    PATH_TRACE_LADDER.iter().rev().find_map(|&spp| {
        let name = Config::PathTrace { spp }.name();
        rows.iter().find(|r| r.config == name).and_then(|r| r.gpu_ms_total).map(|ms| ms / f64::from(spp))
    })
}

/// A DDGI configuration of mean FLIP `flip` and `ms_per_frame` (`large_ms_per_frame` at the timing
/// size) against the path tracer's ladder in `rows` (`timing_ms_per_spp`: its GPU ms per path per
/// pixel at the timing size). `None` without a ladder.
pub(super) fn equal_flip(
    rows: &[EvalRow],
    flip: f64,
    ms_per_frame: Option<f64>,
    timing_ms_per_spp: Option<f64>,
    large_ms_per_frame: Option<f64>,
) -> Option<EqualFlip> {
    let ladder: Vec<(f64, f64)> = PATH_TRACE_LADDER
        .iter()
        .filter_map(|&spp| {
            let name = Config::PathTrace { spp }.name();
            rows.iter().find(|r| r.config == name).map(|r| (f64::from(spp), f64::from(r.error.mean_flip)))
        })
        .collect();
    let (pathtrace_spp, position) = spp_at_equal_flip(&ladder, flip)?;
    let ratio = |ms_per_spp: Option<f64>, ms_per_frame: Option<f64>| {
        let (per_spp, per_frame) = (ms_per_spp?, ms_per_frame?);
        (per_frame > 0.0).then(|| pathtrace_spp * per_spp / per_frame)
    };
    Some(EqualFlip {
        pathtrace_spp,
        position,
        gpu_time_ratio: ratio(ladder_ms_per_spp(rows), ms_per_frame),
        gpu_time_ratio_at_timing_size: ratio(timing_ms_per_spp, large_ms_per_frame),
        gpu_ms_per_frame_at_timing_size: large_ms_per_frame,
    })
}

/// The path tracer's paths per pixel at equal FLIP as the report shows it: "≤ 1" and "≥ 64"
/// outside the ladder.
pub(super) fn spp_text(e: &EqualFlip) -> String {
    match e.position {
        LadderPosition::Within => format!("{:.1} spp", e.pathtrace_spp),
        LadderPosition::Below => format!("≤ {} spp", e.pathtrace_spp),
        LadderPosition::Above => format!("≥ {} spp", e.pathtrace_spp),
    }
}

/// One series per method through its configurations: mean FLIP against GPU ms per frame and in
/// total. Returns a note for the report on what the plot leaves out or clamps.
pub(super) fn plot_error_vs_time(path: &Path, rows: &[EvalRow]) -> Result<String, String> {
    let mut methods: Vec<&str> = Vec::new();
    for row in rows {
        if !methods.contains(&row.method.as_str()) {
            methods.push(&row.method);
        }
    }
    let series = |ms: fn(&EvalRow) -> Option<f64>| -> Vec<plot::Series> {
        methods
            .iter()
            .map(|&method| {
                let mut points: Vec<(f64, f64)> = rows
                    .iter()
                    .filter(|r| r.method == method)
                    .filter_map(|r| Some((plot::floor_for_log(ms(r)?), plot::floor_for_log(f64::from(r.error.mean_flip)))))
                    .collect();
                // A method's configurations in order of cost, so that its line reads left to right.
                points.sort_by(|a, b| a.0.total_cmp(&b.0));
                plot::Series { name: method.to_string(), points }
            })
            .collect()
    };
    plot::error_vs_time(path, &series(|r| r.gpu_ms_per_frame), &series(|r| r.gpu_ms_total))?;
    let mut notes = Vec::new();
    let untimed: Vec<&str> = rows.iter().filter(|r| r.gpu_ms_total.is_none()).map(|r| r.config.as_str()).collect();
    if !untimed.is_empty() {
        notes.push(format!("left out for want of GPU timestamps: {}", untimed.join(", ")));
    }
    let values = rows.iter().flat_map(|r| [r.gpu_ms_per_frame, r.gpu_ms_total, Some(f64::from(r.error.mean_flip))]).flatten();
    let zeros = plot::floored(values);
    if zeros > 0 {
        notes.push(format!("{zeros} values below {} drawn at {} on the log axes", plot::LOG_FLOOR, plot::LOG_FLOOR));
    }
    Ok(if notes.is_empty() { String::new() } else { format!(" ({})", notes.join("; ")) })
}

pub(super) fn write_report(
    out: &Path,
    name: &str,
    adapter: &str,
    options: &EvalOptions,
    rows: &[EvalRow],
    plot_note: &str,
) -> Result<(), String> {
    let EvalOptions { width, height, reference_spp, timing_size, .. } = *options;
    let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
    // A scene made by others names its authors wherever it is shown.
    let credit = scenes::files::find(name).map_or(String::new(), |file| format!("The scene: {}.\n\n", file.credit));
    let mut md = format!(
        "# Evaluation: {name}\n\n{credit}{width}×{height} on {adapter}; reference: the path tracer at {reference_spp} paths per pixel (another seed).\n\
         FLIP on sRGB tonemapped at exposure 1; RMSE and relative MSE on linear radiance.\n\
         Each strip `<configuration>.png`: direct only | the configuration | the reference | FLIP map (magma).\n\n\
         | configuration | frames | GPU ms per frame | GPU ms total | DDGI rays per frame | mean FLIP | RMSE | relative MSE | path tracer at equal FLIP | GPU-time ratio | GPU-time ratio at {timing} |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        timing = timing_size.map_or("the timing size (not timed)".into(), |[w, h]| format!("{w}×{h}"))
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.5} | {} | {} | {} |\n",
            r.config,
            r.frames,
            ms(r.gpu_ms_per_frame),
            ms(r.gpu_ms_total),
            r.rays_per_frame.map_or("-".to_string(), |v| format!("{v:.0}")),
            r.error.mean_flip,
            r.error.rmse,
            r.error.relative_mse,
            r.equal_flip.map_or("-".into(), |e| spp_text(&e)),
            r.equal_flip.map_or("-".into(), |e| e.gpu_time_ratio.map_or("n/a".into(), |v| format!("{v:.3}"))),
            r.equal_flip.map_or("-".into(), |e| e.gpu_time_ratio_at_timing_size.map_or("n/a".into(), |v| format!("{v:.3}"))),
        );
    }
    let timed = timing_size.map_or(String::new(), |[w, h]| {
        format!(
            " At {w}×{h} both are timed there: the path tracer at {TIMING_SPP} paths per pixel ({} frames), its GPU ms in total \
             over {TIMING_SPP}, and each DDGI configuration over its {DDGI_FRAMES} frames, GPU ms per frame.",
            TIMING_SPP.div_ceil(SAMPLES_PER_FRAME)
        )
    });
    md += &format!(
        "\nPath tracer at equal FLIP (DDGI configurations): the path tracer's paths per pixel at the configuration's mean FLIP, \
         interpolated on its ladder ({ladder} spp) linearly in ln spp against ln FLIP between the two rungs around it (exact at a \
         rung; a rung noisier than the one before it counts at the one before's FLIP); \"≤ {first} spp\" or \"≥ {last} spp\": the FLIP is \
         outside the ladder, and the ratio is computed at that end (then a bound). GPU-time ratio: the path tracer's GPU ms for those \
         paths per pixel over the configuration's GPU ms per frame: how many DDGI frames the path-traced image of the same error \
         costs. The path tracer's cost is linear in paths per pixel: at {width}×{height} the ladder's {last}-spp rung's GPU ms in total \
         over {last}, times the paths per pixel.{timed}\n",
        ladder = PATH_TRACE_LADDER.map(|s| s.to_string()).join(", "),
        first = PATH_TRACE_LADDER[0],
        last = PATH_TRACE_LADDER[PATH_TRACE_LADDER.len() - 1],
    );
    md += &format!(
        "\nMean FLIP against GPU time, one series per method, per frame (left) and in total for the image (right), log scales{plot_note}:\n\n\
         ![error against GPU time](error_vs_time.png)\n"
    );
    write(&out.join("report.md"), &md)?;
    let text = serde_json::to_string_pretty(rows).map_err(|e| e.to_string())?;
    write(&out.join("results.json"), &text)
}

/// Writes `panels` (sRGB8 RGB images of `width` × `height`) side by side, left to right, to `path`
/// as one PNG.
pub fn save_strip(path: &Path, panels: &[Vec<u8>], width: u32, height: u32) -> Result<(), String> {
    let mut strip = image::RgbImage::new(width * panels.len() as u32, height);
    for (k, panel) in panels.iter().enumerate() {
        for y in 0..height {
            for x in 0..width {
                let i = ((y * width + x) * 3) as usize;
                strip.put_pixel(k as u32 * width + x, y, image::Rgb([panel[i], panel[i + 1], panel[i + 2]]));
            }
        }
    }
    strip.save(path).map_err(|e| format!("{}: {e}", path.display()))
}

pub(super) fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_flip_is_exact_at_the_rungs_monotone_between_them_and_marked_outside() {
        // FLIP = 0.4 / √spp: a straight line in log-log, which the interpolation follows exactly.
        let law = |spp: f64| 0.4 / spp.sqrt();
        let ladder: Vec<(f64, f64)> = PATH_TRACE_LADDER.iter().map(|&s| (f64::from(s), law(f64::from(s)))).collect();
        for &(spp, flip) in &ladder {
            assert_eq!(spp_at_equal_flip(&ladder, flip), Some((spp, LadderPosition::Within)), "exact at the rung of {spp} spp");
        }
        for spp in [2.0, 10.0, 40.0] {
            let (found, position) = spp_at_equal_flip(&ladder, law(spp)).expect("within");
            assert!((found - spp).abs() < 1e-9 * spp && position == LadderPosition::Within, "{spp}: {found}");
        }
        // Less error needs more paths, never fewer, across the whole ladder (a noisy rung too).
        let noisy = [(1.0, 0.4), (4.0, 0.2), (16.0, 0.21), (64.0, 0.05)];
        for ladder in [ladder.as_slice(), &noisy] {
            let mut last = 0.0;
            for k in 0..=400 {
                let flip = 0.45 * (0.04f64 / 0.45).powf(f64::from(k) / 400.0);
                let (spp, _) = spp_at_equal_flip(ladder, flip).expect("finite");
                assert!(spp >= last && (1.0..=64.0).contains(&spp), "FLIP {flip}: {spp} spp after {last}");
                last = spp;
            }
        }
        // The noisy 16-spp rung counts at 4 spp's FLIP, 0.2: half way from 0.2 to 0.05 in ln FLIP is
        // half way from 16 to 64 spp in ln spp.
        let (spp, _) = spp_at_equal_flip(&noisy, 0.1).expect("within");
        assert!((spp - 32.0).abs() < 1e-9, "{spp}");
        assert_eq!(spp_at_equal_flip(&ladder, 0.5), Some((1.0, LadderPosition::Below)));
        assert_eq!(spp_at_equal_flip(&ladder, 0.01), Some((64.0, LadderPosition::Above)));
        // The order of the rungs does not matter; nothing to interpolate on is no answer.
        let reversed: Vec<(f64, f64)> = ladder.iter().rev().copied().collect();
        assert_eq!(spp_at_equal_flip(&reversed, law(10.0)), spp_at_equal_flip(&ladder, law(10.0)));
        assert_eq!(spp_at_equal_flip(&[], 0.1), None);
        assert_eq!(spp_at_equal_flip(&ladder, f64::NAN), None);
    }
}

//! The evaluation's plots (plotters, drawn into a buffer and saved as PNG with `image`). Text uses
//! an embedded font (Noto Sans, through ab_glyph), so no system font library is needed.

use std::ops::Range;
use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

/// Size of `error_vs_time.png`: two panels side by side.
pub const ERROR_VS_TIME_SIZE: (u32, u32) = (1200, 520);
/// Size of `time_series.png`.
pub const TIME_SERIES_SIZE: (u32, u32) = (900, 520);
/// Size of a walk's `time_series.png`: error and flicker, one panel above the other.
pub const WALK_SERIES_SIZE: (u32, u32) = (1000, 820);
/// Size of the time series' `video_quality.png`.
pub const BARS_SIZE: (u32, u32) = (900, 520);
/// Smallest value drawn on a log axis: zeros (an error of exactly 0, a pass too fast for the
/// timer) are drawn here instead; [`floored`] counts them so that the report can say so.
pub const LOG_FLOOR: f64 = 1e-5;

/// One line of a plot (a method), its points in drawing order.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// `value` raised to [`LOG_FLOOR`] for a log axis.
pub fn floor_for_log(value: f64) -> f64 {
    value.max(LOG_FLOOR)
}

/// How many of `values` [`floor_for_log`] raises.
pub fn floored(values: impl IntoIterator<Item = f64>) -> usize {
    values.into_iter().filter(|&v| v < LOG_FLOOR).count()
}

/// Mean FLIP against GPU milliseconds, log-log, one series per method, in two panels: GPU ms per
/// frame (what each frame costs) and GPU ms in total to produce the image (all its frames).
pub fn error_vs_time(path: &Path, per_frame: &[Series], total: &[Series]) -> Result<(), String> {
    draw_png(path, ERROR_VS_TIME_SIZE, |root| {
        let panels = root.split_evenly((1, 2));
        let y = log_range(per_frame.iter().chain(total).flat_map(|s| s.points.iter().map(|p| p.1)));
        let x = log_range(per_frame.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        let desc = "mean FLIP against the reference (log)";
        draw_chart(&panels[0], "Error against cost per frame", x.log_scale(), "GPU ms per frame (log)", y.clone(), desc, per_frame, &[])?;
        let x = log_range(total.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
        draw_chart(
            &panels[1],
            "Error against time to the image",
            x.log_scale(),
            "GPU ms for the image, all frames (log)",
            y,
            desc,
            total,
            &[],
        )
    })
}

/// Mean FLIP against the frame, the change happening before frame 0, one series per method.
pub fn time_series(path: &Path, caption: &str, series: &[Series]) -> Result<(), String> {
    draw_png(path, TIME_SERIES_SIZE, |root| {
        let frames = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
        let (first, last) = frames.fold((0.0f64, 1.0f64), |(lo, hi), f| (lo.min(f), hi.max(f)));
        let y = log_range(series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
        let x_desc = "frame (the change comes before frame 0)";
        draw_chart(root, caption, first - 0.5..last + 0.5, x_desc, y, "mean FLIP against the changed scene's reference (log)", series, &[])
    })
}

/// A walk frame by frame: mean FLIP (above) and flicker (below) against the frame, one series per
/// method, with a thin vertical line at each frame in `marks` (where a cascade scrolled).
pub fn walk_series(path: &Path, caption: &str, flips: &[Series], flickers: &[Series], marks: &[f64]) -> Result<(), String> {
    draw_png(path, WALK_SERIES_SIZE, |root| {
        let panels = root.split_evenly((2, 1));
        let frames = flips.iter().chain(flickers).flat_map(|s| s.points.iter().map(|p| p.0));
        let (first, last) = frames.fold((0.0f64, 1.0f64), |(lo, hi), f| (lo.min(f), hi.max(f)));
        let x = first - 0.5..last + 0.5;
        let x_desc = "frame of the walk (grey lines: a cascade scrolled)";
        let y = log_range(flips.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
        draw_chart(&panels[0], caption, x.clone(), x_desc, y, "mean FLIP against the view's reference (log)", flips, marks)?;
        let y = log_range(flickers.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
        draw_chart(&panels[1], "Flicker: change beyond the reference's, per frame", x, x_desc, y, "flicker (log)", flickers, marks)
    })
}

/// Grouped bars: for each of `categories`, one bar per group of `groups` (its name and one value
/// per category; a missing value leaves its bar out), on a linear axis from 0 (or the lowest value
/// under it) to the highest value.
pub fn bars(path: &Path, caption: &str, categories: &[String], groups: &[(String, Vec<Option<f64>>)], y_desc: &str) -> Result<(), String> {
    draw_png(path, BARS_SIZE, |root| {
        let values = groups.iter().flat_map(|(_, v)| v.iter().flatten().copied());
        let (lo, hi) = values.fold((0.0f64, 1.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        let n = categories.len().max(1);
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        let label = |x: &f64| {
            let i = x.round();
            let exact = (x - i).abs() < 1e-6 && i >= 0.0;
            exact.then(|| categories.get(i as usize).cloned()).flatten().unwrap_or_default()
        };
        let mut chart = ChartBuilder::on(root)
            .caption(caption, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(-0.5..n as f64 - 0.5, lo..hi + 0.45 * (hi - lo))
            .map_err(e)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(n + 2)
            .x_label_formatter(&label)
            .y_desc(y_desc)
            .y_label_formatter(&tick)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(e)?;
        let width = 0.8 / groups.len().max(1) as f64;
        for (g, (name, values)) in groups.iter().enumerate() {
            let color = Palette99::pick(g).to_rgba();
            let bars = values.iter().enumerate().filter_map(|(i, v)| {
                let x = i as f64 - 0.4 + g as f64 * width;
                v.map(|v| Rectangle::new([(x + 0.05 * width, 0.0), (x + 0.95 * width, v)], color.filled()))
            });
            chart
                .draw_series(bars)
                .map_err(e)?
                .label(name)
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], color.filled()));
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(e)
    })
}

/// A log axis range holding `values` (already floored) with some room; a decade when there are none.
fn log_range(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if !(lo.is_finite() && hi.is_finite()) {
        return 0.01..1.0;
    }
    let lo = lo / 1.5;
    lo..(hi * 1.5).max(lo * 10.0)
}

/// An axis label with about three significant digits and no trailing zeros: 0.3, 0.125, 1, 1000.
fn tick(value: &f64) -> String {
    if *value == 0.0 || !value.is_finite() {
        return format!("{value}");
    }
    let digits = (2 - value.abs().log10().floor() as i32).max(0) as usize;
    let text = format!("{value:.digits$}");
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text }
}

fn font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font("sans-serif", FontStyle::Normal, ttf_noto_sans::REGULAR)
                .map_err(|_| "the embedded Noto Sans font cannot be read".to_string())
        })
        .clone()
}

fn draw_png(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String>,
) -> Result<(), String> {
    font()?;
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw(&root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    image::RgbImage::from_raw(width, height, rgb)
        .ok_or("plot buffer size mismatch")?
        .save(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[allow(clippy::too_many_arguments)]
fn draw_chart<X>(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    caption: &str,
    x: X,
    x_desc: &str,
    y: Range<f64>,
    y_desc: &str,
    series: &[Series],
    marks: &[f64],
) -> Result<(), String>
where
    X: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
{
    let y_range = y.clone();
    let e = |e: DrawingAreaErrorKind<_>| e.to_string();
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x, y.log_scale())
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(e)?;
    let (y_lo, y_hi) = (y_range.start, y_range.end);
    chart
        .draw_series(marks.iter().map(|&m| PathElement::new([(m, y_lo), (m, y_hi)], RGBColor(190, 190, 190).stroke_width(1))))
        .map_err(e)?;
    for (i, s) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(s.points.iter().copied(), color.stroke_width(2)))
            .map_err(e)?
            .label(&s.name)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
        chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 3, color.filled()))).map_err(e)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(e)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_labels_are_short() {
        let labels: Vec<String> = [0.30000000000000004, 0.125, 1.0, 1000.0, 0.00012, -1.0, 0.0].iter().map(tick).collect();
        assert_eq!(labels, ["0.3", "0.125", "1", "1000", "0.00012", "-1", "0"]);
    }
}

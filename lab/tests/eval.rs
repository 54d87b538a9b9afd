//! The evaluation end to end: the report, the strips, the plot, the cached reference, errors that
//! fall as the path tracer gets more paths per pixel; and the time series after a change.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use engine::gpu::GpuContext;
use lab::eval::{EvalOptions, SceneFacts};
use lab::plot::{ERROR_VS_TIME_SIZE, TIME_SERIES_SIZE};

/// What `game_demo eval` does with its defaults but the size and the reference's paths per pixel.
fn options(size: u32, reference_spp: u32, out: PathBuf, cache: PathBuf) -> EvalOptions {
    EvalOptions {
        width: size,
        height: size,
        reference_spp,
        out,
        cache,
        experiments: false,
        adaptive: ddgi::DdgiAdaptive::on(),
        grid: None,
        settle_frames: 240,
        cascades: None,
        timing_size: None,
        hit_occlusion_rays: 0,
        hit_occlusion_reach: ddgi::DdgiVolume::default().hit_occlusion_reach,
    }
}

fn cornell() -> engine::scene::SceneDescription {
    (scenes::find("cornell").expect("cornell").build)()
}

/// The cached references in `cache`, with their modification times.
fn cached(cache: &Path) -> Vec<(PathBuf, SystemTime)> {
    let Ok(entries) = std::fs::read_dir(cache) else { return Vec::new() };
    entries.map(|e| e.expect("cache entry").path()).map(|p| (p.clone(), p.metadata().and_then(|m| m.modified()).expect("mtime"))).collect()
}

/// Asserts that `path` is a PNG of `size` with something drawn on it (not one flat colour).
fn assert_plot(path: &Path, size: (u32, u32)) {
    let plot = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8();
    assert_eq!(plot.dimensions(), size, "{}", path.display());
    let first = plot.get_pixel(0, 0);
    assert!(plot.pixels().any(|p| p != first), "{} is blank", path.display());
}

#[test]
fn eval_writes_a_report_whose_path_tracer_errors_fall_with_more_samples() {
    // CI=true makes a missing adapter a failure.
    let Some(gpu) = GpuContext::for_tests("eval_writes_a_report") else { return };
    let dir = std::env::temp_dir().join(format!("lab_eval_test_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (out, cache) = (dir.join("report"), dir.join("cache"));
    let options = options(48, 256, out.clone(), cache.clone());
    let run = |options: &EvalOptions| lab::eval::run(&gpu, &SceneFacts::named("cornell"), cornell(), options).expect("eval");
    // Timed at a second size too, as `game_demo eval` does at 1920×1080.
    let first_rows = run(&EvalOptions { timing_size: Some([64, 40]), ..self::options(48, 256, out.clone(), cache.clone()) });
    let first = cached(&cache);
    assert_eq!(first.len(), 1, "the first run path traces the reference and caches it: {first:?}");
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("results.json")).expect("json");
    let rows = results.as_array().expect("rows");
    let flip = |name: &str| rows.iter().find(|r| r["config"] == name).and_then(|r| r["error"]["mean_flip"].as_f64()).expect(name);
    let ladder = ["pathtrace_1spp", "pathtrace_4spp", "pathtrace_16spp", "pathtrace_64spp"].map(flip);
    assert!(ladder.windows(2).all(|w| w[1] < w[0]), "FLIP must fall as paths per pixel grow: {ladder:?}");
    // Direct light alone misses all indirect light: worse than 64 paths per pixel of the reference.
    assert!(flip("direct") > ladder[3], "direct {} vs 64 spp {}", flip("direct"), ladder[3]);
    // DDGI adds the indirect light direct light lacks.
    assert!(flip("ddgi_8x8x8") < 0.75 * flip("direct"), "DDGI {} vs direct {}", flip("ddgi_8x8x8"), flip("direct"));
    for name in ["direct", "pathtrace_1spp", "pathtrace_64spp"] {
        let strip = image::open(out.join(format!("{name}.png"))).expect("strip");
        assert_eq!((strip.width(), strip.height()), (4 * 48, 48));
    }
    assert_plot(&out.join("error_vs_time.png"), ERROR_VS_TIME_SIZE);
    let report = std::fs::read_to_string(out.join("report.md")).expect("report");
    assert!(report.contains("| pathtrace_16spp |"), "{report}");
    assert!(report.contains("](error_vs_time.png)"), "the report links the plot: {report}");
    // Each DDGI configuration against the path tracer at equal FLIP: its paths per pixel on the
    // ladder and the GPU-time ratios, finite and positive; none for the other methods.
    for row in &first_rows {
        let Some(equal) = row.equal_flip else {
            assert_ne!(row.method, "DDGI", "{}: no equal-FLIP figures", row.config);
            continue;
        };
        assert_eq!(row.method, "DDGI", "{}", row.config);
        assert!((1.0..=64.0).contains(&equal.pathtrace_spp), "{}: {equal:?}", row.config);
        let ratios = [equal.gpu_time_ratio, equal.gpu_time_ratio_at_timing_size, equal.gpu_ms_per_frame_at_timing_size];
        assert!(ratios.iter().all(|r| r.is_some_and(|r| r.is_finite() && r > 0.0)), "{}: {equal:?}", row.config);
        let json = rows.iter().find(|r| r["config"] == row.config.as_str()).expect("row in results.json");
        assert!(json["equal_flip"]["pathtrace_spp"].as_f64().is_some(), "results.json: {json}");
    }
    assert_eq!(first_rows.iter().filter(|r| r.equal_flip.is_some()).count(), 3, "the three DDGI configurations");
    assert!(report.contains("| path tracer at equal FLIP | GPU-time ratio | GPU-time ratio at 64×40 |"), "{report}");
    // The second run reads the reference from the cache (it does not write it again).
    run(&options);
    assert_eq!(cached(&cache), first);
    // The same scene 1e5 units from the origin (`eval --offset`): judged against the same
    // reference (the cache key leaves the placement out), every configuration — DDGI's volume
    // moved with the scene — within FLIP 0.01 of its error at the origin.
    let far = lab::eval::EvalOptions { out: dir.join("far"), cascades: None, ..self::options(48, 256, out.clone(), cache.clone()) };
    let offset = engine::scene::SceneDescription { origin: glam::DVec3::new(1e5, -1e5, 1e5), ..cornell() };
    let far_rows = lab::eval::run(&gpu, &SceneFacts::named("cornell"), offset, &far).expect("eval at an offset");
    assert_eq!(cached(&cache), first, "the offset scene reuses the origin's reference");
    for row in &far_rows {
        let at_origin = flip(&row.config);
        assert!(
            (f64::from(row.error.mean_flip) - at_origin).abs() <= 0.01,
            "{}: FLIP {} at 1e5, {at_origin} at the origin",
            row.config,
            row.error.mean_flip
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn time_series_measures_every_frame_and_the_path_tracer_converges_after_the_change() {
    let Some(gpu) = GpuContext::for_tests("time_series_measures_every_frame") else { return };
    let dir = std::env::temp_dir().join(format!("lab_time_series_test_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (out, cache) = (dir.join("report"), dir.join("cache"));
    let frames = 8;
    let options = EvalOptions { settle_frames: 60, ..options(32, 128, out.clone(), cache) };
    lab::eval::time_series::run(&gpu, &SceneFacts::named("cornell"), cornell(), &options, frames as u32).expect("time series");

    let csv = std::fs::read_to_string(out.join("time_series.csv")).expect("time_series.csv");
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("frame,config,flip,rmse,gpu_ms,update_ms,rays"));
    let mut rays: Vec<(String, Option<f64>)> = Vec::new();
    let rows: Vec<(i64, String, f64, f64)> = lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            assert_eq!(f.len(), 7, "{line}");
            rays.push((f[1].to_string(), f[6].parse().ok()));
            (f[0].parse().expect("frame"), f[1].to_string(), f[2].parse().expect("flip"), f[3].parse().expect("rmse"))
        })
        .collect();
    let series = |config: &str| -> Vec<(i64, f64, f64)> { rows.iter().filter(|r| r.1 == config).map(|r| (r.0, r.2, r.3)).collect() };
    let configs = ["direct", "pathtrace_4spp", "ddgi_8x8x8", "ddgi_8x8x8_adaptive"];
    for config in configs {
        let frames_seen: Vec<i64> = series(config).iter().map(|r| r.0).collect();
        assert_eq!(frames_seen, (-1..frames).collect::<Vec<_>>(), "{config}: one row per frame, from the last before the change");
    }
    assert_eq!(rows.len(), configs.len() * (frames as usize + 1), "no rows of other configurations");
    // DDGI's probes follow the moved lamp over the frames after the change (its hysteresis).
    let ddgi = series("ddgi_8x8x8");
    assert!(ddgi.last().expect("rows").2 < ddgi[1].2, "DDGI's error must fall as its probes follow the change: {ddgi:?}");
    // DDGI's rows carry the rays it traced (read back a few frames late: the last ones may lack them).
    for config in ["ddgi_8x8x8", "ddgi_8x8x8_adaptive"] {
        let counted = rays.iter().filter(|(c, r)| c == config && r.is_some_and(|r| r > 0.0)).count();
        assert!(counted >= frames as usize - 3, "{config}: rays on only {counted} rows");
    }
    assert!(rays.iter().filter(|(c, _)| c == "direct").all(|(_, r)| r.is_none()), "direct light traces no probe rays");

    // The path tracer starts over at the change and converges towards the changed scene.
    let pt = series("pathtrace_4spp");
    let (early, late) = ((pt[1].1 + pt[2].1) / 2.0, (pt[pt.len() - 2].1 + pt[pt.len() - 1].1) / 2.0);
    assert!(late < 0.8 * early, "path tracer FLIP after the change must fall: {pt:?}");
    // Direct light is closer to the changed scene than before it from the first frame after the
    // change on (linear RMSE: the lamp's light moved with it), and the temporal anti-aliasing's
    // history follows: the last frame closer than the first.
    let direct = series("direct");
    assert!(direct[1..].iter().all(|r| r.2 < direct[0].2), "the change must reach the renderer: {direct:?}");
    assert!(direct.last().expect("rows").2 < direct[1].2, "the history must follow the change: {direct:?}");

    assert_plot(&out.join("time_series.png"), TIME_SERIES_SIZE);
    let report = std::fs::read_to_string(out.join("report.md")).expect("report");
    assert!(report.contains("the lamp moves"), "{report}");
    assert!(report.contains("| pathtrace_4spp |") && report.contains("](time_series.png)"), "{report}");
    // The static phase's error against the scene before the change, and its passes' GPU times.
    for config in ["ddgi_8x8x8", "ddgi_8x8x8_adaptive"] {
        let row = report.lines().find(|l| l.starts_with(&format!("| {config} | "))).expect("a row per DDGI configuration");
        let static_flip: f64 = row.split('|').nth(2).and_then(|c| c.trim().parse().ok()).unwrap_or_else(|| panic!("static FLIP in {row}"));
        assert!(static_flip > 0.0 && static_flip < 1.0, "{row}");
    }
    assert!(report.contains("| ddgi_trace |"), "per-pass GPU times of the static phase: {report}");
    // ColorVideoVDP's JOD of each configuration's static phase and of its frames after the change:
    // on the scale (at most 10), and DDGI, which adds the indirect light direct light lacks, seen
    // as closer to the reference than direct light alone, before the change and after it.
    let video = std::fs::read_to_string(out.join("video_quality.csv")).expect("video_quality.csv");
    let mut lines = video.lines();
    assert_eq!(lines.next(), Some("config,static_flip,static_flicker,static_jod,static_temporal_jod,after_jod,cvvdp_seconds"));
    let jods: Vec<(String, [f64; 3])> = lines
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            // The path tracer accumulates until the change: it has no static phase.
            let no_static = f[0] == "pathtrace_4spp";
            let jod = |i: usize| -> f64 {
                if no_static && i < 5 {
                    assert_eq!(f[i], "", "{line}");
                    return 10.0;
                }
                f[i].parse().unwrap_or_else(|_| panic!("column {i} of {line}"))
            };
            (f[0].to_string(), [jod(3), jod(4), jod(5)])
        })
        .collect();
    assert_eq!(jods.iter().map(|(c, _)| c.as_str()).collect::<Vec<_>>(), configs);
    for (config, jod) in &jods {
        assert!(jod.iter().all(|j| j.is_finite() && *j <= 10.0 + 1e-4), "{config}: {jod:?}");
    }
    let jod = |config: &str| jods.iter().find(|(c, _)| c == config).expect(config).1;
    // Against its own mean, DDGI's static phase shows only its probes' noise: less than all its
    // error against the reference.
    assert!(jod("ddgi_8x8x8")[1] > jod("ddgi_8x8x8")[0], "{:?}", jod("ddgi_8x8x8"));
    for (phase, i) in [("static", 0), ("after the change", 2)] {
        assert!(jod("ddgi_8x8x8")[i] > jod("direct")[i], "{phase}: DDGI {:?} vs direct {:?}", jod("ddgi_8x8x8"), jod("direct"));
    }
    assert!(report.contains("](video_quality.png)"), "{report}");
    assert_plot(&out.join("video_quality.png"), lab::plot::BARS_SIZE);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_walk_measures_every_frame_against_its_own_view_with_the_scrolls_marked() {
    let Some(gpu) = GpuContext::for_tests("a_walk_measures_every_frame") else { return };
    let dir = std::env::temp_dir().join(format!("lab_walk_series_test_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (out, cache) = (dir.join("report"), dir.join("cache"));
    let frames = 6;
    let scene = cornell();
    let extent = scene.bounds().map(|(lo, hi)| (hi - lo).max_element()).expect("bounds");
    // Two cascades of 8×6×8, half and all of the box wide (cascades are kept over the scene, so a
    // box wider than the scene would stay put); carried sideways a tenth of the box a frame, the
    // camera crosses cells of both.
    let cascades = ddgi::DdgiCascades {
        count: Some(2),
        probe_counts: glam::UVec3::new(8, 6, 8),
        spacing: extent / 16.0,
        blend_cells: 1.0,
        ..Default::default()
    };
    let options = EvalOptions { settle_frames: 30, cascades: Some(cascades), ..options(32, 64, out.clone(), cache.clone()) };
    let series = lab::eval::walk_series::WalkSeries { start: 0.0, speed: 6.0 * extent, sky: glam::Vec3::ZERO };
    let runs = lab::eval::walk_series::run(&gpu, &SceneFacts::named("cornell"), scene, &options, frames, series).expect("walk");

    let names: Vec<&str> = runs.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["direct", "ddgi_8x8x8", "ddgi_8x8x8_adaptive", "ddgi_cascades_2x8x6x8"]);
    // Every view's reference is path traced once and shared by the methods.
    assert_eq!(cached(&cache).len(), frames as usize, "one reference per view of the walk");
    let mean_flip = |r: &lab::walk::WalkReport| r.frames.iter().filter_map(|f| f.flip).map(f64::from).sum::<f64>() / r.frames.len() as f64;
    for (name, report) in &runs {
        assert_eq!(report.frames.iter().map(|f| f.frame).collect::<Vec<_>>(), (0..frames).collect::<Vec<_>>(), "{name}");
        for f in &report.frames {
            let flip = f.flip.unwrap_or_else(|| panic!("{name}: frame {} unmeasured", f.frame));
            assert!(flip.is_finite() && flip > 0.0 && flip < 1.0, "{name}: FLIP {flip}");
            // Flicker from the second frame on (it needs the frame before).
            assert_eq!(f.flicker.is_some(), f.frame > 0, "{name}: frame {}", f.frame);
            assert!(f.flicker.is_none_or(|v| v.is_finite() && v >= 0.0), "{name}: {:?}", f.flicker);
        }
    }
    // The views move: each frame's reference is its own, so DDGI's light stays better than direct
    // light's along the whole walk.
    let direct = mean_flip(&runs[0].1);
    for (name, report) in &runs[1..] {
        assert!(mean_flip(report) < direct, "{name}: {} against direct light's {direct}", mean_flip(report));
    }
    let scrolled = runs[3].1.frames.iter().filter(|f| f.scrolled > 0).count();
    assert!(scrolled > 0, "the cascades must scroll as the camera walks");

    let csv = std::fs::read_to_string(out.join("time_series.csv")).expect("time_series.csv");
    assert_eq!(csv.lines().next(), Some("config,frame,distance,flip,flicker,scrolled_volumes,rebased,ddgi_ms"));
    assert_eq!(csv.lines().count(), 1 + 4 * frames as usize);
    assert_plot(&out.join("time_series.png"), lab::plot::WALK_SERIES_SIZE);
    let report = std::fs::read_to_string(out.join("report.md")).expect("report");
    assert!(report.contains("| ddgi_cascades_2x8x6x8 |") && report.contains("](time_series.png)"), "{report}");
    let _ = std::fs::remove_dir_all(&dir);
}

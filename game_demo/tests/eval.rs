//! `game_demo eval` end to end: the report, the strips, the plot, the cached reference, errors that
//! fall as the path tracer gets more paths per pixel.

use std::path::Path;
use std::process::{Command, Output};

/// The size of the plot (`eval::plot::ERROR_VS_TIME_SIZE`).
const ERROR_VS_TIME_SIZE: (u32, u32) = (1200, 520);

fn game_demo(args: &[&str], out: &Path, cache: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_game_demo"))
        .args(args)
        .arg("--out")
        .arg(out)
        .arg("--cache")
        .arg(cache)
        .output()
        .expect("run game_demo")
}

fn succeeded(output: Output) -> String {
    assert!(output.status.success(), "eval failed: {}", String::from_utf8_lossy(&output.stderr));
    String::from_utf8_lossy(&output.stdout).into_owned()
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
    // The binary needs a GPU: same rule as every GPU test (CI=true makes a missing adapter a failure).
    if engine::gpu::GpuContext::for_tests("eval_writes_a_report").is_none() {
        return;
    }
    let dir = std::env::temp_dir().join(format!("game_demo_eval_test_{}", std::process::id()));
    let (out, cache) = (dir.join("report"), dir.join("cache"));
    let run =
        || succeeded(game_demo(&["eval", "--scene", "cornell", "--width", "48", "--height", "48", "--reference-spp", "256"], &out, &cache));
    let first = run();
    assert!(first.contains("path tracing 256 paths per pixel"), "{first}");
    let results: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).expect("results.json")).expect("json");
    let rows = results.as_array().expect("rows");
    let flip = |name: &str| rows.iter().find(|r| r["config"] == name).and_then(|r| r["error"]["mean_flip"].as_f64()).expect(name);
    let ladder = ["pathtrace_1spp", "pathtrace_4spp", "pathtrace_16spp", "pathtrace_64spp"].map(flip);
    assert!(ladder.windows(2).all(|w| w[1] < w[0]), "FLIP must fall as paths per pixel grow: {ladder:?}");
    // Direct light alone misses all indirect light: worse than 64 paths per pixel of the reference.
    assert!(flip("direct") > ladder[3], "direct {} vs 64 spp {}", flip("direct"), ladder[3]);
    for name in ["direct", "pathtrace_1spp", "pathtrace_64spp"] {
        let strip = image::open(out.join(format!("{name}.png"))).expect("strip");
        assert_eq!((strip.width(), strip.height()), (4 * 48, 48));
    }
    assert_plot(&out.join("error_vs_time.png"), ERROR_VS_TIME_SIZE);
    let report = std::fs::read_to_string(out.join("report.md")).expect("report");
    assert!(report.contains("| pathtrace_16spp |"), "{report}");
    assert!(report.contains("](error_vs_time.png)"), "the report links the plot: {report}");
    // The second run reads the reference from the cache.
    assert!(run().contains("reference: cached"));
    let _ = std::fs::remove_dir_all(&dir);
}

//! The examples run for a few frames at a small size, as CI runs them: each writes `DIR/image.png`,
//! and the image is not black. The examples' own code is compiled into this test (their `run`
//! functions are called with the arguments a user would type); their `main`s go unused here.

use std::path::{Path, PathBuf};

use clap::Parser;

#[allow(dead_code)]
#[path = "../examples/headless.rs"]
mod headless;

#[allow(dead_code)]
#[path = "../examples/game.rs"]
mod game;

#[allow(dead_code)]
#[path = "../examples/custom_pass.rs"]
mod custom_pass;

/// Small and quick on lavapipe.
const SMALL: [&str; 4] = ["--frames", "8", "--size", "64"];

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `dir/image.png` exists, has the size asked for and some light in it.
fn assert_lit_image(dir: &Path) {
    let path = dir.join("image.png");
    let image = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8();
    assert_eq!(image.dimensions(), (64, 64));
    let mean = image.pixels().map(|p| p.0.iter().map(|&c| f64::from(c)).sum::<f64>() / 3.0).sum::<f64>() / (64.0 * 64.0);
    assert!(mean > 5.0, "{}: the image is black (mean {mean:.2} of 255)", path.display());
}

#[test]
fn headless_example_writes_a_lit_image() {
    if testkit::gpu("headless_example_writes_a_lit_image").is_none() {
        return;
    }
    let out = out_dir("example_headless");
    let args = ["headless", "--scene", "cornell", "--out", out.to_str().expect("a UTF-8 path")];
    headless::run(headless::Args::parse_from(args.into_iter().chain(SMALL))).expect("the headless example");
    assert_lit_image(&out);
}

#[test]
fn game_example_runs_headless_with_scripted_input_and_writes_a_lit_image() {
    if testkit::gpu("game_example_runs_headless").is_none() {
        return;
    }
    let out = out_dir("example_game");
    let args = ["game", "--headless", "--out", out.to_str().expect("a UTF-8 path")];
    game::run(game::Args::parse_from(args.into_iter().chain(SMALL))).expect("the game example");
    assert_lit_image(&out);
}

#[test]
fn custom_pass_example_adds_probe_lit_fog_to_the_ddgi_passes_and_writes_a_lit_image() {
    if testkit::gpu("custom_pass_example").is_none() {
        return;
    }
    let out = out_dir("example_custom_pass");
    let args = ["custom_pass", "--scene", "cornell", "--out", out.to_str().expect("a UTF-8 path")];
    custom_pass::run(custom_pass::Args::parse_from(args.into_iter().chain(SMALL))).expect("the custom_pass example");
    assert_lit_image(&out);
    // The app's own pass ran after DDGI's, in the same graph: the last frame's `gpu_ms` map
    // (pass label → milliseconds, in pass order) has the three, in that order.
    let text = std::fs::read_to_string(out.join("timings.json")).expect("timings.json");
    let timings: serde_json::Value = serde_json::from_str(&text).expect("timings.json is JSON");
    let last = timings["frames"].as_array().and_then(|f| f.last()).expect("timings.json has frames");
    let ran = last["gpu_ms"].as_object().expect("a frame's gpu_ms is a map");
    let position =
        |label: &str| text[text.rfind("\"gpu_ms\"").expect("gpu_ms")..].find(&format!("\"{label}\"")).filter(|_| ran.contains_key(label));
    let order: Vec<Option<usize>> = ["ddgi_trace", "ddgi_composite", "probe_fog"].into_iter().map(position).collect();
    assert!(order.iter().all(Option::is_some) && order.is_sorted(), "ddgi_trace, ddgi_composite, probe_fog in {ran:?}");
    for (label, ms) in ran {
        assert!(ms.is_null() || ms.as_f64().is_some_and(|ms| ms >= 0.0), "{label}: {ms}");
    }
}

#[test]
fn custom_pass_fog_params_match_naga_layout() {
    ddgi::register_shaders().and_then(|()| engine::shader::register(custom_pass::SHADERS)).expect("register");
    engine::shader::check_struct_layout(&custom_pass::fog_params_layout()).unwrap_or_else(|e| panic!("{e}"));
}

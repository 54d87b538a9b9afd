//! `game_demo`'s command line: bad options are rejected, naming the option.

use std::process::Command;

#[test]
fn eval_rejects_bad_time_series_options_by_name() {
    let dir = std::env::temp_dir();
    for (args, expected) in [
        (&["eval", "--time-series", "--frames", "0"][..], "--frames"),
        (&["eval", "--frames", "5"][..], "--time-series"),
        (&["eval", "--reference-spp", "0"][..], "--reference-spp"),
        (&["eval", "--rest-smoothing", "often"][..], "--rest-smoothing"),
        (&["eval", "--rest-smoothing", "1.5"][..], "adaptive.rest_smoothing"),
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_game_demo"))
            .args(args)
            .arg("--out")
            .arg(&dir)
            .arg("--cache")
            .arg(&dir)
            .output()
            .expect("run game_demo");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success() && stderr.contains(expected), "{args:?}: {stderr}");
    }
}

/// The demo level's day–night cycle owns its sun and sky, and its materials are its own: the
/// global scene overrides are refused there, by name, rather than ignored.
#[test]
fn play_refuses_the_scene_overrides_the_demo_level_would_ignore() {
    for (flag, expected) in [("--sun=0,-1,0,3", "--sun"), ("--sky=0.1,0.1,0.1", "--sky"), ("--opaque", "--opaque")] {
        let output = Command::new(env!("CARGO_BIN_EXE_game_demo"))
            .args(["play", "--headless", "--frames", "1", flag])
            .output()
            .expect("run game_demo");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success() && stderr.contains(expected), "{flag}: {stderr}");
    }
}

/// A floor slab and a box as OBJ, with no lights and no materials.
fn write_lightless_obj(dir: &std::path::Path) -> std::path::PathBuf {
    let cube = |min: [f32; 3], max: [f32; 3], first: usize| {
        let mut text = String::new();
        for i in 0..8 {
            let c = |axis: usize| if i >> axis & 1 == 1 { max[axis] } else { min[axis] };
            text += &format!("v {} {} {}\n", c(0), c(1), c(2));
        }
        // Corners numbered by bits (x, y, z); each face counter-clockwise from outside.
        for face in [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]] {
            text += &format!("f {}\n", face.map(|v| (first + v).to_string()).join(" "));
        }
        text
    };
    let path = dir.join("lightless.obj");
    let text = cube([-4.0, -0.2, -4.0], [4.0, 0.0, 4.0], 1) + &cube([-0.5, 0.0, -0.5], [0.5, 1.0, 0.5], 9);
    std::fs::write(&path, text).expect("write the OBJ");
    path
}

fn test_dir(name: &str) -> std::path::PathBuf {
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the test's folder");
    dir
}

/// A file without lights renders lit by the default sun and sky, and says so, with the same sky in
/// every mode; `--sky` replaces the sky; a file with a light (here `--sun` of irradiance 0) keeps a
/// black sky.
#[test]
fn a_scene_without_lights_is_lit_by_the_default_daylight_and_says_so() {
    if engine::gpu::GpuContext::for_tests("a_scene_without_lights_is_lit").is_none() {
        return;
    }
    let dir = test_dir("lightless_render");
    let scene = write_lightless_obj(&dir);
    let render = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let output = Command::new(env!("CARGO_BIN_EXE_game_demo"))
            .args(["render", "--width", "48", "--height", "32", "--no-taa", "--scene"])
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .args(extra)
            .output()
            .expect("run game_demo render");
        let stderr = String::from_utf8_lossy(&output.stderr).to_string();
        assert!(output.status.success(), "{name}: {stderr}");
        let image = image::open(out.join("image.png")).expect("image.png").to_rgb8();
        let mean = image.pixels().map(|p| p.0.iter().map(|&c| f64::from(c)).sum::<f64>() / 3.0).sum::<f64>() / f64::from(48 * 32);
        (stderr, mean, image.get_pixel(0, 0).0)
    };
    let (note, daylight, background) = render("default", &["--mode", "direct"]);
    assert!(note.contains("has no lights") && note.contains("default sun"), "{note}");
    // The corner sees no geometry: every mode shows the same sky there.
    for mode in [&["--mode", "ddgi", "--frames", "4"][..], &["--mode", "pathtrace", "--spp", "4"]] {
        let (note, _, sky) = render(mode[1], mode);
        assert!(note.contains("has no lights"), "{mode:?}: {note}");
        assert!(
            sky.iter().zip(background).all(|(&a, b)| a.abs_diff(b) <= 2),
            "{mode:?} shows the sky as {sky:?}, direct as {background:?}"
        );
    }
    // The surfaces are lit by the sun alone under a black sky: not only the sky is bright.
    let (note, sun_only, _) = render("black_sky", &["--mode", "direct", "--sky", "0,0,0"]);
    assert!(note.contains("has no lights"), "{note}");
    assert!(sun_only > 20.0 && daylight > sun_only, "mean sRGB code: {sun_only} under a black sky, {daylight} under the default one");
    let (note, dark, _) = render("dark_sun", &["--mode", "direct", "--sun=0,-1,0,0"]);
    assert!(!note.contains("has no lights"), "--sun is a light: {note}");
    assert!(dark < 1.0, "a light of irradiance 0 and a black sky: mean code {dark}");
}

/// A bench over a scene whose probes are all switched off (a sun of irradiance 0 and a black
/// sky: every probe dark) reports the rays the GPU traced, not probes × rays, and says so.
#[test]
fn bench_ddgi_reports_the_rays_the_gpu_traced_when_probes_are_skipped() {
    if engine::gpu::GpuContext::for_tests("bench_ddgi_reports_the_rays_traced").is_none() {
        return;
    }
    let dir = test_dir("bench_skipped");
    let scene = write_lightless_obj(&dir);
    let json = dir.join("bench.json");
    let output = Command::new(env!("CARGO_BIN_EXE_game_demo"))
        .args([
            "bench",
            "ddgi",
            "--probes",
            "4,2,4",
            "--rays",
            "32",
            "--iterations",
            "12",
            "--width",
            "32",
            "--height",
            "32",
            "--sun=0,-1,0,0",
            "--scene",
        ])
        .arg(&scene)
        .arg("--json")
        .arg(&json)
        .output()
        .expect("run game_demo bench ddgi");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    let value: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).expect("bench.json")).expect("JSON");
    let cell = &value["cells"][0];
    let (rays, nominal) = (cell["rays"].as_u64().expect("rays"), cell["nominal_rays"].as_u64().expect("nominal_rays"));
    assert_eq!(nominal, 4 * 2 * 4 * 32);
    assert!(rays < nominal / 2, "dark probes are switched off: {rays} of {nominal} rays counted\n{stdout}");
    assert!(stdout.contains("Probes were skipped"), "{stdout}");
    let mrays = cell["mrays_per_second"].as_f64().expect("MRays/s");
    let update_ms = cell["update_ms"].as_f64().expect("update_ms");
    assert!((mrays - rays as f64 / (update_ms * 1e3)).abs() <= 1e-6 * mrays.max(1.0), "MRays/s of the counted rays: {mrays}");
}

//! `game_demo play` end to end: the headless scripted walk (frames, per-frame timings, the player
//! moving through the level), and the windowed demo under Xvfb, whose screenshot must match the
//! headless render of the same frame.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Small and quick on lavapipe: 160×96 pixels, sparse probes, few rays.
const SMALL: &[&str] = &["--width", "160", "--height", "96", "--probes", "13,3,13", "--rays", "32"];
const FRAMES: u32 = 48;

fn game_demo() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_game_demo"));
    c.env_remove("WAYLAND_DISPLAY");
    c
}

fn gpu_available(test: &str) -> bool {
    engine::gpu::GpuContext::for_tests(test).is_some()
}

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create the test's folder");
    dir
}

fn headless(out: &Path, frames: u32, extra: &[&str]) {
    let output = game_demo()
        .args(["play", "--headless", "--frames", &frames.to_string(), "--every", "16", "--out"])
        .arg(out)
        .args(SMALL)
        .args(extra)
        .output()
        .expect("run game_demo play --headless");
    assert!(output.status.success(), "play --headless failed: {}", String::from_utf8_lossy(&output.stderr));
}

fn rgba(path: &Path) -> (Vec<u8>, u32, u32) {
    let image = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8();
    let (w, h) = image.dimensions();
    (image.into_raw(), w, h)
}

#[test]
fn headless_walk_writes_frames_and_a_timing_row_per_frame_while_the_player_moves() {
    if !gpu_available("headless_walk") {
        return;
    }
    let out = out_dir("play_headless");
    headless(&out, FRAMES, &[]);
    let csv = std::fs::read_to_string(out.join("frames.csv")).expect("frames.csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    for column in ["frame", "player_x", "player_z", "door_open", "ddgi_rays", "gpu_total_ms", "gbuffer_ms", "ddgi_trace_ms"] {
        assert!(header.contains(&column), "frames.csv has no column {column}: {header:?}");
    }
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), FRAMES as usize, "one row per frame");
    let col = |name: &str| header.iter().position(|h| *h == name).expect("column");
    let position = |row: &Vec<&str>| {
        let v = |name: &str| row[col(name)].parse::<f32>().expect("a number");
        glam::Vec3::new(v("player_x"), v("player_y"), v("player_z"))
    };
    let walked = position(&rows[0]).distance(position(rows.last().expect("rows")));
    // The tour walks at 3 m/s: 48 frames at 1/60 s cover up to 2.4 m.
    assert!(walked > 0.5, "the scripted player moved only {walked} m in {FRAMES} frames");
    for row in &rows {
        assert!(position(row).is_finite(), "non-finite player position in {row:?}");
    }
    // Frames 0, 16, 32 and the last one.
    for frame in [0, 16, 32, FRAMES - 1] {
        let (pixels, w, h) = rgba(&out.join(format!("frame_{frame:05}.png")));
        assert_eq!((w, h), (160, 96));
        let first = &pixels[..4];
        assert!(pixels.chunks_exact(4).any(|p| p != first), "frame {frame} is one flat colour");
    }
}

/// An X server on a free display, killed on drop.
struct Xvfb {
    child: Child,
    display: String,
}

impl Xvfb {
    fn start() -> Option<Self> {
        let Ok(path) = which("Xvfb") else {
            let message = "Xvfb is not installed (make test installs the xvfb package)";
            // In CI a missing Xvfb is a failure, never a silent skip.
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("{message}");
            }
            eprintln!("SKIPPED the windowed test: {message}");
            return None;
        };
        // A display of our own: the windowed tests run in parallel in one process, and other test
        // processes may run their own servers. Skip numbers whose lock file exists.
        static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let number = loop {
            let n = 90 + (std::process::id() % 200) * 8 + NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed) % 1000;
            if !Path::new(&format!("/tmp/.X{n}-lock")).exists() && !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() {
                break n;
            }
        };
        let display = format!(":{number}");
        let child = Command::new(path)
            .args([display.as_str(), "-screen", "0", "640x480x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("start Xvfb");
        let socket = PathBuf::from(format!("/tmp/.X11-unix/X{number}"));
        let start = Instant::now();
        while !socket.exists() {
            assert!(start.elapsed() < Duration::from_secs(20), "Xvfb did not start on {display}");
            std::thread::sleep(Duration::from_millis(50));
        }
        Some(Self { child, display })
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs the scripted walk in a window on `x` for FRAMES frames (with `extra` options), its last
/// frame saved to `screenshot`; warnings logged to standard error.
fn scripted_window(x: &Xvfb, screenshot: &Path, extra: &[&str]) -> std::process::Output {
    game_demo()
        .env("DISPLAY", &x.display)
        .env("RUST_LOG", "warn")
        .args(["play", "--frames", &FRAMES.to_string()])
        .args(extra)
        .arg("--script")
        .arg(screenshot)
        .args(SMALL)
        .output()
        .expect("run game_demo play --script")
}

/// Runs the headless walk into `out/headless` and compares its last frame with the window's
/// screenshot (which must have the size asked for): mean FLIP.
fn flip_against_headless(out: &Path, screenshot: &Path, extra: &[&str]) -> f32 {
    headless(&out.join("headless"), FRAMES, extra);
    let (window, w, h) = rgba(screenshot);
    let (reference, rw, rh) = rgba(&out.join("headless").join(format!("frame_{:05}.png", FRAMES - 1)));
    assert_eq!((w, h), (rw, rh), "the window's last frame is not at the size asked for");
    let rgb = |rgba: &[u8]| -> Vec<u8> { rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
    lab::metrics::flip_rgb8(&rgb(&reference), &rgb(&window), w, h).0
}

fn which(program: &str) -> Result<PathBuf, ()> {
    std::env::var_os("PATH").and_then(|paths| std::env::split_paths(&paths).map(|p| p.join(program)).find(|p| p.is_file())).ok_or(())
}

#[test]
fn windowed_demo_under_xvfb_matches_the_headless_frame() {
    if !gpu_available("windowed_demo_under_xvfb") {
        return;
    }
    let Some(x) = Xvfb::start() else { return };
    let out = out_dir("play_window");
    let screenshot = out.join("window.png");
    let output = scripted_window(&x, &screenshot, &[]);
    assert!(output.status.success(), "windowed play failed: {}", String::from_utf8_lossy(&output.stderr));
    let mean = flip_against_headless(&out, &screenshot, &[]);
    eprintln!("windowed vs headless frame {}: mean FLIP {mean:.5}", FRAMES - 1);
    assert!(mean < 0.01, "the windowed frame differs from the headless one: mean FLIP {mean}");
}

/// The soak in CI: 300 frames of the level with everything moving. `make soak` runs 10,000.
#[test]
fn short_soak_keeps_images_and_atlases_finite_and_memory_and_timings_bounded() {
    if !gpu_available("short_soak") {
        return;
    }
    let out = out_dir("play_soak");
    let output = game_demo()
        .args(["play", "--headless", "--soak", "--frames", "300", "--check-every", "50", "--warmup", "100", "--out"])
        .arg(&out)
        .args(["--width", "64", "--height", "48", "--probes", "10,2,10", "--rays", "16"])
        .output()
        .expect("run game_demo play --headless --soak");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "the soak failed:\n{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("soak passed"), "{stdout}");
    let csv = std::fs::read_to_string(out.join("soak.csv")).expect("soak.csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 6, "one sample every 50 frames: {csv}");
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("soak.csv has no column {name}"));
    for row in &rows {
        assert_eq!(row[col("non_finite")], "0", "{row:?}");
        // The binary counts its heap, and the GPU memory report exists on Vulkan.
        let heap: f64 = row[col("heap_mib")].parse().expect("the heap is measured");
        assert!(heap > 1.0, "{row:?}");
        assert!(row[col("gpu_mib")].parse::<f64>().is_ok_and(|m| m > 0.0), "no GPU memory report: {row:?}");
    }
}

/// The window minimized (zero size, frames skipped), shrunk to two pixels by the window system and
/// restored, its surface lost and replaced, and the GPU device lost and reopened with the level
/// rebuilt where the player stood: the run survives all of it and the last frame shows the same
/// place as the headless walk.
#[test]
fn windowed_demo_survives_minimizing_resizing_and_losing_its_surface_and_device() {
    if !gpu_available("windowed_demo_faults") {
        return;
    }
    let Some(x) = Xvfb::start() else { return };
    let out = out_dir("play_window_faults");
    let screenshot = out.join("window.png");
    // Without temporal anti-aliasing: its history restarts with the device, and its lag on the
    // reconverging probes is not what this compares.
    let output = scripted_window(&x, &screenshot, &["--inject-faults", "--no-taa"]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "windowed play with faults failed: {stderr}");
    for expected in ["5 redraws skipped while minimized", "Shrink", "the lost surface was replaced", "the level runs on a new GPU device"] {
        assert!(stderr.contains(expected), "no '{expected}' in the log:\n{stderr}");
    }
    let mean = flip_against_headless(&out, &screenshot, &["--no-taa"]);
    eprintln!("windowed with faults vs headless frame {}: mean FLIP {mean:.5}", FRAMES - 1);
    // The player and the clock carry over; the probes restart on the new device and have 26 frames to
    // converge again instead of 48: measured 0.024 on lavapipe (a player left behind by one step of
    // the fixed clock measured 0.055).
    assert!(mean < 0.04, "the windowed frame after the faults shows another place than the headless one: mean FLIP {mean}");
}

//! `--trace FILE`: a Chrome trace with the CPU's spans and the GPU's passes on one timeline, and
//! nothing at all without it.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

fn out_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// `game_demo render` of a small DDGI frame into `out`, with `extra` arguments.
fn render(out: &Path, extra: &[&str]) {
    let output = Command::new(env!("CARGO_BIN_EXE_game_demo"))
        .args(["render", "--scene", "cornell", "--mode", "ddgi", "--frames", "3", "--width", "64", "--height", "48", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .expect("run game_demo");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "game_demo render {extra:?} failed:\n{stderr}");
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{} is not JSON: {e}", path.display()))
}

/// A span of the trace: a CPU span (a begin and its end event) or a GPU one (a complete event).
#[derive(Debug)]
struct Span {
    name: String,
    tid: u64,
    start: f64,
    end: f64,
    args: Value,
}

/// Argument `key` of a span as a whole number (tracing-chrome writes the CPU spans' arguments as
/// strings, the GPU spans' frame is a number).
fn arg_u64(span: &Span, key: &str) -> Option<u64> {
    let arg = &span.args[key];
    arg.as_u64().or_else(|| arg.as_str().and_then(|s| s.parse().ok()))
}

/// The spans of a Chrome trace, pairing each thread's begin and end events as a stack (what the
/// viewers do); fails on an end without a begin or a begin left open.
fn spans(events: &[Value]) -> Vec<Span> {
    let mut open: HashMap<u64, Vec<&Value>> = HashMap::new();
    let mut out = Vec::new();
    for e in events {
        let (tid, ts) = (e["tid"].as_u64().unwrap_or(0), e["ts"].as_f64());
        match e["ph"].as_str() {
            Some("B") => open.entry(tid).or_default().push(e),
            Some("E") => {
                let begin = open.get_mut(&tid).and_then(Vec::pop).unwrap_or_else(|| panic!("an end without a begin: {e}"));
                assert_eq!(begin["name"], e["name"], "begin and end of a span on thread {tid}");
                let name = begin["name"].as_str().expect("a name").to_string();
                let start = begin["ts"].as_f64().expect("ts");
                out.push(Span { name, tid, start, end: ts.expect("ts"), args: begin["args"].clone() });
            }
            Some("X") => {
                let (start, dur) = (ts.expect("ts"), e["dur"].as_f64().expect("dur"));
                out.push(Span { name: e["name"].as_str().expect("a name").into(), tid, start, end: start + dur, args: e["args"].clone() });
            }
            _ => {}
        }
    }
    let left: Vec<_> = open.values().flatten().map(|e| e["name"].to_string()).collect();
    assert!(left.is_empty(), "spans begun and never ended: {left:?}");
    out
}

#[test]
fn a_traced_render_puts_every_timed_pass_on_the_gpu_track_inside_its_frame_beside_the_cpu_stages() {
    let out = out_dir("trace_render");
    let trace_path = out.join("trace.json");
    render(&out, &["--trace", trace_path.to_str().expect("a UTF-8 path")]);
    let trace = read_json(&trace_path);
    let events = trace["traceEvents"].as_array().expect("traceEvents");
    let gpu_track = events
        .iter()
        .find(|e| e["ph"] == "M" && e["name"] == "thread_name" && e["args"]["name"] == "GPU")
        .and_then(|e| e["tid"].as_u64())
        .expect("a thread named GPU");
    let spans = spans(events);
    for s in &spans {
        assert!(s.end >= s.start && s.start.is_finite(), "a span of negative or no duration: {s:?}");
    }
    let (gpu, cpu): (Vec<&Span>, Vec<&Span>) = spans.iter().partition(|s| s.tid == gpu_track);

    // CPU: the stages, the schedules and systems that run them, the BVH's preparation, the
    // render graph and the waits for the GPU.
    let names: Vec<&str> = cpu.iter().map(|s| s.name.as_str()).collect();
    for wanted in ["main app", "Update", "render_stages", "Extract", "Prepare", "Render", "graph_execute", "record gbuffer", "wait_idle"] {
        assert!(names.contains(&wanted), "no CPU span '{wanted}' in {names:?}");
    }
    for system in ["prepare_gpu_scene", "prepare_ray_tracing_scene", "advance_time", "render_ddgi_frame"] {
        assert!(names.iter().any(|n| n.ends_with(system)), "no span of the system {system}");
    }

    // GPU: every pass timings.json timed, in every frame, inside that frame's render stages.
    let timings = read_json(&out.join("timings.json"));
    let frames = timings["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 3);
    let mut timed = 0;
    for frame in frames {
        let index = frame["frame"].as_u64().expect("frame");
        let stages: Vec<&&Span> = cpu.iter().filter(|s| s.name == "render_stages" && arg_u64(s, "frame") == Some(index)).collect();
        assert_eq!(stages.len(), 1, "frame {index}: one render_stages span");
        for (label, ms) in frame["gpu_ms"].as_object().expect("a frame's gpu_ms is a map") {
            let Some(ms) = ms.as_f64() else { continue };
            timed += 1;
            let found: Vec<&&Span> = gpu.iter().filter(|s| s.name == *label && arg_u64(s, "frame") == Some(index)).collect();
            assert_eq!(found.len(), 1, "frame {index}: one GPU span '{label}'");
            let s = found[0];
            assert!((s.end - s.start - ms * 1e3).abs() < 1.0, "frame {index} {label}: {s:?} against {ms} ms");
            // One microsecond of slack: the file's times are floats in microseconds.
            assert!(
                s.start >= stages[0].start - 1.0 && s.end <= stages[0].end + 1.0,
                "frame {index}: GPU span {s:?} outside the frame's render stages {:?}",
                stages[0]
            );
        }
    }
    assert!(timed > 0, "the adapter timed no pass (timestamp queries missing?)");
    assert_eq!(gpu.len(), timed, "GPU spans without a pass in timings.json");
}

#[test]
fn a_render_without_trace_writes_no_trace() {
    let out = out_dir("trace_none");
    render(&out, &[]);
    let mut written: Vec<String> = std::fs::read_dir(&out)
        .expect("the output folder")
        .map(|e| e.expect("an entry").file_name().to_string_lossy().into_owned())
        .collect();
    written.sort();
    assert_eq!(written, ["image.exr", "image.png", "timings.json"]);
}

/// In this process nothing installed a subscriber: a headless render records no GPU span and
/// leaves every span disabled (each costs one atomic load).
#[test]
fn a_headless_render_installs_no_subscriber_and_keeps_no_gpu_spans() {
    let Some(gpu) = engine::gpu::GpuContext::for_tests("a_headless_render_installs_no_subscriber") else { return };
    let settings = engine::headless::HeadlessSettings { width: 32, height: 32, frames: 2, ..Default::default() };
    let frame = engine::headless::render_scene(&gpu, (scenes::find("cornell").expect("cornell").build)(), &settings).expect("render");
    assert_eq!(frame.timings.len(), 2);
    assert!(!engine::trace::subscriber_installed());
    assert!(!engine::trace::recording_gpu_spans());
}

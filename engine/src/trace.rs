//! Chrome traces: the CPU's spans and the GPU's passes of a run on one timeline.
//!
//! CPU spans are [`tracing`] spans: bevy_ecs and bevy_app put one around every schedule (`First`
//! … `Last`, `Extract`, `Prepare`, `Render`) and every system (with their `trace` feature, which
//! this crate's `trace` feature turns on); the engine adds `render_stages` (with the frame's
//! index), `graph_execute`, one `record_pass` per pass recorded, and the waits for the GPU
//! (`wait_idle`, `wait_for_gpu_timings`). Without a subscriber every span costs one relaxed atomic
//! load, and nothing in the engine installs one: only [`ChromeTrace::start`] does.
//!
//! GPU spans are the render graph's own per-pass timestamps (the ones `timings.json` reports),
//! kept as begin and end ticks while a trace records them ([`recording_gpu_spans`]). GPU ticks
//! count from an epoch of their own, so each frame is placed on the CPU's clock by what is known
//! of it: its passes began after the instant just before its submission (`submitted`) and had
//! ended when their timestamps came back to the CPU (`observed`). For frame *i*, with `g0` its
//! first begin and `g1` its last end (ticks × [`wgpu::Queue::get_timestamp_period`], in ns), the
//! offset from GPU to CPU time lies in `[submitted − g0, observed − g1]`. The trace takes the
//! largest lower bound over all frames (the frame that started soonest after its submission, as a
//! GPU idle at submission does; this sets the whole GPU track early by that frame's submission
//! latency at most) and clamps it into each frame's own interval, so a frame's passes never leave
//! the window in which they ran, even if the two clocks drift or a new device brings a new epoch.
//! Headless runs wait for every frame's timings inside its `Render` stage, so there each frame's
//! GPU spans lie within its `render_stages` span.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::graph::GpuFrameSpans;

static RECORDING: AtomicBool = AtomicBool::new(false);
static GPU_FRAMES: Mutex<Vec<(u64, GpuFrameSpans)>> = Mutex::new(Vec::new());

/// Whether a trace is recording GPU spans ([`ChromeTrace::start`] until
/// [`ChromeTrace::finish`]): the render graph keeps its frames' timestamps only then.
pub fn recording_gpu_spans() -> bool {
    RECORDING.load(Ordering::Relaxed)
}

/// Whether a `tracing` subscriber is installed in this process (by [`ChromeTrace::start`], or
/// by the app itself): without one every span costs one atomic load.
pub fn subscriber_installed() -> bool {
    tracing::dispatcher::has_been_set()
}

fn gpu_frames() -> std::sync::MutexGuard<'static, Vec<(u64, GpuFrameSpans)>> {
    GPU_FRAMES.lock().unwrap_or_else(|e| e.into_inner())
}

/// Keeps frame `frame`'s GPU spans for the trace being recorded (none: they are dropped).
pub(crate) fn record_gpu_frame(frame: u64, spans: GpuFrameSpans) {
    if recording_gpu_spans() && !spans.passes.is_empty() {
        gpu_frames().push((frame, spans));
    }
}

/// A GPU pass placed on the CPU's timeline.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PlacedSpan {
    /// The frame's index.
    pub frame: u64,
    /// The pass label.
    pub label: String,
    /// Nanoseconds after the anchor instant at which the pass began.
    pub start_ns: f64,
    /// Nanoseconds after the anchor instant at which it ended.
    pub end_ns: f64,
}

/// Signed nanoseconds from `anchor` to `t`.
fn ns_since(anchor: Instant, t: Instant) -> f64 {
    match t.checked_duration_since(anchor) {
        Some(d) => d.as_nanos() as f64,
        None => -(anchor.duration_since(t).as_nanos() as f64),
    }
}

/// Places every frame's passes on the CPU's clock (nanoseconds after `anchor`), as the module
/// documentation explains.
pub(crate) fn place_gpu_spans(frames: &[(u64, GpuFrameSpans)], anchor: Instant) -> Vec<PlacedSpan> {
    let Some(base) = frames.iter().flat_map(|(_, f)| f.passes.first()).map(|p| p.1).next() else { return Vec::new() };
    let gpu_ns = |tick: u64, period: f64| (i128::from(tick) - i128::from(base)) as f64 * period;
    // Per frame: its passes in GPU nanoseconds, and the interval the GPU→CPU offset lies in.
    type Bounded<'a> = (u64, Vec<(&'a str, f64, f64)>, f64, f64);
    let bounded: Vec<Bounded> = frames
        .iter()
        .filter(|(_, f)| !f.passes.is_empty())
        .map(|(frame, f)| {
            let passes: Vec<(&str, f64, f64)> =
                f.passes.iter().map(|(l, b, e)| (l.as_str(), gpu_ns(*b, f.period_ns), gpu_ns(*e, f.period_ns))).collect();
            let first = passes.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            let last = passes.iter().map(|p| p.2).fold(f64::NEG_INFINITY, f64::max);
            let lo = ns_since(anchor, f.submitted) - first;
            let hi = ns_since(anchor, f.observed) - last;
            (*frame, passes, lo, hi)
        })
        .collect();
    let offset = bounded.iter().map(|b| b.2).fold(f64::NEG_INFINITY, f64::max);
    let mut out = Vec::new();
    for (frame, passes, lo, hi) in bounded {
        let o = if lo <= hi { offset.clamp(lo, hi) } else { lo };
        out.extend(passes.into_iter().map(|(label, b, e)| PlacedSpan { frame, label: label.into(), start_ns: b + o, end_ns: e + o }));
    }
    out
}

#[cfg(feature = "trace")]
pub use chrome::{ChromeTrace, TraceError, TraceSummary};

#[cfg(feature = "trace")]
mod chrome {
    use std::io::{BufRead, BufWriter, Write};
    use std::path::{Path, PathBuf};
    use std::sync::atomic::Ordering;
    use std::time::Instant;

    use serde_json::{Value, json};
    use tracing_subscriber::layer::SubscriberExt;

    use super::{RECORDING, gpu_frames, place_gpu_spans};

    /// The name of the event that ties the trace's clock to [`Instant`].
    const ANCHOR: &str = "trace_clock_anchor";
    /// The thread id of the GPU's track (the CPU's threads count from 0).
    pub const GPU_TRACK: u64 = 1 << 20;
    /// Spans left out of the trace: bevy_ecs's evaluation of run conditions, one per system and
    /// frame, which would double the file for little.
    const LEFT_OUT: &[&str] = &["check_conditions"];

    /// Why a trace could not be started or written.
    #[derive(Debug, thiserror::Error)]
    pub enum TraceError {
        /// A `tracing` subscriber was installed before (there can be one per process).
        #[error("cannot trace to {path}: a tracing subscriber is already installed in this process")]
        AlreadyInstalled {
            /// The trace file asked for.
            path: String,
        },
        /// The file (or its folder) could not be written, or the CPU spans read back.
        #[error("cannot write the trace {path}: {message}")]
        Write {
            /// The file.
            path: String,
            /// What the file system or the JSON parser said.
            message: String,
        },
    }

    /// What [`ChromeTrace::finish`] wrote.
    #[derive(Clone, Debug, PartialEq, Eq)]
    pub struct TraceSummary {
        /// The trace file.
        pub path: PathBuf,
        /// CPU spans (each a begin and an end event).
        pub cpu_spans: usize,
        /// GPU spans: one per pass that ran and was timed, in every frame.
        pub gpu_spans: usize,
        /// Frames with GPU spans.
        pub gpu_frames: usize,
    }

    /// A Chrome trace being recorded (the JSON trace event format that chrome://tracing and
    /// <https://ui.perfetto.dev> open): every `tracing` span of the process on its thread's track,
    /// and every render graph pass's GPU time on a track named `GPU`, from
    /// [`ChromeTrace::start`] to [`ChromeTrace::finish`].
    ///
    /// `tracing-chrome` writes the CPU spans as they close into `FILE.partial`; `finish` streams
    /// them into `FILE` (naming bevy's `system` and `schedule` spans by the system or schedule
    /// they time), then the GPU spans, placed on the same clock as the module documentation
    /// explains.
    pub struct ChromeTrace {
        path: PathBuf,
        partial: PathBuf,
        guard: tracing_chrome::FlushGuard,
        anchor: Instant,
    }

    fn write_error(path: &Path, e: impl std::fmt::Display) -> TraceError {
        TraceError::Write { path: path.display().to_string(), message: e.to_string() }
    }

    impl ChromeTrace {
        /// Installs the process's `tracing` subscriber, writing a Chrome trace to `path`, and
        /// starts keeping GPU spans. Start it before building the app: bevy_ecs makes each
        /// system's span when the system is added, and a span made without a subscriber stays
        /// disabled.
        pub fn start(path: &Path) -> Result<Self, TraceError> {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir).map_err(|e| write_error(dir, e))?;
            }
            let mut partial = path.as_os_str().to_owned();
            partial.push(".partial");
            let partial = PathBuf::from(partial);
            let file = std::fs::File::create(&partial).map_err(|e| write_error(&partial, e))?;
            let (layer, guard) = tracing_chrome::ChromeLayerBuilder::new().writer(file).include_args(true).build();
            let filter =
                tracing_subscriber::filter::filter_fn(|meta| *meta.level() <= tracing::Level::INFO && !LEFT_OUT.contains(&meta.name()));
            let subscriber = tracing_subscriber::registry().with(filter).with(layer);
            if tracing::subscriber::set_global_default(subscriber).is_err() {
                drop(guard);
                let _ = std::fs::remove_file(&partial);
                return Err(TraceError::AlreadyInstalled { path: path.display().to_string() });
            }
            let before = Instant::now();
            tracing::info!(name: ANCHOR, target: "engine::trace", "the trace's clock");
            let after = Instant::now();
            gpu_frames().clear();
            RECORDING.store(true, Ordering::Relaxed);
            Ok(Self { path: path.to_path_buf(), partial, guard, anchor: before + (after - before) / 2 })
        }

        /// Stops keeping GPU spans, flushes the CPU spans and writes the trace file. Spans that
        /// close after this are not written (the subscriber stays installed: a process has one).
        pub fn finish(self) -> Result<TraceSummary, TraceError> {
            RECORDING.store(false, Ordering::Relaxed);
            let frames = std::mem::take(&mut *gpu_frames());
            let Self { path, partial, guard, anchor } = self;
            drop(guard);
            let input = std::fs::File::open(&partial).map_err(|e| write_error(&partial, e))?;
            let output = std::fs::File::create(&path).map_err(|e| write_error(&path, e))?;
            let mut out = BufWriter::new(output);
            let io = |e: std::io::Error| write_error(&path, e);
            write!(out, "{{\"displayTimeUnit\":\"ms\",\"traceEvents\":[").map_err(io)?;
            let mut first = true;
            let mut emit = |out: &mut BufWriter<std::fs::File>, event: &Value| -> std::io::Result<()> {
                out.write_all(if first { b"\n" } else { b",\n" })?;
                first = false;
                serde_json::to_writer(&mut *out, event).map_err(std::io::Error::other)
            };
            let process = std::env::current_exe().ok().and_then(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()));
            emit(&mut out, &json!({"ph": "M", "pid": 1, "name": "process_name", "args": {"name": process.unwrap_or_default()}}))
                .map_err(io)?;
            let (mut anchor_us, mut cpu_spans) = (None, 0);
            for (number, line) in std::io::BufReader::new(input).lines().enumerate() {
                let line = line.map_err(|e| write_error(&partial, e))?;
                let entry = line.trim().trim_end_matches(',');
                if entry.is_empty() || entry == "[" || entry == "]" {
                    continue;
                }
                let mut event: Value =
                    serde_json::from_str(entry).map_err(|e| write_error(&partial, format!("line {}: {e}", number + 1)))?;
                if event["name"] == ANCHOR {
                    anchor_us = event["ts"].as_f64();
                    continue;
                }
                name_by_args(&mut event);
                cpu_spans += usize::from(event["ph"] == "B");
                emit(&mut out, &event).map_err(io)?;
            }
            let anchor_us = anchor_us.ok_or_else(|| write_error(&partial, "the clock's anchor event is missing"))?;
            let spans = place_gpu_spans(&frames, anchor);
            emit(&mut out, &json!({"ph": "M", "pid": 1, "tid": GPU_TRACK, "name": "thread_name", "args": {"name": "GPU"}})).map_err(io)?;
            emit(&mut out, &json!({"ph": "M", "pid": 1, "tid": GPU_TRACK, "name": "thread_sort_index", "args": {"sort_index": -1}}))
                .map_err(io)?;
            for s in &spans {
                let event = json!({
                    "ph": "X", "pid": 1, "tid": GPU_TRACK, "name": s.label, "cat": "gpu",
                    "ts": anchor_us + s.start_ns / 1e3, "dur": (s.end_ns - s.start_ns) / 1e3, "args": {"frame": s.frame},
                });
                emit(&mut out, &event).map_err(io)?;
            }
            write!(out, "\n]}}\n").map_err(io)?;
            out.flush().map_err(io)?;
            drop(out);
            let _ = std::fs::remove_file(&partial);
            Ok(TraceSummary { path, cpu_spans, gpu_spans: spans.len(), gpu_frames: frames.len() })
        }
    }

    /// Names bevy's spans by what they time: a `system` or `schedule` span by its `name` argument
    /// (the system's path, the schedule's label), `system_commands` as that with ` (commands)`,
    /// `record_pass` as `record ` and the pass label, `readback` as `readback ` and the buffer's.
    fn name_by_args(event: &mut Value) {
        // tracing-chrome writes every argument as its `Debug` form: strings come quoted.
        let arg =
            |key: &str| event["args"][key].as_str().map(|a| a.strip_prefix('"').and_then(|a| a.strip_suffix('"')).unwrap_or(a).to_owned());
        let name = match event["name"].as_str() {
            Some("system" | "schedule") => arg("name"),
            Some("system_commands") => arg("name").map(|n| format!("{n} (commands)")),
            Some("record_pass") => arg("pass").map(|p| format!("record {p}")),
            Some("readback") => arg("buffer").map(|b| format!("readback {b}")),
            _ => None,
        };
        if let Some(name) = name {
            event["name"] = name.into();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    fn frame(submitted: Instant, observed: Instant, passes: &[(&str, u64, u64)]) -> GpuFrameSpans {
        GpuFrameSpans { submitted, observed, period_ns: 1.0, passes: passes.iter().map(|(l, b, e)| (l.to_string(), *b, *e)).collect() }
    }

    /// GPU clock = CPU clock (ns after `t0`) + 5 s. Frame 0 starts 20 µs after its submission,
    /// frame 1 3 µs after it: the offset comes from frame 1, which is placed at its submission;
    /// every pass lands 3 µs early, frame 0's still after its submission.
    #[test]
    fn gpu_spans_land_in_their_frames_window_with_the_tightest_offset() {
        let t0 = Instant::now();
        let at = |us: u64| t0 + Duration::from_micros(us);
        let gpu = |cpu_us: u64| 5_000_000_000 + cpu_us * 1000;
        let frames = vec![
            (0, frame(at(100), at(400), &[("a", gpu(120), gpu(200)), ("b", gpu(200), gpu(300))])),
            (1, frame(at(1000), at(1300), &[("a", gpu(1003), gpu(1100)), ("b", gpu(1100), gpu(1250))])),
        ];
        let spans = place_gpu_spans(&frames, t0);
        let ns = |us: f64| us * 1e3;
        let expect = [(0, "a", 117.0, 197.0), (0, "b", 197.0, 297.0), (1, "a", 1000.0, 1097.0), (1, "b", 1097.0, 1247.0)];
        assert_eq!(spans.len(), expect.len());
        for (s, (frame, label, start, end)) in spans.iter().zip(expect) {
            assert_eq!((s.frame, s.label.as_str()), (frame, label));
            assert!((s.start_ns - ns(start)).abs() < 1.0 && (s.end_ns - ns(end)).abs() < 1.0, "{s:?}");
        }
    }

    /// A frame whose interval excludes the common offset (a drifting clock, another device's
    /// epoch) is clamped into its own window: its passes keep their lengths and stay inside it.
    #[test]
    fn a_frame_whose_clock_jumped_is_clamped_into_its_own_window() {
        let t0 = Instant::now();
        let at = |us: u64| t0 + Duration::from_micros(us);
        let frames = vec![
            (0, frame(at(100), at(400), &[("a", 1_000_000, 1_100_000)])),
            // Another epoch: ticks far below the first frame's.
            (1, frame(at(1000), at(1300), &[("a", 10_000, 60_000)])),
        ];
        let spans = place_gpu_spans(&frames, t0);
        assert_eq!(spans.len(), 2);
        for (s, (window, length)) in spans.iter().zip([((100_000.0, 400_000.0), 100_000.0), ((1_000_000.0, 1_300_000.0), 50_000.0)]) {
            assert!(s.start_ns >= window.0 - 1.0 && s.end_ns <= window.1 + 1.0, "{s:?} outside {window:?}");
            assert!((s.end_ns - s.start_ns - length).abs() < 1.0, "{s:?}");
        }
    }

    #[test]
    fn nothing_is_recorded_without_a_trace() {
        assert!(!recording_gpu_spans());
        record_gpu_frame(3, frame(Instant::now(), Instant::now(), &[("a", 1, 2)]));
        assert!(gpu_frames().is_empty());
    }
}

//! Per-pass GPU timings of camera frames ([`FrameTimings`]): each frame's passes with their GPU
//! milliseconds, the passes left out and why, and per-frame counters, as `timings.json` lists them.

use std::collections::VecDeque;
use std::ops::Not;

use bevy_ecs::prelude::*;
use serde::Serialize;

use crate::gpu::GpuContext;
use crate::graph::{FrameReport, GpuTimer};

/// Per-pass GPU time of each frame, and which passes were left out and why.
#[derive(Resource, Default)]
pub struct FrameTimings {
    /// Every frame whose timings have come back, oldest first (at most `keep` of them).
    pub frames: Vec<FrameTiming>,
    /// Block at the end of each frame until its timings are back (headless, deterministic runs).
    pub wait_each_frame: bool,
    /// Keep at most this many frames (0: all).
    pub keep: usize,
    pending: VecDeque<(u64, FrameReport)>,
    /// Counters that arrived before their frame's timings.
    pending_counters: Vec<(u64, String, f64)>,
}

/// One frame's GPU timings: what `timings.json` lists per frame.
///
/// In JSON it is an object of maps keyed by pass label, in pass order: `frame`; `gpu_ms`, every
/// pass that ran → its GPU milliseconds (`null` without timestamp queries); `left_out`, every pass
/// that did not run → why; `notes`, passes that ran specialized → how (absent when none);
/// `counters`, name → value (absent when none). A label that appears twice in one frame (which
/// no frame script does) keys its second pass as `label#2`.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTiming {
    /// The frame's index ([`Time::frame`](crate::app::Time::frame)).
    pub frame: u64,
    /// Every pass the frame's graph had, in order.
    pub passes: Vec<PassTiming>,
    /// Per-frame counts that plugins report (e.g. `ddgi_rays`: rays traced), by name.
    pub counters: Vec<(String, f64)>,
}

impl FrameTiming {
    /// The GPU milliseconds of the pass `label`, if it ran and was timed.
    pub fn gpu_ms(&self, label: &str) -> Option<f64> {
        self.passes.iter().find(|p| p.ran && p.label == label).and_then(|p| p.gpu_ms)
    }

    /// Every pass that ran, in order, with its GPU milliseconds (`None` without timestamp queries):
    /// the frame's `gpu_ms` map in `timings.json`.
    pub fn gpu_ms_by_pass(&self) -> impl Iterator<Item = (&str, Option<f64>)> + Clone {
        self.passes.iter().filter(|p| p.ran).map(|p| (p.label.as_str(), p.gpu_ms))
    }

    /// The sum of the GPU milliseconds of the passes that ran; `None` if any of them is untimed.
    pub fn total_gpu_ms(&self) -> Option<f64> {
        self.gpu_ms_by_pass().map(|(_, ms)| ms).sum()
    }
}

/// Serializes `(key, value)` pairs as one JSON object in their order; a key seen before gets
/// `#2`, `#3`, … appended, so that no pair is lost.
pub(crate) struct OrderedMap<I>(pub I);

impl<'a, V: Serialize + 'a, I: Clone + Iterator<Item = (&'a str, V)>> Serialize for OrderedMap<I> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(None)?;
        let mut seen: Vec<&str> = Vec::new();
        for (key, value) in self.0.clone() {
            let repeats = seen.iter().filter(|k| **k == key).count();
            seen.push(key);
            if repeats == 0 {
                map.serialize_entry(key, &value)?;
            } else {
                map.serialize_entry(&format!("{key}#{}", repeats + 1), &value)?;
            }
        }
        map.end()
    }
}

impl Serialize for FrameTiming {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(None)?;
        map.serialize_entry("frame", &self.frame)?;
        map.serialize_entry("gpu_ms", &OrderedMap(self.gpu_ms_by_pass()))?;
        let left_out = self.passes.iter().filter(|p| !p.ran).map(|p| (p.label.as_str(), p.note.as_str()));
        map.serialize_entry("left_out", &OrderedMap(left_out))?;
        let notes = self.passes.iter().filter(|p| p.ran && !p.note.is_empty()).map(|p| (p.label.as_str(), p.note.as_str()));
        if notes.clone().next().is_some() {
            map.serialize_entry("notes", &OrderedMap(notes))?;
        }
        if !self.counters.is_empty() {
            map.serialize_entry("counters", &OrderedMap(self.counters.iter().map(|(n, v)| (n.as_str(), *v))))?;
        }
        map.end()
    }
}

/// One pass of a [`FrameTiming`].
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PassTiming {
    /// The pass label (also its wgpu label and timing span).
    pub label: String,
    /// Whether it ran (false: the graph culled it, see `note`).
    pub ran: bool,
    /// Why it was left out, when it was; how it was specialized, when it ran.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
    /// GPU time of the pass in milliseconds; absent without timestamp queries.
    pub gpu_ms: Option<f64>,
}

impl FrameTimings {
    pub(super) fn push(&mut self, gpu: &GpuContext, timer: &mut GpuTimer, frame: u64, mut report: FrameReport) {
        if self.wait_each_frame {
            let times = report.wait_for_timings(gpu, timer);
            self.record(frame, &mut report, times);
        } else {
            self.pending.push_back((frame, report));
            self.collect(gpu, timer);
        }
        if self.keep > 0 && self.frames.len() > self.keep {
            let excess = self.frames.len() - self.keep;
            self.frames.drain(..excess);
        }
    }

    /// Moves every frame whose timestamps have arrived into `frames`, without blocking.
    pub fn collect(&mut self, gpu: &GpuContext, timer: &mut GpuTimer) {
        while let Some((frame, report)) = self.pending.front_mut() {
            let frame = *frame;
            let times = if gpu.timestamps {
                match report.try_timings(gpu, timer) {
                    Some(t) => Some(t),
                    None if self.pending.len() > 8 => None,
                    None => return,
                }
            } else {
                None
            };
            let (_, mut report) = self.pending.pop_front().expect("front exists");
            self.record(frame, &mut report, times);
        }
    }

    fn record(&mut self, frame: u64, report: &mut FrameReport, times: Option<Vec<(String, f64)>>) {
        if let Some(spans) = report.take_gpu_spans() {
            crate::trace::record_gpu_frame(frame, spans);
        }
        let passes = report
            .passes
            .iter()
            .map(|p| PassTiming {
                label: p.label.clone(),
                ran: p.ran,
                note: p.note.clone(),
                gpu_ms: times.as_ref().and_then(|t| t.iter().find(|(l, _)| *l == p.label).map(|(_, ms)| *ms)),
            })
            .collect();
        let mut counters = Vec::new();
        self.pending_counters.retain(|(f, name, value)| {
            let mine = *f == frame;
            if mine {
                counters.push((name.clone(), *value));
            }
            mine.not()
        });
        self.frames.push(FrameTiming { frame, passes, counters });
    }

    /// Records a per-frame count of frame `frame` (it may arrive before or after the frame's
    /// timings; a readback a few frames late is fine).
    pub fn record_counter(&mut self, frame: u64, name: &str, value: f64) {
        if let Some(f) = self.frames.iter_mut().rev().find(|f| f.frame == frame) {
            f.counters.push((name.into(), value));
        } else if self.frames.last().is_none_or(|f| f.frame < frame) {
            self.pending_counters.push((frame, name.into(), value));
        }
    }

    /// The value of counter `name` of each recorded frame that has one.
    pub fn counter(&self, name: &str) -> Vec<(u64, f64)> {
        self.frames.iter().filter_map(|f| f.counters.iter().find(|(n, _)| n == name).map(|(_, v)| (f.frame, *v))).collect()
    }

    /// Mean GPU milliseconds of each pass over the recorded frames, in pass order.
    pub fn mean_ms(&self) -> Vec<(String, Option<f64>)> {
        let mut out: Vec<(String, f64, usize)> = Vec::new();
        for f in &self.frames {
            for p in f.passes.iter().filter(|p| p.ran) {
                let i = out.iter().position(|(l, ..)| *l == p.label).unwrap_or_else(|| {
                    out.push((p.label.clone(), 0.0, 0));
                    out.len() - 1
                });
                if let Some(ms) = p.gpu_ms {
                    out[i].1 += ms;
                    out[i].2 += 1;
                }
            }
        }
        out.into_iter().map(|(l, sum, n)| (l, (n > 0).then(|| sum / n as f64))).collect()
    }
}

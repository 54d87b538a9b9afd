//! Judging a soak run (thousands of frames of an app, sampled every so often): no NaN or Inf, no
//! memory growth and no frame-time drift after the warm-up, within [`SoakLimits`]; and the samples
//! as CSV. The run itself belongs to the app that soaks (`game_demo play --headless --soak` drives
//! the demo level and fills the [`SoakSample`]s).
//!
//! The resident memory is not bounded on a software driver: lavapipe compiles shader variants as
//! it executes and keeps them (its own memory, not ours, which the heap bound covers).

use std::fmt::Write as _;
use std::path::Path;

use engine::gpu::GpuContext;
use engine::wgpu;

/// The bounds a soak must stay within.
#[derive(Clone, Copy, Debug)]
pub struct SoakLimits {
    /// Growth of the Rust heap over its first sample after the warm-up, in MiB.
    pub heap_growth_mib: f64,
    /// Growth of the resident memory over its first sample after the warm-up, in MiB (`None`: not
    /// bounded, on a software driver).
    pub rss_growth_mib: Option<f64>,
    /// Growth of the GPU memory wgpu's allocator holds over its first sample after the warm-up, in MiB.
    pub gpu_growth_mib: f64,
    /// Largest ratio of a window's median frame time (GPU and CPU each) to the first window's
    /// after the warm-up. The level's lighting changes (day and night, the door), so the work of a
    /// frame does too: this catches drift and leaks of work, not the level's own variation.
    pub time_ratio: f64,
}

impl Default for SoakLimits {
    fn default() -> Self {
        Self { heap_growth_mib: 16.0, rss_growth_mib: Some(64.0), gpu_growth_mib: 8.0, time_ratio: 2.0 }
    }
}

impl SoakLimits {
    /// The default bounds for `gpu`'s adapter: the resident memory is left unbounded on a software
    /// driver (see the module's notes).
    pub fn for_adapter(gpu: &GpuContext) -> Self {
        let software = gpu.adapter.get_info().device_type == wgpu::DeviceType::Cpu;
        Self { rss_growth_mib: (!software).then_some(64.0), ..Self::default() }
    }
}

/// One check: the frame it followed and what was measured over the window before it.
#[derive(Clone, Debug, PartialEq)]
pub struct SoakSample {
    pub frame: u32,
    /// Heap held by the Rust code, bytes (`None` without [`engine::memory::CountingAllocator`]).
    pub heap_bytes: Option<u64>,
    /// Resident memory of the process, bytes (`None` where `/proc` is missing).
    pub rss_bytes: Option<u64>,
    /// GPU memory held by wgpu's allocator, bytes (`None` where the backend has no report).
    pub gpu_bytes: Option<u64>,
    /// Median GPU milliseconds of a frame over the window (`None` without timestamps).
    pub gpu_ms: Option<f64>,
    /// Median CPU milliseconds of a frame (the app's update, render and submit) over the window.
    pub cpu_ms: f64,
    /// Median DDGI rays per frame over the window (as read back; `None` before any arrived).
    pub rays: Option<f64>,
    /// Non-finite values in the HDR image and the atlases at this frame.
    pub non_finite: usize,
}

/// Judges a soak's samples: no non-finite value anywhere; after the warm-up (the baselines are the
/// first samples at or after frame `warmup`) no memory growth and no timing rise beyond `limits`.
pub fn judge_soak(samples: &[SoakSample], warmup: u32, limits: &SoakLimits) -> Vec<String> {
    let mut failures = Vec::new();
    for s in samples.iter().filter(|s| s.non_finite > 0) {
        failures.push(format!("{} non-finite values in the image or the probe atlases at frame {}", s.non_finite, s.frame));
    }
    let settled: Vec<&SoakSample> = samples.iter().filter(|s| s.frame >= warmup).collect();
    let Some(base) = settled.first() else {
        failures.push(format!("no sample after the warm-up of {warmup} frames: run more frames"));
        return failures;
    };
    const MIB: f64 = 1024.0 * 1024.0;
    let growth = |what: &str, get: fn(&SoakSample) -> Option<u64>, limit_mib: f64, failures: &mut Vec<String>| {
        let Some(base_bytes) = get(base) else { return };
        if let Some(worst) = settled.iter().filter_map(|s| get(s).map(|b| (s.frame, b))).max_by_key(|(_, b)| *b) {
            let grown = (worst.1 as f64 - base_bytes as f64) / MIB;
            if grown > limit_mib {
                failures.push(format!(
                    "{what} grew by {grown:.1} MiB between frame {} and frame {} (limit {limit_mib} MiB)",
                    base.frame, worst.0
                ));
            }
        }
    };
    growth("the Rust heap", |s| s.heap_bytes, limits.heap_growth_mib, &mut failures);
    if let Some(limit) = limits.rss_growth_mib {
        growth("resident CPU memory", |s| s.rss_bytes, limit, &mut failures);
    }
    growth("GPU memory", |s| s.gpu_bytes, limits.gpu_growth_mib, &mut failures);
    let rise = |what: &str, get: fn(&SoakSample) -> Option<f64>, failures: &mut Vec<String>| {
        let Some(base_ms) = get(base).filter(|ms| *ms > 0.0) else { return };
        for s in &settled[1..] {
            if let Some(ms) = get(s)
                && ms > limits.time_ratio * base_ms
            {
                failures.push(format!(
                    "median {what} time per frame rose from {base_ms:.3} ms (frames up to {}) to {ms:.3} ms (frames up to {}), over {}×",
                    base.frame, s.frame, limits.time_ratio
                ));
            }
        }
    };
    rise("GPU", |s| s.gpu_ms, &mut failures);
    rise("CPU", |s| Some(s.cpu_ms), &mut failures);
    failures
}

/// The process's resident memory, from `VmRSS` in `/proc/self/status` (Linux).
pub fn resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Writes `samples` to `path` as CSV, one row per check (memory in MiB, times in ms).
pub fn write_soak_csv(path: &Path, samples: &[SoakSample]) -> Result<(), String> {
    let mut text = String::from("frame,heap_mib,rss_mib,gpu_mib,gpu_ms_median,cpu_ms_median,rays_median,non_finite\n");
    let mib = |b: Option<u64>| b.map_or(String::new(), |b| format!("{:.2}", b as f64 / (1024.0 * 1024.0)));
    let num = |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
    for s in samples {
        let _ = writeln!(
            text,
            "{},{},{},{},{},{:.3},{},{}",
            s.frame,
            mib(s.heap_bytes),
            mib(s.rss_bytes),
            mib(s.gpu_bytes),
            num(s.gpu_ms, 3),
            s.cpu_ms,
            num(s.rays, 0),
            s.non_finite
        );
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(frame: u32, rss_mib: u64, gpu_mib: u64, gpu_ms: f64, cpu_ms: f64) -> SoakSample {
        SoakSample {
            frame,
            heap_bytes: Some(100 << 20),
            rss_bytes: Some(rss_mib << 20),
            gpu_bytes: Some(gpu_mib << 20),
            gpu_ms: Some(gpu_ms),
            cpu_ms,
            rays: Some(1000.0),
            non_finite: 0,
        }
    }

    #[test]
    fn a_steady_soak_passes_and_the_warm_up_is_not_judged() {
        // Memory and time settle during the warm-up (frames before 100), then stay.
        let samples = vec![
            sample(50, 100, 10, 9.0, 30.0),
            sample(100, 300, 40, 2.0, 10.0),
            sample(150, 310, 40, 2.2, 11.0),
            sample(200, 305, 40, 1.9, 9.0),
        ];
        assert_eq!(judge_soak(&samples, 100, &SoakLimits::default()), Vec::<String>::new());
    }

    #[test]
    fn memory_growth_timing_drift_and_non_finite_values_each_fail() {
        let limits = SoakLimits::default();
        let base = sample(100, 300, 40, 2.0, 10.0);
        let leak_cpu = vec![base.clone(), sample(200, 300 + 65, 40, 2.0, 10.0)];
        let failures = judge_soak(&leak_cpu, 100, &limits);
        assert!(failures.len() == 1 && failures[0].contains("resident CPU memory grew by 65.0 MiB"), "{failures:?}");
        let leak_heap = vec![base.clone(), SoakSample { heap_bytes: Some(117 << 20), ..sample(200, 300, 40, 2.0, 10.0) }];
        let failures = judge_soak(&leak_heap, 100, &limits);
        assert!(failures.len() == 1 && failures[0].contains("the Rust heap grew by 17.0 MiB"), "{failures:?}");
        // On a software driver the resident memory is reported, not bounded.
        let software = SoakLimits { rss_growth_mib: None, ..limits };
        assert!(judge_soak(&leak_cpu, 100, &software).is_empty());
        let leak_gpu = vec![base.clone(), sample(200, 300, 49, 2.0, 10.0)];
        let failures = judge_soak(&leak_gpu, 100, &limits);
        assert!(failures.len() == 1 && failures[0].contains("GPU memory grew by 9.0 MiB"), "{failures:?}");
        let slow_gpu = vec![base.clone(), sample(200, 300, 40, 4.5, 10.0)];
        let failures = judge_soak(&slow_gpu, 100, &limits);
        assert!(failures.len() == 1 && failures[0].contains("median GPU time per frame rose from 2.000 ms"), "{failures:?}");
        let slow_cpu = vec![base.clone(), sample(200, 300, 40, 2.0, 25.0)];
        assert_eq!(judge_soak(&slow_cpu, 100, &limits).len(), 1);
        let nan = vec![base, SoakSample { non_finite: 3, ..sample(200, 300, 40, 2.0, 10.0) }];
        let failures = judge_soak(&nan, 100, &limits);
        assert!(failures.len() == 1 && failures[0].contains("3 non-finite values") && failures[0].contains("frame 200"), "{failures:?}");
    }

    #[test]
    fn a_soak_shorter_than_its_warm_up_is_an_error_not_a_pass() {
        let failures = judge_soak(&[sample(50, 100, 10, 2.0, 10.0)], 100, &SoakLimits::default());
        assert!(failures.len() == 1 && failures[0].contains("no sample after the warm-up"), "{failures:?}");
    }

    #[test]
    fn resident_memory_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let rss = resident_bytes().expect("/proc/self/status");
            assert!(rss > 1 << 20, "a running test process holds more than 1 MiB, got {rss} bytes");
        }
    }
}

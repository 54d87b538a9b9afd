//! `game_demo play --headless --soak`: the demo level for thousands of frames on the fixed clock,
//! with every moving part running (the scripted player looping its tour, the door, the lift, the
//! orbiting coloured light, the flying enemy, the day–night cycle), checked as it goes:
//!
//! - **no NaN or Inf**: every `check_every` frames the HDR image and both atlases of every DDGI
//!   volume are read back and every value must be finite;
//! - **no memory growth**: the heap the program's Rust code holds ([`engine::memory`]), the GPU
//!   memory wgpu's allocator holds (`Device::generate_allocator_report`) and the process's
//!   resident memory (`VmRSS` of `/proc/self/status`) may not grow, after the warm-up, beyond a
//!   bound (the resident memory not on a software driver: see [`lab::soak`]);
//! - **stable timings**: the median GPU time and CPU time of a frame over each window of
//!   `check_every` frames may not rise, after the warm-up, beyond a ratio of the first window's.
//!
//! This module drives the level and samples it; [`lab::soak`] judges the samples and writes them to
//! `soak.csv`; a failed check is an error naming the check, the frame and the values. CI runs a short soak (`game_demo/tests/play.rs`); `make soak` runs 10,000 frames.

use std::path::PathBuf;
use std::time::Instant;

use engine::gpu::GpuContext;
use engine::headless::{headless_app, read_hdr};
use engine::render::{FrameTimings, RenderSize};
use lab::median;
use lab::soak::{SoakLimits, SoakSample, judge_soak, resident_bytes, write_soak_csv};

use super::{PlayOptions, STEP_SECONDS, setup_play};

/// How long to soak and how strictly to judge it.
#[derive(Clone, Debug)]
pub struct SoakOptions {
    pub frames: u32,
    /// Check for NaN and sample memory and timings every this many frames.
    pub check_every: u32,
    /// Frames before the baselines are taken (pipelines, pools and the BVH settle in).
    pub warmup: u32,
    pub limits: SoakLimits,
    /// Where `soak.csv` goes.
    pub out: PathBuf,
}

/// What a soak measured.
pub struct SoakReport {
    pub samples: Vec<SoakSample>,
    pub csv: PathBuf,
    /// Each check that failed, in words. Empty: the soak passed.
    pub failures: Vec<String>,
}

/// Runs the level for `soak.frames` frames and judges it ([`judge_soak`]).
pub fn run_soak(gpu: &GpuContext, options: &PlayOptions, soak: &SoakOptions) -> Result<SoakReport, String> {
    if soak.frames == 0 || soak.check_every == 0 {
        return Err(format!(
            "a soak needs at least one frame and one check (--frames {}, --check-every {})",
            soak.frames, soak.check_every
        ));
    }
    std::fs::create_dir_all(&soak.out).map_err(|e| format!("{}: {e}", soak.out.display()))?;
    let mut app = headless_app(gpu, RenderSize { width: options.width, height: options.height }, STEP_SECONDS);
    setup_play(&mut app, options, true)?;
    // Only the recent frames' timings are kept: the soak must not grow memory of its own.
    app.world_mut().resource_mut::<FrameTimings>().keep = 2 * soak.check_every as usize;
    engine::app::finish_plugins(&mut app);

    let mut samples = Vec::new();
    let mut cpu_window = Vec::with_capacity(soak.check_every as usize);
    let mut gpu_window = Vec::with_capacity(soak.check_every as usize);
    let bar = lab::progress::bar(u64::from(soak.frames), "soak", "frames");
    for frame in 0..soak.frames {
        bar.inc(1);
        let start = Instant::now();
        app.update();
        cpu_window.push(start.elapsed().as_secs_f64() * 1e3);
        let world = app.world_mut();
        if let Some(lost) = world.get_resource::<engine::app::GpuLost>() {
            return Err(format!("the GPU device was lost at frame {}: {}", lost.frame, lost.reason));
        }
        let timings = world.resource::<FrameTimings>();
        if let Some(last) = timings.frames.last().filter(|f| f.frame == u64::from(frame)) {
            let times: Vec<f64> = last.passes.iter().filter_map(|p| p.gpu_ms).collect();
            if !times.is_empty() {
                gpu_window.push(times.iter().sum());
            }
        }
        if (frame + 1) % soak.check_every != 0 && frame + 1 != soak.frames {
            continue;
        }
        let first_in_window = u64::from(frame + 1).saturating_sub(cpu_window.len() as u64);
        let mut rays: Vec<f64> = timings.counter("ddgi_rays").into_iter().filter(|(f, _)| *f >= first_in_window).map(|(_, v)| v).collect();
        let non_finite = count_non_finite(gpu, world);
        samples.push(SoakSample {
            frame: frame + 1,
            heap_bytes: engine::memory::live_heap_bytes(),
            rss_bytes: resident_bytes(),
            gpu_bytes: gpu.device.generate_allocator_report().map(|r| r.total_allocated_bytes),
            gpu_ms: median(&mut gpu_window),
            cpu_ms: median(&mut cpu_window).unwrap_or(0.0),
            rays: median(&mut rays),
            non_finite,
        });
        cpu_window.clear();
        gpu_window.clear();
        if non_finite > 0 {
            // No point going on: the state is already poisoned.
            break;
        }
    }
    let csv = soak.out.join("soak.csv");
    write_soak_csv(&csv, &samples)?;
    let failures = judge_soak(&samples, soak.warmup, &soak.limits);
    bar.finish_and_clear();
    Ok(SoakReport { samples, csv, failures })
}

/// Non-finite values in the last frame's HDR image and in both atlases of every DDGI volume.
fn count_non_finite(gpu: &GpuContext, world: &bevy_ecs::world::World) -> usize {
    let image = read_hdr(gpu, world).iter().filter(|v| !v.is_finite()).count();
    let atlases: usize = world
        .get_resource::<ddgi::DdgiGpuVolumes>()
        .map_or(0, |volumes| volumes.volumes.iter().map(|(_, volume)| ddgi::atlas::count_non_finite(gpu, volume)).sum());
    image + atlases
}

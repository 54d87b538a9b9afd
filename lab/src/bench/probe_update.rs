//! `bench ddgi`: DDGI's probe update timed pass by pass at every grid × rays cell of the
//! published table ([`ddgi_throughput`], one [`DdgiCell`] each).

use engine::app::run_headless;
use engine::gpu::GpuContext;
use engine::render::RenderSize;
use engine::scene::SceneDescription;

use super::median;

/// The passes of DDGI's probe update (everything but the camera's gather and composite);
/// `ddgi_shade` runs only with the persistent trace ([`ddgi::DdgiVolume::persistent_trace`]).
pub const DDGI_UPDATE_PASSES: [&str; 4] = ddgi::PROBE_UPDATE_PASSES;

/// One cell of the DDGI throughput table: median GPU milliseconds of each pass over the timed
/// frames, and of the whole probe update per frame.
pub struct DdgiCell {
    pub grid: [u32; 3],
    pub rays_per_probe: u32,
    /// Traced with the persistent trace ([`ddgi::DdgiVolume::persistent_trace`]).
    pub persistent_trace: bool,
    /// Rays traced per frame, as the GPU counted them (median over the timed frames; the
    /// `ddgi_rays` counter): what the throughput is reported for.
    pub rays: u64,
    /// Probes × rays per probe: what every probe tracing its whole budget would give. More than
    /// [`DdgiCell::rays`] when probes were skipped (switched off as dark or inside geometry, or
    /// resting under adaptive budgets).
    pub nominal_rays: u64,
    pub passes: Vec<(String, f64)>,
    pub update_ms: f64,
}

impl DdgiCell {
    /// Rays per second of the full probe update (budget, generation, trace, shading, map updates,
    /// borders, relocation, classification).
    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / (self.update_ms * 1e-3) / 1e6
    }

    pub fn pass_ms(&self, label: &str) -> Option<f64> {
        self.passes.iter().find(|(l, _)| l == label).map(|(_, ms)| *ms)
    }

    /// The share of the nominal rays that were traced (1: no probe skipped).
    pub fn traced_share(&self) -> f64 {
        if self.nominal_rays == 0 { 1.0 } else { self.rays as f64 / self.nominal_rays as f64 }
    }
}

/// Runs DDGI on `scene` at every grid × rays cell of the published table, traced each way of
/// `persistent_traces` ([`ddgi::DdgiVolume::persistent_trace`]; one after the other in each cell),
/// in one app (the volume's settings changed between cells, so the BVHs are built once): 3 warm-up
/// frames, then `iterations` timed frames per cell and way. Classification is off, but probes can
/// still be skipped (switched off as dark, resting under adaptive budgets): each cell reports the
/// rays the GPU counted ([`DdgiCell::rays`]) beside the nominal probes × rays. The camera renders
/// `size` pixels, so the gather's time is the one of that resolution.
pub fn ddgi_throughput(
    gpu: &GpuContext,
    scene: SceneDescription,
    size: RenderSize,
    iterations: u32,
    grids: &[[u32; 3]],
    ray_counts: &[u32],
    persistent_traces: &[bool],
) -> Result<Vec<DdgiCell>, String> {
    if !gpu.timestamps {
        return Err(format!("{} has no timestamp queries: GPU times cannot be measured", gpu.adapter_name()));
    }
    let volume = |grid: [u32; 3], rays: u32, persistent_trace: bool| ddgi::DdgiVolume {
        probe_counts: Some(grid.into()),
        rays_per_probe: rays,
        classification: false,
        persistent_trace,
        ..Default::default()
    };
    let mut app = engine::headless::headless_app(gpu, size, 1.0 / 60.0);
    crate::progress::show_blas_builds(&mut app);
    let first_way = persistent_traces.first().copied().unwrap_or(false);
    ddgi::use_ddgi(&mut app, volume(grids[0], ray_counts[0], first_way), ddgi::DdgiOutput::Full);
    scene.spawn(app.world_mut());
    let mut cells = Vec::new();
    let ways = if persistent_traces.is_empty() { &[false][..] } else { persistent_traces };
    let bar = crate::progress::bar((grids.len() * ray_counts.len() * ways.len()) as u64, "bench ddgi", "cells");
    for &grid in grids {
        for (&rays_per_probe, &persistent_trace) in ray_counts.iter().flat_map(|r| ways.iter().map(move |w| (r, w))) {
            bar.inc(1);
            {
                let world = app.world_mut();
                let mut volumes = world.query::<&mut ddgi::DdgiVolume>();
                for mut v in volumes.iter_mut(world) {
                    *v = volume(grid, rays_per_probe, persistent_trace);
                }
            }
            run_headless(&mut app, 3 + iterations);
            let world = app.world_mut();
            if let Some(error) = world.resource::<ddgi::DdgiGpuVolumes>().first_error() {
                return Err(format!("{}×{}×{} × {rays_per_probe}: {error}", grid[0], grid[1], grid[2]));
            }
            let frames = std::mem::take(&mut world.resource_mut::<engine::render::FrameTimings>().frames);
            let timed = &frames[frames.len().saturating_sub(iterations as usize)..];
            let mut labels: Vec<String> = Vec::new();
            for f in timed {
                for p in f.passes.iter().filter(|p| p.ran && p.gpu_ms.is_some()) {
                    if !labels.contains(&p.label) {
                        labels.push(p.label.clone());
                    }
                }
            }
            let passes = labels
                .into_iter()
                .map(|l| {
                    let times = timed.iter().filter_map(|f| f.passes.iter().find(|p| p.label == l).and_then(|p| p.gpu_ms)).collect();
                    (l, median(times))
                })
                .collect();
            let update_ms = median(
                timed
                    .iter()
                    .map(|f| f.passes.iter().filter(|p| DDGI_UPDATE_PASSES.contains(&p.label.as_str())).filter_map(|p| p.gpu_ms).sum())
                    .collect(),
            );
            let nominal_rays = u64::from(grid[0] * grid[1] * grid[2] * rays_per_probe);
            let counted: Vec<f64> = timed.iter().filter_map(ddgi::rays_traced).collect();
            if counted.is_empty() {
                return Err(format!("{}×{}×{} × {rays_per_probe}: the GPU reported no ray count", grid[0], grid[1], grid[2]));
            }
            let rays = median(counted).round() as u64;
            cells.push(DdgiCell { grid, rays_per_probe, persistent_trace, rays, nominal_rays, passes, update_ms });
        }
    }
    bar.finish_and_clear();
    Ok(cells)
}

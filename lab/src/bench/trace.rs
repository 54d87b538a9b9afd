//! `bench trace`: the trace pass timed for every grid × rays cell of the published tables
//! ([`trace_throughput`], several variants at once with [`trace_throughput_compared`]), and one
//! cell's hits ([`hit_distances`], [`closest_hits`]) and traversal work ([`traversal_work`]).

use engine::bevy_app::App;
use engine::gpu::GpuContext;
use engine::rng::SplitMix64;
use glam::{DVec3, Vec3};

use super::kernel::{BenchParams, KernelUse, TraceKernel, TraceVariant, params_for};
use super::{GRIDS, RAYS, median};

/// One cell of the throughput table.
#[derive(Clone, Debug)]
pub struct TraceCell {
    pub grid: [u32; 3],
    pub rays_per_probe: u32,
    pub rays: u64,
    pub median_ms: f64,
}

impl TraceCell {
    pub fn mrays_per_second(&self) -> f64 {
        self.rays as f64 / (self.median_ms * 1e-3) / 1e6
    }
}

/// World-space bounds in the render space the TLAS is built in: the render origin follows the
/// scene's camera (the forest's stands 95 m from the world's origin, beyond the rebase distance).
fn render_space(app: &App, (lo, hi): (DVec3, DVec3)) -> (Vec3, Vec3) {
    let origin = app.world().get_resource::<engine::scene::RenderOrigin>().copied().unwrap_or_default();
    (origin.to_render(lo), origin.to_render(hi))
}

pub fn trace_throughput(
    gpu: &GpuContext,
    app: &App,
    bounds: (DVec3, DVec3),
    iterations: u32,
    variant: TraceVariant,
) -> Result<Vec<TraceCell>, String> {
    Ok(trace_throughput_compared(gpu, app, bounds, iterations, &[variant])?.remove(0))
}

/// [`trace_throughput`] of several variants in one run: each dispatch's rays are traced by every
/// variant in turn, so that clocks, caches and the rays are the same for all. One table a variant,
/// in the order given.
pub fn trace_throughput_compared(
    gpu: &GpuContext,
    app: &App,
    bounds: (DVec3, DVec3),
    iterations: u32,
    variants: &[TraceVariant],
) -> Result<Vec<Vec<TraceCell>>, String> {
    if !gpu.timestamps {
        return Err(format!("{} has no timestamp queries: GPU times cannot be measured", gpu.adapter_name()));
    }
    let kernels = variants.iter().map(|&v| TraceKernel::new(gpu, app, KernelUse::Time, v)).collect::<Result<Vec<_>, _>>()?;
    let bounds = render_space(app, bounds);
    let mut rng = SplitMix64::new(0x5EED_1234_ABCD);
    let mut tables = vec![Vec::new(); kernels.len()];
    let bar = crate::progress::bar((GRIDS.len() * RAYS.len()) as u64, "bench trace", "cells");
    for grid in GRIDS {
        for rays_per_probe in RAYS {
            bar.inc(1);
            let mut times = vec![Vec::new(); kernels.len()];
            for iteration in 0..iterations + 3 {
                let p = params_for(&mut rng, bounds, grid, rays_per_probe);
                for (kernel, times) in kernels.iter().zip(&mut times) {
                    let ms = kernel.run(gpu, &p)?;
                    // The first dispatches warm caches and clocks.
                    if iteration >= 3 {
                        times.push(ms);
                    }
                }
            }
            let rays = u64::from(grid[0] * grid[1] * grid[2] * rays_per_probe);
            for (table, times) in tables.iter_mut().zip(times) {
                table.push(TraceCell { grid, rays_per_probe, rays, median_ms: median(times) });
            }
        }
    }
    bar.finish_and_clear();
    Ok(tables)
}

/// One dispatch of `variant`'s kernel over one grid × rays cell, always the same rays (a fixed
/// seed for the rotation), so that `hit_distances` and `traversal_work` see the same ones.
fn run_cell(
    gpu: &GpuContext,
    app: &App,
    bounds: (DVec3, DVec3),
    grid: [u32; 3],
    rays_per_probe: u32,
    variant: TraceVariant,
    usage: KernelUse,
) -> Result<(TraceKernel, BenchParams), String> {
    let kernel = TraceKernel::new(gpu, app, usage, variant)?;
    let p = params_for(&mut SplitMix64::new(0xD1A6), render_space(app, bounds), grid, rays_per_probe);
    kernel.run(gpu, &p)?;
    Ok((kernel, p))
}

/// The closest-hit distance of every ray of one grid × rays cell (the rays `traversal_work`
/// counts), traced by `variant`'s kernel.
pub fn hit_distances(
    gpu: &GpuContext,
    app: &App,
    bounds: (DVec3, DVec3),
    grid: [u32; 3],
    rays_per_probe: u32,
    variant: TraceVariant,
) -> Result<Vec<f32>, String> {
    let (kernel, p) = run_cell(gpu, app, bounds, grid, rays_per_probe, variant, KernelUse::Time)?;
    let mut t: Vec<f32> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &kernel.hits));
    t.truncate(p.ray_count as usize);
    Ok(t)
}

/// A ray's closest hit as the bench kernel finds it ([`closest_hits`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BenchHit {
    /// The hit distance (the ray's tmax, 1e30, for a miss).
    pub t: f32,
    /// The instance slot hit, or u32::MAX for a miss.
    pub instance: u32,
    /// The triangle of the instance's mesh hit (0 for a miss).
    pub primitive: u32,
}

/// The closest hit (distance, instance, triangle) of every ray of one grid × rays cell (the rays
/// [`hit_distances`] traces), traced by `variant`'s kernel.
pub fn closest_hits(
    gpu: &GpuContext,
    app: &App,
    bounds: (DVec3, DVec3),
    grid: [u32; 3],
    rays_per_probe: u32,
    variant: TraceVariant,
) -> Result<Vec<BenchHit>, String> {
    let (kernel, p) = run_cell(gpu, app, bounds, grid, rays_per_probe, variant, KernelUse::HitIds)?;
    let t: Vec<f32> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &kernel.hits));
    let ids: Vec<[u32; 2]> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &kernel.hit_ids));
    Ok(t.iter().zip(&ids).take(p.ray_count as usize).map(|(&t, &[instance, primitive])| BenchHit { t, instance, primitive }).collect())
}

/// Traversal work per ray of one grid × rays cell (the kernel's RT_COUNT_WORK variant).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraversalWork {
    /// TLAS nodes tested, per ray.
    pub tlas_nodes: f64,
    /// Instances entered, per ray.
    pub instances: f64,
    /// BLAS nodes tested, per ray.
    pub blas_nodes: f64,
    /// Triangles tested, per ray.
    pub triangles: f64,
    /// Steps of the traversal loop (its iterations and the triangle tests in them), per ray.
    pub steps: f64,
    /// The steps of all lanes over 32 × each warp's most (warps of 32 consecutive threads of a
    /// workgroup): the share of a warp's lanes busy while it walks, if lanes stepped in lockstep.
    /// Steps in which a lane only waited with its postponed triangles count as idle.
    pub simt_efficiency: f64,
    /// Steps in which a lane put off its triangle tests, per ray ([`TraceVariant::postpone_triangles`]
    /// only).
    pub postponed: f64,
    /// Of those, steps in which it did nothing but wait with them, per ray.
    pub waits: f64,
    /// Stack entries moved from workgroup memory to function memory, per ray (a shared stack
    /// only: [`TraceVariant::shared_stack_entries`]).
    pub stack_spills: f64,
    /// The deepest any ray's traversal stack got, in entries.
    pub deepest_stack: u32,
}

impl TraversalWork {
    /// TLAS nodes, instances entered, BLAS nodes and triangles tested, per ray.
    pub fn counts(&self) -> [f64; 4] {
        [self.tlas_nodes, self.instances, self.blas_nodes, self.triangles]
    }
}

/// Traversal work per ray for one grid × rays cell.
pub fn traversal_work(
    gpu: &GpuContext,
    app: &App,
    bounds: (DVec3, DVec3),
    grid: [u32; 3],
    rays_per_probe: u32,
    variant: TraceVariant,
) -> Result<TraversalWork, String> {
    let (kernel, p) = run_cell(gpu, app, bounds, grid, rays_per_probe, variant, KernelUse::CountWork)?;
    let words = kernel.work(gpu)?;
    let w = words.map(f64::from);
    let per_ray = |v: f64| v / f64::from(p.ray_count);
    Ok(TraversalWork {
        tlas_nodes: per_ray(w[0]),
        instances: per_ray(w[1]),
        blas_nodes: per_ray(w[2]),
        triangles: per_ray(w[3]),
        steps: per_ray(w[4]),
        simt_efficiency: if w[5] > 0.0 { (w[4] - w[9]) / w[5] } else { 1.0 },
        postponed: per_ray(w[8]),
        waits: per_ray(w[9]),
        stack_spills: per_ray(w[6]),
        deepest_stack: words[7],
    })
}

//! `game_demo bench trace`: closest-hit throughput of probe-like rays (GPU timestamps of the trace
//! pass alone) and the CPU cost of keeping the TLAS up to date when instances move.

use std::time::{Duration, Instant};

use engine::app::{EnginePlugin, Time, run_headless};
use engine::bevy_app::App;
use engine::bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::render::{GpuScene, RenderPlugin, RenderSize};
use engine::rt::{RayTracingScene, WaitForBlasBuilds, ray_workgroups};
use engine::scene::{Assets, Mesh, MeshInstance, SceneDescription, Transform};
use engine::shader::compute_program;
use engine::wgpu;
use glam::{Mat4, Quat, Vec3};

/// Probe grids and rays per probe of the published DDGI throughput tables.
pub const GRIDS: [[u32; 3]; 4] = [[16, 8, 16], [32, 8, 32], [32, 16, 32], [32, 32, 32]];
pub const RAYS: [u32; 4] = [32, 64, 128, 256];
/// Numbers of moving instances for the TLAS update measurement.
pub const MOVING: [usize; 4] = [1, 100, 1_000, 10_000];

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BenchParams {
    rotation: [[f32; 4]; 4],
    grid_origin: [f32; 3],
    rays_per_probe: u32,
    grid_spacing: [f32; 3],
    ray_count: u32,
    grid_counts: [u32; 3],
    max_distance: f32,
}

/// Deterministic pseudo-random numbers (xorshift64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn rotation(&mut self) -> Quat {
        let axis = Vec3::new(self.next() - 0.5, self.next() - 0.5, self.next() - 0.5).normalize_or(Vec3::Y);
        Quat::from_axis_angle(axis, self.next() * std::f32::consts::TAU)
    }
}

/// One cell of the throughput table.
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

/// A headless app with the scene prepared (BLASes built, TLAS uploaded).
pub fn prepared_app(gpu: &GpuContext, scene: SceneDescription) -> App {
    let mut app = App::new();
    app.insert_resource(Time::fixed(1.0 / 60.0)).insert_resource(WaitForBlasBuilds(true));
    app.add_plugins((EnginePlugin, RenderPlugin { gpu: gpu.clone(), size: RenderSize { width: 8, height: 8 } }));
    scene.spawn(app.world_mut());
    run_headless(&mut app, 1);
    app
}

/// Times the trace pass for every grid × rays cell: `iterations` timed dispatches after warm-up, median.
pub fn trace_throughput(gpu: &GpuContext, app: &App, bounds: (Vec3, Vec3), iterations: u32) -> Result<Vec<TraceCell>, String> {
    if !gpu.timestamps {
        return Err(format!("{} has no timestamp queries: GPU times cannot be measured", gpu.adapter_name()));
    }
    let program = compute_program(&gpu.device, "bench_trace.wgsl", "main", "trace").map_err(|e| e.to_string())?;
    let scene = app.world().resource::<GpuScene>();
    let rt = app.world().resource::<RayTracingScene>();
    let group0 = program.bind_group(&gpu.device, 0, &rt.scene_bindings(scene));
    let max_rays = GRIDS.iter().map(|g| g[0] * g[1] * g[2]).max().unwrap_or(1) * RAYS.iter().max().unwrap_or(&1);
    let hits = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("bench_hits"),
        size: u64::from(max_rays) * 4,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("bench_params"),
        size: size_of::<BenchParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group1 = program.bind_group(&gpu.device, 1, &[("bench", params.as_entire_binding()), ("bench_hits", hits.as_entire_binding())]);
    let queries = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
        label: Some("bench_timestamps"),
        ty: wgpu::QueryType::Timestamp,
        count: 2,
    });
    let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("bench_resolve"),
        size: 16,
        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("bench_readback"),
        size: 16,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let (lo, hi) = bounds;
    let extent = (hi - lo).max(Vec3::splat(1e-3));
    let mut rng = Rng(0x5EED_1234_ABCD);
    let mut cells = Vec::new();
    for grid in GRIDS {
        let counts = Vec3::new(grid[0] as f32, grid[1] as f32, grid[2] as f32);
        let spacing = extent / counts;
        for rays_per_probe in RAYS {
            let ray_count = grid[0] * grid[1] * grid[2] * rays_per_probe;
            let mut times = Vec::new();
            for iteration in 0..iterations + 3 {
                let p = BenchParams {
                    rotation: Mat4::from_quat(rng.rotation()).to_cols_array_2d(),
                    grid_origin: (lo + spacing * 0.5).to_array(),
                    rays_per_probe,
                    grid_spacing: spacing.to_array(),
                    ray_count,
                    grid_counts: grid,
                    max_distance: 1e30,
                };
                gpu.queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
                let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bench_trace") });
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("trace"),
                        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                            query_set: &queries,
                            beginning_of_pass_write_index: Some(0),
                            end_of_pass_write_index: Some(1),
                        }),
                    });
                    pass.set_pipeline(&program.pipeline);
                    pass.set_bind_group(0, &group0, &[]);
                    pass.set_bind_group(1, &group1, &[]);
                    let (x, y) = ray_workgroups(ray_count);
                    pass.dispatch_workgroups(x, y, 1);
                }
                encoder.resolve_query_set(&queries, 0..2, &resolve, 0);
                encoder.copy_buffer_to_buffer(&resolve, 0, &readback, 0, 16);
                gpu.queue.submit([encoder.finish()]);
                readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
                gpu.wait_idle();
                let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&readback.slice(..).get_mapped_range().map_err(|e| e.to_string())?);
                readback.unmap();
                // The first dispatches warm caches and clocks.
                if iteration >= 3 {
                    times.push(ticks[1].saturating_sub(ticks[0]) as f64 * f64::from(gpu.timestamp_period) * 1e-6);
                }
            }
            times.sort_by(f64::total_cmp);
            let median_ms = times[times.len() / 2];
            cells.push(TraceCell { grid, rays_per_probe, rays: u64::from(ray_count), median_ms });
        }
    }
    Ok(cells)
}

/// CPU time of one frame's TLAS update (instance slots, refit or rebuild, uploads) when `count`
/// instances move, median over `frames` frames; `None` when the scene has fewer instances.
pub fn tlas_update_cost(app: &mut App, count: usize, frames: usize) -> Option<(Duration, Duration, bool)> {
    let world = app.world_mut();
    let mut query = world.query_filtered::<Entity, With<MeshInstance>>();
    let entities: Vec<Entity> = query.iter(world).collect();
    if entities.len() < count {
        return None;
    }
    let mut rng = Rng(0xC0FF_EE00 + count as u64);
    let mut times = Vec::new();
    let mut rebuilt = false;
    for _ in 0..frames {
        let world = app.world_mut();
        for &e in entities.iter().take(count) {
            if let Some(mut t) = world.get_mut::<Transform>(e) {
                // A small jiggle, as animated props move from frame to frame.
                t.translation += Vec3::new(rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5) * 0.02;
            }
        }
        app.update();
        let scene = app.world().resource::<GpuScene>();
        let rt = app.world().resource::<RayTracingScene>();
        rebuilt |= rt.stats.tlas_rebuilt;
        times.push((scene.instance_changes().cpu_time + rt.stats.cpu_time, rt.stats.cpu_time));
    }
    times.sort();
    let (total, tlas) = times[times.len() / 2];
    Some((total, tlas, rebuilt))
}

/// CPU time to build one flat CWBVH over every triangle of the scene in world space.
pub fn flat_rebuild_cost(app: &mut App) -> (Duration, usize) {
    let world = app.world();
    let meshes = world.resource::<Assets<Mesh>>();
    let scene = world.resource::<GpuScene>();
    let mut tris = Vec::new();
    for (_, mesh, transform) in scene.live_instances() {
        let Some(m) = meshes.get(engine::scene::Handle::from_index(mesh)) else { continue };
        for t in m.indices.chunks_exact(3) {
            let p = |i: u32| transform.transform_point3a(m.positions[i as usize].into());
            tris.push(obvhs::triangle::Triangle { v0: p(t[0]), v1: p(t[1]), v2: p(t[2]) });
        }
    }
    let started = Instant::now();
    let mut core = Duration::ZERO;
    let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, obvhs::BvhBuildParams::medium_build(), &mut core);
    std::hint::black_box(&bvh);
    (started.elapsed(), tris.len())
}

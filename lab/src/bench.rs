//! `game_demo bench trace`: closest-hit throughput of probe-like rays (GPU timestamps of the trace
//! pass alone) and the CPU cost of keeping the TLAS up to date when instances move.

use std::time::{Duration, Instant};

use engine::app::run_headless;
use engine::bevy_app::App;
use engine::bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::render::{GpuScene, RenderSize};
use engine::rng::SplitMix64;
use engine::rt::RayTracingScene;
use engine::scene::{Assets, Mesh, MeshInstance, SceneDescription, Transform};
use engine::shader::compute_program_with_constants;
use engine::wgpu;
use glam::{DVec3, Mat4, Quat, Vec3};

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
    /// Where this ray count's order starts in `bench_order`, or u32::MAX for the Fibonacci order.
    order_offset: u32,
    _pad: [u32; 3],
}

/// The order in which a probe's rays are given to threads: which spherical Fibonacci direction
/// thread k of a probe traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RayOrder {
    /// Thread k traces direction k: consecutive directions sit a golden angle apart, so a warp's
    /// 32 rays fan out over a band around the whole sphere.
    #[default]
    Fibonacci,
    /// Directions sorted along a Hilbert curve over their octahedral map: a warp's rays cover one
    /// compact patch of the sphere.
    Coherent,
}

/// How the bench kernel runs: the variants `bench trace` can compare.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceVariant {
    /// Which direction each thread of a probe traces.
    pub ray_order: RayOrder,
    /// Threads a workgroup.
    pub workgroup_size: u32,
    /// `Some(n)`: the persistent kernel, n workgroups each walking its share of the rays, a lane
    /// taking the next ray as soon as its own is done; `None`: a thread a ray.
    pub persistent_groups: Option<u32>,
    /// Where the traversal stack lives: 0, all of it in function memory (the engine's); K > 0, the
    /// top K entries of each thread's stack in workgroup memory, older ones moved to function
    /// memory (`RT_SHARED_STACK_ENTRIES` in `ray_tracing.inc.wgsl`).
    pub shared_stack_entries: u32,
    /// `Some(share)`: postponed triangle tests (Ylitie, Karras and Laine 2017): a thread tests the
    /// triangles a node hit only when at least `share` (0 to 1) of its subgroup's active threads
    /// want to test theirs, and otherwise walks its next nodes first. Needs subgroup operations
    /// ([`GpuContext::subgroups`]): the kernels of `bench_trace_subgroup.wgsl`. `None`: tests at once.
    pub postpone_triangles: Option<f32>,
    /// Dynamic fetch in the persistent kernel (Aila and Laine 2009): the threads of a subgroup whose
    /// rays ended in the same step take their next rays with one atomic add on the workgroup's
    /// counter, not one each. Needs subgroup operations, like `postpone_triangles`.
    pub subgroup_fetch: bool,
    /// `Some(scope)`: packet traversal, a thread a ray: the rays of a subgroup or of a workgroup
    /// walk as one, every node any of them hits visited by all, in their lead ray's octant order
    /// (`bench_packet_main` in `bench_trace.inc.wgsl`). Not with the persistent kernel, postponed
    /// tests or a shared stack.
    pub packet: Option<PacketScope>,
}

/// The largest workgroup packet ([`PacketScope::Workgroup`]): on lavapipe, packets of 256 threads
/// or more left every ray of the crowd test scene but the first subgroup's unwritten (packets of
/// up to 128 threads, and subgroup packets in workgroups of up to 1,024, found every hit; not
/// understood, so refused rather than trusted).
pub const MAX_WORKGROUP_PACKET: u32 = 128;

/// Which threads walk as one packet ([`TraceVariant::packet`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketScope {
    /// A subgroup (a warp of 32 on NVIDIA): hit masks united with `subgroupOr`. Needs subgroup
    /// operations.
    Subgroup,
    /// The workgroup ([`TraceVariant::workgroup_size`] threads): hit masks united in workgroup
    /// memory by one thread, slowly. For counting the walk of packets of a given size on any device.
    Workgroup,
}

impl TraceVariant {
    /// Whether the variant's kernel uses subgroup operations (`bench_trace_subgroup.wgsl`).
    pub fn uses_subgroups(&self) -> bool {
        self.postpone_triangles.is_some() || self.subgroup_fetch || self.packet == Some(PacketScope::Subgroup)
    }
}

impl Default for TraceVariant {
    fn default() -> Self {
        Self {
            ray_order: RayOrder::Fibonacci,
            workgroup_size: 64,
            persistent_groups: None,
            shared_stack_entries: 0,
            postpone_triangles: None,
            subgroup_fetch: false,
            packet: None,
        }
    }
}

/// Entries of the traversal stack (`RT_STACK_SIZE` in `ray_tracing.inc.wgsl`): the most a shared
/// stack can hold.
pub const RT_STACK_SIZE: u32 = 48;

/// Bytes of workgroup memory the bench kernel uses besides the shared stack: `bench_steps` (1,024
/// words) and `bench_next` (one); workgroup packets add their masks (a word a thread, and one).
const BENCH_WORKGROUP_BYTES: u32 = 1024 * 4 + 4;

/// Words of `bench_work` (see `bench_trace.inc.wgsl`).
const BENCH_WORK_WORDS: usize = 10;

/// Direction i of n spherical Fibonacci points (the bench shader's formula).
fn spherical_fibonacci(i: u32, n: u32) -> Vec3 {
    const GOLDEN_ANGLE: f32 = 2.399_963_3;
    let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = i as f32 * GOLDEN_ANGLE;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Threads that run in lockstep on the GPUs we tune for (an NVIDIA warp).
const WARP: usize = 32;

/// The spherical Fibonacci indices of `n` directions in coherent order: split recursively at a
/// multiple of a warp along the axis over which the directions spread most, so that every warp's
/// rays cover one compact patch of the sphere (an octant for 256 rays).
pub fn coherent_ray_order(n: u32) -> Vec<u32> {
    fn split(ids: &mut [u32], n: u32) {
        if ids.len() <= WARP {
            return;
        }
        let dirs = |ids: &[u32]| ids.iter().map(|&i| spherical_fibonacci(i, n)).collect::<Vec<_>>();
        let d = dirs(ids);
        let lo = d.iter().fold(Vec3::splat(f32::MAX), |a, &b| a.min(b));
        let hi = d.iter().fold(Vec3::splat(f32::MIN), |a, &b| a.max(b));
        let axis = (hi - lo).max_position();
        ids.sort_by(|&a, &b| spherical_fibonacci(a, n)[axis].total_cmp(&spherical_fibonacci(b, n)[axis]));
        let left = ids.len().div_ceil(2 * WARP) * WARP;
        let (a, b) = ids.split_at_mut(left.min(ids.len()));
        split(a, n);
        split(b, n);
    }
    let mut order: Vec<u32> = (0..n).collect();
    split(&mut order, n);
    order
}

/// A random rotation (axis and angle uniform), for the per-dispatch rotation of the ray directions.
fn random_rotation(rng: &mut SplitMix64) -> Quat {
    Quat::from_axis_angle(rng.direction(), rng.unit() * std::f32::consts::TAU)
}

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

/// A headless app with the scene prepared (BLASes built, TLAS uploaded).
pub fn prepared_app(gpu: &GpuContext, scene: SceneDescription) -> App {
    prepared_app_with(gpu, scene, engine::rt::BlasBuildQuality::default())
}

/// [`prepared_app`] with BLASes built at `quality`.
pub fn prepared_app_with(gpu: &GpuContext, scene: SceneDescription, quality: engine::rt::BlasBuildQuality) -> App {
    let mut app = engine::headless::headless_app(gpu, RenderSize { width: 8, height: 8 }, 1.0 / 60.0);
    app.insert_resource(quality);
    crate::progress::show_blas_builds(&mut app);
    scene.spawn(app.world_mut());
    run_headless(&mut app, 1);
    app
}

/// The bench's WGSL (`lab/shaders/`): kernels that trace probe-like rays and nothing else, for any
/// device (`bench_trace.wgsl`) and with subgroup operations (`bench_trace_subgroup.wgsl`).
pub const SHADERS: &[engine::shader::ShaderModule] = &[
    ("bench_trace.inc.wgsl", include_str!("../shaders/bench_trace.inc.wgsl")),
    ("bench_trace.wgsl", include_str!("../shaders/bench_trace.wgsl")),
    ("bench_trace_subgroup.wgsl", include_str!("../shaders/bench_trace_subgroup.wgsl")),
];

/// What a bench kernel is built for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum KernelUse {
    /// Timing: the hit distances only.
    Time,
    /// The RT_COUNT_WORK variant: traversal work counted (by the thread-a-ray kernel only).
    CountWork,
    /// The hits' instances and triangles written too (BENCH_HIT_IDS), for tests.
    HitIds,
}

/// The bench kernel's module, entry point and `override` values for `variant`, compiled with the
/// traversal's alpha test when the scene has alpha-masked materials (`alpha_test`), as DDGI's
/// passes are.
fn kernel_pipeline(variant: TraceVariant, usage: KernelUse, alpha_test: bool) -> (&'static str, &'static str, Vec<(&'static str, f64)>) {
    let count_work = usage == KernelUse::CountWork;
    let mut constants = vec![("BENCH_GROUP", f64::from(variant.workgroup_size)), ("SCENE_HAS_ALPHA_TEST", f64::from(u8::from(alpha_test)))];
    if count_work {
        constants.push(("RT_COUNT_WORK", 1.0));
    }
    if usage == KernelUse::HitIds {
        constants.push(("BENCH_HIT_IDS", 1.0));
    }
    if let Some(share) = variant.postpone_triangles {
        constants.push(("BENCH_POSTPONE_SHARE", f64::from(share)));
    }
    let persistent_groups = variant.persistent_groups.filter(|_| !count_work);
    if let Some(n) = persistent_groups {
        constants.push(("BENCH_PERSISTENT_GROUPS", f64::from(n)));
        if variant.subgroup_fetch {
            constants.push(("BENCH_SUBGROUP_FETCH", 1.0));
        }
    }
    if variant.shared_stack_entries > 0 {
        constants.push(("RT_SHARED_STACK_ENTRIES", f64::from(variant.shared_stack_entries)));
        constants.push(("RT_SHARED_STACK_LANES", f64::from(variant.workgroup_size)));
    }
    let file = if variant.uses_subgroups() { "bench_trace_subgroup.wgsl" } else { "bench_trace.wgsl" };
    let entry = match (persistent_groups, variant.packet) {
        (Some(_), _) => "persistent",
        (None, Some(_)) => "packet",
        (None, None) => "main",
    };
    (file, entry, constants)
}

/// The bench kernel with its buffers, built for `usage` ([`KernelUse`]).
struct TraceKernel {
    program: engine::shader::Program<wgpu::ComputePipeline>,
    hits: wgpu::Buffer,
    /// Each ray's hit instance and triangle ([`KernelUse::HitIds`]; one unused entry otherwise).
    hit_ids: wgpu::Buffer,
    groups: [wgpu::BindGroup; 2],
    /// Where each ray count's coherent order starts in `bench_order`.
    order_offsets: Vec<(u32, u32)>,
    ray_order: RayOrder,
    workgroup_size: u32,
    persistent_groups: Option<u32>,
    params: wgpu::Buffer,
    work: wgpu::Buffer,
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
}

impl TraceKernel {
    fn new(gpu: &GpuContext, app: &App, usage: KernelUse, variant: TraceVariant) -> Result<Self, String> {
        let count_work = usage == KernelUse::CountWork;
        let TraceVariant {
            ray_order,
            workgroup_size,
            persistent_groups,
            shared_stack_entries,
            postpone_triangles,
            subgroup_fetch: _,
            packet,
        } = variant;
        if packet.is_some() && (persistent_groups.is_some() || shared_stack_entries > 0 || postpone_triangles.is_some()) {
            return Err(format!(
                "{variant:?}: packet traversal runs a thread a ray, with the stack in function memory and triangle tests at once"
            ));
        }
        if packet == Some(PacketScope::Workgroup) && workgroup_size > MAX_WORKGROUP_PACKET {
            return Err(format!("workgroup packets of {workgroup_size} threads: at most {MAX_WORKGROUP_PACKET}"));
        }
        if let Some(share) = postpone_triangles
            && !(share > 0.0 && share <= 1.0)
        {
            return Err(format!("postponed triangle tests at a share of {share} of the lanes: more than 0, at most 1"));
        }
        if variant.uses_subgroups() && !gpu.subgroups {
            let why = if gpu.adapter.features().contains(wgpu::Features::SUBGROUP) {
                "the context did not ask for them (GpuOptions::subgroups)".to_string()
            } else {
                format!("{} does not offer them", gpu.adapter_name())
            };
            return Err(format!("{variant:?} needs subgroup operations (wgpu::Features::SUBGROUP): {why}"));
        }
        // Work is counted by the thread-a-ray kernel only.
        let persistent_groups = persistent_groups.filter(|_| !count_work);
        if persistent_groups.is_some_and(|n| n == 0 || n > 65535) {
            return Err(format!("{persistent_groups:?} persistent workgroups: 1 to 65,535"));
        }
        let limit = gpu.device.limits().max_compute_invocations_per_workgroup.min(gpu.device.limits().max_compute_workgroup_size_x);
        // bench_steps in the shader holds 1,024 threads.
        let limit = limit.min(1024);
        if workgroup_size == 0 || workgroup_size > limit {
            return Err(format!("workgroup size {workgroup_size}: {} allows 1 to {limit}", gpu.adapter_name()));
        }
        if shared_stack_entries > RT_STACK_SIZE {
            return Err(format!("shared stack of {shared_stack_entries} entries: 0 to {RT_STACK_SIZE} (the whole stack)"));
        }
        let packet_bytes = if packet == Some(PacketScope::Workgroup) { workgroup_size * 4 + 4 } else { 0 };
        let bytes = shared_stack_entries * workgroup_size * 8 + BENCH_WORKGROUP_BYTES + packet_bytes;
        let available = gpu.device.limits().max_compute_workgroup_storage_size;
        if bytes > available {
            return Err(format!(
                "shared stack of {shared_stack_entries} entries × {workgroup_size} threads: {bytes} bytes of workgroup memory, {} allows {available}",
                gpu.adapter_name()
            ));
        }
        let alpha_test = app.world().resource::<GpuScene>().has_alpha_test;
        let (file, entry, constants) = kernel_pipeline(variant, usage, alpha_test);
        let constants = constants.as_slice();
        let program = engine::shader::register(SHADERS)
            .and_then(|()| compute_program_with_constants(&gpu.device, file, entry, "trace", constants))
            .map_err(|e| e.to_string())?;
        let scene = app.world().resource::<GpuScene>();
        let rt = app.world().resource::<RayTracingScene>();
        let max_rays = GRIDS.iter().map(|g| g[0] * g[1] * g[2]).max().unwrap_or(1) * RAYS.iter().max().unwrap_or(&1);
        let buffer = |label, size, usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        use wgpu::BufferUsages as U;
        let hits = buffer("bench_hits", u64::from(max_rays) * 4, U::STORAGE | U::COPY_SRC);
        let id_entries = if usage == KernelUse::HitIds { u64::from(max_rays) } else { 1 };
        let hit_ids = buffer("bench_hit_ids", id_entries * 8, U::STORAGE | U::COPY_SRC);
        let params = buffer("bench_params", size_of::<BenchParams>() as u64, U::UNIFORM | U::COPY_DST);
        let work = buffer("bench_work", (BENCH_WORK_WORDS * 4) as u64, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        let (mut orders, mut order_offsets) = (Vec::new(), Vec::new());
        for n in RAYS {
            order_offsets.push((n, orders.len() as u32));
            orders.extend(coherent_ray_order(n));
        }
        let order = buffer("bench_order", (orders.len() * 4) as u64, U::STORAGE | U::COPY_DST);
        gpu.queue.write_buffer(&order, 0, bytemuck::cast_slice(&orders));
        let groups = [
            program.bind_group(&gpu.device, 0, &rt.scene_bindings(scene)),
            program.bind_group(
                &gpu.device,
                1,
                &[
                    ("bench", params.as_entire_binding()),
                    ("bench_hits", hits.as_entire_binding()),
                    ("bench_work", work.as_entire_binding()),
                    ("bench_order", order.as_entire_binding()),
                    ("bench_hit_ids", hit_ids.as_entire_binding()),
                ],
            ),
        ];
        Ok(Self {
            program,
            hits,
            hit_ids,
            groups,
            order_offsets,
            ray_order,
            workgroup_size,
            persistent_groups,
            params,
            work,
            queries: gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("bench_timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            }),
            resolve: buffer("bench_resolve", 16, U::QUERY_RESOLVE | U::COPY_SRC),
        })
    }

    /// One dispatch; returns its GPU milliseconds.
    fn run(&self, gpu: &GpuContext, p: &BenchParams) -> Result<f64, String> {
        let mut p = *p;
        p.order_offset = match self.ray_order {
            RayOrder::Fibonacci => u32::MAX,
            RayOrder::Coherent => self.order_offsets.iter().find(|(n, _)| *n == p.rays_per_probe).map_or(u32::MAX, |&(_, offset)| offset),
        };
        gpu.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&p));
        gpu.queue.write_buffer(&self.work, 0, &[0; BENCH_WORK_WORDS * 4]);
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bench_trace") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("trace"),
                timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                    query_set: &self.queries,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(&self.program.pipeline);
            pass.set_bind_group(0, &self.groups[0], &[]);
            pass.set_bind_group(1, &self.groups[1], &[]);
            match self.persistent_groups {
                Some(n) => pass.dispatch_workgroups(n, 1, 1),
                None => {
                    let groups = p.ray_count.div_ceil(self.workgroup_size).max(1);
                    pass.dispatch_workgroups(groups.min(65535), groups.div_ceil(65535), 1);
                }
            }
        }
        encoder.resolve_query_set(&self.queries, 0..2, &self.resolve, 0);
        gpu.queue.submit([encoder.finish()]);
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &self.resolve));
        Ok(ticks[1].saturating_sub(ticks[0]) as f64 * f64::from(gpu.timestamp_period) * 1e-6)
    }

    /// Work counted by the last dispatch (diagnostic variant only).
    fn work(&self, gpu: &GpuContext) -> Result<[u32; BENCH_WORK_WORDS], String> {
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &self.work));
        w.try_into().map_err(|w: Vec<u32>| format!("bench_work: {} words read back, {BENCH_WORK_WORDS} expected", w.len()))
    }
}

/// The world-space bounds of a scene's geometry, its placement ([`SceneDescription::origin`])
/// included: where the bench spreads its probes.
pub fn world_bounds(scene: &SceneDescription) -> Option<(DVec3, DVec3)> {
    scene.bounds().map(|(lo, hi)| (scene.origin + lo.as_dvec3(), scene.origin + hi.as_dvec3()))
}

/// World-space bounds in the render space the TLAS is built in: the render origin follows the
/// scene's camera (the forest's stands 95 m from the world's origin, beyond the rebase distance).
fn render_space(app: &App, (lo, hi): (DVec3, DVec3)) -> (Vec3, Vec3) {
    let origin = app.world().get_resource::<engine::scene::RenderOrigin>().copied().unwrap_or_default();
    (origin.to_render(lo), origin.to_render(hi))
}

fn params_for(rng: &mut SplitMix64, bounds: (Vec3, Vec3), grid: [u32; 3], rays_per_probe: u32) -> BenchParams {
    let (lo, hi) = bounds;
    let extent = (hi - lo).max(Vec3::splat(1e-3));
    let spacing = extent / Vec3::new(grid[0] as f32, grid[1] as f32, grid[2] as f32);
    BenchParams {
        rotation: Mat4::from_quat(random_rotation(rng)).to_cols_array_2d(),
        grid_origin: (lo + spacing * 0.5).to_array(),
        rays_per_probe,
        grid_spacing: spacing.to_array(),
        ray_count: grid[0] * grid[1] * grid[2] * rays_per_probe,
        grid_counts: grid,
        max_distance: 1e30,
        order_offset: u32::MAX,
        _pad: [0; 3],
    }
}

/// Times the trace pass for every grid × rays cell: `iterations` timed dispatches after warm-up, median.
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

/// A TLAS build timed by [`tlas_build`].
pub struct TlasBuild {
    /// The re-braiding budget it was built with.
    pub budget: f32,
    /// How static instances were grouped, and how many groups formed (with the instances they hold).
    pub static_grouping: engine::rt::StaticGrouping,
    pub groups: usize,
    pub grouped_instances: usize,
    /// TLAS primitives (instances, and BLAS nodes opened by re-braiding).
    pub primitives: usize,
    /// Live instances.
    pub instances: usize,
    /// CPU time of the frame's BVH work: the TLAS build and its upload.
    pub time: Duration,
}

/// Rebuilds the TLAS with re-braiding budget `budget` (`None`: the one it has) and static groups on
/// grouped as `grouping` says (`None`: as they are), and times it (static groups formed included).
pub fn tlas_build(app: &mut App, budget: Option<f32>, grouping: Option<engine::rt::StaticGrouping>) -> TlasBuild {
    let mut rt = app.world_mut().resource_mut::<RayTracingScene>();
    let budget = budget.unwrap_or(rt.rebraid_budget());
    rt.set_rebraid_budget(budget);
    let grouping = grouping.unwrap_or(rt.static_grouping());
    rt.set_static_grouping(grouping);
    app.update();
    let rt = app.world().resource::<RayTracingScene>();
    TlasBuild {
        budget: rt.rebraid_budget(),
        static_grouping: rt.static_grouping(),
        groups: rt.static_group_count(),
        grouped_instances: rt.grouped_instance_count(),
        primitives: rt.tlas_primitive_count(),
        instances: app.world().resource::<GpuScene>().live_instances().len(),
        time: rt.stats.cpu_time,
    }
}

/// CPU cost of one frame's TLAS update when some instances move: medians over the frames of each way.
pub struct TlasUpdateCost {
    /// Instance slots, TLAS refit or rebuild, uploads, with the refit on the CPU
    /// ([`engine::rt::TlasRefit::Cpu`]) as the engine does it there by default (in parallel from
    /// [`engine::rt::default_parallel_refit_from`] movers on).
    pub total: Duration,
    /// Of which the TLAS refit or rebuild and its upload.
    pub tlas: Duration,
    /// The TLAS refit or rebuild and its upload with the refit kept on the frame's thread.
    pub tlas_one_thread: Duration,
    /// Of the one-thread refit frames, the medians of each step: the binary TLAS's refit, the wide
    /// nodes' re-encoding and the staging of their upload ([`engine::rt::BvhFrameStats`]).
    pub one_thread_steps: [Duration; 3],
    /// Whether any of the frames rebuilt the TLAS.
    pub rebuilt: bool,
}

/// CPU time of one frame's TLAS update (instance slots, refit or rebuild, uploads) when `count`
/// instances move, with the refit on the CPU: median over `frames` frames its default way and
/// `frames` frames on one thread, alternated; `None` when the scene has fewer instances. The refit
/// goes back to the engine's default ([`engine::rt::TlasRefit`]) afterwards.
pub fn tlas_update_cost(app: &mut App, count: usize, frames: usize) -> Option<TlasUpdateCost> {
    let world = app.world_mut();
    let mut query = world.query_filtered::<Entity, With<MeshInstance>>();
    let entities: Vec<Entity> = query.iter(world).collect();
    if entities.len() < count {
        return None;
    }
    world.resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Cpu;
    let mut rng = SplitMix64::new(0xC0FF_EE00 + count as u64);
    let (mut times, mut one_thread) = (Vec::new(), Vec::new());
    let mut steps: [Vec<Duration>; 3] = Default::default();
    let mut rebuilt = false;
    // One untimed frame first: an instance that re-braiding opened is rebuilt at its root the first
    // time it moves (once; from then on it is refitted as one leaf).
    for frame in 0..2 * frames + 1 {
        let warm_up = frame == 0;
        let frame = frame.saturating_sub(1);
        let default = frame % 2 == 0;
        let world = app.world_mut();
        world.resource_mut::<RayTracingScene>().parallel_refit_from =
            if default { engine::rt::default_parallel_refit_from() } else { usize::MAX };
        for &e in entities.iter().take(count) {
            if let Some(mut t) = world.get_mut::<Transform>(e) {
                // A small jiggle, as animated props move from frame to frame.
                t.translation += Vec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * 0.02;
            }
        }
        app.update();
        if warm_up {
            continue;
        }
        let scene = app.world().resource::<GpuScene>();
        let rt = app.world().resource::<RayTracingScene>();
        rebuilt |= rt.stats.tlas_rebuilt;
        if default {
            times.push((scene.instance_changes().cpu_time + rt.stats.cpu_time, rt.stats.cpu_time));
        } else {
            one_thread.push(rt.stats.cpu_time);
            let st = &rt.stats;
            for (step, time) in steps.iter_mut().zip([st.tlas_refit_time, st.tlas_encode_time, st.tlas_upload_time]) {
                step.push(time);
            }
        }
    }
    let mut rt = app.world_mut().resource_mut::<RayTracingScene>();
    rt.parallel_refit_from = engine::rt::default_parallel_refit_from();
    rt.tlas_refit = engine::rt::TlasRefit::default();
    times.sort();
    one_thread.sort();
    let (total, tlas) = times[times.len() / 2];
    let one_thread_steps = steps.map(|mut v| {
        v.sort();
        v[v.len() / 2]
    });
    Some(TlasUpdateCost { total, tlas, tlas_one_thread: one_thread[one_thread.len() / 2], one_thread_steps, rebuilt })
}

/// CPU cost of one frame's TLAS update with the refit on the GPU ([`engine::rt::TlasRefit::Gpu`]),
/// and the refit's GPU time.
pub struct TlasGpuRefitCost {
    /// Median CPU time of the frames' instance updates and TLAS work (as [`TlasUpdateCost::total`]),
    /// and the slowest frame's.
    pub total: Duration,
    pub total_slowest: Duration,
    /// Median CPU time of the frames' TLAS work (the moved leaves' world boxes, their staging and the
    /// dispatches' recording).
    pub tlas: Duration,
    /// The slowest frame's.
    pub tlas_slowest: Duration,
    /// Medians of its steps: the moved leaves' world boxes with the reading of the GPU's SAH cost,
    /// and their staging with the dispatches' recording ([`engine::rt::BvhFrameStats`]).
    pub steps: [Duration; 2],
    /// Median GPU time of the refit's four dispatches (`None` without timestamp queries, or not asked).
    pub gpu: Option<Duration>,
    /// Whether any of the frames rebuilt the TLAS.
    pub rebuilt: bool,
}

/// [`tlas_update_cost`]'s frames with the refit on the GPU: `frames` frames (after one untimed, which
/// uploads the binary TLAS to the GPU once) in which `count` instances move; with `gpu_iterations`
/// above 0, the last refit's dispatches are then timed that many times (GPU timestamps). The refit
/// goes back to the engine's default afterwards, with the CPU's copy of the TLAS brought up to date. `None` when the scene has fewer instances.
pub fn tlas_gpu_refit_cost(app: &mut App, count: usize, frames: usize, gpu_iterations: u32) -> Option<TlasGpuRefitCost> {
    let world = app.world_mut();
    let mut query = world.query_filtered::<Entity, With<MeshInstance>>();
    let entities: Vec<Entity> = query.iter(world).collect();
    if entities.len() < count {
        return None;
    }
    world.resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Gpu;
    let mut rng = SplitMix64::new(0x6B0F_17E0 + count as u64);
    let mut times = Vec::new();
    let mut totals = Vec::new();
    let mut steps: [Vec<Duration>; 2] = Default::default();
    let mut rebuilt = false;
    for frame in 0..=frames {
        let world = app.world_mut();
        for &e in entities.iter().take(count) {
            if let Some(mut t) = world.get_mut::<Transform>(e) {
                t.translation += Vec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * 0.02;
            }
        }
        app.update();
        let rt = app.world().resource::<RayTracingScene>();
        if frame > 0 {
            rebuilt |= rt.stats.tlas_rebuilt;
            times.push(rt.stats.cpu_time);
            totals.push(app.world().resource::<GpuScene>().instance_changes().cpu_time + rt.stats.cpu_time);
            steps[0].push(rt.stats.tlas_refit_time);
            steps[1].push(rt.stats.tlas_upload_time);
        }
    }
    let gpu = app.world().resource::<GpuContext>();
    let rt = app.world().resource::<RayTracingScene>();
    let mut gpu_times: Vec<Duration> = (0..gpu_iterations).filter_map(|_| rt.time_gpu_refit(gpu)).collect();
    gpu_times.sort();
    let mut rt = app.world_mut().resource_mut::<RayTracingScene>();
    rt.tlas_refit = engine::rt::TlasRefit::default();
    rt.sync_cpu_tlas();
    times.sort();
    totals.sort();
    Some(TlasGpuRefitCost {
        total: totals[totals.len() / 2],
        total_slowest: *totals.last()?,
        tlas: times[times.len() / 2],
        tlas_slowest: *times.last()?,
        steps: steps.map(|mut v| {
            v.sort();
            v[v.len() / 2]
        }),
        gpu: gpu_times.get(gpu_times.len() / 2).copied(),
        rebuilt,
    })
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
    let quality = world.get_resource::<engine::rt::BlasBuildQuality>().copied().unwrap_or_default();
    let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, quality.params(), &mut core);
    std::hint::black_box(&bvh);
    (started.elapsed(), tris.len())
}

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

fn median(mut v: Vec<f64>) -> f64 {
    crate::median(&mut v).unwrap_or(f64::NAN)
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

/// Classification against an independent test, after DDGI (adaptive budgets on) has run: which
/// probes sit inside solid geometry, and which probes a visible surface depends on.
#[derive(Debug)]
pub struct ClassificationCheck {
    pub probes: usize,
    /// Probes whose position sees back faces in at least 90% of 64 directions and escapes in none.
    pub inside: usize,
    pub inside_off: usize,
    /// Probes, not inside, of the cage around a surface point that a camera ray hits and that
    /// they see unoccluded.
    pub needed: usize,
    pub needed_off: usize,
    /// Of those, the ones that saw light (luma above the dark threshold): switched off for
    /// another reason than darkness.
    pub needed_off_lit: usize,
    /// Each needed probe switched off, for a diagnosis: (index, grid coordinates, relocation
    /// offset in cells, share of the checker's 64 rays that hit back faces, the probe's luma, its
    /// rays in a row that found no surface in its region).
    pub needed_off_probes: Vec<(usize, glam::UVec3, Vec3, f32, f32, u32)>,
}

/// Runs `frames` frames of DDGI on `scene` with a `grid` of probes (the scene's bounds, adaptive
/// budgets on), then checks every probe's state with rays traced on the GPU: 64 spherical Fibonacci
/// rays from each probe's position (inside: ≥ 90% back faces, no miss), and for each of 64 × 64
/// camera rays, a visibility ray from each probe of the cage around its hit point.
pub fn classification_check(gpu: &GpuContext, scene: SceneDescription, grid: [u32; 3], frames: u32) -> Result<ClassificationCheck, String> {
    use engine::rt::cpu::GpuRay;
    let volume = ddgi::DdgiVolume { probe_counts: Some(grid.into()), adaptive: ddgi::DdgiAdaptive::on(), ..Default::default() };
    let mut app = engine::headless::headless_app(gpu, RenderSize { width: 64, height: 64 }, 1.0 / 60.0);
    crate::progress::show_blas_builds(&mut app);
    ddgi::use_ddgi(&mut app, volume, ddgi::DdgiOutput::Full);
    scene.spawn(app.world_mut());
    run_headless(&mut app, frames.max(1));
    let world = app.world();
    let volumes = world.resource::<ddgi::DdgiGpuVolumes>();
    let Some((_, v)) = volumes.volumes.first() else {
        return Err(volumes.first_error().unwrap_or("no DDGI volume").to_string());
    };
    let data: Vec<ddgi::gpu::DdgiProbeData> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &v.probes));
    let layout = v.layout.clone();
    let n = layout.probe_count as usize;
    let position = |i: usize| layout.grid_position(i as u32) + Vec3::from_array(data[i].offset);
    let off = |i: usize| data[i].state & ddgi::gpu::PROBE_INACTIVE != 0;
    let brightest = data.iter().map(|d| d.luma).fold(0.0f32, f32::max);
    let dark = |i: usize| data[i].luma < v.settings.adaptive.dark_fraction * brightest;
    let (gpu_scene, rt) = (world.resource::<GpuScene>(), world.resource::<RayTracingScene>());
    let tracer = engine::rt::RayTracer::new(gpu).map_err(|e| e.to_string())?;
    let directions = engine::rt::cpu::fibonacci_directions(64);
    let rays: Vec<GpuRay> = (0..n)
        .flat_map(|i| {
            let origin = position(i).to_array();
            directions.iter().map(move |d| GpuRay { origin, tmin: 0.0, direction: d.to_array(), tmax: 1e30 })
        })
        .collect();
    let hits = tracer.trace(gpu, gpu_scene, rt, &rays, false);
    let backface_share: Vec<f32> =
        hits.chunks_exact(64).map(|h| h.iter().filter(|r| r.instance != u32::MAX && r.flags & 1 == 0).count() as f32 / 64.0).collect();
    let inside: Vec<bool> = hits
        .chunks_exact(64)
        .map(|h| {
            let misses = h.iter().filter(|r| r.instance == u32::MAX).count();
            let back = h.iter().filter(|r| r.instance != u32::MAX && r.flags & 1 == 0).count();
            misses == 0 && back * 10 >= 9 * 64
        })
        .collect();
    // Camera rays through a 64 × 64 grid of the view.
    let view = gpu_scene.view_uniform;
    let world_from_clip = Mat4::from_cols_array_2d(&view.world_from_clip);
    let eye = Vec3::from_array(view.camera_position);
    let camera_rays: Vec<GpuRay> = (0..64 * 64)
        .map(|k| {
            let ndc = glam::Vec2::new((k % 64) as f32 + 0.5, (k / 64) as f32 + 0.5) / 64.0 * 2.0 - 1.0;
            let near = world_from_clip.project_point3(Vec3::new(ndc.x, -ndc.y, 1.0));
            GpuRay { origin: eye.to_array(), tmin: 0.0, direction: (near - eye).normalize_or(Vec3::Z).to_array(), tmax: 1e30 }
        })
        .collect();
    let mut cage_rays = Vec::new();
    let mut cage_probes = Vec::new();
    for (ray, hit) in camera_rays.iter().zip(tracer.trace(gpu, gpu_scene, rt, &camera_rays, false)) {
        if hit.instance == u32::MAX {
            continue;
        }
        let p = Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * hit.t;
        let g = ((p - layout.origin) / layout.spacing).floor().as_ivec3();
        let base = g.clamp(glam::IVec3::ZERO, (layout.counts.as_ivec3() - 2).max(glam::IVec3::ZERO));
        for corner in 0..8 {
            let c =
                (base + glam::IVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1)).min(layout.counts.as_ivec3() - 1).as_uvec3();
            let i = (c.x + layout.counts.x * (c.y + layout.counts.y * c.z)) as usize;
            if inside[i] {
                continue;
            }
            let from = position(i);
            let to = p - Vec3::from_array(ray.direction) * 1e-3 * hit.t;
            let d = to - from;
            cage_rays.push(GpuRay { origin: from.to_array(), tmin: 0.0, direction: d.to_array(), tmax: 0.999 });
            cage_probes.push(i);
        }
    }
    let mut needed = vec![false; n];
    for (i, r) in cage_probes.iter().zip(tracer.trace(gpu, gpu_scene, rt, &cage_rays, true)) {
        if r.any_hit == 0 {
            needed[*i] = true;
        }
    }
    Ok(ClassificationCheck {
        probes: n,
        inside: inside.iter().filter(|&&x| x).count(),
        inside_off: (0..n).filter(|&i| inside[i] && off(i)).count(),
        needed: needed.iter().filter(|&&x| x).count(),
        needed_off: (0..n).filter(|&i| needed[i] && off(i)).count(),
        needed_off_lit: (0..n).filter(|&i| needed[i] && off(i) && !dark(i)).count(),
        needed_off_probes: (0..n)
            .filter(|&i| needed[i] && off(i))
            .map(|i| {
                let offset = Vec3::from_array(data[i].offset) / layout.spacing;
                (i, layout.probe_grid(i as u32), offset, backface_share[i], data[i].luma, data[i].empty_rays)
            })
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_coherent_order_is_a_permutation_whose_warps_cover_compact_patches() {
        for n in [32, 64, 128, 256, 1024] {
            let order = coherent_ray_order(n);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>(), "{n} rays");
            // The widest angle between a warp's rays and their mean direction, over the warps.
            let spread = |ids: &[u32]| {
                let mean = ids.iter().map(|&i| spherical_fibonacci(i, n)).sum::<Vec3>().normalize_or_zero();
                ids.iter().map(|&i| spherical_fibonacci(i, n).dot(mean)).fold(1.0f32, f32::min)
            };
            let fibonacci: Vec<u32> = (0..n).collect();
            let worst = |ids: &[u32]| ids.chunks(32).map(spread).fold(1.0f32, f32::min);
            // Up to 64 directions a warp is half the sphere or all of it whatever the order.
            if n <= 64 {
                continue;
            }
            // From 4 warps a probe on, a coherent warp stays within a cone (the cosine to its
            // widest ray over 0.2); the Fibonacci order's warps span bands around the sphere.
            println!("{n} rays: widest ray of a warp at cosine {} (Fibonacci order {})", worst(&order), worst(&fibonacci));
            assert!(n < 256 || worst(&order) > 0.5, "{n} rays: coherent warps spread to cosine {}", worst(&order));
            assert!(worst(&order) > worst(&fibonacci) + 0.15, "{n} rays");
        }
    }

    /// naga resolves and validates every variant of the bench kernel that `bench trace` can build:
    /// the three kernels, counting work or not, each stack, several workgroup sizes, triangle tests at
    /// once or postponed, packets of a subgroup or a workgroup (the subgroup module, validated as on a device with subgroups; the other
    /// as on any device).
    #[test]
    fn every_bench_kernel_variant_validates() {
        use engine::naga::valid::Capabilities;
        engine::shader::register(SHADERS).expect("register");
        let plain = engine::shader::parse("bench_trace.wgsl").unwrap_or_else(|e| panic!("{e}"));
        let subgroup = engine::shader::parse_with("bench_trace_subgroup.wgsl", Capabilities::default() | Capabilities::SUBGROUP)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut entries = std::collections::BTreeSet::new();
        for persistent_groups in [None, Some(4224)] {
            for workgroup_size in [32, 64, 128, 256] {
                for shared_stack_entries in [0, 1, 8, 16, RT_STACK_SIZE] {
                    for (postpone_triangles, subgroup_fetch) in
                        [(None, false), (Some(0.2), false), (Some(1.0), false), (None, true), (Some(0.2), true)]
                    {
                        for usage in [KernelUse::Time, KernelUse::CountWork, KernelUse::HitIds] {
                            let variant = TraceVariant {
                                workgroup_size,
                                persistent_groups,
                                shared_stack_entries,
                                postpone_triangles,
                                subgroup_fetch,
                                ..Default::default()
                            };
                            let (file, entry, constants) = kernel_pipeline(variant, usage, true);
                            entries.insert((file, entry));
                            let parsed = if file == subgroup.name { &subgroup } else { &plain };
                            assert_eq!(file, parsed.name);
                            parsed.validate_compute_variant(entry, &constants).unwrap_or_else(|e| panic!("{e}"));
                        }
                    }
                }
            }
        }
        // The packet kernel: a thread a ray, tests at once, the engine's stack.
        for packet in [PacketScope::Subgroup, PacketScope::Workgroup] {
            for workgroup_size in [32, 64, 128, 256] {
                for usage in [KernelUse::Time, KernelUse::CountWork, KernelUse::HitIds] {
                    let variant = TraceVariant { workgroup_size, packet: Some(packet), ..Default::default() };
                    let (file, entry, constants) = kernel_pipeline(variant, usage, true);
                    entries.insert((file, entry));
                    let parsed = if file == subgroup.name { &subgroup } else { &plain };
                    parsed.validate_compute_variant(entry, &constants).unwrap_or_else(|e| panic!("{e}"));
                }
            }
        }
        assert_eq!(entries.len(), 6, "the three kernels of both modules: {entries:?}");
        // The check refuses what wgpu would: a value for an override the shader does not have.
        let misspelt = [("BENCH_GROUP", 64.0), ("RT_SHARED_STACK", 8.0)];
        assert!(plain.validate_compute_variant("main", &misspelt).is_err(), "a misspelt override must be refused");
        assert_eq!(plain.u32_constant("RT_STACK_SIZE"), Some(RT_STACK_SIZE));
        // Validated as for a device without subgroups, the subgroup module is refused (so wgpu
        // would refuse it there too), and the plain one has no subgroup operation.
        assert!(engine::shader::parse("bench_trace_subgroup.wgsl").is_err(), "subgroup operations need Capabilities::SUBGROUP");
    }

    #[test]
    fn the_bench_shader_is_registered_and_its_params_match_naga_layout() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        engine::shader::check_shader_folder(&dir, SHADERS).unwrap_or_else(|e| panic!("{e}"));
        engine::shader::register(SHADERS).expect("register");
        let host = engine::gpu_struct_layout!(BenchParams in "bench_trace.wgsl" {
            rotation, grid_origin, rays_per_probe, grid_spacing, ray_count, grid_counts, max_distance, order_offset,
        });
        engine::shader::check_struct_layout(&host).unwrap_or_else(|e| panic!("{e}"));
    }
}

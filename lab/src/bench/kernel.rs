//! The bench's kernel: its WGSL ([`SHADERS`]), the variants `bench trace` compares
//! ([`TraceVariant`]), the order of a probe's rays ([`RayOrder`]) and the pipeline with its buffers
//! that one dispatch runs ([`TraceKernel`]).

use engine::bevy_app::App;
use engine::gpu::GpuContext;
use engine::render::GpuScene;
use engine::rng::SplitMix64;
use engine::rt::RayTracingScene;
use engine::shader::compute_program_with_constants;
use engine::wgpu;
use glam::{Mat4, Quat, Vec3};

use super::{GRIDS, RAYS};

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct BenchParams {
    rotation: [[f32; 4]; 4],
    grid_origin: [f32; 3],
    rays_per_probe: u32,
    grid_spacing: [f32; 3],
    pub(super) ray_count: u32,
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

/// The bench's WGSL (`lab/shaders/`): kernels that trace probe-like rays and nothing else, for any
/// device (`bench_trace.wgsl`) and with subgroup operations (`bench_trace_subgroup.wgsl`).
pub const SHADERS: &[engine::shader::ShaderModule] = &[
    ("bench_trace.inc.wgsl", include_str!("../../shaders/bench_trace.inc.wgsl")),
    ("bench_trace.wgsl", include_str!("../../shaders/bench_trace.wgsl")),
    ("bench_trace_subgroup.wgsl", include_str!("../../shaders/bench_trace_subgroup.wgsl")),
];

/// What a bench kernel is built for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum KernelUse {
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
pub(super) struct TraceKernel {
    program: engine::shader::Program<wgpu::ComputePipeline>,
    pub(super) hits: wgpu::Buffer,
    /// Each ray's hit instance and triangle ([`KernelUse::HitIds`]; one unused entry otherwise).
    pub(super) hit_ids: wgpu::Buffer,
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
    pub(super) fn new(gpu: &GpuContext, app: &App, usage: KernelUse, variant: TraceVariant) -> Result<Self, String> {
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
    pub(super) fn run(&self, gpu: &GpuContext, p: &BenchParams) -> Result<f64, String> {
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
    pub(super) fn work(&self, gpu: &GpuContext) -> Result<[u32; BENCH_WORK_WORDS], String> {
        let w: Vec<u32> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &self.work));
        w.try_into().map_err(|w: Vec<u32>| format!("bench_work: {} words read back, {BENCH_WORK_WORDS} expected", w.len()))
    }
}

/// The parameters of one dispatch over `grid` probes spread over `bounds` (render space), each
/// tracing `rays_per_probe` rays turned by a random rotation.
pub(super) fn params_for(rng: &mut SplitMix64, bounds: (Vec3, Vec3), grid: [u32; 3], rays_per_probe: u32) -> BenchParams {
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

//! `bench trace`'s TLAS measurements: a build with a re-braiding budget ([`tlas_build`]), one
//! frame's update when instances move with the refit on the CPU ([`tlas_update_cost`]) or on the
//! GPU ([`tlas_gpu_refit_cost`]), and a flat CWBVH over every triangle ([`flat_rebuild_cost`]).

use std::time::{Duration, Instant};

use engine::bevy_app::App;
use engine::bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::render::GpuScene;
use engine::rng::SplitMix64;
use engine::rt::RayTracingScene;
use engine::scene::{Assets, Mesh, MeshInstance, Transform};
use glam::Vec3;

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

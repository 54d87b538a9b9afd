//! The ray-tracing core shared by every ray consumer (camera shadows, DDGI probes, the reference
//! path tracer): two-level BVHs traversed in WGSL compute shaders (no hardware ray queries).
//!
//! - **BLAS**: one per mesh asset, in the mesh's local space, an 8-wide compressed BVH (CWBVH,
//!   Ylitie et al. 2017) built once by obvhs. Triangles are stored in leaf order (vertex + two edges,
//!   full float) so that traversal reads them without indirection; each keeps its mesh triangle index.
//!   Meshes above [`ASYNC_BLAS_TRIANGLES`] are built on a worker thread, off the frame loop, with
//!   progress in [`BlasBuildProgress`] (and a [`BlasBuildHook`] told of each step); smaller ones are
//!   built in the frame, in parallel. Until its BLAS is ready an instance is not traced.
//! - **TLAS**: an 8-wide CWBVH over the world bounds of the instances, encoded like a BLAS so that
//!   one node test serves both levels. It is collapsed from a binary BVH (obvhs PLOC plus
//!   reinsertion) that stays on the CPU: each wide node opens its largest descendants until it has
//!   eight children, placed in the slots of the ray octants they are nearest for. Its leaves are
//!   [`TlasEntry`]s (instance slot, where the BLAS lives and the BLAS node the walk starts at).
//!   With partial re-braiding ([`RayTracingScene::set_rebraid_budget`]; Benthin, Woop, Wald and
//!   Áfra, HPG 2017) the build's primitives are (instance, BLAS node) pairs: static instances'
//!   largest BLAS nodes are opened into leaves of their own, each bounded by its node's box in world
//!   space, so that a ray crossing overlapping instances enters only the parts it meets. Instances
//!   that move stay one leaf (opened ones are rebuilt at their root when they first move). When
//!   entities move only their leaves are updated, the binary BVH is refitted and the wide nodes over
//!   changed children are re-encoded; it is rebuilt when instances are added or removed, or when
//!   refitting has let its quality decay (its SAH cost grew [`TLAS_REBUILD_COST_RATIO`] times). By
//!   default the GPU refits ([`TlasRefit::Gpu`], `engine/shaders/tlas_refit.wgsl`): the CPU only
//!   computes and uploads the moved leaves' world boxes, and reads back the SAH cost the GPU
//!   measures every few refits. With [`TlasRefit::Cpu`] the CPU refits, many movers in parallel on
//!   rayon's pool: the binary BVH is cut into subtrees whose nodes are contiguous, each refitted
//!   through its own slice, then the few nodes above them; only changed nodes are uploaded, those
//!   near each other in one copy. Every way gives the same nodes, bit for bit. A static scene does
//!   no BVH work per frame.
//! - **Static groups** (`groups.rs`, [`StaticGrouping`]): static instances whose meshes are used once
//!   and whose world boxes overlap (a building's walls, vaults and floor) are traced through one BLAS
//!   built over all their triangles in one member's space, entered by one TLAS leaf; each triangle
//!   carries its member's instance slot, which the hit reports. A cluster becomes a group only where
//!   rays traced on the CPU say it saves work; a member that moves leaves its group.
//!
//! Traversal lives in `engine/shaders/ray_tracing.inc.wgsl`: closest hit and any hit in one loop over both
//! levels (a warp's lanes test TLAS and BLAS nodes with the same code in the same step), the ray
//! transformed into instance space without normalizing its direction, so `t` is comparable across
//! instances.

mod blas;
mod collapse;
pub mod cpu;
pub(crate) mod gpu_refit;
mod groups;
mod layouts;
mod rebraid;
mod refit;
mod refit_plan;
mod tlas;
mod tracer;
pub use blas::{
    ASYNC_BLAS_TRIANGLES, Blas, BlasBuildCounts, BlasBuildHook, BlasBuildProgress, BlasBuildQuality, BlasBuildSettings, WaitForBlasBuilds,
};
pub use collapse::{TLAS_ENCODE_INV_255, TLAS_ENCODE_MIN_EXTENT, TLAS_STACK_SIZE};
pub use gpu_refit::{TLAS_GPU_COST_READ_EVERY, TLAS_REFIT_COST_SCALE};
pub use groups::{
    GROUP_COST_RAYS, GROUP_ENTER_COST, GROUP_MAX_TRIANGLES, GROUP_NODE_COST, GROUP_OVERLAP, GROUP_OVERLAP_PADDING, GROUP_TRIANGLE_COST,
    StaticGrouping,
};
pub(crate) use layouts::gpu_layouts;
pub use rebraid::{TLAS_REBRAID_AREA_RATIO, TLAS_REBRAID_BUDGET};
pub use refit::{
    TLAS_PARALLEL_REFIT_MIN_THREADS, TLAS_PARALLEL_REFIT_MOVERS, TLAS_REBUILD_COST_RATIO, TlasRefit, default_parallel_refit_from,
};
pub use tlas::{TLAS_REINSERTION_RATIO, TlasEntry};
pub use tracer::{RayTracer, ray_workgroups};

use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bevy_ecs::prelude::*;
use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::node::CwBvhNode;

use blas::{BuiltBlas, GpuBlas};
use refit_plan::RefitPlan;
use tlas::TlasPrim;

use crate::gpu::GpuContext;
use crate::gpu::{GrowableBuffer, Uploads};
use crate::graph::NamedResource;
use crate::render::GpuScene;
use crate::scene::{Assets, Mesh};

/// The world bounds of a local box under `world` (its eight corners transformed).
fn world_aabb((lo, hi): (Vec3, Vec3), world: &Affine3A) -> Option<Aabb> {
    let mut aabb = Aabb::empty();
    for i in 0..8 {
        let corner =
            Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
        aabb.extend(world.transform_point3a(corner.into()));
    }
    // + 0.0 turns -0.0 into +0.0 (and nothing else), so that a union's minimum never depends on the
    // order of its operands: the GPU refit's integer min/max then gives the CPU's bits.
    aabb.valid().then_some(Aabb { min: aabb.min + Vec3A::ZERO, max: aabb.max + Vec3A::ZERO })
}

/// Sentinel for "none" in the TLAS's index tables.
const NONE: u32 = u32::MAX;

/// CPU cost of the last frame's BVH work, for benchmarks and the overlay.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhFrameStats {
    /// Whether the TLAS was rebuilt from scratch this frame.
    pub tlas_rebuilt: bool,
    /// TLAS leaves refitted this frame (instances that moved).
    pub tlas_refitted_leaves: usize,
    /// Whether this frame's TLAS refit ran on rayon's thread pool.
    pub tlas_refit_parallel: bool,
    /// Wide TLAS nodes uploaded this frame.
    pub tlas_nodes_uploaded: usize,
    /// Copies that upload them (changed nodes near each other share one).
    pub tlas_upload_copies: usize,
    /// Uploads of the BLAS buffers this frame (all of them at once, when new BLASes arrived): 0 or 1.
    pub blas_uploaded: usize,
    /// CPU time of the frame's BVH work (BLAS requests and uploads, TLAS build or refit); zero on a
    /// frame that did none.
    pub cpu_time: Duration,
    /// Of a refit's time: moving the leaves and refitting the binary TLAS's nodes above them.
    pub tlas_refit_time: Duration,
    /// Of a refit's time: re-encoding the wide nodes over changed children.
    pub tlas_encode_time: Duration,
    /// Of a refit's time: staging the changed wide nodes for upload (with [`TlasRefit::Gpu`]: the
    /// moved leaves' boxes and the refit's dispatches).
    pub tlas_upload_time: Duration,
    /// Whether this frame's refit ran on the GPU ([`TlasRefit::Gpu`]).
    pub tlas_refit_on_gpu: bool,
    /// The TLAS's SAH cost (its inner nodes' half areas over its root's) as a GPU refit measured
    /// it, when a reading arrived this frame ([`TlasRefit::Gpu`]; the rebuild test uses it).
    pub tlas_gpu_cost: Option<f64>,
}

/// The scene's BVHs on the CPU and the GPU.
#[derive(Resource)]
pub struct RayTracingScene {
    /// Every BLAS's nodes, one after the other (WGSL `blas_nodes`).
    pub(crate) blas_nodes: GrowableBuffer,
    /// Every BLAS's triangles in leaf order (WGSL `blas_triangles`).
    pub(crate) blas_triangles: GrowableBuffer,
    /// A [`GpuBlas`] per mesh (WGSL `blas_info`).
    pub(crate) blas_info: GrowableBuffer,
    /// The wide TLAS: nodes, then their entries (WGSL `tlas_nodes`).
    pub(crate) tlas_nodes: GrowableBuffer,
    blas: Vec<Option<Arc<Blas>>>,
    gpu_blas: Vec<GpuBlas>,
    requested_meshes: usize,
    /// BLAS builds requested and not yet received.
    outstanding: usize,
    results: Mutex<Receiver<BuiltBlas>>,
    sender: Sender<BuiltBlas>,
    /// The [`BlasBuildQuality`] of the builds requested last, and how many times it changed (the
    /// generation each build carries): a build of an older generation that arrives after a newer
    /// one of the same mesh is dropped.
    blas_quality: BlasBuildQuality,
    blas_generation: u32,
    /// The generation of each mesh's BLAS in `blas`.
    blas_built_generation: Vec<u32>,
    /// Triangles built and pending, shared with the worker threads that build large BLASes.
    pub progress: BlasBuildProgress,
    /// The BVH over the adapter's buffer limits, when it is (nothing is traced then).
    pub over_limit: Option<crate::scene::SceneDataError>,
    /// The binary BVH the 8-wide TLAS is collapsed from; refits happen here.
    tlas: Option<Bvh2>,
    /// Each TLAS primitive (the Bvh2's primitive indices point here).
    tlas_prims: Vec<TlasPrim>,
    /// The primitive of each instance slot in `tlas_prims` (`NONE`: not in the TLAS).
    slot_prims: Vec<u32>,
    /// The Bvh2 leaf of each primitive.
    prim_leaf: Vec<u32>,
    /// The wide TLAS as uploaded: CWBVH nodes, then eight entries per node (one per child slot).
    gpu_tlas: Vec<CwBvhNode>,
    gpu_entries: Vec<TlasEntry>,
    /// For each wide node: the Bvh2 node it stands for, and the Bvh2 node in each child slot.
    wide_source: Vec<u32>,
    wide_children: Vec<[u32; 8]>,
    /// For each Bvh2 node: the wide node that has it as a child (`NONE` for inner nodes collapsed away).
    wide_owner: Vec<u32>,
    /// Sum of the half areas of the TLAS's inner nodes, now and right after its last build, each
    /// over the root's: the normalized SAH cost. Refitting lets it decay; past
    /// [`TLAS_REBUILD_COST_RATIO`] times its built value the TLAS is rebuilt.
    inner_area: f64,
    built_cost: f64,
    /// The binary TLAS cut into subtrees for a parallel refit (`None`: no TLAS, or too small to cut).
    refit_plan: Option<RefitPlan>,
    /// With [`TlasRefit::Cpu`]: moving instances from which the TLAS refit runs on rayon's thread
    /// pool (default [`default_parallel_refit_from`]; `usize::MAX`: never, 0: always). Both ways
    /// give the same TLAS.
    pub parallel_refit_from: usize,
    /// Where the TLAS is refitted when instances move (default [`TlasRefit::Gpu`]). Either way gives
    /// the same TLAS; it can change from one frame to the next.
    pub tlas_refit: TlasRefit,
    /// With [`TlasRefit::Gpu`]: leaves whose boxes changed since the CPU copy's inner nodes were last
    /// refitted (and a mark per Bvh2 node), and the wide nodes whose CPU encoding is stale.
    stale_leaves: Vec<u32>,
    leaf_stale: Vec<bool>,
    wide_stale: Vec<bool>,
    /// The GPU refit's pipelines and buffers (created at the first GPU refit), and whether its
    /// buffers hold this TLAS and its leaves' current boxes.
    gpu_refit: Option<gpu_refit::GpuRefit>,
    gpu_refit_ready: bool,
    /// Re-braiding (partial re-braiding, Benthin, Woop, Wald and Áfra, HPG 2017): the TLAS build
    /// may have up to this many times as many primitives as instances, opening the BLAS nodes of
    /// static instances with the largest world-space boxes into TLAS leaves of their own (each
    /// entered at that node). 0 or anything up to 1: off, one leaf per instance. Default
    /// [`TLAS_REBRAID_BUDGET`]; set it with [`RayTracingScene::set_rebraid_budget`], which rebuilds
    /// the TLAS on the next frame. Instances that have moved are never opened, so a refit stays one
    /// leaf per mover.
    rebraid_budget: f32,
    /// A rebuild was asked for (a setting changed).
    rebuild_requested: bool,
    /// Whether static instances that overlap are traced through shared BLASes (static groups, see
    /// `groups.rs`; [`RayTracingScene::set_static_grouping`]).
    static_grouping: StaticGrouping,
    /// The static groups, and the clusters found not worth one.
    static_groups: groups::StaticGroups,
    /// Instance slots that have moved since the scene was loaded: kept at their BLAS root by
    /// re-braiding (a freed slot that a new instance takes keeps its mark).
    slot_moved: Vec<bool>,
    /// Scratch: inner nodes already queued for refit, wide nodes to re-encode, the movers of each
    /// subtree of the refit plan.
    marked: Vec<bool>,
    wide_marked: Vec<bool>,
    refit_buckets: Vec<Vec<(u32, u32)>>,
    /// What this frame's BVH work did and cost (reset by every prepare stage).
    pub stats: BvhFrameStats,
}

impl RayTracingScene {
    /// An empty scene: no BLAS, an empty TLAS uploaded.
    pub fn new(gpu: &GpuContext) -> Self {
        let storage = wgpu::BufferUsages::STORAGE;
        let (sender, results) = channel();
        let mut scene = Self {
            blas_nodes: GrowableBuffer::new(&gpu.device, "blas_nodes", storage),
            blas_triangles: GrowableBuffer::new(&gpu.device, "blas_triangles", storage),
            blas_info: GrowableBuffer::new(&gpu.device, "blas_info", storage),
            // COPY_SRC: read back to check the GPU refit ([`RayTracingScene::read_tlas_nodes`]).
            tlas_nodes: GrowableBuffer::new(&gpu.device, "tlas_nodes", storage | wgpu::BufferUsages::COPY_SRC),
            blas: Vec::new(),
            gpu_blas: Vec::new(),
            requested_meshes: 0,
            outstanding: 0,
            results: Mutex::new(results),
            sender,
            blas_quality: BlasBuildQuality::default(),
            blas_generation: 0,
            blas_built_generation: Vec::new(),
            progress: BlasBuildProgress::default(),
            over_limit: None,
            tlas: None,
            tlas_prims: Vec::new(),
            slot_prims: Vec::new(),
            prim_leaf: Vec::new(),
            gpu_tlas: Vec::new(),
            gpu_entries: Vec::new(),
            wide_source: Vec::new(),
            wide_children: Vec::new(),
            wide_owner: Vec::new(),
            inner_area: 0.0,
            built_cost: 0.0,
            refit_plan: None,
            parallel_refit_from: default_parallel_refit_from(),
            tlas_refit: TlasRefit::default(),
            stale_leaves: Vec::new(),
            leaf_stale: Vec::new(),
            wide_stale: Vec::new(),
            gpu_refit: None,
            gpu_refit_ready: false,
            rebraid_budget: TLAS_REBRAID_BUDGET,
            rebuild_requested: false,
            static_grouping: StaticGrouping::default(),
            static_groups: groups::StaticGroups::default(),
            slot_moved: Vec::new(),
            marked: Vec::new(),
            wide_marked: Vec::new(),
            refit_buckets: Vec::new(),
            stats: BvhFrameStats::default(),
        };
        scene.upload_tlas_all(gpu);
        scene
    }

    /// Everything `ray_tracing.inc.wgsl` binds in group 0, by WGSL name: the GPU scene's resources
    /// and the BVHs'. A frame's graph imports them ([`crate::graph::RenderGraph::import_named`]).
    pub fn scene_resources<'a>(&'a self, scene: &'a GpuScene) -> Vec<(&'static str, NamedResource<'a>)> {
        let mut all = scene.resources();
        all.extend([
            ("blas_nodes", NamedResource::Buffer(&self.blas_nodes.buffer)),
            ("blas_triangles", NamedResource::Buffer(&self.blas_triangles.buffer)),
            ("blas_info", NamedResource::Buffer(&self.blas_info.buffer)),
            ("tlas_nodes", NamedResource::Buffer(&self.tlas_nodes.buffer)),
        ]);
        all
    }

    /// [`RayTracingScene::scene_resources`] as bind group entries, for dispatches outside a render
    /// graph (the trace tests and benchmarks).
    pub fn scene_bindings<'a>(&'a self, scene: &'a GpuScene) -> Vec<(&'static str, wgpu::BindingResource<'a>)> {
        self.scene_resources(scene)
            .into_iter()
            .map(|(name, r)| {
                let binding = match r {
                    NamedResource::Buffer(b) => b.as_entire_binding(),
                    NamedResource::Texture { view, .. } => wgpu::BindingResource::TextureView(view),
                    NamedResource::Sampler(s) => wgpu::BindingResource::Sampler(s),
                };
                (name, binding)
            })
            .collect()
    }
}

/// Prepare stage (after the GPU scene): builds BLASes for new meshes, and rebuilds or refits the TLAS
/// from the instance changes the GPU scene recorded this frame.
pub fn prepare_ray_tracing_scene(
    gpu: Res<GpuContext>,
    meshes: Res<Assets<Mesh>>,
    scene: Res<GpuScene>,
    settings: BlasBuildSettings,
    mut uploads: ResMut<Uploads>,
    mut rt: ResMut<RayTracingScene>,
) {
    let started = Instant::now();
    rt.stats = BvhFrameStats::default();
    let BlasBuildSettings { wait, quality, hook } = settings;
    let quality = quality.map_or_else(BlasBuildQuality::default, |q| *q);
    if meshes.len() > rt.requested_meshes || quality != rt.blas_quality {
        rt.request_blas(&meshes, quality, hook.as_deref());
    }
    let new_blas = rt.receive_blas(wait.is_some_and(|w| w.0));
    if new_blas {
        rt.upload_blas(&gpu, &scene);
    }
    let changes = scene.instance_changes();
    if new_blas || changes.structure_changed || rt.rebuild_requested {
        for &slot in &changes.moved {
            rt.note_moved(slot);
        }
        rt.rebuild_tlas(&gpu, &scene);
    } else if !changes.moved.is_empty() {
        let moved: Vec<(u32, u32, Affine3A)> =
            changes.moved.iter().filter_map(|&slot| scene.instance_placement(slot).map(|(m, w)| (slot, m, w))).collect();
        if !rt.refit_tlas(&gpu, &mut uploads, &moved) {
            rt.rebuild_tlas(&gpu, &scene);
        }
    }
    if rt.stats.tlas_rebuilt || rt.stats.tlas_refitted_leaves > 0 || new_blas {
        rt.stats.cpu_time = started.elapsed();
    }
}

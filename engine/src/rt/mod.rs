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

pub mod cpu;
pub(crate) mod gpu_refit;
mod groups;
mod layouts;
pub use gpu_refit::{TLAS_GPU_COST_READ_EVERY, TLAS_REFIT_COST_SCALE};
pub use groups::{
    GROUP_COST_RAYS, GROUP_ENTER_COST, GROUP_MAX_TRIANGLES, GROUP_NODE_COST, GROUP_OVERLAP, GROUP_OVERLAP_PADDING, GROUP_TRIANGLE_COST,
    StaticGrouping,
};
pub(crate) use layouts::gpu_layouts;

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bevy_ecs::prelude::*;
use bytemuck::{Pod, Zeroable};
use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};
use obvhs::triangle::Triangle;
use rayon::prelude::*;

use crate::gpu::GpuContext;
use crate::gpu::{GrowableBuffer, Uploads};
use crate::graph::NamedResource;
use crate::render::GpuScene;
use crate::scene::{Assets, Mesh};

/// Meshes with more triangles than this get their BLAS built on a worker thread.
pub const ASYNC_BLAS_TRIANGLES: usize = 200_000;

/// Share of TLAS nodes the reinsertion optimizer revisits after a build.
pub const TLAS_REINSERTION_RATIO: f32 = 0.1;

/// The TLAS is rebuilt when refitting has raised its normalized SAH cost by this factor.
pub const TLAS_REBUILD_COST_RATIO: f64 = 1.5;

/// Moving instances from which a TLAS refit runs on rayon's thread pool by default
/// ([`RayTracingScene::parallel_refit_from`]). Fewer are refitted on the frame's thread: waking the
/// pool's threads and their scattered writes cost more than the refit of a few thousand leaves
/// (H200 host, 16 cores, `bench trace --scene forest --cpu-only`: 1,000 movers 0.394 ms on one
/// thread against 0.544 in parallel; 10,000 movers 3.496 against 2.038).
pub const TLAS_PARALLEL_REFIT_MOVERS: usize = 4096;

/// Threads rayon's pool needs for the refit to go parallel by default: on fewer cores (a 2-core
/// machine shared with other work) the pool's hand-offs cost more than the split saves.
pub const TLAS_PARALLEL_REFIT_MIN_THREADS: usize = 4;

/// The default of [`RayTracingScene::parallel_refit_from`]: [`TLAS_PARALLEL_REFIT_MOVERS`] when
/// rayon's pool has [`TLAS_PARALLEL_REFIT_MIN_THREADS`] threads or more, else never.
pub fn default_parallel_refit_from() -> usize {
    if rayon::current_num_threads() >= TLAS_PARALLEL_REFIT_MIN_THREADS { TLAS_PARALLEL_REFIT_MOVERS } else { usize::MAX }
}

/// Subtrees the binary TLAS is cut into for a parallel refit: several per core, so that movers spread
/// unevenly over the scene still keep every core busy.
const TLAS_REFIT_SUBTREES: usize = 128;

/// How the TLAS is refitted when instances move ([`RayTracingScene::tlas_refit`]). Both give the same
/// wide nodes, bit for bit. The GPU is the default: its CPU cost is computing and staging 32 bytes a
/// mover (1,000 movers of the forest: 0.11–0.13 ms a frame, 0.28 at most, on the H200's host, where
/// the CPU refit took 0.48–0.77 ms in the same runs), and its GPU time, a pass over every TLAS node,
/// is small (0.06 ms for the forest's 11,400 instances).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TlasRefit {
    /// On the CPU: the moved leaves, their ancestors in the binary TLAS and the wide nodes over them
    /// (on rayon's pool from [`RayTracingScene::parallel_refit_from`] movers on); the changed wide
    /// nodes are uploaded. Cheaper in GPU time when a few instances of very many move; used
    /// when the GPU refit's shader cannot be made.
    Cpu,
    /// On the GPU (`engine/shaders/tlas_refit.wgsl`): the CPU computes the moved leaves' world boxes
    /// and uploads them (32 bytes a mover); four dispatches before anything traces refit every inner
    /// node, sum the TLAS's SAH cost and re-encode every wide node in place. The CPU reads the cost
    /// back every [`TLAS_GPU_COST_READ_EVERY`] refits, a frame or two late (nothing waits), for the
    /// rebuild test ([`TLAS_REBUILD_COST_RATIO`]): a TLAS whose quality decayed is rebuilt a few
    /// frames later than with [`TlasRefit::Cpu`], its refitted bounds exact meanwhile (no hit is
    /// missed). The CPU's copy of the binary TLAS keeps its leaves current and refits its inner
    /// nodes only when asked ([`RayTracingScene::sync_cpu_tlas`]) or when the refit goes back to
    /// the CPU.
    #[default]
    Gpu,
}

/// Changed wide TLAS nodes at most this many bytes apart are uploaded in one copy, with the unchanged
/// ones between them: recording a copy costs the CPU a microsecond or two (wgpu's tracking), about
/// as much as staging 16 KiB at memory speed, so a refit that touches nodes all over the TLAS
/// uploads it in a few copies rather than hundreds.
const TLAS_UPLOAD_GAP_BYTES: usize = 16 << 10;

/// How much CPU time a BLAS build spends on the tree's quality: a resource, read whenever a mesh's
/// BLAS is built. Insert it before the meshes load; changing it later rebuilds every BLAS (the old
/// ones trace until the new ones arrive). The presets are obvhs's PLOC builder (Meister and
/// Bittner, TVCG 2018) followed by parallel reinsertion (Meister and Bittner, Eurographics 2018);
/// a better tree means fewer node
/// tests for every ray of the mesh's life, so the default spends more build time than obvhs's own
/// "medium" preset. Traversal work a ray at 32×8×32 probes × 128 rays (`game_demo bench trace
/// --scene S --work-only --no-flat-rebuild --blas-build Q`; it does not depend on the GPU) and the
/// scene's preparation time on this project's 2-core development VM, `Medium` → `High`: cathedral
/// (72,576 triangles) 8.3 → 6.6 BLAS nodes, 14.8 → 12.8 loop steps, 192 → 254–285 ms; forest 47.0
/// → 45.6 steps; cornell 7.4 → 7.5 steps (its warps' longest walks 12.8 → 12.5); door_room and the
/// demo level unchanged (2.5 and 3.5 steps). `Fast` is `Medium`'s work in the cathedral (14.8).
/// Timed on an H100 (BENCHMARKS.md, 2026-12-05, `bench trace` against `Medium` in the same
/// calls): the cathedral traces 1.28–1.33× faster a thread a ray and 1.18–1.33× with the bench's
/// persistent kernel (2,299–2,320 against 1,936–1,946 MRays/s at 32³ × 256), the level
/// 1.04–1.08×, the forest 1.02–1.05×, cornell 0.98–1.01×.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BlasBuildQuality {
    /// obvhs's `fast_build`: PLOC pairs each cluster with the best of its nearest 1 neighbour in
    /// the first 2 merging passes and of 6 after; 2% of the nodes reinserted.
    Fast,
    /// obvhs's `medium_build` (this engine's BLAS build until 2026-12-05): 1 neighbour in the first
    /// 3 merging passes and 14 after; 5% of the nodes reinserted.
    Medium,
    /// 14 neighbours in every merging pass (the first ones, over the most clusters, decide the
    /// tree's lower levels); half of the nodes reinserted.
    #[default]
    High,
}

impl BlasBuildQuality {
    /// obvhs's build parameters for this preset.
    pub fn params(self) -> obvhs::BvhBuildParams {
        match self {
            Self::Fast => obvhs::BvhBuildParams::fast_build(),
            Self::Medium => obvhs::BvhBuildParams::medium_build(),
            Self::High => {
                obvhs::BvhBuildParams { search_depth_threshold: 0, reinsertion_batch_ratio: 0.5, ..obvhs::BvhBuildParams::medium_build() }
            }
        }
    }
}

/// A bottom-level BVH: a CWBVH over one mesh in its local space.
#[derive(Clone, Debug)]
pub struct Blas {
    /// The 8-wide nodes, root first (obvhs's CWBVH encoding, 80 bytes each on the GPU).
    pub nodes: Vec<obvhs::cwbvh::node::CwBvhNode>,
    /// Triangles in leaf order: `[v0.xyz, mesh triangle index as bits], [e1.xyz, tag], [e2.xyz, 0]`,
    /// the tag 0 in a mesh's BLAS and the member's instance slot + 1 (as bits) in a static group's.
    pub triangles: Vec<[f32; 12]>,
    /// Local-space bounds (`None` for a mesh without triangles).
    pub bounds: Option<(Vec3, Vec3)>,
}

impl Blas {
    /// Builds the BLAS of a mesh at the default [`BlasBuildQuality`]. Degenerate triangles are kept
    /// (they never report a hit).
    pub fn build(mesh: &Mesh) -> Self {
        Self::build_with(mesh, BlasBuildQuality::default())
    }

    /// Builds the BLAS of a mesh at `quality`.
    pub fn build_with(mesh: &Mesh, quality: BlasBuildQuality) -> Self {
        // Scene data with NaN or infinite positions is rejected at upload; its BLAS is empty.
        if mesh.positions.iter().any(|p| !p.is_finite()) {
            return Self { nodes: Vec::new(), triangles: Vec::new(), bounds: None };
        }
        let tris: Vec<Triangle> = mesh
            .indices
            .chunks_exact(3)
            .map(|t| {
                let p = |i: u32| Vec3A::from(mesh.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO));
                Triangle { v0: p(t[0]), v1: p(t[1]), v2: p(t[2]) }
            })
            .collect();
        let tags: Vec<(u32, u32)> = (0..tris.len() as u32).map(|i| (i, 0)).collect();
        Self::build_tagged(&tris, &tags, quality)
    }

    /// Builds a BLAS over `tris`, each stored with its tag: (mesh triangle index, instance slot + 1
    /// for a static group's triangle, 0 for a mesh's), in the first and second records' w.
    pub(crate) fn build_tagged(tris: &[Triangle], tags: &[(u32, u32)], quality: BlasBuildQuality) -> Self {
        if tris.is_empty() {
            return Self { nodes: Vec::new(), triangles: Vec::new(), bounds: None };
        }
        let mut time = Duration::ZERO;
        let cwbvh: CwBvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(tris, quality.params(), &mut time);
        let triangles = cwbvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = tris[i as usize];
                let (prim, member) = tags[i as usize];
                let (e1, e2) = (t.v1 - t.v0, t.v2 - t.v0);
                [t.v0.x, t.v0.y, t.v0.z, f32::from_bits(prim), e1.x, e1.y, e1.z, f32::from_bits(member), e2.x, e2.y, e2.z, 0.0]
            })
            .collect();
        let b = cwbvh.total_aabb;
        Self { nodes: cwbvh.nodes, triangles, bounds: Some((b.min.into(), b.max.into())) }
    }
}

/// Where a BLAS lives in the shared GPU buffers. Mirrors WGSL `GpuBlas`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct GpuBlas {
    /// First node in `blas_nodes` (in nodes, 80 bytes each); `u32::MAX` when not built.
    pub node_offset: u32,
    /// First triangle in `blas_triangles`.
    pub triangle_offset: u32,
    pub node_count: u32,
    pub triangle_count: u32,
    /// Where the mesh's indices and vertices start in the scene's shared buffers (attributes at hits).
    pub first_index: u32,
    pub base_vertex: u32,
    pub _pad0: u32,
    pub _pad1: u32,
}

/// A TLAS leaf: the instance a ray enters there and where its BLAS lives (as in WGSL `GpuBlas`), so
/// that entering does not wait for the mesh's record. Mirrors WGSL `TlasEntry`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct TlasEntry {
    /// The instance slot a ray that reaches this leaf enters.
    pub instance: u32,
    /// First node of the instance's BLAS in `blas_nodes` (`u32::MAX`: not built, the leaf is skipped).
    pub node_offset: u32,
    /// First triangle of the instance's BLAS in `blas_triangles`.
    pub triangle_offset: u32,
    /// The BLAS node the walk starts at (relative to `node_offset`): 0, the root, for an instance
    /// that is not opened; a node below it when re-braiding opened the instance (one entry per
    /// node of the cut).
    pub start_node: u32,
}

/// One TLAS primitive: an instance's entry, with its BLAS start node's local-space bounds.
#[derive(Clone, Copy, Debug)]
struct TlasPrim {
    local: (Vec3, Vec3),
    entry: TlasEntry,
}

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

/// The default of [`RayTracingScene::rebraid_budget`]: re-braiding off (see
/// [`RayTracingScene::set_rebraid_budget`]). Off because the work it saves was small where it was
/// counted (`forest`, 32×8×32 × 128 rays: 34.0 node tests a ray off, 32.2 at a budget of 4, 30.2
/// at 16) against a slower TLAS build and a refit whose fixed cost grows with the TLAS;
/// `game_demo bench trace --rebraid B` compares it on a GPU.
pub const TLAS_REBRAID_BUDGET: f32 = 0.0;

/// Re-braiding opens a BLAS node only when the summed world-space half areas of its children are at
/// most this many times its own: where the children are nearly as large as the node (a tree's root
/// children span the tree), opening multiplies the TLAS leaves a ray meets without sparing it a
/// node test.
pub const TLAS_REBRAID_AREA_RATIO: f32 = 2.0;

/// Sentinel for "none" in the TLAS's index tables.
const NONE: u32 = u32::MAX;

/// Progress of BLAS builds, for loading screens and logs: counters shared with the threads that
/// build, read at any time. To be told of each step instead, insert a [`BlasBuildHook`].
#[derive(Resource, Clone, Default)]
pub struct BlasBuildProgress {
    /// Triangles of every mesh whose BLAS was requested.
    pub total_triangles: Arc<AtomicUsize>,
    /// Triangles of the meshes whose BLAS is built.
    pub built_triangles: Arc<AtomicUsize>,
    /// Meshes whose BLAS was requested (built or not).
    pub total_meshes: Arc<AtomicUsize>,
    /// Meshes whose BLAS is requested and not yet built.
    pub pending_meshes: Arc<AtomicUsize>,
    /// Held while the counters change and the hook is called, so that calls never overlap and their
    /// counts never go down.
    report: Arc<Mutex<()>>,
}

impl BlasBuildProgress {
    /// Fraction of triangles whose BLAS is built, in [0, 1].
    pub fn fraction(&self) -> f32 {
        let total = self.total_triangles.load(Ordering::Relaxed);
        if total == 0 { 1.0 } else { self.built_triangles.load(Ordering::Relaxed) as f32 / total as f32 }
    }

    /// Whether every requested BLAS is built.
    pub fn is_done(&self) -> bool {
        self.pending_meshes.load(Ordering::Relaxed) == 0
    }

    /// The counters now.
    pub fn counts(&self) -> BlasBuildCounts {
        let total_meshes = self.total_meshes.load(Ordering::Relaxed);
        BlasBuildCounts {
            built_meshes: total_meshes.saturating_sub(self.pending_meshes.load(Ordering::Relaxed)),
            total_meshes,
            built_triangles: self.built_triangles.load(Ordering::Relaxed),
            total_triangles: self.total_triangles.load(Ordering::Relaxed),
        }
    }

    /// Counts `meshes` more requested builds of `triangles` triangles in all, and tells `hook`.
    fn requested(&self, meshes: usize, triangles: usize, hook: Option<&BlasBuildHook>) {
        let _report = self.report.lock().unwrap_or_else(|e| e.into_inner());
        self.total_triangles.fetch_add(triangles, Ordering::Relaxed);
        self.total_meshes.fetch_add(meshes, Ordering::Relaxed);
        self.pending_meshes.fetch_add(meshes, Ordering::Relaxed);
        if let Some(hook) = hook {
            (hook.0)(self.counts());
        }
    }

    /// Counts one built BLAS of `triangles` triangles, and tells `hook`.
    fn built(&self, triangles: usize, hook: Option<&BlasBuildHook>) {
        let _report = self.report.lock().unwrap_or_else(|e| e.into_inner());
        self.built_triangles.fetch_add(triangles, Ordering::Relaxed);
        self.pending_meshes.fetch_sub(1, Ordering::Relaxed);
        if let Some(hook) = hook {
            (hook.0)(self.counts());
        }
    }
}

/// Counts of BLAS builds since the app started, as [`BlasBuildProgress::counts`] and a
/// [`BlasBuildHook`] give them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BlasBuildCounts {
    /// Meshes whose BLAS is built.
    pub built_meshes: usize,
    /// Meshes whose BLAS was requested (built or not).
    pub total_meshes: usize,
    /// Triangles of the meshes whose BLAS is built.
    pub built_triangles: usize,
    /// Triangles of every mesh whose BLAS was requested.
    pub total_triangles: usize,
}

impl BlasBuildCounts {
    /// Whether every requested BLAS is built.
    pub fn is_done(&self) -> bool {
        self.built_meshes == self.total_meshes
    }
}

/// A resource that is told of BLAS build progress, for a loading screen or a terminal progress bar
/// (the engine draws none). The callback gets the [`BlasBuildCounts`] when the builds of new meshes
/// are requested (the totals grown, before any of them is built) and after each BLAS is built. It
/// runs on the frame's thread or on the thread that built the BLAS, never two calls at once, and
/// the counts it gets never go down; a batch's last call has [`BlasBuildCounts::is_done`]. Builders
/// wait for it to return, so it should be quick. Insert it before the frame that first sees the
/// meshes: later requests find it, builds already under way keep the hook they started with.
#[derive(Resource, Clone)]
pub struct BlasBuildHook(pub Arc<dyn Fn(BlasBuildCounts) + Send + Sync>);

impl BlasBuildHook {
    /// A hook calling `f`.
    pub fn new(f: impl Fn(BlasBuildCounts) + Send + Sync + 'static) -> Self {
        Self(Arc::new(f))
    }
}

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

    /// The TLAS as uploaded (CPU copy): its 8-wide nodes and their entries, eight per node. After
    /// GPU refits ([`TlasRefit::Gpu`]) the nodes are those of the last [`RayTracingScene::sync_cpu_tlas`].
    pub fn tlas_cpu(&self) -> (&[CwBvhNode], &[TlasEntry]) {
        (&self.gpu_tlas, &self.gpu_entries)
    }

    /// The wide TLAS nodes as the GPU holds them, read back (as many as [`RayTracingScene::tlas_cpu`]
    /// has). Blocks until the GPU is idle. For tests of the GPU refit.
    pub fn read_tlas_nodes(&self, gpu: &GpuContext) -> Vec<CwBvhNode> {
        let bytes = crate::gpu::readback::read_buffer(gpu, &self.tlas_nodes.buffer);
        bytemuck::pod_collect_to_vec(&bytes[..size_of_val(self.gpu_tlas.as_slice())])
    }

    /// Brings the CPU's copy of the TLAS up to date after GPU refits ([`TlasRefit::Gpu`]): refits the
    /// binary TLAS's inner nodes above the leaves moved since it was last refitted and re-encodes the
    /// wide nodes over them, which then equal the GPU's bit for bit. Costs about one CPU refit of
    /// those movers; nothing when the copy is current (always with [`TlasRefit::Cpu`]).
    pub fn sync_cpu_tlas(&mut self) {
        self.refit_cpu_copy();
        let Some(bvh) = &self.tlas else { return };
        for (w, stale) in self.wide_stale.iter_mut().enumerate().filter(|(_, s)| **s) {
            encode_bounds(bvh, self.wide_source[w] as usize, &self.wide_children[w], &mut self.gpu_tlas[w]);
            *stale = false;
        }
    }

    /// Refits the CPU copy's inner nodes above the leaves GPU refits moved (marking the wide nodes
    /// over changed nodes stale) and updates the SAH cost.
    fn refit_cpu_copy(&mut self) {
        if self.stale_leaves.is_empty() {
            return;
        }
        let Some(mut bvh) = self.tlas.take() else { return };
        let leaves: Vec<(u32, Aabb)> = self.stale_leaves.iter().map(|&l| (l, *bvh.nodes[l as usize].aabb())).collect();
        for &l in &self.stale_leaves {
            self.leaf_stale[l as usize] = false;
        }
        self.stale_leaves.clear();
        self.marked.clear();
        self.marked.resize(bvh.nodes.len(), false);
        let out = self.refit_leaves_on_this_thread(&mut bvh, &leaves);
        self.inner_area += out.area;
        mark_wide_owners(&self.wide_owner, &out.dirty, &mut self.wide_stale);
        self.tlas = Some(bvh);
    }

    /// The SAH cost of the TLAS over its cost when built exceeds [`TLAS_REBUILD_COST_RATIO`].
    fn decayed(&self, bvh: &Bvh2) -> bool {
        self.decayed_at(over_root(bvh, self.inner_area))
    }

    /// A TLAS of normalized SAH cost `cost` has decayed past [`TLAS_REBUILD_COST_RATIO`] times its
    /// cost when built.
    fn decayed_at(&self, cost: f64) -> bool {
        cost > TLAS_REBUILD_COST_RATIO * self.built_cost
    }

    /// The re-braiding budget ([`RayTracingScene::set_rebraid_budget`]).
    pub fn rebraid_budget(&self) -> f32 {
        self.rebraid_budget
    }

    /// Sets the re-braiding budget: the TLAS build may have up to `budget` times as many primitives
    /// as instances (0, or anything up to 1: off). The TLAS is rebuilt on the next frame. A budget
    /// that is not a finite number is taken as 0.
    pub fn set_rebraid_budget(&mut self, budget: f32) {
        self.rebraid_budget = if budget.is_finite() { budget.max(0.0) } else { 0.0 };
        self.rebuild_requested = true;
    }

    /// TLAS primitives (instance leaves and, with re-braiding, the opened BLAS nodes) in the TLAS.
    pub fn tlas_primitive_count(&self) -> usize {
        self.tlas_prims.len()
    }

    /// The BLAS of mesh `index`, once built.
    pub fn blas(&self, index: usize) -> Option<&Blas> {
        self.blas.get(index).and_then(|b| b.as_deref())
    }

    /// Starts BLAS builds for meshes added since the last call: small ones now, in parallel on
    /// rayon's pool, large ones one after the other on a worker thread of their own (so that they
    /// never hold up the pool a refit runs on). Tells `hook` of the progress.
    fn request_blas(&mut self, meshes: &Assets<Mesh>, quality: BlasBuildQuality, hook: Option<&BlasBuildHook>) {
        if quality != self.blas_quality {
            // Every mesh again, at the new quality.
            self.blas_quality = quality;
            self.blas_generation += 1;
            self.requested_meshes = 0;
        }
        let generation = self.blas_generation;
        let mut background: Vec<(usize, Mesh)> = Vec::new();
        let mut now: Vec<(usize, &Mesh)> = Vec::new();
        let mut triangles = 0;
        for (handle, mesh) in meshes.iter().skip(self.requested_meshes) {
            let index = handle.index() as usize;
            self.blas.resize(self.blas.len().max(index + 1), None);
            triangles += mesh.triangle_count();
            if mesh.triangle_count() > ASYNC_BLAS_TRIANGLES {
                background.push((index, mesh.clone()));
            } else {
                now.push((index, mesh));
            }
        }
        self.requested_meshes = meshes.len();
        self.outstanding += now.len() + background.len();
        self.progress.requested(now.len() + background.len(), triangles, hook);
        now.par_iter().for_each_with(self.sender.clone(), |sender, &(index, mesh)| {
            let _ = sender.send(BuiltBlas { index, generation, blas: Arc::new(Blas::build_with(mesh, quality)) });
            self.progress.built(mesh.triangle_count(), hook);
        });
        if !background.is_empty() {
            let sender = self.sender.clone();
            let progress = self.progress.clone();
            let hook = hook.cloned();
            std::thread::spawn(move || {
                for (index, mesh) in background {
                    let started = Instant::now();
                    let blas = Arc::new(Blas::build_with(&mesh, quality));
                    log::info!("BLAS of '{}' ({} triangles) built in {:.2?}", mesh.name, mesh.triangle_count(), started.elapsed());
                    // Send first: once progress says done, the next frame finds every result.
                    if sender.send(BuiltBlas { index, generation, blas }).is_err() {
                        return;
                    }
                    progress.built(mesh.triangle_count(), hook.as_ref());
                }
            });
        }
    }

    /// Collects finished BLAS builds; returns true if any arrived. With `wait`, blocks until every
    /// requested build has finished (headless rendering, tests).
    fn receive_blas(&mut self, wait: bool) -> bool {
        let mut any = false;
        let mut arrived = Vec::new();
        {
            let results = self.results.lock().unwrap_or_else(|e| e.into_inner());
            loop {
                let next = if wait && self.outstanding > arrived.len() {
                    results.recv_timeout(Duration::from_secs(600)).ok()
                } else {
                    results.try_recv().ok()
                };
                let Some(item) = next else { break };
                arrived.push(item);
            }
        }
        self.outstanding = self.outstanding.saturating_sub(arrived.len());
        self.blas_built_generation.resize(self.blas.len(), 0);
        for BuiltBlas { index, generation, blas } in arrived {
            if generation < self.blas_built_generation[index] {
                continue;
            }
            self.blas[index] = Some(blas);
            self.blas_built_generation[index] = generation;
            any = true;
        }
        any
    }

    /// Uploads every BLAS (the meshes', then the static groups') and the meshes' [`GpuBlas`] records.
    fn upload_blas(&mut self, gpu: &GpuContext, scene: &GpuScene) {
        let mut nodes: Vec<u8> = Vec::new();
        let mut triangles: Vec<[f32; 12]> = Vec::new();
        self.gpu_blas.clear();
        for (mesh, blas) in self.blas.iter().enumerate() {
            let range = scene.mesh_ranges.get(mesh);
            let info = match (blas, range) {
                (Some(b), Some(range)) if !b.nodes.is_empty() && !range.indices.is_empty() => {
                    let info = GpuBlas {
                        node_offset: (nodes.len() / 80) as u32,
                        triangle_offset: triangles.len() as u32,
                        node_count: b.nodes.len() as u32,
                        triangle_count: b.triangles.len() as u32,
                        first_index: range.indices.start,
                        base_vertex: range.base_vertex as u32,
                        _pad0: 0,
                        _pad1: 0,
                    };
                    nodes.extend_from_slice(bytemuck::cast_slice(&b.nodes));
                    triangles.extend_from_slice(&b.triangles);
                    info
                }
                _ => GpuBlas { node_offset: u32::MAX, ..GpuBlas::zeroed() },
            };
            self.gpu_blas.push(info);
        }
        let limit = crate::gpu::max_storage_buffer_bytes(&gpu.device);
        // Static groups after the meshes, while both buffers stay within the limit (a group that
        // does not fit is not used: its members are traced one by one).
        for group in &mut self.static_groups.groups {
            let (node_bytes, triangle_bytes) =
                (nodes.len() + group.blas.nodes.len() * 80, (triangles.len() + group.blas.triangles.len()) * 48);
            if node_bytes as u64 > limit || triangle_bytes as u64 > limit {
                group.node_offset = NONE;
                continue;
            }
            group.node_offset = (nodes.len() / 80) as u32;
            group.triangle_offset = triangles.len() as u32;
            nodes.extend_from_slice(bytemuck::cast_slice(&group.blas.nodes));
            triangles.extend_from_slice(&group.blas.triangles);
        }
        let needed = (nodes.len() as u64).max(std::mem::size_of_val(triangles.as_slice()) as u64);
        self.over_limit = None;
        if needed > limit {
            let buffer = if nodes.len() as u64 > limit { "BVH node buffer" } else { "BVH triangle buffer (48 bytes per triangle)" };
            let largest = self
                .blas
                .iter()
                .enumerate()
                .filter_map(|(i, b)| b.as_ref().map(|b| (i, b.triangles.len())))
                .max_by_key(|(_, n)| *n)
                .map_or(String::new(), |(i, n)| format!(" (largest: mesh {i}, {n} triangles)"));
            let error = crate::scene::SceneDataError::OverLimit { item: format!("scene BVH{largest}"), buffer, needed, limit };
            log::error!("{error}; nothing is traced");
            self.over_limit = Some(error);
            nodes.clear();
            triangles.clear();
            for info in &mut self.gpu_blas {
                *info = GpuBlas { node_offset: u32::MAX, ..GpuBlas::zeroed() };
            }
            for group in &mut self.static_groups.groups {
                group.node_offset = NONE;
            }
        }
        self.blas_nodes.write(gpu, &nodes);
        self.blas_triangles.write(gpu, bytemuck::cast_slice(&triangles));
        self.blas_info.write(gpu, bytemuck::cast_slice(&self.gpu_blas));
        self.stats.blas_uploaded += 1;
    }

    /// The TLAS primitive of one instance under `world`; `None` when it has none (BLAS not ready or
    /// not on the GPU, empty mesh) or a transform that gives no valid bounds.
    fn instance_prim(&self, slot: u32, mesh: u32, world: &Affine3A) -> Option<(TlasPrim, Aabb)> {
        let local = self.blas(mesh as usize)?.bounds?;
        // A BLAS that is not on the GPU (over the buffer limit) is not traced.
        let info = self.gpu_blas.get(mesh as usize).filter(|b| b.node_offset != u32::MAX)?;
        let aabb = world_aabb(local, world)?;
        let entry = TlasEntry { instance: slot, node_offset: info.node_offset, triangle_offset: info.triangle_offset, start_node: 0 };
        Some((TlasPrim { local, entry }, aabb))
    }

    /// Rebuilds the TLAS from every live instance whose BLAS is ready (static groups formed or
    /// dissolved first, the BLAS buffers uploaded again when they changed).
    fn rebuild_tlas(&mut self, gpu: &GpuContext, scene: &GpuScene) {
        self.rebuild_requested = false;
        let instances = scene.live_instances();
        // Alpha-tested instances keep their own TLAS leaf: the traversal's alpha test reads the
        // entered instance's material and mesh.
        let groupable: Vec<_> = instances.iter().filter(|(slot, _, _)| !scene.instance_alpha_tested(*slot)).copied().collect();
        if self.update_static_groups(&groupable) {
            self.upload_blas(gpu, scene);
        }
        let grouped: std::collections::HashSet<u32> =
            self.static_groups.groups.iter().filter(|g| g.node_offset != NONE).flat_map(|g| g.members.iter().map(|m| m.0)).collect();
        let mut roots = Vec::with_capacity(instances.len());
        for &(slot, mesh, world) in &instances {
            if grouped.contains(&slot) {
                continue;
            }
            let Some((prim, aabb)) = self.instance_prim(slot, mesh, &world) else { continue };
            roots.push((prim, aabb, mesh, world));
        }
        let opened = self.open_instances(roots);
        let mut aabbs = Vec::with_capacity(opened.len());
        self.tlas_prims.clear();
        self.slot_prims.clear();
        for (prim, aabb) in opened {
            let slot = prim.entry.instance as usize;
            if self.slot_prims.len() <= slot {
                self.slot_prims.resize(slot + 1, NONE);
            }
            if self.slot_prims[slot] == NONE {
                self.slot_prims[slot] = self.tlas_prims.len() as u32;
            }
            self.tlas_prims.push(prim);
            aabbs.push(aabb);
        }
        // A group's leaf is entered in its frame instance's space. Its members keep no primitive of
        // their own (`slot_prims`): one that moves makes the refit give way to a rebuild, which
        // dissolves the group.
        for group in self.static_groups.groups.iter().filter(|g| g.node_offset != NONE) {
            let Some(local) = group.blas.bounds else { continue };
            let Some(&(_, _, world)) = group.members.iter().find(|m| m.0 == group.frame) else { continue };
            let Some(aabb) = world_aabb(local, &world) else { continue };
            let entry =
                TlasEntry { instance: group.frame, node_offset: group.node_offset, triangle_offset: group.triangle_offset, start_node: 0 };
            self.tlas_prims.push(TlasPrim { local, entry });
            aabbs.push(aabb);
        }
        if aabbs.is_empty() {
            self.tlas = None;
            self.refit_plan = None;
        } else {
            let indices = (0..aabbs.len() as u32).collect();
            let mut bvh = PlocBuilder::with_capacity(aabbs.len()).build(PlocSearchDistance::High, &aabbs, indices, SortPrecision::U64, 2);
            // Reinsertion lowers the SAH cost of the tree PLOC builds: overlapping instance bounds
            // (a forest's trees) make a TLAS's quality matter.
            ReinsertionOptimizer::default().run(&mut bvh, TLAS_REINSERTION_RATIO, None);
            // Reinsertion leaves the nodes in no particular order; depth-first order keeps each
            // subtree together in memory, so a refit's walks up the tree and its re-encoding of
            // wide nodes (whose children are their source's descendants) read nearby nodes, and
            // puts every parent before its children, so descending indices are a bottom-up order.
            bvh.reorder_in_stack_traversal_order();
            bvh.update_parents();
            self.prim_leaf = vec![NONE; self.tlas_prims.len()];
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let n = bvh.nodes[i];
                if n.is_leaf() {
                    for k in 0..n.prim_count {
                        self.prim_leaf[bvh.primitive_indices[(n.first_index + k) as usize] as usize] = i as u32;
                    }
                } else {
                    stack.extend([n.first_index as usize, n.first_index as usize + 1]);
                }
            }
            self.inner_area = inner_half_areas(&bvh);
            self.built_cost = over_root(&bvh, self.inner_area);
            self.refit_plan = RefitPlan::new(&bvh, TLAS_REFIT_SUBTREES);
            self.leaf_stale = vec![false; bvh.nodes.len()];
            self.tlas = Some(bvh);
        }
        self.stale_leaves.clear();
        self.gpu_refit_ready = false;
        self.collapse_tlas();
        self.wide_stale = vec![false; self.gpu_tlas.len()];
        self.stats.tlas_rebuilt = true;
        self.upload_tlas_all(gpu);
    }

    /// Partial re-braiding: replaces instance roots by BLAS nodes below them while the primitives
    /// stay within [`RayTracingScene::rebraid_budget`] times the instances. The node with the
    /// largest world-space box is opened first (its box is what rays meet most); a node is opened
    /// only when every child is an inner node (a leaf's triangles can only be reached through their
    /// node) and its children's summed world half areas are at most [`TLAS_REBRAID_AREA_RATIO`]
    /// times its own. Instances that have moved are not opened. Returns the primitives with their
    /// world boxes, each instance's together, its first one first.
    fn open_instances(&self, roots: Vec<(TlasPrim, Aabb, u32, Affine3A)>) -> Vec<(TlasPrim, Aabb)> {
        let budget = (f64::from(self.rebraid_budget) * roots.len() as f64).min(u32::MAX as f64) as usize;
        if budget <= roots.len() {
            return roots.into_iter().map(|(p, a, ..)| (p, a)).collect();
        }
        // Each primitive: (prim, world box, index of its instance in `roots`).
        let mut prims: Vec<(TlasPrim, Aabb, u32)> = Vec::with_capacity(budget);
        // Candidates by world half area (positive floats order as their bits).
        let mut heap = std::collections::BinaryHeap::new();
        for (i, (prim, aabb, _, _)) in roots.iter().enumerate() {
            let moved = self.slot_moved.get(prim.entry.instance as usize).copied().unwrap_or(false);
            if !moved {
                heap.push((aabb.half_area().max(0.0).to_bits(), prims.len() as u32));
            }
            prims.push((*prim, *aabb, i as u32));
        }
        let mut children: Vec<(TlasPrim, Aabb)> = Vec::with_capacity(8);
        while let Some((_, p)) = heap.pop() {
            let (prim, aabb, root) = prims[p as usize];
            let (_, _, mesh, world) = &roots[root as usize];
            let Some(blas) = self.blas(*mesh as usize) else { continue };
            let Some(node) = blas.nodes.get(prim.entry.start_node as usize) else { continue };
            children.clear();
            let mut all_inner = true;
            for s in 0..8 {
                if node.is_child_empty(s) {
                    continue;
                }
                if node.is_leaf(s) {
                    all_inner = false;
                    break;
                }
                let b = node.child_aabb(s);
                let local = (Vec3::from(b.min), Vec3::from(b.max));
                let Some(child_aabb) = world_aabb(local, world) else {
                    all_inner = false;
                    break;
                };
                let entry = TlasEntry { start_node: node.child_node_index(s), ..prim.entry };
                children.push((TlasPrim { local, entry }, child_aabb));
            }
            if !all_inner || children.is_empty() || prims.len() + children.len() - 1 > budget {
                continue;
            }
            let area: f32 = children.iter().map(|(_, a)| a.half_area()).sum();
            if area > TLAS_REBRAID_AREA_RATIO * aabb.half_area() {
                continue;
            }
            for (k, &(child, child_aabb)) in children.iter().enumerate() {
                let at = if k == 0 { p as usize } else { prims.len() };
                let item = (child, child_aabb, root);
                if k == 0 {
                    prims[at] = item
                } else {
                    prims.push(item)
                }
                heap.push((child_aabb.half_area().max(0.0).to_bits(), at as u32));
            }
        }
        // Each instance's primitives together (the refit finds an instance's by its first).
        prims.sort_by_key(|&(_, _, root)| root);
        prims.into_iter().map(|(p, a, _)| (p, a)).collect()
    }

    /// Collapses the binary TLAS into the 8-wide one the GPU walks: each wide node takes the Bvh2
    /// node it stands for and opens its largest inner descendants until it has eight children,
    /// placed in the slots of the ray octants they are nearest for. Nodes are numbered breadth
    /// first, so each node's inner children are consecutive.
    fn collapse_tlas(&mut self) {
        self.wide_source.clear();
        self.wide_children.clear();
        self.gpu_tlas.clear();
        self.gpu_entries.clear();
        let Some(bvh) = &self.tlas else { return };
        self.wide_owner = vec![NONE; bvh.nodes.len()];
        self.wide_source.push(0);
        let mut depth = vec![1usize];
        let mut next = 0;
        while next < self.wide_source.len() {
            let w = next;
            next += 1;
            let source = self.wide_source[w] as usize;
            let mut children: Vec<u32> = if bvh.nodes[source].is_leaf() {
                vec![source as u32]
            } else {
                let first = bvh.nodes[source].first_index;
                vec![first, first + 1]
            };
            while children.len() < 8 {
                let largest = children
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| !bvh.nodes[**c as usize].is_leaf())
                    .max_by(|a, b| bvh.nodes[*a.1 as usize].aabb().half_area().total_cmp(&bvh.nodes[*b.1 as usize].aabb().half_area()));
                let Some((k, &c)) = largest else { break };
                let first = bvh.nodes[c as usize].first_index;
                children[k] = first;
                children.push(first + 1);
            }
            let slots = order_slots(bvh, source, &children);
            let mut node = CwBvhNode { child_base_idx: self.wide_source.len() as u32, ..Default::default() };
            for (s, &c) in slots.iter().enumerate() {
                if c == NONE {
                    continue;
                }
                self.wide_owner[c as usize] = w as u32;
                if bvh.nodes[c as usize].is_leaf() {
                    // One entry, at the slot's offset (CWBVH leaf metadata: count 1 in unary, offset).
                    node.child_meta[s] = 0b0010_0000 | s as u8;
                } else {
                    node.child_meta[s] = 0b0010_0000 | (24 + s as u8);
                    node.imask |= 1 << s;
                    self.wide_source.push(c);
                    depth.push(depth[w] + 1);
                }
            }
            self.gpu_tlas.push(node);
            self.wide_children.push(slots);
        }
        // Entries (one vec4 each) follow the nodes (five each).
        let entries_base = (self.gpu_tlas.len() * 5) as u32;
        self.gpu_entries = vec![TlasEntry::zeroed(); self.gpu_tlas.len() * 8];
        for w in 0..self.gpu_tlas.len() {
            self.gpu_tlas[w].primitive_base_idx = entries_base + 8 * w as u32;
            for (s, &c) in self.wide_children[w].iter().enumerate() {
                if c != NONE && bvh.nodes[c as usize].is_leaf() {
                    let prim = bvh.primitive_indices[bvh.nodes[c as usize].first_index as usize];
                    self.gpu_entries[8 * w + s] = self.tlas_prims[prim as usize].entry;
                }
            }
            encode_bounds(bvh, self.wide_source[w] as usize, &self.wide_children[w], &mut self.gpu_tlas[w]);
        }
        let depth = depth.into_iter().max().unwrap_or(0);
        if depth > TLAS_STACK_SIZE {
            log::warn!("the TLAS is {depth} nodes deep, over the traversal stack of {TLAS_STACK_SIZE}: some hits may be missed");
        }
    }

    fn upload_tlas_all(&mut self, gpu: &GpuContext) {
        if self.gpu_tlas.is_empty() {
            // An empty TLAS: a root without children.
            self.gpu_tlas = vec![CwBvhNode::default()];
            self.gpu_entries = vec![TlasEntry::zeroed(); 8];
        }
        let mut bytes: Vec<u8> = Vec::with_capacity(size_of_val(self.gpu_tlas.as_slice()) + size_of_val(self.gpu_entries.as_slice()));
        bytes.extend_from_slice(bytemuck::cast_slice(&self.gpu_tlas));
        bytes.extend_from_slice(bytemuck::cast_slice(&self.gpu_entries));
        self.tlas_nodes.write(gpu, &bytes);
        self.stats.tlas_nodes_uploaded += self.gpu_tlas.len();
    }

    /// Moves the leaves of the given instances, refits their ancestors in the binary TLAS and
    /// re-encodes the wide nodes whose children changed; uploads those nodes. Returns false when the
    /// TLAS should be rebuilt instead (an instance is not in it, or quality decayed).
    ///
    /// From [`RayTracingScene::parallel_refit_from`] movers on, the subtrees of the refit plan are
    /// refitted on rayon's pool (each through its own slice of the nodes), then the few nodes above
    /// them on this thread, and the wide nodes are re-encoded in parallel: the same nodes get the
    /// same bounds as on one thread, so the TLAS is the same either way.
    fn refit_tlas(&mut self, gpu: &GpuContext, uploads: &mut Uploads, moved: &[(u32, u32, Affine3A)]) -> bool {
        // An instance that re-braiding opened and that now moves is rebuilt at its root (once: it
        // stays there), so that a refit moves one leaf per mover.
        let mut opened_mover = false;
        for &(slot, _, _) in moved {
            self.note_moved(slot);
            let prim = self.slot_prims.get(slot as usize).copied().unwrap_or(NONE);
            opened_mover |= self.tlas_prims.get(prim as usize).is_some_and(|p| p.entry.start_node != 0);
        }
        if opened_mover {
            return false;
        }
        if self.tlas_refit == TlasRefit::Gpu {
            return self.refit_tlas_on_gpu(gpu, uploads, moved);
        }
        // After GPU refits: the CPU copy catches up (its wide nodes then equal the GPU's, so none
        // is uploaded for it), and the GPU's boxes will need uploading before the next GPU refit.
        self.sync_cpu_tlas();
        self.gpu_refit_ready = false;
        let Some(mut bvh) = self.tlas.take() else { return moved.is_empty() };
        self.marked.clear();
        self.marked.resize(bvh.nodes.len(), false);
        let parallel = moved.len() >= self.parallel_refit_from && self.refit_plan.is_some();
        let started = Instant::now();
        let refit = if parallel { self.refit_subtrees_in_parallel(&mut bvh, moved) } else { self.refit_on_this_thread(&mut bvh, moved) };
        let Some(RefitOutput { dirty, area }) = refit else {
            self.tlas = Some(bvh);
            return false;
        };
        self.inner_area += area;
        if self.decayed(&bvh) {
            self.tlas = Some(bvh);
            return false;
        }
        let refitted = Instant::now();
        // The wide nodes over changed Bvh2 nodes, each once, in order (a mark per wide node, no sort).
        self.wide_marked.clear();
        self.wide_marked.resize(self.gpu_tlas.len(), false);
        mark_wide_owners(&self.wide_owner, dirty.iter().flatten(), &mut self.wide_marked);
        let (sources, children, marked) = (&self.wide_source, &self.wide_children, &self.wide_marked);
        let encode = |(w, node): (usize, &mut CwBvhNode)| {
            if marked[w] {
                encode_bounds(&bvh, sources[w] as usize, &children[w], node);
            }
        };
        if parallel {
            self.gpu_tlas.par_iter_mut().enumerate().with_min_len(64).for_each(encode);
        } else {
            self.gpu_tlas.iter_mut().enumerate().for_each(encode);
        }
        self.tlas = Some(bvh);
        let encoded = Instant::now();
        self.upload_wide_nodes(gpu, uploads);
        self.stats.tlas_refit_time = refitted - started;
        self.stats.tlas_encode_time = encoded - refitted;
        self.stats.tlas_upload_time = encoded.elapsed();
        self.stats.tlas_refitted_leaves += moved.len();
        self.stats.tlas_refit_parallel = parallel;
        true
    }

    /// The refit with [`TlasRefit::Gpu`]: the moved leaves' world boxes into the CPU copy's leaves
    /// and to the GPU, whose dispatches (recorded in `uploads`' encoder, after its copies) refit the
    /// inner nodes, measure the SAH cost and re-encode the wide ones. Returns false when the TLAS
    /// should be rebuilt instead (the last cost read back from the GPU says its quality decayed).
    fn refit_tlas_on_gpu(&mut self, gpu: &GpuContext, uploads: &mut Uploads, moved: &[(u32, u32, Affine3A)]) -> bool {
        let started = Instant::now();
        let Some(bvh) = self.tlas.as_mut() else { return moved.is_empty() };
        let mut leaves = Vec::with_capacity(moved.len());
        for &(slot, _, world) in moved {
            let prim = self.slot_prims.get(slot as usize).copied().unwrap_or(NONE) as usize;
            let Some(aabb) = self.tlas_prims.get(prim).and_then(|p| world_aabb(p.local, &world)) else { return false };
            let leaf = self.prim_leaf[prim];
            bvh.nodes[leaf as usize].set_aabb(aabb);
            if !std::mem::replace(&mut self.leaf_stale[leaf as usize], true) {
                self.stale_leaves.push(leaf);
            }
            leaves.push(gpu_refit::TlasRefitLeaf::new(leaf, &aabb));
        }
        // The rebuild test, on the cost an earlier refit of this TLAS measured (one from before a CPU
        // refit, which has run the test itself since, is dropped).
        let cost = self.gpu_refit.as_mut().and_then(|r| r.poll_cost(gpu, uploads)).filter(|_| self.gpu_refit_ready);
        self.stats.tlas_gpu_cost = cost;
        if cost.is_some_and(|cost| self.decayed_at(cost)) {
            return false;
        }
        let refitted = Instant::now();
        if let Err(error) = self.record_gpu_refit(gpu, uploads, &leaves) {
            // Refitted on the CPU from now on (this frame: rebuilt, its leaves being ahead of the GPU).
            log::error!("the TLAS refit on the GPU is not available ({error}); refitting on the CPU");
            self.tlas_refit = TlasRefit::Cpu;
            return false;
        }
        self.stats.tlas_refit_time = refitted - started;
        self.stats.tlas_upload_time = refitted.elapsed();
        self.stats.tlas_refitted_leaves += moved.len();
        self.stats.tlas_refit_on_gpu = true;
        true
    }

    /// Stages the moved leaves and records the GPU refit's dispatches after this frame's uploads,
    /// first uploading the whole binary TLAS when the GPU's copy is not this TLAS's (after a build or
    /// a CPU refit).
    fn record_gpu_refit(
        &mut self,
        gpu: &GpuContext,
        uploads: &mut Uploads,
        leaves: &[gpu_refit::TlasRefitLeaf],
    ) -> Result<(), crate::shader::ShaderError> {
        let refit = match &mut self.gpu_refit {
            Some(r) => r,
            none => none.insert(gpu_refit::GpuRefit::new(gpu)?),
        };
        let Some(bvh) = &self.tlas else { return Ok(()) };
        if !self.gpu_refit_ready {
            refit.load(gpu, bvh, &self.wide_source, &self.wide_children, &self.tlas_nodes.buffer);
            self.gpu_refit_ready = true;
        }
        refit.record(gpu, uploads, leaves, &self.tlas_nodes.buffer);
        self.stats.tlas_upload_copies += 2;
        Ok(())
    }

    /// The SAH cost of the TLAS (its inner nodes' half areas over its root's): as built, and now in
    /// the CPU's copy of the binary TLAS (summed anew; after GPU refits, as of the last
    /// [`RayTracingScene::sync_cpu_tlas`]). `None` without a TLAS.
    pub fn tlas_cost(&self) -> Option<(f64, f64)> {
        let bvh = self.tlas.as_ref()?;
        Some((self.built_cost, over_root(bvh, inner_half_areas(bvh))))
    }

    /// The SAH cost the last GPU refit measured (see [`RayTracingScene::tlas_cost`]), read now;
    /// `None` before a GPU refit. Blocks until the GPU is idle. For tests.
    pub fn read_gpu_tlas_cost(&self, gpu: &GpuContext) -> Option<f64> {
        self.gpu_refit.as_ref()?.read_cost_now(gpu)
    }

    /// Runs the last GPU refit's dispatches again (the same result: they are idempotent) between
    /// two timestamps and returns their GPU time; `None` without timestamp queries or before a GPU
    /// refit. Blocks. For benchmarks.
    pub fn time_gpu_refit(&self, gpu: &GpuContext) -> Option<Duration> {
        self.gpu_refit.as_ref().filter(|_| self.gpu_refit_ready)?.time(gpu)
    }

    /// Remembers that instance `slot` has moved: re-braiding no longer opens it.
    fn note_moved(&mut self, slot: u32) {
        let slot = slot as usize;
        if self.slot_moved.len() <= slot {
            self.slot_moved.resize(slot + 1, false);
        }
        self.slot_moved[slot] = true;
    }

    /// The refit on the frame's thread: every moved leaf, then each inner node above them once.
    fn refit_on_this_thread(&mut self, bvh: &mut Bvh2, moved: &[(u32, u32, Affine3A)]) -> Option<RefitOutput> {
        let mut leaves = Vec::with_capacity(moved.len());
        for &(slot, _, world) in moved {
            let prim = self.slot_prims.get(slot as usize).copied().unwrap_or(NONE) as usize;
            let aabb = world_aabb(self.tlas_prims.get(prim)?.local, &world)?;
            leaves.push((self.prim_leaf[prim], aabb));
        }
        let out = self.refit_leaves_on_this_thread(bvh, &leaves);
        Some(RefitOutput { dirty: vec![out.dirty], area: out.area })
    }

    /// Sets the bounds of `leaves` (Bvh2 leaf, world box) and refits every inner node above them
    /// once, on this thread (the refit marks cleared beforehand).
    fn refit_leaves_on_this_thread(&mut self, bvh: &mut Bvh2, leaves: &[(u32, Aabb)]) -> SubtreeRefit {
        let part = TlasPart { nodes: &mut bvh.nodes, marks: &mut self.marked, base: 0, stop: NONE as usize, scan_marks: true };
        let mut out = SubtreeRefit::default();
        part.refit(&bvh.parents, leaves, &[], &mut out);
        out
    }

    /// The refit on rayon's pool: the movers sorted into the plan's subtrees, each subtree with
    /// movers refitted by one task up to (not including) its root, then the roots of the changed
    /// subtrees, the movers above the cut and every node above them on this thread.
    fn refit_subtrees_in_parallel(&mut self, bvh: &mut Bvh2, moved: &[(u32, u32, Affine3A)]) -> Option<RefitOutput> {
        let plan = self.refit_plan.as_ref()?;
        let subtrees = plan.roots.len();
        self.refit_buckets.resize_with(subtrees + 1, Vec::new);
        self.refit_buckets.iter_mut().for_each(Vec::clear);
        for (k, &(slot, _, _)) in moved.iter().enumerate() {
            let prim = *self.slot_prims.get(slot as usize).filter(|&&p| p != NONE)?;
            let subtree = plan.subtree[self.prim_leaf[prim as usize] as usize];
            self.refit_buckets[if subtree == NONE { subtrees } else { subtree as usize }].push((prim, k as u32));
        }
        let (prims, prim_leaf, buckets) = (&self.tlas_prims, &self.prim_leaf, &self.refit_buckets);
        let leaves_of = |bucket: &[(u32, u32)]| -> Option<Vec<(u32, Aabb)>> {
            bucket
                .iter()
                .map(|&(prim, k)| Some((prim_leaf[prim as usize], world_aabb(prims[prim as usize].local, &moved[k as usize].2)?)))
                .collect()
        };
        // Split the nodes and marks into the subtrees' runs (in order, disjoint), keep those with movers.
        let mut parts = Vec::new();
        let (mut nodes, mut marks, mut at): (&mut [Bvh2Node], &mut [bool], usize) = (&mut bvh.nodes, &mut self.marked, 0);
        for (t, &(start, end)) in plan.runs.iter().enumerate() {
            let (start, end) = (start as usize, end as usize);
            let (run, rest) = std::mem::take(&mut nodes).split_at_mut(start - at).1.split_at_mut(end - start);
            let (run_marks, rest_marks) = std::mem::take(&mut marks).split_at_mut(start - at).1.split_at_mut(end - start);
            (nodes, marks, at) = (rest, rest_marks, end);
            if !buckets[t].is_empty() {
                let stop = plan.roots[t] as usize;
                parts.push((t, TlasPart { nodes: run, marks: run_marks, base: start, stop, scan_marks: true }));
            }
        }
        let parents = &bvh.parents;
        let results: Vec<Option<(usize, SubtreeRefit)>> = parts
            .into_par_iter()
            .map(|(t, part)| {
                let leaves = leaves_of(&buckets[t])?;
                let mut out = SubtreeRefit::default();
                part.refit(parents, &leaves, &[], &mut out);
                Some((t, out))
            })
            .collect();
        // Above the cut: the roots of the subtrees that changed, and the movers there.
        let mut roots = Vec::new();
        let mut dirty = Vec::with_capacity(results.len() + 1);
        let mut area = 0.0;
        for (t, out) in results.into_iter().collect::<Option<Vec<_>>>()? {
            if !out.dirty.is_empty() {
                roots.push(plan.roots[t]);
            }
            area += out.area;
            dirty.push(out.dirty);
        }
        let leaves = leaves_of(&buckets[subtrees])?;
        let top = TlasPart { nodes: &mut bvh.nodes, marks: &mut self.marked, base: 0, stop: NONE as usize, scan_marks: false };
        let mut out = SubtreeRefit::default();
        top.refit(&bvh.parents, &leaves, &roots, &mut out);
        dirty.push(out.dirty);
        Some(RefitOutput { dirty, area: area + out.area })
    }

    /// Uploads the wide nodes marked in `wide_marked`: changed nodes near each other in one copy.
    fn upload_wide_nodes(&mut self, gpu: &GpuContext, uploads: &mut Uploads) {
        let gap = TLAS_UPLOAD_GAP_BYTES / size_of::<CwBvhNode>();
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for w in (0..self.wide_marked.len()).filter(|&w| self.wide_marked[w]) {
            match runs.last_mut() {
                Some((_, end)) if w <= *end + gap => *end = w + 1,
                _ => runs.push((w, w + 1)),
            }
            self.stats.tlas_nodes_uploaded += 1;
        }
        for &(a, b) in &runs {
            let offset = (a * size_of::<CwBvhNode>()) as u64;
            uploads.write(gpu, &self.tlas_nodes.buffer, offset, bytemuck::cast_slice(&self.gpu_tlas[a..b]));
        }
        self.stats.tlas_upload_copies += runs.len();
    }
}

/// The summed half areas of the binary TLAS's inner nodes (its root's included).
fn inner_half_areas(bvh: &Bvh2) -> f64 {
    bvh.nodes.iter().filter(|n| !n.is_leaf()).map(|n| f64::from(n.aabb().half_area())).sum()
}

/// `area` over the root's half area: with [`inner_half_areas`], the normalized SAH cost.
fn over_root(bvh: &Bvh2, area: f64) -> f64 {
    area / f64::from(bvh.nodes[0].aabb().half_area()).max(f64::MIN_POSITIVE)
}

/// Marks in `marks` (one per wide node) the wide node that holds each of the `dirty` Bvh2 nodes as a
/// child (inner nodes collapsed away have none: `NONE` in `wide_owner`).
fn mark_wide_owners<'a>(wide_owner: &[u32], dirty: impl IntoIterator<Item = &'a u32>, marks: &mut [bool]) {
    for &i in dirty {
        if let Some(&w) = wide_owner.get(i as usize).filter(|&&w| w != NONE) {
            marks[w as usize] = true;
        }
    }
}

/// What a refit changed: the Bvh2 nodes whose bounds changed (in lists, one per part refitted) and
/// the change of the inner nodes' summed half areas.
struct RefitOutput {
    dirty: Vec<Vec<u32>>,
    area: f64,
}

/// What refitting one part of the binary TLAS changed.
#[derive(Default)]
struct SubtreeRefit {
    /// Bvh2 nodes whose bounds changed (the moved leaves included).
    dirty: Vec<u32>,
    /// Change of the summed half areas of its inner nodes.
    area: f64,
}

/// A part of the binary TLAS to refit: the nodes `base..base + nodes.len()` and their refit marks,
/// holding every node the refit touches.
struct TlasPart<'a> {
    nodes: &'a mut [Bvh2Node],
    marks: &'a mut [bool],
    base: usize,
    /// The node the walks up the tree stop below (a subtree's root; `usize::MAX`: none, up to the root).
    stop: usize,
    /// Whether many marked nodes are taken by a scan of the marks rather than sorted (only where
    /// every mark in `marks` is this refit's).
    scan_marks: bool,
}

impl TlasPart<'_> {
    /// Sets the bounds of the moved `leaves`, then recomputes each inner node above them (and each of
    /// `roots`, refitted subtrees' roots, with the nodes above them) once, children before parents:
    /// descending indices, as the build put every parent before its children.
    fn refit(self, parents: &[u32], leaves: &[(u32, Aabb)], roots: &[u32], out: &mut SubtreeRefit) {
        let Self { nodes, marks, base, stop, scan_marks } = self;
        let mut inner: Vec<usize> = Vec::new();
        // Marks the inner nodes above `index` (below `stop`) not yet marked; they are refitted below.
        let climb = |marks: &mut [bool], inner: &mut Vec<usize>, mut index: usize| {
            while index != 0 {
                index = parents[index] as usize;
                if index == stop || marks[index - base] {
                    break;
                }
                marks[index - base] = true;
                inner.push(index);
            }
        };
        for &(leaf, aabb) in leaves {
            nodes[leaf as usize - base].set_aabb(aabb);
            out.dirty.push(leaf);
            climb(marks, &mut inner, leaf as usize);
        }
        for &root in roots {
            let root = root as usize;
            if !marks[root - base] {
                marks[root - base] = true;
                inner.push(root);
                climb(marks, &mut inner, root);
            }
        }
        // Few nodes: sort them; many (a thousand random movers touch most of the tree): take the
        // marked ones from the end down, which costs no sort.
        if scan_marks && inner.len() * 16 >= nodes.len() {
            inner.clear();
            inner.extend((0..nodes.len()).rev().filter(|&i| marks[i]).map(|i| i + base));
        } else {
            inner.sort_unstable_by(|a, b| b.cmp(a));
        }
        for index in inner {
            let first = nodes[index - base].first_index as usize - base;
            let union = nodes[first].aabb().union(nodes[first + 1].aabb());
            let node = &mut nodes[index - base];
            if *node.aabb() != union {
                out.area += f64::from(union.half_area()) - f64::from(node.aabb().half_area());
                node.set_aabb(union);
                out.dirty.push(index as u32);
            }
        }
    }
}

/// The binary TLAS cut into subtrees for a parallel refit. The build orders the nodes depth first,
/// so each subtree's descendants are one contiguous run of nodes, which one task refits through its
/// own slice; the nodes above the cut (the subtrees' roots included) are few.
struct RefitPlan {
    /// Each subtree's root, in the order of their runs.
    roots: Vec<u32>,
    /// Each subtree's descendants: `start..end` in the Bvh2's nodes.
    runs: Vec<(u32, u32)>,
    /// The subtree each Bvh2 node descends from (its index in `roots`); `NONE` above the cut.
    subtree: Vec<u32>,
}

impl RefitPlan {
    /// Cuts `bvh` into at most `count` subtrees, opening the largest first; `None` when it is too
    /// small to cut or a subtree's descendants are not contiguous (then refits stay on one thread).
    fn new(bvh: &Bvh2, count: usize) -> Option<Self> {
        if !bvh.children_are_ordered_after_parents || bvh.nodes.len() < 3 {
            return None;
        }
        let n = bvh.nodes.len();
        let mut size = vec![1u32; n];
        for i in (0..n).rev() {
            if !bvh.nodes[i].is_leaf() {
                let first = bvh.nodes[i].first_index as usize;
                size[i] = 1 + size[first] + size[first + 1];
            }
        }
        let mut cut = std::collections::BinaryHeap::from([(size[0], 0u32)]);
        while cut.len() < count {
            match cut.peek() {
                Some(&(s, i)) if s > 1 => {
                    cut.pop();
                    let first = bvh.nodes[i as usize].first_index;
                    cut.extend([(size[first as usize], first), (size[first as usize + 1], first + 1)]);
                }
                _ => break,
            }
        }
        let mut roots: Vec<u32> = cut.into_iter().filter(|&(s, _)| s > 1).map(|(_, i)| i).collect();
        roots.sort_unstable_by_key(|&r| bvh.nodes[r as usize].first_index);
        let mut subtree = vec![NONE; n];
        let mut runs = Vec::with_capacity(roots.len());
        let mut stack = Vec::new();
        for (t, &root) in roots.iter().enumerate() {
            let start = bvh.nodes[root as usize].first_index;
            let run = start..start + size[root as usize] - 1;
            stack.extend([start, start + 1]);
            while let Some(i) = stack.pop() {
                if !run.contains(&i) || subtree[i as usize] != NONE {
                    return None;
                }
                subtree[i as usize] = t as u32;
                let node = &bvh.nodes[i as usize];
                if !node.is_leaf() {
                    stack.extend([node.first_index, node.first_index + 1]);
                }
            }
            runs.push((run.start, run.end));
        }
        Some(Self { roots, runs, subtree })
    }
}

/// The share of the traversal stack in `ray_tracing.inc.wgsl` (`RT_STACK_SIZE`, shared by both
/// levels) that a TLAS this deep leaves to the BLAS walks.
pub const TLAS_STACK_SIZE: usize = 24;

/// Places up to eight children in the slots of a wide node so that, for a ray of octant `s`, the
/// child in slot `s` is the one nearest the ray's start (greedy assignment on the offsets of the
/// children's centres from the node's, as obvhs orders its CWBVH children).
fn order_slots(bvh: &Bvh2, source: usize, children: &[u32]) -> [u32; 8] {
    let centre = bvh.nodes[source].aabb().center();
    let mut cost = [[f32::MAX; 8]; 8];
    for (c, &child) in children.iter().enumerate() {
        let v = bvh.nodes[child as usize].aabb().center() - centre;
        for (s, cost) in cost[c].iter_mut().enumerate() {
            let d =
                Vec3A::new(if s & 4 != 0 { -1.0 } else { 1.0 }, if s & 2 != 0 { -1.0 } else { 1.0 }, if s & 1 != 0 { -1.0 } else { 1.0 });
            *cost = d.dot(v);
        }
    }
    let mut slots = [NONE; 8];
    let mut placed = [false; 8];
    loop {
        let mut best: Option<(usize, usize, f32)> = None;
        for c in (0..children.len()).filter(|&c| !placed[c]) {
            for s in (0..8).filter(|&s| slots[s] == NONE) {
                if best.is_none_or(|(_, _, b)| cost[c][s] < b) {
                    best = Some((c, s, cost[c][s]));
                }
            }
        }
        let Some((c, s, _)) = best else { break };
        placed[c] = true;
        slots[s] = children[c];
    }
    slots
}

/// The smallest extent a wide node's quantization step is computed from (`encode_bounds`; the GPU
/// refit's `ENCODE_MIN_EXTENT_BITS` holds its bits).
pub const TLAS_ENCODE_MIN_EXTENT: f32 = 1e-20;

/// 1 / 255 as `encode_bounds` multiplies by it (the GPU refit's `ENCODE_INV_255_BITS` holds its bits).
pub const TLAS_ENCODE_INV_255: f32 = 1.0 / 255.0;

/// Sets a wide node's bounds (origin, exponents) and its children's quantized boxes from the Bvh2's
/// current bounds, rounding outwards (as obvhs encodes a CWBVH node).
fn encode_bounds(bvh: &Bvh2, source: usize, children: &[u32; 8], node: &mut CwBvhNode) {
    let aabb = bvh.nodes[source].aabb();
    let p = aabb.min;
    // The smallest power of two at least extent / 255 (from the float's bits: refits re-encode
    // many nodes), so that 255 steps span the node.
    let step = |extent: f32| {
        let bits = (extent.max(TLAS_ENCODE_MIN_EXTENT) * TLAS_ENCODE_INV_255).to_bits();
        let exponent = bits & 0x7f80_0000;
        f32::from_bits(if bits & 0x007f_ffff != 0 { exponent + 0x0080_0000 } else { exponent })
    };
    let extent = aabb.max - aabb.min;
    let e = Vec3A::new(step(extent.x), step(extent.y), step(extent.z));
    let rcp_e = 1.0 / e;
    node.p = p.into();
    node.e = [(e.x.to_bits() >> 23) as u8, (e.y.to_bits() >> 23) as u8, (e.z.to_bits() >> 23) as u8];
    for (s, &c) in children.iter().enumerate() {
        if c == NONE {
            continue;
        }
        let child = bvh.nodes[c as usize].aabb();
        let lo = ((child.min - p) * rcp_e).floor().clamp(Vec3A::ZERO, Vec3A::splat(255.0));
        let hi = ((child.max - p) * rcp_e).ceil().clamp(Vec3A::ZERO, Vec3A::splat(255.0));
        node.child_min_x[s] = lo.x as u8;
        node.child_min_y[s] = lo.y as u8;
        node.child_min_z[s] = lo.z as u8;
        node.child_max_x[s] = hi.x as u8;
        node.child_max_y[s] = hi.y as u8;
        node.child_max_z[s] = hi.z as u8;
    }
}

/// A finished BLAS build on its way from a worker thread: the mesh, the generation of the request
/// ([`BlasBuildQuality`] changes start a new one) and the BLAS.
struct BuiltBlas {
    index: usize,
    generation: u32,
    blas: Arc<Blas>,
}

/// Whether BLAS builds block the frame (headless, deterministic) or run in the background.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct WaitForBlasBuilds(pub bool);

/// The resources that shape BLAS builds, each optional.
#[derive(bevy_ecs::system::SystemParam)]
pub struct BlasBuildSettings<'w> {
    wait: Option<Res<'w, WaitForBlasBuilds>>,
    quality: Option<Res<'w, BlasBuildQuality>>,
    hook: Option<Res<'w, BlasBuildHook>>,
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

/// Traces arbitrary rays with `engine/shaders/trace_rays.wgsl`: the GPU side of the CPU-reference tests and
/// of the trace benchmark.
pub struct RayTracer {
    /// The `trace_rays` compute pipeline and its bindings.
    pub program: crate::shader::Program<wgpu::ComputePipeline>,
}

/// Workgroups of 64 threads covering `count` items, split into (x ≤ 65535, y) as the shader expects.
pub fn ray_workgroups(count: u32) -> (u32, u32) {
    let groups = count.div_ceil(64).max(1);
    (groups.min(65535), groups.div_ceil(65535))
}

impl RayTracer {
    /// Builds the pipeline of `trace_rays.wgsl`.
    pub fn new(gpu: &GpuContext) -> Result<Self, crate::shader::ShaderError> {
        Ok(Self { program: crate::shader::compute_program(&gpu.device, "trace_rays.wgsl", "main", "trace_rays")? })
    }

    /// Bind groups for tracing `rays` into `results` (both storage buffers) with `params` (uniform).
    pub fn bind_groups(
        &self,
        gpu: &GpuContext,
        scene: &GpuScene,
        rt: &RayTracingScene,
        params: &wgpu::Buffer,
        rays: &wgpu::Buffer,
        results: &wgpu::Buffer,
    ) -> [wgpu::BindGroup; 2] {
        [
            self.program.bind_group(&gpu.device, 0, &rt.scene_bindings(scene)),
            self.program.bind_group(
                &gpu.device,
                1,
                &[
                    ("trace_params", params.as_entire_binding()),
                    ("trace_rays", rays.as_entire_binding()),
                    ("trace_results", results.as_entire_binding()),
                ],
            ),
        ]
    }

    /// Traces `rays` (closest hit, and any hit when asked) and reads the results back. Blocks.
    pub fn trace(
        &self,
        gpu: &GpuContext,
        scene: &GpuScene,
        rt: &RayTracingScene,
        rays: &[cpu::GpuRay],
        with_any_hit: bool,
    ) -> Vec<cpu::TraceResult> {
        use wgpu::util::DeviceExt;
        let count = rays.len() as u32;
        let params = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("trace_params"),
            contents: bytemuck::cast_slice(&[count, u32::from(with_any_hit), 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let ray_buffer = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("trace_rays"),
            contents: if rays.is_empty() { &[0; 32] } else { bytemuck::cast_slice(rays) },
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = (rays.len().max(1) * size_of::<cpu::TraceResult>()) as u64;
        let results = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace_results"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace_results_readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let groups = self.bind_groups(gpu, scene, rt, &params, &ray_buffer, &results);
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("trace_rays") });
        crate::gpu::dispatch(&mut encoder, "trace_rays", &self.program.pipeline, &[&groups[0], &groups[1]], ray_workgroups(count));
        encoder.copy_buffer_to_buffer(&results, 0, &readback, 0, size);
        gpu.queue.submit([encoder.finish()]);
        readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        gpu.wait_idle();
        let mapped = readback.slice(..).get_mapped_range().expect("mapped after wait");
        let mut out: Vec<cpu::TraceResult> = bytemuck::pod_collect_to_vec(&mapped);
        drop(mapped);
        readback.unmap();
        out.truncate(rays.len());
        out
    }
}

//! The BLASes: their build quality, one mesh's build ([`Blas`]), their progress and hook, the
//! requests that build them (in the frame or on a worker thread), their arrival and their upload
//! into the shared buffers with the meshes' [`GpuBlas`] records.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bevy_ecs::prelude::*;
use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::triangle::Triangle;
use rayon::prelude::*;

use super::{NONE, RayTracingScene};
use crate::gpu::GpuContext;
use crate::render::GpuScene;
use crate::scene::{Assets, Mesh};

/// Meshes with more triangles than this get their BLAS built on a worker thread.
pub const ASYNC_BLAS_TRIANGLES: usize = 200_000;

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

impl RayTracingScene {
    /// The BLAS of mesh `index`, once built.
    pub fn blas(&self, index: usize) -> Option<&Blas> {
        self.blas.get(index).and_then(|b| b.as_deref())
    }

    /// Starts BLAS builds for meshes added since the last call: small ones now, in parallel on
    /// rayon's pool, large ones one after the other on a worker thread of their own (so that they
    /// never hold up the pool a refit runs on). Tells `hook` of the progress.
    pub(super) fn request_blas(&mut self, meshes: &Assets<Mesh>, quality: BlasBuildQuality, hook: Option<&BlasBuildHook>) {
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
    pub(super) fn receive_blas(&mut self, wait: bool) -> bool {
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
    pub(super) fn upload_blas(&mut self, gpu: &GpuContext, scene: &GpuScene) {
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
}

/// A finished BLAS build on its way from a worker thread: the mesh, the generation of the request
/// ([`BlasBuildQuality`] changes start a new one) and the BLAS.
pub(super) struct BuiltBlas {
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
    pub(super) wait: Option<Res<'w, WaitForBlasBuilds>>,
    pub(super) quality: Option<Res<'w, BlasBuildQuality>>,
    pub(super) hook: Option<Res<'w, BlasBuildHook>>,
}

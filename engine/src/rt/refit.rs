//! The TLAS refit when instances move: where it runs ([`TlasRefit`]), the moved leaves and their
//! ancestors refitted on the CPU (on the frame's thread or, through the refit plan, on rayon's
//! pool) or on the GPU (`gpu_refit.rs`), the rebuild test on the SAH cost, the CPU copy brought up
//! to date after GPU refits, and the changed wide nodes' upload.

use std::time::{Duration, Instant};

use glam::Affine3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::node::CwBvhNode;
use rayon::prelude::*;

use super::collapse::encode_bounds;
use super::refit_plan::{SubtreeRefit, TlasPart};
use super::tlas::over_root;
use super::{NONE, RayTracingScene, gpu_refit, world_aabb};
use crate::gpu::{GpuContext, Uploads};

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
    /// back every [`TLAS_GPU_COST_READ_EVERY`](super::TLAS_GPU_COST_READ_EVERY) refits, a frame or two late (nothing waits), for the
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

impl RayTracingScene {
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

    /// Moves the leaves of the given instances, refits their ancestors in the binary TLAS and
    /// re-encodes the wide nodes whose children changed; uploads those nodes. Returns false when the
    /// TLAS should be rebuilt instead (an instance is not in it, or quality decayed).
    ///
    /// From [`RayTracingScene::parallel_refit_from`] movers on, the subtrees of the refit plan are
    /// refitted on rayon's pool (each through its own slice of the nodes), then the few nodes above
    /// them on this thread, and the wide nodes are re-encoded in parallel: the same nodes get the
    /// same bounds as on one thread, so the TLAS is the same either way.
    pub(super) fn refit_tlas(&mut self, gpu: &GpuContext, uploads: &mut Uploads, moved: &[(u32, u32, Affine3A)]) -> bool {
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
pub(super) struct RefitOutput {
    pub(super) dirty: Vec<Vec<u32>>,
    pub(super) area: f64,
}

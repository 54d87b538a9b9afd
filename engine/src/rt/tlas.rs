//! The TLAS's leaves ([`TlasEntry`]) and its build: the binary BVH over the instances' world
//! bounds (static groups and re-braided BLAS nodes among them), its upload and its SAH cost. The
//! wide nodes are collapsed from it in `collapse.rs`; re-braiding is in `rebraid.rs`.

use bytemuck::{Pod, Zeroable};
use glam::{Affine3A, Vec3};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ploc::{PlocBuilder, PlocSearchDistance, SortPrecision};

use super::refit_plan::{RefitPlan, TLAS_REFIT_SUBTREES};
use super::{NONE, RayTracingScene, world_aabb};
use crate::gpu::GpuContext;
use crate::render::GpuScene;

/// Share of TLAS nodes the reinsertion optimizer revisits after a build.
pub const TLAS_REINSERTION_RATIO: f32 = 0.1;

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
pub(super) struct TlasPrim {
    pub(super) local: (Vec3, Vec3),
    pub(super) entry: TlasEntry,
}

impl RayTracingScene {
    /// The TLAS as uploaded (CPU copy): its 8-wide nodes and their entries, eight per node. After
    /// GPU refits ([`TlasRefit::Gpu`](super::TlasRefit::Gpu)) the nodes are those of the last [`RayTracingScene::sync_cpu_tlas`].
    pub fn tlas_cpu(&self) -> (&[CwBvhNode], &[TlasEntry]) {
        (&self.gpu_tlas, &self.gpu_entries)
    }

    /// The wide TLAS nodes as the GPU holds them, read back (as many as [`RayTracingScene::tlas_cpu`]
    /// has). Blocks until the GPU is idle. For tests of the GPU refit.
    pub fn read_tlas_nodes(&self, gpu: &GpuContext) -> Vec<CwBvhNode> {
        let bytes = crate::gpu::readback::read_buffer(gpu, &self.tlas_nodes.buffer);
        bytemuck::pod_collect_to_vec(&bytes[..size_of_val(self.gpu_tlas.as_slice())])
    }

    /// TLAS primitives (instance leaves and, with re-braiding, the opened BLAS nodes) in the TLAS.
    pub fn tlas_primitive_count(&self) -> usize {
        self.tlas_prims.len()
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
    pub(super) fn rebuild_tlas(&mut self, gpu: &GpuContext, scene: &GpuScene) {
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

    pub(super) fn upload_tlas_all(&mut self, gpu: &GpuContext) {
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

    /// The SAH cost of the TLAS (its inner nodes' half areas over its root's): as built, and now in
    /// the CPU's copy of the binary TLAS (summed anew; after GPU refits, as of the last
    /// [`RayTracingScene::sync_cpu_tlas`]). `None` without a TLAS.
    pub fn tlas_cost(&self) -> Option<(f64, f64)> {
        let bvh = self.tlas.as_ref()?;
        Some((self.built_cost, over_root(bvh, inner_half_areas(bvh))))
    }
}

/// The summed half areas of the binary TLAS's inner nodes (its root's included).
pub(super) fn inner_half_areas(bvh: &Bvh2) -> f64 {
    bvh.nodes.iter().filter(|n| !n.is_leaf()).map(|n| f64::from(n.aabb().half_area())).sum()
}

/// `area` over the root's half area: with [`inner_half_areas`], the normalized SAH cost.
pub(super) fn over_root(bvh: &Bvh2, area: f64) -> f64 {
    area / f64::from(bvh.nodes[0].aabb().half_area()).max(f64::MIN_POSITIVE)
}

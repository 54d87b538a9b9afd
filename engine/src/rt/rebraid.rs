//! Partial re-braiding (Benthin, Woop, Wald and Áfra, HPG 2017): static instances' largest BLAS
//! nodes opened into TLAS leaves of their own, within a budget; instances that have moved stay one
//! leaf.

use glam::{Affine3A, Vec3};
use obvhs::aabb::Aabb;

use super::tlas::TlasPrim;
use super::{RayTracingScene, TlasEntry, world_aabb};

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

impl RayTracingScene {
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

    /// Partial re-braiding: replaces instance roots by BLAS nodes below them while the primitives
    /// stay within [`RayTracingScene::rebraid_budget`] times the instances. The node with the
    /// largest world-space box is opened first (its box is what rays meet most); a node is opened
    /// only when every child is an inner node (a leaf's triangles can only be reached through their
    /// node) and its children's summed world half areas are at most [`TLAS_REBRAID_AREA_RATIO`]
    /// times its own. Instances that have moved are not opened. Returns the primitives with their
    /// world boxes, each instance's together, its first one first.
    pub(super) fn open_instances(&self, roots: Vec<(TlasPrim, Aabb, u32, Affine3A)>) -> Vec<(TlasPrim, Aabb)> {
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

    /// Remembers that instance `slot` has moved: re-braiding no longer opens it.
    pub(super) fn note_moved(&mut self, slot: u32) {
        let slot = slot as usize;
        if self.slot_moved.len() <= slot {
            self.slot_moved.resize(slot + 1, false);
        }
        self.slot_moved[slot] = true;
    }
}

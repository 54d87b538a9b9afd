//! The refit plan: the binary TLAS cut into subtrees whose nodes are contiguous, each refitted
//! through its own slice on rayon's pool, then the few nodes above them; and the refit of one part
//! of the binary TLAS ([`TlasPart`]) that both the parallel refit and the one on the frame's
//! thread use.

use glam::Affine3A;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::node::Bvh2Node;
use rayon::prelude::*;

use super::refit::RefitOutput;
use super::{NONE, RayTracingScene, world_aabb};

/// Subtrees the binary TLAS is cut into for a parallel refit: several per core, so that movers spread
/// unevenly over the scene still keep every core busy.
pub(super) const TLAS_REFIT_SUBTREES: usize = 128;

impl RayTracingScene {
    /// The refit on rayon's pool: the movers sorted into the plan's subtrees, each subtree with
    /// movers refitted by one task up to (not including) its root, then the roots of the changed
    /// subtrees, the movers above the cut and every node above them on this thread.
    pub(super) fn refit_subtrees_in_parallel(&mut self, bvh: &mut Bvh2, moved: &[(u32, u32, Affine3A)]) -> Option<RefitOutput> {
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
}

/// What refitting one part of the binary TLAS changed.
#[derive(Default)]
pub(super) struct SubtreeRefit {
    /// Bvh2 nodes whose bounds changed (the moved leaves included).
    pub(super) dirty: Vec<u32>,
    /// Change of the summed half areas of its inner nodes.
    pub(super) area: f64,
}

/// A part of the binary TLAS to refit: the nodes `base..base + nodes.len()` and their refit marks,
/// holding every node the refit touches.
pub(super) struct TlasPart<'a> {
    pub(super) nodes: &'a mut [Bvh2Node],
    pub(super) marks: &'a mut [bool],
    pub(super) base: usize,
    /// The node the walks up the tree stop below (a subtree's root; `usize::MAX`: none, up to the root).
    pub(super) stop: usize,
    /// Whether many marked nodes are taken by a scan of the marks rather than sorted (only where
    /// every mark in `marks` is this refit's).
    pub(super) scan_marks: bool,
}

impl TlasPart<'_> {
    /// Sets the bounds of the moved `leaves`, then recomputes each inner node above them (and each of
    /// `roots`, refitted subtrees' roots, with the nodes above them) once, children before parents:
    /// descending indices, as the build put every parent before its children.
    pub(super) fn refit(self, parents: &[u32], leaves: &[(u32, Aabb)], roots: &[u32], out: &mut SubtreeRefit) {
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
pub(super) struct RefitPlan {
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
    pub(super) fn new(bvh: &Bvh2, count: usize) -> Option<Self> {
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

//! The binary TLAS collapsed into the 8-wide one the GPU walks: the wide nodes, their children's
//! slots by ray octant and the quantized bounds each wide node is encoded with (on a build, and
//! again on a CPU refit).

use bytemuck::Zeroable;
use glam::Vec3A;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::node::CwBvhNode;

use super::{NONE, RayTracingScene, TlasEntry};

/// The share of the traversal stack in `ray_tracing.inc.wgsl` (`RT_STACK_SIZE`, shared by both
/// levels) that a TLAS this deep leaves to the BLAS walks.
pub const TLAS_STACK_SIZE: usize = 24;

impl RayTracingScene {
    /// Collapses the binary TLAS into the 8-wide one the GPU walks: each wide node takes the Bvh2
    /// node it stands for and opens its largest inner descendants until it has eight children,
    /// placed in the slots of the ray octants they are nearest for. Nodes are numbered breadth
    /// first, so each node's inner children are consecutive.
    pub(super) fn collapse_tlas(&mut self) {
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
}

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
pub(super) fn encode_bounds(bvh: &Bvh2, source: usize, children: &[u32; 8], node: &mut CwBvhNode) {
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

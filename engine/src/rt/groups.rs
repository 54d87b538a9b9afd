//! Static groups: static instances whose world boxes overlap, traced through one BLAS.
//!
//! A ray that crosses overlapping instances enters each of them and walks each BLAS from its root
//! (the cathedral's walls, vaults, columns and floor all span the nave: 2.15 instances a ray). A
//! group is built over the triangles of all its members, in the space of one of them (its frame
//! instance), so that the ray enters once and one BVH sorts their triangles together. Each triangle
//! keeps its mesh triangle index and carries its member's instance slot, which the hit reports
//! (`rt_walk_hit` in `ray_tracing.inc.wgsl`): shading sees the member's instance, mesh and
//! material, as without the group.
//!
//! Members are instances whose mesh no other live instance uses (a group copies their triangles:
//! instanced meshes such as a forest's trees would be copied thousands of times) and that have
//! never moved. Candidates are clustered by overlap, and a cluster becomes a group only where rays
//! traced on the CPU through the group do less work than through its members entered one by one
//! (see [`group_costs`]). A member that moves dissolves its group on the TLAS rebuild that follows;
//! the others may be grouped again.

use std::collections::HashSet;
use std::sync::Arc;

use glam::{Affine3A, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::triangle::Triangle;
use rayon::prelude::*;

use super::{Blas, BlasBuildQuality, NONE, RayTracingScene, world_aabb};

/// Two candidates join one cluster when the overlap of their world boxes holds at least this share
/// of the smaller box's volume (boxes padded by [`GROUP_OVERLAP_PADDING`] of the larger one's
/// diagonal, so that flat boxes — a floor, a wall quad — have a volume).
pub const GROUP_OVERLAP: f32 = 0.25;

/// Padding of the boxes in the overlap test, as a share of the larger box's diagonal.
pub const GROUP_OVERLAP_PADDING: f32 = 0.01;

/// The most triangles a group holds: its BLAS is built in the frame that forms it (2-core VM, High
/// build: about 3 µs a triangle), and its triangles are a second copy of its members'.
pub const GROUP_MAX_TRIANGLES: usize = 1_000_000;

/// The cost estimate's price of a node test, in traversal loop steps (one a node).
pub const GROUP_NODE_COST: f64 = 1.0;
/// The cost estimate's price of a triangle test (one loop step a triangle).
pub const GROUP_TRIANGLE_COST: f64 = 1.0;
/// The cost estimate's price of entering an instance: the ray's transform and the TLAS's state
/// pushed (counted steps say about half a step; its matrix product and stack writes cost more
/// than a step's node test).
pub const GROUP_ENTER_COST: f64 = 1.0;

/// A static group and where its BLAS lives on the GPU.
#[derive(Clone, Debug)]
pub(crate) struct StaticGroup {
    /// Its members (slot, mesh, world transform), by slot: the group stands while each is live there
    /// with this mesh and this transform.
    pub members: Vec<(u32, u32, Affine3A)>,
    /// The member whose space the BLAS is in: its TLAS entry's instance.
    pub frame: u32,
    pub blas: Arc<Blas>,
    /// Where its BLAS lives in the shared buffers (`NONE`: not uploaded, over the buffer limit).
    pub node_offset: u32,
    pub triangle_offset: u32,
}

/// A cluster's identity for the cache of clusters that were not worth a group: (slot, mesh,
/// transform's bits) of each member.
pub(crate) type ClusterKey = Vec<(u32, u32, [u32; 12])>;

fn cluster_key(members: &[(u32, u32, Affine3A)]) -> ClusterKey {
    members.iter().map(|&(s, m, w)| (s, m, w.to_cols_array().map(f32::to_bits))).collect()
}

/// Whether static instances that overlap are traced through shared BLASes
/// ([`RayTracingScene::set_static_grouping`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StaticGrouping {
    /// Every instance is entered on its own.
    Off,
    /// Clusters of overlapping static instances become groups where the CPU estimate
    /// (`group_costs`) says rays do less work through the group (the default). Costs the group
    /// BLAS's build and the estimate's rays (cathedral, 72,576 triangles: 146 ms on a 2-core VM)
    /// when the scene is loaded, and a second copy of the members' triangles and nodes.
    #[default]
    Estimated,
    /// Every cluster becomes a group, whatever the estimate says (for measuring it).
    Always,
}

/// The grouping state kept between TLAS builds.
#[derive(Default)]
pub(crate) struct StaticGroups {
    pub groups: Vec<StaticGroup>,
    /// Clusters whose group would cost more than its members (not tried again while they stand).
    pub rejected: HashSet<ClusterKey>,
    /// The [`BlasBuildQuality`] the groups were built at.
    pub quality: Option<BlasBuildQuality>,
    /// Whether `rejected` was filled under [`StaticGrouping::Always`].
    pub always: bool,
}

impl RayTracingScene {
    /// Forms, keeps and dissolves static groups for the live `instances` (slot, mesh, world).
    /// Returns true when the groups changed (the BLAS buffers are then uploaded again). While BLAS
    /// builds are outstanding only groups that still stand are kept: none is formed.
    pub(crate) fn update_static_groups(&mut self, instances: &[(u32, u32, Affine3A)]) -> bool {
        let before = self.static_groups.groups.len();
        if self.static_groups.quality != Some(self.blas_quality) {
            self.static_groups = StaticGroups { quality: Some(self.blas_quality), ..Default::default() };
        }
        if self.static_grouping == StaticGrouping::Off {
            self.static_groups.groups.clear();
            return before != 0;
        }
        let candidates = self.group_candidates(instances);
        let clusters = clusters(&candidates);
        let standing: HashSet<ClusterKey> = clusters.iter().map(|c| cluster_key(c)).collect();
        if self.static_groups.always != (self.static_grouping == StaticGrouping::Always) {
            // The rejections were made under the other rule.
            self.static_groups.rejected.clear();
            self.static_groups.always = self.static_grouping == StaticGrouping::Always;
        }
        let old = std::mem::take(&mut self.static_groups.groups);
        let kept: Vec<StaticGroup> = old.into_iter().filter(|g| standing.contains(&cluster_key(&g.members))).collect();
        let mut changed = kept.len() != before;
        self.static_groups.groups = kept;
        self.static_groups.rejected.retain(|k| standing.contains(k));
        if self.outstanding == 0 {
            let known: HashSet<ClusterKey> = self.static_groups.groups.iter().map(|g| cluster_key(&g.members)).collect();
            let new: Vec<&Vec<(u32, u32, Affine3A)>> = clusters
                .iter()
                .filter(|c| {
                    let k = cluster_key(c);
                    !known.contains(&k) && !self.static_groups.rejected.contains(&k)
                })
                .collect();
            let (quality, always) = (self.blas_quality, self.static_grouping == StaticGrouping::Always);
            let built: Vec<Option<StaticGroup>> = new.par_iter().map(|c| self.build_group(c, quality, always)).collect();
            for (c, group) in new.into_iter().zip(built) {
                match group {
                    Some(g) => {
                        self.static_groups.groups.push(g);
                        changed = true;
                    }
                    None => {
                        self.static_groups.rejected.insert(cluster_key(c));
                    }
                }
            }
        }
        changed
    }

    /// Live instances that may join a group: never moved, their mesh used by no other live
    /// instance, their BLAS built, uploaded and small enough, with valid world bounds.
    fn group_candidates(&self, instances: &[(u32, u32, Affine3A)]) -> Vec<((u32, u32, Affine3A), Aabb)> {
        let mut uses = std::collections::HashMap::<u32, u32>::new();
        for &(_, mesh, _) in instances {
            *uses.entry(mesh).or_default() += 1;
        }
        instances
            .iter()
            .filter(|&&(slot, mesh, _)| {
                uses[&mesh] == 1
                    && !self.slot_moved.get(slot as usize).copied().unwrap_or(false)
                    && self.gpu_blas.get(mesh as usize).is_some_and(|b| b.node_offset != NONE)
            })
            .filter_map(|&(slot, mesh, world)| {
                let blas = self.blas(mesh as usize)?;
                (blas.triangles.len() <= GROUP_MAX_TRIANGLES).then_some(())?;
                Some(((slot, mesh, world), world_aabb(blas.bounds?, &world)?))
            })
            .collect()
    }

    /// The group of a cluster, when its estimated traversal work (`group_costs`) is below its
    /// members' one by one (or `always`); `None` otherwise (or when it would be too large, or its
    /// frame's transform cannot be inverted).
    fn build_group(&self, members: &[(u32, u32, Affine3A)], quality: BlasBuildQuality, always: bool) -> Option<StaticGroup> {
        let blases: Vec<&Blas> = members.iter().map(|&(_, mesh, _)| self.blas(mesh as usize)).collect::<Option<_>>()?;
        if blases.iter().map(|b| b.triangles.len()).sum::<usize>() > GROUP_MAX_TRIANGLES {
            return None;
        }
        // The frame: the member with the largest world box (a building's shell, not a detail in it).
        let world_area = |k: usize| blases[k].bounds.and_then(|b| world_aabb(b, &members[k].2)).map_or(0.0, |a| a.half_area());
        let frame = (0..members.len()).max_by(|&a, &b| world_area(a).total_cmp(&world_area(b)))?;
        let frame_world = members[frame].2;
        let frame_from_world = frame_world.inverse();
        if !frame_from_world.to_cols_array().iter().all(|v| v.is_finite()) {
            return None;
        }
        let started = std::time::Instant::now();
        let mut tris = Vec::new();
        let mut tags = Vec::new();
        for (&(slot, _, world), blas) in members.iter().zip(&blases) {
            let to_frame = frame_from_world * world;
            for t in &blas.triangles {
                let v0 = Vec3::new(t[0], t[1], t[2]);
                let (v1, v2) = (v0 + Vec3::new(t[4], t[5], t[6]), v0 + Vec3::new(t[8], t[9], t[10]));
                let [v0, v1, v2] = [v0, v1, v2].map(|v| Vec3A::from(to_frame.transform_point3(v)));
                tris.push(Triangle { v0, v1, v2 });
                tags.push((t[3].to_bits(), slot + 1));
            }
        }
        let group = Blas::build_tagged(&tris, &tags, quality);
        let (merged, separate) = group_costs(&group, &frame_world, members, &blases)?;
        let formed = always || merged < separate;
        log::info!(
            "static group of {} instances ({} triangles): {merged:.2} steps a ray against {separate:.2} one by one (estimated): {} (built and estimated in {:.1?})",
            members.len(),
            group.triangles.len(),
            if formed { "formed" } else { "not formed" },
            started.elapsed()
        );
        formed.then(|| StaticGroup {
            members: members.to_vec(),
            frame: members[frame].0,
            blas: Arc::new(group),
            node_offset: NONE,
            triangle_offset: NONE,
        })
    }

    /// Static groups in use (formed and uploaded).
    pub fn static_group_count(&self) -> usize {
        self.static_groups.groups.iter().filter(|g| g.node_offset != NONE).count()
    }

    /// Instances traced through static groups.
    pub fn grouped_instance_count(&self) -> usize {
        self.static_groups.groups.iter().filter(|g| g.node_offset != NONE).map(|g| g.members.len()).sum()
    }

    /// How static instances that overlap are grouped ([`StaticGrouping`]).
    pub fn static_grouping(&self) -> StaticGrouping {
        self.static_grouping
    }

    /// Sets how static instances that overlap are grouped; the TLAS is rebuilt on the next frame.
    pub fn set_static_grouping(&mut self, grouping: StaticGrouping) {
        self.static_grouping = grouping;
        self.rebuild_requested = true;
    }
}

/// Candidates in clusters of two or more by box overlap ([`GROUP_OVERLAP`]), each cluster's members
/// by slot. A sweep along x finds the pairs whose boxes can overlap.
fn clusters(candidates: &[((u32, u32, Affine3A), Aabb)]) -> Vec<Vec<(u32, u32, Affine3A)>> {
    let n = candidates.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| candidates[a].1.min.x.total_cmp(&candidates[b].1.min.x));
    for (k, &a) in order.iter().enumerate() {
        let box_a = candidates[a].1;
        for &b in &order[k + 1..] {
            let box_b = candidates[b].1;
            let pad = GROUP_OVERLAP_PADDING * (box_a.diagonal().length().max(box_b.diagonal().length()));
            if box_b.min.x > box_a.max.x + 2.0 * pad {
                break;
            }
            if overlaps(&box_a, &box_b, pad) {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                parent[ra] = rb;
            }
        }
    }
    let mut by_root: std::collections::BTreeMap<usize, Vec<(u32, u32, Affine3A)>> = Default::default();
    for (i, candidate) in candidates.iter().enumerate() {
        let r = find(&mut parent, i);
        by_root.entry(r).or_default().push(candidate.0);
    }
    by_root
        .into_values()
        .filter(|c| c.len() > 1)
        .map(|mut c| {
            c.sort_by_key(|m| m.0);
            c
        })
        .collect()
}

/// Whether two boxes, each padded by `pad`, overlap by [`GROUP_OVERLAP`] of the smaller one's volume.
fn overlaps(a: &Aabb, b: &Aabb, pad: f32) -> bool {
    let pad = Vec3A::splat(pad);
    let (a_lo, a_hi, b_lo, b_hi) = (a.min - pad, a.max + pad, b.min - pad, b.max + pad);
    let volume = |lo: Vec3A, hi: Vec3A| {
        let e = (hi - lo).max(Vec3A::ZERO);
        e.x * e.y * e.z
    };
    let overlap = volume(a_lo.max(b_lo), a_hi.min(b_hi));
    overlap > 0.0 && overlap >= GROUP_OVERLAP * volume(a_lo, a_hi).min(volume(b_lo, b_hi))
}

/// Rays the cost estimate of a cluster traces on the CPU (`group_costs`).
pub const GROUP_COST_RAYS: u32 = 2048;

/// The traversal work of the closest hits of one ray through a BLAS, in its space: node tests and
/// triangle tests weighted by their costs, nearest children first, `tmax` shrinking at each hit.
fn walk_cost(blas: &Blas, origin: Vec3A, dir: Vec3A, tmax: &mut f32) -> f64 {
    let inv = Vec3A::ONE / dir;
    let entry = |b: Aabb, tmax: f32| {
        let (t0, t1) = ((b.min - origin) * inv, (b.max - origin) * inv);
        let (near, far) = (t0.min(t1).max_element().max(0.0), t0.max(t1).min_element().min(tmax));
        (near <= far).then_some(near)
    };
    let mut cost = 0.0;
    let mut stack = vec![0u32];
    let mut children: Vec<(f32, u32)> = Vec::with_capacity(8);
    while let Some(index) = stack.pop() {
        let Some(node) = blas.nodes.get(index as usize) else { break };
        cost += GROUP_NODE_COST;
        children.clear();
        for s in 0..8 {
            if node.is_child_empty(s) {
                continue;
            }
            let Some(near) = entry(node.child_aabb(s), *tmax) else { continue };
            if node.is_leaf(s) {
                let (first, count) = node.child_primitives(s);
                for t in blas.triangles.iter().skip(first as usize).take(count as usize) {
                    cost += GROUP_TRIANGLE_COST;
                    if let Some(t) = intersect(t, origin, dir, *tmax) {
                        *tmax = t;
                    }
                }
            } else {
                children.push((near, node.child_node_index(s)));
            }
        }
        // Farthest pushed first: the nearest child is walked next.
        children.sort_by(|a, b| b.0.total_cmp(&a.0));
        stack.extend(children.iter().map(|c| c.1));
    }
    cost
}

/// Möller–Trumbore against a stored triangle (`[v0, _, e1, _, e2, _]`): its distance when the ray
/// meets it before `tmax`.
fn intersect(t: &[f32; 12], origin: Vec3A, dir: Vec3A, tmax: f32) -> Option<f32> {
    let (v0, e1, e2) = (Vec3A::new(t[0], t[1], t[2]), Vec3A::new(t[4], t[5], t[6]), Vec3A::new(t[8], t[9], t[10]));
    let p = dir.cross(e2);
    let det = e1.dot(p);
    if det.abs() < f32::MIN_POSITIVE {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - v0;
    let u = s.dot(p) * inv;
    let q = s.cross(e1);
    let v = dir.dot(q) * inv;
    let t = e2.dot(q) * inv;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 && t < tmax).then_some(t)
}

/// (group, members one by one): the mean traversal work of [`GROUP_COST_RAYS`] rays from points
/// spread through the cluster's world box in directions spread over the sphere (probes and cameras
/// see a scene from inside it, where a surface-area estimate, which assumes rays from outside,
/// says little), traced on the CPU to their closest hits: through the group's BLAS, against entering
/// each member whose box the ray meets before its hit so far (nearest first) and walking its BLAS.
/// Both pay one TLAS node and [`GROUP_ENTER_COST`] an instance entered.
pub(crate) fn group_costs(group: &Blas, frame_world: &Affine3A, members: &[(u32, u32, Affine3A)], blases: &[&Blas]) -> Option<(f64, f64)> {
    let world_box = world_aabb(group.bounds?, frame_world)?;
    let frame_from_world = frame_world.inverse();
    let member_boxes: Vec<(Aabb, Affine3A)> = members
        .iter()
        .zip(blases)
        .map(|(&(_, _, world), blas)| Some((world_aabb(blas.bounds?, &world)?, world.inverse())))
        .collect::<Option<_>>()?;
    let mut rng = 0x9E37_79B9_7F4A_7C15u64 ^ members.len() as u64;
    let mut next = move || {
        rng = rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    };
    let (mut merged, mut separate) = (0.0, 0.0);
    for _ in 0..GROUP_COST_RAYS {
        let origin = world_box.min + (world_box.max - world_box.min) * Vec3A::new(next(), next(), next());
        let (y, phi) = (1.0 - 2.0 * next(), std::f32::consts::TAU * next());
        let r = (1.0 - y * y).max(0.0).sqrt();
        let dir = Vec3A::new(r * phi.cos(), y, r * phi.sin());
        // Through the group, in its frame's space (directions not normalized: t is the world's).
        let mut tmax = f32::INFINITY;
        merged += GROUP_NODE_COST
            + GROUP_ENTER_COST
            + walk_cost(group, frame_from_world.transform_point3a(origin), frame_from_world.transform_vector3a(dir), &mut tmax);
        // One member after another, nearest box first.
        let mut order: Vec<(f32, usize)> = member_boxes
            .iter()
            .enumerate()
            .filter_map(|(k, (b, _))| {
                let inv = Vec3A::ONE / dir;
                let (t0, t1) = ((b.min - origin) * inv, (b.max - origin) * inv);
                let (near, far) = (t0.min(t1).max_element().max(0.0), t0.max(t1).min_element());
                (near <= far).then_some((near, k))
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut tmax = f32::INFINITY;
        separate += GROUP_NODE_COST;
        for (near, k) in order {
            if near > tmax {
                break;
            }
            let local = member_boxes[k].1;
            separate += GROUP_ENTER_COST + walk_cost(blases[k], local.transform_point3a(origin), local.transform_vector3a(dir), &mut tmax);
        }
    }
    let rays = f64::from(GROUP_COST_RAYS);
    Some((merged / rays, separate / rays))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(slot: u32, lo: [f32; 3], hi: [f32; 3]) -> ((u32, u32, Affine3A), Aabb) {
        ((slot, slot, Affine3A::IDENTITY), Aabb::new(Vec3A::from(lo), Vec3A::from(hi)))
    }

    fn slots(clusters: &[Vec<(u32, u32, Affine3A)>]) -> Vec<Vec<u32>> {
        clusters.iter().map(|c| c.iter().map(|m| m.0).collect()).collect()
    }

    #[test]
    fn a_floor_and_columns_inside_a_hall_join_it_and_neighbours_that_only_touch_do_not() {
        let found = clusters(&[
            // A hall, its flat floor (no volume of its own) and a column inside it.
            candidate(0, [0.0, 0.0, 0.0], [10.0, 5.0, 10.0]),
            candidate(1, [0.0, 0.0, 0.0], [10.0, 0.0, 10.0]),
            candidate(2, [4.0, 0.0, 4.0], [5.0, 5.0, 5.0]),
            // Two rooms side by side, sharing a wall plane, far from the hall.
            candidate(3, [20.0, 0.0, 0.0], [24.0, 3.0, 4.0]),
            candidate(4, [24.0, 0.0, 0.0], [28.0, 3.0, 4.0]),
            // Two boxes that overlap by a tenth of the smaller one.
            candidate(5, [40.0, 0.0, 0.0], [42.0, 2.0, 2.0]),
            candidate(6, [41.9, 0.0, 0.0], [43.9, 2.0, 2.0]),
        ]);
        assert_eq!(slots(&found), vec![vec![0, 1, 2]]);
    }

    #[test]
    fn overlaps_measures_against_the_smaller_box() {
        let big = Aabb::new(Vec3A::ZERO, Vec3A::splat(10.0));
        let half_in = Aabb::new(Vec3A::splat(9.0), Vec3A::splat(11.0));
        let mostly_in = Aabb::new(Vec3A::splat(8.0), Vec3A::new(10.5, 10.0, 10.0));
        assert!(!overlaps(&big, &half_in, 0.0), "an eighth of the small box inside");
        assert!(overlaps(&big, &mostly_in, 0.0), "four fifths of the small box inside");
        assert!(!overlaps(&big, &Aabb::new(Vec3A::splat(10.0), Vec3A::splat(12.0)), 0.0), "touching at a corner");
    }
}

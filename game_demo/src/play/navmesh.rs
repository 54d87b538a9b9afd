//! A navigation mesh of the demo level: a constrained Delaunay triangulation (spade) of the level's
//! floor plan, every face classified walkable, blocked or door.
//!
//! The walkable region is the level's bounds shrunk by the agent radius, minus every wall footprint
//! grown by the agent radius; the door's footprint, grown the same way, is walkable only while the
//! door is open. All rectangles are axis-aligned, so their edges are split at every x and z
//! coordinate of the others before they go in as constraint edges: no two constraints cross, and
//! every face lies entirely inside or entirely outside each rectangle, which lets the face's
//! centroid decide its kind exactly.

use std::collections::{HashMap, HashSet, VecDeque};

use glam::Vec2;
use spade::handles::{FixedFaceHandle, FixedVertexHandle, InnerTag};
use spade::{ConstrainedDelaunayTriangulation, Point2, PositionInTriangulation, Triangulation};

use super::level::{Footprint, LevelLayout};

/// What a face of the navigation mesh is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceKind {
    /// Open floor.
    Walkable,
    /// Outside the bounds, or within the agent radius of a wall.
    Blocked,
    /// Within the agent radius of the door panel: walkable only while the door is open.
    Door,
}

impl FaceKind {
    fn passable(self, door_open: bool) -> bool {
        match self {
            FaceKind::Walkable => true,
            FaceKind::Door => door_open,
            FaceKind::Blocked => false,
        }
    }
}

/// Why a navigation mesh could not be built.
#[derive(Debug, thiserror::Error)]
pub enum NavMeshError {
    #[error("agent radius {0} is not a finite number >= 0")]
    BadRadius(f32),
    #[error("footprint {what}: min {min:?} / max {max:?} are not finite")]
    NonFinite { what: String, min: Vec2, max: Vec2 },
    #[error("footprint {what}: min {min:?} is not below max {max:?} on both axes")]
    Inverted { what: String, min: Vec2, max: Vec2 },
    #[error("bounds {min:?}..{max:?} leave no walkable area for an agent of radius {radius}")]
    BoundsTooSmall { min: Vec2, max: Vec2, radius: f32 },
    #[error("triangulation failed at {what}: {message}")]
    Triangulation { what: String, message: String },
}

type Cdt = ConstrainedDelaunayTriangulation<Point2<f64>>;

/// A grid point: indices into the sorted x and z coordinates.
type GridPoint = (usize, usize);

/// The level's floor plan as classified triangles. Coordinates are the world's (x, z).
#[derive(Clone)]
pub struct NavMesh {
    cdt: Cdt,
    /// Kind of every face, by face index (index 0 is spade's outer face: blocked).
    kinds: Vec<FaceKind>,
    agent_radius: f32,
}

impl std::fmt::Debug for NavMesh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NavMesh")
            .field("faces", &self.cdt.num_inner_faces())
            .field("vertices", &self.cdt.num_vertices())
            .field("agent_radius", &self.agent_radius)
            .finish()
    }
}

fn check(what: &str, fp: &Footprint) -> Result<(), NavMeshError> {
    if !(fp.min.is_finite() && fp.max.is_finite()) {
        return Err(NavMeshError::NonFinite { what: what.into(), min: fp.min, max: fp.max });
    }
    if !(fp.min.x < fp.max.x && fp.min.y < fp.max.y) {
        return Err(NavMeshError::Inverted { what: what.into(), min: fp.min, max: fp.max });
    }
    Ok(())
}

/// Index of `value` in the sorted, deduplicated `axis`.
fn grid_index(axis: &[f64], value: f64) -> usize {
    axis.partition_point(|&v| v < value)
}

impl NavMesh {
    /// Triangulates the layout's bounds, walls and door for an agent of `agent_radius` metres.
    pub fn build(layout: &LevelLayout, agent_radius: f32) -> Result<Self, NavMeshError> {
        if !(agent_radius.is_finite() && agent_radius >= 0.0) {
            return Err(NavMeshError::BadRadius(agent_radius));
        }
        check("bounds", &layout.bounds)?;
        for (i, wall) in layout.walls.iter().enumerate() {
            check(&format!("walls[{i}]"), wall)?;
        }
        check(&format!("door '{}'", layout.door.node), &layout.door.footprint)?;

        let inner = layout.bounds.inflate(-agent_radius);
        if !(inner.min.x < inner.max.x && inner.min.y < inner.max.y) {
            return Err(NavMeshError::BoundsTooSmall { min: layout.bounds.min, max: layout.bounds.max, radius: agent_radius });
        }
        let walls: Vec<Footprint> = layout.walls.iter().map(|w| w.inflate(agent_radius)).collect();
        let door = layout.door.footprint.inflate(agent_radius);

        let mut rects: Vec<(String, Footprint)> = vec![("bounds".into(), inner)];
        rects.extend(walls.iter().enumerate().map(|(i, w)| (format!("walls[{i}]"), *w)));
        rects.push(("door".into(), door));

        let mut xs: Vec<f64> = rects.iter().flat_map(|(_, r)| [r.min.x as f64, r.max.x as f64]).collect();
        let mut zs: Vec<f64> = rects.iter().flat_map(|(_, r)| [r.min.y as f64, r.max.y as f64]).collect();
        for axis in [&mut xs, &mut zs] {
            axis.sort_by(f64::total_cmp);
            axis.dedup();
        }

        // Every rectangle side, split at each grid coordinate it passes.
        let mut segments: Vec<(String, GridPoint, GridPoint)> = Vec::new();
        let mut seen: HashSet<(GridPoint, GridPoint)> = HashSet::new();
        for (what, r) in &rects {
            let (x0, x1) = (grid_index(&xs, r.min.x as f64), grid_index(&xs, r.max.x as f64));
            let (z0, z1) = (grid_index(&zs, r.min.y as f64), grid_index(&zs, r.max.y as f64));
            let mut push = |a: GridPoint, b: GridPoint| {
                let key = if a <= b { (a, b) } else { (b, a) };
                if seen.insert(key) {
                    segments.push((what.clone(), key.0, key.1));
                }
            };
            for i in x0..x1 {
                push((i, z0), (i + 1, z0));
                push((i, z1), (i + 1, z1));
            }
            for j in z0..z1 {
                push((x0, j), (x0, j + 1));
                push((x1, j), (x1, j + 1));
            }
        }

        let mut cdt = Cdt::new();
        let mut handles: HashMap<GridPoint, FixedVertexHandle> = HashMap::new();
        for (what, a, b) in &segments {
            let mut vertex = |key: GridPoint| -> Result<FixedVertexHandle, NavMeshError> {
                if let Some(&h) = handles.get(&key) {
                    return Ok(h);
                }
                let h = cdt
                    .insert(Point2::new(xs[key.0], zs[key.1]))
                    .map_err(|e| NavMeshError::Triangulation { what: what.clone(), message: format!("{e:?}") })?;
                handles.insert(key, h);
                Ok(h)
            };
            let (ha, hb) = (vertex(*a)?, vertex(*b)?);
            if ha == hb {
                continue;
            }
            if !cdt.can_add_constraint(ha, hb) {
                return Err(NavMeshError::Triangulation {
                    what: what.clone(),
                    message: format!("edge ({}, {})-({}, {}) crosses another", xs[a.0], zs[a.1], xs[b.0], zs[b.1]),
                });
            }
            cdt.add_constraint(ha, hb);
        }

        let mut kinds = vec![FaceKind::Blocked; cdt.num_all_faces()];
        for face in cdt.inner_faces() {
            let c = face.center();
            let c = Vec2::new(c.x as f32, c.y as f32);
            let kind = if !inner.contains(c) || walls.iter().any(|w| w.contains(c)) {
                FaceKind::Blocked
            } else if door.contains(c) {
                FaceKind::Door
            } else {
                FaceKind::Walkable
            };
            kinds[face.fix().index()] = kind;
        }
        Ok(Self { cdt, kinds, agent_radius })
    }

    fn kind(&self, face: FixedFaceHandle<InnerTag>) -> FaceKind {
        self.kinds.get(face.index()).copied().unwrap_or(FaceKind::Blocked)
    }

    /// The passable faces touching `p` (one when inside a face, more on an edge or a vertex), and
    /// whether all faces touching it are passable. `None` outside the triangulation.
    fn faces_at(&self, p: Vec2, door_open: bool) -> Option<(Vec<FixedFaceHandle<InnerTag>>, bool)> {
        if !p.is_finite() {
            return None;
        }
        let touching: Vec<Option<FixedFaceHandle<InnerTag>>> = match self.cdt.locate(Point2::new(p.x as f64, p.y as f64)) {
            PositionInTriangulation::OnFace(f) => vec![Some(f)],
            PositionInTriangulation::OnEdge(e) => {
                let e = self.cdt.directed_edge(e);
                vec![e.face().as_inner().map(|f| f.fix()), e.rev().face().as_inner().map(|f| f.fix())]
            }
            PositionInTriangulation::OnVertex(v) => self.cdt.vertex(v).out_edges().map(|e| e.face().as_inner().map(|f| f.fix())).collect(),
            _ => return None,
        };
        let passable: Vec<_> = touching.iter().flatten().copied().filter(|&f| self.kind(f).passable(door_open)).collect();
        let all = passable.len() == touching.len();
        Some((passable, all))
    }

    /// Whether an agent's centre may stand at `p` = (x, z). Points on the border between a passable
    /// and a blocked face are not walkable.
    pub fn is_walkable(&self, p: Vec2, door_open: bool) -> bool {
        self.faces_at(p, door_open).is_some_and(|(faces, all)| all && !faces.is_empty())
    }

    /// Whether an agent can walk from `a` to `b` (both walkable) across passable faces.
    pub fn connected(&self, a: Vec2, b: Vec2, door_open: bool) -> bool {
        if !(self.is_walkable(a, door_open) && self.is_walkable(b, door_open)) {
            return false;
        }
        let (Some((start, _)), Some((goal, _))) = (self.faces_at(a, door_open), self.faces_at(b, door_open)) else {
            return false;
        };
        let goal: HashSet<usize> = goal.iter().map(|f| f.index()).collect();
        let mut visited = vec![false; self.kinds.len()];
        let mut queue: VecDeque<FixedFaceHandle<InnerTag>> = VecDeque::new();
        for f in start {
            visited[f.index()] = true;
            queue.push_back(f);
        }
        while let Some(f) = queue.pop_front() {
            if goal.contains(&f.index()) {
                return true;
            }
            for edge in self.cdt.face(f).adjacent_edges() {
                let Some(next) = edge.rev().face().as_inner() else { continue };
                let next = next.fix();
                if !visited[next.index()] && self.kind(next).passable(door_open) {
                    visited[next.index()] = true;
                    queue.push_back(next);
                }
            }
        }
        false
    }

    /// `p` itself when walkable, else the walkable point nearest to it (just inside the nearest
    /// passable face); `None` when nothing is walkable or `p` is not finite.
    pub fn nearest_walkable(&self, p: Vec2, door_open: bool) -> Option<Vec2> {
        if !p.is_finite() {
            return None;
        }
        if self.is_walkable(p, door_open) {
            return Some(p);
        }
        let mut best: Option<(f32, Vec2, Vec2)> = None;
        for face in self.cdt.inner_faces() {
            if !self.kind(face.fix()).passable(door_open) {
                continue;
            }
            let [a, b, c] = face.positions().map(|q| Vec2::new(q.x as f32, q.y as f32));
            let q = closest_point_on_triangle(p, a, b, c);
            let d = q.distance_squared(p);
            if best.is_none_or(|(bd, _, _)| d < bd) {
                best = Some((d, q, (a + b + c) / 3.0));
            }
        }
        let (_, q, centroid) = best?;
        // Step just inside the face so that the point is not on its border.
        let to_centre = centroid - q;
        let mut step = 1e-3f32;
        for _ in 0..12 {
            let candidate = q + to_centre.normalize_or_zero() * step.min(to_centre.length() * 0.5);
            if self.is_walkable(candidate, door_open) {
                return Some(candidate);
            }
            step *= 2.0;
        }
        self.is_walkable(centroid, door_open).then_some(centroid)
    }

    /// Every face as its corners (x, z) and kind, for debug drawing.
    pub fn triangles(&self) -> Vec<([Vec2; 3], FaceKind)> {
        self.cdt.inner_faces().map(|face| (face.positions().map(|q| Vec2::new(q.x as f32, q.y as f32)), self.kind(face.fix()))).collect()
    }
}

/// The point of triangle `abc` closest to `p` (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_point_on_triangle(p: Vec2, a: Vec2, b: Vec2, c: Vec2) -> Vec2 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::play::level::demo_level;

    const R: f32 = 0.3;

    fn xz(p: Vec3) -> Vec2 {
        Vec2::new(p.x, p.z)
    }

    fn mesh() -> (NavMesh, LevelLayout) {
        let level = demo_level(None);
        let nav = NavMesh::build(&level.layout, R).expect("navmesh");
        (nav, level.layout)
    }

    #[test]
    fn open_ground_and_house_interior_are_walkable() {
        let (nav, layout) = mesh();
        assert!(nav.is_walkable(xz(layout.spawn), false));
        assert!(nav.is_walkable(xz(layout.indoor_point), false));
        assert!(nav.is_walkable(xz(layout.indoor_point), true));
        // Every face kind exists.
        let tris = nav.triangles();
        for kind in [FaceKind::Walkable, FaceKind::Blocked, FaceKind::Door] {
            assert!(tris.iter().any(|(_, k)| *k == kind), "no {kind:?} face");
        }
    }

    #[test]
    fn walls_and_their_margin_are_not_walkable() {
        let (nav, layout) = mesh();
        for wall in &layout.walls {
            let c = (wall.min + wall.max) * 0.5;
            assert!(!nav.is_walkable(c, true), "centre of wall {wall:?} is walkable");
            // Just outside the wall, but within the agent radius of it.
            let beside = Vec2::new(wall.max.x + R * 0.5, c.y);
            assert!(!nav.is_walkable(beside, true), "{beside} within the radius of {wall:?} is walkable");
        }
    }

    #[test]
    fn outside_the_bounds_is_not_walkable() {
        let (nav, layout) = mesh();
        let b = layout.bounds;
        for p in [b.max + Vec2::ONE, b.min - Vec2::ONE, Vec2::new(b.max.x - R * 0.5, 0.0), Vec2::new(0.0, b.min.y + R * 0.5)] {
            assert!(!nav.is_walkable(p, true), "{p} is walkable");
        }
        assert!(!nav.is_walkable(Vec2::NAN, true));
    }

    #[test]
    fn door_separates_inside_from_outside() {
        let (nav, layout) = mesh();
        let (a, b) = (xz(layout.spawn), xz(layout.indoor_point));
        assert!(!nav.connected(a, b, false), "spawn reaches the house with the door closed");
        assert!(nav.connected(a, b, true), "spawn does not reach the house with the door open");
        let doorway = layout.door.footprint.center();
        assert!(!nav.is_walkable(doorway, false));
        assert!(nav.is_walkable(doorway, true));
    }

    #[test]
    fn nearest_walkable_leaves_a_wall() {
        let (nav, layout) = mesh();
        let wall = layout.walls[0];
        let inside = (wall.min + wall.max) * 0.5;
        let out = nav.nearest_walkable(inside, false).expect("a walkable point");
        assert!(nav.is_walkable(out, false));
        assert!(!wall.inflate(R - 1e-3).contains(out), "{out} is still within the radius of {wall:?}");
        // Not far: at most the wall's half thickness plus the radius, plus a little.
        let half = (wall.max - wall.min).min_element() * 0.5;
        assert!(out.distance(inside) <= half + R + 0.05, "{out} is {} m away", out.distance(inside));
        // A walkable point stays where it is.
        assert_eq!(nav.nearest_walkable(xz(layout.spawn), false), Some(xz(layout.spawn)));
    }

    #[test]
    fn bad_input_is_an_error() {
        let (_, layout) = mesh();
        assert!(matches!(NavMesh::build(&layout, f32::NAN), Err(NavMeshError::BadRadius(_))));
        let mut bad = layout.clone();
        bad.walls[1].max.x = f32::INFINITY;
        let err = NavMesh::build(&bad, R).unwrap_err();
        assert!(err.to_string().contains("walls[1]"), "{err}");
        let mut bad = layout.clone();
        bad.door.footprint.min.x = bad.door.footprint.max.x + 1.0;
        assert!(matches!(NavMesh::build(&bad, R), Err(NavMeshError::Inverted { .. })));
        assert!(matches!(NavMesh::build(&layout, 100.0), Err(NavMeshError::BoundsTooSmall { .. })));
    }
}

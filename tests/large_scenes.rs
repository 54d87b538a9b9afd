//! The large benchmark scenes of `scenes::large`: `cathedral` (≈73k static triangles, a closed stone
//! interior lit through its windows) and `forest` (≈21.6M instanced triangles).
//!
//! Checks their budgets, the validity of every mesh (and that the cathedral's and the trees' meshes
//! are unions of closed solids), their cameras and lights, that every forest instance stands on the
//! terrain, and, with a small CPU ray caster (triangles bucketed in clusters with bounding boxes),
//! that the cathedral is closed except through its windows and that the sun shines in.

use std::collections::HashMap;
use std::sync::LazyLock;
use std::time::Instant;

use engine::scene::{Mesh, NodeContent, SceneDescription};
use glam::{Affine3A, Vec3};
use scenes::Opening;
use scenes::large::{CATHEDRAL_NAVE_MAX, CATHEDRAL_NAVE_MIN, FOREST_SIZE, cathedral_openings, forest_terrain_height};
use workspace_tests::assert_valid_mesh;
use workspace_tests::cpu_rays::{fibonacci_directions, intersect};

/// Triangle budgets and their tolerance.
const CATHEDRAL_TRIANGLES: f64 = 73_000.0;
const FOREST_INSTANCED_TRIANGLES: f64 = 21_600_000.0;
const BUDGET_TOLERANCE: f64 = 0.03;
/// The forest must have this many instances at least, and its unique meshes fewer triangles than
/// `MAX_UNIQUE_TRIANGLES` together.
const MIN_FOREST_INSTANCES: usize = 10_000;
const MAX_UNIQUE_TRIANGLES: usize = 1_000_000;
/// Allowed distance (metres) between an instance's origin and the terrain height under it.
const TERRAIN_TOLERANCE: f32 = 1e-3;
/// Allowed distance (metres) between the terrain function and the terrain mesh's linear
/// interpolation of it, at the centre of each grid cell.
const TERRAIN_MESH_TOLERANCE: f32 = 0.05;
/// How far outside a window's box an escaping ray may pass (metres).
const OPENING_TOLERANCE: f32 = 1e-3;
/// Rays cast from each interior point of the cathedral (Fibonacci directions).
const RAY_COUNT: usize = 1500;
/// Triangles per cluster of the ray caster.
const CLUSTER_SIZE: usize = 32;
/// Spacing (metres) of the parallel rays that sweep the cathedral's interior.
const SWEEP_STEP: f32 = 0.08;
/// Height (metres) of the horizontal rays cast through the aisle windows (between their sill at
/// 2.5 m and their head at 7 m, below the arches at 5.8 m).
const WINDOW_RAY_HEIGHT: f32 = 4.75;

static CATHEDRAL: LazyLock<SceneDescription> = LazyLock::new(|| timed_build("cathedral"));
static FOREST: LazyLock<SceneDescription> = LazyLock::new(|| timed_build("forest"));

fn timed_build(name: &str) -> SceneDescription {
    let start = Instant::now();
    let desc = (scenes::find(name).unwrap_or_else(|| panic!("built-in scene {name} is missing")).build)();
    eprintln!("{name}: built in {:.3} s", start.elapsed().as_secs_f64());
    desc
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn within_budget(value: usize, target: f64) -> bool {
    (value as f64 - target).abs() <= target * BUDGET_TOLERANCE
}

/// The (mesh, material) pairs of a node.
fn node_meshes(content: &[NodeContent]) -> Vec<(usize, usize)> {
    content
        .iter()
        .flat_map(|c| match c {
            NodeContent::Meshes(list) => list.clone(),
            _ => Vec::new(),
        })
        .collect()
}

/// The world transform of the first node whose content `pick` accepts.
fn find_node(desc: &SceneDescription, pick: impl Fn(&NodeContent) -> bool) -> Option<(usize, Affine3A)> {
    let world = desc.world_transforms();
    desc.nodes.iter().enumerate().find(|(_, n)| n.content.iter().any(&pick)).map(|(i, _)| (i, world[i]))
}

fn camera_position(desc: &SceneDescription) -> Vec3 {
    let (_, xf) = find_node(desc, |c| matches!(c, NodeContent::Camera(_))).unwrap_or_else(|| panic!("{}: no camera", desc.name));
    xf.translation.into()
}

fn sun_direction(desc: &SceneDescription) -> Vec3 {
    let (_, xf) = find_node(desc, |c| matches!(c, NodeContent::DirectionalLight(_))).unwrap_or_else(|| panic!("{}: no sun", desc.name));
    xf.transform_vector3(Vec3::NEG_Z).normalize()
}

fn node_position(desc: &SceneDescription, name: &str) -> Vec3 {
    let index = desc.nodes.iter().position(|n| n.name == name).unwrap_or_else(|| panic!("{}: no node {name}", desc.name));
    desc.world_transforms()[index].translation.into()
}

/// Asserts that `mesh` is a union of closed, consistently wound surfaces: every edge (by exact
/// positions) is used as often in one direction as in the other.
fn assert_closed(scene: &str, mesh: &Mesh) {
    let key = |i: u32| (mesh.positions[i as usize] + Vec3::ZERO).to_array().map(f32::to_bits);
    let mut edges: HashMap<([u32; 3], [u32; 3]), i32> = HashMap::new();
    for tri in mesh.indices.chunks_exact(3) {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let (p, q) = (key(tri[i]), key(tri[j]));
            if p <= q {
                *edges.entry((p, q)).or_default() += 1;
            } else {
                *edges.entry((q, p)).or_default() -= 1;
            }
        }
    }
    let open = edges.values().filter(|&&balance| balance != 0).count();
    assert_eq!(open, 0, "{scene}/{}: {open} edges without a matching reversed edge (not closed)", mesh.name);
}

/// Signed volume enclosed by a mesh (positive for closed surfaces wound outwards).
fn signed_volume(mesh: &Mesh) -> f32 {
    mesh.indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| mesh.positions[i as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

// ---------------------------------------------------------------------------------------------
// Ray caster
// ---------------------------------------------------------------------------------------------

/// A world-space triangle.
struct Triangle {
    a: Vec3,
    b: Vec3,
    c: Vec3,
}

/// Every triangle of a scene in world space, in runs of `CLUSTER_SIZE` consecutive triangles (the
/// generators emit neighbouring triangles together) with the bounding box of each run.
struct RayCaster {
    triangles: Vec<Triangle>,
    clusters: Vec<(Vec3, Vec3)>,
}

/// A ray hit: distance and the triangle's geometric normal (from its winding).
struct Hit {
    t: f32,
    normal: Vec3,
}

impl RayCaster {
    fn new(desc: &SceneDescription) -> Self {
        let world = desc.world_transforms();
        let mut triangles = Vec::new();
        for (node, xf) in desc.nodes.iter().zip(&world) {
            for (mesh, _) in node_meshes(&node.content) {
                let mesh = &desc.meshes[mesh];
                for tri in mesh.indices.chunks_exact(3) {
                    let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| xf.transform_point3(mesh.positions[i as usize]));
                    triangles.push(Triangle { a, b, c });
                }
            }
        }
        let clusters = triangles
            .chunks(CLUSTER_SIZE)
            .map(|run| {
                run.iter().flat_map(|t| [t.a, t.b, t.c]).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)))
            })
            .collect();
        Self { triangles, clusters }
    }

    /// The nearest hit along the ray (`dir` unit).
    fn first_hit(&self, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let mut best: Option<(f32, usize)> = None;
        for (k, &(lo, hi)) in self.clusters.iter().enumerate() {
            let limit = best.map_or(f32::INFINITY, |b| b.0);
            if !ray_hits_box(origin, dir, lo - 1e-4, hi + 1e-4, limit) {
                continue;
            }
            let start = k * CLUSTER_SIZE;
            for (i, tri) in self.triangles[start..(start + CLUSTER_SIZE).min(self.triangles.len())].iter().enumerate() {
                if let Some(t) = intersect(origin, dir, [tri.a, tri.b, tri.c])
                    && best.is_none_or(|b| t < b.0)
                {
                    best = Some((t, start + i));
                }
            }
        }
        best.map(|(t, i)| {
            let tri = &self.triangles[i];
            Hit { t, normal: (tri.b - tri.a).cross(tri.c - tri.a).normalize_or_zero() }
        })
    }
}

/// Slab test: the ray meets the box `lo`..`hi` before distance `limit`.
fn ray_hits_box(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3, limit: f32) -> bool {
    let (mut near, mut far) = (0.0f32, limit);
    for axis in 0..3 {
        if dir[axis].abs() < 1e-12 {
            if origin[axis] < lo[axis] || origin[axis] > hi[axis] {
                return false;
            }
            continue;
        }
        let inv = 1.0 / dir[axis];
        let (t0, t1) = ((lo[axis] - origin[axis]) * inv, (hi[axis] - origin[axis]) * inv);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
        if near > far {
            return false;
        }
    }
    true
}

/// The opening an escaping ray leaves through: the first whose box (with tolerance) it crosses.
fn opening_crossed(openings: &[Opening], origin: Vec3, dir: Vec3) -> Option<&Opening> {
    let slack = Vec3::splat(OPENING_TOLERANCE);
    openings.iter().find(|o| ray_hits_box(origin, dir, o.min - slack, o.max + slack, f32::INFINITY))
}

/// Centres (z) of the cathedral's bays, from its +X aisle windows, in increasing z.
fn bay_centers() -> Vec<f32> {
    let mut z: Vec<f32> =
        cathedral_openings().iter().filter(|o| o.name == "aisle_window" && o.min.x > 0.0).map(|o| 0.5 * (o.min.z + o.max.z)).collect();
    z.sort_by(f32::total_cmp);
    z
}

// ---------------------------------------------------------------------------------------------
// Both scenes
// ---------------------------------------------------------------------------------------------

#[test]
fn large_scenes_are_registered_and_deterministic() {
    let [cathedral, forest] =
        ["cathedral", "forest"].map(|name| scenes::find(name).unwrap_or_else(|| panic!("{name} is not listed in scenes::ALL")));
    assert_eq!(CATHEDRAL.name, "cathedral");
    assert_eq!(FOREST.name, "forest");
    assert_eq!((cathedral.build)(), *CATHEDRAL, "cathedral: building twice gives the same scene");
    assert_eq!((forest.build)(), *FOREST, "forest: building twice gives the same scene");
    assert_eq!((cathedral.openings)(), cathedral_openings());
    assert!((forest.openings)().is_empty());
}

#[test]
fn every_mesh_is_valid() {
    for desc in [&*CATHEDRAL, &*FOREST] {
        assert!(!desc.meshes.is_empty());
        for mesh in &desc.meshes {
            assert_valid_mesh(&desc.name, mesh);
        }
        for (i, node) in desc.nodes.iter().enumerate() {
            assert!(node.parent.is_none_or(|p| p < i), "{}/{}: parent after child", desc.name, node.name);
            let t = &node.transform;
            assert!(t.translation.is_finite() && t.scale.is_finite() && t.rotation.is_normalized());
            for (mesh, material) in node_meshes(&node.content) {
                assert!(mesh < desc.meshes.len() && material < desc.materials.len(), "{}/{}: dangling reference", desc.name, node.name);
            }
        }
        for m in &desc.materials {
            let albedo = m.base_color.truncate();
            assert!(albedo.cmpge(Vec3::ZERO).all() && albedo.cmplt(Vec3::ONE).all(), "{}/{}: albedo {albedo}", desc.name, m.name);
        }
    }
}

#[test]
fn walls_columns_and_trees_are_closed_solids() {
    for mesh in &CATHEDRAL.meshes {
        assert_closed("cathedral", mesh);
        assert!(signed_volume(mesh) > 0.0, "cathedral/{}: wound inwards", mesh.name);
    }
    for mesh in FOREST.meshes.iter().filter(|m| m.name != "terrain") {
        assert_closed("forest", mesh);
        assert!(signed_volume(mesh) > 0.0, "forest/{}: wound inwards", mesh.name);
    }
}

#[test]
fn each_scene_has_one_camera_and_a_sun() {
    for desc in [&*CATHEDRAL, &*FOREST] {
        let contents = || desc.nodes.iter().flat_map(|n| &n.content);
        assert_eq!(contents().filter(|c| matches!(c, NodeContent::Camera(_))).count(), 1, "{}: one camera", desc.name);
        let suns: Vec<_> = contents()
            .filter_map(|c| match c {
                NodeContent::DirectionalLight(l) => Some(*l),
                _ => None,
            })
            .collect();
        assert_eq!(suns.len(), 1, "{}: one sun", desc.name);
        let sun = suns[0];
        assert!((5.0..=8.0).contains(&sun.intensity), "{}: sun irradiance {} W/m²", desc.name, sun.intensity);
        assert!(sun.color.cmpge(Vec3::ZERO).all() && sun.color.cmple(Vec3::ONE).all() && sun.color.max_element() > 0.0);
        assert!(sun_direction(desc).y < -0.3, "{}: the sun shines downwards", desc.name);
    }
}

// ---------------------------------------------------------------------------------------------
// cathedral
// ---------------------------------------------------------------------------------------------

#[test]
fn cathedral_has_about_73k_static_triangles() {
    let triangles = CATHEDRAL.triangle_count();
    eprintln!("cathedral: {triangles} triangles in {} meshes", CATHEDRAL.meshes.len());
    assert!(within_budget(triangles, CATHEDRAL_TRIANGLES), "cathedral: {triangles} triangles");
    // Static: every mesh drawn exactly once.
    assert_eq!(CATHEDRAL.instanced_triangle_count(), triangles);
    let mut uses = vec![0; CATHEDRAL.meshes.len()];
    for node in &CATHEDRAL.nodes {
        for (mesh, _) in node_meshes(&node.content) {
            uses[mesh] += 1;
        }
    }
    assert!(uses.iter().all(|&u| u == 1), "cathedral: meshes drawn {uses:?} times");
}

#[test]
fn cathedral_camera_stands_in_the_nave() {
    let eye = camera_position(&CATHEDRAL);
    assert!(eye.cmpgt(CATHEDRAL_NAVE_MIN).all() && eye.cmplt(CATHEDRAL_NAVE_MAX).all(), "camera at {eye}");
    let (min, max) = CATHEDRAL.bounds().expect("geometry");
    let size = max - min;
    assert!(size.z > 40.0 && size.x > 12.0 && size.y > 18.0, "cathedral: bounds {min}..{max}");
}

#[test]
fn cathedral_is_closed_except_through_its_windows() {
    let caster = RayCaster::new(&CATHEDRAL);
    let openings = cathedral_openings();
    let bays = bay_centers();
    let origins = [
        ("camera", camera_position(&CATHEDRAL)),
        ("nave centre", Vec3::new(0.0, 9.0, 0.0)),
        ("sun patch", node_position(&CATHEDRAL, "sun_patch") + Vec3::Y * 0.05),
        ("arcade", Vec3::new(6.4, 3.0, bays[4])),
        ("+x aisle", Vec3::new(8.9, 3.0, bays[2])),
        ("-x aisle", Vec3::new(-8.9, 6.0, bays[5])),
        ("apse", Vec3::new(0.0, 10.0, -23.0)),
        ("under the vault", Vec3::new(0.0, 16.0, 18.0)),
    ];
    let mut escaped_total = 0;
    for (label, origin) in origins {
        let mut escaped = 0;
        for dir in fibonacci_directions(RAY_COUNT) {
            match caster.first_hit(origin, dir) {
                Some(hit) => {
                    // Solids are wound outwards, so from the empty interior every hit is a front face.
                    assert!(hit.normal.dot(dir) < 0.0, "cathedral: from the {label} ({origin}) towards {dir}, a back face at {}", hit.t);
                }
                None => {
                    let through = opening_crossed(openings, origin, dir);
                    assert!(through.is_some(), "cathedral: a ray from the {label} ({origin}) towards {dir} escapes outside every window");
                    escaped += 1;
                }
            }
        }
        eprintln!("cathedral: {escaped} of {RAY_COUNT} rays from the {label} leave through windows");
        escaped_total += escaped;
    }
    assert!(escaped_total > 0, "cathedral: no ray reaches the sky");
}

/// Height of the cathedral's interior above the floor point (x, ·) of the nave's cross-section: under
/// the vault in the nave, under the aisle roofs in the aisles, under the clerestory wall's underside
/// on the arcade line.
fn interior_height(x: f32) -> f32 {
    let (half_width, spring) = (CATHEDRAL_NAVE_MAX.x, CATHEDRAL_NAVE_MAX.y - CATHEDRAL_NAVE_MAX.x);
    if x.abs() < half_width {
        spring + (half_width * half_width - x * x).sqrt()
    } else if x.abs() < half_width + 0.8 {
        8.2
    } else {
        9.0
    }
}

/// Casts `dir` from every origin; each ray must hit something or leave through a window. Returns how
/// many left through windows.
fn assert_rays_hit_or_leave_through_windows(caster: &RayCaster, origins: &[Vec3], dir: Vec3) -> usize {
    let openings = cathedral_openings();
    let mut escaped = 0;
    for &origin in origins {
        if caster.first_hit(origin, dir).is_none() {
            assert!(
                opening_crossed(openings, origin, dir).is_some(),
                "cathedral: a ray from {origin} towards {dir} escapes outside every window"
            );
            escaped += 1;
        }
    }
    escaped
}

/// Points from `lo` to `hi` (both included) spaced `step` apart.
fn steps(lo: f32, hi: f32, step: f32) -> impl Iterator<Item = f32> + Clone {
    let count = ((hi - lo) / step).round() as usize;
    (0..=count).map(move |i| lo + (hi - lo) * i as f32 / count.max(1) as f32)
}

#[test]
fn cathedral_is_closed_along_dense_axis_rays() {
    // Thin slits between pieces are easily missed by rays in spread directions: sweep the interior
    // with parallel rays about 8 cm apart along each axis instead (at odd offsets, so that the rays
    // do not graze the faces of the building's round dimensions).
    let caster = RayCaster::new(&CATHEDRAL);
    let (nave_min, nave_max) = (CATHEDRAL_NAVE_MIN, CATHEDRAL_NAVE_MAX);
    let inner_x = steps(-10.9537, 10.9537, SWEEP_STEP);
    // Up from just above the floor, across nave and aisles along their whole length and in the apse.
    let mut floor_points: Vec<Vec3> =
        inner_x.clone().flat_map(|x| steps(nave_min.z + 0.0413, nave_max.z - 0.0413, 0.25).map(move |z| Vec3::new(x, 0.5, z))).collect();
    let apse_radius = nave_max.x - 0.05;
    floor_points.extend(
        steps(-apse_radius, apse_radius, SWEEP_STEP)
            .flat_map(|x| steps(0.0413, apse_radius, SWEEP_STEP).map(move |d| Vec3::new(x, 0.5, nave_min.z - d)))
            .filter(|p| p.x * p.x + (p.z - nave_min.z).powi(2) < apse_radius * apse_radius),
    );
    assert_eq!(assert_rays_hit_or_leave_through_windows(&caster, &floor_points, Vec3::Y), 0, "cathedral: open roof");
    // Across the building from the nave's axis, at every height.
    let axis_points: Vec<Vec3> = steps(nave_min.z + 0.0413, nave_max.z - 0.0413, SWEEP_STEP)
        .flat_map(|z| steps(0.2377, nave_max.y - 0.1, 0.25).map(move |y| Vec3::new(0.0, y, z)))
        .collect();
    let sideways = assert_rays_hit_or_leave_through_windows(&caster, &axis_points, Vec3::X)
        + assert_rays_hit_or_leave_through_windows(&caster, &axis_points, Vec3::NEG_X);
    assert!(sideways > 0, "cathedral: no horizontal ray leaves through the side windows");
    // Along the building from its middle, at every height inside.
    let cross_section: Vec<Vec3> =
        inner_x.flat_map(|x| steps(0.2377, interior_height(x) - 0.05, 0.25).map(move |y| Vec3::new(x, y, 0.0))).collect();
    assert_eq!(assert_rays_hit_or_leave_through_windows(&caster, &cross_section, Vec3::NEG_Z), 0, "cathedral: open towards the apse");
    let towards_facade = assert_rays_hit_or_leave_through_windows(&caster, &cross_section, Vec3::Z);
    assert!(towards_facade > 0, "cathedral: no ray leaves through the façade window");
}

#[test]
fn cathedral_walls_block_rays_except_at_windows() {
    let caster = RayCaster::new(&CATHEDRAL);
    let openings = cathedral_openings();
    let bays = bay_centers();
    assert_eq!(bays.len(), 8);
    for &z in &bays {
        // From the nave at a bay's centre, straight out through the arcade and the aisle: each side's
        // aisle window lets the ray out.
        let origin = Vec3::new(0.0, WINDOW_RAY_HEIGHT, z);
        for dir in [Vec3::X, Vec3::NEG_X] {
            assert!(caster.first_hit(origin, dir).is_none(), "cathedral: ray from {origin} towards {dir} blocked");
            let through = opening_crossed(openings, origin, dir).map(|o| o.name);
            assert_eq!(through, Some("aisle_window"), "cathedral: ray from {origin} towards {dir}");
        }
        // Straight up: the vault (or a rib) is above.
        assert!(caster.first_hit(origin, Vec3::Y).is_some_and(|h| h.t < 14.0), "cathedral: no vault above {origin}");
        // Off the windows' height, the same directions meet the walls.
        for y in [1.0, 8.6] {
            let origin = Vec3::new(0.0, y, z);
            for dir in [Vec3::X, Vec3::NEG_X] {
                assert!(caster.first_hit(origin, dir).is_some(), "cathedral: ray from {origin} towards {dir} escapes");
            }
        }
    }
    // Between two bays a column stands in the way.
    for pair in bays.windows(2) {
        let origin = Vec3::new(0.0, WINDOW_RAY_HEIGHT, 0.5 * (pair[0] + pair[1]));
        for dir in [Vec3::X, Vec3::NEG_X] {
            let hit = caster.first_hit(origin, dir);
            assert!(hit.as_ref().is_some_and(|h| h.t < 6.5), "cathedral: no column towards {dir} from {origin}");
        }
    }
    // Along the nave: the façade (its window is high up) and the apse close the ends.
    for (origin, dir) in
        [(Vec3::new(0.0, 5.0, 0.0), Vec3::Z), (Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Z), (Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y)]
    {
        assert!(caster.first_hit(origin, dir).is_some(), "cathedral: ray from {origin} towards {dir} escapes");
    }
    // The façade window is open.
    let origin = Vec3::new(0.0, 14.5, 0.0);
    assert!(caster.first_hit(origin, Vec3::Z).is_none(), "cathedral: façade window closed");
    assert_eq!(opening_crossed(openings, origin, Vec3::Z).map(|o| o.name), Some("facade_window"));
}

#[test]
fn cathedral_sun_shines_through_a_window_onto_the_nave_floor() {
    let caster = RayCaster::new(&CATHEDRAL);
    let patch = node_position(&CATHEDRAL, "sun_patch");
    assert!(patch.cmpgt(CATHEDRAL_NAVE_MIN - Vec3::Y).all() && patch.cmplt(CATHEDRAL_NAVE_MAX).all(), "sun patch {patch} in the nave");
    assert!(patch.y.abs() < 1e-3, "sun patch {patch} on the floor");
    let origin = patch + Vec3::Y * 0.01;
    let towards_sun = -sun_direction(&CATHEDRAL);
    assert!(caster.first_hit(origin, towards_sun).is_none(), "cathedral: the sun patch is in shadow");
    let through = opening_crossed(cathedral_openings(), origin, towards_sun).map(|o| o.name);
    assert_eq!(through, Some("clerestory_window"));
    // Floor points beside the patch, 3 m away along x, are in the shade of the walls.
    let shaded = [Vec3::new(5.0, 0.01, patch.z + 2.5), Vec3::new(-5.5, 0.01, patch.z + 2.5)];
    assert!(shaded.iter().any(|&p| caster.first_hit(p, towards_sun).is_some()), "cathedral: no shade on the nave floor");
}

// ---------------------------------------------------------------------------------------------
// forest
// ---------------------------------------------------------------------------------------------

/// The forest's instance nodes: (node index, world transform, mesh).
fn forest_instances() -> Vec<(usize, Affine3A, usize)> {
    let world = FOREST.world_transforms();
    FOREST
        .nodes
        .iter()
        .enumerate()
        .filter(|(_, n)| n.parent.is_some())
        .filter_map(|(i, n)| node_meshes(&n.content).first().map(|&(mesh, _)| (i, world[i], mesh)))
        .collect()
}

#[test]
fn forest_has_about_21_6m_instanced_triangles_from_few_unique_meshes() {
    let instanced = FOREST.instanced_triangle_count();
    let unique = FOREST.triangle_count();
    let instances = forest_instances();
    let counts: Vec<(String, usize)> = FOREST.meshes.iter().map(|m| (m.name.clone(), m.triangle_count())).collect();
    eprintln!("forest: {instanced} instanced triangles, {unique} unique, {} instances, meshes {counts:?}", instances.len());
    assert!(within_budget(instanced, FOREST_INSTANCED_TRIANGLES), "forest: {instanced} instanced triangles");
    assert!(unique < MAX_UNIQUE_TRIANGLES, "forest: {unique} unique triangles");
    assert!(instances.len() >= MIN_FOREST_INSTANCES, "forest: {} instances", instances.len());

    // Every mesh-drawing node draws exactly one mesh with one material.
    for node in &FOREST.nodes {
        let meshes = node_meshes(&node.content);
        assert!(meshes.is_empty() || meshes.len() == 1, "forest/{}: {} meshes", node.name, meshes.len());
    }
    // Tree variants of 2,000–8,000 triangles, plants of a few hundred, a terrain of at most 200k.
    let used: Vec<usize> = {
        let mut used: Vec<usize> = instances.iter().map(|&(_, _, m)| m).collect();
        used.sort_unstable();
        used.dedup();
        used
    };
    let trees = used.iter().filter(|&&m| (2_000..=8_000).contains(&FOREST.meshes[m].triangle_count())).count();
    let plants = used.iter().filter(|&&m| (100..1_000).contains(&FOREST.meshes[m].triangle_count())).count();
    assert!(trees >= 2 && plants >= 1, "forest: {trees} tree and {plants} plant meshes");
    let terrain = FOREST.meshes.iter().find(|m| m.name == "terrain").expect("terrain mesh");
    assert!(terrain.triangle_count() <= 200_000);
}

#[test]
fn forest_instances_stand_on_the_terrain() {
    let limit = 0.5 * FOREST_SIZE;
    let instances = forest_instances();
    for &(i, xf, _) in &instances {
        let name = &FOREST.nodes[i].name;
        let p: Vec3 = xf.translation.into();
        assert!(p.x.abs() <= limit && p.z.abs() <= limit, "forest/{name}: at {p}, off the terrain");
        let ground = forest_terrain_height(p.x, p.z);
        assert!((p.y - ground).abs() < TERRAIN_TOLERANCE, "forest/{name}: at height {} over ground at {ground}", p.y);
        // Turned about Y only, uniformly scaled by 0.7–1.3.
        let (scale, rotation, _) = xf.to_scale_rotation_translation();
        assert!((scale.x - scale.y).abs() < 1e-4 && (scale.x - scale.z).abs() < 1e-4, "forest/{name}: scale {scale}");
        assert!((0.7 - 1e-4..=1.3 + 1e-4).contains(&scale.x), "forest/{name}: scale {scale}");
        assert!((rotation * Vec3::Y).abs_diff_eq(Vec3::Y, 1e-4), "forest/{name}: tilted");
    }
    // Random turns: not all alike.
    let yaws: Vec<f32> =
        instances.iter().take(100).map(|&(i, _, _)| FOREST.nodes[i].transform.rotation.to_euler(glam::EulerRot::YXZ).0).collect();
    assert!(yaws.iter().any(|&y| (y - yaws[0]).abs() > 0.1), "forest: every instance faces the same way");

    // The terrain mesh follows the same function: at its vertices exactly, between them closely.
    let terrain = FOREST.meshes.iter().find(|m| m.name == "terrain").expect("terrain mesh");
    for p in &terrain.positions {
        assert!((p.y - forest_terrain_height(p.x, p.z)).abs() < 1e-4, "forest: terrain vertex {p} off the height function");
    }
    let (lo, hi) = terrain.bounds().expect("terrain");
    assert!((hi.x - lo.x - FOREST_SIZE).abs() < 1e-3 && (hi.z - lo.z - FOREST_SIZE).abs() < 1e-3, "forest: terrain {lo}..{hi}");
    for tri in terrain.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| terrain.positions[i as usize]);
        let centre = (a + b + c) / 3.0;
        let error = (centre.y - forest_terrain_height(centre.x, centre.z)).abs();
        assert!(error < TERRAIN_MESH_TOLERANCE, "forest: terrain mesh {error} m off the function at {centre}");
    }
}

#[test]
fn forest_camera_overlooks_the_forest() {
    let eye = camera_position(&FOREST);
    let (lo, hi) = FOREST.bounds().expect("geometry");
    assert!(eye.y > hi.y, "forest: camera at {eye} below the treetops ({})", hi.y);
    let margin = 0.1 * FOREST_SIZE;
    assert!(eye.x > lo.x - margin && eye.x < hi.x + margin && eye.z > lo.z - margin && eye.z < hi.z + margin);
}

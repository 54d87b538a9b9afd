//! The built-in scenes of the `scenes` crate and the mesh primitives of `engine::shapes` they are
//! built from: every scene is valid, each has the layout its documentation promises, and the
//! closed rooms are closed: rays cast from inside in every direction hit something unless they
//! leave through one of the scene's designed openings.

use std::collections::{HashMap, HashSet};
use std::f32::consts::PI;

use bevy_ecs::component::Component;
use bevy_ecs::world::World;
use engine::scene::{Camera, DirectionalLight, MeshInstance, Name, NodeContent, Orbit, PointLight, SceneDescription, SceneRoot, SpotLight};
use engine::shapes::{box_with_hole, cuboid, merge, quad};
use glam::{Affine3A, Quat, Vec2, Vec3};
use scenes::{Opening, SceneEntry};
use workspace_tests::assert_valid_mesh;
use workspace_tests::cpu_rays::{fibonacci_directions, intersect};

/// The small test scenes checked here; `cathedral` and `forest` (benchmark scale) are covered by
/// `tests/large_scenes.rs`.
const SMALL_SCENES: [&str; 5] = ["cornell", "ceiling_opening", "door_room", "door_room_thin", "color_bleed"];

/// Rays cast from each interior point: Fibonacci directions cover the sphere evenly.
const RAY_COUNT: usize = 2000;
/// How far an escaping ray's exit point may lie outside its opening (metres).
const OPENING_TOLERANCE: f32 = 1e-3;
/// Test points stand this far above the floor they are marked on, so that rays start in the air.
const ABOVE_FLOOR: f32 = 0.01;
/// Allowed deviation of a normal's length from 1.
const UNIT_TOLERANCE: f32 = 1e-4;
/// Aspect ratio of the headless renderer's default 640 × 480 frame.
const DEFAULT_ASPECT: f32 = 4.0 / 3.0;

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

fn count<C: Component>(world: &mut World) -> usize {
    world.query::<&C>().iter(world).count()
}

fn entry(name: &str) -> &'static SceneEntry {
    scenes::find(name).unwrap_or_else(|| panic!("built-in scene {name} is missing"))
}

fn scene(name: &str) -> SceneDescription {
    (entry(name).build)()
}

fn node_index(desc: &SceneDescription, name: &str) -> usize {
    desc.nodes.iter().position(|n| n.name == name).unwrap_or_else(|| panic!("{}: no node named {name}", desc.name))
}

fn node_position(desc: &SceneDescription, name: &str) -> Vec3 {
    desc.world_transforms()[node_index(desc, name)].translation.into()
}

/// The camera node's world transform and camera.
fn camera(desc: &SceneDescription) -> (Affine3A, Camera) {
    let world = desc.world_transforms();
    desc.nodes
        .iter()
        .zip(world)
        .find_map(|(node, xf)| {
            node.content.iter().find_map(|c| match c {
                NodeContent::Camera(camera) => Some((xf, *camera)),
                _ => None,
            })
        })
        .unwrap_or_else(|| panic!("{}: no camera", desc.name))
}

/// The direction sunlight travels in a scene with a directional light.
fn sun_direction(desc: &SceneDescription) -> Vec3 {
    let world = desc.world_transforms();
    desc.nodes
        .iter()
        .zip(world)
        .find(|(node, _)| node.content.iter().any(|c| matches!(c, NodeContent::DirectionalLight(_))))
        .map(|(_, xf)| xf.transform_vector3(Vec3::NEG_Z).normalize())
        .unwrap_or_else(|| panic!("{}: no directional light", desc.name))
}

/// A world-space triangle and the node that draws it.
struct Triangle {
    a: Vec3,
    b: Vec3,
    c: Vec3,
    node: usize,
}

/// Every triangle of every mesh instance of the nodes that `keep` accepts, in world space.
fn world_triangles(desc: &SceneDescription, keep: impl Fn(&str) -> bool) -> Vec<Triangle> {
    let world = desc.world_transforms();
    let mut out = Vec::new();
    for (index, (node, xf)) in desc.nodes.iter().zip(&world).enumerate() {
        if !keep(&node.name) {
            continue;
        }
        for content in &node.content {
            let NodeContent::Meshes(list) = content else {
                continue;
            };
            for &(mesh, _) in list {
                let mesh = &desc.meshes[mesh];
                for tri in mesh.indices.chunks_exact(3) {
                    let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| xf.transform_point3(mesh.positions[i as usize]));
                    out.push(Triangle { a, b, c, node: index });
                }
            }
        }
    }
    out
}

fn all_triangles(desc: &SceneDescription) -> Vec<Triangle> {
    world_triangles(desc, |_| true)
}

/// The nearest hit along the ray: (distance, triangle index).
fn first_hit(origin: Vec3, dir: Vec3, tris: &[Triangle]) -> Option<(f32, usize)> {
    tris.iter()
        .enumerate()
        .filter_map(|(i, tri)| intersect(origin, dir, [tri.a, tri.b, tri.c]).map(|t| (t, i)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

/// Nothing blocks the straight line from `from` to `to` (allowing `slack` metres at the far end).
fn unobstructed(from: Vec3, to: Vec3, tris: &[Triangle], slack: f32) -> bool {
    let distance = from.distance(to);
    first_hit(from, (to - from) / distance, tris).is_none_or(|(t, _)| t >= distance - slack)
}

/// Where a ray leaves through `opening`'s outer face (the face along the opening's thinnest axis
/// that the ray crosses last), if it does, within the tolerance.
fn exit_through(opening: &Opening, origin: Vec3, dir: Vec3) -> Option<Vec3> {
    let size = opening.max - opening.min;
    let axis = (0..3).min_by(|&a, &b| size[a].total_cmp(&size[b])).unwrap();
    if dir[axis].abs() < 1e-6 {
        return None;
    }
    let plane = if dir[axis] > 0.0 { opening.max[axis] } else { opening.min[axis] };
    let t = (plane - origin[axis]) / dir[axis];
    if t <= 0.0 {
        return None;
    }
    let exit = origin + dir * t;
    let inside = (0..3)
        .filter(|&a| a != axis)
        .all(|a| exit[a] >= opening.min[a] - OPENING_TOLERANCE && exit[a] <= opening.max[a] + OPENING_TOLERANCE);
    inside.then_some(exit)
}

/// Casts [`RAY_COUNT`] rays from `origin`; every ray must hit a triangle or leave through one of
/// `openings`. Returns how many left through each opening.
fn assert_closed_except(scene: &str, origin: Vec3, tris: &[Triangle], openings: &[Opening]) -> Vec<usize> {
    let mut escaped = vec![0; openings.len()];
    for dir in fibonacci_directions(RAY_COUNT) {
        if first_hit(origin, dir, tris).is_some() {
            continue;
        }
        let through = openings.iter().position(|o| exit_through(o, origin, dir).is_some());
        let Some(through) = through else {
            panic!("{scene}: a ray from {origin} towards {dir} escapes outside every designed opening");
        };
        escaped[through] += 1;
    }
    escaped
}

/// `point` is inside the camera's frustum (frame of the given aspect ratio).
fn in_frustum(desc: &SceneDescription, point: Vec3, aspect: f32) -> bool {
    let (xf, camera) = camera(desc);
    let local = xf.inverse().transform_point3(point);
    let depth = -local.z;
    let tan_half = (camera.yfov * 0.5).tan();
    depth > camera.znear && local.y.abs() <= depth * tan_half && local.x.abs() <= depth * tan_half * aspect
}

/// `point` (on a surface) is seen by the camera: inside its frustum and not hidden.
fn camera_sees(desc: &SceneDescription, point: Vec3, tris: &[Triangle]) -> bool {
    let eye: Vec3 = camera(desc).0.translation.into();
    in_frustum(desc, point, DEFAULT_ASPECT) && unobstructed(eye, point, tris, ABOVE_FLOOR)
}

/// The box reached by rays from `p` along the six axis directions (the room around `p`).
fn axis_extent(p: Vec3, tris: &[Triangle]) -> (Vec3, Vec3) {
    let reach = |dir: Vec3| first_hit(p, dir, tris).expect("closed along every axis").0;
    let lo = p - Vec3::new(reach(Vec3::NEG_X), reach(Vec3::NEG_Y), reach(Vec3::NEG_Z));
    let hi = p + Vec3::new(reach(Vec3::X), reach(Vec3::Y), reach(Vec3::Z));
    (lo, hi)
}

/// Points evenly spaced from `lo` to `hi` (both included), `steps[axis]` intervals per axis (0: just
/// `lo` along that axis).
fn grid(lo: Vec3, hi: Vec3, steps: [usize; 3]) -> impl Iterator<Item = Vec3> {
    let at = move |axis: usize, i: usize| {
        if steps[axis] == 0 { lo[axis] } else { lo[axis] + (hi[axis] - lo[axis]) * i as f32 / steps[axis] as f32 }
    };
    (0..=steps[0]).flat_map(move |i| (0..=steps[1]).flat_map(move |j| (0..=steps[2]).map(move |k| Vec3::new(at(0, i), at(1, j), at(2, k)))))
}

/// World-space bounds of one node's meshes.
fn node_bounds(desc: &SceneDescription, name: &str) -> (Vec3, Vec3) {
    let index = node_index(desc, name);
    let tris = world_triangles(desc, |n| n == name);
    assert!(!tris.is_empty(), "{}: node {name} has no triangles", desc.name);
    tris.iter()
        .filter(|t| t.node == index)
        .flat_map(|t| [t.a, t.b, t.c])
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p), hi.max(p)))
}

/// Mean of the world positions of one node's vertices.
fn node_centroid(desc: &SceneDescription, index: usize) -> Vec3 {
    let xf = desc.world_transforms()[index];
    let mut sum = Vec3::ZERO;
    let mut vertices = 0;
    for content in &desc.nodes[index].content {
        let NodeContent::Meshes(list) = content else {
            continue;
        };
        for &(mesh, _) in list {
            for &p in &desc.meshes[mesh].positions {
                sum += xf.transform_point3(p);
                vertices += 1;
            }
        }
    }
    assert!(vertices > 0, "{}: node {} has no vertices", desc.name, desc.nodes[index].name);
    sum / vertices as f32
}

/// The nodes drawn with a material whose albedo satisfies `pick`.
fn nodes_with_albedo(desc: &SceneDescription, pick: impl Fn(Vec3) -> bool) -> Vec<usize> {
    (0..desc.nodes.len())
        .filter(|&i| {
            desc.nodes[i].content.iter().any(|c| match c {
                NodeContent::Meshes(list) => list.iter().any(|&(_, m)| pick(desc.materials[m].base_color.truncate())),
                _ => false,
            })
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Primitives (engine::shapes)
// ---------------------------------------------------------------------------------------------

#[test]
fn quad_lies_in_xz_facing_up() {
    let mesh = quad("q", Vec2::new(3.0, 2.0));
    assert_valid_mesh("primitives", &mesh);
    assert_eq!(mesh.name, "q");
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.triangle_count(), 2);
    assert!(mesh.normals.iter().all(|&n| n == Vec3::Y));
    assert_eq!(mesh.bounds(), Some((Vec3::new(-1.5, 0.0, -1.0), Vec3::new(1.5, 0.0, 1.0))));
    let uv_range = (Vec2::ZERO, Vec2::ONE);
    assert_eq!(mesh.uvs.iter().fold((Vec2::ONE, Vec2::ZERO), |(lo, hi), &uv| (lo.min(uv), hi.max(uv))), uv_range);
}

#[test]
fn cuboid_is_a_closed_box_with_outward_normals() {
    let half = Vec3::new(0.5, 1.0, 2.0);
    let mesh = cuboid("box", half);
    assert_valid_mesh("primitives", &mesh);
    assert_eq!(mesh.positions.len(), 24);
    assert_eq!(mesh.indices.len(), 36);
    assert_eq!(mesh.bounds(), Some((-half, half)));
    assert!(mesh.uvs.iter().all(|uv| uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()));
    for tri in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let face = (b - a).cross(c - a).normalize();
        assert!(face.dot(mesh.normals[tri[0] as usize]) > 1.0 - UNIT_TOLERANCE, "flat faces");
        assert!(face.dot((a + b + c) / 3.0) > 0.0, "normals point outwards");
    }
    // Closed and consistently wound: every edge (by position) is used once in each direction.
    let key = |p: Vec3| p.to_array().map(f32::to_bits);
    let mut edges: HashMap<_, i32> = HashMap::new();
    for tri in mesh.indices.chunks_exact(3) {
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let (p, q) = (mesh.positions[tri[i] as usize], mesh.positions[tri[j] as usize]);
            *edges.entry(key(p).into_iter().chain(key(q)).collect::<Vec<_>>()).or_default() += 1;
        }
    }
    for (edge, count) in &edges {
        let reversed: Vec<u32> = edge[3..].iter().chain(&edge[..3]).copied().collect();
        assert_eq!(*count, 1, "edge used more than once in the same direction");
        assert_eq!(edges.get(&reversed), Some(&1), "open edge");
    }
}

#[test]
fn merge_transforms_normals_and_keeps_winding_under_mirroring() {
    let mirror = Affine3A::from_scale_rotation_translation(Vec3::new(-1.0, 2.0, 0.5), Quat::from_rotation_y(0.7), Vec3::new(3.0, 0.0, 0.0));
    let shear = Affine3A::from_cols_array(&[1.0, 0.0, 0.0, 0.8, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0]);
    let mut no_uvs = quad("plain", Vec2::ONE);
    no_uvs.uvs.clear();
    let parts = [
        (cuboid("a", Vec3::ONE), Affine3A::IDENTITY),
        (cuboid("b", Vec3::splat(0.5)), mirror),
        (cuboid("c", Vec3::splat(0.5)), shear),
        (no_uvs, Affine3A::from_translation(Vec3::Y * 5.0)),
    ];
    let merged = merge("merged", &parts);
    assert_eq!(merged.name, "merged");
    assert_valid_mesh("primitives", &merged);
    assert_eq!(merged.positions.len(), 24 * 3 + 4);
    assert_eq!(merged.indices.len(), 36 * 3 + 6);
    assert_eq!(merged.uvs.len(), merged.positions.len(), "zeros fill in for the part without uvs");
    // Flat faces stay flat: each vertex normal is its face's geometric normal, mirrored and
    // sheared parts included (the inverse transpose, not the matrix itself).
    for tri in merged.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| merged.positions[i as usize]);
        let face = (b - a).cross(c - a).normalize();
        for &i in tri {
            let n = merged.normals[i as usize];
            assert!(face.dot(n) > 1.0 - UNIT_TOLERANCE, "normal {n} is not the face normal {face}");
        }
    }
    // The mirrored box's positions are its own box's, moved.
    let mirrored_first = merged.positions[24];
    assert!(mirrored_first.abs_diff_eq(mirror.transform_point3(parts[1].0.positions[0]), 1e-6));
}

#[test]
fn box_with_hole_is_closed_except_through_the_hole() {
    let (min, max) = (Vec3::new(-2.0, 0.0, -0.1), Vec3::new(2.0, 3.0, 0.1));
    let (hole_min, hole_max) = (Vec3::new(-0.5, 0.0, -1.0), Vec3::new(0.5, 2.0, 1.0));
    let desc = {
        let mut desc = SceneDescription { name: "hole".into(), ..Default::default() };
        let material = desc.add_material(engine::scene::Material::diffuse("m", Vec3::splat(0.5)));
        let mesh = desc.add_mesh(merge("slab", &box_with_hole(min, max, hole_min, hole_max)));
        desc.add_node("slab", Default::default(), None, vec![NodeContent::Meshes(vec![(mesh, material)])]);
        desc
    };
    assert_valid_mesh("hole", &desc.meshes[0]);
    let tris = all_triangles(&desc);
    // A grid of rays straight through the slab: they pass exactly where the hole is.
    for ix in 0..40 {
        for iy in 0..30 {
            let p = Vec3::new(-1.95 + 0.1 * ix as f32, 0.05 + 0.1 * iy as f32, 1.0);
            let in_hole = p.x > hole_min.x && p.x < hole_max.x && p.y < hole_max.y;
            let hit = first_hit(p, Vec3::NEG_Z, &tris).is_some();
            assert_eq!(hit, !in_hole, "ray at {p}");
        }
    }
    // A hole that misses the slab leaves it whole.
    assert_eq!(box_with_hole(min, max, Vec3::splat(5.0), Vec3::splat(6.0)).len(), 1);
}

// ---------------------------------------------------------------------------------------------
// Every scene
// ---------------------------------------------------------------------------------------------

#[test]
fn every_scene_is_valid() {
    for name in SMALL_SCENES {
        let desc = scene(name);
        for mesh in &desc.meshes {
            assert_valid_mesh(name, mesh);
        }

        let mut material_names = HashSet::new();
        for m in &desc.materials {
            assert!(!m.name.is_empty(), "{name}: unnamed material");
            assert!(material_names.insert(&m.name), "{name}: material name {} twice", m.name);
            let albedo = m.base_color.truncate();
            assert!(albedo.cmpge(Vec3::ZERO).all() && albedo.cmplt(Vec3::ONE).all(), "{name}/{}: albedo {albedo} outside [0, 1)", m.name);
            assert_eq!(m.base_color.w, 1.0, "{name}/{}: opaque", m.name);
            assert!(m.emissive.is_finite() && m.emissive.cmpge(Vec3::ZERO).all());
        }

        let mut node_names = HashSet::new();
        let mut lights = 0;
        let mut cameras = 0;
        for (i, node) in desc.nodes.iter().enumerate() {
            assert!(!node.name.is_empty(), "{name}: node {i} has no name");
            assert!(node_names.insert(&node.name), "{name}: node name {} twice", node.name);
            assert!(node.parent.is_none_or(|p| p < i), "{name}/{}: parent after child", node.name);
            let t = &node.transform;
            assert!(t.translation.is_finite() && t.scale.is_finite() && t.rotation.is_normalized());
            for content in &node.content {
                match content {
                    NodeContent::Meshes(list) => {
                        assert!(!list.is_empty(), "{name}/{}: empty mesh list", node.name);
                        for &(mesh, material) in list {
                            assert!(mesh < desc.meshes.len() && material < desc.materials.len());
                        }
                    }
                    NodeContent::Camera(c) => {
                        cameras += 1;
                        assert!(c.yfov > 10f32.to_radians() && c.yfov < 120f32.to_radians());
                        assert!(c.znear > 0.0 && c.exposure > 0.0);
                    }
                    NodeContent::DirectionalLight(DirectionalLight { color, intensity })
                    | NodeContent::PointLight(PointLight { color, intensity, .. })
                    | NodeContent::SpotLight(SpotLight { color, intensity, .. }) => {
                        lights += 1;
                        assert!(intensity.is_finite() && *intensity > 0.0, "{name}: light intensity");
                        assert!(color.cmpge(Vec3::ZERO).all() && color.cmple(Vec3::ONE).all());
                        assert!(color.max_element() > 0.0);
                    }
                    NodeContent::Empty => {}
                }
            }
        }
        assert_eq!(cameras, 1, "{name}: one camera");
        assert!(desc.has_camera());
        assert!(lights >= 1, "{name}: no light");

        let (lo, hi) = desc.bounds().expect("scene has geometry");
        let size = hi - lo;
        assert!(lo.is_finite() && hi.is_finite());
        assert!(size.cmpgt(Vec3::splat(0.5)).all() && size.cmplt(Vec3::splat(100.0)).all(), "{name}: bounds {lo}..{hi}");
        let eye: Vec3 = camera(&desc).0.translation.into();
        let margin = Vec3::splat(10.0);
        assert!(eye.cmpge(lo - margin).all() && eye.cmple(hi + margin).all(), "{name}: camera far from the scene");
    }
}

#[test]
fn every_scene_spawns_one_entity_per_node_and_mesh_instance() {
    for name in scenes::names() {
        let desc = scene(name);
        let instances: usize = desc
            .nodes
            .iter()
            .flat_map(|n| &n.content)
            .map(|c| match c {
                NodeContent::Meshes(list) => list.len(),
                _ => 0,
            })
            .sum();
        let count_content = |f: fn(&NodeContent) -> bool| desc.nodes.iter().flat_map(|n| &n.content).filter(|c| f(c)).count();
        let cameras = count_content(|c| matches!(c, NodeContent::Camera(_)));
        let suns = count_content(|c| matches!(c, NodeContent::DirectionalLight(_)));
        let points = count_content(|c| matches!(c, NodeContent::PointLight(_)));
        let spots = count_content(|c| matches!(c, NodeContent::SpotLight(_)));
        let orbits = desc.nodes.iter().filter(|n| n.orbit.is_some()).count();
        let nodes = desc.nodes.len();
        let meshes = desc.meshes.len();

        let mut world = World::new();
        desc.spawn(&mut world);
        assert_eq!(count::<MeshInstance>(&mut world), instances, "{name}: mesh instances");
        // The root, one entity per node and one per mesh instance: all named.
        assert_eq!(count::<Name>(&mut world), 1 + nodes + instances, "{name}: named entities");
        assert_eq!(count::<SceneRoot>(&mut world), 1, "{name}: roots");
        assert_eq!(count::<Camera>(&mut world), cameras, "{name}: cameras");
        assert_eq!(count::<DirectionalLight>(&mut world), suns, "{name}: directional lights");
        assert_eq!(count::<PointLight>(&mut world), points, "{name}: point lights");
        assert_eq!(count::<SpotLight>(&mut world), spots, "{name}: spot lights");
        assert_eq!(count::<Orbit>(&mut world), orbits, "{name}: orbits");
        let stored = world.resource::<engine::scene::Assets<engine::scene::Mesh>>().len();
        assert_eq!(stored, meshes, "{name}: every mesh stored");
    }
}

#[test]
fn closed_rooms_are_closed_except_through_their_openings() {
    // Interior points per scene, by marker node or fixed offset from one; rays from each must
    // all hit something or leave through a designed opening.
    for name in SMALL_SCENES {
        let desc = scene(name);
        let openings = (entry(name).openings)();
        // The ground is outside the room: rays through the door would hit it.
        let tris = world_triangles(&desc, |n| n != "ground");
        let mut origins = vec![camera(&desc).0.translation.into()];
        let up = Vec3::Y * ABOVE_FLOOR;
        match name {
            "cornell" => {
                let light = node_position(&desc, "lamp_light");
                let opening = (openings[0].min + openings[0].max) * 0.5 - Vec3::Z * 0.1;
                origins = vec![light, opening, (light + opening) * 0.5];
            }
            "ceiling_opening" => {
                origins.push(node_position(&desc, "sun_patch") + up);
                origins.push(node_position(&desc, "dark_corner") + up);
            }
            "door_room" | "door_room_thin" => {
                // The camera stands outside: only interior points.
                let corner = node_position(&desc, "interior_corner") + up;
                let door = node_position(&desc, "door");
                origins = vec![corner, node_position(&desc, "sun_patch") + up, (corner + door) * 0.5];
            }
            "color_bleed" => {
                // Every point of the spot's orbit.
                let orbit = desc.nodes[node_index(&desc, "spot")].orbit.expect("spot orbits");
                for i in 0..8 {
                    let angle = i as f32 * PI / 4.0;
                    let (s, c) = angle.sin_cos();
                    origins.push(orbit.center + Vec3::new(c, 0.0, s) * orbit.radius);
                }
            }
            other => panic!("no interior points for {other}"),
        }
        for origin in origins {
            let escaped = assert_closed_except(name, origin, &tris, openings);
            if name.starts_with("door_room") || name == "cornell" {
                assert!(escaped.iter().sum::<usize>() > 0, "{name}: the opening is seen from {origin}");
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// cornell
// ---------------------------------------------------------------------------------------------

#[test]
fn cornell_has_red_left_and_green_right_walls() {
    let desc = scene("cornell");
    let red = nodes_with_albedo(&desc, |c| c.x > 0.5 && c.y < 0.2 && c.z < 0.2);
    let green = nodes_with_albedo(&desc, |c| c.y > 0.3 && c.y > 2.0 * c.x && c.y > 2.0 * c.z);
    assert_eq!((red.len(), green.len()), (1, 1), "one red and one green wall");
    let (red, green) = (node_centroid(&desc, red[0]), node_centroid(&desc, green[0]));
    assert!(red.x < green.x, "red wall at {red}, green at {green}");
    // Left and right as the camera sees them.
    let (xf, _) = camera(&desc);
    let right = xf.transform_vector3(Vec3::X);
    let eye: Vec3 = xf.translation.into();
    assert!((red - eye).dot(right) < 0.0 && (green - eye).dot(right) > 0.0);
}

#[test]
fn cornell_light_is_inside_and_lights_the_floor_moderately() {
    let desc = scene("cornell");
    let opening = (entry("cornell").openings)()[0];
    let light_node = node_index(&desc, "lamp_light");
    let light = node_position(&desc, "lamp_light");
    let (lo, _) = desc.bounds().unwrap();
    let inside = light.x > opening.min.x
        && light.x < opening.max.x
        && light.y > opening.min.y
        && light.y < opening.max.y
        && light.z > lo.z
        && light.z < opening.min.z;
    assert!(inside, "light {light} inside the box");
    let NodeContent::PointLight(point) = desc.nodes[light_node].content[0] else { panic!("lamp_light is a point light") };
    // Straight down, the light sees the floor centre; its irradiance there is I / d².
    let tris = all_triangles(&desc);
    let (distance, tri) = first_hit(light, Vec3::NEG_Y, &tris).expect("floor below the light");
    let floor = light + Vec3::NEG_Y * distance;
    assert_eq!(desc.nodes[tris[tri].node].name, "white_walls");
    assert!(floor.y.abs() < 1e-3 && floor.x.abs() < 0.1 && floor.z.abs() < 0.1, "floor centre {floor}");
    let irradiance = point.intensity / (distance * distance);
    assert!((2.0..=5.0).contains(&irradiance), "floor irradiance {irradiance} W/m²");

    // The visible lamp is an emissive quad facing down, just above the light.
    let lamp = node_index(&desc, "lamp");
    let NodeContent::Meshes(list) = &desc.nodes[lamp].content[0] else { panic!("lamp has a mesh") };
    let (mesh, material) = list[0];
    assert!(desc.materials[material].is_emissive());
    assert!(desc.meshes[mesh].normals.iter().all(|n| n.y < -0.99));
    let lamp_y = node_position(&desc, "lamp").y;
    assert!(lamp_y > light.y && lamp_y < opening.max.y);
}

#[test]
fn cornell_camera_sees_the_whole_box() {
    let desc = scene("cornell");
    let (_, camera) = camera(&desc);
    assert!((camera.yfov.to_degrees() - 40.0).abs() < 5.0);
    let (lo, hi) = desc.bounds().unwrap();
    for i in 0..8 {
        let corner =
            Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
        // A square frame: the most conservative aspect.
        assert!(in_frustum(&desc, corner, 1.0), "corner {corner} out of view");
    }
}

#[test]
fn cornell_escapes_only_out_of_the_open_front() {
    let desc = scene("cornell");
    let tris = all_triangles(&desc);
    let origin = node_position(&desc, "lamp_light");
    let mut front = 0;
    for dir in fibonacci_directions(RAY_COUNT) {
        let hit = first_hit(origin, dir, &tris).is_some();
        assert!(hit || dir.z > 0.0, "a ray towards {dir} escapes but not out of the front");
        front += usize::from(!hit);
    }
    assert!(front > 0);
}

// ---------------------------------------------------------------------------------------------
// ceiling_opening
// ---------------------------------------------------------------------------------------------

#[test]
fn ceiling_opening_dark_half_gets_no_direct_sun() {
    let desc = scene("ceiling_opening");
    let tris = all_triangles(&desc);
    let to_sun = -sun_direction(&desc);
    let sun_patch = node_position(&desc, "sun_patch");
    let dark_corner = node_position(&desc, "dark_corner");
    let up = Vec3::Y * ABOVE_FLOOR;
    assert!(first_hit(sun_patch + up, to_sun, &tris).is_none(), "the sun patch is sunlit");
    assert!(first_hit(dark_corner + up, to_sun, &tris).is_some(), "the dark corner is in shade");

    // The divider splits the room; the dark half is the side without the sun patch.
    let (div_lo, div_hi) = node_bounds(&desc, "divider");
    assert!(sun_patch.x < div_lo.x && dark_corner.x > div_hi.x);
    // The lit face of the divider catches sun at its foot: a bright face with a dark back.
    let lit_face = Vec3::new(div_lo.x - ABOVE_FLOOR, sun_patch.y + 0.1, sun_patch.z);
    assert!(first_hit(lit_face, to_sun, &tris).is_none(), "the divider's lit face is sunlit");

    // Every point of the dark half is in shade; some of the lit half's floor is not. Each half's
    // extent is measured by rays along the axes from its marker.
    const STEPS: usize = 8;
    let inset = Vec3::splat(0.05);
    let (dark_lo, dark_hi) = axis_extent(dark_corner + up, &tris);
    assert!(dark_lo.x >= div_hi.x - 1e-4, "the dark half ends at the divider");
    for p in grid(dark_lo + inset, dark_hi - inset, [STEPS; 3]) {
        assert!(first_hit(p, to_sun, &tris).is_some(), "direct sun reaches {p} in the dark half");
    }
    let (lit_lo, lit_hi) = axis_extent(sun_patch + up, &tris);
    assert!(lit_hi.x <= div_lo.x + 1e-4, "the lit half ends at the divider");
    let floor = |p: Vec3| p.with_y(lit_lo.y + ABOVE_FLOOR);
    let lit =
        grid(floor(lit_lo + inset), floor(lit_hi - inset), [STEPS, 0, STEPS]).filter(|&p| first_hit(p, to_sun, &tris).is_none()).count();
    assert!(lit > 0, "some floor in the lit half is sunlit");
}

#[test]
fn ceiling_opening_camera_sees_both_halves() {
    let desc = scene("ceiling_opening");
    let tris = all_triangles(&desc);
    for marker in ["sun_patch", "dark_corner"] {
        let p = node_position(&desc, marker) + Vec3::Y * ABOVE_FLOOR;
        assert!(camera_sees(&desc, p, &tris), "the camera sees {marker}");
    }
    let opening = (entry("ceiling_opening").openings)()[0];
    assert!(in_frustum(&desc, (opening.min + opening.max) * 0.5, DEFAULT_ASPECT), "skylight in view");
}

// ---------------------------------------------------------------------------------------------
// door_room
// ---------------------------------------------------------------------------------------------

/// Both door rooms: the thick-walled one and its thin-walled variant.
const DOOR_ROOMS: [&str; 2] = ["door_room", "door_room_thin"];

#[test]
fn door_rooms_leak_only_through_the_door() {
    for name in DOOR_ROOMS {
        door_room_leaks_only_through_the_door(name);
    }
}

fn door_room_leaks_only_through_the_door(name: &str) {
    let desc = scene(name);
    let door = (entry(name).openings)()[0];
    assert_eq!(door.name, "door");
    let door_node = node_position(&desc, "door");
    assert!(door_node.abs_diff_eq((door.min + door.max) * 0.5, 1e-5), "door node at the opening's centre");

    // Rays from the interior corner, ground left out: those that get out leave through the door.
    let room = world_triangles(&desc, |n| n != "ground");
    let corner = node_position(&desc, "interior_corner") + Vec3::Y * ABOVE_FLOOR;
    let mut escaped = 0;
    for dir in fibonacci_directions(RAY_COUNT) {
        if first_hit(corner, dir, &room).is_some() {
            continue;
        }
        let exit = exit_through(&door, corner, dir);
        assert!(exit.is_some(), "a ray towards {dir} leaves the room outside the door");
        escaped += 1;
    }
    assert!(escaped > 0, "the door is seen from the interior corner");
}

#[test]
fn door_rooms_sun_lights_ground_and_a_patch_inside_but_not_the_corner() {
    for name in DOOR_ROOMS {
        door_room_sun_lights_ground_and_a_patch_inside_but_not_the_corner(name);
    }
}

fn door_room_sun_lights_ground_and_a_patch_inside_but_not_the_corner(name: &str) {
    let desc = scene(name);
    let tris = all_triangles(&desc);
    let to_sun = -sun_direction(&desc);
    assert!(to_sun.y > 0.0);
    let up = Vec3::Y * ABOVE_FLOOR;
    let corner = node_position(&desc, "interior_corner");
    let patch = node_position(&desc, "sun_patch");
    let door = node_position(&desc, "door");
    assert!(first_hit(patch + up, to_sun, &tris).is_none(), "the sun patch inside is sunlit");
    assert!(first_hit(corner + up, to_sun, &tris).is_some(), "the interior corner is in shade");
    assert!(corner.distance(door) > patch.distance(door));
    // Both markers are on the floor.
    for p in [corner, patch] {
        let (t, hit) = first_hit(p + up, Vec3::NEG_Y, &tris).expect("floor below");
        assert!((t - ABOVE_FLOOR).abs() < 1e-3 && desc.nodes[tris[hit].node].name == "floor");
    }
    // The ground in front of the door is sunlit and in view, as is the corner through the door.
    let eye: Vec3 = camera(&desc).0.translation.into();
    let outwards = (eye - door).with_y(0.0).normalize();
    let ground = (door + outwards).with_y(0.0);
    let (t, hit) = first_hit(ground + up, Vec3::NEG_Y, &tris).expect("ground");
    assert!(t < 2.0 * ABOVE_FLOOR && desc.nodes[tris[hit].node].name == "ground");
    assert!(first_hit(ground + up, to_sun, &tris).is_none(), "the ground by the door is sunlit");
    assert!(camera_sees(&desc, ground + up, &tris), "the camera sees the ground");
    assert!(camera_sees(&desc, corner + up, &tris), "the camera sees the interior corner");
}

// ---------------------------------------------------------------------------------------------
// color_bleed
// ---------------------------------------------------------------------------------------------

#[test]
fn color_bleed_spot_orbits_and_sweeps_both_objects() {
    let desc = scene("color_bleed");
    let spot_index = node_index(&desc, "spot");
    let node = &desc.nodes[spot_index];
    let NodeContent::SpotLight(spot) = node.content[0] else { panic!("spot is a spot light") };
    assert!((spot.inner_cone_angle.to_degrees() - 20.0).abs() < 2.0);
    assert!((spot.outer_cone_angle.to_degrees() - 30.0).abs() < 2.0);
    let orbit = node.orbit.expect("the spot orbits");
    assert!((orbit.period - 8.0).abs() < 1.0 && orbit.radius > 0.0);
    let target = orbit.look_at.expect("the spot keeps aiming");

    // It starts where the orbit puts it at t = 0, aimed at the target.
    let start = desc.world_transforms()[spot_index];
    let start_pos: Vec3 = start.translation.into();
    assert!(start_pos.abs_diff_eq(orbit.center + Vec3::X * orbit.radius, 1e-5));
    let forward = start.transform_vector3(Vec3::NEG_Z).normalize();
    assert!(forward.dot((target - start_pos).normalize()) > 0.9999);

    // The target is on the floor, and the spot's cone takes in each object at some point of its
    // orbit.
    let tris = all_triangles(&desc);
    let (t, _) = first_hit(target + Vec3::Y * ABOVE_FLOOR, Vec3::NEG_Y, &tris).expect("floor");
    assert!(t < 2.0 * ABOVE_FLOOR);
    let red = nodes_with_albedo(&desc, |c| c.x > 5.0 * c.y.max(c.z));
    let blue = nodes_with_albedo(&desc, |c| c.z > 5.0 * c.x.max(c.y));
    assert_eq!((red.len(), blue.len()), (1, 1), "one saturated red and one saturated blue object");
    for object in [red[0], blue[0]] {
        let centre = node_centroid(&desc, object);
        let covered = (0..32).any(|i| {
            let (s, c) = (i as f32 * PI / 16.0).sin_cos();
            let p = orbit.center + Vec3::new(c, 0.0, s) * orbit.radius;
            let axis = (target - p).normalize();
            axis.dot((centre - p).normalize()) > spot.outer_cone_angle.cos()
        });
        assert!(covered, "the spot never points at {}", desc.nodes[object].name);
    }
}

#[test]
fn color_bleed_camera_sees_both_objects() {
    let desc = scene("color_bleed");
    let tris = all_triangles(&desc);
    let (xf, _) = camera(&desc);
    let eye: Vec3 = xf.translation.into();
    for name in ["red_cube", "blue_box"] {
        let index = node_index(&desc, name);
        let centre = node_centroid(&desc, index);
        assert!(in_frustum(&desc, centre, DEFAULT_ASPECT), "{name} in view");
        let (_, hit) = first_hit(eye, (centre - eye).normalize(), &tris).expect("something in view");
        assert_eq!(tris[hit].node, index, "the camera's ray towards {name} hits it first");
    }
}

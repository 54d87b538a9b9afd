//! The ray-tracing core against a brute-force CPU reference, on lavapipe in CI: closest hits on
//! thousands of random rays (scaled, rotated and moving instances), any-hit against closest-hit, and
//! hard shadows in the camera path.

use engine::app::{EnginePlugin, Time, run_headless};
use engine::bevy_app::App;
use engine::headless::{HeadlessSettings, render_scene};
use engine::render::{GpuScene, RenderPlugin, RenderSize};
use engine::rng::SplitMix64;
use engine::rt::cpu::{CpuScene, GpuRay, TraceResult};
use engine::rt::{RayTracer, RayTracingScene, WaitForBlasBuilds};
use engine::scene::{Assets, Camera, Material, Mesh, NodeContent, PointLight, SceneDescription, Transform};
use glam::{Quat, Vec2, Vec3};

fn app_for(gpu: &engine::gpu::GpuContext, scene: SceneDescription) -> App {
    let mut app = engine::headless::headless_app(gpu, RenderSize { width: 8, height: 8 }, 1.0 / 60.0);
    scene.spawn(app.world_mut());
    run_headless(&mut app, 1);
    app
}

fn trace(app: &App, gpu: &engine::gpu::GpuContext, rays: &[GpuRay], any: bool) -> Vec<TraceResult> {
    let tracer = RayTracer::new(gpu).expect("trace shader");
    tracer.trace(gpu, app.world().resource::<GpuScene>(), app.world().resource::<RayTracingScene>(), rays, any)
}

fn cpu_reference(app: &App) -> CpuScene {
    let world = app.world();
    let meshes = world.resource::<Assets<Mesh>>();
    let list: Vec<&Mesh> = meshes.iter().map(|(_, m)| m).collect();
    CpuScene::new(&world.resource::<GpuScene>().live_instances(), &list)
}

/// Random rays from inside (and around) the scene's bounds with directions of random length.
fn random_rays(bounds: (Vec3, Vec3), count: usize, seed: u64) -> Vec<GpuRay> {
    let mut rng = SplitMix64::new(seed);
    let (lo, hi) = bounds;
    let pad = (hi - lo) * 0.25;
    (0..count)
        .map(|_| {
            let o = Vec3::new(
                rng.range(lo.x - pad.x, hi.x + pad.x),
                rng.range(lo.y - pad.y, hi.y + pad.y),
                rng.range(lo.z - pad.z, hi.z + pad.z),
            );
            // Unnormalized directions: t must still be the parameter along them.
            let d = rng.direction() * rng.range(0.2, 5.0);
            GpuRay { origin: o.to_array(), tmin: 0.0, direction: d.to_array(), tmax: 1e30 }
        })
        .collect()
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-4 * b.abs().max(1e-3)
}

/// Compares GPU and CPU closest hits; returns (rays compared, exact agreements, hits).
fn compare(name: &str, app: &App, gpu: &engine::gpu::GpuContext, rays: &[GpuRay]) -> (usize, usize, usize) {
    let cpu = cpu_reference(app);
    let got = trace(app, gpu, rays, true);
    let (mut exact, mut hits, mut edge_cases) = (0, 0, Vec::new());
    for (i, (ray, g)) in rays.iter().zip(&got).enumerate() {
        let want = cpu.closest_hit(ray);
        assert_eq!(g.any_hit == 1, g.instance != u32::MAX, "{name} ray {i}: any-hit disagrees with closest-hit");
        match want {
            None if g.instance == u32::MAX => exact += 1,
            Some(w) if g.instance == w.instance && g.primitive == w.primitive && close(g.t, w.t) => {
                assert_eq!(g.flags & 1 == 1, w.front_face, "{name} ray {i}: front/back face differs");
                exact += 1;
                hits += 1;
            }
            // A tie: coincident faces (overlapping walls) at the same distance. The GPU's triangle must
            // really lie on the ray at the reference distance.
            Some(w)
                if g.instance != u32::MAX && close(g.t, w.t) && cpu.hit_t(ray, g.instance, g.primitive).is_some_and(|t| close(t, w.t)) =>
            {
                exact += 1;
                hits += 1;
            }
            _ => edge_cases.push((i, want, *g)),
        }
    }
    // Rays through a shared edge or grazing a silhouette may legitimately land on a neighbour: allow a
    // handful, but never a different distance on a ray that is not such a case.
    let allowed = rays.len() / 500;
    assert!(
        edge_cases.len() <= allowed,
        "{name}: {} of {} rays disagree with the CPU reference, e.g. {:?}",
        edge_cases.len(),
        rays.len(),
        &edge_cases[..edge_cases.len().min(5)]
    );
    (rays.len(), exact, hits)
}

fn cuboid_scene() -> SceneDescription {
    let mut s = SceneDescription { name: "transformed".into(), ..Default::default() };
    let cube = s.add_mesh(engine::shapes::cuboid("cube", Vec3::splat(0.5)));
    let plate = s.add_mesh(engine::shapes::quad("plate", Vec2::new(4.0, 4.0)));
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    let parent = s.add_node(
        "parent",
        Transform::from_xyz(0.5, 0.2, -0.3)
            .with_rotation(Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, -0.2))
            .with_scale(Vec3::new(2.0, 0.5, 1.5)),
        None,
        vec![NodeContent::Meshes(vec![(cube, m)])],
    );
    s.add_node(
        "child",
        Transform::from_xyz(0.0, 2.5, 0.0).with_scale(Vec3::splat(0.25)),
        Some(parent),
        vec![NodeContent::Meshes(vec![(cube, m)])],
    );
    s.add_node("floor", Transform::from_xyz(0.0, -1.0, 0.0), None, vec![NodeContent::Meshes(vec![(plate, m)])]);
    for i in 0..20 {
        let t = Transform::from_xyz((i % 5) as f32 - 2.0, (i / 5) as f32 * 0.7 - 0.5, 1.5)
            .with_rotation(Quat::from_rotation_y(i as f32 * 0.4))
            .with_scale(Vec3::new(0.3, 0.1 + 0.05 * i as f32, 0.2));
        s.add_node(&format!("small{i}"), t, None, vec![NodeContent::Meshes(vec![(cube, m)])]);
    }
    s
}

/// A wavy sheet of `n` × `n` cells (2n² triangles) over [-1, 1]² in XZ.
fn sheet(n: usize) -> Mesh {
    let mut mesh = Mesh { name: "sheet".into(), ..Default::default() };
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (2.0 * i as f32 / n as f32 - 1.0, 2.0 * j as f32 / n as f32 - 1.0);
            mesh.positions.push(Vec3::new(x, 0.2 * (5.0 * x).sin() * (4.0 * z).cos(), z));
        }
    }
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * (n as u32 + 1) + i;
            let (b, c, d) = (a + 1, a + n as u32 + 2, a + n as u32 + 1);
            mesh.indices.extend([a, d, c, a, c, b]);
        }
    }
    mesh.compute_normals();
    mesh
}

/// Hundreds of overlapping instances of three meshes (a TLAS several levels deep, nodes with several
/// instance leaves that one ray hits, BLASes of several levels).
fn crowd_scene() -> SceneDescription {
    let mut s = SceneDescription { name: "crowd".into(), ..Default::default() };
    let meshes = [
        s.add_mesh(engine::shapes::cuboid("cube", Vec3::splat(0.5))),
        s.add_mesh(sheet(12)),
        s.add_mesh(engine::shapes::quad("plate", Vec2::new(1.0, 1.0))),
    ];
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    let mut rng = SplitMix64::new(0xC0_0D);
    for i in 0..400 {
        let t = Transform::from_xyz(rng.range(-5.0, 5.0), rng.range(0.0, 3.0), rng.range(-5.0, 5.0))
            .with_rotation(Quat::from_axis_angle(rng.direction(), rng.range(0.0, 6.0)))
            .with_scale(Vec3::new(rng.range(0.1, 0.8), rng.range(0.1, 0.8), rng.range(0.1, 0.8)));
        s.add_node(&format!("item{i}"), t, None, vec![NodeContent::Meshes(vec![(meshes[i % 3], m)])]);
    }
    s
}

#[test]
fn gpu_closest_hits_match_the_cpu_reference() {
    let Some(gpu) = testkit::gpu("gpu_closest_hits_match_the_cpu_reference") else { return };
    let mut tested = vec![cuboid_scene(), crowd_scene()];
    for name in ["cornell", "color_bleed", "door_room"] {
        tested.push((scenes::find(name).expect("built-in").build)());
    }
    for (k, scene) in tested.into_iter().enumerate() {
        let name = scene.name.clone();
        let bounds = scene.bounds().expect("bounds");
        let app = app_for(&gpu, scene);
        let rays = random_rays(bounds, 3000, 0x9E37_79B9 + k as u64);
        let (n, exact, hits) = compare(&name, &app, &gpu, &rays);
        eprintln!("{name}: {exact}/{n} rays agree exactly ({hits} hits)");
        assert!(hits > n / 10, "{name}: too few hits ({hits}) for the test to mean anything");
    }
}

#[test]
fn a_moved_entity_is_seen_at_its_new_place_in_the_same_frame() {
    let Some(gpu) = testkit::gpu("a_moved_entity_is_seen_at_its_new_place_in_the_same_frame") else { return };
    let mut s = SceneDescription { name: "move_test".into(), ..Default::default() };
    let cube = s.add_mesh(engine::shapes::cuboid("cube", Vec3::splat(0.5)));
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    s.add_node("static", Transform::from_xyz(0.0, 0.0, -10.0), None, vec![NodeContent::Meshes(vec![(cube, m)])]);
    s.add_node("mover", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(cube, m)])]);
    let mut app = app_for(&gpu, s);
    let ray_at = |x: f32| GpuRay { origin: [x, 0.0, 5.0], tmin: 0.0, direction: [0.0, 0.0, -1.0], tmax: 1e30 };
    let before = trace(&app, &gpu, &[ray_at(0.0), ray_at(3.0)], true);
    assert!((before[0].t - 4.5).abs() < 1e-4, "{before:?}");
    assert!((before[1].t - 1e30).abs() > 1.0 || before[1].instance == u32::MAX);

    // Move the entity (through its Transform, as game code would) and run one frame.
    let world = app.world_mut();
    let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
    for (name, mut t) in q.iter_mut(world) {
        if name.0 == "mover" {
            t.translation = Vec3::new(3.0, 0.0, 1.0);
        }
    }
    run_headless(&mut app, 1);
    let after = trace(&app, &gpu, &[ray_at(0.0), ray_at(3.0)], true);
    // The old place now shows the static cube far behind; the new place shows the mover, nearer.
    assert!((after[0].t - 14.5).abs() < 1e-3, "old place still occupied: {after:?}");
    assert!((after[1].t - 3.5).abs() < 1e-4, "mover not at its new place: {after:?}");
    assert_eq!(after[1].instance, before[0].instance, "the moved entity keeps its instance slot");
    let stats = app.world().resource::<RayTracingScene>().stats;
    assert!(!stats.tlas_rebuilt && stats.tlas_refitted_leaves == 1, "a move refits the TLAS: {stats:?}");

    // A static frame does no BVH work.
    run_headless(&mut app, 1);
    let stats = app.world().resource::<RayTracingScene>().stats;
    assert!(!stats.tlas_rebuilt && stats.tlas_refitted_leaves == 0 && stats.tlas_nodes_uploaded == 0, "{stats:?}");
}

#[test]
fn rays_parallel_to_axes_from_surfaces_and_past_degenerate_triangles_are_robust() {
    let Some(gpu) = testkit::gpu("rays_parallel_to_axes_from_surfaces_and_past_degenerate_triangles_are_robust") else { return };
    let mut s = SceneDescription { name: "robust".into(), ..Default::default() };
    let mut cube = engine::shapes::cuboid("cube", Vec3::splat(1.0));
    // Degenerate triangles: a zero-area sliver and a collapsed one, in the middle of the box.
    let base = cube.positions.len() as u32;
    cube.positions.extend([Vec3::ZERO, Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::splat(0.2)]);
    cube.normals.extend([Vec3::Y; 4]);
    cube.uvs.extend([Vec2::ZERO; 4]);
    cube.indices.extend([base, base + 1, base + 2, base + 3, base + 3, base + 3]);
    let c = s.add_mesh(cube);
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    s.add_node("cube", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(c, m)])]);
    let app = app_for(&gpu, s);
    let mut rays = Vec::new();
    for axis in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
        // From outside along an axis, and from exactly on the surface outwards (tmin 0).
        rays.push(GpuRay { origin: (-axis * 5.0 + Vec3::splat(0.3)).to_array(), tmin: 0.0, direction: axis.to_array(), tmax: 1e30 });
        rays.push(GpuRay { origin: (axis * 1.0).to_array(), tmin: 1e-4, direction: axis.to_array(), tmax: 1e30 });
    }
    let got = trace(&app, &gpu, &rays, true);
    for (i, (r, g)) in rays.iter().zip(&got).enumerate() {
        assert!(g.t.is_finite() && !g.barycentrics[0].is_nan(), "ray {i}: {g:?}");
        if i % 2 == 0 {
            let expected = -Vec3::from(r.origin).dot(Vec3::from(r.direction)) - 1.0;
            assert!((g.t - expected).abs() < 1e-4, "axis ray {i} {r:?}: {g:?}, expected t = {expected}");
            assert_eq!(g.flags & 1, 1, "entering the box hits a front face");
        } else {
            assert_eq!(g.instance, u32::MAX, "ray {i} leaving the surface must not hit it: {g:?}");
        }
    }
}

/// A floor of albedo 0.5 under a point light at (1, 2, 0), seen from above; optionally a small box
/// between the floor's centre and the light.
fn lit_floor(occluder: bool) -> SceneDescription {
    let mut s = SceneDescription { name: "lit_floor".into(), ..Default::default() };
    let floor = s.add_mesh(engine::shapes::quad("floor", Vec2::splat(20.0)));
    let cube = s.add_mesh(engine::shapes::cuboid("blocker", Vec3::splat(0.1)));
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    s.add_node("floor", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(floor, m)])]);
    if occluder {
        s.add_node("blocker", Transform::from_xyz(0.5, 1.0, 0.0), None, vec![NodeContent::Meshes(vec![(cube, m)])]);
    }
    let camera = Transform::from_xyz(0.0, 5.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
    s.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov: 0.3, ..Default::default() })]);
    s.add_node(
        "light",
        Transform::from_xyz(1.0, 2.0, 0.0),
        None,
        vec![NodeContent::PointLight(PointLight { color: Vec3::ONE, intensity: 10.0, range: None })],
    );
    s
}

#[test]
fn point_light_irradiance_is_i_cos_over_d2_and_zero_in_shadow() {
    let Some(gpu) = testkit::gpu("point_light_irradiance_is_i_cos_over_d2_and_zero_in_shadow") else { return };
    let settings = HeadlessSettings { width: 33, height: 33, ..Default::default() };
    let centre = |f: &engine::headless::RenderedFrame| f.hdr[((16 * 33 + 16) * 4) as usize];
    let lit = render_scene(&gpu, lit_floor(false), &settings).expect("render");
    // Floor centre: d² = 5, cosθ = 2/√5, radiance = albedo/π · I cosθ / d².
    let expected = 0.5 / std::f32::consts::PI * 10.0 * (2.0 / 5f32.sqrt()) / 5.0;
    let got = centre(&lit);
    assert!((got - expected).abs() / expected < 0.01, "unshadowed: got {got}, expected {expected}");
    let shadowed = render_scene(&gpu, lit_floor(true), &settings).expect("render");
    assert_eq!(centre(&shadowed), 0.0, "the blocker must cast a hard shadow on the floor's centre");
}

#[test]
fn after_many_moves_and_refits_hits_still_match_the_cpu_reference() {
    let Some(gpu) = testkit::gpu("after_many_moves_and_refits_hits_still_match_the_cpu_reference") else { return };
    let scene = cuboid_scene();
    let bounds = scene.bounds().expect("bounds");
    let mut app = app_for(&gpu, scene);
    let mut rng = SplitMix64::new(77);
    let mut refits = 0;
    for _ in 0..6 {
        let world = app.world_mut();
        let mut q = world.query_filtered::<&mut Transform, bevy_ecs::query::With<engine::scene::MeshInstance>>();
        for mut t in q.iter_mut(world) {
            if rng.unit() < 0.5 {
                t.translation += Vec3::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), rng.range(-0.3, 0.3));
                t.rotation *= Quat::from_rotation_y(rng.range(-0.5, 0.5));
            }
        }
        run_headless(&mut app, 1);
        refits += app.world().resource::<RayTracingScene>().stats.tlas_refitted_leaves;
    }
    assert!(refits > 0, "the moves must have exercised the refit path");
    compare("moved", &app, &gpu, &random_rays(bounds, 3000, 4242));
}

#[test]
fn hits_report_the_material_with_texture_and_texture_transform() {
    use engine::scene::{Handle, Image, TextureRef, UvTransform};
    let Some(gpu) = testkit::gpu("hits_report_the_material_with_texture_and_texture_transform") else { return };
    // A 2×2 texture: red, green / blue, white (sRGB bytes), on a quad whose uv is ((x+1)/2, (z+1)/2).
    let texels: [[u8; 4]; 4] = [[200, 30, 30, 255], [30, 200, 30, 255], [30, 30, 200, 255], [250, 250, 250, 255]];
    let quad = Mesh {
        name: "quad".into(),
        positions: vec![Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(-1.0, 0.0, 1.0)],
        normals: vec![Vec3::Y; 4],
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![0, 2, 1, 0, 3, 2],
        ..Default::default()
    };
    let mut s = SceneDescription { name: "textured".into(), ..Default::default() };
    s.images.push(Image { name: "checker".into(), width: 2, height: 2, rgba8: texels.concat() });
    let q = s.add_mesh(quad);
    let factor = glam::Vec4::new(1.0, 0.5, 1.0, 1.0);
    let texture = |offset: Vec2| {
        Some(TextureRef {
            image: Handle::from_index(0),
            transform: UvTransform { offset, ..Default::default() },
            filter: Default::default(),
        })
    };
    let plain = s.add_material(Material {
        base_color: factor,
        base_color_texture: texture(Vec2::ZERO),
        emissive: Vec3::new(2.0, 1.0, 0.5),
        emissive_strength: 3.0,
        ..Default::default()
    });
    let shifted = s.add_material(Material { base_color: factor, base_color_texture: texture(Vec2::new(0.5, 0.0)), ..Default::default() });
    s.add_node("plain", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(q, plain)])]);
    s.add_node("shifted", Transform::from_xyz(10.0, 0.0, 0.0), None, vec![NodeContent::Meshes(vec![(q, shifted)])]);
    let app = app_for(&gpu, s);
    let down = |x: f32, z: f32| GpuRay { origin: [x, 1.0, z], tmin: 0.0, direction: [0.0, -1.0, 0.0], tmax: 1e30 };
    for (col, row) in [(0usize, 0usize), (1, 0), (0, 1), (1, 1)] {
        let (x, z) = (col as f32 - 0.5, row as f32 - 0.5);
        let got = trace(&app, &gpu, &[down(x, z), down(x + 10.0, z)], false);
        for (k, hit) in got.iter().enumerate() {
            // The transform's offset of half the texture swaps the columns.
            let texel = texels[row * 2 + if k == 0 { col } else { 1 - col }];
            let expected = Vec3::new(
                engine::color::srgb8_to_linear(texel[0]),
                engine::color::srgb8_to_linear(texel[1]),
                engine::color::srgb8_to_linear(texel[2]),
            ) * factor.truncate();
            let albedo = Vec3::from_slice(&hit.albedo[..3]);
            assert!(
                (albedo - expected).abs().max_element() < 0.01,
                "quadrant ({col}, {row}) instance {k}: albedo {albedo}, expected {expected}"
            );
        }
        let emissive = Vec3::from_slice(&got[0].emissive[..3]);
        assert!((emissive - Vec3::new(6.0, 3.0, 1.5)).abs().max_element() < 1e-4, "emissive {emissive}");
        assert_eq!(got[1].emissive[..3], [0.0; 3]);
    }
}

/// A grid mesh just over the asynchronous-build threshold.
fn big_grid() -> Mesh {
    let n = ((engine::rt::ASYNC_BLAS_TRIANGLES / 2) as f64).sqrt().ceil() as u32 + 1;
    let mut grid = Mesh { name: "big_grid".into(), ..Default::default() };
    for j in 0..=n {
        for i in 0..=n {
            grid.positions.push(Vec3::new(i as f32 / n as f32 * 2.0 - 1.0, 0.0, j as f32 / n as f32 * 2.0 - 1.0));
            grid.normals.push(Vec3::Y);
            grid.uvs.push(Vec2::ZERO);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            grid.indices.extend([a, a + n + 1, a + 1, a + 1, a + n + 1, a + n + 2]);
        }
    }
    assert!(grid.triangle_count() > engine::rt::ASYNC_BLAS_TRIANGLES);
    grid
}

#[test]
fn large_blas_builds_run_off_the_frame_loop_and_report_progress() {
    let Some(gpu) = testkit::gpu("large_blas_builds_run_off_the_frame_loop_and_report_progress") else { return };
    let grid = big_grid();
    let mut s = SceneDescription { name: "async".into(), ..Default::default() };
    let g = s.add_mesh(grid);
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    s.add_node("grid", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(g, m)])]);

    let mut app = App::new();
    app.insert_resource(Time::fixed(1.0 / 60.0)).insert_resource(WaitForBlasBuilds(false));
    app.add_plugins((EnginePlugin, RenderPlugin { gpu: gpu.clone(), size: RenderSize { width: 8, height: 8 } }));
    s.spawn(app.world_mut());
    let started = std::time::Instant::now();
    run_headless(&mut app, 1);
    let first_frame = started.elapsed();
    let down = [GpuRay { origin: [0.1, 1.0, 0.1], tmin: 0.0, direction: [0.0, -1.0, 0.0], tmax: 1e30 }];
    let progress = app.world().resource::<RayTracingScene>().progress.clone();
    assert!(!progress.is_done(), "the first frame waited for the build ({first_frame:?})");
    assert_eq!(trace(&app, &gpu, &down, false)[0].instance, u32::MAX, "an instance without its BLAS is not traced");
    while !progress.is_done() {
        assert!(started.elapsed().as_secs() < 120, "the BLAS never arrived (progress {:.2})", progress.fraction());
        std::thread::sleep(std::time::Duration::from_millis(5));
        run_headless(&mut app, 1);
    }
    // The frame after the build finishes picks it up.
    run_headless(&mut app, 1);
    assert_eq!(progress.fraction(), 1.0);
    assert!((trace(&app, &gpu, &down, false)[0].t - 1.0).abs() < 1e-4);
}

/// `transforms.len()` cubes of random sizes and orientations, one node each, in spawn order.
fn cube_field(transforms: &[Transform]) -> SceneDescription {
    let mut s = SceneDescription { name: "cube_field".into(), ..Default::default() };
    let cube = s.add_mesh(engine::shapes::cuboid("cube", Vec3::splat(0.5)));
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    for (i, t) in transforms.iter().enumerate() {
        s.add_node(&format!("cube{i}"), *t, None, vec![NodeContent::Meshes(vec![(cube, m)])]);
    }
    s
}

/// Two apps of the same cube field: the first refits its TLAS on the CPU, the second on the GPU.
fn refit_pair(gpu: &engine::gpu::GpuContext, start: &[Transform]) -> [App; 2] {
    let mut apps = [app_for(gpu, cube_field(start)), app_for(gpu, cube_field(start))];
    apps[0].world_mut().resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Cpu;
    apps[1].world_mut().resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Gpu;
    apps
}

/// `count` placements over a `side` × `side` square, up to 4 m high, as a forest's trees and props.
fn field_transforms(count: usize, side: f32, seed: u64) -> Vec<Transform> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|_| {
            Transform::from_xyz(rng.range(-0.5, 0.5) * side, rng.range(0.0, 4.0), rng.range(-0.5, 0.5) * side)
                .with_rotation(Quat::from_rotation_y(rng.range(0.0, 6.3)))
                .with_scale(Vec3::new(rng.range(0.3, 1.5), rng.range(0.5, 4.0), rng.range(0.3, 1.5)))
        })
        .collect()
}

/// Moves every cube's node of [`cube_field`] a little (seeded; not the mesh entities under them,
/// named `cube{i}#0`), runs a frame and returns its BVH statistics.
fn jiggle_all(app: &mut App, rng: &mut SplitMix64) -> engine::rt::BvhFrameStats {
    let world = app.world_mut();
    let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
    for (_, mut t) in q.iter_mut(world).filter(|(name, _)| name.0.starts_with("cube") && !name.0.contains('#')) {
        t.translation += Vec3::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2), rng.range(-0.2, 0.2));
        t.rotation *= Quat::from_rotation_y(rng.range(-0.3, 0.3));
    }
    run_headless(app, 1);
    app.world().resource::<RayTracingScene>().stats
}

#[test]
fn thousands_of_movers_refitted_in_parallel_hit_what_a_fresh_build_hits() {
    let Some(gpu) = testkit::gpu("thousands_of_movers_refitted_in_parallel_hit_what_a_fresh_build_hits") else { return };
    let count = 3000;
    let start = field_transforms(count, 120.0, 31);
    let mut app = app_for(&gpu, cube_field(&start));
    app.world_mut().resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Cpu;
    app.world_mut().resource_mut::<RayTracingScene>().parallel_refit_from = 0;
    let mut rng = SplitMix64::new(5);
    for frame in 0..4 {
        let stats = jiggle_all(&mut app, &mut rng);
        assert!(
            !stats.tlas_rebuilt && stats.tlas_refit_parallel && stats.tlas_refitted_leaves == count,
            "frame {frame}: every instance moved must be refitted in parallel, without a rebuild: {stats:?}"
        );
    }
    // Rays from all over the field, and rays along it at the cubes' heights (many instances each).
    let bounds = (Vec3::new(-60.0, 0.0, -60.0), Vec3::new(60.0, 8.0, 60.0));
    let mut rays = random_rays(bounds, 4000, 99);
    let mut rng = SplitMix64::new(17);
    for _ in 0..1000 {
        let o = Vec3::new(-70.0, rng.range(0.0, 6.0), rng.range(-60.0, 60.0));
        let d = Vec3::new(1.0, rng.range(-0.02, 0.02), rng.range(-0.3, 0.3));
        rays.push(GpuRay { origin: o.to_array(), tmin: 0.0, direction: d.to_array(), tmax: 1e30 });
    }
    let refitted = trace(&app, &gpu, &rays, true);
    // A new instance, far from every ray, makes the next frame build the TLAS from scratch over the
    // same instances.
    cube_field(&[Transform::from_xyz(0.0, -1e5, 0.0)]).spawn(app.world_mut());
    run_headless(&mut app, 1);
    assert!(app.world().resource::<RayTracingScene>().stats.tlas_rebuilt);
    let rebuilt = trace(&app, &gpu, &rays, true);
    let hits = rebuilt.iter().filter(|r| r.instance != u32::MAX).count();
    assert!(hits > rays.len() / 4, "too few rays hit the field ({hits} of {}): the test would prove little", rays.len());
    for (i, (a, b)) in refitted.iter().zip(&rebuilt).enumerate() {
        assert_eq!(bytemuck::bytes_of(a), bytemuck::bytes_of(b), "ray {i} {:?}: refitted {a:?}, rebuilt {b:?}", rays[i]);
    }
}

#[test]
fn a_parallel_refit_gives_the_tlas_a_refit_on_one_thread_gives() {
    let Some(gpu) = testkit::gpu("a_parallel_refit_gives_the_tlas_a_refit_on_one_thread_gives") else { return };
    let start = field_transforms(2000, 80.0, 8);
    let mut apps = [app_for(&gpu, cube_field(&start)), app_for(&gpu, cube_field(&start))];
    for app in &mut apps {
        app.world_mut().resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Cpu;
    }
    apps[0].world_mut().resource_mut::<RayTracingScene>().parallel_refit_from = usize::MAX;
    apps[1].world_mut().resource_mut::<RayTracingScene>().parallel_refit_from = 0;
    for frame in 0..3 {
        let stats = apps.each_mut().map(|app| jiggle_all(app, &mut SplitMix64::new(100 + frame)));
        assert!(!stats[0].tlas_refit_parallel && stats[1].tlas_refit_parallel, "{stats:?}");
        assert!(!stats[0].tlas_rebuilt && !stats[1].tlas_rebuilt, "{stats:?}");
        assert_eq!(stats[0].tlas_nodes_uploaded, stats[1].tlas_nodes_uploaded, "frame {frame}");
        let [one, parallel] = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().tlas_cpu());
        assert_eq!(bytemuck::cast_slice::<_, u8>(one.0), bytemuck::cast_slice::<_, u8>(parallel.0), "frame {frame}: wide nodes differ");
        assert_eq!(one.1, parallel.1, "frame {frame}: entries differ");
    }
}

/// CPU cost of the TLAS refit and upload, on one thread and in parallel, for 1,000 and 10,000 of
/// 11,400 instances moving (the forest's count), median of 9 frames each. A timing, not a check:
/// `cargo test --release -p workspace_tests --test ray_tracing tlas_refit_cost -- --ignored --nocapture`.
#[test]
#[ignore]
fn tlas_refit_cost_on_one_thread_and_in_parallel() {
    let Some(gpu) = testkit::gpu("tlas_refit_cost_on_one_thread_and_in_parallel") else { return };
    let count = 11_400;
    let mut app = app_for(&gpu, cube_field(&field_transforms(count, 500.0, 3)));
    let world = app.world_mut();
    let entities: Vec<bevy_ecs::entity::Entity> =
        world.query_filtered::<bevy_ecs::entity::Entity, bevy_ecs::query::With<engine::scene::MeshInstance>>().iter(world).collect();
    app.world_mut().resource_mut::<RayTracingScene>().tlas_refit = engine::rt::TlasRefit::Cpu;
    let mut rng = SplitMix64::new(1);
    for movers in [1000, 10_000] {
        let mut times = [Vec::new(), Vec::new()];
        for frame in 0..18 {
            let mode = frame % 2;
            app.world_mut().resource_mut::<RayTracingScene>().parallel_refit_from = if mode == 0 { usize::MAX } else { 0 };
            for &e in &entities[..movers] {
                if let Some(mut t) = app.world_mut().get_mut::<Transform>(e) {
                    t.translation += Vec3::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5) * 0.02;
                }
            }
            run_headless(&mut app, 1);
            let stats = app.world().resource::<RayTracingScene>().stats;
            assert!(!stats.tlas_rebuilt);
            times[mode].push((stats.cpu_time, stats.tlas_upload_copies, stats.tlas_nodes_uploaded));
        }
        for (mode, mut t) in times.into_iter().enumerate() {
            t.sort();
            let (time, copies, nodes) = t[t.len() / 2];
            let how = if mode == 0 { "one thread" } else { "parallel" };
            println!("{movers} movers, {how}: {:.3} ms, {nodes} wide nodes in {copies} copies", time.as_secs_f64() * 1e3);
        }
    }
}

#[test]
fn the_blas_build_hook_is_told_of_every_build_in_order_up_to_the_totals() {
    use engine::rt::{BlasBuildCounts, BlasBuildHook};
    use std::sync::{Arc, Mutex};
    let Some(gpu) = testkit::gpu("the_blas_build_hook_is_told_of_every_build_in_order_up_to_the_totals") else { return };
    // One mesh built on the worker thread, a dozen built in the frame on rayon's pool.
    let mut s = SceneDescription { name: "hooked".into(), ..Default::default() };
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    let mut meshes = vec![big_grid()];
    meshes.extend((0..12).map(|k| sheet(2 + k)));
    for (k, mesh) in meshes.into_iter().enumerate() {
        let mesh = s.add_mesh(mesh);
        s.add_node(&format!("mesh{k}"), Transform::from_xyz(3.0 * k as f32, 0.0, 0.0), None, vec![NodeContent::Meshes(vec![(mesh, m)])]);
    }
    let calls: Arc<Mutex<Vec<BlasBuildCounts>>> = Arc::default();
    let mut app = engine::headless::headless_app(&gpu, RenderSize { width: 8, height: 8 }, 1.0 / 60.0);
    let record = calls.clone();
    app.insert_resource(BlasBuildHook::new(move |counts| record.lock().unwrap().push(counts)));
    s.spawn(app.world_mut());
    run_headless(&mut app, 1);
    let meshes = app.world().resource::<Assets<Mesh>>();
    let total = BlasBuildCounts {
        built_meshes: meshes.len(),
        total_meshes: meshes.len(),
        built_triangles: meshes.iter().map(|(_, m)| m.triangle_count()).sum(),
        total_triangles: meshes.iter().map(|(_, m)| m.triangle_count()).sum(),
    };
    // The worker thread tells the hook just after it hands its BLAS over: wait for its call.
    let started = std::time::Instant::now();
    while calls.lock().unwrap().last().is_none_or(|c| !c.is_done()) {
        assert!(started.elapsed().as_secs() < 60, "the builds never reported done: {:?}", calls.lock().unwrap());
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let calls = calls.lock().unwrap().clone();
    assert_eq!(calls.len(), total.total_meshes + 1, "one call at the request, one per build: {calls:?}");
    assert_eq!(calls[0], BlasBuildCounts { built_meshes: 0, built_triangles: 0, ..total }, "the request comes first, with the totals");
    for pair in calls.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        assert_eq!(b.built_meshes, a.built_meshes + 1, "one build per call: {a:?} then {b:?}");
        assert!(b.built_triangles > a.built_triangles, "counts never go down: {a:?} then {b:?}");
        assert_eq!((a.total_meshes, a.total_triangles), (b.total_meshes, b.total_triangles));
    }
    assert_eq!(*calls.last().unwrap(), total);
    assert_eq!(app.world().resource::<RayTracingScene>().progress.counts(), total);
}

/// Overlapping, rotated and non-uniformly scaled instances of meshes whose BLASes are several levels
/// deep (wavy sheets of 1,152 and 4,608 triangles) and of a cube (one BLAS node, never opened), as
/// a forest's trees overlap.
fn braided_scene() -> SceneDescription {
    let mut s = SceneDescription { name: "braided".into(), ..Default::default() };
    let meshes = [s.add_mesh(sheet(24)), s.add_mesh(sheet(48)), s.add_mesh(engine::shapes::cuboid("cube", Vec3::splat(0.5)))];
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    let mut rng = SplitMix64::new(0x00B2_A1D5);
    for i in 0..150 {
        let t = Transform::from_xyz(rng.range(-4.0, 4.0), rng.range(0.0, 3.0), rng.range(-4.0, 4.0))
            .with_rotation(Quat::from_axis_angle(rng.direction(), rng.range(0.0, 6.0)))
            .with_scale(Vec3::new(rng.range(0.5, 3.0), rng.range(0.3, 2.0), rng.range(0.5, 3.0)));
        s.add_node(&format!("item{i}"), t, None, vec![NodeContent::Meshes(vec![(meshes[i % 3], m)])]);
    }
    s
}

/// The instance slots re-braiding opened (with a TLAS entry below the BLAS root).
fn opened_slots(app: &App) -> std::collections::BTreeSet<u32> {
    let (_, entries) = app.world().resource::<RayTracingScene>().tlas_cpu();
    entries.iter().filter(|e| e.start_node != 0).map(|e| e.instance).collect()
}

/// Sets the re-braiding budget and runs the frame that rebuilds the TLAS with it.
fn rebraid(app: &mut App, budget: f32) -> usize {
    app.world_mut().resource_mut::<RayTracingScene>().set_rebraid_budget(budget);
    run_headless(app, 1);
    let rt = app.world().resource::<RayTracingScene>();
    assert!(rt.stats.tlas_rebuilt, "a new budget rebuilds the TLAS");
    rt.tlas_primitive_count()
}

/// Asserts that two traces of the same rays found the same closest hits and any-hit answers. Two
/// triangles met at exactly the same distance may be found in another order: then the hit must be
/// on the ray at that distance by the CPU reference.
fn assert_same_hits(what: &str, app: &App, rays: &[GpuRay], want: &[TraceResult], got: &[TraceResult]) {
    let cpu = cpu_reference(app);
    for (i, (w, g)) in want.iter().zip(got).enumerate() {
        if bytemuck::bytes_of(w) == bytemuck::bytes_of(g) {
            continue;
        }
        let tie = w.t == g.t && w.any_hit == g.any_hit && cpu.hit_t(&rays[i], g.instance, g.primitive).is_some_and(|t| close(t, w.t));
        assert!(tie, "{what}, ray {i} {:?}: one leaf per instance {w:?}, re-braided {g:?}", rays[i]);
    }
}

#[test]
fn a_rebraided_tlas_gives_the_hits_of_one_leaf_per_instance() {
    let Some(gpu) = testkit::gpu("a_rebraided_tlas_gives_the_hits_of_one_leaf_per_instance") else { return };
    let scene = braided_scene();
    let bounds = scene.bounds().expect("bounds");
    let mut app = app_for(&gpu, scene);
    let instances = rebraid(&mut app, 0.0);
    assert_eq!(instances, 150, "off: one TLAS leaf per instance");
    let rays = random_rays(bounds, 2000, 0xB2A1);
    let (closest, any) = (trace(&app, &gpu, &rays, false), trace(&app, &gpu, &rays, true));
    let hits = closest.iter().filter(|r| r.instance != u32::MAX).count();
    assert!(hits > rays.len() / 5, "too few hits ({hits} of {}) for the test to mean anything", rays.len());
    for budget in [2.0, 4.0, 64.0] {
        let primitives = rebraid(&mut app, budget);
        // The sheets' roots have only inner children: some instances must have been opened.
        assert!(primitives > instances && primitives as f32 <= budget * instances as f32, "budget {budget}: {primitives} primitives");
        let what = format!("budget {budget} ({primitives} primitives)");
        assert_same_hits(&what, &app, &rays, &closest, &trace(&app, &gpu, &rays, false));
        assert_same_hits(&what, &app, &rays, &any, &trace(&app, &gpu, &rays, true));
    }
    // And the CPU reference agrees with the most opened TLAS.
    compare("budget 64", &app, &gpu, &rays);
}

#[test]
fn an_opened_instance_that_moves_is_refitted_as_one_leaf() {
    let Some(gpu) = testkit::gpu("an_opened_instance_that_moves_is_refitted_as_one_leaf") else { return };
    let scene = braided_scene();
    let bounds = scene.bounds().expect("bounds");
    let mut app = app_for(&gpu, scene);
    rebraid(&mut app, 8.0);
    let opened = opened_slots(&app);
    let mut rng = SplitMix64::new(3);
    let mut move_some = |app: &mut App| {
        let world = app.world_mut();
        let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
        for (_, mut t) in q.iter_mut(world).filter(|(name, _)| matches!(name.0.as_str(), "item1" | "item4" | "item7" | "item10")) {
            t.translation += Vec3::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), rng.range(-0.5, 0.5));
            t.rotation *= Quat::from_rotation_y(rng.range(-0.5, 0.5));
        }
        run_headless(app, 1);
        let rt = app.world().resource::<RayTracingScene>();
        (rt.stats, rt.tlas_primitive_count())
    };
    // Items 1, 4, 7 and 10 are instances of the 4,608-triangle sheet, opened at a budget of 8; the
    // rebuild keeps them at their roots.
    let (stats, primitives) = move_some(&mut app);
    let now = opened_slots(&app);
    assert!(stats.tlas_rebuilt, "opened movers are rebuilt at their roots: {stats:?}");
    assert_eq!(opened.difference(&now).count(), 4, "the four movers were opened and are no more: {opened:?} then {now:?}");
    for frame in 0..3 {
        let (stats, now) = move_some(&mut app);
        assert!(!stats.tlas_rebuilt && stats.tlas_refitted_leaves == 4 && now == primitives, "frame {frame}: {stats:?}, {now}");
    }
    compare("moved", &app, &gpu, &random_rays(bounds, 1000, 0x40E5));
}

/// `bench trace` spreads its probes over the scene's bounds: a scene whose camera stands far from
/// the world's origin (the render origin follows it) must get the same rays as at the origin, so its
/// traversal work per ray is the same, and the coherent ray order changes the order of the rays,
/// not the work.
#[test]
fn bench_trace_work_per_ray_is_the_same_for_a_scene_placed_far_from_the_origin() {
    let Some(gpu) = testkit::gpu("bench_trace_work_per_ray_is_the_same_for_a_scene_placed_far_from_the_origin") else { return };
    let (grid, rays) = ([6, 6, 6], 64);
    let work = |origin: glam::DVec3, ray_order: lab::bench::RayOrder| {
        let mut scene = (scenes::find("cornell").expect("built-in").build)();
        scene.origin = origin;
        let bounds = lab::bench::world_bounds(&scene).expect("bounds");
        let app = lab::bench::prepared_app(&gpu, scene);
        let rebases = app.world().resource::<engine::scene::RenderOrigin>().rebases;
        (
            lab::bench::traversal_work(&gpu, &app, bounds, grid, rays, lab::bench::TraceVariant { ray_order, ..Default::default() })
                .expect("work")
                .counts(),
            rebases,
        )
    };
    let (near, _) = work(glam::DVec3::ZERO, lab::bench::RayOrder::Fibonacci);
    let (far, rebases) = work(glam::DVec3::new(5000.0, 0.0, -3000.0), lab::bench::RayOrder::Fibonacci);
    let (coherent, _) = work(glam::DVec3::ZERO, lab::bench::RayOrder::Coherent);
    eprintln!("work per ray (TLAS nodes, instances, BLAS nodes, triangles): {near:?} at the origin, {far:?} far, {coherent:?} coherent");
    assert!(rebases > 0, "the far scene's camera should have moved the render origin");
    assert!(near[2] > 1.0 && near[3] > 1.0, "{near:?}: the rays should walk the scene");
    for k in 0..4 {
        assert!((far[k] - near[k]).abs() <= 0.01 * near[k].max(1.0), "far {far:?} against {near:?}");
        assert!((coherent[k] - near[k]).abs() <= 1e-9 * near[k].max(1.0), "coherent {coherent:?} against {near:?}");
    }
}

/// The bench's persistent kernel (a lane takes the next ray inside the traversal loop) finds the
/// hits the thread-a-ray kernel finds, ray for ray, in either ray order.
#[test]
fn the_persistent_bench_kernel_finds_the_same_hits() {
    let Some(gpu) = testkit::gpu("the_persistent_bench_kernel_finds_the_same_hits") else { return };
    let scene = (scenes::find("door_room").expect("built-in").build)();
    let bounds = lab::bench::world_bounds(&scene).expect("bounds");
    let app = lab::bench::prepared_app(&gpu, scene);
    let (grid, rays) = ([5, 4, 3], 64);
    for ray_order in [lab::bench::RayOrder::Fibonacci, lab::bench::RayOrder::Coherent] {
        let one = lab::bench::TraceVariant { ray_order, ..Default::default() };
        let expected = lab::bench::hit_distances(&gpu, &app, bounds, grid, rays, one).expect("thread a ray");
        // Fewer workgroups than rays / 64, and a share that does not divide the rays evenly.
        let persistent = lab::bench::TraceVariant { persistent_groups: Some(7), ..one };
        let got = lab::bench::hit_distances(&gpu, &app, bounds, grid, rays, persistent).expect("persistent");
        let hits = expected.iter().filter(|t| **t < 1e29).count();
        assert!(hits > expected.len() / 4, "{hits} of {} rays hit: the rays should meet the room", expected.len());
        assert_eq!(got, expected, "{ray_order:?}");
    }
}

/// A traversal stack whose top entries live in workgroup memory (`bench trace --shared-stack K`)
/// finds the hits of the engine's stack in function memory, ray for ray, in both bench kernels; and
/// walks the same nodes. Stacks grow past K = 1 in the door room (8-wide trees are shallow) and past
/// 3 in the crowd (a TLAS several levels deep, overlapping instances), so entries move to function
/// memory and back, through a ring of 1, 2 and 3 slots (its wrap-around included); at K = 8 nothing
/// moves, which the test checks too.
#[test]
fn the_shared_stack_finds_the_hits_of_the_function_memory_stack() {
    let Some(gpu) = testkit::gpu("the_shared_stack_finds_the_hits_of_the_function_memory_stack") else { return };
    let (grid, rays) = ([5, 4, 3], 64);
    for (name, scene) in [("door_room", (scenes::find("door_room").expect("built-in").build)()), ("crowd", crowd_scene())] {
        let bounds = lab::bench::world_bounds(&scene).expect("bounds");
        let app = lab::bench::prepared_app(&gpu, scene);
        let one = lab::bench::TraceVariant { ray_order: lab::bench::RayOrder::Coherent, ..Default::default() };
        let expected = lab::bench::hit_distances(&gpu, &app, bounds, grid, rays, one).expect("function-memory stack");
        let hits = expected.iter().filter(|t| **t < 1e29).count();
        assert!(hits > expected.len() / 4, "{name}: {hits} of {} rays hit: the rays should meet the scene", expected.len());
        let work = lab::bench::traversal_work(&gpu, &app, bounds, grid, rays, one).expect("work");
        assert_eq!(work.stack_spills, 0.0, "{name}: nothing moves without a shared stack");
        eprintln!("{name}: deepest stack {} entries", work.deepest_stack);
        for k in [1, 2, 3, 8] {
            // 128 threads a workgroup: lanes of several warps share the workgroup array.
            let shared = lab::bench::TraceVariant { shared_stack_entries: k, workgroup_size: 128, ..one };
            // The first ray whose hit differs, if any (the lists are thousands long).
            let differ = |got: &[f32]| got.len() != expected.len() || got.iter().zip(&expected).any(|(a, b)| a != b);
            let first = |got: &[f32]| got.iter().zip(&expected).enumerate().find(|(_, (a, b))| a != b).map(|(i, (a, b))| (i, *a, *b));
            let got = lab::bench::hit_distances(&gpu, &app, bounds, grid, rays, shared).expect("shared stack");
            assert!(!differ(&got), "{name}, thread a ray, shared stack of {k}: (ray, got, expected) {:?}", first(&got));
            // Fewer workgroups than rays / 128, and a share that does not divide the rays evenly.
            let persistent = lab::bench::TraceVariant { persistent_groups: Some(7), ..shared };
            let got = lab::bench::hit_distances(&gpu, &app, bounds, grid, rays, persistent).expect("persistent, shared stack");
            assert!(!differ(&got), "{name}, persistent, shared stack of {k}: (ray, got, expected) {:?}", first(&got));
            let w = lab::bench::traversal_work(&gpu, &app, bounds, grid, rays, shared).expect("work");
            eprintln!("{name}, shared stack of {k}: {:.3} entries moved to function memory per ray", w.stack_spills);
            assert_eq!(w.counts(), work.counts(), "{name}, shared stack of {k}: the same walk");
            assert_eq!(w.deepest_stack, work.deepest_stack, "{name}, shared stack of {k}");
            // An entry moves exactly when a push finds the lane's K slots full: first when a stack
            // grows past K.
            assert_eq!(w.stack_spills > 0.0, work.deepest_stack > k, "{name}, shared stack of {k}: {} moves a ray", w.stack_spills);
        }
        let deep = if name == "crowd" { 3 } else { 1 };
        assert!(work.deepest_stack > deep, "{name}: deepest stack {}: it should pass a shared part of {deep}", work.deepest_stack);
    }
}

/// A cube's node of [`cube_field`] (`cube{i}`; not the scene's root, `cube_field`, nor the mesh
/// entities under the nodes, `cube{i}#0`).
fn is_cube_node(name: &str) -> bool {
    name.strip_prefix("cube").is_some_and(|i| !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit()))
}

/// Moves `share` of the cube nodes of [`cube_field`] (seeded) a little; when `wild`, a fifth of them
/// far instead, or rescaled (tiny, large, flat, stretched), as thrown objects move.
fn move_cubes(app: &mut App, rng: &mut SplitMix64, share: f32, wild: bool) {
    let world = app.world_mut();
    let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
    for (_, mut t) in q.iter_mut(world).filter(|(name, _)| is_cube_node(&name.0)) {
        if rng.unit() >= share {
            continue;
        }
        let kind = if wild { rng.unit() } else { 0.0 };
        if kind < 0.8 {
            t.translation += Vec3::new(rng.range(-0.3, 0.3), rng.range(-0.3, 0.3), rng.range(-0.3, 0.3));
            t.rotation *= Quat::from_rotation_y(rng.range(-0.3, 0.3));
        } else if kind < 0.9 {
            t.translation = Vec3::new(rng.range(-60.0, 60.0), rng.range(0.0, 8.0), rng.range(-60.0, 60.0));
            t.rotation = Quat::from_axis_angle(rng.direction(), rng.range(0.0, 6.3));
        } else {
            let s = [Vec3::splat(1e-3), Vec3::splat(20.0), Vec3::new(3.0, 0.0, 3.0), Vec3::new(0.5, 2.0, 1.0)];
            t.scale = s[(rng.unit() * 4.0) as usize % 4];
        }
    }
}

/// Each instance's previous-frame transform (what motion vectors use) through frames in which
/// different sets of cubes move, stay still, or move again: the old transform in a frame it moved,
/// its current one after a still frame; for a thousand instances, every frame.
#[test]
fn every_instance_keeps_its_previous_frames_transform_for_the_motion_vectors() {
    let Some(gpu) = testkit::gpu("every_instance_keeps_its_previous_frames_transform_for_the_motion_vectors") else { return };
    let start = field_transforms(1000, 60.0, 23);
    let mut app = app_for(&gpu, cube_field(&start));
    let slots = |app: &App| {
        let scene = app.world().resource::<engine::render::gpu_scene::GpuScene>();
        (0..scene.instance_slot_count() as u32).filter_map(|s| Some((s, scene.instance_placement(s)?.1))).collect::<Vec<_>>()
    };
    let mut before = slots(&app);
    assert_eq!(before.len(), 1000);
    for frame in 0..6u64 {
        // Every cube in frames 0 and 3, none in frame 2, a third in the others.
        let share = match frame {
            0 | 3 => 1.0,
            2 => 0.0,
            _ => 0.33,
        };
        move_cubes(&mut app, &mut SplitMix64::new(800 + frame), share, false);
        run_headless(&mut app, 1);
        let now = slots(&app);
        let scene = app.world().resource::<engine::render::gpu_scene::GpuScene>();
        let mut moved = 0;
        for ((slot, was), (_, is)) in before.iter().zip(&now) {
            moved += usize::from(was != is);
            let previous = scene.previous_world_from_local(*slot).expect("a live slot");
            assert_eq!(previous, glam::Mat4::from(*was), "frame {frame}, slot {slot}: the previous frame's transform");
        }
        let expected = if share == 0.0 { 0 } else { 1 };
        assert!((moved > 0) as usize == expected, "frame {frame}: {moved} moved");
        before = now;
    }
}

/// The wide nodes the GPU refit wrote, read back, against the CPU copy refitted and re-encoded from
/// the same leaves ([`RayTracingScene::sync_cpu_tlas`]): the same bytes.
fn assert_gpu_nodes_are_the_cpu_copy(app: &mut App, gpu: &engine::gpu::GpuContext, what: &str) {
    let on_gpu = app.world().resource::<RayTracingScene>().read_tlas_nodes(gpu);
    let mut rt = app.world_mut().resource_mut::<RayTracingScene>();
    rt.sync_cpu_tlas();
    let (cpu, _) = rt.tlas_cpu();
    assert_eq!(on_gpu.len(), cpu.len());
    for (w, (g, c)) in on_gpu.iter().zip(cpu).enumerate() {
        assert_eq!(bytemuck::bytes_of(g), bytemuck::bytes_of(c), "{what}: wide node {w} differs: GPU {g:?}, CPU {c:?}");
    }
}

/// The SAH cost the last GPU refit summed (in fixed point), read back, against the CPU copy's summed
/// anew after [`RayTracingScene::sync_cpu_tlas`]: equal within the fixed point's rounding (both 0
/// for a TLAS with no inner node).
fn assert_gpu_cost_is_the_cpu_copys(app: &mut App, gpu: &engine::gpu::GpuContext, what: &str) {
    let on_gpu = app.world().resource::<RayTracingScene>().read_gpu_tlas_cost(gpu).expect("a GPU refit ran");
    let mut rt = app.world_mut().resource_mut::<RayTracingScene>();
    rt.sync_cpu_tlas();
    let (built, cpu) = rt.tlas_cost().expect("a TLAS");
    if built == 0.0 {
        // A lone instance: the root is a leaf, no inner node costs anything.
        assert!(on_gpu == 0.0 && cpu == 0.0, "{what}: no inner node, yet costs {on_gpu} (GPU), {cpu} (CPU)");
        return;
    }
    assert!(cpu >= 1.0 && built >= 1.0, "{what}: costs {cpu}, built {built}: the root counts 1");
    assert!((on_gpu - cpu).abs() <= 1e-5 * cpu, "{what}: the GPU measured the SAH cost {on_gpu}, the CPU copy has {cpu}");
}

#[test]
fn a_gpu_refit_writes_the_wide_nodes_a_cpu_refit_encodes_bit_for_bit() {
    use engine::rt::TlasRefit;
    let Some(gpu) = testkit::gpu("a_gpu_refit_writes_the_wide_nodes_a_cpu_refit_encodes_bit_for_bit") else { return };
    let start = field_transforms(2000, 80.0, 12);
    let mut apps = refit_pair(&gpu, &start);
    let (mut gpu_refits, mut compared) = (0, 0);
    // Frames 9 and 10 refit on the CPU (the GPU's copy is then reloaded), the others on the GPU; from
    // frame 4 on some instances move far or change scale (the TLASes are then rebuilt at times).
    for frame in 0..14u64 {
        let mode = if (9..11).contains(&frame) { TlasRefit::Cpu } else { TlasRefit::Gpu };
        apps[1].world_mut().resource_mut::<RayTracingScene>().tlas_refit = mode;
        let share = if frame % 3 == 0 { 1.0 } else { 0.1 };
        for app in &mut apps {
            move_cubes(app, &mut SplitMix64::new(300 + frame), share, frame >= 4);
            run_headless(app, 1);
        }
        let stats = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().stats);
        assert_eq!(stats[1].tlas_refit_on_gpu, mode == TlasRefit::Gpu && !stats[1].tlas_rebuilt, "frame {frame}: {stats:?}");
        gpu_refits += usize::from(stats[1].tlas_refit_on_gpu);
        if stats[1].tlas_refit_on_gpu {
            assert_gpu_cost_is_the_cpu_copys(&mut apps[1], &gpu, &format!("frame {frame}"));
        }
        assert_gpu_nodes_are_the_cpu_copy(&mut apps[1], &gpu, &format!("frame {frame}"));
        // While neither has rebuilt its TLAS (each decides on its own schedule), both apps' TLASes are one.
        if !stats.iter().any(|s| s.tlas_rebuilt) && compared == frame {
            let [cpu, on_gpu] = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().read_tlas_nodes(&gpu));
            assert_eq!(
                bytemuck::cast_slice::<_, u8>(&cpu),
                bytemuck::cast_slice::<_, u8>(&on_gpu),
                "frame {frame}: the apps' TLASes differ"
            );
            compared += 1;
        }
    }
    assert!(gpu_refits >= 8 && compared >= 4, "{gpu_refits} GPU refits, {compared} frames compared: the test would prove little");
}

/// With the refit on the GPU the CPU decides on rebuilds from the SAH cost the GPU measures, read
/// back every [`engine::rt::TLAS_GPU_COST_READ_EVERY`] refits a frame or two late: cubes that jitter
/// keep their TLAS (readings arrive, below the rebuild ratio), and cubes thrown all over the field
/// get a new one within a few frames, as the CPU refit rebuilds at once; refits on the GPU go on
/// after it, and the cost they measure is the CPU copy's.
#[test]
fn a_gpu_refit_rebuilds_a_tlas_whose_quality_decayed() {
    use engine::rt::{TLAS_GPU_COST_READ_EVERY, TLAS_REBUILD_COST_RATIO};
    let Some(gpu) = testkit::gpu("a_gpu_refit_rebuilds_a_tlas_whose_quality_decayed") else { return };
    let every = TLAS_GPU_COST_READ_EVERY as u64;
    let start = field_transforms(2000, 80.0, 17);
    let mut apps = refit_pair(&gpu, &start);
    let mut readings = Vec::new();
    let jitter_frames = 3 * every + 2;
    for frame in 0..jitter_frames {
        for app in &mut apps {
            move_cubes(app, &mut SplitMix64::new(70 + frame), 1.0, false);
            run_headless(app, 1);
        }
        let stats = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().stats);
        assert!(!stats[0].tlas_rebuilt && stats[1].tlas_refit_on_gpu && !stats[1].tlas_rebuilt, "jitter, frame {frame}: {stats:?}");
        readings.extend(stats[1].tlas_gpu_cost);
    }
    let (built, _) = apps[1].world().resource::<RayTracingScene>().tlas_cost().expect("a TLAS");
    assert!(readings.len() >= 2, "{} readings of the GPU's cost in {jitter_frames} frames: {readings:?}", readings.len());
    assert!(readings.iter().all(|&c| c >= built * 0.9 && c <= built * TLAS_REBUILD_COST_RATIO), "built {built}, read {readings:?}");
    // Every cube thrown somewhere else in the field: the refitted tree's boxes span it.
    let throw = |app: &mut App, seed: u64| {
        let mut rng = SplitMix64::new(seed);
        let world = app.world_mut();
        let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
        for (_, mut t) in q.iter_mut(world).filter(|(name, _)| is_cube_node(&name.0)) {
            t.translation = Vec3::new(rng.range(-40.0, 40.0), rng.range(0.0, 4.0), rng.range(-40.0, 40.0));
        }
    };
    let mut rebuilt_at = None;
    for frame in 0..2 * every + 4 {
        for app in &mut apps {
            // Thrown once, then jittering.
            if frame == 0 {
                throw(app, 99);
            } else {
                move_cubes(app, &mut SplitMix64::new(170 + frame), 1.0, false);
            }
            run_headless(app, 1);
        }
        let stats = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().stats);
        if frame == 0 {
            assert!(stats[0].tlas_rebuilt, "the CPU refit rebuilds a TLAS thrown apart at once: {stats:?}");
            assert!(stats[1].tlas_refit_on_gpu, "the GPU refit has no reading of the new cost yet: {stats:?}");
        }
        if stats[1].tlas_rebuilt {
            rebuilt_at = Some(frame);
            break;
        }
    }
    let rebuilt_at = rebuilt_at.expect("the GPU refit never rebuilt a TLAS thrown apart");
    assert!(rebuilt_at <= every + 2, "rebuilt {rebuilt_at} frames after the throw");
    for app in &mut apps {
        move_cubes(app, &mut SplitMix64::new(400), 1.0, false);
        run_headless(app, 1);
    }
    let stats = apps[1].world().resource::<RayTracingScene>().stats;
    assert!(stats.tlas_refit_on_gpu && !stats.tlas_rebuilt, "after the rebuild: {stats:?}");
    assert_gpu_cost_is_the_cpu_copys(&mut apps[1], &gpu, "after the rebuild");
    assert_gpu_nodes_are_the_cpu_copy(&mut apps[1], &gpu, "after the rebuild");
}

/// The GPU refit of the smallest TLASes: one instance (the root is a leaf: no inner node, a cost of
/// 0 to measure), two, and nine (the first with a wide node below the root) give the CPU refit's
/// nodes bit for bit, frame after frame, with no rebuild; the cost they measure is the CPU copy's.
#[test]
fn a_gpu_refit_of_one_two_and_nine_instances_is_the_cpu_refit() {
    let Some(gpu) = testkit::gpu("a_gpu_refit_of_one_two_and_nine_instances_is_the_cpu_refit") else { return };
    for count in [1, 2, 9] {
        let start = field_transforms(count, 10.0, 60 + count as u64);
        let mut apps = refit_pair(&gpu, &start);
        for frame in 0..2 * engine::rt::TLAS_GPU_COST_READ_EVERY as u64 + 2 {
            for app in &mut apps {
                move_cubes(app, &mut SplitMix64::new(500 + frame), 1.0, false);
                run_headless(app, 1);
            }
            let what = format!("{count} instances, frame {frame}");
            let stats = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().stats);
            assert!(stats[1].tlas_refit_on_gpu && !stats[0].tlas_rebuilt && !stats[1].tlas_rebuilt, "{what}: {stats:?}");
            let [cpu, on_gpu] = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().read_tlas_nodes(&gpu));
            assert_eq!(bytemuck::cast_slice::<_, u8>(&cpu), bytemuck::cast_slice::<_, u8>(&on_gpu), "{what}: the TLASes differ");
            let (built, _) = apps[1].world().resource::<RayTracingScene>().tlas_cost().expect("a TLAS");
            assert_eq!(built == 0.0, count == 1, "{what}: built cost {built}");
            assert_gpu_cost_is_the_cpu_copys(&mut apps[1], &gpu, &what);
        }
    }
}

#[test]
fn rays_after_a_gpu_refit_hit_what_rays_after_a_cpu_refit_hit() {
    let Some(gpu) = testkit::gpu("rays_after_a_gpu_refit_hit_what_rays_after_a_cpu_refit_hit") else { return };
    let start = field_transforms(3000, 120.0, 41);
    let mut apps = refit_pair(&gpu, &start);
    // Wild moves, then small ones: the last two refitted on the GPU (the cost readings of the wild
    // moves, a few frames late, may ask for rebuilds before).
    let last = 5 + 2 * engine::rt::TLAS_GPU_COST_READ_EVERY as u64 + 4;
    for frame in 0..last {
        for app in &mut apps {
            move_cubes(app, &mut SplitMix64::new(900 + frame), 0.5, frame < 5);
            run_headless(app, 1);
        }
        let stats = apps[1].world().resource::<RayTracingScene>().stats;
        assert!(stats.tlas_refit_on_gpu || stats.tlas_rebuilt, "frame {frame}: {stats:?}");
        if frame + 2 >= last {
            assert!(stats.tlas_refit_on_gpu && !stats.tlas_rebuilt, "frame {frame}: {stats:?}");
        }
    }
    let bounds = (Vec3::new(-60.0, 0.0, -60.0), Vec3::new(60.0, 8.0, 60.0));
    let mut rays = random_rays(bounds, 4000, 7);
    let mut rng = SplitMix64::new(8);
    for _ in 0..1000 {
        let o = Vec3::new(-70.0, rng.range(0.0, 6.0), rng.range(-60.0, 60.0));
        let d = Vec3::new(1.0, rng.range(-0.02, 0.02), rng.range(-0.3, 0.3));
        rays.push(GpuRay { origin: o.to_array(), tmin: 0.0, direction: d.to_array(), tmax: 1e30 });
    }
    let [cpu, on_gpu] = apps.each_ref().map(|app| trace(app, &gpu, &rays, true));
    let hits = cpu.iter().filter(|r| r.instance != u32::MAX).count();
    assert!(hits > rays.len() / 4, "too few rays hit the field ({hits} of {}): the test would prove little", rays.len());
    for (i, (a, b)) in cpu.iter().zip(&on_gpu).enumerate() {
        assert_eq!(bytemuck::bytes_of(a), bytemuck::bytes_of(b), "ray {i} {:?}: CPU refit {a:?}, GPU refit {b:?}", rays[i]);
    }
    // And what a TLAS built from scratch over the same instances hits (a new instance far from every
    // ray makes the next frame rebuild it).
    cube_field(&[Transform::from_xyz(0.0, -1e5, 0.0)]).spawn(apps[1].world_mut());
    run_headless(&mut apps[1], 1);
    assert!(apps[1].world().resource::<RayTracingScene>().stats.tlas_rebuilt);
    let rebuilt = trace(&apps[1], &gpu, &rays, true);
    assert_same_hits("GPU refit against a rebuild", &apps[1], &rays, &rebuilt, &on_gpu);
}

#[test]
fn a_gpu_refit_of_far_flat_and_tiny_instances_is_the_cpu_refit() {
    let Some(gpu) = testkit::gpu("a_gpu_refit_of_far_flat_and_tiny_instances_is_the_cpu_refit") else { return };
    // Cubes 300 km out (float steps of 1/32 m there), flat ones (zero thickness on an
    // axis), tiny ones, mirrored ones and a few at the origin, all moving.
    let far = Vec3::new(1.0e5, -2.0e4, 3.0e5);
    let mut rng = SplitMix64::new(3);
    let start: Vec<Transform> = (0..300)
        .map(|i| {
            let at = if i % 10 == 0 { Vec3::ZERO } else { far };
            let scale = match i % 4 {
                0 => Vec3::new(4.0, 0.0, 4.0),
                1 => Vec3::splat(1e-4),
                2 => Vec3::new(-2.0, 1.0, 1.0),
                _ => Vec3::ONE,
            };
            Transform::from_translation(at + Vec3::new(rng.range(-50.0, 50.0), rng.range(-50.0, 50.0), rng.range(-50.0, 50.0)))
                .with_scale(scale)
        })
        .collect();
    let mut apps = refit_pair(&gpu, &start);
    for frame in 0..4u64 {
        for app in &mut apps {
            let mut rng = SplitMix64::new(50 + frame);
            let world = app.world_mut();
            let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
            for (_, mut t) in q.iter_mut(world).filter(|(name, _)| is_cube_node(&name.0)) {
                t.translation += Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0));
            }
            run_headless(app, 1);
        }
        let stats = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().stats);
        assert!(stats[1].tlas_refit_on_gpu && !stats[0].tlas_rebuilt && !stats[1].tlas_rebuilt, "frame {frame}: {stats:?}");
        let [cpu, on_gpu] = apps.each_ref().map(|app| app.world().resource::<RayTracingScene>().read_tlas_nodes(&gpu));
        assert_eq!(bytemuck::cast_slice::<_, u8>(&cpu), bytemuck::cast_slice::<_, u8>(&on_gpu), "frame {frame}: the TLASes differ");
        assert_gpu_cost_is_the_cpu_copys(&mut apps[1], &gpu, &format!("frame {frame}"));
        assert_gpu_nodes_are_the_cpu_copy(&mut apps[1], &gpu, &format!("frame {frame}"));
    }
    // Rays at each cube from a few metres off, and random ones through the far cluster: the same
    // hits either way.
    let world = apps[0].world_mut();
    let mut q = world.query::<(&engine::scene::Name, &Transform)>();
    let centres: Vec<Vec3> = q.iter(world).filter(|(name, _)| is_cube_node(&name.0)).map(|(_, t)| t.translation).collect();
    let mut rng = SplitMix64::new(5);
    let mut rays: Vec<GpuRay> = centres
        .iter()
        .map(|&c| {
            let d = rng.direction();
            GpuRay { origin: (c - 3.0 * d).to_array(), tmin: 0.0, direction: d.to_array(), tmax: 1e30 }
        })
        .collect();
    rays.extend(random_rays((far - Vec3::splat(60.0), far + Vec3::splat(60.0)), 1000, 6));
    let [cpu, on_gpu] = apps.each_ref().map(|app| trace(app, &gpu, &rays, true));
    let hits = cpu.iter().filter(|r| r.instance != u32::MAX).count();
    assert!(hits > 100, "too few rays hit the cubes ({hits}): the test would prove little");
    for (i, (a, b)) in cpu.iter().zip(&on_gpu).enumerate() {
        assert_eq!(bytemuck::bytes_of(a), bytemuck::bytes_of(b), "ray {i} {:?}: CPU refit {a:?}, GPU refit {b:?}", rays[i]);
    }
}

/// Postponed triangle tests (`bench trace --subgroup-postpone SHARE`: a thread tests its triangles
/// only when at least SHARE of its subgroup's active threads want theirs, and otherwise walks nodes
/// first) find the closest hits of tests done at once, ray for ray: the same distance, instance and
/// triangle (but for rare exact ties), in both bench kernels, at shares from "rarely" to "only when every lane wants to", and
/// with a shared stack of 2 (postponed triangles pushed through the workgroup ring). At a share of
/// 1 the lanes do wait, so the postponing path is the one tested. So does the persistent kernel's
/// dynamic fetch (`--subgroup-fetch`: one atomic add for a subgroup's lanes done together), with
/// tests at once or postponed. Needs subgroup operations (lavapipe has them); skipped with a line
/// saying so on an adapter without them.
#[test]
fn postponed_triangle_tests_find_the_hits_of_tests_at_once() {
    let test = "postponed_triangle_tests_find_the_hits_of_tests_at_once";
    let Some(gpu) = testkit::gpu_with(test, engine::gpu::GpuOptions { subgroups: true, ..Default::default() }) else { return };
    if !gpu.subgroups {
        let adapter = gpu.adapter_name();
        // lavapipe offers subgroups: there a skip would hide a regression.
        assert!(
            !(std::env::var("CI").is_ok_and(|v| v == "true") && adapter.contains("llvmpipe")),
            "{test}: CI=true and lavapipe ({adapter}) without subgroup operations"
        );
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), "{test}: skipped: {adapter} has no subgroup operations (wgpu::Features::SUBGROUP)");
        return;
    }
    let (grid, rays) = ([5, 4, 3], 64);
    for (name, scene) in [("door_room", (scenes::find("door_room").expect("built-in").build)()), ("crowd", crowd_scene())] {
        let bounds = lab::bench::world_bounds(&scene).expect("bounds");
        let app = lab::bench::prepared_app(&gpu, scene);
        let at_once = lab::bench::TraceVariant { ray_order: lab::bench::RayOrder::Coherent, ..Default::default() };
        let expected = lab::bench::closest_hits(&gpu, &app, bounds, grid, rays, at_once).expect("tests at once");
        let hits = expected.iter().filter(|h| h.instance != u32::MAX).count();
        assert!(hits > expected.len() / 4, "{name}: {hits} of {} rays hit: the rays should meet the scene", expected.len());
        assert_eq!(
            lab::bench::hit_distances(&gpu, &app, bounds, grid, rays, at_once).expect("distances"),
            expected.iter().map(|h| h.t).collect::<Vec<_>>(),
            "{name}: writing the hits' ids changes no distance"
        );
        // The first ray whose hit differs, if any. Two triangles hit at the same distance, bit for
        // bit (along a shared edge), are a tie that the order of the tests settles: tests in another
        // order may find the other one, in the same instance. A few such rays are allowed.
        let first_difference = |got: &[lab::bench::BenchHit]| {
            assert_eq!(got.len(), expected.len());
            let tie = |a: &lab::bench::BenchHit, b: &lab::bench::BenchHit| a.t.to_bits() == b.t.to_bits() && a.instance == b.instance;
            let ties = got.iter().zip(&expected).filter(|(a, b)| a != b && tie(a, b)).count();
            if ties > 0 {
                eprintln!("{name}: {ties} ties of {hits} hits settled otherwise");
            }
            assert!(ties * 200 <= hits, "{name}: {ties} ties settled otherwise of {hits} hits: too many to be ties");
            got.iter().zip(&expected).enumerate().find(|(_, (a, b))| a != b && !tie(a, b)).map(|(i, (a, b))| (i, *a, *b))
        };
        // Traces with `variant` and asserts the hits are those of the tests at once.
        let finds_the_same_hits = |variant: lab::bench::TraceVariant, what: &str| {
            let got = lab::bench::closest_hits(&gpu, &app, bounds, grid, rays, variant).expect(what);
            assert_eq!(first_difference(&got), None, "{what}: (ray, got, expected)");
        };
        let work = |variant: lab::bench::TraceVariant| lab::bench::traversal_work(&gpu, &app, bounds, grid, rays, variant).expect("work");
        for share in [0.2, 0.5, 1.0] {
            for (workgroup_size, shared_stack_entries) in [(64, 0), (128, 0), (128, 2)] {
                let postponed =
                    lab::bench::TraceVariant { postpone_triangles: Some(share), workgroup_size, shared_stack_entries, ..at_once };
                let what = format!("{name}, share {share}, {workgroup_size} threads a workgroup, shared stack {shared_stack_entries}");
                finds_the_same_hits(postponed, &format!("{what}, thread a ray"));
                // Fewer workgroups than rays / 64, and a share that does not divide the rays evenly;
                // next rays taken one a lane, or one fetch for a subgroup's lanes done together.
                for subgroup_fetch in [false, true] {
                    let persistent = lab::bench::TraceVariant { persistent_groups: Some(7), subgroup_fetch, ..postponed };
                    finds_the_same_hits(persistent, &format!("{what}, persistent, subgroup fetch {subgroup_fetch}"));
                }
            }
            // Dynamic fetch alone.
            let fetch = lab::bench::TraceVariant { persistent_groups: Some(7), subgroup_fetch: true, ..at_once };
            finds_the_same_hits(fetch, &format!("{name}, persistent, subgroup fetch"));
            let w = work(lab::bench::TraceVariant { postpone_triangles: Some(share), ..at_once });
            eprintln!(
                "{name}, share {share}: {:.1} BLAS nodes, {:.1} triangles, {:.1} steps of which {:.2} put tests off and {:.2} waited, a ray; \
                 SIMT efficiency {:.0}%",
                w.blas_nodes,
                w.triangles,
                w.steps,
                w.postponed,
                w.waits,
                100.0 * w.simt_efficiency
            );
            assert!(w.postponed >= w.waits, "{name}, share {share}");
            if share == 1.0 {
                assert!(w.waits > 0.0, "{name}: at a share of 1 some lane should wait for the others");
                assert!(w.postponed > w.waits, "{name}: at a share of 1 some lane should walk nodes before its triangles");
            }
        }
        // Packets (`bench trace --packet`): the rays of a subgroup or a workgroup walk as one; each
        // lane still culls by its own closest hit, so the hits are the same. (Workgroup packets
        // go up to 128 threads: see lab::bench::MAX_WORKGROUP_PACKET.)
        for packet in [lab::bench::PacketScope::Subgroup, lab::bench::PacketScope::Workgroup] {
            for workgroup_size in [32, 64, 128] {
                let v = lab::bench::TraceVariant { packet: Some(packet), workgroup_size, ..at_once };
                finds_the_same_hits(v, &format!("{name}, packets of a {packet:?}, {workgroup_size} threads"));
            }
            let w = work(lab::bench::TraceVariant { packet: Some(packet), workgroup_size: 32, ..at_once });
            let alone = work(lab::bench::TraceVariant { workgroup_size: 32, ..at_once });
            eprintln!("{name}, packets of a {packet:?}: {:.1} steps a ray against {:.1} a ray walked alone", w.steps, alone.steps);
            // A packet visits every node any of its rays needs: never less work a ray.
            assert!(
                w.blas_nodes >= alone.blas_nodes && w.steps >= alone.steps,
                "{name}, {packet:?}: a packet walks a superset of its rays' nodes"
            );
        }
    }
}

/// Every mesh's BLAS as the scene holds it, built again at `quality` on the side: equal node for node.
fn assert_blases_built_at(app: &App, quality: engine::rt::BlasBuildQuality) {
    let rt = app.world().resource::<RayTracingScene>();
    let meshes = app.world().resource::<Assets<Mesh>>();
    for (handle, mesh) in meshes.iter() {
        let held = rt.blas(handle.index() as usize).expect("built");
        let fresh = engine::rt::Blas::build_with(mesh, quality);
        let bytes = |b: &engine::rt::Blas| bytemuck::cast_slice::<_, u8>(&b.nodes).to_vec();
        assert!(bytes(held) == bytes(&fresh) && held.triangles == fresh.triangles, "mesh '{}': not the BLAS of {quality:?}", mesh.name);
    }
}

#[test]
fn every_blas_build_quality_finds_the_cpu_references_hits_and_a_change_rebuilds_every_blas() {
    use engine::rt::BlasBuildQuality;
    let Some(gpu) = testkit::gpu("every_blas_build_quality_finds_the_cpu_references_hits_and_a_change_rebuilds_every_blas") else { return };
    let scene = (scenes::find("door_room").expect("built-in").build)();
    let bounds = scene.bounds().expect("bounds");
    let rays = random_rays(bounds, 3000, 0xB1A5);
    let mut app = app_for(&gpu, scene);
    assert_blases_built_at(&app, BlasBuildQuality::default());
    let nodes = |app: &App| -> usize {
        let rt = app.world().resource::<RayTracingScene>();
        (0..app.world().resource::<Assets<Mesh>>().len()).filter_map(|i| rt.blas(i)).map(|b| b.nodes.len()).sum()
    };
    let mut node_counts = Vec::new();
    for quality in [BlasBuildQuality::Fast, BlasBuildQuality::Medium, BlasBuildQuality::High] {
        app.insert_resource(quality);
        run_headless(&mut app, 1);
        assert_blases_built_at(&app, quality);
        let (n, exact, hits) = compare(&format!("door_room, {quality:?}"), &app, &gpu, &rays);
        assert!(hits > n / 10 && exact > n * 99 / 100, "{quality:?}: {exact}/{n} exact, {hits} hits");
        node_counts.push(nodes(&app));
    }
    // The presets build different trees (else this test could not tell them apart).
    assert!(node_counts[0] != node_counts[2] || node_counts[1] != node_counts[2], "node counts {node_counts:?}");
}

/// Overlapping instances of meshes each used once (sheets and boxes, rotated and non-uniformly
/// scaled, as a building's walls, vaults and floor overlap), plus two instances of one shared cube,
/// which no group may take (a group copies its members' triangles).
fn grouped_scene() -> SceneDescription {
    let mut s = SceneDescription { name: "grouped".into(), ..Default::default() };
    let m = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    let mut rng = SplitMix64::new(0x006A_0C1D);
    for i in 0..8 {
        let mesh = if i % 2 == 0 {
            s.add_mesh(sheet(16 + 4 * i))
        } else {
            s.add_mesh(engine::shapes::cuboid("box", Vec3::splat(0.3 + 0.1 * i as f32)))
        };
        let t = Transform::from_xyz(rng.range(-1.0, 1.0), rng.range(-0.5, 0.5), rng.range(-1.0, 1.0))
            .with_rotation(Quat::from_axis_angle(rng.direction(), rng.range(0.0, 6.0)))
            .with_scale(Vec3::new(rng.range(1.0, 2.5), rng.range(0.5, 2.0), rng.range(1.0, 2.5)));
        s.add_node(&format!("unique{i}"), t, None, vec![NodeContent::Meshes(vec![(mesh, m)])]);
    }
    let cube = s.add_mesh(engine::shapes::cuboid("cube", Vec3::splat(0.4)));
    for i in 0..2 {
        s.add_node(&format!("shared{i}"), Transform::from_xyz(0.5 * i as f32, 0.2, -0.3), None, vec![NodeContent::Meshes(vec![(cube, m)])]);
    }
    s
}

/// Asserts that traces of the same rays without and with static groups found the same hits: the
/// same instance, triangle and any-hit answer, at distances equal to float rounding (a group's
/// triangles are stored in its frame instance's space), or a tie the CPU reference confirms.
fn assert_close_hits(what: &str, app: &App, rays: &[GpuRay], want: &[TraceResult], got: &[TraceResult]) {
    let cpu = cpu_reference(app);
    for (i, (w, g)) in want.iter().zip(got).enumerate() {
        let same =
            w.instance == g.instance && w.primitive == g.primitive && w.any_hit == g.any_hit && (w.instance == u32::MAX || close(g.t, w.t));
        let tie = close(g.t, w.t) && w.any_hit == g.any_hit && cpu.hit_t(&rays[i], g.instance, g.primitive).is_some_and(|t| close(t, w.t));
        assert!(same || tie, "{what}, ray {i} {:?}: without groups {w:?}, grouped {g:?}", rays[i]);
    }
}

/// Sets the static grouping and runs the frame that rebuilds the TLAS with it.
fn group(app: &mut App, grouping: engine::rt::StaticGrouping) -> (usize, usize) {
    app.world_mut().resource_mut::<RayTracingScene>().set_static_grouping(grouping);
    run_headless(app, 1);
    let rt = app.world().resource::<RayTracingScene>();
    assert!(rt.stats.tlas_rebuilt, "a new grouping rebuilds the TLAS");
    (rt.static_group_count(), rt.grouped_instance_count())
}

/// A static group (one BLAS over overlapping static instances, in one member's space) reports each
/// hit on the member it belongs to, with that member's triangle index and distance: the CPU
/// reference's hits, and the hits of the same scene without groups. A member that moves leaves its
/// group (the TLAS is rebuilt) and is seen where it went.
#[test]
fn static_groups_report_their_members_hits_and_a_member_that_moves_leaves() {
    use engine::rt::StaticGrouping;
    let Some(gpu) = testkit::gpu("static_groups_report_their_members_hits_and_a_member_that_moves_leaves") else { return };
    let scene = grouped_scene();
    let bounds = scene.bounds().expect("bounds");
    let mut app = app_for(&gpu, scene);
    assert_eq!(group(&mut app, StaticGrouping::Off), (0, 0));
    let rays = random_rays(bounds, 3000, 0x6A0C);
    let (closest, any) = (trace(&app, &gpu, &rays, false), trace(&app, &gpu, &rays, true));
    let (groups, grouped) = group(&mut app, StaticGrouping::Always);
    assert_eq!((groups, grouped), (1, 8), "the eight unique instances overlap: one group, the shared cube's instances outside it");
    assert_eq!(app.world().resource::<RayTracingScene>().tlas_primitive_count(), 3, "one leaf for the group, one for each shared cube");
    let (n, _, hits) = compare("grouped", &app, &gpu, &rays);
    assert!(hits > n / 10, "too few hits ({hits} of {n}) for the test to mean anything");
    let got = trace(&app, &gpu, &rays, false);
    let members: std::collections::BTreeSet<u32> = got.iter().filter(|r| r.instance != u32::MAX).map(|r| r.instance).collect();
    assert!(members.len() >= 8, "hits should land on many members, each reported as itself: {members:?}");
    assert_close_hits("grouped", &app, &rays, &closest, &got);
    assert_close_hits("grouped, any hit", &app, &rays, &any, &trace(&app, &gpu, &rays, true));

    // unique3 moves: the refit gives way to a rebuild, which leaves it out of the group.
    let world = app.world_mut();
    let mut q = world.query::<(&engine::scene::Name, &mut Transform)>();
    for (name, mut t) in q.iter_mut(world) {
        if name.0 == "unique3" {
            t.translation += Vec3::new(0.7, 0.4, -0.5);
            t.rotation *= Quat::from_rotation_x(0.8);
        }
    }
    run_headless(&mut app, 1);
    let rt = app.world().resource::<RayTracingScene>();
    assert!(rt.stats.tlas_rebuilt, "a grouped member's move rebuilds the TLAS: {:?}", rt.stats);
    assert_eq!((rt.static_group_count(), rt.grouped_instance_count()), (1, 7), "the others are grouped again, without the mover");
    compare("a member moved", &app, &gpu, &random_rays(bounds, 3000, 0x6A0D));
}

/// The default grouping (`StaticGrouping::Estimated`) forms a group only where its CPU estimate says
/// rays do less work: the traversal steps the GPU counts for probe rays are then no more than
/// without groups (the cathedral, whose four meshes all span the nave, is grouped; the Cornell box,
/// whose room holds small boxes, is not).
#[test]
fn the_estimated_grouping_never_adds_traversal_work() {
    use engine::rt::StaticGrouping;
    let Some(gpu) = testkit::gpu("the_estimated_grouping_never_adds_traversal_work") else { return };
    let (grid, rays) = ([6, 4, 6], 64);
    for (name, grouped) in [("cathedral", true), ("cornell", false)] {
        let scene = (scenes::find(name).expect("built-in").build)();
        let bounds = lab::bench::world_bounds(&scene).expect("bounds");
        let mut app = lab::bench::prepared_app(&gpu, scene);
        let steps = |app: &mut App, grouping| {
            let (groups, _) = group(app, grouping);
            let work = lab::bench::traversal_work(&gpu, app, bounds, grid, rays, Default::default()).expect("work");
            (groups, work.steps)
        };
        let (none, off) = steps(&mut app, StaticGrouping::Off);
        let (groups, estimated) = steps(&mut app, StaticGrouping::Estimated);
        let (_, always) = steps(&mut app, StaticGrouping::Always);
        eprintln!("{name}: steps a ray {off:.2} without groups, {estimated:.2} estimated ({groups} groups), {always:.2} always");
        assert_eq!((none, groups > 0), (0, grouped), "{name}: {groups} groups");
        assert!(estimated <= off * 1.001, "{name}: {estimated} steps a ray with the estimated grouping against {off} without");
        if grouped {
            assert!(estimated < off * 0.95, "{name}: the group should save steps ({estimated} against {off})");
        } else {
            assert!(always > off, "{name}: the estimate declined a group that would add work ({always} against {off})");
        }
    }
}

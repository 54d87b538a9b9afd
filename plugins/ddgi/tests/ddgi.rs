//! DDGI on a real Vulkan driver (lavapipe in CI): the mapping functions against the CPU, the atlas
//! borders, the white furnace, the hysteresis, images against path-traced references, and
//! stability over hundreds of frames.

use ddgi::atlas::{Atlas, probe_mean_irradiance, read_distance, read_irradiance};
use ddgi::{DdgiGpuVolumes, DdgiOutput, DdgiProbe, DdgiProbeState, DdgiVolume, use_ddgi};
use engine::app::run_headless;
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, RenderedFrame, add_default_camera, headless_app, render_scene_and_inspect};
use engine::render::RenderSize;
use engine::scene::{Assets, Material, NodeContent, SceneDescription, Transform};
use glam::{DVec3, UVec3, Vec3};
use testkit::{closed_room, gpu, mean_flip, path_traced_reference};

// ---------------------------------------------------------------------------------------------
// Without a GPU

#[test]
fn host_structs_match_naga_layout() {
    ddgi::register_shaders().expect("register");
    for host in ddgi::gpu::gpu_structs() {
        engine::shader::check_struct_layout(&host).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn every_ddgi_module_is_registered_parses_and_validates() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    engine::shader::check_shader_folder(&dir, ddgi::SHADERS).unwrap_or_else(|e| panic!("{e}"));
    ddgi::register_shaders().expect("register");
    // The self-test kernels too (whichever test runs first registers them; registering again is a no-op).
    engine::shader::register(SELFTEST_SHADERS).expect("register the self-test kernels");
    for (name, _) in ddgi::SHADERS.iter().chain(SELFTEST_SHADERS) {
        let parsed = engine::shader::parse(name).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(!parsed.module.entry_points.is_empty(), !name.ends_with(".inc.wgsl"), "{name}: entry points only outside libraries");
    }
    // The generated constants read back from the parsed shader as the host's values.
    let parsed = engine::shader::parse("ddgi_budget.wgsl").expect("parse");
    assert_eq!(parsed.u32_constant("DDGI_BUDGET_BLOCK"), Some(ddgi::gpu::BUDGET_BLOCK));
    assert_eq!(parsed.u32_constant("DDGI_NO_PIN"), Some(ddgi::gpu::NO_PIN));
}

/// The self-test kernels (GPU functions checked against the CPU), registered by the tests only.
const SELFTEST_SHADERS: &[engine::shader::ShaderModule] = &[("ddgi_selftest.wgsl", include_str!("shaders/ddgi_selftest.wgsl"))];

#[test]
fn invalid_settings_name_their_field_and_value() {
    let exponent =
        |e: f32| DdgiVolume { adaptive: ddgi::DdgiAdaptive { hysteresis_exponent: e, ..ddgi::DdgiAdaptive::on() }, ..Default::default() };
    let smoothing =
        |s: f32| DdgiVolume { adaptive: ddgi::DdgiAdaptive { rest_smoothing: Some(s), ..ddgi::DdgiAdaptive::on() }, ..Default::default() };
    let drift = |d: f32| DdgiVolume { adaptive: ddgi::DdgiAdaptive { drift_rate: d, ..ddgi::DdgiAdaptive::on() }, ..Default::default() };
    let cases: [(DdgiVolume, &str, &str); 13] = [
        (DdgiVolume { probe_counts: Some(UVec3::new(4, 0, 4)), ..Default::default() }, "probe_counts", "UVec3(4, 0, 4)"),
        (DdgiVolume { rays_per_probe: 0, ..Default::default() }, "rays_per_probe", "0"),
        (DdgiVolume { hysteresis: 1.5, ..Default::default() }, "hysteresis", "1.5"),
        (DdgiVolume { normal_bias: f32::NAN, ..Default::default() }, "normal_bias", "NaN"),
        (DdgiVolume { bounds: Some((DVec3::ONE, DVec3::ZERO)), ..Default::default() }, "bounds", "DVec3(1.0, 1.0, 1.0)"),
        (exponent(-0.5), "adaptive.hysteresis_exponent", "-0.5"),
        (exponent(f32::NAN), "adaptive.hysteresis_exponent", "NaN"),
        (smoothing(1.0), "adaptive.rest_smoothing", "1.0"),
        (smoothing(f32::NAN), "adaptive.rest_smoothing", "NaN"),
        (drift(0.5), "adaptive.drift_rate", "0.5"),
        (drift(f32::INFINITY), "adaptive.drift_rate", "inf"),
        (DdgiVolume { hit_occlusion_rays: 65, ..Default::default() }, "hit_occlusion_rays", "65"),
        (DdgiVolume { hit_occlusion_reach: 0.0, ..Default::default() }, "hit_occlusion_reach", "0.0"),
    ];
    for (volume, field, value) in cases {
        let message = volume.validate().expect_err(field).to_string();
        assert!(message.contains(field) && message.contains(value), "{message}");
    }
    // A grid whose ray buffers exceed the adapter's storage buffer limit is refused with the sizes.
    let huge = DdgiVolume { probe_counts: Some(UVec3::splat(128)), rays_per_probe: 1024, ..Default::default() };
    let limits = ddgi::volume::DdgiLimits { max_texture_dimension: 1 << 20, max_storage_buffer_bytes: 128 << 20 };
    let err = ddgi::DdgiLayout::new(&huge, (Vec3::ZERO, Vec3::ONE), limits).expect_err("over the limit").to_string();
    assert!(err.contains("34359738368") && err.contains("134217728"), "{err}");
}

#[test]
fn layout_puts_probes_at_cell_centres_and_tiles_in_rows() {
    let volume = DdgiVolume { probe_counts: Some(UVec3::new(3, 2, 5)), ..Default::default() };
    let limits = ddgi::volume::DdgiLimits { max_texture_dimension: 256, max_storage_buffer_bytes: 1 << 30 };
    let layout = ddgi::DdgiLayout::new(&volume, (Vec3::ZERO, Vec3::new(3.0, 2.0, 10.0)), limits).expect("layout");
    assert_eq!(layout.spacing, Vec3::new(1.0, 1.0, 2.0));
    assert_eq!(layout.grid_position(0), Vec3::new(0.5, 0.5, 1.0));
    assert_eq!(layout.grid_position(layout.probe_count - 1), Vec3::new(2.5, 1.5, 9.0));
    // 18-texel distance tiles: 14 fit in a 256-texel row; 30 probes take 3 rows.
    assert_eq!(layout.tiles_per_row, 14);
    assert_eq!(layout.distance_atlas, glam::UVec2::new(14 * 18, 3 * 18));
    assert_eq!(layout.irradiance_atlas, glam::UVec2::new(14 * 10, 3 * 10));
    // The same grid does not fit in 64-texel textures: refused with the height it needs.
    let small = ddgi::volume::DdgiLimits { max_texture_dimension: 64, ..limits };
    let err = ddgi::DdgiLayout::new(&volume, (Vec3::ZERO, Vec3::ONE), small).expect_err("too tall").to_string();
    assert!(err.contains("180") && err.contains("64"), "{err}");
}

// ---------------------------------------------------------------------------------------------
// Single functions on the GPU against the CPU

fn run_selftest(gpu: &GpuContext, entry: &str, input: &[[f32; 4]]) -> Vec<[f32; 4]> {
    use engine::wgpu::util::DeviceExt;
    let device = &gpu.device;
    ddgi::register_shaders().and_then(|()| engine::shader::register(SELFTEST_SHADERS)).expect("register");
    let program = engine::shader::compute_program(device, "ddgi_selftest.wgsl", entry, entry).expect("selftest shader");
    let input_buffer = device.create_buffer_init(&engine::wgpu::util::BufferInitDescriptor {
        label: Some("selftest_in"),
        contents: bytemuck::cast_slice(input),
        usage: engine::wgpu::BufferUsages::STORAGE,
    });
    let output = device.create_buffer(&engine::wgpu::BufferDescriptor {
        label: Some("selftest_out"),
        size: (input.len() * 16) as u64,
        usage: engine::wgpu::BufferUsages::STORAGE | engine::wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let empty = |g: u32| {
        device.create_bind_group(&engine::wgpu::BindGroupDescriptor {
            label: None,
            layout: &program.pipeline.get_bind_group_layout(g),
            entries: &[],
        })
    };
    let groups = [
        empty(0),
        empty(1),
        empty(2),
        program.bind_group(device, 3, &[("selftest_in", input_buffer.as_entire_binding()), ("selftest_out", output.as_entire_binding())]),
    ];
    let mut encoder = device.create_command_encoder(&Default::default());
    engine::gpu::dispatch(
        &mut encoder,
        entry,
        &program.pipeline,
        &groups.iter().collect::<Vec<_>>(),
        ((input.len() as u32).div_ceil(64), 1),
    );
    gpu.queue.submit([encoder.finish()]);
    bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &output))
}

#[test]
fn octahedral_mapping_round_trips_and_fibonacci_directions_cover_the_sphere() {
    let Some(gpu) = gpu("octahedral_mapping_round_trips") else { return };
    let mut rng = engine::rng::SplitMix64::new(7);
    let mut dirs: Vec<Vec3> = (0..2000).map(|_| rng.direction()).collect();
    // The axes and the octahedron's seams.
    dirs.extend([Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z, Vec3::new(1.0, -1.0, 0.0).normalize()]);
    let input: Vec<[f32; 4]> = dirs.iter().map(|d| d.extend(0.0).to_array()).collect();
    let out = run_selftest(&gpu, "octahedral_round_trip", &input);
    for (d, o) in dirs.iter().zip(&out) {
        let back = Vec3::new(o[0], o[1], o[2]);
        assert!(back.distance(*d) < 1e-5, "{d} came back as {back}");
        assert!(o[3] <= 1.0 + 1e-6, "{d}: octahedral coordinates outside [-1, 1]²");
    }

    // Spherical Fibonacci: unit length, mean near zero, and no direction of the sphere far from a
    // point (covering radius ~ 2/√n for an even cover; a clumped set would leave holes).
    for n in [32usize, 128, 256] {
        let points: Vec<Vec3> =
            run_selftest(&gpu, "fibonacci_directions", &vec![[0.0; 4]; n]).iter().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let expected = workspace_free_fibonacci(n);
        for (p, e) in points.iter().zip(&expected) {
            assert!((p.length() - 1.0).abs() < 1e-5 && p.distance(*e) < 1e-4, "n = {n}: {p} vs CPU {e}");
        }
        let mean = points.iter().sum::<Vec3>() / n as f32;
        assert!(mean.length() < 2.0 / n as f32 + 0.01, "n = {n}: mean {mean}");
        let covering = (0..4000)
            .map(|_| {
                let d = rng.direction();
                points.iter().map(|p| p.dot(d)).fold(-1.0f32, f32::max).clamp(-1.0, 1.0).acos()
            })
            .fold(0.0f32, f32::max);
        // An ideal (hexagonal) cover has radius ≈ 2.2/√n; Fibonacci sets come close, while a
        // clumped or one-sided set leaves holes of a radian or more.
        assert!(covering < 3.0 / (n as f32).sqrt(), "n = {n}: a direction is {covering} rad from every ray");
    }
}

/// The CPU mirror of `ddgi_spherical_fibonacci` (Keinert et al. 2015, z-up).
fn workspace_free_fibonacci(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let phi = std::f32::consts::TAU * (i as f32 * 0.618_034).fract();
            let cos_theta = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let sin_theta = (1.0 - cos_theta * cos_theta).clamp(0.0, 1.0).sqrt();
            Vec3::new(phi.cos() * sin_theta, phi.sin() * sin_theta, cos_theta)
        })
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Running DDGI

/// Runs `scene` with one DDGI volume for `frames` frames and returns the image and the world.
fn run_ddgi(gpu: &GpuContext, scene: SceneDescription, volume: DdgiVolume, size: u32, frames: u32) -> (RenderedFrame, bevy_app::App) {
    let mut scene = scene;
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    let mut app = headless_app(gpu, RenderSize { width: size, height: size }, 1.0 / 60.0);
    use_ddgi(&mut app, volume, DdgiOutput::Full);
    scene.spawn(app.world_mut());
    run_headless(&mut app, frames);
    let frame = engine::headless::read_frame(gpu, app.world());
    (frame, app)
}

fn first_volume(app: &bevy_app::App) -> &ddgi::VolumeGpu {
    &app.world().resource::<DdgiGpuVolumes>().volumes.first().expect("a volume").1
}

fn assert_finite_atlases(gpu: &GpuContext, volume: &ddgi::VolumeGpu, what: &str) {
    let irradiance = read_irradiance(gpu, volume);
    assert!(irradiance.texels.iter().all(|t| t.is_finite()), "{what}: non-finite irradiance texel");
    let distance = read_distance(gpu, volume);
    assert!(distance.texels.iter().all(|t| t.is_finite()), "{what}: non-finite distance texel");
}

/// The interior texel a border texel of an `(n + 2)²` tile repeats (written independently of the
/// shader: each edge is mirrored around its midpoint, corners take the opposite corner).
fn mirrored_source(x: u32, y: u32, n: u32) -> (u32, u32) {
    let last = n + 1;
    let edge = |c: u32| c == 0 || c == last;
    match (edge(x), edge(y)) {
        (true, true) => (if x == 0 { n } else { 1 }, if y == 0 { n } else { 1 }),
        (false, true) => (last - x, if y == 0 { 1 } else { n }),
        (true, false) => (if x == 0 { 1 } else { n }, last - y),
        (false, false) => (x, y),
    }
}

fn assert_borders_mirror<T: Copy + PartialEq + std::fmt::Debug>(atlas: &Atlas<T>, n: u32, tiles: u32, what: &str) {
    let mut checked = 0;
    for tile in 0..tiles {
        let tx = (tile % (atlas.size.x / (n + 2))) * (n + 2);
        let ty = (tile / (atlas.size.x / (n + 2))) * (n + 2);
        for y in 0..n + 2 {
            for x in 0..n + 2 {
                let (sx, sy) = mirrored_source(x, y, n);
                if (sx, sy) != (x, y) {
                    assert_eq!(atlas.get(tx + x, ty + y), atlas.get(tx + sx, ty + sy), "{what}: tile {tile}, border texel ({x}, {y})");
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, tiles * (4 * n + 4), "{what}: every border texel checked");
}

#[test]
fn border_texels_equal_their_mirrored_interior_texels() {
    let Some(gpu) = gpu("border_texels_equal_their_mirrored_interior_texels") else { return };
    let scene = (scenes::find("cornell").expect("cornell").build)();
    let volume = DdgiVolume {
        bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
        probe_counts: Some(UVec3::new(3, 2, 2)),
        rays_per_probe: 64,
        irradiance_texels: 6,
        distance_texels: 10,
        classification: false,
        ..Default::default()
    };
    let (_, app) = run_ddgi(&gpu, scene, volume, 16, 4);
    let v = first_volume(&app);
    let irradiance = read_irradiance(&gpu, v);
    assert!(irradiance.texels.iter().any(|t| t.max_element() > 0.0), "the probes saw light");
    assert_borders_mirror(&irradiance, 6, v.layout.probe_count, "irradiance");
    assert_borders_mirror(&read_distance(&gpu, v), 10, v.layout.probe_count, "distance");
}

#[test]
fn furnace_probes_converge_to_the_analytic_irradiance() {
    let Some(gpu) = gpu("furnace_probes_converge_to_the_analytic_irradiance") else { return };
    // A closed room of albedo ρ emitting Le everywhere: radiance L = Le / (1 − ρ) in every
    // direction, so every probe's irradiance is E = π L. DDGI gets there one bounce per frame.
    let (albedo, emission) = (0.5f32, 0.3f32);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.5), Vec3::new(1.0, 1.5, 1.5));
    let material = Material { base_color: Vec3::splat(albedo).extend(1.0), emissive: Vec3::splat(emission), ..Default::default() };
    let volume = DdgiVolume {
        bounds: Some((lo.into(), hi.into())),
        probe_counts: Some(UVec3::new(3, 2, 3)),
        rays_per_probe: 96,
        hysteresis: 0.8,
        // The fixed budget's bounce-per-frame convergence is what this checks.
        adaptive: ddgi::DdgiAdaptive::off(),
        ..Default::default()
    };
    let (frame, app) = run_ddgi(&gpu, closed_room(lo, hi, 0.2, material), volume, 24, 90);
    let expected = std::f32::consts::PI * emission / (1.0 - albedo);
    let v = first_volume(&app);
    let atlas = read_irradiance(&gpu, v);
    for probe in 0..v.layout.probe_count {
        let e = probe_mean_irradiance(&atlas, v, probe);
        assert!((e - Vec3::splat(expected)).abs().max_element() < 0.02 * expected, "probe {probe}: {e}, expected {expected}");
    }
    // The camera sees radiance L on every wall: emission + albedo/π · E.
    let mean = frame.hdr.chunks_exact(4).map(|p| p[0]).sum::<f32>() / (frame.width * frame.height) as f32;
    let radiance = emission / (1.0 - albedo);
    assert!((mean - radiance).abs() < 0.03 * radiance, "image radiance {mean}, expected {radiance}");
}

#[test]
fn hit_occlusion_keeps_a_cluttered_furnace_exact() {
    let Some(gpu) = gpu("hit_occlusion_keeps_a_cluttered_furnace_exact") else { return };
    // The furnace of the test above with clutter of the same material: a slab a hand above the
    // floor and a block in a corner. Every surface still emits Le and reflects ρ, so the radiance
    // is Le / (1 − ρ) everywhere and every probe's irradiance π Le / (1 − ρ), however occluded the
    // probe rays' hits are. Hit occlusion rays find those hits' blocked directions; the surfaces
    // there are taken to reflect like the hit's own (emission plus albedo times the probes'
    // light), which is exact here: merely darkening the blocked share would settle lower.
    let (albedo, emission) = (0.5f32, 0.3f32);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.5), Vec3::new(1.0, 1.5, 1.5));
    let material = Material { base_color: Vec3::splat(albedo).extend(1.0), emissive: Vec3::splat(emission), ..Default::default() };
    let mut scene = closed_room(lo, hi, 0.2, material);
    let clutter = [("slab", Vec3::new(-0.2, 0.12, 0.0), Vec3::new(0.6, 0.02, 0.8)), ("block", Vec3::new(0.7, 0.3, 1.2), Vec3::splat(0.3))];
    for (name, centre, half) in clutter {
        scene.add_mesh_node(name, Transform::from_translation(centre), engine::shapes::cuboid(name, half), 0);
    }
    let volume = DdgiVolume {
        bounds: Some((lo.into(), hi.into())),
        probe_counts: Some(UVec3::new(3, 2, 3)),
        rays_per_probe: 96,
        hysteresis: 0.8,
        hit_occlusion_rays: 8,
        adaptive: ddgi::DdgiAdaptive::off(),
        ..Default::default()
    };
    let (_, app) = run_ddgi(&gpu, scene, volume, 16, 90);
    let expected = std::f32::consts::PI * emission / (1.0 - albedo);
    let v = first_volume(&app);
    let atlas = read_irradiance(&gpu, v);
    let bytes = engine::gpu::readback::read_buffer(&gpu, &v.probes);
    let probes: Vec<ddgi::gpu::DdgiProbeData> =
        bytemuck::pod_collect_to_vec(&bytes[..v.layout.probe_count as usize * size_of::<ddgi::gpu::DdgiProbeData>()]);
    let mut checked = 0;
    for probe in 0..v.layout.probe_count {
        if probes[probe as usize].state & ddgi::gpu::PROBE_INACTIVE != 0 {
            continue;
        }
        let e = probe_mean_irradiance(&atlas, v, probe);
        assert!((e - Vec3::splat(expected)).abs().max_element() < 0.03 * expected, "probe {probe}: {e}, expected {expected}");
        checked += 1;
    }
    assert!(checked >= 9, "only {checked} probes were active");
}

/// Emission of the walls of [`emitting_room`].
const EMITTING_ROOM_LE: f32 = 0.5;

/// Black walls around [−1, 1]³ that emit [`EMITTING_ROOM_LE`]: every ray sees it, so a probe's
/// irradiance is π·Le from its first update on; switching the emission off makes every new sample
/// zero.
fn emitting_room() -> SceneDescription {
    let black = Material { base_color: Vec3::ZERO.extend(1.0), emissive: Vec3::splat(EMITTING_ROOM_LE), ..Default::default() };
    closed_room(Vec3::splat(-1.0), Vec3::splat(1.0), 0.2, black)
}

/// 2³ probes of 64 rays over [`emitting_room`], with hysteresis `h` and no firefly clamp.
fn emitting_room_volume(h: f32) -> DdgiVolume {
    DdgiVolume {
        bounds: Some((DVec3::splat(-1.0), DVec3::splat(1.0))),
        probe_counts: Some(UVec3::splat(2)),
        rays_per_probe: 64,
        hysteresis: h,
        adaptive: ddgi::DdgiAdaptive::off(),
        firefly_threshold: 0.0,
        ..Default::default()
    }
}

/// The mean irradiance (red) over every probe of the first volume.
fn mean_probe_irradiance(gpu: &GpuContext, app: &bevy_app::App) -> f32 {
    let v = first_volume(app);
    let atlas = read_irradiance(gpu, v);
    (0..v.layout.probe_count).map(|p| probe_mean_irradiance(&atlas, v, p).x).sum::<f32>() / v.layout.probe_count as f32
}

/// Switches the emission off and checks that k = 1, 5 and 10 frames later the probes hold
/// `before · rate^k`.
fn assert_decay_after_emission_off(gpu: &GpuContext, app: &mut bevy_app::App, before: f32, rate: f32, what: &str) {
    switch_emission_off(app);
    let mut done = 0;
    for k in [1u32, 5, 10] {
        run_headless(app, k - done);
        done = k;
        let expected = before * rate.powi(k as i32);
        let got = mean_probe_irradiance(gpu, app);
        assert!((got - expected).abs() < 0.01 * before, "{what}{k} frames after: {got}, formula {expected}");
    }
}

#[test]
fn hysteresis_zero_takes_the_new_value_and_decay_follows_the_formula() {
    let Some(gpu) = gpu("hysteresis_zero_takes_the_new_value") else { return };
    let (_, mut app) = run_ddgi(&gpu, emitting_room(), emitting_room_volume(0.0), 8, 3);
    let full = std::f32::consts::PI * EMITTING_ROOM_LE;
    let settled = mean_probe_irradiance(&gpu, &app);
    assert!((settled - full).abs() < 0.01 * full, "hysteresis 0: {settled} vs {full}");
    switch_emission_off(&mut app);
    run_headless(&mut app, 1);
    let after = mean_probe_irradiance(&gpu, &app);
    assert!(after < 1e-3 * full, "hysteresis 0 drops to zero at once: {after}");

    // With hysteresis h, k frames after the switch the irradiance is h^k of its value.
    let h = 0.9f32;
    let (_, mut app) = run_ddgi(&gpu, emitting_room(), emitting_room_volume(h), 8, 3);
    let before = mean_probe_irradiance(&gpu, &app);
    assert!((before - full).abs() < 0.01 * full, "settled at {before}");
    assert_decay_after_emission_off(&gpu, &mut app, before, h, "");
}

#[test]
fn a_probe_with_fewer_rays_blends_by_the_hysteresis_exponent() {
    let Some(gpu) = gpu("hysteresis_exponent") else { return };
    // The room of the test above, its probes pinned active at a quarter of the rays (no resting):
    // with adaptive budgets each update blends by 1 − (1 − h) · (1/4)^hysteresis_exponent, so k
    // frames after the emission goes off the irradiance is that to the k of its value.
    let (h, pinned) = (0.9f32, 16u32);
    for exponent in [1.0f32, 0.5, 0.0] {
        let adaptive = ddgi::DdgiAdaptive { hysteresis_exponent: exponent, max_rest_frames: 1, ..ddgi::DdgiAdaptive::on() };
        let volume = DdgiVolume { adaptive, ..emitting_room_volume(h) };
        let rays = volume.rays_per_probe;
        let (_, mut app) = run_ddgi(&gpu, emitting_room(), volume, 8, 1);
        let world = app.world_mut();
        let probes: Vec<bevy_ecs::entity::Entity> =
            world.query_filtered::<bevy_ecs::entity::Entity, bevy_ecs::query::With<DdgiProbe>>().iter(world).collect();
        for entity in probes {
            world.entity_mut(entity).insert(ddgi::DdgiProbePin { rays: Some(pinned), state: Some(DdgiProbeState::Active) });
        }
        run_headless(&mut app, 4);
        let before = mean_probe_irradiance(&gpu, &app);
        let full = std::f32::consts::PI * EMITTING_ROOM_LE;
        assert!((before - full).abs() < 0.01 * full, "exponent {exponent}: settled at {before}");
        let rate = 1.0 - (1.0 - h) * (pinned as f32 / rays as f32).powf(exponent);
        assert_decay_after_emission_off(&gpu, &mut app, before, rate, &format!("exponent {exponent}, "));
    }
}

/// 3×2×3 probes of 64 rays over `lo..hi` with hysteresis `h`, adaptive budgets that neither rest
/// nor skip updates (every probe blends every frame), and the given `drift_rate`.
fn every_frame_volume(lo: Vec3, hi: Vec3, h: f32, drift_rate: f32) -> DdgiVolume {
    DdgiVolume {
        bounds: Some((lo.into(), hi.into())),
        probe_counts: Some(UVec3::new(3, 2, 3)),
        rays_per_probe: 64,
        hysteresis: h,
        firefly_threshold: 0.0,
        adaptive: ddgi::DdgiAdaptive { max_rest_frames: 1, max_update_period: 1, drift_rate, ..ddgi::DdgiAdaptive::on() },
        ..Default::default()
    }
}

#[test]
fn a_drifting_probe_blends_faster_and_noise_does_not_make_it() {
    let Some(gpu) = gpu("a_drifting_probe_blends_faster") else { return };
    // Light building up over bounces: a closed room of albedo ρ that emits Le everywhere. Every
    // ray sees the same radiance (no noise), and each update adds a bounce, so the probes' maps
    // move the same way update after update towards E = π Le / (1 − ρ): at hysteresis h the gap
    // shrinks by 1 − (1 − h)(1 − ρ) a frame (0.99 here), by 1 − 4 (1 − h)(1 − ρ) (0.96) at a drift
    // rate of 4.
    let (albedo, emission) = (0.8f32, 0.3f32);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.5), Vec3::new(1.0, 1.5, 1.5));
    let material = Material { base_color: Vec3::splat(albedo).extend(1.0), emissive: Vec3::splat(emission), ..Default::default() };
    let expected = std::f32::consts::PI * emission / (1.0 - albedo);
    let gap = |drift_rate: f32, frames: u32| {
        let (_, app) = run_ddgi(&gpu, closed_room(lo, hi, 0.2, material.clone()), every_frame_volume(lo, hi, 0.95, drift_rate), 8, frames);
        (expected - mean_probe_irradiance(&gpu, &app)) / expected
    };
    let (usual, drifting) = (gap(1.0, 60), gap(4.0, 60));
    eprintln!("gap to the converged irradiance after 60 frames: {usual:.4} at drift rate 1, {drifting:.4} at 4");
    assert!(usual > 0.05, "the room converged too fast to tell: gap {usual}");
    assert!(drifting.abs() < 0.5 * usual, "a drift rate of 4 left a gap of {drifting}, 1 left {usual}");
    // Faster, not elsewhere: the drifting probes settle on the same irradiance.
    let settled = gap(4.0, 240);
    assert!(settled.abs() < 0.02, "at a drift rate of 4 the probes settled {settled} of the way off {expected}");

    // Noise: a grey room lit by a point light, its probes' estimates noisy (16 rays each) around
    // light that has converged. Noise is zero-mean, so the slow average keeps little of it and the
    // drift rate must not speed the blending up: the maps flicker about as much as without it
    // (lavapipe: 1.33× as much; 4.24× with every probe blending at 4× the rate).
    let grey = Material { base_color: Vec3::splat(0.5).extend(1.0), ..Default::default() };
    let flicker = |drift_rate: f32| {
        let mut scene = closed_room(lo, hi, 0.2, grey.clone());
        let light = engine::scene::PointLight { color: Vec3::ONE, intensity: 2.0, range: None };
        scene.add_node("light", Transform::from_xyz(0.6, 1.2, 1.0), None, vec![NodeContent::PointLight(light)]);
        let volume = DdgiVolume { rays_per_probe: 16, ..every_frame_volume(lo, hi, 0.9, drift_rate) };
        let (_, mut app) = run_ddgi(&gpu, scene, volume, 8, 150);
        let probe_means = |app: &bevy_app::App| {
            let v = first_volume(app);
            let atlas = read_irradiance(&gpu, v);
            (0..v.layout.probe_count).map(|p| probe_mean_irradiance(&atlas, v, p)).collect::<Vec<Vec3>>()
        };
        let (mut previous, mut change, mut level) = (probe_means(&app), 0.0f32, 0.0f32);
        for _ in 0..30 {
            run_headless(&mut app, 1);
            let now = probe_means(&app);
            change += now.iter().zip(&previous).map(|(a, b)| (*a - *b).abs().element_sum()).sum::<f32>();
            level += now.iter().map(|a| a.element_sum()).sum::<f32>();
            previous = now;
        }
        change / level.max(1e-30)
    };
    let (usual, drifting) = (flicker(1.0), flicker(4.0));
    eprintln!("relative change of the probes per frame, converged and noisy: {usual:.5} at drift rate 1, {drifting:.5} at 4");
    assert!(usual > 0.0, "the probes did not change at all: nothing was measured");
    assert!(drifting < 1.5 * usual, "noise made the probes blend faster: flicker {drifting} at a drift rate of 4, {usual} at 1");
}

fn switch_emission_off(app: &mut bevy_app::App) {
    let mut materials = app.world_mut().resource_mut::<Assets<Material>>();
    let handles: Vec<_> = materials.iter().map(|(h, _)| h).collect();
    for h in handles {
        materials.get_mut(h).expect("material").emissive = Vec3::ZERO;
    }
}

#[test]
fn atlases_stay_finite_over_hundreds_of_frames_with_a_moving_light() {
    let Some(gpu) = gpu("atlases_stay_finite_over_hundreds_of_frames") else { return };
    let scene = (scenes::find("color_bleed").expect("color_bleed").build)();
    let volume = DdgiVolume {
        bounds: scenes::find("color_bleed").expect("built-in scene").gi_box(),
        probe_counts: Some(UVec3::new(4, 3, 4)),
        rays_per_probe: 32,
        ..Default::default()
    };
    let (frame, app) = run_ddgi(&gpu, scene, volume, 16, 300);
    assert!(frame.hdr.iter().all(|v| v.is_finite()), "non-finite pixel");
    assert_finite_atlases(&gpu, first_volume(&app), "color_bleed after 300 frames");
}

#[test]
fn probes_are_entities_that_mirror_relocation_and_classification() {
    let Some(gpu) = gpu("probes_are_entities") else { return };
    // The scene's own bounds include the 0.2 m walls; at 0.37 m spacing the outer probes of this
    // grid sit inside them.
    let scene = (scenes::find("color_bleed").expect("color_bleed").build)();
    let volume = DdgiVolume { probe_counts: Some(UVec3::new(12, 8, 12)), rays_per_probe: 32, ..Default::default() };
    let (_, mut app) = run_ddgi(&gpu, scene, volume, 16, 12);
    let world = app.world_mut();
    let probes: Vec<DdgiProbe> = world.query::<&DdgiProbe>().iter(world).cloned().collect();
    assert_eq!(probes.len(), 12 * 8 * 12);
    let inactive = probes.iter().filter(|p| p.state == DdgiProbeState::Inactive).count();
    let moved = probes.iter().filter(|p| p.offset != Vec3::ZERO).count();
    assert!(inactive > 0 && inactive < probes.len(), "{inactive} of {} probes switched off", probes.len());
    assert!(probes.iter().filter(|p| p.state == DdgiProbeState::Inactive).all(|p| p.ray_count == 0));
    assert!(moved > 0, "relocation moved no probe");
    for p in &probes {
        let spacing = first_volume(&app).layout.spacing;
        assert!((p.offset / spacing).length() < 0.45 + 1e-4, "probe {} moved {} (cell {spacing})", p.index, p.offset);
    }
}

/// Mean of the linear luminance over the `half`-pixel square around the image centre.
fn centre_luminance(hdr: &[f32], size: u32, half: u32) -> f32 {
    let mut sum = 0.0;
    let mut count = 0;
    for y in size / 2 - half..size / 2 + half {
        for x in size / 2 - half..size / 2 + half {
            let p = &hdr[((y * size + x) * 4) as usize..][..3];
            sum += 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            count += 1;
        }
    }
    sum / count as f32
}

/// DDGI with the paper's settings for `scene` against a stored path-traced reference: its mean
/// FLIP, the mean FLIP of direct light alone (the error DDGI is there to remove), the DDGI image
/// and the reference.
fn against_reference(gpu: &GpuContext, scene: &str, probes: UVec3, frames: u32) -> (f32, f32, RenderedFrame, image::RgbaImage) {
    let description = (scenes::find(scene).expect("scene").build)();
    let volume = DdgiVolume {
        bounds: scenes::find(scene).expect("built-in scene").gi_box(),
        probe_counts: Some(probes),
        rays_per_probe: 128,
        ..Default::default()
    };
    let settings = HeadlessSettings { width: REFERENCE_SIZE, height: REFERENCE_SIZE, frames, ..Default::default() };
    let frame = render_scene_and_inspect(gpu, description.clone(), &settings, |app| use_ddgi(app, volume, DdgiOutput::Full), |_| {})
        .expect("render");
    assert!(frame.hdr.iter().all(|v| v.is_finite()));
    let direct = engine::headless::render_scene(gpu, description, &HeadlessSettings { frames: 1, ..settings }).expect("render");
    let reference = path_traced_reference(gpu, scene, REFERENCE_SIZE);
    let flip = mean_flip(reference.as_raw(), &frame.ldr, REFERENCE_SIZE, REFERENCE_SIZE);
    let direct_flip = mean_flip(reference.as_raw(), &direct.ldr, REFERENCE_SIZE, REFERENCE_SIZE);
    if std::env::var("DDGI_WRITE_ACTUAL").is_ok() {
        let actual = testkit::golden_dir().join(format!("{scene}_ddgi_actual.png"));
        image::save_buffer(&actual, &frame.ldr, REFERENCE_SIZE, REFERENCE_SIZE, image::ExtendedColorType::Rgba8).expect("write");
    }
    eprintln!("{scene}: mean FLIP against the path-traced reference: DDGI {flip:.4}, direct light alone {direct_flip:.4}");
    (flip, direct_flip, frame, reference)
}

const REFERENCE_SIZE: u32 = 96;

#[test]
fn cornell_box_matches_the_path_traced_reference() {
    let Some(gpu) = gpu("cornell_box_matches_the_path_traced_reference") else { return };
    let (flip, direct, _, _) = against_reference(&gpu, "cornell", UVec3::new(6, 6, 6), 100);
    assert!(flip < CORNELL_FLIP_BOUND, "mean FLIP {flip} ≥ {CORNELL_FLIP_BOUND}");
    assert!(flip < 0.75 * direct, "DDGI ({flip}) must remove a quarter of direct light's error ({direct}) at least");
}

/// Bounds on the mean FLIP against 4096-path-per-pixel references (whose own noise is far below
/// these), measured on lavapipe on 2026-11-30: `cornell` DDGI 0.178 where direct light alone scores
/// 0.509. The bound leaves 10% for drivers' float differences; what DDGI cannot represent (contact
/// shadows finer than the probe spacing) makes up most of what remains. `door_room`: DDGI 0.072,
/// direct light alone 0.217.
const CORNELL_FLIP_BOUND: f32 = 0.2;
const DOOR_ROOM_FLIP_BOUND: f32 = 0.08;

#[test]
fn door_room_matches_the_reference_and_its_dark_corner_does_not_leak() {
    let Some(gpu) = gpu("door_room_matches_the_reference") else { return };
    let (flip, direct, frame, reference) = against_reference(&gpu, "door_room", UVec3::new(16, 8, 16), 100);
    assert!(flip < 0.75 * direct, "DDGI ({flip}) must remove a quarter of direct light's error ({direct}) at least");
    // The camera looks at the interior corner through the door: it is the centre of the image.
    let ddgi = centre_luminance(&frame.hdr, REFERENCE_SIZE, 3);
    // The reference PNG holds exposure × radiance (the camera's exposure is 1.5).
    let expected = centre_luminance(&linear_reference(&reference), REFERENCE_SIZE, 3) / 1.5;
    eprintln!("door_room: mean FLIP {flip:.4}; interior corner luminance DDGI {ddgi:.4}, reference {expected:.4}");
    assert!(flip < DOOR_ROOM_FLIP_BOUND, "mean FLIP {flip} ≥ {DOOR_ROOM_FLIP_BOUND}");
    // Light leaking through the walls would brighten the corner; over-eager visibility weights
    // would black it out. Measured: 0.0100 against 0.0150.
    assert!(ddgi < 1.5 * expected, "the dark corner leaks: {ddgi} against {expected}");
    assert!(ddgi > 0.5 * expected, "the dark corner lost its indirect light: {ddgi} against {expected}");
}

/// The thin-walled door room (walls 1/25 of the fitted spacing, one volume over the whole 40 m
/// scene) at three grids whose dark region was 2.6–4.2× too bright when the normal and view biases
/// were shares of the smallest spacing (`eval --grid-sweep`, lavapipe, 2026-12-06: 32×8×32 3.82,
/// 16×16×16 4.22, 12×6×12 2.62; after 1.52, 2.39, 2.08): the probes just outside the walls passed
/// the visibility test. Each grid with the bound on the dark corner's luminance (the image's
/// centre) over the reference's. The corner measured so (lavapipe, 2026-12-06, against a 1,024-spp
/// reference): 16×8×16 9.22× before the change, 3.11× after; after it 32×8×32 1.76×, 12×6×12
/// 2.47×; by this test (its 4,096-spp reference) 32×8×32 1.69×, 16×16×16 2.93×. What is left is
/// no leak: the probes nearest the corner inside the room are 1.3–1.65 m from it, and the corner
/// takes their light (15×8×15, 0.23 m from it: 1.29×).
const THIN_WALL_GRIDS: [([u32; 3], f32); 3] = [([32, 8, 32], 2.2), ([16, 16, 16], 4.0), ([12, 6, 12], 3.0)];

#[test]
fn thin_walls_do_not_leak_at_grids_that_did() {
    let Some(gpu) = gpu("thin_walls_do_not_leak_at_grids_that_did") else { return };
    for (grid, bound) in THIN_WALL_GRIDS {
        let (flip, _, frame, reference) = against_reference(&gpu, "door_room_thin", UVec3::from(grid), 240);
        let ddgi = centre_luminance(&frame.hdr, REFERENCE_SIZE, 3);
        let expected = centre_luminance(&linear_reference(&reference), REFERENCE_SIZE, 3) / 1.5;
        let ratio = ddgi / expected;
        eprintln!("door_room_thin at {grid:?}: mean FLIP {flip:.4}; dark corner {ddgi:.4} against {expected:.4} ({ratio:.2}×)");
        assert!(ratio < bound, "{grid:?}: the dark corner leaks: {ratio:.2}× the reference's (bound {bound})");
        assert!(ratio > 0.6, "{grid:?}: the dark corner lost its indirect light: {ratio:.2}× the reference's");
    }
}

/// A reference PNG (sRGB of exposure × radiance) as linear RGBA.
fn linear_reference(reference: &image::RgbaImage) -> Vec<f32> {
    use engine::color::srgb8_to_linear;
    reference.as_raw().chunks_exact(4).flat_map(|p| [srgb8_to_linear(p[0]), srgb8_to_linear(p[1]), srgb8_to_linear(p[2]), 1.0]).collect()
}

#[test]
fn two_volumes_light_the_scene_like_one() {
    let Some(gpu) = gpu("two_volumes_light_the_scene_like_one") else { return };
    let scene = || (scenes::find("cornell").expect("cornell").build)();
    let (lo, hi) = scenes::find("cornell").expect("built-in scene").gi_box().expect("bounds");
    let base = DdgiVolume { probe_counts: Some(UVec3::new(4, 4, 4)), rays_per_probe: 64, ..Default::default() };
    let one = render_scene_and_inspect(
        &gpu,
        scene(),
        &HeadlessSettings { width: 48, height: 48, frames: 40, ..Default::default() },
        |app| use_ddgi(app, DdgiVolume { bounds: Some((lo, hi)), ..base.clone() }, DdgiOutput::Indirect),
        |_| {},
    )
    .expect("render");
    let mid = (lo.x + hi.x) * 0.5;
    let two = render_scene_and_inspect(
        &gpu,
        scene(),
        &HeadlessSettings { width: 48, height: 48, frames: 40, ..Default::default() },
        |app| {
            let half = UVec3::new(2, 4, 4);
            use_ddgi(
                app,
                DdgiVolume { bounds: Some((lo, DVec3::new(mid, hi.y, hi.z))), probe_counts: Some(half), ..base.clone() },
                DdgiOutput::Indirect,
            );
            app.world_mut().spawn(DdgiVolume { bounds: Some((DVec3::new(mid, lo.y, lo.z), hi)), probe_counts: Some(half), ..base.clone() });
        },
        |world| assert_eq!(world.resource::<DdgiGpuVolumes>().volumes.len(), 2),
    )
    .expect("render");
    let flip = mean_flip(&one.ldr, &two.ldr, 48, 48);
    // Both volumes trace in the one trace pass (their rays counted apart).
    assert!(two.timings.last().expect("timings").passes.iter().any(|p| p.label == "ddgi_trace" && p.ran));
    for k in 0..2 {
        let name = format!("ddgi_rays_{k}");
        assert!(two.timings.iter().any(|t| t.counters.iter().any(|(n, v)| *n == name && *v > 0.0)), "volume {k} traced no rays");
    }
    assert!(flip < 0.12, "two half volumes differ from one whole volume by FLIP {flip}");
}

// ---------------------------------------------------------------------------------------------
// Adaptive ray budgets

/// The CPU mirror of `ddgi_smape_ycocg`.
fn smape_ycocg(a: Vec3, b: Vec3, floor: f32) -> f32 {
    let ycocg = |c: Vec3| Vec3::new(0.25 * c.x + 0.5 * c.y + 0.25 * c.z, 0.5 * c.x - 0.5 * c.z, -0.25 * c.x + 0.5 * c.y - 0.25 * c.z);
    let (x, y) = (ycocg(a), ycocg(b));
    let e = (x - y).abs() / ((x.abs() + y.abs()) * 0.5 + Vec3::splat(floor) + Vec3::splat(1e-30));
    e.dot(Vec3::new(0.5, 0.25, 0.25)).clamp(0.0, 2.0)
}

#[test]
fn smape_in_ycocg_is_zero_for_equal_colours_symmetric_and_bounded_near_black() {
    let Some(gpu) = gpu("smape_in_ycocg") else { return };
    let floor = 1e-3;
    let mut rng = engine::rng::SplitMix64::new(3);
    let mut pairs: Vec<(Vec3, Vec3, f32)> = vec![
        (Vec3::new(0.3, 0.2, 0.9), Vec3::new(0.3, 0.2, 0.9), floor),
        (Vec3::ONE, Vec3::splat(0.5), 0.0),
        (Vec3::ZERO, Vec3::splat(1e-7), floor),
        (Vec3::ZERO, Vec3::ZERO, 0.0),
        (Vec3::new(5.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 5.0), floor),
    ];
    for _ in 0..200 {
        let mut c = || Vec3::new(rng.unit(), rng.unit(), rng.unit()) * 10f32.powf(rng.range(-4.0, 3.0));
        let (a, b) = (c(), c());
        pairs.push((a, b, floor));
        pairs.push((b, a, floor));
    }
    let input: Vec<[f32; 4]> = pairs.iter().flat_map(|(a, b, f)| [a.extend(*f).to_array(), b.extend(0.0).to_array()]).collect();
    let out = run_selftest(&gpu, "smape_pairs", &input);
    let gpu_values: Vec<f32> = out.iter().take(pairs.len()).map(|o| o[0]).collect();
    for ((a, b, f), g) in pairs.iter().zip(&gpu_values) {
        let cpu = smape_ycocg(*a, *b, *f);
        assert!((g - cpu).abs() <= 1e-5 + 1e-4 * cpu, "SMAPE({a}, {b}): GPU {g}, CPU {cpu}");
        assert!((0.0..=2.0).contains(g), "SMAPE({a}, {b}) = {g} outside [0, 2]");
    }
    assert_eq!(gpu_values[0], 0.0, "identical colours");
    // Grey 1 against grey 0.5: luma differs by 0.5 over a mean of 0.75, chroma is zero.
    assert!((gpu_values[1] - 0.5 * 0.5 / 0.75).abs() < 1e-6, "{}", gpu_values[1]);
    assert!(gpu_values[2] < 1e-3, "near black, the floor keeps the ratio small: {}", gpu_values[2]);
    assert_eq!(gpu_values[3], 0.0, "black against black");
    for k in 0..200 {
        let (ab, ba) = (gpu_values[5 + 2 * k], gpu_values[6 + 2 * k]);
        assert!((ab - ba).abs() <= 1e-6 * ab.max(1.0), "not symmetric: {ab} vs {ba}");
    }
}

/// The slow error average is stored as bfloat16: a round trip keeps the sign and 8 significant
/// bits (relative error at most 2⁻⁸, rounded), keeps zero, clamps beyond 1e30 and turns NaN to 0.
#[test]
fn bfloat16_packing_of_the_slow_error_average_round_trips() {
    let Some(gpu) = gpu("bf16_round_trip") else { return };
    let mut rng = engine::rng::SplitMix64::new(5);
    let mut values: Vec<[f32; 2]> = vec![[0.0, -0.0], [1.0, -1.0], [1e-30, 3.0e38], [f32::NAN, f32::INFINITY], [65504.0, -1e-3]];
    for _ in 0..300 {
        let mut v = || (rng.unit() - 0.5) * 10f32.powf(rng.range(-20.0, 20.0));
        values.push([v(), v()]);
    }
    let input: Vec<[f32; 4]> = values.iter().map(|v| [v[0], v[1], 0.0, 0.0]).collect();
    let out = run_selftest(&gpu, "bf16_round_trip", &input);
    for (v, o) in values.iter().zip(&out) {
        for k in 0..2 {
            let (x, y) = (v[k], o[k]);
            let expected = if x.is_nan() { 0.0 } else { x.clamp(-1e30, 1e30) };
            assert!(y.is_finite(), "{x} came back as {y}");
            assert!((y - expected).abs() <= expected.abs() * 2f32.powi(-8), "{x}: {y}, expected {expected} within 2^-8");
            assert!(expected == 0.0 || y.signum() == expected.signum(), "{x}: sign lost ({y})");
        }
    }
}

/// A per-frame counter of the frame timings (read back asynchronously: `ddgi_rays`,
/// `ddgi_probes_updated`) over the last `n` frames that have it.
fn last_counts(app: &bevy_app::App, counter: &str, n: usize) -> Vec<f64> {
    let counts = app.world().resource::<engine::render::FrameTimings>().counter(counter);
    counts.iter().rev().take(n).map(|(_, v)| *v).collect()
}

/// Rays traced per frame of the last `n` frames that have a count.
fn last_ray_counts(app: &bevy_app::App, n: usize) -> Vec<f64> {
    last_counts(app, "ddgi_rays", n)
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

#[test]
fn adaptive_budgets_trace_fewer_rays_in_a_static_scene_at_the_same_error() {
    let Some(gpu) = gpu("adaptive_budgets_trace_fewer_rays") else { return };
    let reference = path_traced_reference(&gpu, "cornell", REFERENCE_SIZE);
    // The per-probe budgets alone (the volume updating every frame), resting decided by the
    // error itself and by the settled error, then the defaults (the settled error and the calm
    // update period).
    let run = |adaptive: bool, rest_smoothing: Option<f32>, max_update_period: u32| {
        let volume = DdgiVolume {
            bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
            probe_counts: Some(UVec3::new(6, 6, 6)),
            rays_per_probe: 128,
            adaptive: ddgi::DdgiAdaptive { enabled: adaptive, rest_smoothing, max_update_period, ..Default::default() },
            ..Default::default()
        };
        let settings = HeadlessSettings { width: REFERENCE_SIZE, height: REFERENCE_SIZE, frames: 200, ..Default::default() };
        let scene = (scenes::find("cornell").expect("cornell").build)();
        let frame =
            render_scene_and_inspect(&gpu, scene, &settings, |app| use_ddgi(app, volume, DdgiOutput::Full), |_| {}).expect("render");
        assert!(frame.hdr.iter().all(|v| v.is_finite()));
        let rays: Vec<f64> = frame
            .timings
            .iter()
            .rev()
            .filter_map(|f| f.counters.iter().find(|(n, _)| n == "ddgi_rays").map(|(_, v)| *v))
            .take(20)
            .collect();
        assert!(!rays.is_empty(), "rays per frame were read back");
        (mean_flip(reference.as_raw(), &frame.ldr, REFERENCE_SIZE, REFERENCE_SIZE), mean(&rays))
    };
    let (fixed_flip, fixed_rays) = run(false, None, 1);
    let (adaptive_flip, adaptive_rays) = run(true, None, 1);
    let (settled_flip, settled_rays) = run(true, Some(0.97), 1);
    let defaults = ddgi::DdgiAdaptive::default();
    let (calm_flip, calm_rays) = run(true, defaults.rest_smoothing, defaults.max_update_period);
    eprintln!(
        "static cornell: fixed {fixed_rays:.0} rays per frame, FLIP {fixed_flip:.4}; adaptive {adaptive_rays:.0}, FLIP {adaptive_flip:.4}"
    );
    // Measured on lavapipe (2026-11-30): 26,630 rays and FLIP 0.1496 fixed, 8,746 and 0.1534
    // adaptive with quiet probes resting (defaults; 13,705 and 0.1492 before they rested). The
    // error lost grows as the budget shrinks (rest_error 0.5 gave 5,685 rays and FLIP 0.1567), so
    // the bound on it is what the defaults are for. 2026-12-01: 26,630 / 0.1556 fixed, 6,591 /
    // 0.1566 adaptive, 3,797 / 0.1539 with rest_smoothing 0.97.
    assert!(adaptive_rays < 0.5 * fixed_rays, "adaptive budgets traced {adaptive_rays} rays per frame against {fixed_rays}");
    // The rays it saved did not cost the image (no black holes where probes were switched off).
    assert!(adaptive_flip <= 1.05 * fixed_flip + 0.005, "FLIP against the reference: adaptive {adaptive_flip}, fixed {fixed_flip}");
    // Resting decided by the settled error (a slower average, less noise in it): fewer rays still,
    // at the same bound on the error.
    eprintln!("static cornell, rest_smoothing 0.97: {settled_rays:.0} rays per frame, FLIP {settled_flip:.4}");
    assert!(settled_rays < adaptive_rays, "rest_smoothing 0.97 traced {settled_rays} rays per frame against {adaptive_rays}");
    assert!(
        settled_flip <= 1.05 * fixed_flip + 0.005,
        "FLIP against the reference: rest_smoothing 0.97 {settled_flip}, fixed {fixed_flip}"
    );
    // The defaults: a calm volume updates every few frames (frames left out count 0 rays), at the
    // same bound on the error.
    eprintln!("static cornell, defaults (calm update period): {calm_rays:.0} rays per frame, FLIP {calm_flip:.4}");
    assert!(calm_rays < settled_rays, "the calm update period traced {calm_rays} rays per frame against {settled_rays}");
    assert!(calm_flip <= 1.05 * fixed_flip + 0.005, "FLIP against the reference: calm update period {calm_flip}, fixed {fixed_flip}");
}

#[test]
fn switching_a_light_on_raises_the_rays_within_a_few_frames() {
    let Some(gpu) = gpu("switching_a_light_on_raises_the_rays") else { return };
    // The Cornell box in the dark: its lamp's light off and its panel not glowing. Every probe
    // sees black, its error is zero and it drops to the fewest rays.
    let mut scene = (scenes::find("cornell").expect("cornell").build)();
    let mut intensity = 0.0;
    for node in &mut scene.nodes {
        for c in &mut node.content {
            if let NodeContent::PointLight(light) = c {
                intensity = light.intensity;
                light.intensity = 0.0;
            }
        }
    }
    for m in &mut scene.materials {
        m.emissive = Vec3::ZERO;
    }
    let volume = DdgiVolume {
        bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
        probe_counts: Some(UVec3::new(6, 6, 6)),
        adaptive: ddgi::DdgiAdaptive::on(),
        ..Default::default()
    };
    let (_, mut app) = run_ddgi(&gpu, scene, volume, 16, 120);
    let settled = mean(&last_ray_counts(&app, 10));
    assert!(settled > 0.0, "rays per frame were read back");
    {
        let world = app.world_mut();
        let mut lights = world.query::<&mut engine::scene::PointLight>();
        for mut light in lights.iter_mut(world) {
            light.intensity = intensity;
        }
    }
    run_headless(&mut app, 8);
    let after = last_ray_counts(&app, 6);
    let peak = after.iter().cloned().fold(0.0, f64::max);
    eprintln!("rays per frame: settled {settled:.0}, after the light came on {after:?}");
    assert!(peak > 3.0 * settled, "the rays did not follow the light: settled {settled}, then {after:?}");
}

#[test]
fn a_change_of_light_wakes_every_resting_probe_on_its_frame() {
    let Some(gpu) = gpu("a_change_of_light_wakes_every_resting_probe") else { return };
    // The lit Cornell box, still, with long rests (and no calm periods, so that every frame
    // updates): most probes come to rest.
    let counts = UVec3::new(6, 6, 6);
    let volume = DdgiVolume {
        bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
        probe_counts: Some(counts),
        adaptive: ddgi::DdgiAdaptive { max_rest_frames: 64, max_update_period: 1, ..ddgi::DdgiAdaptive::on() },
        ..Default::default()
    };
    let (_, mut app) = run_ddgi(&gpu, (scenes::find("cornell").expect("cornell").build)(), volume, 16, 240);
    let probes = |app: &bevy_app::App| -> Vec<ddgi::gpu::DdgiProbeData> {
        let bytes = engine::gpu::readback::read_buffer(&gpu, &first_volume(app).probes);
        bytemuck::pod_collect_to_vec(&bytes[..counts.element_product() as usize * size_of::<ddgi::gpu::DdgiProbeData>()])
    };
    let active = |p: &&ddgi::gpu::DdgiProbeData| p.state & ddgi::gpu::PROBE_INACTIVE == 0;
    let before = probes(&app);
    let resting = before.iter().filter(active).filter(|p| p.ray_count == 0).count();
    assert!(resting > 0, "no active probe rested before the change");
    // The lamp dims: light changes everywhere, and the frame that sees it traces every active
    // probe, however long its rest had left to run.
    {
        let world = app.world_mut();
        let mut lights = world.query::<&mut engine::scene::PointLight>();
        for mut light in lights.iter_mut(world) {
            light.intensity *= 0.5;
        }
    }
    run_headless(&mut app, 1);
    let after = probes(&app);
    let asleep = after.iter().filter(active).filter(|p| p.ray_count == 0).count();
    eprintln!("active probes without rays: {resting} before the change, {asleep} on its frame");
    assert_eq!(asleep, 0, "{asleep} active probes slept through the change of light");
}

/// A closed room (interior −1.5…1.5 × 0…3 × −1.5…1.5) with a doorway in its +Z wall closed by a
/// door of its own, and a sun outside shining in through the doorway when the door is open.
fn room_with_door() -> SceneDescription {
    let mut s = SceneDescription { name: "room_with_door".into(), ..Default::default() };
    let (lo, hi, t) = (Vec3::new(-1.5, 0.0, -1.5), Vec3::new(1.5, 3.0, 1.5), 0.2);
    let (door_lo, door_hi) = (Vec3::new(-0.5, 0.0, hi.z), Vec3::new(0.5, 2.0, hi.z + t));
    let mut parts = Vec::new();
    for axis in 0..3 {
        for positive in [false, true] {
            let (mut a, mut b) = (lo - t, hi + t);
            if positive {
                a[axis] = hi[axis];
            } else {
                b[axis] = lo[axis];
            }
            if axis == 2 && positive {
                parts.extend(engine::shapes::box_with_hole(a, b, door_lo, door_hi));
            } else {
                parts.push(engine::shapes::box_part(a, b));
            }
        }
    }
    let white = s.add_material(Material::diffuse("white", Vec3::splat(0.7)));
    let room = s.add_mesh(engine::shapes::merge("room", &parts));
    s.add_node("room", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(room, white)])]);
    // The door overlaps the doorway's edges, so that no ray slips through a crack.
    let door = s.add_mesh(engine::shapes::cuboid("door", (door_hi - door_lo) * 0.5 + Vec3::new(0.1, 0.1, 0.0)));
    s.add_node("door", Transform::from_translation((door_lo + door_hi) * 0.5), None, vec![NodeContent::Meshes(vec![(door, white)])]);
    let ground = s.add_mesh(engine::shapes::quad("ground", glam::Vec2::splat(12.0)));
    s.add_node("ground", Transform::from_xyz(0.0, -0.2, 0.0), None, vec![NodeContent::Meshes(vec![(ground, white)])]);
    let sun = engine::scene::DirectionalLight { color: Vec3::ONE, intensity: 5.0 };
    let sun_transform = Transform::IDENTITY.looking_at(Vec3::new(0.0, -0.5, -1.0), Vec3::Y);
    s.add_node("sun", sun_transform, None, vec![NodeContent::DirectionalLight(sun)]);
    s
}

#[test]
fn dark_probes_switch_off_and_an_opening_door_wakes_them() {
    let Some(gpu) = gpu("dark_probes_switch_off_and_an_opening_door_wakes_them") else { return };
    // 1.2 m cells in x and z: the 2 × 2 × 2 probes at x, z = ±0.6 and y ≈ 1.2, 2.3 are inside the
    // room, the next ones at ±1.8 outside its walls. No probe lies on a wall's plane: one there (with 1 m
    // cells, on the door's inner face, coplanar with the wall's) is lit or not by a tie between
    // coplanar faces, which the BVH's traversal order decides.
    let volume = DdgiVolume {
        bounds: Some((DVec3::new(-3.6, -0.5, -3.6), DVec3::new(3.6, 4.0, 6.0))),
        probe_counts: Some(UVec3::new(6, 4, 8)),
        rays_per_probe: 64,
        // The walls are thin against the 1.2 m cells, so DDGI's own leaking lights the closed room
        // at about 1% of the sunlit probes' luma (measured with 1 m cells: 0.2–1%): call that dark here.
        adaptive: ddgi::DdgiAdaptive { dark_fraction: 0.02, ..ddgi::DdgiAdaptive::on() },
        ..Default::default()
    };
    let (_, mut app) = run_ddgi(&gpu, room_with_door(), volume, 16, 40);
    let inside = |app: &mut bevy_app::App| -> Vec<DdgiProbe> {
        let world = app.world_mut();
        world
            .query::<&DdgiProbe>()
            .iter(world)
            .filter(|p| p.position.x.abs() < 1.4 && p.position.z.abs() < 1.4 && p.position.y > 0.2 && p.position.y < 2.8)
            .cloned()
            .collect()
    };
    let before = inside(&mut app);
    assert_eq!(before.len(), 8, "{before:?}");

    // A probe may be awake for a few frames after a noisy re-check (16 rays) finds it lit.
    let asleep = before.iter().filter(|p| p.state == DdgiProbeState::Inactive).count();
    assert!(asleep >= 6, "the closed room's probes are dark, but only {asleep} of 8 are off: {before:?}");
    assert!(
        before.iter().filter(|p| p.state == DdgiProbeState::Inactive).all(|p| p.ray_count <= 16),
        "off probes trace at most the re-check rays"
    );
    // Open the door: move it out of the doorway.
    {
        let world = app.world_mut();
        let mut doors = world.query::<(&engine::scene::Name, &mut Transform)>();
        for (name, mut t) in doors.iter_mut(world) {
            if name.0 == "door" {
                t.translation.x += 3.0;
            }
        }
    }
    run_headless(&mut app, 12);
    let after = inside(&mut app);
    let awake = after.iter().filter(|p| p.state == DdgiProbeState::Active).count();
    assert!(awake >= 6, "only {awake} of 8 probes woke after the door opened: {after:?}");
}

#[test]
fn a_frame_budget_caps_the_rays_of_every_frame() {
    let Some(gpu) = gpu("a_frame_budget_caps_the_rays_of_every_frame") else { return };
    let budget = 6000u32;
    let volume = DdgiVolume {
        bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
        probe_counts: Some(UVec3::new(6, 6, 6)),
        rays_per_probe: 128,
        // Every frame updates (no calm period), so that every frame's rays are the budget's.
        adaptive: ddgi::DdgiAdaptive { frame_budget: Some(budget), max_update_period: 1, ..ddgi::DdgiAdaptive::on() },
        ..Default::default()
    };
    let (frame, app) = run_ddgi(&gpu, (scenes::find("cornell").expect("cornell").build)(), volume, 16, 30);
    assert!(frame.hdr.iter().all(|v| v.is_finite()));
    // The scale applies from the frame after the one that went over; each probe keeps a ray.
    let rays = last_ray_counts(&app, 20);
    assert!(rays.len() >= 15, "{rays:?}");
    let probes = 6.0 * 6.0 * 6.0;
    assert!(rays.iter().all(|&r| r <= f64::from(budget) + probes), "over the budget of {budget}: {rays:?}");
    assert!(rays.iter().all(|&r| r > 0.5 * f64::from(budget)), "the budget is used: {rays:?}");
}

/// The budget pass packs every probe's rays as a CPU prefix sum of its ray counts would, lists the
/// probes with rays in order and sizes the indirect dispatches from the totals — over several
/// blocks of its prefix sum, with a frame budget and without.
#[test]
fn the_budget_pass_packs_the_rays_as_a_cpu_prefix_sum() {
    let Some(gpu) = gpu("the_budget_pass_packs_the_rays_as_a_cpu_prefix_sum") else { return };
    use ddgi::gpu::{BUDGET_BLOCK, DdgiCounters, DdgiProbeData, RAY_GROUP};
    // 9 × 8 × 8 probes: three blocks, the last one partial.
    let counts = UVec3::new(9, 8, 8);
    let probe_count = counts.x * counts.y * counts.z;
    assert!(probe_count > 2 * BUDGET_BLOCK && !probe_count.is_multiple_of(BUDGET_BLOCK));
    for frame_budget in [None, Some(4000)] {
        let what = format!("frame budget {frame_budget:?}");
        let volume = DdgiVolume {
            bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
            probe_counts: Some(counts),
            rays_per_probe: 32,
            adaptive: ddgi::DdgiAdaptive { frame_budget, max_update_period: 1, min_rays: 4, ..ddgi::DdgiAdaptive::on() },
            ..Default::default()
        };
        let (_, app) = run_ddgi(&gpu, (scenes::find("cornell").expect("cornell").build)(), volume, 16, 8);
        let v = first_volume(&app);
        let read = |b: &engine::wgpu::Buffer| engine::gpu::readback::read_buffer(&gpu, b);
        let probes: Vec<DdgiProbeData> =
            bytemuck::pod_collect_to_vec(&read(&v.probes)[..probe_count as usize * size_of::<DdgiProbeData>()]);
        let updated: Vec<u32> = bytemuck::pod_collect_to_vec(&read(&v.updated));
        let counters: DdgiCounters = bytemuck::pod_read_unaligned(&read(&v.counters)[..size_of::<DdgiCounters>()]);
        let mut offset = 0u32;
        let mut listed = Vec::new();
        for (p, data) in probes.iter().enumerate() {
            assert_eq!(data.ray_offset, offset, "{what}: probe {p}'s ray offset");
            offset += data.ray_count;
            if data.ray_count > 0 {
                listed.push(p as u32);
            }
        }
        assert!(probes.iter().any(|d| d.ray_count != probes[0].ray_count), "{what}: every probe has {} rays", probes[0].ray_count);
        assert_eq!(counters.total_rays, offset, "{what}: total rays");
        assert_eq!(counters.updated_probes as usize, listed.len(), "{what}: probes with rays");
        assert_eq!(&updated[..listed.len()], &listed[..], "{what}: the list of probes with rays");
        assert_eq!(counters.dispatch, [offset.div_ceil(RAY_GROUP), 1, 1], "{what}: the trace's dispatch");
        assert_eq!(counters.probe_dispatch, [listed.len() as u32, 1, 1], "{what}: the per-probe passes' dispatch");
        assert!(counters.max_luma.is_finite() && counters.max_luma > 0.0, "{what}: the brightest probe's luma {}", counters.max_luma);
        if let Some(budget) = frame_budget {
            assert!(offset <= budget + probe_count, "{what}: {offset} rays over the budget");
            assert!(
                counters.budget_scale > 0.0 && counters.budget_scale < 1.0,
                "{what}: the budget cut nothing (scale {})",
                counters.budget_scale
            );
        }
    }
}

#[test]
fn quiet_probes_rest_and_the_per_probe_passes_skip_them() {
    let Some(gpu) = gpu("quiet_probes_rest") else { return };
    let volume = |max_rest_frames: u32| DdgiVolume {
        bounds: scenes::find("cornell").expect("built-in scene").gi_box(),
        probe_counts: Some(UVec3::new(6, 6, 6)),
        // Per-probe resting alone: the volume updates every frame.
        adaptive: ddgi::DdgiAdaptive { max_rest_frames, max_update_period: 1, ..ddgi::DdgiAdaptive::on() },
        ..Default::default()
    };
    let scene = || (scenes::find("cornell").expect("cornell").build)();
    // The same static scene, its probes resting or not.
    let (_, awake) = run_ddgi(&gpu, scene(), volume(1), 16, 240);
    let (_, mut resting) = run_ddgi(&gpu, scene(), volume(8), 16, 240);
    let (awake_rays, resting_rays) = (mean(&last_ray_counts(&awake, 20)), mean(&last_ray_counts(&resting, 20)));
    let world = resting.world_mut();
    let probes: Vec<DdgiProbe> = world.query::<&DdgiProbe>().iter(world).cloned().collect();
    let active = probes.iter().filter(|p| p.state == DdgiProbeState::Active).count();
    let at_rest: Vec<&DdgiProbe> = probes.iter().filter(|p| p.resting_frames > 0).collect();
    eprintln!(
        "static cornell, adaptive: {awake_rays:.0} rays per frame awake, {resting_rays:.0} resting ({active} probes active, {} at rest)",
        at_rest.len()
    );
    // The ECS shows which probes rest (all of them active), and some active probes traced nothing.
    assert!(!at_rest.is_empty(), "no DdgiProbe shows a rest");
    assert!(at_rest.iter().all(|p| p.state == DdgiProbeState::Active), "a switched-off probe shows a rest");
    assert!(probes.iter().any(|p| p.state == DdgiProbeState::Active && p.ray_count == 0), "no active probe rested in the frame read back");
    // Measured on lavapipe (2026-12-01): 12,204 rays per frame awake, 6,232 resting (12,575 and 7,241
    // at hysteresis exponent ½).
    assert!(resting_rays < 0.8 * awake_rays, "resting saved too little: {resting_rays} against {awake_rays}");
    // Some active probes rest this frame, and the per-probe passes run one workgroup per probe with
    // rays: fewer than the active probes.
    let v = first_volume(&resting);
    let counters: ddgi::gpu::DdgiCounters = bytemuck::pod_read_unaligned(&engine::gpu::readback::read_buffer(&gpu, &v.counters));
    assert!(counters.updated_probes < active as u32, "{} probes updated of {active} active", counters.updated_probes);
    assert_eq!(counters.probe_dispatch[0] * counters.probe_dispatch[1], counters.updated_probes, "one workgroup per updated probe");
    // The frame timings record the probes updated per frame: fewer when quiet probes rest.
    let updated = |app: &bevy_app::App| mean(&last_counts(app, "ddgi_probes_updated", 20));
    let (awake_probes, resting_probes) = (updated(&awake), updated(&resting));
    assert!(
        resting_probes > 0.0 && resting_probes < awake_probes,
        "probes updated per frame: {resting_probes} resting, {awake_probes} awake"
    );
    // Resting probes keep their maps and their weight: the image stays whole.
    assert_finite_atlases(&gpu, v, "resting");
    let frame = engine::headless::read_frame(&gpu, resting.world());
    assert!(frame.hdr.iter().all(|x| x.is_finite()));
}

// ---------------------------------------------------------------------------------------------
// Contact occlusion
// ---------------------------------------------------------------------------------------------

/// The open share of cosine-distributed rays of length `radius` from a point of a floor at
/// `distance` from a wall that rises from it without end: a ray at angle θ from the normal and φ
/// from the wall's direction reaches the wall's plane within `radius` when sin θ cos φ > a =
/// distance / radius. Cosine-distributed directions are uniform on the unit disc (sin θ cos φ is
/// the disc's x), so the blocked share is the disc's segment beyond x = a over its area.
fn open_share_beside_a_wall(distance: f32, radius: f32) -> f32 {
    let a = (distance / radius).clamp(0.0, 1.0);
    1.0 - (a.acos() - a * (1.0 - a * a).sqrt()) / std::f32::consts::PI
}

#[test]
fn contact_occlusion_is_one_on_an_open_floor_and_follows_the_analytic_share_beside_a_wall() {
    let Some(gpu) = gpu("contact_occlusion_follows_the_analytic_share") else { return };
    // A floor (y = 0, x from 0 to 8) and a wall rising 4 units along x = 0 (far higher and longer
    // than the radius), seen straight from above: each image column is one distance from the wall.
    let radius = 1.0;
    let mut scene = SceneDescription { name: "wall_floor".into(), ..Default::default() };
    let grey = scene.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    let floor = engine::shapes::cuboid("floor", Vec3::new(4.0, 0.05, 20.0));
    scene.add_mesh_node("floor", Transform::from_xyz(4.0, -0.05, 0.0), floor, grey);
    let wall = engine::shapes::cuboid("wall", Vec3::new(0.1, 2.05, 20.0));
    scene.add_mesh_node("wall", Transform::from_xyz(-0.1, 1.95, 0.0), wall, grey);
    let (height, half_width) = (10.0f32, 2.0f32);
    let yfov = 2.0 * (half_width / height).atan();
    let eye = Vec3::new(half_width, height, 0.0);
    let camera = Transform::from_translation(eye).looking_at(Vec3::new(half_width, 0.0, 0.0), Vec3::NEG_Z);
    scene.add_node("camera", camera, None, vec![NodeContent::Camera(engine::scene::Camera { yfov, znear: 0.1, exposure: 1.0 })]);
    let size = 64u32;
    let pixel_width = 2.0 * half_width / size as f32;
    // Every pixel traced, then one pixel of each 2×2 block brought back to all four by depth and
    // normal: within one pixel of the wall's reach the values come from pixels up to two pixels
    // away, so "exactly open" starts two pixels further out.
    for (half_resolution, exact_beyond) in [(false, radius), (true, radius + 2.0 * pixel_width)] {
        let volume = DdgiVolume { probe_counts: Some(UVec3::new(4, 2, 4)), ..Default::default() };
        let occlusion = ddgi::DdgiContactOcclusion { rays: 64, radius: Some(radius), half_resolution };
        let frame = render_scene_and_inspect(
            &gpu,
            scene.clone(),
            &HeadlessSettings { width: size, height: size, frames: 1, ..Default::default() },
            |app| {
                use_ddgi(app, volume, DdgiOutput::Occlusion);
                app.insert_resource(occlusion);
            },
            |_| {},
        )
        .expect("render");
        assert!(frame.hdr.iter().all(|v| v.is_finite()), "non-finite occlusion (half resolution: {half_resolution})");
        // At half resolution the rays are traced by a pass of their own, at full resolution by the
        // composite.
        let ran = |label: &str| frame.timings.last().expect("timings").passes.iter().any(|p| p.label == label && p.ran);
        assert_eq!(ran("ddgi_contact_occlusion"), half_resolution);
        assert!(ran("ddgi_composite"));
        // Column i sees the floor at x = (2 (i + 0.5) / size − 1) · half_width + half_width; the
        // mean over its rows averages the per-pixel rotations of the rays.
        let mut checked = 0;
        for i in 0..size {
            let x = (2.0 * (i as f32 + 0.5) / size as f32 - 1.0) * half_width + half_width;
            if x < 0.05 {
                continue;
            }
            let column: Vec<f32> = (0..size).map(|j| frame.hdr[((j * size + i) * 4) as usize]).collect();
            let mean = column.iter().sum::<f32>() / size as f32;
            let expected = open_share_beside_a_wall(x, radius);
            assert!(
                (mean - expected).abs() < 0.03,
                "{x:.3} from the wall (half resolution: {half_resolution}): occlusion {mean:.4}, analytic {expected:.4}"
            );
            if x > exact_beyond {
                // Beyond the radius nothing is in reach: open everywhere, exactly.
                assert!(column.iter().all(|&v| v == 1.0), "{x:.3} from the wall (half resolution: {half_resolution}): {column:?}");
            }
            checked += 1;
        }
        assert!(checked > size / 2, "too few columns on the floor: {checked}");
    }
}

/// The default grid (`probe_counts: None`) is fitted to the volume's box: 16 probes along its
/// longest side, in proportion along the others but at least 8 unless a side is thin (then 2);
/// the volume's layout takes it.
#[test]
fn the_default_grid_is_fitted_to_the_box() {
    for scene in ["door_room", "ceiling_opening", "cornell", "color_bleed"] {
        let (lo, hi) = (scenes::find(scene).expect("scene").gi_bounds)().expect("bounds");
        let (extent, grid) = (hi - lo, ddgi::auto_probe_counts(hi - lo));
        let spacing = extent / grid.as_vec3();
        assert_eq!(grid.max_element(), ddgi::AUTO_PROBES_LONGEST, "{scene}: {grid}");
        assert!(grid.min_element() >= ddgi::AUTO_PROBES_MIN, "{scene}: {grid} (no side of a room is thin)");
        // Cells no longer than the longest side's (the floor of 8 only makes them shorter).
        assert!(spacing.max_element() <= extent.max_element() / 16.0 * 1.1, "{scene}: {grid} over {extent}, cells {spacing}");
        let layout = ddgi::DdgiLayout::new(
            &DdgiVolume::default(),
            (lo, hi),
            ddgi::volume::DdgiLimits { max_texture_dimension: 8192, max_storage_buffer_bytes: 1 << 30 },
        )
        .expect("layout");
        assert_eq!(layout.counts, grid, "{scene}");
    }
    assert_eq!(ddgi::auto_probe_counts(Vec3::new(10.0, 0.0, 5.0)), UVec3::new(16, 2, 8), "a floor gets two layers");
    assert_eq!(ddgi::auto_probe_counts(Vec3::new(44.0, 7.0, 44.0)), UVec3::new(16, 8, 16), "the demo level's field");
    assert_eq!(ddgi::auto_probe_counts(Vec3::new(100.0, 5.0, 50.0)), UVec3::new(16, 2, 8), "a thin side: in proportion");
    assert_eq!(ddgi::auto_probe_counts(Vec3::splat(f32::NAN)), UVec3::splat(2));
    assert_eq!(ddgi::auto_probe_counts(Vec3::splat(3.0)), UVec3::splat(16));
}

/// The white furnace through the raster path: a white rough metal (and a white glossy dielectric)
/// box under a uniform white sky, lit only by it, through DDGI's probes and the specular lobe's
/// gather along the reflection: every pixel as bright as the sky (the box vanishes), as in the path
/// tracer (tests/pathtrace.rs) — metals are never black, and no lobe adds or loses energy.
#[test]
fn a_glossy_box_in_a_white_furnace_vanishes_into_the_sky() {
    let Some(gpu) = gpu("a_glossy_box_in_a_white_furnace_vanishes_into_the_sky") else { return };
    for (metallic, roughness) in [(1.0f32, 1.0f32), (1.0, 0.4), (0.0, 0.5)] {
        let mut s = engine::scene::SceneDescription { name: "furnace".into(), ..Default::default() };
        let cube = s.add_mesh(engine::shapes::cuboid("box", Vec3::splat(0.5)));
        let m = s.add_material(engine::scene::Material::pbr("white", Vec3::ONE, metallic, roughness));
        s.add_node("box", engine::scene::Transform::IDENTITY, None, vec![engine::scene::NodeContent::Meshes(vec![(cube, m)])]);
        let camera = engine::scene::Transform::from_xyz(1.6, 1.2, 2.0).looking_at(Vec3::ZERO, Vec3::Y);
        let lens = engine::scene::Camera { yfov: 0.6, ..Default::default() };
        s.add_node("camera", camera, None, vec![engine::scene::NodeContent::Camera(lens)]);
        // What is measured is the BRDF's energy, not how fast the budgets get there.
        let volume = DdgiVolume {
            bounds: Some((DVec3::splat(-1.5), DVec3::splat(1.5))),
            probe_counts: Some(UVec3::splat(4)),
            adaptive: ddgi::DdgiAdaptive::off(),
            ..Default::default()
        };
        let frame = engine::headless::render_scene_with(
            &gpu,
            s,
            &HeadlessSettings { width: 32, height: 32, frames: 60, ..Default::default() },
            |app| {
                app.insert_resource(engine::render::Sky::Uniform(Vec3::ONE));
                use_ddgi(app, volume, DdgiOutput::Full)
            },
        )
        .expect("render");
        let worst = frame.hdr.chunks_exact(4).map(|p| (p[0] - 1.0).abs().max((p[2] - 1.0).abs())).fold(0.0f32, f32::max);
        eprintln!("metallic {metallic}, roughness {roughness}: worst pixel off by {worst}");
        assert!(worst < 0.05, "metallic {metallic}, roughness {roughness}: a pixel off by {worst}");
    }
}

/// The persistent trace (`DdgiVolume::persistent_trace`: closest hits by persistent threads into
/// `ddgi_hits`, then the pass `ddgi_shade`) gives the same atlases, bit for bit, as the trace that
/// shades in the thread that traced: same rays, same hits, same shading. Adaptive budgets vary the
/// ray count from frame to frame, so the persistent workgroups' shares (from the GPU-side count)
/// vary too.
#[test]
fn the_persistent_trace_gives_the_same_atlases_as_a_thread_a_ray() {
    let Some(gpu) = gpu("the_persistent_trace_gives_the_same_atlases_as_a_thread_a_ray") else { return };
    const FRAMES: u32 = 12;
    for (name, probes) in [("cornell", UVec3::new(6, 6, 6)), ("door_room", UVec3::new(8, 4, 8))] {
        let run = |persistent_trace: bool| {
            let volume = DdgiVolume {
                bounds: scenes::find(name).expect("built-in scene").gi_box(),
                probe_counts: Some(probes),
                rays_per_probe: 64,
                adaptive: ddgi::DdgiAdaptive::on(),
                persistent_trace,
                ..Default::default()
            };
            let (_, app) = run_ddgi(&gpu, (scenes::find(name).expect("built-in scene").build)(), volume, 16, FRAMES);
            let v = first_volume(&app);
            let shaded = app
                .world()
                .resource::<engine::render::FrameTimings>()
                .frames
                .iter()
                .any(|f| f.passes.iter().any(|p| p.ran && p.label == "ddgi_shade"));
            // Rays a frame, by frame (read back asynchronously: the runs may get different frames back).
            let rays: std::collections::BTreeMap<u64, f64> =
                app.world().resource::<engine::render::FrameTimings>().counter("ddgi_rays").into_iter().collect();
            (read_irradiance(&gpu, v), read_distance(&gpu, v), rays, shaded)
        };
        let (irradiance, distance, rays, shaded) = run(false);
        let (persistent_irradiance, persistent_distance, persistent_rays, persistent_shaded) = run(true);
        assert!(!shaded && persistent_shaded, "{name}: ddgi_shade runs only with the persistent trace");
        let both: Vec<(u64, f64, f64)> =
            rays.iter().filter_map(|(frame, &r)| persistent_rays.get(frame).map(|&p| (*frame, r, p))).collect();
        assert!(both.len() >= 5, "{name}: frames with a ray count back from both runs: {both:?}");
        assert!(both.iter().all(|&(_, r, p)| r == p), "{name}: rays a frame (frame, thread a ray, persistent): {both:?}");
        assert!(both.iter().any(|&(_, r, _)| r != both[0].1), "{name}: the adaptive budgets vary the ray count: {both:?}");
        assert!(irradiance.texels.iter().any(|t| t.max_element() > 0.0), "{name}: the probes saw light");
        let first_difference = |a: &[Vec3], b: &[Vec3]| a.iter().zip(b).position(|(x, y)| x != y);
        assert_eq!(first_difference(&irradiance.texels, &persistent_irradiance.texels), None, "{name}: irradiance texel");
        let distance_difference = distance.texels.iter().zip(&persistent_distance.texels).position(|(x, y)| x != y);
        assert_eq!(distance_difference, None, "{name}: distance texel");
    }
}

/// A 1 m leaf card 1 m over a white floor (a 4×4 checkerboard of alpha 1 and 0, `AlphaMode::Mask`
/// at 0.5), the sun at 45° and a uniform sky: the camera looks straight down at the card's sun
/// shadow. Half its cells are cut, so half the shadow's area is lit by the sun (the analytic
/// count of lit pixels), and the probes' rays see the sky through the holes and the card's green
/// underside. DDGI against the path tracer by FLIP (issue 45's target: 0.08). Measured on lavapipe
/// (2026-12-07): 0.024; 0.092 when the probes' rays took the card's back face for the inside of a
/// solid (black), the shadow 8% too dark and grey where the path tracer's is green.
#[test]
fn a_masked_cards_shadow_matches_the_path_tracer() {
    use engine::scene::{AlphaMode, Handle, Image, TextureFilter, TextureRef};
    let Some(gpu) = gpu("a_masked_cards_shadow_matches_the_path_tracer") else { return };
    let mut scene = SceneDescription { name: "masked_card".into(), ..Default::default() };
    let floor = scene.add_mesh(engine::shapes::quad("floor", glam::Vec2::splat(20.0)));
    let white = scene.add_material(Material::diffuse("floor", Vec3::splat(0.8)));
    scene.add_node("floor", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(floor, white)])]);
    let checker: Vec<u8> = (0..16).flat_map(|i| [255, 255, 255, if (i % 4 + i / 4) % 2 == 0 { 255 } else { 0 }]).collect();
    scene.images.push(Image { name: "checker".into(), width: 4, height: 4, rgba8: checker });
    let card = scene.add_material(Material {
        base_color_texture: Some(TextureRef {
            image: Handle::from_index(0),
            transform: Default::default(),
            filter: TextureFilter::Nearest,
        }),
        alpha_mode: AlphaMode::Mask { cutoff: 0.5 },
        ..Material::diffuse("leaf", Vec3::new(0.3, 0.6, 0.2))
    });
    let quad = scene.add_mesh(engine::shapes::quad("leaf", glam::Vec2::ONE));
    scene.add_node("leaf", Transform::from_xyz(0.0, 1.0, 0.0), None, vec![NodeContent::Meshes(vec![(quad, card)])]);
    // The sun travels along +x and down: the card's shadow is the square x, z ∈ [0.5, 1.5] × [-0.5, 0.5].
    scene.add_sun(Vec3::new(1.0, -1.0, 0.0), 3.0);
    scene.sky = Some(engine::sky::Sky::Uniform(Vec3::splat(0.15)));
    // Straight down at the shadow's centre, seeing its middle 0.8 m (the card's edge stays outside).
    let camera = Transform::from_xyz(1.0, 4.0, 0.0).looking_at(Vec3::new(1.0, 0.0, 0.0), Vec3::NEG_Z);
    let fov = 2.0 * (0.4f32 / 4.0).atan();
    scene.add_node("camera", camera, None, vec![NodeContent::Camera(engine::scene::Camera { yfov: fov, ..Default::default() })]);

    const SIZE: u32 = 64;
    let settings = HeadlessSettings { width: SIZE, height: SIZE, frames: 240, ..Default::default() };
    let no_taa = |app: &mut bevy_app::App| {
        app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
    };
    let volume = DdgiVolume {
        bounds: Some((DVec3::new(-2.0, 0.0, -2.0), DVec3::new(3.0, 2.5, 2.0))),
        probe_counts: Some(UVec3::new(10, 5, 8)),
        ..Default::default()
    };
    let ddgi = engine::headless::render_scene_with(&gpu, scene.clone(), &settings, |app| {
        no_taa(app);
        use_ddgi(app, volume, DdgiOutput::Full);
    })
    .expect("ddgi");
    let traced = engine::headless::render_scene_with(&gpu, scene, &HeadlessSettings { frames: 64, ..settings }, |app| {
        no_taa(app);
        pathtrace::use_path_tracer(app, pathtrace::PathTraceSettings { samples_per_frame: 32, ..Default::default() });
    })
    .expect("path trace");
    assert!(ddgi.hdr.iter().all(|v| v.is_finite()));
    let luminance = |p: &[f32]| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
    // The lit floor: albedo / π × (the sun's 3 cos 45° + the sky's π · 0.15, less what the card
    // hides of it); the shadowed floor only the sky. Halfway between the sun's share and none.
    let sun_radiance = 0.8 / std::f32::consts::PI * 3.0 * std::f32::consts::FRAC_1_SQRT_2;
    for (mode, frame) in [("ddgi", &ddgi), ("pathtrace", &traced)] {
        let l: Vec<f32> = frame.hdr.chunks_exact(4).map(luminance).collect();
        let darkest = l.iter().copied().fold(f32::INFINITY, f32::min);
        let lit = l.iter().filter(|&&v| v > darkest + 0.5 * sun_radiance).count() as f32 / l.len() as f32;
        eprintln!("{mode}: {lit:.3} of the shadow lit by the sun (0.5 expected); darkest {darkest:.4}");
        assert!((lit - 0.5).abs() < 0.06, "{mode}: {lit:.3} of the shadow is lit by the sun through the holes (half expected)");
    }
    if let Ok(dir) = std::env::var("DDGI_DUMP_DIR") {
        for (name, frame) in [("ddgi", &ddgi), ("pathtrace", &traced)] {
            let bytes: Vec<u8> = frame.hdr.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(format!("{dir}/masked_{name}.f32"), bytes).expect("write");
        }
    }
    let flip = mean_flip(&traced.ldr, &ddgi.ldr, SIZE, SIZE);
    eprintln!("masked card's shadow: mean FLIP of DDGI against the path tracer {flip:.4}");
    assert!(flip < MASKED_SHADOW_FLIP_BOUND, "mean FLIP {flip} ≥ {MASKED_SHADOW_FLIP_BOUND}");
}

/// Issue 45's target for DDGI against the path tracer in a masked card's shadow.
const MASKED_SHADOW_FLIP_BOUND: f32 = 0.08;

//! The camera path on a real Vulkan driver (lavapipe in CI): the radiometric convention measured on
//! analytic cases, and golden images compared by FLIP.

use engine::headless::{HeadlessSettings, RenderedFrame, render_scene};
use engine::scene::{Camera, DirectionalLight, Material, Mesh, NodeContent, PointLight, SceneDescription, Transform};
use glam::{Vec2, Vec3};

/// A square of side `size` in the XZ plane facing +Y.
fn floor(size: f32) -> Mesh {
    let h = size / 2.0;
    Mesh {
        name: "floor".into(),
        positions: vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)],
        normals: vec![Vec3::Y; 4],
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        indices: vec![0, 2, 1, 0, 3, 2],
        ..Default::default()
    }
}

/// A lit floor of albedo `albedo` seen straight from above by a camera at height 5.
fn floor_scene(albedo: f32, light: NodeContent, light_transform: Transform) -> SceneDescription {
    let mut s = SceneDescription { name: "floor".into(), ..Default::default() };
    let mesh = s.add_mesh(floor(20.0));
    let material = s.add_material(Material::diffuse("grey", Vec3::splat(albedo)));
    s.add_node("floor", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(mesh, material)])]);
    let camera = Transform::from_xyz(0.0, 5.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z);
    s.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov: 0.5, ..Default::default() })]);
    s.add_node("light", light_transform, None, vec![light]);
    s
}

fn centre_radiance(frame: &RenderedFrame) -> Vec3 {
    let i = ((frame.height / 2 * frame.width + frame.width / 2) * 4) as usize;
    Vec3::new(frame.hdr[i], frame.hdr[i + 1], frame.hdr[i + 2])
}

fn small() -> HeadlessSettings {
    HeadlessSettings { width: 32, height: 32, ..Default::default() }
}

#[test]
fn directional_light_gives_lambertian_radiance_albedo_times_irradiance_over_pi() {
    let Some(gpu) = testkit::gpu("directional_light_gives_lambertian_radiance") else { return };
    let (albedo, irradiance) = (0.5, 2.0);
    // 60° from the normal: the floor receives E·cos60°.
    let sun = Transform::IDENTITY.looking_at(Vec3::new(3f32.sqrt(), -1.0, 0.0), Vec3::Y);
    let light = NodeContent::DirectionalLight(DirectionalLight { color: Vec3::ONE, intensity: irradiance });
    let frame = render_scene(&gpu, floor_scene(albedo, light, sun), &small()).expect("render");
    let expected = albedo * irradiance * 0.5 / std::f32::consts::PI;
    let got = centre_radiance(&frame);
    assert!((got - Vec3::splat(expected)).abs().max_element() < 1e-3 * expected.max(1.0), "got {got}, expected {expected}");
}

#[test]
fn point_light_follows_the_inverse_square_law() {
    let Some(gpu) = testkit::gpu("point_light_follows_the_inverse_square_law") else { return };
    let intensity = 40.0;
    for height in [1.0f32, 2.0, 4.0] {
        let light = NodeContent::PointLight(PointLight { color: Vec3::new(1.0, 0.5, 0.25), intensity, range: None });
        let frame = render_scene(&gpu, floor_scene(0.8, light, Transform::from_xyz(0.0, height, 0.0)), &small()).expect("render");
        // The centre pixel sees the floor within a few millimetres of the point under the light.
        let expected = Vec3::new(1.0, 0.5, 0.25) * 0.8 * intensity / (height * height) / std::f32::consts::PI;
        let got = centre_radiance(&frame);
        let rel = ((got - expected).abs() / expected).max_element();
        assert!(rel < 0.01, "height {height}: got {got}, expected {expected} (relative error {rel})");
    }
}

#[test]
fn cornell_box_direct_light_matches_its_golden_image() {
    let Some(gpu) = testkit::gpu("cornell_box_direct_light_matches_its_golden_image") else { return };
    let scene = (scenes::find("cornell").expect("built-in cornell").build)();
    let settings = HeadlessSettings { width: 256, height: 256, ..Default::default() };
    let frame = render_scene(&gpu, scene, &settings).expect("render");
    assert!(frame.hdr.iter().all(|v| v.is_finite()), "non-finite radiance");
    // Bound: rasterization and float differences between Vulkan drivers (lavapipe, NVIDIA) move
    // edge pixels only; a wrong light, material or camera moves the mean FLIP by well over 0.05.
    let mean = testkit::assert_golden("cornell_direct", 256, 256, &frame.ldr, 0.02);
    eprintln!("cornell_direct: mean FLIP {mean:.5}");
}

#[test]
fn the_agx_display_transform_matches_its_cpu_mirror_and_keeps_highlights() {
    let Some(gpu) = testkit::gpu("the_agx_display_transform_matches_its_cpu_mirror") else { return };
    let scene = (scenes::find("cornell").expect("built-in cornell").build)();
    let settings = HeadlessSettings { width: 64, height: 64, ..Default::default() };
    let render = |display| {
        engine::headless::render_scene_with(&gpu, scene.clone(), &settings, |app| {
            app.insert_resource(display);
        })
        .expect("render")
    };
    let (clamped, agx) = (render(engine::render::DisplayTransform::Clamp), render(engine::render::DisplayTransform::AgX));
    assert_eq!(clamped.hdr, agx.hdr, "the display transform leaves the linear radiance alone");
    // Every pixel of the GPU's AgX within two 8-bit codes of the CPU's (the cornell camera's
    // exposure is 1).
    let mut worst = 0;
    for (hdr, ldr) in agx.hdr.chunks_exact(4).zip(agx.ldr.chunks_exact(4)) {
        let display = engine::color::agx(Vec3::new(hdr[0], hdr[1], hdr[2]));
        for (c, &got) in display.to_array().into_iter().zip(ldr) {
            worst = worst.max((i32::from(engine::color::srgb8(c)) - i32::from(got)).abs());
        }
    }
    assert!(worst <= 2, "GPU AgX differs from the CPU mirror by {worst} codes");
    // The lamp and the lit ceiling burn to white under the clamp; AgX keeps them below it.
    let white = |ldr: &[u8]| ldr.chunks_exact(4).filter(|p| p[..3] == [255, 255, 255]).count();
    assert!(white(&clamped.ldr) > 0, "the cornell lamp saturates the clamp");
    assert!(
        white(&agx.ldr) < white(&clamped.ldr),
        "AgX rolls highlights off: {} white pixels against {}",
        white(&agx.ldr),
        white(&clamped.ldr)
    );
}

#[test]
fn kenney_model_renders_with_its_texture() {
    let Some(dir) = testkit::shared("kenney_model_renders_with_its_texture", scenes::shared::KENNEY_FPS) else { return };
    let Some(gpu) = testkit::gpu("kenney_model_renders_with_its_texture") else { return };
    let mut scene = engine::import::load_scene(&dir.join("platform-large-grass.glb")).expect("load");
    let sun = Transform::IDENTITY.looking_at(Vec3::new(-0.3, -1.0, -0.5), Vec3::Y);
    scene.add_node("sun", sun, None, vec![NodeContent::DirectionalLight(DirectionalLight { color: Vec3::ONE, intensity: 3.0 })]);
    let settings = HeadlessSettings { width: 160, height: 120, ..Default::default() };
    let frame = render_scene(&gpu, scene, &settings).expect("render");
    testkit::assert_golden("kenney_platform", 160, 120, &frame.ldr, 0.02);
}

#[test]
fn an_adapter_is_found_in_ci() {
    // Under CI=true this fails when no Vulkan driver is installed; elsewhere it reports a skip.
    if let Some(gpu) = testkit::gpu("an_adapter_is_found_in_ci") {
        eprintln!("adapter: {} (timestamps: {})", gpu.adapter_name(), gpu.timestamps);
    }
}

#[test]
fn absurd_sizes_are_refused_with_a_clear_error() {
    let Some(gpu) = testkit::gpu("absurd_sizes_are_refused_with_a_clear_error") else { return };
    let scene = (scenes::find("cornell").expect("cornell").build)();
    for (w, h) in [(0, 10), (10, 0), (1 << 20, 4)] {
        let settings = HeadlessSettings { width: w, height: h, ..Default::default() };
        let err = render_scene(&gpu, scene.clone(), &settings).err().expect("must fail");
        assert!(err.to_string().contains(&format!("{w}×{h}")), "{err}");
    }
}

/// Preetham's sky behind an empty scene: every background pixel is the CPU mirror's radiance along
/// that pixel's view ray (`engine::sky::Sky::background`), below the horizon too, and the sun's disk
/// shows where the camera looks at the sun.
#[test]
fn the_sky_background_matches_its_cpu_mirror() {
    let Some(gpu) = testkit::gpu("the_sky_background_matches_its_cpu_mirror") else { return };
    use engine::render::Sky;
    use engine::sky::{PhysicalSky, Sun};
    let to_sun = Vec3::new(0.3, 0.4, -0.8).normalize();
    let sun = Sun { direction: to_sun, irradiance: 4.0 };
    let sky = Sky::Physical(PhysicalSky { turbidity: 3.0, ..Default::default() });
    let size = 48u32;
    for (eye_target, yfov) in [(Vec3::new(0.2, 0.1, -1.0), 1.6f32), (to_sun, 0.01)] {
        let mut scene = SceneDescription { name: "sky".into(), ..Default::default() };
        let camera = Transform::IDENTITY.looking_at(eye_target, Vec3::Y);
        scene.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov, ..Default::default() })]);
        let light = Transform::IDENTITY.looking_at(-to_sun, Vec3::Y);
        let sunlight = DirectionalLight { color: Vec3::ONE, intensity: sun.irradiance };
        scene.add_node("sun", light, None, vec![NodeContent::DirectionalLight(sunlight)]);
        let settings = HeadlessSettings { width: size, height: size, ..Default::default() };
        let frame = engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
            app.insert_resource(sky);
        })
        .expect("render");
        let render_size = engine::render::RenderSize { width: size, height: size };
        let clip = engine::render::gpu_scene::clip_from_world(
            &Camera { yfov, ..Default::default() },
            &engine::scene::GlobalTransform(camera.to_affine()),
            render_size,
        );
        let world_from_clip = clip.inverse();
        let mut worst = 0.0f32;
        for y in 0..size {
            for x in 0..size {
                let ndc = glam::Vec2::new((x as f32 + 0.5) / size as f32 * 2.0 - 1.0, 1.0 - (y as f32 + 0.5) / size as f32 * 2.0);
                let dir = world_from_clip.project_point3(ndc.extend(1.0)).normalize();
                // On the disk's rim float rounding decides which side a pixel falls on.
                if (dir.dot(to_sun) - engine::sky::SUN_ANGULAR_RADIUS.cos()).abs() < 3e-6 {
                    continue;
                }
                let expected = sky.background(Some(sun), dir);
                let i = ((y * size + x) * 4) as usize;
                let got = Vec3::new(frame.hdr[i], frame.hdr[i + 1], frame.hdr[i + 2]);
                worst = worst.max(((got - expected).abs() / expected.max(Vec3::splat(1e-3))).max_element());
            }
        }
        assert!(worst < 2e-3, "yfov {yfov}: GPU sky differs from the CPU mirror by {worst} (relative)");
        if yfov < 0.1 {
            let i = ((size / 2 * size + size / 2) * 4) as usize;
            assert!(frame.hdr[i + 1] > 1e3 * sun.irradiance, "the sun's disk: {}", frame.hdr[i + 1]);
        }
    }
}

/// Auto-exposure: the same floor under a lamp, lit 16× brighter, shows the same picture once the
/// exposure has adapted (it jumps to its target on the first frame), its exposure value 4 stops
/// higher; the linear radiance (image.exr) is untouched by it; and after a sudden change it follows
/// at its set speed.
#[test]
fn auto_exposure_finds_the_same_picture_at_any_brightness_and_adapts_at_its_speed() {
    let Some(gpu) = testkit::gpu("auto_exposure_finds_the_same_picture") else { return };
    use engine::render::{AutoExposure, DefaultAutoExposure, ExposureState};
    // The lamp 1.5 m over the floor's centre, seen from 5 m: a bright pool fading outwards.
    let scene = |scale: f32| {
        let lamp = NodeContent::PointLight(PointLight { color: Vec3::ONE, intensity: 20.0 * scale, range: None });
        let mut s = floor_scene(0.5, lamp, Transform::from_xyz(0.0, 1.5, 0.0));
        for node in &mut s.nodes {
            for content in &mut node.content {
                if let NodeContent::Camera(c) = content {
                    c.yfov = 1.2;
                }
            }
        }
        s
    };
    let settings = HeadlessSettings { width: 48, height: 48, ..Default::default() };
    let exposure = |world: &bevy_ecs::world::World| {
        let bytes = engine::gpu::readback::read_buffer(&gpu, world.resource::<ExposureState>().exposure_buffer());
        bytemuck::cast_slice::<u8, f32>(&bytes).to_vec()
    };
    let render = |scale: f32, auto: Option<AutoExposure>| {
        let mut state = Vec::new();
        let frame = engine::headless::render_scene_and_inspect(
            &gpu,
            scene(scale),
            &settings,
            |app| {
                if let Some(a) = auto {
                    app.insert_resource(DefaultAutoExposure(a));
                }
            },
            |world| state = exposure(world),
        )
        .expect("render");
        (frame, state)
    };
    let auto = AutoExposure::default();
    let ((dim, dim_state), (bright, bright_state)) = (render(1.0, Some(auto)), render(16.0, Some(auto)));
    assert!(dim_state.iter().chain(&bright_state).all(|v| v.is_finite()), "{dim_state:?} {bright_state:?}");
    assert!((bright_state[0] - dim_state[0] - 4.0).abs() < 0.2, "16× the light, 4 stops: EV {} against {}", bright_state[0], dim_state[0]);
    let worst = dim.ldr.iter().zip(&bright.ldr).map(|(a, b)| (i32::from(*a) - i32::from(*b)).abs()).max().unwrap_or(0);
    assert!(worst <= 12, "the adapted pictures differ by {worst} codes");
    // Linear radiance is what the scene emits, whatever the exposure.
    let (plain, _) = render(1.0, None);
    assert_eq!(plain.hdr, dim.hdr);
    // A sudden 16× change: one frame later the exposure has moved by the brightening speed × 1/60 s.
    let mut app = engine::headless::scene_app(&gpu, scene(1.0), &settings, |app| {
        app.insert_resource(DefaultAutoExposure(auto));
    })
    .expect("app");
    let mut evs = Vec::new();
    engine::headless::run_frames(&mut app, 3, |k, world| {
        evs.push(exposure(world)[0]);
        if k == 0 {
            let mut q = world.query::<&mut engine::scene::PointLight>();
            for mut l in q.iter_mut(world) {
                l.intensity *= 16.0;
            }
        }
    });
    let step = evs[1] - evs[0];
    assert!(step > 0.0 && step <= auto.speed_brighten / 60.0 + 1e-4, "EV {evs:?}: one frame's step {step}");
}

/// A red leaf card (a 4×4 checkerboard of alpha 1 and 0, `AlphaMode::Mask` at 0.5) 5 cm over a
/// white floor, the sun straight overhead, seen from straight above: the camera sees the card's
/// solid half and, through its holes, the floor lit through the same holes (shadow rays skip the
/// cut texels). Without the G-buffer's discard the card would fill the view; without the rays'
/// alpha test the floor seen through the holes would lie in the card's full shadow.
#[test]
fn an_alpha_masked_card_is_cut_out_for_the_camera_and_for_shadow_and_path_rays() {
    let Some(gpu) = testkit::gpu("an_alpha_masked_card_is_cut_out") else { return };
    let mut scene = floor_scene(0.8, NodeContent::Empty, Transform::IDENTITY);
    scene.add_sun(Vec3::NEG_Y, 3.0);
    let checker: Vec<u8> = (0..16).flat_map(|i| [255, 255, 255, if (i % 4 + i / 4) % 2 == 0 { 255 } else { 0 }]).collect();
    scene.images.push(engine::scene::Image { name: "checker".into(), width: 4, height: 4, rgba8: checker });
    let card = Material {
        base_color: glam::Vec4::new(0.8, 0.05, 0.05, 1.0),
        base_color_texture: Some(engine::scene::TextureRef {
            image: engine::scene::Handle::from_index(0),
            transform: Default::default(),
            filter: Default::default(),
        }),
        alpha_mode: engine::scene::AlphaMode::Mask { cutoff: 0.5 },
        ..Material::diffuse("leaf", Vec3::ONE)
    };
    let card = scene.add_material(card);
    let quad = scene.add_mesh(engine::shapes::quad("leaf", Vec2::splat(2.6)));
    scene.add_node("leaf", Transform::from_xyz(0.0, 0.05, 0.0), None, vec![NodeContent::Meshes(vec![(quad, card)])]);
    let settings = HeadlessSettings { width: 64, height: 64, frames: 16, ..Default::default() };
    let no_taa = |app: &mut engine::bevy_app::App| {
        app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
    };
    let direct = engine::headless::render_scene_with(&gpu, scene.clone(), &settings, no_taa).expect("render");
    let path = pathtrace::PathTraceSettings { samples_per_frame: 4, ..Default::default() };
    let traced = engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
        no_taa(app);
        pathtrace::use_path_tracer(app, path);
    })
    .expect("path trace");
    for (mode, frame) in [("direct", &direct), ("pathtrace", &traced)] {
        let (mut red, mut lit, mut dark) = (0, 0, 0);
        for p in frame.hdr.chunks_exact(4) {
            let (r, g) = (p[0], p[1]);
            if r > 4.0 * g && r > 0.1 {
                red += 1;
            } else if g > 0.3 {
                lit += 1;
            } else {
                dark += 1;
            }
        }
        let n = (frame.width * frame.height) as f32;
        let (red, lit, dark) = (red as f32 / n, lit as f32 / n, dark as f32 / n);
        // Half the card's texels are cut; the floor's lit patches show through them.
        assert!((red - 0.5).abs() < 0.08, "{mode}: the card's solid texels cover {red:.3} of the view (half expected)");
        assert!((lit - 0.5).abs() < 0.08, "{mode}: lit floor through the holes {lit:.3} of the view (half expected)");
        assert!(dark < 0.05, "{mode}: {dark:.3} of the view is dark (the card shadows as a solid quad?)");
    }
}

/// glTF Asset Generator's seven alpha-mask planes (`../shared/scenes/alpha-mask-planes`): each
/// plane, seen straight on in front of a white sky, is cut exactly where its texture's alpha
/// times the base colour factor's is below its cutoff (0.5 by default, 0.4, 0.7, 1.1: all cut,
/// 0.0: none, and a factor of 0.7 at 0.4 and 0.6), pixel by pixel against the texture itself.
#[test]
fn the_alpha_mask_conformance_planes_are_cut_where_their_alpha_is_below_the_cutoff() {
    let Some(dir) = testkit::shared("the_alpha_mask_conformance_planes", "scenes/alpha-mask-planes") else { return };
    let Some(gpu) = testkit::gpu("the_alpha_mask_conformance_planes") else { return };
    let size = 64u32;
    for i in 0..7 {
        let path = dir.join(format!("Material_AlphaMask_0{i}.gltf"));
        let mut scene = engine::import::load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
        let material = scene.materials[0].clone();
        let engine::scene::AlphaMode::Mask { cutoff } = material.alpha_mode else {
            panic!("{}: {:?}", path.display(), material.alpha_mode)
        };
        let expected_cutoff = [0.5, 0.4, 0.7, 1.1, 0.0, 0.4, 0.6][i];
        assert_eq!(cutoff, expected_cutoff, "{}", path.display());
        // The unit plane (z = 0, facing +Z) filling the view from 1.2 in front: the view spans
        // ±0.45 of it.
        let half = 0.45f32;
        let camera = Transform::from_xyz(0.0, 0.0, 1.2).looking_at(Vec3::ZERO, Vec3::Y);
        scene.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov: 2.0 * (half / 1.2).atan(), ..Default::default() })]);
        scene.sky = Some(engine::render::Sky::Uniform(Vec3::ONE));
        let settings = HeadlessSettings { width: size, height: size, frames: 1, ..Default::default() };
        let frame = engine::headless::render_scene_with(&gpu, scene.clone(), &settings, |app| {
            app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
        })
        .expect("render");
        // The expected mask from the texture: each pixel centre's point on the plane, its uv from
        // the plane's own corners (uv linear in x and y), the texel's alpha there.
        let mesh = &scene.meshes[0];
        let corner =
            |x: f32, y: f32| mesh.positions.iter().position(|p| (p.x - x).abs() < 1e-4 && (p.y - y).abs() < 1e-4).expect("a corner");
        let (uv00, uv10, uv01) = (mesh.uvs[corner(-0.5, -0.5)], mesh.uvs[corner(0.5, -0.5)], mesh.uvs[corner(-0.5, 0.5)]);
        let texture = &scene.images[material.base_color_texture.expect("a base colour texture").image.index() as usize];
        let (mut agree, mut cut) = (0, 0);
        for py in 0..size {
            for px in 0..size {
                let (x, y) = ((px as f32 + 0.5) / size as f32 * 2.0 - 1.0, 1.0 - (py as f32 + 0.5) / size as f32 * 2.0);
                let (sx, sy) = (x * half + 0.5, y * half + 0.5);
                let uv = uv00 + (uv10 - uv00) * sx + (uv01 - uv00) * sy;
                let (tx, ty) =
                    ((uv.x.rem_euclid(1.0) * texture.width as f32) as u32, (uv.y.rem_euclid(1.0) * texture.height as f32) as u32);
                let alpha = f32::from(texture.rgba8[((ty * texture.width + tx) * 4 + 3) as usize]) / 255.0 * material.base_color.w;
                let expected_cut = alpha < cutoff;
                let shows_sky = frame.hdr[((py * size + px) * 4) as usize] > 0.5;
                agree += usize::from(expected_cut == shows_sky);
                cut += usize::from(shows_sky);
            }
        }
        let n = (size * size) as usize;
        eprintln!("Material_AlphaMask_0{i}: cutoff {cutoff}, {cut} of {n} pixels cut, {agree} agree with the texture");
        // Texels that straddle the cutoff may go either way under bilinear filtering.
        assert!(agree as f32 >= 0.97 * n as f32, "Material_AlphaMask_0{i}: {agree} of {n} pixels agree with the texture's mask");
    }
}

/// A 2×2 red and blue checker texture magnified over a quad that fills the view: sampled nearest
/// (glTF `NEAREST`), every pixel is one of the two colours; bilinear, the texel borders blend them.
#[test]
fn a_texture_sampled_nearest_keeps_its_texel_edges() {
    let Some(gpu) = testkit::gpu("a_texture_sampled_nearest_keeps_its_texel_edges") else { return };
    let blended = |filter: engine::scene::TextureFilter| {
        let mut scene = floor_scene(0.8, NodeContent::Empty, Transform::IDENTITY);
        scene.add_sun(Vec3::NEG_Y, 3.0);
        scene.images.push(engine::scene::Image {
            name: "checker".into(),
            width: 2,
            height: 2,
            rgba8: vec![255, 0, 0, 255, 0, 0, 255, 255, 0, 0, 255, 255, 255, 0, 0, 255],
        });
        let texture = engine::scene::TextureRef { image: engine::scene::Handle::from_index(0), transform: Default::default(), filter };
        let card = scene.add_material(Material { base_color_texture: Some(texture), ..Material::diffuse("checker", Vec3::splat(0.8)) });
        let quad = scene.add_mesh(engine::shapes::quad("checker", Vec2::splat(2.6)));
        scene.add_node("checker", Transform::from_xyz(0.0, 0.05, 0.0), None, vec![NodeContent::Meshes(vec![(quad, card)])]);
        let settings = HeadlessSettings { width: 64, height: 64, frames: 1, ..Default::default() };
        let frame = engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
            app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
        })
        .expect("render");
        // Pixels with both red and blue well above zero: a blend of the two texels.
        frame.hdr.chunks_exact(4).filter(|p| p[0].min(p[2]) > 0.1 * p[0].max(p[2])).count()
    };
    let (nearest, linear) = (blended(engine::scene::TextureFilter::Nearest), blended(engine::scene::TextureFilter::Linear));
    assert_eq!(nearest, 0, "nearest sampling blended {nearest} pixels");
    assert!(linear > 64 * 64 / 4, "bilinear sampling should blend the texels across the view: {linear} pixels");
}

//! The DDGI overlay: its field docs and editors, its settings files, its shader, and on a real
//! Vulkan driver (lavapipe in CI) the plugin added in one line to a headless app, its UI built from
//! a running app, volumes and cascades selected, and the visualizer's views against the geometry
//! they draw.

use bevy_app::App;
use ddgi::{DdgiGpuVolumes, DdgiOutput, DdgiProbeView, DdgiVolume};
use ddgi_overlay::fields::{ADAPTIVE_FIELDS, VOLUME_FIELDS, WEIGHT_FIELDS, field_docs, parse_field_docs};
use ddgi_overlay::settings::{self, DdgiSettingsFile, SettingsError};
use ddgi_overlay::{DdgiOverlay, DdgiOverlayPlugin, DdgiVisualizerViews};
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, read_ldr, run_frames, scene_app};
use engine::render::gpu_scene::clip_from_world;
use engine::render::{FrameTimings, RenderSize};
use engine::scene::{Camera, GlobalTransform};
use glam::{DVec3, UVec3, Vec2, Vec3};
use testkit::gpu;

// ---------------------------------------------------------------------------------------------
// Without a GPU

/// The keys a struct serializes to: every field's name.
fn serialized_fields<T: serde::Serialize>(value: &T) -> Vec<String> {
    let mut keys: Vec<String> = serde_json::to_value(value).expect("serialize").as_object().expect("an object").keys().cloned().collect();
    keys.sort();
    keys
}

fn sorted(names: impl Iterator<Item = impl Into<String>>) -> Vec<String> {
    let mut v: Vec<String> = names.map(Into::into).collect();
    v.sort();
    v
}

#[test]
fn every_setting_has_an_editor_and_its_doc_as_tooltip() {
    // The editors, the parsed docs and the serialized settings name the same fields.
    let mut volume_editors = sorted(VOLUME_FIELDS.iter().map(|f| f.name));
    volume_editors.extend(["adaptive".to_string(), "weights".to_string()]);
    volume_editors.sort();
    assert_eq!(volume_editors, serialized_fields(&DdgiVolume::default()));
    assert_eq!(sorted(field_docs("DdgiVolume").keys().cloned()), volume_editors);
    assert_eq!(sorted(ADAPTIVE_FIELDS.iter().map(|f| f.name)), serialized_fields(&ddgi::DdgiAdaptive::default()));
    assert_eq!(sorted(field_docs("DdgiAdaptive").keys().cloned()), serialized_fields(&ddgi::DdgiAdaptive::default()));
    assert_eq!(sorted(WEIGHT_FIELDS.iter().map(|f| f.name)), serialized_fields(&ddgi::DdgiWeights::default()));
    assert_eq!(sorted(field_docs("DdgiWeights").keys().cloned()), serialized_fields(&ddgi::DdgiWeights::default()));
    // Each tooltip is the field's doc comment, as plain text.
    let hysteresis = &field_docs("DdgiVolume")["hysteresis"];
    assert!(
        hysteresis.starts_with("Weight of the old value when blending in a frame's rays, in [0, 1]: close to 1 is stable"),
        "{hysteresis}"
    );
    let min_rays = &field_docs("DdgiAdaptive")["min_rays"];
    assert!(min_rays.contains("Fewest rays of an active probe"), "{min_rays}");
    for docs in ["DdgiVolume", "DdgiAdaptive", "DdgiWeights"].map(field_docs) {
        for (field, doc) in docs {
            assert!(doc.len() > 20 && !doc.contains("[`") && !doc.contains("///"), "{field}: {doc}");
        }
    }
}

#[test]
fn docs_are_parsed_with_links_as_code_and_paragraphs_kept() {
    let source = "pub struct S {\n    /// First [`a::B`] and [`c`](crate::c).\n    ///\n    /// Second.\n    #[allow(x)]\n    pub one: u32,\n    pub two: f32,\n}\npub struct T {\n    /// Not S's.\n    pub three: u8,\n}\n";
    let docs = parse_field_docs(source, "S");
    assert_eq!(docs["one"], "First `a::B` and `c`.\n\nSecond.");
    assert_eq!(docs["two"], "");
    assert!(!docs.contains_key("three"));
}

#[test]
fn settings_round_trip_through_json() {
    let dir = std::env::temp_dir().join(format!("ddgi_overlay_settings_{}", std::process::id()));
    let path = dir.join("tuned.json");
    let mut tuned = DdgiVolume {
        bounds: Some((DVec3::new(-1.0, 0.0, -2.5), DVec3::new(3.0, 2.0, 1e5))),
        probe_counts: Some(UVec3::new(7, 3, 9)),
        rays_per_probe: 77,
        hysteresis: 0.913,
        sky_radiance: Some(Vec3::new(0.1, 0.2, 0.3)),
        max_ray_distance: Some(42.5),
        seed: 0xfeed_beef_dead_0001,
        ..Default::default()
    };
    tuned.weights.crush = false;
    tuned.adaptive.min_rays = 9;
    tuned.adaptive.rest_smoothing = None;
    tuned.adaptive.frame_budget = Some(123_456);
    let cascades = ddgi::DdgiCascades { count: Some(3), spacing: 0.75, ..Default::default() };
    let file = DdgiSettingsFile { volumes: vec![tuned, DdgiVolume::default()], cascades: Some(cascades) };
    settings::save(&file, &path).expect("save");
    assert_eq!(settings::load(&path).expect("load"), file);
    // Fields left out keep their defaults.
    let partial =
        settings::parse(r#"{ "volumes": [ { "hysteresis": 0.5, "adaptive": { "decay": 0.5 } } ] }"#, "partial.json").expect("parse");
    let expected = DdgiVolume { hysteresis: 0.5, adaptive: ddgi::DdgiAdaptive { decay: 0.5, ..Default::default() }, ..Default::default() };
    assert_eq!(partial.volumes, vec![expected]);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bad_settings_files_name_the_file_the_field_and_the_value() {
    let cases: [(&str, &str); 7] = [
        // A value of the wrong type, nested: the field's path and the value.
        (
            r#"{ "volumes": [ {}, { "adaptive": { "min_rays": "many" } } ] }"#,
            r#"bad.json: volumes[1].adaptive.min_rays = "many": invalid type: string"#,
        ),
        // A field the settings do not have.
        (r#"{ "volumes": [ { "hysterisis": 0.5 } ] }"#, "bad.json: volumes[0].hysterisis = 0.5: unknown field `hysterisis`"),
        (r#"{ "volumes": [ { "weights": { "chebyshev": 1 } } ] }"#, "bad.json: volumes[0].weights.chebyshev = 1: invalid type"),
        (r#"{ "cascades": { "volume": { "rays_per_probe": -3 } } }"#, "bad.json: cascades.volume.rays_per_probe = -3: invalid value"),
        // In range of its type, out of the setting's: the settings' own check.
        (r#"{ "volumes": [ { "hysteresis": 1.5 } ] }"#, "bad.json: volumes[0]: DdgiVolume.hysteresis = 1.5: must be between 0 and 1"),
        (r#"{ "cascades": { "count": 12 } }"#, "bad.json: cascades: DdgiCascades.count = 12: must be between 1 and 8"),
        // Not JSON: the line and column.
        ("{ \"volumes\": [\n  { \"hysteresis\": 0.5, }\n] }", "bad.json: not valid JSON: trailing comma at line 2 column"),
    ];
    for (text, message) in cases {
        let error = settings::parse(text, "bad.json").expect_err(text).to_string();
        assert!(error.starts_with(message), "{text}\n  gave: {error}\n  want: {message}…");
    }
    let missing = settings::load(std::path::Path::new("/no/such/dir/settings.json")).expect_err("no file");
    assert!(matches!(&missing, SettingsError::Io { file, .. } if file == "/no/such/dir/settings.json"), "{missing}");
}

#[test]
fn the_visualizer_shader_validates_and_its_params_match_naga() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    ddgi::register_shaders().expect("register ddgi");
    engine::shader::check_shader_folder(&dir, ddgi_overlay::visualizer::SHADERS).unwrap_or_else(|e| panic!("{e}"));
    engine::shader::register(ddgi_overlay::visualizer::SHADERS).expect("register");
    let parsed = engine::shader::parse("ddgi_visualizer.wgsl").unwrap_or_else(|e| panic!("{e}"));
    assert!(!parsed.module.entry_points.is_empty());
    for host in ddgi_overlay::visualizer::gpu_structs() {
        engine::shader::check_struct_layout(&host).unwrap_or_else(|e| panic!("{e}"));
    }
    assert_eq!(ddgi_overlay::visualizer::vertex_counts().expect("constants"), (576, 6));
}

// ---------------------------------------------------------------------------------------------
// On the GPU

const WIDTH: u32 = 160;
const HEIGHT: u32 = 120;

/// The Cornell box with DDGI (volumes of `volumes`, each 4×4×4 probes, 16 rays) and the overlay
/// added in one line, the temporal anti-aliasing off (lines stay where they are drawn).
fn cornell_with_overlay(gpu: &GpuContext, volumes: &[(Vec3, Vec3)]) -> App {
    let scene = (scenes::find("cornell").expect("cornell").build)();
    let settings = HeadlessSettings { width: WIDTH, height: HEIGHT, frames: 1, ..Default::default() };
    let volumes: Vec<DdgiVolume> = volumes
        .iter()
        .map(|&(lo, hi)| DdgiVolume {
            bounds: Some((lo.as_dvec3(), hi.as_dvec3())),
            probe_counts: Some(UVec3::splat(4)),
            rays_per_probe: 16,
            ..Default::default()
        })
        .collect();
    scene_app(gpu, scene, &settings, |app| {
        app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
        ddgi::use_ddgi(app, volumes[0].clone(), DdgiOutput::Full);
        for v in &volumes[1..] {
            app.world_mut().spawn(v.clone());
        }
        app.add_plugins(DdgiOverlayPlugin);
    })
    .expect("app")
}

/// The Cornell box's interior, from its GI box.
fn cornell_interior() -> (Vec3, Vec3) {
    let (lo, hi) = scenes::find("cornell").expect("cornell").gi_box().expect("a GI box");
    (lo.as_vec3(), hi.as_vec3())
}

fn last_passes(app: &App) -> Vec<engine::render::PassTiming> {
    app.world().resource::<FrameTimings>().frames.last().expect("a frame").passes.clone()
}

fn ran(app: &App, label: &str) -> bool {
    last_passes(app).iter().any(|p| p.label == label && p.ran)
}

#[test]
fn the_plugin_added_in_one_line_draws_its_ui_into_the_image() {
    let Some(gpu) = gpu("the_plugin_added_in_one_line_draws_its_ui_into_the_image") else { return };
    let room = cornell_interior();
    let mut hidden = cornell_with_overlay(&gpu, &[room]);
    run_frames(&mut hidden, 3, |_, _| {});
    let without = read_ldr(&gpu, hidden.world());
    let mut shown = cornell_with_overlay(&gpu, &[room]);
    shown.world_mut().resource_mut::<DdgiOverlay>().visible = true;
    run_frames(&mut shown, 3, |_, _| {});
    let with = read_ldr(&gpu, shown.world());
    assert!(ran(&shown, "egui_overlay"), "{:?}", last_passes(&shown));
    let changed = without.chunks_exact(4).zip(with.chunks_exact(4)).filter(|(a, b)| a != b).count();
    let share = changed as f64 / f64::from(WIDTH * HEIGHT);
    assert!(share > 0.2, "the visible overlay changed only {:.1}% of the pixels", share * 100.0);
    assert!(shown.world().resource::<DdgiOverlay>().timed_frames() > 0, "no frame timings collected");
}

#[test]
fn the_ui_builds_every_window_from_a_running_app() {
    let Some(gpu) = gpu("the_ui_builds_every_window_from_a_running_app") else { return };
    let mut app = cornell_with_overlay(&gpu, &[cornell_interior()]);
    run_frames(&mut app, 4, |_, _| {});
    let world = app.world_mut();
    {
        let mut overlay = world.resource_mut::<DdgiOverlay>();
        overlay.visible = true;
        overlay.show_atlases = true;
    }
    world.resource_mut::<DdgiProbeView>().selected = Some(0);
    let ctx = egui::Context::default();
    let input = || egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(1280.0, 720.0))),
        ..Default::default()
    };
    let mut panels = ddgi_overlay::DdgiOverlayPanels::default();
    let mut shapes = 0;
    for _ in 0..3 {
        let mut output = ctx.run_pass(input(), |ctx| ddgi_overlay::overlay_ui(ctx, world, &mut panels));
        shapes = output.shapes.len();
        output.textures_delta.clear();
    }
    assert!(shapes > 100, "the overlay drew only {shapes} shapes");
    assert!(world.resource::<DdgiOverlay>().has_atlas_images(), "the atlases were not read back into textures");
}

#[test]
fn every_volume_and_cascade_is_listed_and_selectable() {
    let Some(gpu) = gpu("every_volume_and_cascade_is_listed_and_selectable") else { return };
    let (lo, hi) = cornell_interior();
    let mid = (lo + hi) * 0.5;
    let mut app = cornell_with_overlay(&gpu, &[(lo, Vec3::new(mid.x, hi.y, hi.z)), (Vec3::new(mid.x, lo.y, lo.z), hi)]);
    run_frames(&mut app, 2, |_, _| {});
    let names = ddgi_overlay::ui::volume_names(app.world_mut());
    assert_eq!(names.iter().map(|(_, n)| n.split(' ').take(2).collect::<Vec<_>>().join(" ")).collect::<Vec<_>>(), ["volume 0", "volume 1"]);
    // The probe spheres and picking follow the selection.
    let second = names[1].0;
    {
        let mut view = app.world_mut().resource_mut::<DdgiProbeView>();
        view.volume = Some(second);
        view.color = ddgi::DdgiProbeColor::State;
    }
    run_frames(&mut app, 1, |_, _| {});
    assert!(ran(&app, "ddgi_probe_spheres"));
    let world = app.world_mut();
    let size = *world.resource::<RenderSize>();
    let (camera, transform) = ddgi_overlay::picking::view_camera(world).expect("a camera");
    let volumes = world.resource::<DdgiGpuVolumes>();
    let probe = volumes.get(second).expect("the second volume lights");
    let target = probe.layout.grid_position(probe.layout.probe_count / 2)
        + Vec3::from_array(probe.probe_data[(probe.layout.probe_count / 2) as usize].offset);
    let pixel = project(&camera, &transform, size, target);
    let picked = ddgi_overlay::pick_probe_in_world(world, pixel);
    assert!(picked.is_some(), "no probe of the selected volume under its own probe's pixel {pixel}");

    // Cascades: each is listed, and the views draw the selected one.
    let scene = (scenes::find("cornell").expect("cornell").build)();
    let settings = HeadlessSettings { width: 64, height: 48, frames: 1, ..Default::default() };
    let cascades = ddgi::DdgiCascades {
        count: Some(2),
        probe_counts: UVec3::splat(4),
        spacing: 0.4,
        blend_cells: 0.5,
        volume: DdgiVolume { rays_per_probe: 8, warm_up: true, ..Default::default() },
        ..Default::default()
    };
    let mut app = scene_app(&gpu, scene, &settings, |app| {
        ddgi::use_ddgi_cascades(app, cascades, DdgiOutput::Full);
        app.add_plugins(DdgiOverlayPlugin);
    })
    .expect("app");
    run_frames(&mut app, 2, |_, _| {});
    let names = ddgi_overlay::ui::volume_names(app.world_mut());
    assert!(names.len() == 2 && names[0].1.starts_with("cascade 0") && names[1].1.starts_with("cascade 1"), "{names:?}");
    app.world_mut().resource_mut::<DdgiProbeView>().volume = Some(names[1].0);
    app.world_mut().resource_mut::<DdgiVisualizerViews>().bounds = true;
    run_frames(&mut app, 1, |_, _| {});
    assert!(ran(&app, "ddgi_visualizer"), "{:?}", last_passes(&app));
}

/// The pixel a world point projects to (the renderer's own projection, unjittered).
fn project(camera: &Camera, transform: &GlobalTransform, size: RenderSize, p: Vec3) -> Vec2 {
    let c = clip_from_world(camera, transform, size) * p.extend(1.0);
    let ndc = c.truncate() / c.w;
    Vec2::new((ndc.x + 1.0) * 0.5 * size.width as f32, (1.0 - ndc.y) * 0.5 * size.height as f32)
}

/// Distance from point `p` to segment `a`–`b`.
fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f32 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 { ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0) } else { 0.0 };
    (a + ab * t).distance(p)
}

/// The twelve edges of a box, as corner pairs.
fn box_edges(lo: Vec3, hi: Vec3) -> Vec<(Vec3, Vec3)> {
    let corner = |k: u32| {
        Vec3::new(if k & 1 == 0 { lo.x } else { hi.x }, if k & 2 == 0 { lo.y } else { hi.y }, if k & 4 == 0 { lo.z } else { hi.z })
    };
    let mut edges = Vec::new();
    for k in 0..8u32 {
        for bit in [1, 2, 4] {
            if k & bit == 0 {
                edges.push((corner(k), corner(k | bit)));
            }
        }
    }
    edges
}

#[test]
fn the_wireframe_and_the_offset_lines_lie_on_their_projected_geometry() {
    let Some(gpu) = gpu("the_wireframe_and_the_offset_lines_lie_on_their_projected_geometry") else { return };
    // A box floating in the middle of the room: its edges are in free space.
    let (lo, hi) = cornell_interior();
    let (center, half) = ((lo + hi) * 0.5, (hi - lo) * 0.25);
    let mut app = cornell_with_overlay(&gpu, &[(center - half, center + half)]);
    run_frames(&mut app, 3, |_, _| {});
    app.world_mut().insert_resource(DdgiVisualizerViews { bounds: true, relocation_offsets: true, ..Default::default() });
    run_frames(&mut app, 1, |_, _| {});
    assert!(ran(&app, "ddgi_visualizer"), "{:?}", last_passes(&app));
    let ldr = read_ldr(&gpu, app.world());
    let world = app.world_mut();
    let size = *world.resource::<RenderSize>();
    let (camera, transform) = ddgi_overlay::picking::view_camera(world).expect("a camera");
    let volumes = world.resource::<DdgiGpuVolumes>();
    let v = &volumes.volumes[0].1;
    // The layout's box (the cells around the probes) and each probe's offset as the GPU holds them.
    let probes: Vec<ddgi::gpu::DdgiProbeData> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(&gpu, &v.probes));
    let edges: Vec<(Vec2, Vec2)> = box_edges(v.layout.bounds.0, v.layout.bounds.1)
        .into_iter()
        .map(|(a, b)| (project(&camera, &transform, size, a), project(&camera, &transform, size, b)))
        .collect();
    let offsets: Vec<(Vec2, Vec2)> = (0..v.layout.probe_count)
        .map(|i| {
            let a = v.layout.grid_position(i);
            (project(&camera, &transform, size, a), project(&camera, &transform, size, a + Vec3::from_array(probes[i as usize].offset)))
        })
        .collect();
    let pixel = |x: u32, y: u32| &ldr[((y * WIDTH + x) * 4) as usize..((y * WIDTH + x) * 4 + 3) as usize];
    let is = |p: &[u8], rgb: [u8; 3]| p.iter().zip(rgb).all(|(a, b)| a.abs_diff(b) <= 2);
    let near = |p: Vec2, segments: &[(Vec2, Vec2)]| segments.iter().map(|(a, b)| segment_distance(p, *a, *b)).fold(f32::INFINITY, f32::min);
    let (mut yellow, mut cyan) = (0, 0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            if is(pixel(x, y), [255, 255, 0]) {
                yellow += 1;
                let d = near(centre, &edges);
                assert!(d <= 2.0, "a wireframe pixel ({x}, {y}) lies {d:.2} px from every projected edge of the volume's box");
            }
            if is(pixel(x, y), [0, 255, 255]) {
                cyan += 1;
                let d = near(centre, &offsets);
                assert!(d <= 2.0, "an offset-line pixel ({x}, {y}) lies {d:.2} px from every projected offset");
            }
        }
    }
    // The box's edges, floating in the room, are drawn along most of their length.
    let mut samples = 0;
    let mut covered = 0;
    for (a, b) in &edges {
        for k in 1..20 {
            let p = a.lerp(*b, k as f32 / 20.0);
            if p.x < 2.0 || p.y < 2.0 || p.x > WIDTH as f32 - 2.0 || p.y > HEIGHT as f32 - 2.0 {
                continue;
            }
            samples += 1;
            let hit = (-1..=1)
                .any(|dy: i32| (-1..=1).any(|dx: i32| is(pixel((p.x as i32 + dx) as u32, (p.y as i32 + dy) as u32), [255, 255, 0])));
            covered += u32::from(hit);
        }
    }
    assert!(samples > 50 && covered as f32 > 0.6 * samples as f32, "{covered} of {samples} points along the edges are drawn");
    assert!(yellow > 100, "only {yellow} wireframe pixels");
    let relocated = probes
        .iter()
        .take(v.layout.probe_count as usize)
        .filter(|p| Vec3::from_array(p.offset).length() > 0.05 * v.layout.spacing.min_element())
        .count();
    if relocated > 0 {
        assert!(cyan > 0, "{relocated} probes moved but no offset line is drawn");
    }

    // The distance spheres colour the probes: the pass draws them and the image changes beyond
    // the noise of one more frame of convergence.
    app.world_mut().insert_resource(DdgiVisualizerViews::default());
    run_frames(&mut app, 1, |_, _| {});
    let plain = read_ldr(&gpu, app.world());
    app.world_mut().insert_resource(DdgiVisualizerViews { distance_spheres: true, radius: 0.3, ..Default::default() });
    run_frames(&mut app, 1, |_, _| {});
    let spheres = read_ldr(&gpu, app.world());
    let changed = spheres
        .chunks_exact(4)
        .zip(plain.chunks_exact(4))
        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.abs_diff(*y) > 30))
        .count();
    assert!(changed > 200, "the distance spheres changed only {changed} pixels");
}

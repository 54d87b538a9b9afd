//! Large-world coordinates: the Cornell box placed 1e3, 1e4 and 1e5 units from the world's origin
//! renders as it does at the origin in every mode (direct light, DDGI, DDGI's indirect light alone,
//! the path tracer, DDGI's camera-following cascades), with a still camera and with one that moves while the render origin rebases
//! under it; and the same box at 1e5 without rebasing (single-precision world coordinates) does not,
//! which shows that the comparison can fail and that rebasing is what passes it.

use ddgi::{DdgiOutput, DdgiVolume, use_ddgi};
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, read_ldr, run_frames, scene_app};
use engine::scene::{Camera, RenderOrigin, SceneDescription, Transform};
use glam::{DVec3, UVec3, Vec3};
use testkit::{gpu, mean_flip};

/// The size of the stored path-traced reference of the box (`testkit::path_traced_reference`).
const SIZE: u32 = 96;
/// Frames of every run: the path tracer gathers 16 paths per pixel per frame, DDGI converges part
/// of the way (both runs of a comparison take the same frames, so only precision can differ).
const FRAMES: u32 = 12;
/// The bound: FLIP against the origin's image within 0.01.
const MAX_FLIP: f32 = 0.01;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Direct,
    Ddgi,
    Indirect,
    PathTrace,
    /// DDGI with camera-following cascades (they scroll as the camera walks, and shift with every
    /// rebase without losing their probes).
    Cascades,
}

const MODES: [Mode; 5] = [Mode::Direct, Mode::Ddgi, Mode::Indirect, Mode::PathTrace, Mode::Cascades];

fn cornell(offset: DVec3) -> SceneDescription {
    let mut scene = (scenes::find("cornell").expect("cornell").build)();
    scene.origin = offset;
    scene
}

/// Renders `scene` in `mode` for [`FRAMES`] frames; `origin` replaces the render origin's settings
/// (rebasing), `each_frame` may move things after each frame. Returns every frame's LDR image.
fn render(
    gpu: &GpuContext,
    scene: SceneDescription,
    mode: Mode,
    origin: RenderOrigin,
    mut each_frame: impl FnMut(u32, &mut engine::bevy_ecs::world::World),
) -> (Vec<Vec<u8>>, RenderOrigin) {
    let settings = HeadlessSettings { width: SIZE, height: SIZE, frames: FRAMES, ..Default::default() };
    let mut app = scene_app(gpu, scene, &settings, |app| {
        app.insert_resource(origin);
        // The fixed budget: what is compared is the coordinates, frame by frame, and the adaptive
        // budgets' shares come back from the GPU a frame or two late, not on a fixed frame.
        let volume = DdgiVolume {
            probe_counts: Some(UVec3::splat(4)),
            rays_per_probe: 64,
            adaptive: ddgi::DdgiAdaptive::off(),
            ..Default::default()
        };
        match mode {
            Mode::Direct => {}
            Mode::Ddgi => use_ddgi(app, volume, DdgiOutput::Full),
            Mode::Indirect => use_ddgi(app, volume, DdgiOutput::Indirect),
            Mode::PathTrace => {
                pathtrace::use_path_tracer(app, pathtrace::PathTraceSettings { samples_per_frame: 16, ..Default::default() })
            }
            Mode::Cascades => {
                // Wide enough for the coarse one to reach the box from the camera 4.3 units in front.
                let cascades = ddgi::DdgiCascades {
                    count: Some(2),
                    probe_counts: UVec3::new(8, 6, 8),
                    spacing: 1.0,
                    blend_cells: 1.0,
                    volume: DdgiVolume { warm_up: true, ..volume },
                    ..Default::default()
                };
                ddgi::use_ddgi_cascades(app, cascades, DdgiOutput::Full)
            }
        }
    })
    .expect("app");
    let mut frames = Vec::new();
    run_frames(&mut app, FRAMES, |frame, world| {
        frames.push(read_ldr(gpu, world));
        each_frame(frame, world);
    });
    let origin = *app.world().resource::<RenderOrigin>();
    (frames, origin)
}

/// Mean FLIP of an image against the box's path-traced reference (4,096 paths per pixel).
fn reference_flip(gpu: &GpuContext, image: &[u8]) -> f32 {
    mean_flip(testkit::path_traced_reference(gpu, "cornell", SIZE).as_raw(), image, SIZE, SIZE)
}

fn last(frames: &[Vec<u8>]) -> &[u8] {
    frames.last().expect("frames")
}

#[test]
fn a_scene_far_from_the_origin_renders_as_at_the_origin_in_every_mode() {
    let Some(gpu) = gpu("a_scene_far_from_the_origin_renders_as_at_the_origin_in_every_mode") else { return };
    let mean = |image: &[u8]| image.iter().map(|&b| f64::from(b)).sum::<f64>() / image.len() as f64;
    let mut direct = 0.0;
    for mode in MODES {
        let (at_origin, o) = render(&gpu, cornell(DVec3::ZERO), mode, RenderOrigin::default(), |_, _| {});
        assert_eq!(o.rebases, 0, "{mode:?}: a scene at the origin does not rebase");
        // The DDGI modes add indirect light: their images are brighter than direct light alone.
        match mode {
            Mode::Direct => direct = mean(last(&at_origin)),
            Mode::Ddgi | Mode::Cascades => assert!(mean(last(&at_origin)) > 1.1 * direct, "{mode:?} adds no indirect light"),
            _ => {}
        }
        for offset in [DVec3::new(1e3, 0.0, 0.0), DVec3::new(-1e4, 1e4, 0.0), DVec3::new(1e5, -1e5, 1e5)] {
            let (far, o) = render(&gpu, cornell(offset), mode, RenderOrigin::default(), |_, _| {});
            assert_eq!(o.rebases, 1, "{mode:?} at {offset}: one rebase, at the first frame");
            if mode == Mode::PathTrace {
                // Noise: a path that bounces off a surface a float step away takes other random
                // numbers from there on, so two placements' images differ by their noise; what must
                // not move is their error against the converged reference.
                let (a, b) = (reference_flip(&gpu, last(&at_origin)), reference_flip(&gpu, last(&far)));
                eprintln!("{mode:?} at {offset}: FLIP against the reference {b:.5}, at the origin {a:.5}");
                assert!((a - b).abs() <= MAX_FLIP, "{mode:?} at {offset}: FLIP against the reference {b}, at the origin {a}");
            } else {
                let flip = mean_flip(last(&at_origin), last(&far), SIZE, SIZE);
                eprintln!("{mode:?} at {offset}: FLIP {flip:.5} against the origin");
                assert!(flip <= MAX_FLIP, "{mode:?} at {offset}: FLIP {flip} against the same scene at the origin");
            }
        }
    }
}

#[test]
fn without_rebasing_a_scene_1e5_away_breaks_which_is_what_rebasing_fixes() {
    let Some(gpu) = gpu("without_rebasing_a_scene_1e5_away_breaks_which_is_what_rebasing_fixes") else { return };
    let single = RenderOrigin { rebase_distance: f64::INFINITY, ..Default::default() };
    for mode in [Mode::Direct, Mode::PathTrace] {
        let (at_origin, _) = render(&gpu, cornell(DVec3::ZERO), mode, RenderOrigin::default(), |_, _| {});
        let (far, o) = render(&gpu, cornell(DVec3::splat(1e5)), mode, single, |_, _| {});
        assert_eq!(o.rebases, 0);
        let flip = mean_flip(last(&at_origin), last(&far), SIZE, SIZE);
        eprintln!("{mode:?} at 1e5 in single-precision world coordinates: FLIP {flip:.4}");
        assert!(flip > 4.0 * MAX_FLIP, "{mode:?}: expected the single-precision render at 1e5 to break, FLIP {flip}");
    }
}

/// The camera walks 0.3 units per frame through the box's opening and back; far from the origin the
/// render origin is rebased every 0.5 units (instead of 1,024) so that it moves under the camera
/// several times during the run, with DDGI's probes and the path tracer's accumulation in flight.
#[test]
fn a_moving_camera_far_from_the_origin_sees_every_frame_as_at_the_origin_while_rebasing() {
    let Some(gpu) = gpu("a_moving_camera_far_from_the_origin_sees_every_frame_as_at_the_origin_while_rebasing") else { return };
    let walk = |frame: u32, world: &mut engine::bevy_ecs::world::World| {
        let mut cameras = world.query_filtered::<&mut Transform, engine::bevy_ecs::query::With<Camera>>();
        for mut t in cameras.iter_mut(world) {
            let step = if frame < FRAMES / 2 { -0.3 } else { 0.3 };
            t.translation += Vec3::new(0.05, 0.0, step);
        }
    };
    let frequent = RenderOrigin { rebase_distance: 0.5, ..Default::default() };
    for mode in MODES {
        let (at_origin, _) = render(&gpu, cornell(DVec3::ZERO), mode, RenderOrigin::default(), walk);
        let offset = DVec3::new(-3e4, 2e4, 7e4);
        let (far, o) = render(&gpu, cornell(offset), mode, frequent, walk);
        assert!(o.rebases >= 3, "{mode:?}: {} rebases", o.rebases);
        let worst = at_origin.iter().zip(&far).map(|(a, b)| mean_flip(a, b, SIZE, SIZE)).fold(0.0f32, f32::max);
        eprintln!("{mode:?}, moving camera at {offset}, {} rebases: worst frame FLIP {worst:.5}", o.rebases);
        assert!(worst <= MAX_FLIP, "{mode:?}: a frame differs from the origin's by FLIP {worst}");
    }
}

#[test]
fn meshes_far_from_their_own_origin_are_recentred_and_keep_their_shape() {
    let mut mesh = engine::shapes::cuboid("far", Vec3::splat(0.5));
    for p in &mut mesh.positions {
        *p += Vec3::new(5e4, 0.0, -2e3);
    }
    let before = mesh.positions.clone();
    let (moved, centre) = engine::scene::recentre_far_mesh(mesh);
    assert!((centre - Vec3::new(5e4, 0.0, -2e3)).abs().max_element() < 1e-2, "{centre}");
    for (a, b) in before.iter().zip(&moved.positions) {
        assert!((*a - (*b + centre)).abs().max_element() <= 5e4 * f32::EPSILON, "the vertex goes back where it was: {a} {b}");
    }
    let near = engine::shapes::cuboid("near", Vec3::splat(0.5));
    let (same, zero) = engine::scene::recentre_far_mesh(near.clone());
    assert_eq!((same.positions, zero), (near.positions, Vec3::ZERO), "a mesh near its origin is left as it is");
}

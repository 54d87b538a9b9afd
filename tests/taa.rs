//! Temporal anti-aliasing on a real Vulkan driver (lavapipe in CI): a still camera converges to the
//! supersampled image, a moving object leaves no trail, a camera cut starts the history afresh.

use bevy_ecs::prelude::*;
use engine::headless::{HeadlessSettings, read_hdr, run_frames, scene_app};
use engine::render::TemporalAntiAliasing;
use engine::scene::{Camera, DirectionalLight, Material, Name, NodeContent, SceneDescription, Transform};
use glam::Vec3;

/// Renders `scene` for `frames` frames with `taa` on its camera; `each_frame(k, world)` runs before
/// frame k (k from 0). Returns the last frame's linear radiance.
fn render(
    gpu: &engine::gpu::GpuContext,
    scene: SceneDescription,
    size: u32,
    taa: TemporalAntiAliasing,
    frames: u32,
    mut each_frame: impl FnMut(u32, &mut World),
) -> Vec<f32> {
    let settings = HeadlessSettings { width: size, height: size, frames, ..Default::default() };
    let mut app = scene_app(gpu, scene, &settings, |_| {}).expect("app");
    let world = app.world_mut();
    let cameras: Vec<Entity> = world.query_filtered::<Entity, With<Camera>>().iter(world).collect();
    for camera in cameras {
        world.entity_mut(camera).insert(taa);
    }
    each_frame(0, world);
    run_frames(&mut app, frames, |k, world| each_frame(k + 1, world));
    read_hdr(gpu, app.world())
}

/// The clamp-and-sRGB display of linear RGBA radiance (what the golden images use), as RGB8.
fn display(hdr: &[f32]) -> Vec<u8> {
    lab::metrics::tonemap_to_srgb8(hdr, 1.0)
}

fn mean_flip(reference: &[f32], test: &[f32], size: u32) -> f32 {
    lab::metrics::flip_rgb8(&display(reference), &display(test), size, size).0
}

/// `hdr` (`size × factor` square) averaged over blocks of `factor × factor` pixels: a box filter.
fn downsample(hdr: &[f32], size: u32, factor: u32) -> Vec<f32> {
    let big = size * factor;
    let mut out = vec![0.0f32; (size * size * 4) as usize];
    for y in 0..big {
        for x in 0..big {
            let (i, o) = (((y * big + x) * 4) as usize, (((y / factor) * size + x / factor) * 4) as usize);
            for c in 0..4 {
                out[o + c] += hdr[i + c] / (factor * factor) as f32;
            }
        }
    }
    out
}

fn cornell() -> SceneDescription {
    (scenes::find("cornell").expect("built-in cornell").build)()
}

#[test]
fn a_still_camera_converges_to_the_supersampled_image() {
    let Some(gpu) = testkit::gpu("a_still_camera_converges_to_the_supersampled_image") else { return };
    let size = 64;
    let supersampled =
        |factor| downsample(&render(&gpu, cornell(), size * factor, TemporalAntiAliasing::off(), 1, |_, _| {}), size, factor);
    // The reference: 8×8 samples per pixel, box-filtered (the path tracer's pixel filter).
    let reference = supersampled(8);
    let aliased = render(&gpu, cornell(), size, TemporalAntiAliasing::default(), 1, |_, _| {});
    let resolved = render(&gpu, cornell(), size, TemporalAntiAliasing::default(), 48, |_, _| {});
    assert!(resolved.iter().all(|v| v.is_finite()), "non-finite radiance");
    let (one_frame, taa, sixteen) =
        (mean_flip(&reference, &aliased, size), mean_flip(&reference, &resolved, size), mean_flip(&reference, &supersampled(4), size));
    eprintln!("FLIP against 8×8 supersampling: one frame {one_frame:.4}, TAA after 48 frames {taa:.4}, 4×4 supersampling {sixteen:.4}");
    // Most of the edges' aliasing gone, and as close as 16 samples per pixel on a regular grid get.
    assert!(taa < 0.5 * one_frame, "TAA {taa:.4} against one frame {one_frame:.4}");
    assert!(taa < 1.1 * sixteen, "TAA {taa:.4} against 4×4 supersampling {sixteen:.4}");
}

/// A dark floor under a sun, seen from above, with a white box that `at(k)` places at frame k.
fn moving_box_scene() -> SceneDescription {
    let mut s = SceneDescription { name: "moving_box".into(), ..Default::default() };
    let floor = s.add_mesh(engine::shapes::cuboid("floor", Vec3::new(10.0, 0.05, 10.0)));
    let cube = s.add_mesh(engine::shapes::cuboid("box", Vec3::splat(0.5)));
    let (dark, white) =
        (s.add_material(Material::diffuse("dark", Vec3::splat(0.1))), s.add_material(Material::diffuse("white", Vec3::ONE)));
    s.add_node("floor", Transform::from_xyz(0.0, -0.05, 0.0), None, vec![NodeContent::Meshes(vec![(floor, dark)])]);
    s.add_node("box", Transform::from_xyz(-2.0, 0.5, 0.0), None, vec![NodeContent::Meshes(vec![(cube, white)])]);
    let camera = Transform::from_xyz(0.0, 8.0, 0.01).looking_at(Vec3::ZERO, Vec3::NEG_Z);
    s.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov: 0.9, ..Default::default() })]);
    let sun = Transform::IDENTITY.looking_at(Vec3::new(0.2, -1.0, 0.1), Vec3::Y);
    s.add_node("sun", sun, None, vec![NodeContent::DirectionalLight(DirectionalLight { color: Vec3::ONE, intensity: 3.0 })]);
    s
}

fn place_box(world: &mut World, x: f32) {
    let mut q = world.query::<(&Name, &mut Transform)>();
    for (name, mut t) in q.iter_mut(world) {
        if name.0 == "box" {
            t.translation.x = x;
        }
    }
}

#[test]
fn a_moving_object_leaves_no_trail() {
    let Some(gpu) = testkit::gpu("a_moving_object_leaves_no_trail") else { return };
    let size = 96;
    let (frames, speed) = (40u32, 0.1f32);
    let x = |k: u32| -2.0 + speed * k as f32;
    let last = x(frames - 1);
    let moving = render(&gpu, moving_box_scene(), size, TemporalAntiAliasing::default(), frames, |k, world| place_box(world, x(k)));
    // The same scene with the box where it ends, rendered afresh (no history).
    let fresh = render(&gpu, moving_box_scene(), size, TemporalAntiAliasing::off(), 1, |_, world| place_box(world, last));
    assert!(moving.iter().all(|v| v.is_finite()), "non-finite radiance");
    // The floor the box crossed in the last 10 frames (its footprint then, minus where it is now,
    // with a pixel of margin) must be the floor again: a trail would be the box's white.
    let pixel_x = |world_x: f32| (world_x / (8.0 * (0.45f32).tan()) * 0.5 + 0.5) * size as f32;
    let (trail_lo, trail_hi) = (pixel_x(x(frames - 11) - 0.5), pixel_x(last - 0.5) - 1.0);
    let (row_lo, row_hi) = (size / 2 - 3, size / 2 + 3);
    let (mut worst, mut sum, mut n) = (0.0f32, 0.0f32, 0);
    for y in row_lo..row_hi {
        for px in (trail_lo.ceil() as u32)..(trail_hi.floor() as u32) {
            let i = ((y * size + px) * 4) as usize;
            let d = (moving[i + 1] - fresh[i + 1]).abs();
            worst = worst.max(d);
            sum += d;
            n += 1;
        }
    }
    assert!(n > 30, "trail region of {n} pixels");
    let floor_radiance = fresh[((size / 2 * size + trail_lo.ceil() as u32) * 4 + 1) as usize];
    let box_radiance = fresh[((size / 2 * size) as f32 * 4.0 + (pixel_x(last).round() * 4.0) + 1.0) as usize];
    let contrast = (box_radiance - floor_radiance).abs();
    eprintln!("trail: worst {worst:.4}, mean {:.4} over {n} pixels; box {box_radiance:.3}, floor {floor_radiance:.3}", sum / n as f32);
    assert!(contrast > 0.3, "the box ({box_radiance}) stands out from the floor ({floor_radiance})");
    assert!(worst < 0.05 * contrast, "trail: {worst} of a contrast of {contrast}");
    // Away from the box's edges the whole image is the fresh one.
    assert!(mean_flip(&fresh, &moving, size) < 0.05);
}

#[test]
fn a_camera_cut_resets_the_history() {
    let Some(gpu) = testkit::gpu("a_camera_cut_resets_the_history") else { return };
    let size = 48;
    // The scene's camera looks down on the floor; at frame 20 it jumps to look at the box from the side.
    let view_b = Transform::from_xyz(5.0, 3.0, 5.0).looking_at(Vec3::ZERO, Vec3::Y);
    let cut = |reset: bool| {
        move |k: u32, world: &mut World| {
            if k == 20 {
                let mut q = world.query::<(&mut Transform, &mut TemporalAntiAliasing)>();
                for (mut t, mut taa) in q.iter_mut(world) {
                    *t = view_b;
                    taa.reset = reset;
                }
            }
        }
    };
    let after_cut = render(&gpu, moving_box_scene(), size, TemporalAntiAliasing::default(), 21, cut(true));
    let mut scene_b = moving_box_scene();
    for node in &mut scene_b.nodes {
        if node.name == "camera" {
            node.transform = view_b;
        }
    }
    let fresh = render(&gpu, scene_b, size, TemporalAntiAliasing::off(), 1, |_, _| {});
    let max_difference = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
    // The frame after a reset is the new view as rendered alone: no trace of the old one.
    assert!(max_difference(&after_cut, &fresh) < 1e-5, "after the reset: {}", max_difference(&after_cut, &fresh));
    // Without the reset the history of the old view (and the jitter) shows in that frame.
    let without_reset = render(&gpu, moving_box_scene(), size, TemporalAntiAliasing::default(), 21, cut(false));
    assert!(max_difference(&without_reset, &fresh) > 1e-3, "the cut without a reset is not the fresh view");
}

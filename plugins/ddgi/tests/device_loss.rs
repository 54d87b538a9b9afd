//! A lost GPU device (driver reset, GPU removed; here `Device::destroy`) in the middle of a DDGI
//! run: no panic and no wgpu error from our side, the render stages stop and say why, and a new
//! device renders the same image again.

use ddgi::{DdgiOutput, DdgiVolume, use_ddgi};
use engine::app::GpuLost;
use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, read_frame, run_frames, scene_app};
use glam::UVec3;

const FRAMES: u32 = 8;

fn cornell_app(gpu: &GpuContext) -> engine::bevy_app::App {
    let scene = (scenes::find("cornell").expect("cornell is built in").build)();
    let settings = HeadlessSettings { width: 48, height: 48, ..Default::default() };
    let volume = DdgiVolume { probe_counts: Some(UVec3::splat(4)), rays_per_probe: 32, ..Default::default() };
    scene_app(gpu, scene, &settings, |app| use_ddgi(app, volume, DdgiOutput::Full)).expect("a valid scene")
}

#[test]
fn a_lost_device_stops_rendering_cleanly_and_a_new_device_renders_the_same_image() {
    // Validation errors panic on these contexts: any error not caused by the loss fails the test.
    let Some(gpu) = testkit::gpu("device_loss") else { return };
    let mut app = cornell_app(&gpu);
    run_frames(&mut app, FRAMES, |_, _| {});
    let before = read_frame(&gpu, app.world());
    assert!(gpu.lost().is_none());

    gpu.simulate_device_loss();
    let reason = gpu.lost().expect("wgpu reports the loss");
    assert!(reason.contains("Destroyed"), "{reason}");
    // The app goes on without rendering: no panic, no GPU call, the loss recorded once with its frame.
    run_frames(&mut app, 3, |_, _| {});
    let lost = app.world().get_resource::<GpuLost>().expect("GpuLost is inserted").clone();
    assert_eq!(lost.frame, u64::from(FRAMES), "noticed on the first frame after the loss");
    assert_eq!(lost.reason, reason);

    // What a runner does: a new device, the same scene, the same frames.
    let gpu = testkit::gpu("device_loss").expect("a second device");
    let mut app = cornell_app(&gpu);
    run_frames(&mut app, FRAMES, |_, _| {});
    let after = read_frame(&gpu, app.world());
    let mean = testkit::mean_flip(&before.ldr, &after.ldr, before.width, before.height);
    assert!(mean < 1e-3, "the new device renders another image: mean FLIP {mean}");
    assert!(after.ldr.chunks_exact(4).any(|p| p[..3] != after.ldr[..3]), "the image is one flat colour");
}

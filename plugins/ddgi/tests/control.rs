//! Pause, step and reset of the probe updates ([`DdgiUpdateControl`]), the calm update period
//! ([`ddgi::DdgiAdaptive::max_update_period`]), the probe state counts and a volume's GPU memory,
//! on a real Vulkan driver (lavapipe in CI).

use bevy_app::App;
use bevy_ecs::prelude::*;
use ddgi::gpu::{DdgiCounters, DdgiProbeData, PROBE_INACTIVE};
use ddgi::{DdgiGpuVolumes, DdgiOutput, DdgiProbe, DdgiUpdateControl, DdgiVolume, use_ddgi};
use engine::gpu::GpuContext;
use engine::gpu::readback::{read_buffer, read_texture};
use engine::headless::{HeadlessSettings, run_frames, scene_app};
use glam::UVec3;
use testkit::gpu;

/// The Cornell box lit by one 4×4×4 volume with the fixed budget (every active probe updates at
/// every update), 32 rays a probe.
fn cornell_app(gpu: &GpuContext) -> App {
    let scene = (scenes::find("cornell").expect("cornell").build)();
    let volume = DdgiVolume {
        bounds: scenes::find("cornell").expect("cornell").gi_box(),
        probe_counts: Some(UVec3::splat(4)),
        rays_per_probe: 32,
        recheck_interval: 0,
        adaptive: ddgi::DdgiAdaptive::off(),
        ..Default::default()
    };
    let settings = HeadlessSettings { width: 48, height: 36, frames: 1, ..Default::default() };
    scene_app(gpu, scene, &settings, |app| use_ddgi(app, volume, DdgiOutput::Full)).expect("app")
}

/// The Cornell box lit by one 4×4×4 volume with adaptive budgets, 64 rays a probe, calm update
/// periods up to `max_update_period`.
fn adaptive_cornell_app(gpu: &GpuContext, max_update_period: u32) -> App {
    let scene = (scenes::find("cornell").expect("cornell").build)();
    let volume = DdgiVolume {
        bounds: scenes::find("cornell").expect("cornell").gi_box(),
        probe_counts: Some(UVec3::splat(4)),
        rays_per_probe: 64,
        adaptive: ddgi::DdgiAdaptive { max_update_period, ..ddgi::DdgiAdaptive::on() },
        ..Default::default()
    };
    let settings = HeadlessSettings { width: 48, height: 36, frames: 1, ..Default::default() };
    scene_app(gpu, scene, &settings, |app| use_ddgi(app, volume, DdgiOutput::Full)).expect("app")
}

fn calm_period(app: &App) -> (u32, bool) {
    let (_, v) = app.world().resource::<DdgiGpuVolumes>().volumes.first().expect("a volume");
    (v.calm.period, v.updates_this_frame)
}

/// The volume's atlases and probe data as the GPU holds them, bit for bit.
struct Snapshot {
    irradiance: Vec<u8>,
    distance: Vec<u8>,
    probes: Vec<DdgiProbeData>,
}

fn snapshot(gpu: &GpuContext, world: &World) -> Snapshot {
    let volumes = world.resource::<DdgiGpuVolumes>();
    let (_, v) = volumes.volumes.first().expect("a volume");
    Snapshot {
        irradiance: read_texture(gpu, &v.irradiance),
        distance: read_texture(gpu, &v.distance),
        probes: bytemuck::pod_collect_to_vec(&read_buffer(gpu, &v.probes)),
    }
}

fn control(app: &mut App) -> Mut<'_, DdgiUpdateControl> {
    app.world_mut().resource_mut::<DdgiUpdateControl>()
}

#[test]
fn paused_probes_keep_their_maps_and_a_step_is_one_update() {
    let Some(gpu) = gpu("paused_probes_keep_their_maps_and_a_step_is_one_update") else { return };
    let mut app = cornell_app(&gpu);
    run_frames(&mut app, 4, |_, _| {});
    control(&mut app).set_paused(true);
    run_frames(&mut app, 1, |_, _| {});
    let paused = snapshot(&gpu, app.world());
    run_frames(&mut app, 3, |_, _| {});
    let still = snapshot(&gpu, app.world());
    assert!(paused.irradiance == still.irradiance && paused.distance == still.distance, "a paused volume's atlases changed");
    let updates = |s: &Snapshot| s.probes.iter().map(|p| p.updates).collect::<Vec<_>>();
    assert_eq!(updates(&paused), updates(&still), "a paused volume's probes updated");
    let timings = app.world().resource::<engine::render::FrameTimings>();
    let last = timings.frames.last().expect("a frame");
    assert!(!last.passes.iter().any(|p| p.label == "ddgi_trace" && p.ran), "a paused volume traced rays");

    // One step: exactly one more update of every active probe, then paused again.
    control(&mut app).step();
    run_frames(&mut app, 1, |_, _| {});
    let stepped = snapshot(&gpu, app.world());
    assert!(stepped.irradiance != still.irradiance, "the step did not update the maps");
    let mut advanced = 0;
    for (i, (before, after)) in still.probes.iter().zip(&stepped.probes).enumerate() {
        let delta = after.updates - before.updates;
        if before.state & PROBE_INACTIVE == 0 {
            assert_eq!(delta, 1, "active probe {i} updated {delta} times in one step");
            advanced += 1;
        } else {
            assert!(delta <= 1, "inactive probe {i} updated {delta} times in one step");
        }
    }
    assert!(advanced > 0, "no probe is active");
    run_frames(&mut app, 2, |_, _| {});
    let after = snapshot(&gpu, app.world());
    assert!(after.irradiance == stepped.irradiance && updates(&after) == updates(&stepped), "the volume kept updating after one step");

    // Resumed, it updates again.
    control(&mut app).set_paused(false);
    run_frames(&mut app, 1, |_, _| {});
    assert!(snapshot(&gpu, app.world()).irradiance != after.irradiance, "the resumed volume did not update");
}

#[test]
fn a_calm_volume_skips_updates_and_a_light_change_updates_it_at_once() {
    let Some(gpu) = gpu("a_calm_volume_skips_updates_and_a_light_change_updates_it_at_once") else { return };
    let mut app = adaptive_cornell_app(&gpu, 4);
    // The still box settles and its volume's period grows past 1.
    run_frames(&mut app, 1, |_, _| {});
    let mut frames = 1;
    while calm_period(&app).0 < 2 {
        run_frames(&mut app, 1, |_, _| {});
        frames += 1;
        assert!(frames < 400, "the volume of a still scene was not calm after {frames} frames");
    }
    eprintln!("calm after {frames} frames");
    // Then run to its full period, and to a frame that updated: the next one is left out.
    run_frames(&mut app, 120, |_, _| {});
    assert_eq!(calm_period(&app).0, 4, "the period did not reach max_update_period");
    while !calm_period(&app).1 {
        run_frames(&mut app, 1, |_, _| {});
    }
    let before = snapshot(&gpu, app.world());
    run_frames(&mut app, 1, |_, _| {});
    assert!(!calm_period(&app).1, "a calm volume at period 4 updated two frames in a row");
    let skipped = snapshot(&gpu, app.world());
    assert!(skipped.irradiance == before.irradiance && skipped.distance == before.distance, "a frame left out changed the maps");
    let updates = |s: &Snapshot| s.probes.iter().map(|p| (p.updates, p.rest)).collect::<Vec<_>>();
    assert_eq!(updates(&skipped), updates(&before), "a frame left out moved the probes' updates or rests");
    // The frame timings show it: the trace left out, 0 rays traced, 4 frames between updates.
    let timings = app.world().resource::<engine::render::FrameTimings>();
    let left_out: Vec<u64> =
        timings.frames.iter().filter(|f| f.passes.iter().any(|p| p.label == "ddgi_trace" && !p.ran)).map(|f| f.frame).collect();
    assert!(left_out.len() > 20, "only {} frames left the update out", left_out.len());
    // (A frame's count is recorded at the next frame: the last one has none yet.)
    let rays = timings.counter("ddgi_rays");
    let last = timings.frames.last().map_or(0, |f| f.frame);
    for frame in left_out.iter().filter(|&&f| f < last) {
        let count = rays.iter().find(|(f, _)| f == frame).map(|(_, r)| *r);
        assert_eq!(count, Some(0.0), "frame {frame} left the update out but reports {count:?} rays");
    }
    assert!(timings.counter("ddgi_update_period").iter().any(|(_, p)| *p == 4.0), "no frame reports 4 frames between updates");

    // The lamp dims to a tenth on a frame the period would leave out: that frame updates, the
    // period is 1 again and the maps darken at once.
    let world = app.world_mut();
    let mut lights = world.query::<&mut engine::scene::PointLight>();
    for mut light in lights.iter_mut(world) {
        light.intensity *= 0.1;
    }
    run_frames(&mut app, 1, |_, _| {});
    assert_eq!(calm_period(&app), (1, true), "the frame the light changed did not update, or the period stayed");
    let changed = snapshot(&gpu, app.world());
    assert!(changed.irradiance != skipped.irradiance, "the maps did not respond to the light in the frame it changed");
    // And the volume keeps updating every frame while it follows the change.
    for _ in 0..4 {
        run_frames(&mut app, 1, |_, _| {});
        assert_eq!(calm_period(&app), (1, true), "the volume skipped a frame while following the change");
    }
    let darker = snapshot(&gpu, app.world());
    let mean = |s: &Snapshot| {
        let texels: &[u16] = bytemuck::cast_slice(&s.irradiance);
        // Stored as E^(1/gamma): the mean irradiance in W/m².
        let gamma = f64::from(ddgi::gpu::IRRADIANCE_GAMMA);
        texels.iter().map(|&h| f64::from(half_to_f32(h)).powf(gamma)).sum::<f64>() / texels.len() as f64
    };
    assert!(mean(&darker) < 0.97 * mean(&skipped), "irradiance {} after the lamp dimmed, {} before", mean(&darker), mean(&skipped));
}

/// A half float's value (the atlases' format).
fn half_to_f32(h: u16) -> f32 {
    let (sign, exponent, mantissa) = ((h >> 15) & 1, i32::from((h >> 10) & 0x1f), f32::from(h & 0x3ff));
    let magnitude = match exponent {
        0 => mantissa * 2f32.powi(-24),
        31 => f32::INFINITY,
        e => (1.0 + mantissa / 1024.0) * 2f32.powi(e - 15),
    };
    if sign == 1 { -magnitude } else { magnitude }
}

#[test]
fn at_period_one_the_calm_machinery_changes_nothing() {
    // With max_update_period 1 the volume updates at every frame, as before the calm period
    // existed; and at 4, before the volume is calm, its output is the same bit for bit: the
    // calm state draws no random numbers and moves no counter of the update.
    let Some(gpu) = gpu("at_period_one_the_calm_machinery_changes_nothing") else { return };
    let mut one = adaptive_cornell_app(&gpu, 1);
    let mut four = adaptive_cornell_app(&gpu, 4);
    run_frames(&mut one, 12, |_, _| {});
    run_frames(&mut four, 12, |_, _| {});
    for app in [&one, &four] {
        let timings = app.world().resource::<engine::render::FrameTimings>();
        assert!(timings.frames.len() > 5, "timings came back");
        assert!(
            timings.frames.iter().all(|f| f.passes.iter().any(|p| p.label == "ddgi_trace" && p.ran)),
            "a frame left the update out before the volume was calm"
        );
    }
    let (a, b) = (snapshot(&gpu, one.world()), snapshot(&gpu, four.world()));
    assert!(a.irradiance == b.irradiance && a.distance == b.distance, "the atlases differ");
    assert_eq!(a.probes, b.probes, "the probe states differ");
    // Period 1 never skips, however calm: 200 frames of the still box.
    run_frames(&mut one, 200, |_, _| {});
    let timings = one.world().resource::<engine::render::FrameTimings>();
    assert!(timings.frames.iter().all(|f| f.passes.iter().any(|p| p.label == "ddgi_trace" && p.ran)), "period 1 left an update out");
    assert_eq!(calm_period(&one), (1, true));
}

#[test]
fn a_reset_volume_equals_a_fresh_one() {
    let Some(gpu) = gpu("a_reset_volume_equals_a_fresh_one") else { return };
    let mut app = cornell_app(&gpu);
    run_frames(&mut app, 6, |_, _| {});
    let entity = app.world().resource::<DdgiGpuVolumes>().volumes[0].0;
    let old_probes: Vec<Entity> = app.world().resource::<DdgiGpuVolumes>().volumes[0].1.probe_entities.clone();
    control(&mut app).reset(entity);
    // The reset happens in the next frame's prepare, which updates the new volume once.
    run_frames(&mut app, 3, |_, _| {});
    let reset = snapshot(&gpu, app.world());
    let mut fresh_app = cornell_app(&gpu);
    run_frames(&mut fresh_app, 3, |_, _| {});
    let fresh = snapshot(&gpu, fresh_app.world());
    assert!(reset.irradiance == fresh.irradiance, "the reset volume's irradiance differs from a fresh volume's after as many frames");
    assert!(reset.distance == fresh.distance, "the reset volume's distances differ from a fresh volume's after as many frames");
    assert_eq!(reset.probes, fresh.probes, "the reset volume's probe states differ from a fresh volume's");
    // Its probe entities were spawned again, the old ones despawned.
    let world = app.world_mut();
    let count = world.query::<&DdgiProbe>().iter(world).count();
    assert_eq!(count, 64, "{count} probe entities after the reset");
    assert!(old_probes.iter().all(|e| world.get_entity(*e).is_err()), "the old probe entities survived the reset");
}

#[test]
fn state_counts_and_gpu_memory_add_up() {
    let Some(gpu) = gpu("state_counts_and_gpu_memory_add_up") else { return };
    let mut app = cornell_app(&gpu);
    run_frames(&mut app, 8, |_, _| {});
    let world = app.world_mut();
    let states: Vec<ddgi::DdgiProbeState> = world.query::<&DdgiProbe>().iter(world).map(|p| p.state).collect();
    let volumes = world.resource::<DdgiGpuVolumes>();
    let v = &volumes.volumes[0].1;
    let counts = v.probe_state_counts();
    assert_eq!(counts.active + counts.inactive, 64);
    assert_eq!(counts.inactive as usize, states.iter().filter(|s| **s == ddgi::DdgiProbeState::Inactive).count(), "{counts:?}");
    assert_eq!(counts.rays, v.probe_data.iter().map(|p| u64::from(p.ray_count)).sum::<u64>());
    assert!(counts.rays > 0 && counts.pinned == 0, "{counts:?}");

    // The memory is every buffer and atlas the layout sizes, and the few fixed-size ones.
    let sizes = v.layout.sizes;
    let resources: std::collections::HashMap<&str, u64> = v.gpu_resources().into_iter().collect();
    let atlas = |size: glam::UVec2| u64::from(size.x) * u64::from(size.y) * 8;
    let expected = [
        ("ddgi_probes", sizes.probes),
        ("ddgi_rays", sizes.rays),
        ("ddgi_radiance", sizes.rays),
        ("ddgi_hits", sizes.hits.max(16)),
        ("ddgi_irradiance_history", sizes.irradiance_history),
        ("ddgi_distance_history", sizes.distance_history),
        ("ddgi_blocks", sizes.blocks.max(16)),
        ("ddgi_updated", sizes.probe_words),
        ("ddgi_lit", sizes.probe_words),
        ("ddgi_counters", size_of::<DdgiCounters>() as u64),
        ("ddgi_wake", u64::from(ddgi::gpu::MAX_WAKE_BOXES) * 32),
        ("ddgi_irradiance", atlas(v.layout.irradiance_atlas)),
        ("ddgi_distance", atlas(v.layout.distance_atlas)),
    ];
    for (name, bytes) in expected {
        assert_eq!(resources.get(name), Some(&bytes), "{name}");
    }
    assert_eq!(resources.len(), expected.len() + 1, "the uniform and the listed resources: {resources:?}");
    assert_eq!(v.memory_bytes(), resources.values().sum::<u64>());
    assert!(v.memory_bytes() > sizes.probes + 2 * sizes.rays + sizes.irradiance_history);
}

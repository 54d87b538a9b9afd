//! `play --scene open_world`: the open world's tour (`scenes::open::tour_at`) — out of the house,
//! across the yard, 500 m into the forest and back — walked by the camera at a steady pace, lit by
//! DDGI's camera-following cascades; in a window, or headless (`--headless`: PNGs every `--every`
//! frames and the GPU time of every frame in `walk.csv`, through `lab::walk`).

use bevy_app::{App, Update};
use bevy_ecs::prelude::*;
use engine::app::Time;
use engine::gpu::GpuContext;
use engine::render::{RenderSize, Sky};
use engine::scene::{Camera, SceneDescription, Transform};
use engine::window::{WindowContext, WindowHooks};
use glam::{UVec3, Vec3};

/// Walking pace of the tour, metres per second.
pub const TOUR_SPEED: f32 = 1.5;
/// The sky's radiance over the open world (a pale blue, W/(m²·sr)): its entry's walk sky.
pub const OPEN_SKY: Vec3 = scenes::OPEN_WORLD_SKY;

/// Cascades of the tour unless `--cascades` says otherwise: 8 of 16×8×16 reach 1.5 km from the
/// camera, so no pixel of the world is left to the sky light (BENCHMARKS.md: 1.48 ms a frame of
/// every DDGI pass at 1920×1080 on an H200; 4 cascades leave the distance to the sky light, 2.5 ms).
pub const TOUR_CASCADES: u32 = 8;

/// The cascades of the tour: `count` of 16×8×16 probes, the finest 1.5 m apart.
pub fn tour_cascades(count: u32, rays: u32, adaptive: bool) -> ddgi::DdgiCascades {
    let volume = ddgi::DdgiVolume {
        rays_per_probe: rays,
        warm_up: true,
        adaptive: ddgi::DdgiAdaptive {
            enabled: adaptive,
            min_rays: ddgi::DdgiAdaptive::default().min_rays.min(rays),
            ..Default::default()
        },
        ..Default::default()
    };
    ddgi::DdgiCascades { count: Some(count.max(1)), probe_counts: UVec3::new(16, 8, 16), spacing: 1.5, volume, ..Default::default() }
}

/// Puts the camera on the tour, `TOUR_SPEED` × the time walked so far.
fn walk_the_tour(time: Res<Time>, mut cameras: Query<&mut Transform, With<Camera>>) {
    let (eye, forward) = scenes::open::tour_at(time.elapsed_seconds as f32 * TOUR_SPEED);
    for mut t in &mut cameras {
        *t = Transform::from_translation(eye).looking_at(eye + forward * 10.0 - Vec3::Y, Vec3::Y);
    }
}

/// Sets `app` up for the tour: the sky, the cascades and the walking camera (the scene is spawned
/// by the caller).
pub fn setup_tour(app: &mut App, cascades: ddgi::DdgiCascades) {
    app.insert_resource(Sky::Uniform(OPEN_SKY));
    // A terminal bar while the forest's BLASes build.
    lab::progress::show_blas_builds(app);
    ddgi::use_ddgi_cascades(app, cascades, ddgi::DdgiOutput::Full);
    app.add_systems(Update, walk_the_tour);
}

/// The tour in a window.
pub struct TourWindow {
    pub scene: SceneDescription,
    pub cascades: ddgi::DdgiCascades,
}

impl WindowHooks for TourWindow {
    fn build(&mut self, window: &mut WindowContext) -> Result<(), String> {
        setup_tour(&mut window.app, self.cascades.clone());
        // The DDGI overlay (F1): every cascade selectable.
        window.app.add_plugins(ddgi_overlay::DdgiOverlayPlugin);
        self.scene.clone().spawn(window.app.world_mut());
        Ok(())
    }
}

/// The tour headless: `frames` frames at 60 per second, a PNG every `every` frames into `out`,
/// and walk.csv. Returns the mean DDGI GPU ms per frame.
pub fn run_tour_headless(
    gpu: &GpuContext,
    scene: SceneDescription,
    cascades: ddgi::DdgiCascades,
    size: RenderSize,
    frames: u32,
    every: u32,
    out: &std::path::Path,
) -> Result<lab::walk::WalkReport, String> {
    let config = lab::eval::Config::ddgi_cascades(&cascades);
    let options = lab::walk::WalkOptions {
        speed: TOUR_SPEED,
        warmup: 0,
        sky: OPEN_SKY,
        every: (every > 0).then_some(every),
        ..lab::walk::WalkOptions::new(config, lab::walk::WalkPath::Tour(scenes::open::tour_at), size, frames)
    };
    lab::walk::walk(gpu, scene, &options, Some(out))
}

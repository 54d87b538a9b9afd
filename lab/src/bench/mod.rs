//! `game_demo bench`'s measurements: closest-hit throughput of probe-like rays (GPU timestamps of
//! the trace pass alone: [`trace`], with the bench's own kernel in [`kernel`]), the CPU cost of
//! keeping the TLAS up to date when instances move ([`tlas`]), DDGI's probe update per grid × rays
//! cell ([`probe_update`]) and its probe classification against an independent test
//! ([`classify`]).

mod classify;
mod kernel;
mod probe_update;
mod tlas;
mod trace;

use engine::app::run_headless;
use engine::bevy_app::App;
use engine::gpu::GpuContext;
use engine::render::RenderSize;
use engine::scene::SceneDescription;
use glam::DVec3;

pub use classify::{ClassificationCheck, classification_check};
pub use kernel::{MAX_WORKGROUP_PACKET, PacketScope, RT_STACK_SIZE, RayOrder, SHADERS, TraceVariant, coherent_ray_order};
pub use probe_update::{DDGI_UPDATE_PASSES, DdgiCell, ddgi_throughput};
pub use tlas::{TlasBuild, TlasGpuRefitCost, TlasUpdateCost, flat_rebuild_cost, tlas_build, tlas_gpu_refit_cost, tlas_update_cost};
pub use trace::{
    BenchHit, TraceCell, TraversalWork, closest_hits, hit_distances, trace_throughput, trace_throughput_compared, traversal_work,
};

/// Probe grids and rays per probe of the published DDGI throughput tables.
pub const GRIDS: [[u32; 3]; 4] = [[16, 8, 16], [32, 8, 32], [32, 16, 32], [32, 32, 32]];
pub const RAYS: [u32; 4] = [32, 64, 128, 256];
/// Numbers of moving instances for the TLAS update measurement.
pub const MOVING: [usize; 4] = [1, 100, 1_000, 10_000];

/// A headless app with the scene prepared (BLASes built, TLAS uploaded).
pub fn prepared_app(gpu: &GpuContext, scene: SceneDescription) -> App {
    prepared_app_with(gpu, scene, engine::rt::BlasBuildQuality::default())
}

/// [`prepared_app`] with BLASes built at `quality`.
pub fn prepared_app_with(gpu: &GpuContext, scene: SceneDescription, quality: engine::rt::BlasBuildQuality) -> App {
    let mut app = engine::headless::headless_app(gpu, RenderSize { width: 8, height: 8 }, 1.0 / 60.0);
    app.insert_resource(quality);
    crate::progress::show_blas_builds(&mut app);
    scene.spawn(app.world_mut());
    run_headless(&mut app, 1);
    app
}

/// The world-space bounds of a scene's geometry, its placement ([`SceneDescription::origin`])
/// included: where the bench spreads its probes.
pub fn world_bounds(scene: &SceneDescription) -> Option<(DVec3, DVec3)> {
    scene.bounds().map(|(lo, hi)| (scene.origin + lo.as_dvec3(), scene.origin + hi.as_dvec3()))
}

/// The median of `v` (NaN when it is empty).
fn median(mut v: Vec<f64>) -> f64 {
    crate::median(&mut v).unwrap_or(f64::NAN)
}

//! A progressive GPU path tracer: the project's ground truth for judging DDGI.
//!
//! Each frame adds [`PathTraceSettings::samples_per_frame`] paths per pixel to a float
//! accumulation buffer; the image is their mean, so it converges as frames go by, and starts over
//! when the camera, an instance or a light changes. Paths use the engine's ray-tracing core
//! (`shaders/ray_tracing.inc.wgsl`): Lambertian surfaces with base-colour textures, emissive
//! surfaces found by the paths, punctual lights by next-event estimation with shadow rays,
//! cosine-weighted bounces, Russian roulette after three bounces (unbiased, so the bounce count is
//! unbounded unless [`PathTraceSettings::max_bounces`] caps it), seeds derived from pixel, sample
//! index and [`PathTraceSettings::seed`] (the same settings give the same image).
//!
//! Add [`PathTracePlugin`] and set `FrameScript("pathtrace")` to render with it.

#![warn(missing_docs)]

use std::sync::Arc;

use bevy_app::{App, Plugin};
use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::graph::Bind;
use engine::render::gpu_scene::flush_uploads;
use engine::render::gpu_types::{GpuLight, ViewUniform};
use engine::render::{CameraFrame, RenderSize, frame_script_is};
use engine::shader::{Program, compute_program};
use engine::wgpu;

/// The name of the path tracer's frame script.
pub const FRAME_SCRIPT: &str = "pathtrace";

/// Path tracing settings.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct PathTraceSettings {
    /// Paths per pixel added each frame. More converges faster per frame and costs proportionally
    /// more GPU time per frame.
    pub samples_per_frame: u32,
    /// Largest number of surface interactions of a path; 0 leaves it to Russian roulette
    /// (unbiased). A cap biases the image darker and bounds the cost of long paths.
    pub max_bounces: u32,
    /// Seed of the random sequences; the same seed gives the same image.
    pub seed: u32,
}

impl Default for PathTraceSettings {
    fn default() -> Self {
        Self { samples_per_frame: 4, max_bounces: 0, seed: 0x5eed }
    }
}

/// How many paths per pixel the current image holds.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PathTraceProgress {
    /// Paths per pixel accumulated since the image last started over.
    pub samples: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PathTraceParams {
    sample_offset: u32,
    samples: u32,
    max_bounces: u32,
    seed: u32,
}

#[derive(Resource)]
struct PathTraceState {
    program: Arc<Program<wgpu::ComputePipeline>>,
    params: wgpu::Buffer,
    accumulation: wgpu::Buffer,
    size: RenderSize,
    last: Option<(ViewUniform, Vec<GpuLight>)>,
}

/// Adds the path tracer to `app` with `settings` and makes it the active frame script.
pub fn use_path_tracer(app: &mut App, settings: PathTraceSettings) {
    app.insert_resource(settings).insert_resource(engine::render::FrameScript(FRAME_SCRIPT)).add_plugins(PathTracePlugin);
}

/// The path tracer's WGSL (`plugins/pathtrace/shaders/`), registered by [`PathTracePlugin`].
pub const SHADERS: &[engine::shader::ShaderModule] = &[("pathtrace.wgsl", include_str!("../shaders/pathtrace.wgsl"))];

/// Adds the `"pathtrace"` frame script.
pub struct PathTracePlugin;

impl Plugin for PathTracePlugin {
    fn build(&self, app: &mut App) {
        let Some(gpu) = app.world().get_resource::<GpuContext>().cloned() else {
            log::warn!("PathTracePlugin needs the engine's RenderPlugin (a GPU); path tracing is off");
            return;
        };
        let program =
            match engine::shader::register(SHADERS).and_then(|()| compute_program(&gpu.device, "pathtrace.wgsl", "main", "pathtrace")) {
                Ok(p) => Arc::new(p),
                Err(e) => {
                    log::warn!("path tracer shader failed, path tracing is off: {e}");
                    return;
                }
            };
        let size = *app.world().resource::<RenderSize>();
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pathtrace_params"),
            size: size_of::<PathTraceParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let accumulation = accumulation_buffer(&gpu, size);
        app.init_resource::<PathTraceSettings>()
            .init_resource::<PathTraceProgress>()
            .insert_resource(PathTraceState { program, params, accumulation, size, last: None })
            .add_systems(engine::app::Render, render_path_traced_frame.run_if(frame_script_is(FRAME_SCRIPT)).after(flush_uploads));
    }
}

fn accumulation_buffer(gpu: &GpuContext, size: RenderSize) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pathtrace_accumulation"),
        size: u64::from(size.width.max(1)) * u64::from(size.height.max(1)) * 16,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}

/// Render stage: the `"pathtrace"` frame script — path tracing into the HDR output, then the
/// engine's tonemap and present.
fn render_path_traced_frame(
    mut frame: CameraFrame,
    settings: Res<PathTraceSettings>,
    mut state: ResMut<PathTraceState>,
    mut progress: ResMut<PathTraceProgress>,
) {
    let size = frame.size();
    if state.size != size {
        state.accumulation = accumulation_buffer(&frame.gpu, size);
        state.size = size;
        state.last = None;
    }
    // Start over when what the image shows has changed.
    let now = (frame.scene.view_uniform, frame.scene.light_data.clone());
    let view_changed = state.last.as_ref().is_none_or(|(v, l)| {
        // What the path tracer reads of the view: the frame counter, the raster's jitter and the
        // last frame's camera are not part of it.
        let mut v = *v;
        v.frame = now.0.frame;
        v.jitter = now.0.jitter;
        v.previous_clip_from_world = now.0.previous_clip_from_world;
        v != now.0 || *l != now.1
    });
    if view_changed || !frame.scene.instance_changes().dirty.is_empty() {
        progress.samples = 0;
    }
    state.last = Some(now);
    let samples = settings.samples_per_frame.max(1);
    let params = PathTraceParams { sample_offset: progress.samples, samples, max_bounces: settings.max_bounces, seed: settings.seed };
    frame.gpu.queue.write_buffer(&state.params, 0, bytemuck::bytes_of(&params));
    progress.samples += samples;

    let mut script = frame.begin();
    {
        let params = script.graph.import_buffer("pathtrace_params", &state.params);
        let mut accumulation = script.graph.import_buffer("pathtrace_accumulation", &state.accumulation);
        let mut pass = script.graph.add_pass("pathtrace");
        let program = state.program.clone();
        let group0 = pass.read_named(&program.bindings, 0);
        pass.read(&accumulation);
        let group1 = vec![
            ("path_params", Bind::buffer(pass.read(&params))),
            ("path_accumulation", Bind::buffer(pass.write(&mut accumulation))),
            ("path_radiance_out", Bind::texture(pass.write(&mut script.hdr))),
        ];
        pass.compute(program, vec![group0, group1], (size.width.div_ceil(8), size.height.div_ceil(8)));
        // The accumulation lives on into the next frame.
        script.graph.export(&accumulation);
    }
    frame.finish(script);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shader_folder_is_registered_and_the_params_match_naga_layout() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        engine::shader::check_shader_folder(&dir, SHADERS).unwrap_or_else(|e| panic!("{e}"));
        engine::shader::register(SHADERS).expect("register");
        let host = engine::gpu_struct_layout!(PathTraceParams in "pathtrace.wgsl" { sample_offset, samples, max_bounces, seed });
        engine::shader::check_struct_layout(&host).unwrap_or_else(|e| panic!("{e}"));
    }
}

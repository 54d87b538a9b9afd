//! Auto-exposure from a luminance histogram: `exposure_histogram` sorts every pixel's luminance
//! into [`HISTOGRAM_BINS`] bins of log₂ luminance, `exposure_adapt` averages the bins between two
//! percentiles (the darkest and brightest pixels left out), turns the mean into an exposure value
//! (EV100), and moves the camera's exposure towards it at a limited speed; the tonemap pass reads
//! it. `image.exr` and every metric read the linear radiance before exposure, so what `eval`
//! measures does not move with it.
//!
//! Settings: [`AutoExposure`] on the camera (or [`DefaultAutoExposure`] for every camera); off
//! without one: the camera's own `exposure` is used, as before.

use bevy_ecs::prelude::*;
use bytemuck::{Pod, Zeroable};

use super::CameraFrame;
use crate::app::Time;
use crate::gpu::{GpuContext, dispatch};
use crate::graph::{Handle, RenderGraph, Texture as GraphTexture};
use crate::scene::Camera;

/// Bins of the luminance histogram (and threads of the adapting pass).
pub const HISTOGRAM_BINS: u32 = 64;

/// Auto-exposure of a camera (a component): the exposure follows the scene's brightness, so that
/// walking from sunlight into a room shows both. Costs two compute passes (a histogram of every
/// pixel, then 64 threads).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct AutoExposure {
    /// The range of exposure values (EV100) it may choose: darker scenes than `min_ev100` stay dark,
    /// brighter than `max_ev100` burn.
    pub min_ev100: f32,
    /// The largest exposure value (EV100) it may choose: scenes brighter than it burn.
    pub max_ev100: f32,
    /// Luminance below and above these shares of the pixels does not count (0.1 and 0.9: the
    /// darkest 10% — shadows, the night sky — and the brightest 10% — the sun, lamps — leave the
    /// exposure alone).
    pub low_percentile: f32,
    /// The share of the pixels, darkest first, above which luminance does not count; see
    /// `low_percentile`.
    pub high_percentile: f32,
    /// Exposure compensation in stops: positive brightens.
    pub compensation: f32,
    /// How fast the exposure follows, in stops per second, when the scene gets brighter and
    /// darker (eyes adapt to light faster than to dark).
    pub speed_brighten: f32,
    /// How fast the exposure follows a scene that gets darker, in stops per second.
    pub speed_darken: f32,
}

impl Default for AutoExposure {
    fn default() -> Self {
        Self {
            min_ev100: -8.0,
            max_ev100: 16.0,
            low_percentile: 0.1,
            high_percentile: 0.9,
            compensation: 0.0,
            speed_brighten: 3.0,
            speed_darken: 1.0,
        }
    }
}

/// The auto-exposure of cameras that have no [`AutoExposure`] of their own (a resource).
#[derive(Resource, Clone, Copy, Debug, PartialEq, Default)]
pub struct DefaultAutoExposure(pub AutoExposure);

/// `ExposureParams` of the exposure shaders: the fields of [`AutoExposure`] and the frame's step.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct ExposureParams {
    pub min_ev100: f32,
    pub max_ev100: f32,
    pub low_percentile: f32,
    pub high_percentile: f32,
    pub compensation: f32,
    pub speed_brighten: f32,
    pub speed_darken: f32,
    /// Seconds since the last frame (the exposure jumps to its target on its first frame).
    pub delta_seconds: f32,
}

/// The host mirror of `exposure.inc.wgsl`'s struct, for the layout test ([`crate::gpu_structs`]).
pub(crate) fn gpu_layouts() -> Vec<crate::shader::HostStruct> {
    vec![crate::gpu_struct_layout!(ExposureParams in "exposure.inc.wgsl" {
        min_ev100, max_ev100, low_percentile, high_percentile, compensation, speed_brighten, speed_darken, delta_seconds
    })]
}

/// The histogram, the current exposure (on the GPU, read by the tonemapper) and this frame's
/// settings.
#[derive(Resource)]
pub struct ExposureState {
    params: wgpu::Buffer,
    histogram: wgpu::Buffer,
    /// `[ev100, exposure, valid, _]`.
    exposure: wgpu::Buffer,
    /// This frame's settings (the first camera's), `None` when off.
    pub settings: Option<AutoExposure>,
}

/// The EV100 at which the mean log₂ luminance `log_luminance` shows as middle grey on a sensor of
/// ISO 100 (calibration K = 12.5): EV100 = log₂(L · 100 / 12.5).
pub fn ev100_for_luminance(log_luminance: f32) -> f32 {
    log_luminance + (100.0f32 / 12.5).log2()
}

impl ExposureState {
    /// The buffers, with no settings yet (off until [`prepare_exposure`] reads a camera's).
    pub fn new(gpu: &GpuContext) -> Self {
        let buffer = |label, size, usage| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false })
        };
        use wgpu::BufferUsages as B;
        Self {
            params: buffer("exposure_params", size_of::<ExposureParams>() as u64, B::UNIFORM | B::COPY_DST),
            histogram: buffer("exposure_histogram", u64::from(HISTOGRAM_BINS) * 4, B::STORAGE | B::COPY_DST),
            exposure: buffer("exposure", 16, B::STORAGE | B::COPY_DST | B::COPY_SRC),
            settings: None,
        }
    }

    /// The buffer `[ev100, exposure, valid, _]` the tonemapper reads.
    pub fn exposure_buffer(&self) -> &wgpu::Buffer {
        &self.exposure
    }
}

/// Prepare stage: the first camera's auto-exposure settings and this frame's time step.
pub fn prepare_exposure(
    gpu: Res<GpuContext>,
    time: Option<Res<Time>>,
    mut state: ResMut<ExposureState>,
    fallback: Option<Res<DefaultAutoExposure>>,
    cameras: Query<Option<&AutoExposure>, With<Camera>>,
) {
    let settings = match cameras.iter().next() {
        Some(Some(a)) => Some(*a),
        Some(None) => fallback.map(|f| f.0),
        None => None,
    };
    let finite = |v: f32, default: f32| if v.is_finite() { v } else { default };
    let d = AutoExposure::default();
    let Some(s) = settings else {
        state.settings = None;
        return;
    };
    let (lo, hi) = (finite(s.min_ev100, d.min_ev100), finite(s.max_ev100, d.max_ev100));
    let (low, high) =
        (finite(s.low_percentile, d.low_percentile).clamp(0.0, 1.0), finite(s.high_percentile, d.high_percentile).clamp(0.0, 1.0));
    let params = ExposureParams {
        min_ev100: lo.min(hi),
        max_ev100: hi.max(lo),
        low_percentile: low.min(high),
        high_percentile: high.max(low),
        compensation: finite(s.compensation, 0.0),
        speed_brighten: finite(s.speed_brighten, d.speed_brighten).max(0.0),
        speed_darken: finite(s.speed_darken, d.speed_darken).max(0.0),
        delta_seconds: finite(time.map_or(0.0, |t| t.delta_seconds as f32), 0.0).max(0.0),
    };
    gpu.queue.write_buffer(&state.params, 0, bytemuck::bytes_of(&params));
    state.settings = Some(s);
}

impl CameraFrame<'_> {
    /// With auto-exposure on: the histogram of `hdr`'s luminance and the exposure's adaptation;
    /// returns the exposure buffer for the tonemapper (`None`: the camera's own exposure).
    pub(super) fn add_auto_exposure(&self, graph: &mut RenderGraph, hdr: &Handle<GraphTexture>) -> Option<Handle<crate::graph::Buffer>> {
        let state = self.exposure.as_deref()?;
        state.settings?;
        let (histogram_program, adapt_program) = (self.pipelines.exposure_histogram.clone(), self.pipelines.exposure_adapt.clone());
        let params = graph.import_buffer("exposure_params", &state.params);
        let mut histogram = graph.import_buffer("exposure_histogram", &state.histogram);
        let mut exposure = graph.import_buffer("exposure", &state.exposure);
        let size = self.outputs.size;
        {
            let mut pass = graph.add_pass("exposure_histogram");
            let (input, params) = (pass.read(hdr), pass.read(&params));
            let out = pass.write(&mut histogram);
            let scene_reads = pass.read_named(&histogram_program.bindings, 0);
            pass.render(move |ctx| {
                ctx.encoder.clear_buffer(ctx.buffer(out), 0, None);
                let group0 = ctx.bind_group(&*histogram_program, 0, &scene_reads);
                let group1 = histogram_program.bind_group(
                    &ctx.gpu.device,
                    1,
                    &[
                        ("exposure_params", ctx.buffer(params).as_entire_binding()),
                        ("exposure_hdr", wgpu::BindingResource::TextureView(ctx.view(input))),
                        ("exposure_histogram", ctx.buffer(out).as_entire_binding()),
                    ],
                );
                dispatch(
                    ctx.encoder,
                    ctx.label,
                    &histogram_program.pipeline,
                    &[&group0, &group1],
                    (size.width.div_ceil(16), size.height.div_ceil(16)),
                );
            });
        }
        {
            let mut pass = graph.add_pass("exposure_adapt");
            let (input, params) = (pass.read(&histogram), pass.read(&params));
            pass.read(&exposure);
            let out = pass.write(&mut exposure);
            let scene_reads = pass.read_named(&adapt_program.bindings, 0);
            pass.render(move |ctx| {
                let group0 = ctx.bind_group(&*adapt_program, 0, &scene_reads);
                let group1 = adapt_program.bind_group(
                    &ctx.gpu.device,
                    1,
                    &[
                        ("exposure_params", ctx.buffer(params).as_entire_binding()),
                        ("exposure_histogram", ctx.buffer(input).as_entire_binding()),
                        ("exposure_state", ctx.buffer(out).as_entire_binding()),
                    ],
                );
                dispatch(ctx.encoder, ctx.label, &adapt_program.pipeline, &[&group0, &group1], (1, 1));
            });
        }
        graph.export(&exposure);
        Some(exposure)
    }
}

//! Temporal anti-aliasing (TAA) of the camera path: every frame rasterizes with a sub-pixel jitter
//! (a Halton sequence), and the `taa` pass blends the frame into a history of the frames before
//! it, reprojected by the G-buffer's motion vectors and clipped to the colours of the frame's
//! neighbourhood; `taa_output` writes the result, sharpened when asked, into the frame's radiance.
//! A still camera converges to the box-filtered image the path tracer converges to; the same
//! averaging smooths the probes' temporal noise.
//!
//! A frame script resolves it with [`CameraFrame::add_taa`] after the passes that light the image
//! (the engine's `"direct"` script and DDGI's do; the path tracer accumulates on its own and
//! does not jitter). Settings: [`TemporalAntiAliasing`] on the camera.

use bevy_ecs::prelude::*;
use bytemuck::{Pod, Zeroable};
use glam::Vec2;

use super::{CameraFrame, GBuffer, HDR_FORMAT, RenderSize, frame_texture, workgroups};
use crate::gpu::{GpuContext, dispatch};
use crate::graph::{Handle, RenderGraph, Texture as GraphTexture};
use crate::scene::{Camera, GlobalTransform};

/// Temporal anti-aliasing of a camera (a component). A camera without one takes
/// [`DefaultTemporalAntiAliasing`] if the app has it, else the default: on.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct TemporalAntiAliasing {
    /// Off: no jitter and no history; each frame shows as it was rendered (aliased edges, the
    /// probes' noise unfiltered). Costs two full-screen passes at 1920×1080 (see BENCHMARKS.md).
    pub enabled: bool,
    /// Most frames a pixel's history averages: a still camera's image becomes the mean of this
    /// many jittered samples per pixel, then an exponential average of weight 1/`max_samples`.
    /// More: smoother edges and less noise, slower to follow changes the neighbourhood clipping
    /// does not catch (lighting that changes slowly lags by about this many frames).
    pub max_samples: u32,
    /// Sharpening of the output, 0 (none) to 1: restores the detail that resampling the history
    /// blurs while the camera moves. Costs nothing when 0 beyond the output pass's copy.
    pub sharpness: f32,
    /// Set to discard the history at the next frame (a camera cut: the history no longer shows
    /// the same place); the engine clears it after that frame.
    pub reset: bool,
}

impl Default for TemporalAntiAliasing {
    fn default() -> Self {
        Self { enabled: true, max_samples: 16, sharpness: 0.0, reset: false }
    }
}

/// The temporal anti-aliasing of cameras that have no [`TemporalAntiAliasing`] of their own (a
/// resource: an app's default, e.g. off for every camera of a benchmark).
#[derive(Resource, Clone, Copy, Debug, PartialEq, Default)]
pub struct DefaultTemporalAntiAliasing(pub TemporalAntiAliasing);

impl TemporalAntiAliasing {
    /// Off.
    pub fn off() -> Self {
        Self { enabled: false, ..Default::default() }
    }
}

/// Length of the jitter sequence: positions 1–15 of the Halton (2, 3) sequence and the pixel centre.
pub const JITTER_SEQUENCE: u32 = 16;

/// The radical inverse of `index` in `base` (the Halton sequence's coordinate).
fn halton(mut index: u32, base: u32) -> f32 {
    let (mut result, mut f) = (0.0f32, 1.0f32);
    while index > 0 {
        f /= base as f32;
        result += f * (index % base) as f32;
        index /= base;
    }
    result
}

/// The sub-pixel offset (pixels, in (−½, ½), y down) of the `sample`-th frame since a reset: the
/// pixel centre first (so that a single frame renders as without TAA), then Halton (2, 3).
pub fn jitter(sample: u32) -> Vec2 {
    let k = sample % JITTER_SEQUENCE;
    if k == 0 { Vec2::ZERO } else { Vec2::new(halton(k, 2), halton(k, 3)) - 0.5 }
}

/// `TaaParams` of `taa.inc.wgsl`, which both TAA passes (`taa.wgsl`, `taa_output.wgsl`) include.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct TaaParams {
    /// Most samples a history pixel averages; past it the running mean is an exponential one.
    pub max_samples: f32,
    /// 0: no history (the first frame, a camera cut or a new size): the frame is taken as it is.
    pub history_valid: u32,
    /// Sharpening of the output (pass `taa_output`), 0–1.
    pub sharpness: f32,
    /// Padding to the WGSL layout.
    pub _pad: u32,
}

/// The host mirror of `taa.inc.wgsl`'s struct, for the layout test ([`crate::gpu_structs`]).
pub(crate) fn gpu_layouts() -> Vec<crate::shader::HostStruct> {
    vec![crate::gpu_struct_layout!(TaaParams in "taa.inc.wgsl" { max_samples, history_valid, sharpness, _pad })]
}

/// The TAA history (two textures: last frame's, read, and this frame's, written) and this frame's
/// settings, as the prepare stage found them on the first camera.
#[derive(Resource)]
pub struct TaaState {
    history: [wgpu::Texture; 2],
    /// The index of the history texture this frame writes.
    write: usize,
    params: wgpu::Buffer,
    size: RenderSize,
    /// Frames resolved since the history was last reset.
    sample: u32,
    /// Whether the last frame's script resolved TAA (wrote the history).
    resolved: bool,
    /// This frame's settings (the first camera's; off without a camera).
    pub settings: TemporalAntiAliasing,
    /// This frame's raster jitter in pixels (zero when off).
    pub jitter: Vec2,
    /// Whether the history holds earlier frames of this view.
    pub history_valid: bool,
}

fn history_texture(gpu: &GpuContext, size: RenderSize, label: &str) -> wgpu::Texture {
    use wgpu::TextureUsages as U;
    frame_texture(gpu, size, label, HDR_FORMAT, U::STORAGE_BINDING | U::TEXTURE_BINDING)
}

impl TaaState {
    /// Two empty history textures of `size` (no history yet) and the parameter buffer.
    pub fn new(gpu: &GpuContext, size: RenderSize) -> Self {
        Self {
            history: [history_texture(gpu, size, "taa_history_a"), history_texture(gpu, size, "taa_history_b")],
            write: 0,
            params: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("taa_params"),
                size: size_of::<TaaParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            size,
            sample: 0,
            resolved: false,
            settings: TemporalAntiAliasing::off(),
            jitter: Vec2::ZERO,
            history_valid: false,
        }
    }

    /// Frames resolved since the history was last reset (0 on a frame that starts it afresh).
    pub fn samples(&self) -> u32 {
        self.sample
    }
}

/// Prepare stage, before the view is written: takes the first camera's settings, clears its
/// `reset`, and decides this frame's jitter and whether the history is valid — not after a reset,
/// a resize, a frame whose script did not resolve TAA, or while TAA is off.
pub fn prepare_taa(
    gpu: Res<GpuContext>,
    size: Res<RenderSize>,
    mut state: ResMut<TaaState>,
    mut fallback: Option<ResMut<DefaultTemporalAntiAliasing>>,
    mut cameras: Query<(&Camera, &GlobalTransform, Option<&mut TemporalAntiAliasing>)>,
) {
    let state = &mut *state;
    let resolved_last = std::mem::take(&mut state.resolved);
    if resolved_last {
        state.write ^= 1;
        state.sample = state.sample.saturating_add(1);
    }
    let (settings, reset) = match cameras.iter_mut().next() {
        Some((_, _, Some(mut taa))) => {
            let reset = taa.reset;
            if reset {
                taa.reset = false;
            }
            (*taa, reset)
        }
        Some((_, _, None)) => match fallback.as_deref_mut() {
            Some(DefaultTemporalAntiAliasing(taa)) => (*taa, std::mem::take(&mut taa.reset)),
            None => (TemporalAntiAliasing::default(), false),
        },
        None => (TemporalAntiAliasing::off(), false),
    };
    if state.size != *size {
        *state = TaaState { settings: state.settings, ..TaaState::new(&gpu, *size) };
    }
    if reset || !resolved_last || !settings.enabled {
        state.sample = 0;
    }
    state.settings = settings;
    state.history_valid = state.sample > 0;
    state.jitter = if settings.enabled { jitter(state.sample) } else { Vec2::ZERO };
    let params = TaaParams {
        max_samples: settings.max_samples.max(1) as f32,
        history_valid: state.history_valid as u32,
        sharpness: if settings.sharpness.is_finite() { settings.sharpness.clamp(0.0, 1.0) } else { 0.0 },
        _pad: 0,
    };
    gpu.queue.write_buffer(&state.params, 0, bytemuck::bytes_of(&params));
}

impl CameraFrame<'_> {
    /// Temporal anti-aliasing of `hdr` (the frame's lit radiance, rendered with this frame's
    /// jitter): `taa` blends it into the history by `gbuffer`'s motion vectors, `taa_output`
    /// writes the result back into `hdr`. Nothing when the camera's TAA is off.
    pub fn add_taa(&mut self, graph: &mut RenderGraph, gbuffer: &GBuffer, hdr: &mut Handle<GraphTexture>) {
        let Some(state) = self.taa.as_deref_mut() else { return };
        if !state.settings.enabled {
            return;
        }
        state.resolved = true;
        let size = self.outputs.size;
        let (taa, output) = (self.pipelines.taa.clone(), self.pipelines.taa_output.clone());
        let previous = graph.import_texture("taa_history", &state.history[state.write ^ 1]);
        let mut resolved = graph.import_texture("taa_history_next", &state.history[state.write]);
        let params = graph.import_buffer("taa_params", &state.params);
        {
            let mut pass = graph.add_pass("taa");
            if !state.history_valid {
                pass.note("history reset: this frame as rendered");
            }
            let (current, history, motion, params) = (pass.read(hdr), pass.read(&previous), pass.read(&gbuffer.motion), pass.read(&params));
            let out = pass.write(&mut resolved);
            let scene_reads = pass.read_named(&taa.bindings, 0);
            pass.render(move |ctx| {
                let group0 = ctx.bind_group(&*taa, 0, &scene_reads);
                let [current, history, motion] = [current, history, motion].map(|t| wgpu::BindingResource::TextureView(ctx.view(t)));
                let group1 = taa.bind_group(
                    &ctx.gpu.device,
                    1,
                    &[
                        ("taa", ctx.buffer(params).as_entire_binding()),
                        ("taa_current", current),
                        ("taa_history", history),
                        ("gbuffer_motion", motion),
                        ("taa_history_out", wgpu::BindingResource::TextureView(ctx.view(out))),
                    ],
                );
                dispatch(ctx.encoder, ctx.label, &taa.pipeline, &[&group0, &group1], workgroups(size));
            });
        }
        {
            let mut pass = graph.add_pass("taa_output");
            if state.settings.sharpness > 0.0 {
                pass.note(&format!("sharpness {}", state.settings.sharpness));
            }
            let (input, params) = (pass.read(&resolved), pass.read(&params));
            let out = pass.write(hdr);
            let scene_reads = pass.read_named(&output.bindings, 0);
            pass.render(move |ctx| {
                let group0 = ctx.bind_group(&*output, 0, &scene_reads);
                let group1 = output.bind_group(
                    &ctx.gpu.device,
                    1,
                    &[
                        ("taa", ctx.buffer(params).as_entire_binding()),
                        ("taa_resolved", wgpu::BindingResource::TextureView(ctx.view(input))),
                        ("radiance_out", wgpu::BindingResource::TextureView(ctx.view(out))),
                    ],
                );
                dispatch(ctx.encoder, ctx.label, &output.pipeline, &[&group0, &group1], workgroups(size));
            });
        }
        // Next frame reads it.
        graph.export(&resolved);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_jitter_starts_at_the_pixel_centre_and_covers_the_pixel_evenly() {
        assert_eq!(jitter(0), Vec2::ZERO);
        assert_eq!(jitter(JITTER_SEQUENCE), Vec2::ZERO, "the sequence repeats");
        let points: Vec<Vec2> = (0..JITTER_SEQUENCE).map(jitter).collect();
        for p in &points {
            assert!(p.abs().max_element() < 0.5, "{p} outside the pixel");
        }
        // Every quadrant of the pixel gets its share (4 of 16 ± 1), and the mean is near the centre.
        for (sx, sy) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
            let n = points.iter().filter(|p| p.x * sx >= 0.0 && p.y * sy >= 0.0).count();
            assert!((3..=6).contains(&n), "quadrant ({sx}, {sy}): {n} points");
        }
        let mean = points.iter().copied().sum::<Vec2>() / points.len() as f32;
        assert!(mean.length() < 0.06, "mean {mean}");
        assert_eq!(halton(1, 2), 0.5);
        assert!((halton(5, 3) - 7.0 / 9.0).abs() < 1e-6);
    }
}

//! Tonemapping of the camera path: the `tonemap` pass multiplies the frame's linear radiance by
//! the exposure (the camera's, or the auto-exposure's when on, [`super::exposure`]), turns it into
//! display values by the [`DisplayTransform`] and writes them sRGB-encoded into the LDR output.
//! [`CameraFrame::finish`] adds it (with the auto-exposure's passes before it) to every frame.
//! Settings: [`DisplayTransform`], a resource.

use std::sync::Arc;

use bevy_ecs::prelude::*;

use super::{CameraFrame, workgroups};
use crate::gpu::{GpuContext, dispatch};
use crate::graph::{Handle, RenderGraph, Texture as GraphTexture};
use crate::shader::{Program, ShaderError, compute_program_with_constants};

/// How the `tonemap` pass turns exposed linear radiance into display values (a resource; the
/// default when absent). `image.exr` and every metric read the linear radiance before it, so the
/// choice changes what a person sees, not what `eval` measures.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DisplayTransform {
    /// Clamp to [0, 1], then sRGB: radiometric values shown as they are (what the golden images
    /// and `eval`'s tonemapper use); light over 1 burns to flat white.
    #[default]
    Clamp,
    /// AgX ([`crate::color::agx`]): highlights roll off into white and desaturate like film, shadows
    /// keep their detail; the filmic transform Blender 4 and Bevy offer. Costs a few dozen
    /// arithmetic operations a pixel.
    ///
    /// Chosen over Tony McMapface (Bevy's default) because it is analytic: a matrix, a log2 and a
    /// polynomial, with no 48³ lookup table to ship, load and bind as a 3D texture, so a CPU
    /// mirror tests it (monotone, 0 to 0, never NaN, `tests/camera_path.rs`) and any app gets it
    /// without an asset. Both give saturated highlights a path to white; McMapface keeps hues a
    /// little more faithfully, which a LUT could add later beside this variant.
    AgX,
}

/// The tonemap pass with each [`DisplayTransform`] (in the order of its variants), with the camera's
/// exposure (`[0]`) or the auto-exposure's (`[1]`).
pub(super) fn programs(gpu: &GpuContext) -> Result<[[Arc<Program<wgpu::ComputePipeline>>; 2]; 2], ShaderError> {
    let variant = |display: f64, auto: f64| {
        compute_program_with_constants(
            &gpu.device,
            "tonemap.wgsl",
            "main",
            "tonemap",
            &[("DISPLAY_TRANSFORM", display), ("AUTO_EXPOSURE", auto)],
        )
        .map(Arc::new)
    };
    Ok([[variant(0.0, 0.0)?, variant(0.0, 1.0)?], [variant(1.0, 0.0)?, variant(1.0, 1.0)?]])
}

impl CameraFrame<'_> {
    /// Tonemaps `hdr` into `ldr` (the frame's LDR output), after the auto-exposure's passes when it
    /// is on.
    pub(super) fn add_tonemap(&self, graph: &mut RenderGraph, hdr: &Handle<GraphTexture>, ldr: &mut Handle<GraphTexture>) {
        let auto_exposure = self.add_auto_exposure(graph, hdr);
        let (pipelines, size) = (&self.pipelines, self.size());
        let mut pass = graph.add_pass("tonemap");
        let input = pass.read(hdr);
        let out = pass.write(ldr);
        let display = self.display.as_deref().copied().unwrap_or_default();
        if display == DisplayTransform::AgX {
            pass.note("AgX display transform");
        }
        if auto_exposure.is_some() {
            pass.note("auto-exposure");
        }
        let program = pipelines.tonemap[display as usize][auto_exposure.is_some() as usize].clone();
        let exposure = auto_exposure.as_ref().map(|e| pass.read(e));
        // Without auto-exposure the shader reads no exposure buffer; the binding still needs one.
        let unused = self.exposure.as_deref().map(|e| e.exposure_buffer().clone());
        let scene_reads = pass.read_named(&program.bindings, 0);
        pass.render(move |ctx| {
            let group0 = ctx.bind_group(&*program, 0, &scene_reads);
            let exposure = match (exposure, &unused) {
                (Some(e), _) => Some(ctx.buffer(e).as_entire_binding()),
                (None, Some(b)) => Some(b.as_entire_binding()),
                (None, None) => None,
            };
            let mut entries = vec![
                ("hdr_in", wgpu::BindingResource::TextureView(ctx.view(input))),
                ("ldr_out", wgpu::BindingResource::TextureView(ctx.view(out))),
            ];
            entries.extend(exposure.map(|e| ("tonemap_exposure", e)));
            let group1 = program.bind_group(&ctx.gpu.device, 1, &entries);
            dispatch(ctx.encoder, ctx.label, &program.pipeline, &[&group0, &group1], workgroups(size));
        });
    }
}

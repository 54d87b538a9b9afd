//! Contact occlusion of the indirect light ([`DdgiContactOcclusion`]) and its half-resolution
//! pass `ddgi_contact_occlusion` (`DdgiFrame::add_contact_occlusion`).

use bevy_ecs::prelude::*;
use engine::graph::{Bind, Buffer as GraphBuffer, BufferDesc, Handle, RenderGraph};
use engine::render::{CameraFrame, GBuffer};
use engine::wgpu;

use crate::debug_view::DdgiOutput;
use crate::frame::DdgiFrame;

/// Contact occlusion of the indirect light: small-scale occlusion that probes a spacing apart
/// cannot resolve (the corner where a box meets the floor, the gap under a door) darkens DDGI's
/// indirect light — and only it — by the cosine-weighted share of `rays` rays from each pixel's
/// surface that travel `radius` without a hit (ray-traced ambient occlusion). The probes already
/// carry occlusion at larger scales, so the radius is tied to their spacing. The rays turn every
/// frame, so the temporal anti-aliasing accumulates them into a smooth result.
///
/// Cost: `rays` short rays a pixel at every pixel a volume lights, or, at half resolution (the
/// default), at one pixel of each 2×2 block (another each frame: pass `ddgi_contact_occlusion`), a
/// quarter of the rays, which the composite brings back to every pixel by depth and normal (pixels
/// whose block neighbours all lie on other surfaces trace their own). Off (`rays: 0`) by default:
/// the probes at the fitted spacing already hold most of this occlusion, and adding it again
/// darkened every evaluation scene (BENCHMARKS.md, `eval --experiments`).
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct DdgiContactOcclusion {
    /// Rays per traced pixel (0: off). More: less noise.
    pub rays: u32,
    /// How far an occluder may be, in world units; `None`: the smallest probe spacing of the
    /// volumes (the finest cascade's). Longer: darker corners and wider shadows of occlusion, which
    /// the probes may already hold.
    pub radius: Option<f32>,
    /// Trace at one pixel of each 2×2 block a frame (`true`, the default: a quarter of the rays,
    /// slightly softer edges of occlusion while the camera moves) or at every pixel (`false`).
    pub half_resolution: bool,
}

impl Default for DdgiContactOcclusion {
    fn default() -> Self {
        Self { rays: 0, radius: None, half_resolution: true }
    }
}

impl DdgiContactOcclusion {
    /// The side of the pixel blocks traced at one pixel each: 2 at half resolution, else 1.
    pub(crate) fn scale(&self) -> u32 {
        if self.half_resolution { 2 } else { 1 }
    }
}

impl DdgiFrame<'_> {
    /// Adds the pass `ddgi_contact_occlusion` when [`crate::DdgiContactOcclusion`] is on at half
    /// resolution and the output shows it: one pixel of each 2×2 block traces its rays. Returns
    /// the per-block values the composite reads (a placeholder of one value when the composite
    /// traces at every pixel or not at all).
    pub(crate) fn add_contact_occlusion(
        &self,
        graph: &mut RenderGraph,
        frame: &CameraFrame,
        gbuffer: &GBuffer,
        params: &Handle<GraphBuffer>,
    ) -> Handle<GraphBuffer> {
        let settings = self.contact_occlusion.as_deref().copied().unwrap_or_default();
        let shown = matches!(*self.output, DdgiOutput::Full | DdgiOutput::Indirect | DdgiOutput::Occlusion);
        let scale = settings.scale();
        let on = settings.rays > 0 && scale > 1 && shown && !self.volumes.volumes.is_empty();
        let size = frame.size();
        let blocks = if on { (size.width.div_ceil(scale), size.height.div_ceil(scale)) } else { (1, 1) };
        let usage = wgpu::BufferUsages::STORAGE;
        let mut occlusion =
            graph.create_buffer("ddgi_occlusion", BufferDesc { size: u64::from(blocks.0) * u64::from(blocks.1) * 4, usage });
        if !on {
            return occlusion;
        }
        let program = self.pipelines.contact_occlusion.clone();
        let mut pass = graph.add_pass("ddgi_contact_occlusion");
        pass.note(&format!("{} rays at one pixel of each {scale}×{scale} block", settings.rays));
        let group2 = vec![
            ("ddgi_gather_params", Bind::buffer(pass.read(params))),
            ("gbuffer_depth", Bind::texture(pass.read(&gbuffer.depth))),
            ("gbuffer_normal", Bind::texture(pass.read(&gbuffer.normal))),
            ("ddgi_occlusion", Bind::buffer(pass.write(&mut occlusion))),
        ];
        let group0 = pass.read_named(&program.bindings, 0);
        pass.compute(program, vec![group0, Vec::new(), group2], (blocks.0.div_ceil(8), blocks.1.div_ceil(8)));
        occlusion
    }
}

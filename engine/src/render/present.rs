//! The end of a camera frame: an [`ImageOverlay`] drawn over the tonemapped image, and the
//! `present_blit` pass that copies the image to a window's [`SurfaceTarget`].

use std::sync::Arc;

use bevy_ecs::prelude::*;

use super::CameraFrame;
use crate::gpu::GpuContext;
use crate::graph::{Handle, RenderGraph, Texture as GraphTexture};
use crate::shader::{Program, RenderTargets, render_program};

/// A window surface the frame is presented to (windowed runner).
#[derive(Resource)]
pub struct SurfaceTarget {
    /// The window's surface.
    pub surface: wgpu::Surface<'static>,
    /// How it is configured (format, size in pixels, present mode); resized with the window.
    pub config: wgpu::SurfaceConfiguration,
    /// The `present_blit` pipeline for the surface's format ([`blit_program`]).
    pub blit: Arc<Program<wgpu::RenderPipeline>>,
    /// Set when the surface reported itself lost: the windowed runner ([`crate::window`]) creates
    /// a new one from its window after the frame; frames are not presented until then.
    pub lost: std::sync::atomic::AtomicBool,
}

/// Something drawn over the finished image (a debug UI such as `ddgi_overlay`'s egui): it records
/// into the frame's encoder as the graph pass [`ImageOverlay::label`], after the tonemap, into the
/// tonemapped image ([`RenderOutputs::ldr`](super::RenderOutputs::ldr), [`LDR_FORMAT`](super::LDR_FORMAT), sRGB-encoded values), so that the
/// window shows it and the frames an app saves hold it.
pub trait ImageOverlay: Send + Sync + 'static {
    /// The pass label (wgpu label, timing span and overlay name).
    fn label(&self) -> &'static str;
    /// Records the overlay's draws into `target` (the tonemapped image, `size` pixels, to be loaded
    /// and drawn over).
    fn record(&self, gpu: &GpuContext, encoder: &mut wgpu::CommandEncoder, target: &wgpu::TextureView, size: (u32, u32));
}

/// The overlay drawn over every frame's tonemapped image; absent: nothing is drawn.
#[derive(Resource, Clone)]
pub struct ImageOverlayHook(pub Arc<dyn ImageOverlay>);

impl CameraFrame<'_> {
    /// The [`ImageOverlayHook`]'s pass over the tonemapped image `ldr`, if the app has one.
    pub(super) fn add_image_overlay(&self, graph: &mut RenderGraph, ldr: &mut Handle<GraphTexture>) {
        let size = self.size();
        if let Some(overlay) = self.overlay.as_ref().map(|o| o.0.clone()) {
            let mut pass = graph.add_pass(overlay.label());
            pass.read(ldr);
            let out = pass.write(ldr);
            pass.render(move |ctx| overlay.record(ctx.gpu, ctx.encoder, ctx.view(out), (size.width, size.height)));
        }
    }

    /// The `present_blit` pass of `ldr` into the window's next surface texture, when there is a
    /// window and its surface gives one; returns that texture, to present once the graph ran.
    pub(super) fn add_present_blit(&self, graph: &mut RenderGraph, ldr: &Handle<GraphTexture>) -> Option<wgpu::SurfaceTexture> {
        let surface = self.surface.as_ref();
        let surface_texture = surface.and_then(|s| acquire_surface(&self.gpu, s));
        if let (Some(target), Some(frame)) = (surface, &surface_texture) {
            let mut swap = graph.import_texture("surface", &frame.texture);
            let mut pass = graph.add_pass("present_blit");
            let input = pass.read(ldr);
            let out = pass.write(&mut swap);
            let program = target.blit.clone();
            pass.render(move |ctx| {
                let group0 =
                    program.bind_group(&ctx.gpu.device, 0, &[("blit_source", wgpu::BindingResource::TextureView(ctx.view(input)))]);
                let mut rp = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(ctx.label),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: ctx.view(out),
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Store },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                rp.set_pipeline(&program.pipeline);
                rp.set_bind_group(0, &group0, &[]);
                rp.draw(0..3, 0..1);
            });
            graph.export(&swap);
        }
        surface_texture
    }
}

/// The surface's next texture, or `None` when this frame cannot be presented: a timeout or an
/// occluded window skip the frame; an outdated surface is reconfigured (the next frame presents); a
/// lost surface is flagged for the runner to replace ([`SurfaceTarget::lost`]).
fn acquire_surface(gpu: &GpuContext, target: &SurfaceTarget) -> Option<wgpu::SurfaceTexture> {
    use std::sync::atomic::Ordering;
    if target.lost.load(Ordering::Relaxed) {
        return None;
    }
    match target.surface.get_current_texture() {
        wgpu::CurrentSurfaceTexture::Success(t) => Some(t),
        wgpu::CurrentSurfaceTexture::Suboptimal(t) => {
            // Present this one; the next frame uses a surface that fits again.
            target.surface.configure(&gpu.device, &target.config);
            Some(t)
        }
        wgpu::CurrentSurfaceTexture::Outdated => {
            log::info!("the surface is outdated (the window changed): reconfiguring it");
            target.surface.configure(&gpu.device, &target.config);
            None
        }
        wgpu::CurrentSurfaceTexture::Lost => {
            log::warn!("the surface was lost: the runner creates a new one");
            target.lost.store(true, Ordering::Relaxed);
            None
        }
        other => {
            log::info!("no surface texture this frame ({other:?}): the frame is not presented");
            None
        }
    }
}

/// The blit pipeline for presenting to a surface of `format` (must not be an sRGB format: the image
/// is already encoded).
pub fn blit_program(gpu: &GpuContext, format: wgpu::TextureFormat) -> Result<Program<wgpu::RenderPipeline>, crate::shader::ShaderError> {
    render_program(
        &gpu.device,
        "blit.wgsl",
        "present_blit",
        RenderTargets {
            colors: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            depth: None,
            primitive: Default::default(),
        },
    )
}

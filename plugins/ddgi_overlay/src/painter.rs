//! egui's draws over the tonemapped image: the overlay's [`ImageOverlay`], recorded by the engine as
//! the graph pass `egui_overlay` after the tonemap.

use std::sync::Mutex;

use engine::gpu::GpuContext;
use engine::render::{ImageOverlay, LDR_FORMAT};
use engine::wgpu;

/// The pass label of egui's draws (wgpu label and timing span).
pub const PASS_LABEL: &str = "egui_overlay";

/// egui's renderer on the app's device, and the frame it draws next.
pub struct EguiPainter {
    renderer: Mutex<egui_wgpu::Renderer>,
    frame: Mutex<Option<EguiFrame>>,
}

struct EguiFrame {
    jobs: Vec<egui::ClippedPrimitive>,
    textures: egui::TexturesDelta,
    pixels_per_point: f32,
}

impl Drop for EguiFrame {
    /// A frame dropped undrawn (the app closing) lets its texture updates go.
    fn drop(&mut self) {
        self.textures.clear();
    }
}

impl EguiPainter {
    /// A painter drawing into images of the engine's [`LDR_FORMAT`] (sRGB-encoded values in a
    /// linear format: egui blends in gamma space, as on a non-sRGB window surface).
    pub fn new(gpu: &GpuContext) -> Self {
        let renderer = egui_wgpu::Renderer::new(&gpu.device, LDR_FORMAT, egui_wgpu::RendererOptions::default());
        Self { renderer: Mutex::new(renderer), frame: Mutex::new(None) }
    }

    /// The shapes of this frame, drawn at the next render. The texture updates of a frame that was
    /// never drawn (a skipped render) are kept and go first.
    pub fn submit(&self, jobs: Vec<egui::ClippedPrimitive>, textures: egui::TexturesDelta, pixels_per_point: f32) {
        let mut pending = self.frame.lock().unwrap_or_else(|e| e.into_inner());
        let mut merged = pending.take().map(|mut f| std::mem::take(&mut f.textures)).unwrap_or_default();
        merged.append(textures);
        *pending = Some(EguiFrame { jobs, textures: merged, pixels_per_point });
    }
}

impl ImageOverlay for EguiPainter {
    fn label(&self) -> &'static str {
        PASS_LABEL
    }

    fn record(&self, gpu: &GpuContext, encoder: &mut wgpu::CommandEncoder, target: &wgpu::TextureView, size: (u32, u32)) {
        let Some(frame) = self.frame.lock().unwrap_or_else(|e| e.into_inner()).take() else { return };
        let mut renderer = self.renderer.lock().unwrap_or_else(|e| e.into_inner());
        for (id, deltas) in &frame.textures.set {
            for delta in deltas {
                renderer.update_texture(&gpu.device, &gpu.queue, *id, delta);
            }
        }
        if !frame.jobs.is_empty() {
            let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: frame.pixels_per_point };
            renderer.update_buffers(&gpu.device, &gpu.queue, encoder, &frame.jobs, &screen);
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some(PASS_LABEL),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            renderer.render(&mut pass.forget_lifetime(), &frame.jobs, &screen);
        }
        for id in &frame.textures.free {
            renderer.free_texture(id);
        }
    }
}

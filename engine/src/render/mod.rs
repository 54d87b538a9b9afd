//! The camera path: raster G-buffer → direct lighting → temporal anti-aliasing → tonemapping, as
//! one frame script on the render graph, plus output readback and per-pass GPU timings.
//!
//! ```text
//!  scene (ECS) ──extract/prepare──▶ GpuScene (bind group 0)
//!                                     │
//!  gbuffer ──depth, normal, albedo, emissive, motion──▶ direct_lighting ──hdr_radiance──▶ taa, taa_output
//!      ──hdr_radiance──▶ tonemap ──ldr_image──▶ present_blit
//! ```

pub mod exposure;
pub mod gpu_scene;
pub mod gpu_types;
mod present;
pub mod taa;
mod timings;
pub mod tonemap;

use std::sync::Arc;

use bevy_app::{App, Plugin};
use bevy_ecs::prelude::*;
use bevy_ecs::system::SystemParam;

use crate::app::{Prepare, Render, Time};
use crate::gpu::{GpuContext, dispatch};
use crate::graph::{GpuTimer, Handle, RenderGraph, Texture as GraphTexture, TextureDesc, TransientPool};
use crate::shader::{Program, RenderTargets, compute_program, render_program_with_constants};
pub use crate::sky::Sky;
pub use exposure::{AutoExposure, DefaultAutoExposure, ExposureState};
pub use gpu_scene::{GpuScene, RenderSize, prepare_gpu_scene};
pub use present::{ImageOverlay, ImageOverlayHook, SurfaceTarget, blit_program};
pub use taa::{DefaultTemporalAntiAliasing, TaaState, TemporalAntiAliasing};
pub(crate) use timings::OrderedMap;
pub use timings::{FrameTiming, FrameTimings, PassTiming};
pub use tonemap::DisplayTransform;

/// Depth of the G-buffer: reversed Z (1 at the near plane, cleared to 0), full float.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// The G-buffer's shading normal (xyz, world space, normal map applied, facing the viewer) and
/// perceptual roughness (w).
pub const NORMAL_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Half floats, not 8-bit: an albedo quantized to 1/255 shifts every lit surface's colour by up to
/// a few per cent in dark channels (0.065 → 17/255 is +2.6%), against the path tracer, which reads
/// the materials' exact values. Base colour (rgb) and metallic (w).
pub const ALBEDO_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The G-buffer's emitted radiance (rgb, clamped to the largest half float) and specular weight
/// (w).
pub const EMISSIVE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Screen motion since the previous frame (screen units), for the temporal anti-aliasing.
pub const MOTION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg16Float;
/// Linear radiance, kept in full float so that readback and the EXR output lose nothing.
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// Tonemapped, sRGB-encoded output.
pub const LDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// Adds the camera path. Needs a [`GpuContext`]; inserts the GPU scene, pipelines, outputs and timings.
pub struct RenderPlugin {
    /// The device to render with (inserted as a resource).
    pub gpu: GpuContext,
    /// The size of the image the camera renders, in pixels (inserted as [`RenderSize`]).
    pub size: RenderSize,
}

impl Plugin for RenderPlugin {
    fn build(&self, app: &mut App) {
        let pipelines = CameraPipelines::new(&self.gpu).unwrap_or_else(|e| panic!("camera path shaders: {e}"));
        app.insert_resource(self.gpu.clone())
            .insert_resource(self.size)
            .init_resource::<Sky>()
            .insert_resource(GpuScene::new(&self.gpu))
            .insert_resource(RenderOutputs::new(&self.gpu, self.size))
            .insert_resource(TaaState::new(&self.gpu, self.size))
            .insert_resource(ExposureState::new(&self.gpu))
            .insert_resource(pipelines)
            .init_resource::<TransientPool>()
            .init_resource::<GpuTimer>()
            .init_resource::<FrameTimings>()
            .insert_resource(crate::rt::RayTracingScene::new(&self.gpu))
            .insert_resource(crate::gpu::Uploads::new(&self.gpu))
            .add_systems(
                Prepare,
                (
                    prepare_render_outputs,
                    taa::prepare_taa,
                    exposure::prepare_exposure,
                    prepare_gpu_scene,
                    crate::rt::prepare_ray_tracing_scene,
                )
                    .chain(),
            )
            .init_resource::<FrameScript>()
            .add_systems(Render, (gpu_scene::flush_uploads, render_camera_frame.run_if(frame_script_is("direct"))).chain());
    }
}

/// The pipelines of the camera path.
#[derive(Resource)]
pub(crate) struct CameraPipelines {
    /// The G-buffer pass without (`[0]`) and with (`[1]`) the alpha test: a scene without
    /// alpha-masked materials keeps the early depth test a `discard` would cost.
    pub gbuffer: [Arc<Program<wgpu::RenderPipeline>>; 2],
    pub direct_lighting: Arc<Program<wgpu::ComputePipeline>>,
    /// The tonemap pass with each [`DisplayTransform`] (in the order of its variants), with the
    /// camera's exposure (`[0]`) or the auto-exposure's (`[1]`).
    pub tonemap: [[Arc<Program<wgpu::ComputePipeline>>; 2]; 2],
    pub exposure_histogram: Arc<Program<wgpu::ComputePipeline>>,
    pub exposure_adapt: Arc<Program<wgpu::ComputePipeline>>,
    pub taa: Arc<Program<wgpu::ComputePipeline>>,
    pub taa_output: Arc<Program<wgpu::ComputePipeline>>,
}

/// The direct-lighting pass: its shadow rays test masked materials' alpha
/// (`rt_alpha.inc.wgsl`) where the device binds the storage buffers that needs; on a smaller GPU
/// (WebGPU's default of 8 a stage) the same pass built on `rt_opaque.inc.wgsl` (every surface casts
/// a solid shadow in direct light; a warning says so once).
fn direct_lighting_program(gpu: &GpuContext) -> Result<Program<wgpu::ComputePipeline>, crate::shader::ShaderError> {
    const FILE: &str = "direct_lighting.wgsl";
    let needed = crate::shader::parse(FILE)?.storage_buffers_used(&["main"]);
    let available = gpu.device.limits().max_storage_buffers_per_shader_stage;
    if needed <= available {
        return compute_program(&gpu.device, FILE, "main", "direct_lighting");
    }
    static WARNED: std::sync::Once = std::sync::Once::new();
    WARNED.call_once(|| {
        log::warn!(
            "direct light: the alpha test of shadow rays needs {needed} storage buffers a stage, this GPU binds {available}: masked materials cast solid shadows in direct light"
        )
    });
    compute_program(&gpu.device, register_opaque_direct_lighting()?, "main", "direct_lighting")
}

/// Registers `direct_lighting_opaque.wgsl`, the direct-lighting pass built on `rt_opaque.inc.wgsl`
/// (no alpha test, fewer storage buffers: what a small GPU gets), and returns its name.
pub fn register_opaque_direct_lighting() -> Result<&'static str, crate::shader::ShaderError> {
    const OPAQUE: &str = "direct_lighting_opaque.wgsl";
    let source =
        crate::shader::source("direct_lighting.wgsl")?.replace("#include \"rt_alpha.inc.wgsl\"", "#include \"rt_opaque.inc.wgsl\"");
    crate::shader::register_generated(OPAQUE, source)?;
    Ok(OPAQUE)
}

impl CameraPipelines {
    /// Builds every pipeline of the camera path.
    pub fn new(gpu: &GpuContext) -> Result<Self, crate::shader::ShaderError> {
        let color = |format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL });
        let gbuffer = |alpha_test: f64| {
            let targets = RenderTargets {
                colors: &[color(NORMAL_FORMAT), color(ALBEDO_FORMAT), color(EMISSIVE_FORMAT), color(MOTION_FORMAT)],
                depth: Some(depth_test()),
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            };
            render_program_with_constants(&gpu.device, "gbuffer.wgsl", "gbuffer", targets, &[("SCENE_HAS_ALPHA_TEST", alpha_test)])
                .map(Arc::new)
        };
        Ok(Self {
            gbuffer: [gbuffer(0.0)?, gbuffer(1.0)?],
            direct_lighting: Arc::new(direct_lighting_program(gpu)?),
            tonemap: tonemap::programs(gpu)?,
            exposure_histogram: Arc::new(compute_program(&gpu.device, "exposure_histogram.wgsl", "main", "exposure_histogram")?),
            exposure_adapt: Arc::new(compute_program(&gpu.device, "exposure_adapt.wgsl", "main", "exposure_adapt")?),
            taa: Arc::new(compute_program(&gpu.device, "taa.wgsl", "main", "taa")?),
            taa_output: Arc::new(compute_program(&gpu.device, "taa_output.wgsl", "main", "taa_output")?),
        })
    }
}

/// The frame's outputs, kept between frames: linear radiance and the tonemapped image.
#[derive(Resource)]
pub struct RenderOutputs {
    /// Their size in pixels; they are made again when [`RenderSize`] changes.
    pub size: RenderSize,
    /// Linear radiance ([`HDR_FORMAT`]), before exposure: what `image.exr` and the metrics read.
    pub hdr: wgpu::Texture,
    /// The exposed, tonemapped, sRGB-encoded image ([`LDR_FORMAT`]): what `image.png` and the
    /// window show.
    pub ldr: wgpu::Texture,
}

impl RenderOutputs {
    /// Both textures at `size` (at least 1×1).
    pub fn new(gpu: &GpuContext, size: RenderSize) -> Self {
        let texture = |label, format, usage| frame_texture(gpu, size, label, format, usage);
        use wgpu::TextureUsages as U;
        Self {
            size,
            // Render attachment too: debug overlays (DDGI's probe spheres) rasterize into it.
            hdr: texture("hdr_radiance", HDR_FORMAT, U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC | U::RENDER_ATTACHMENT),
            // Render attachment too: an image overlay (a debug UI) rasterizes into it.
            ldr: texture("ldr_image", LDR_FORMAT, U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC | U::RENDER_ATTACHMENT),
        }
    }
}

/// A 2D texture of `size` (at least 1×1) kept between frames: the outputs, the TAA history.
pub(crate) fn frame_texture(
    gpu: &GpuContext,
    size: RenderSize,
    label: &str,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: size.width.max(1), height: size.height.max(1), depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

fn prepare_render_outputs(gpu: Res<GpuContext>, size: Res<RenderSize>, mut outputs: ResMut<RenderOutputs>) {
    if outputs.size != *size {
        *outputs = RenderOutputs::new(&gpu, *size);
    }
}

fn texture_desc(size: RenderSize, format: wgpu::TextureFormat, usage: wgpu::TextureUsages) -> TextureDesc {
    TextureDesc { width: size.width, height: size.height, format, usage }
}

fn workgroups(size: RenderSize) -> (u32, u32) {
    (size.width.div_ceil(8), size.height.div_ceil(8))
}

/// Which frame script renders the camera: the engine's `"direct"` (direct light only) or one a
/// plugin registers (`"pathtrace"`, `"ddgi"`, …). Each script's system runs only when it is active.
#[derive(Resource, Clone, Debug, PartialEq, Eq)]
pub struct FrameScript(pub &'static str);

impl Default for FrameScript {
    fn default() -> Self {
        Self("direct")
    }
}

/// A run condition: the frame script named `name` is active.
pub fn frame_script_is(name: &'static str) -> impl Fn(Res<FrameScript>) -> bool + Clone {
    move |script: Res<FrameScript>| script.0 == name
}

/// The G-buffer of a frame.
pub struct GBuffer {
    /// Reversed-Z depth ([`DEPTH_FORMAT`]).
    pub depth: Handle<GraphTexture>,
    /// Shading normal and roughness ([`NORMAL_FORMAT`]).
    pub normal: Handle<GraphTexture>,
    /// Base colour and metallic ([`ALBEDO_FORMAT`]).
    pub albedo: Handle<GraphTexture>,
    /// Emitted radiance and specular weight ([`EMISSIVE_FORMAT`]).
    pub emissive: Handle<GraphTexture>,
    /// Where each pixel's surface was on the screen in the previous frame, as an offset (screen
    /// units) from where it is now.
    pub motion: Handle<GraphTexture>,
}

/// One camera frame being scripted: its graph and its two outputs.
pub struct FrameGraph {
    /// The frame's graph: add passes to it.
    pub graph: RenderGraph,
    /// Linear radiance: the passes that light the image write it.
    pub hdr: Handle<GraphTexture>,
    /// The tonemapped image: [`CameraFrame::finish`] writes it.
    pub ldr: Handle<GraphTexture>,
}

/// Everything a camera frame script needs; frame scripts are systems that take this and compose
/// the passes top to bottom: `begin`, `add_*` passes, `finish` (tonemap, present, execute).
#[derive(SystemParam)]
pub struct CameraFrame<'w> {
    /// The device.
    pub gpu: Res<'w, GpuContext>,
    /// The scene on the GPU (bind group 0 of scene-reading shaders).
    pub scene: Res<'w, GpuScene>,
    /// The scene's BVHs (bound with the scene by [`CameraFrame::begin`]).
    pub rt: Res<'w, crate::rt::RayTracingScene>,
    /// The camera path's pipelines.
    pub(crate) pipelines: Res<'w, CameraPipelines>,
    /// The frame's output textures.
    pub outputs: Res<'w, RenderOutputs>,
    /// The frame's time (its index, for per-frame random sequences).
    pub time: Res<'w, Time>,
    pool: ResMut<'w, TransientPool>,
    timer: ResMut<'w, GpuTimer>,
    timings: ResMut<'w, FrameTimings>,
    surface: Option<Res<'w, SurfaceTarget>>,
    overlay: Option<Res<'w, ImageOverlayHook>>,
    display: Option<Res<'w, DisplayTransform>>,
    taa: Option<ResMut<'w, TaaState>>,
    exposure: Option<Res<'w, ExposureState>>,
}

impl CameraFrame<'_> {
    /// The size of the image, in pixels.
    pub fn size(&self) -> RenderSize {
        self.outputs.size
    }

    /// A new graph with the frame's outputs imported, and the scene's resources (bind group 0 of
    /// every scene-reading shader) imported by name: a pass declares the ones its shader reads with
    /// `pass.read_named(&program.bindings, 0)` and binds them from what that returns.
    pub fn begin(&self) -> FrameGraph {
        let mut graph = RenderGraph::new();
        graph.import_named(&self.rt.scene_resources(&self.scene));
        let hdr = graph.import_texture("hdr_radiance", &self.outputs.hdr);
        let ldr = graph.import_texture("ldr_image", &self.outputs.ldr);
        FrameGraph { graph, hdr, ldr }
    }

    /// Rasterizes every instance into a new G-buffer.
    pub fn add_gbuffer(&self, graph: &mut RenderGraph) -> GBuffer {
        use wgpu::TextureUsages as U;
        let (scene, pipelines, size) = (&self.scene, &self.pipelines, self.size());
        let attachment = U::RENDER_ATTACHMENT | U::TEXTURE_BINDING;
        let mut depth = graph.create_texture("gbuffer_depth", texture_desc(size, DEPTH_FORMAT, attachment));
        let mut normal = graph.create_texture("gbuffer_normal", texture_desc(size, NORMAL_FORMAT, attachment));
        let mut albedo = graph.create_texture("gbuffer_albedo", texture_desc(size, ALBEDO_FORMAT, attachment));
        let mut emissive = graph.create_texture("gbuffer_emissive", texture_desc(size, EMISSIVE_FORMAT, attachment));
        let mut motion = graph.create_texture("gbuffer_motion", texture_desc(size, MOTION_FORMAT, attachment));
        {
            let mut pass = graph.add_pass("gbuffer");
            let targets = [pass.write(&mut normal), pass.write(&mut albedo), pass.write(&mut emissive), pass.write(&mut motion)];
            let depth_target = pass.write(&mut depth);
            let program = pipelines.gbuffer[usize::from(scene.has_alpha_test)].clone();
            let scene_reads = pass.read_named(&program.bindings, 0);
            let index_buffer = scene.indices.buffer.clone();
            let draws = scene.draws.clone();
            pass.render(move |ctx| {
                let group0 = ctx.bind_group(&*program, 0, &scene_reads);
                let colors = targets.map(|t| {
                    Some(wgpu::RenderPassColorAttachment {
                        view: ctx.view(t),
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT), store: wgpu::StoreOp::Store },
                    })
                });
                let mut rp = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some(ctx.label),
                    color_attachments: &colors,
                    depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                        view: ctx.view(depth_target),
                        depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Store }),
                        stencil_ops: None,
                    }),
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                rp.set_pipeline(&program.pipeline);
                rp.set_bind_group(0, &group0, &[]);
                rp.set_index_buffer(index_buffer.slice(..), wgpu::IndexFormat::Uint32);
                for d in &draws {
                    rp.draw_indexed(d.indices.clone(), d.base_vertex, d.instance..d.instance + 1);
                }
            });
        }

        GBuffer { depth, normal, albedo, emissive, motion }
    }

    /// Direct light (emission + every light with a shadow ray) of the G-buffer into `hdr`.
    pub fn add_direct_lighting(&self, graph: &mut RenderGraph, gbuffer: &GBuffer, hdr: &mut Handle<GraphTexture>) {
        let (pipelines, size) = (&self.pipelines, self.size());
        let GBuffer { depth, normal, albedo, emissive, .. } = gbuffer;
        {
            let mut pass = graph.add_pass("direct_lighting");
            let inputs = [pass.read(depth), pass.read(normal), pass.read(albedo), pass.read(emissive)];
            let out = pass.write(hdr);
            let program = pipelines.direct_lighting.clone();
            let scene_reads = pass.read_named(&program.bindings, 0);
            pass.render(move |ctx| {
                let group0 = ctx.bind_group(&*program, 0, &scene_reads);
                let [d, n, a, e] = inputs.map(|i| wgpu::BindingResource::TextureView(ctx.view(i)));
                let group1 = program.bind_group(
                    &ctx.gpu.device,
                    1,
                    &[
                        ("gbuffer_depth", d),
                        ("gbuffer_normal", n),
                        ("gbuffer_albedo", a),
                        ("gbuffer_emissive", e),
                        ("radiance_out", wgpu::BindingResource::TextureView(ctx.view(out))),
                    ],
                );
                dispatch(ctx.encoder, ctx.label, &program.pipeline, &[&group0, &group1], workgroups(size));
            });
        }
    }

    /// Tonemaps `hdr` into the LDR output, presents it to the window if there is one, executes the
    /// graph and records its timings.
    pub fn finish(&mut self, frame: FrameGraph) {
        let FrameGraph { mut graph, hdr, mut ldr } = frame;
        self.add_tonemap(&mut graph, &hdr, &mut ldr);
        self.add_image_overlay(&mut graph, &mut ldr);
        graph.export(&hdr);
        graph.export(&ldr);
        let surface_texture = self.add_present_blit(&mut graph, &ldr);
        let gpu = self.gpu.clone();
        let report = graph.execute(&gpu, &mut self.pool, Some(&mut self.timer));
        if let Some(frame) = surface_texture {
            gpu.queue.present(frame);
        }
        let frame_index = self.time.frame;
        self.timings.push(&gpu, &mut self.timer, frame_index, report);
    }
}

/// Render stage: the engine's frame script, `"direct"` — G-buffer, direct light, temporal
/// anti-aliasing, tonemap.
pub fn render_camera_frame(mut frame: CameraFrame) {
    let mut script = frame.begin();
    let gbuffer = frame.add_gbuffer(&mut script.graph);
    frame.add_direct_lighting(&mut script.graph, &gbuffer, &mut script.hdr);
    frame.add_taa(&mut script.graph, &gbuffer, &mut script.hdr);
    frame.finish(script);
}

/// The depth test of everything rasterized against the G-buffer's depth: reverse Z (1 near, 0 at
/// infinity, cleared to 0), so nearer is greater; depth written.
pub fn depth_test() -> wgpu::DepthStencilState {
    wgpu::DepthStencilState {
        format: DEPTH_FORMAT,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Greater),
        stencil: Default::default(),
        bias: Default::default(),
    }
}

/// Begins a render pass that draws over the lit image `color`, depth-tested against the G-buffer's
/// `depth` ([`depth_test`]): both loaded and kept (the probe spheres, the DDGI visualizer).
pub fn begin_pass_over_image<'p>(
    ctx: &'p mut crate::graph::PassContext<'_>,
    color: crate::graph::Write<GraphTexture>,
    depth: crate::graph::Write<GraphTexture>,
) -> wgpu::RenderPass<'p> {
    let keep = wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store };
    let (color, depth) = (ctx.view(color), ctx.view(depth));
    ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(ctx.label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment { view: color, depth_slice: None, resolve_target: None, ops: keep })],
        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

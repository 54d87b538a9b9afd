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
pub mod taa;

use std::collections::VecDeque;
use std::ops::Not;
use std::sync::Arc;

use bevy_app::{App, Plugin};
use bevy_ecs::prelude::*;
use bevy_ecs::system::SystemParam;
use serde::Serialize;

use crate::app::{Prepare, Render, Time};
use crate::gpu::{GpuContext, dispatch};
use crate::graph::{FrameReport, GpuTimer, Handle, RenderGraph, Texture as GraphTexture, TextureDesc, TransientPool};
use crate::shader::{
    Program, RenderTargets, compute_program, compute_program_with_constants, render_program, render_program_with_constants,
};
pub use crate::sky::Sky;
pub use exposure::{AutoExposure, DefaultAutoExposure, ExposureState};
pub use gpu_scene::{GpuScene, RenderSize, prepare_gpu_scene};
pub use taa::{DefaultTemporalAntiAliasing, TaaState, TemporalAntiAliasing};

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
            tonemap: {
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
                [[variant(0.0, 0.0)?, variant(0.0, 1.0)?], [variant(1.0, 0.0)?, variant(1.0, 1.0)?]]
            },
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
        let texture = |label, format, usage| {
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
        };
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

fn prepare_render_outputs(gpu: Res<GpuContext>, size: Res<RenderSize>, mut outputs: ResMut<RenderOutputs>) {
    if outputs.size != *size {
        *outputs = RenderOutputs::new(&gpu, *size);
    }
}

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
/// tonemapped image ([`RenderOutputs::ldr`], [`LDR_FORMAT`], sRGB-encoded values), so that the
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

/// Per-pass GPU time of each frame, and which passes were left out and why.
#[derive(Resource, Default)]
pub struct FrameTimings {
    /// Every frame whose timings have come back, oldest first (at most `keep` of them).
    pub frames: Vec<FrameTiming>,
    /// Block at the end of each frame until its timings are back (headless, deterministic runs).
    pub wait_each_frame: bool,
    /// Keep at most this many frames (0: all).
    pub keep: usize,
    pending: VecDeque<(u64, FrameReport)>,
    /// Counters that arrived before their frame's timings.
    pending_counters: Vec<(u64, String, f64)>,
}

/// One frame's GPU timings: what `timings.json` lists per frame.
///
/// In JSON it is an object of maps keyed by pass label, in pass order: `frame`; `gpu_ms`, every
/// pass that ran → its GPU milliseconds (`null` without timestamp queries); `left_out`, every pass
/// that did not run → why; `notes`, passes that ran specialized → how (absent when none);
/// `counters`, name → value (absent when none). A label that appears twice in one frame (which
/// no frame script does) keys its second pass as `label#2`.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTiming {
    /// The frame's index ([`Time::frame`]).
    pub frame: u64,
    /// Every pass the frame's graph had, in order.
    pub passes: Vec<PassTiming>,
    /// Per-frame counts that plugins report (e.g. `ddgi_rays`: rays traced), by name.
    pub counters: Vec<(String, f64)>,
}

impl FrameTiming {
    /// The GPU milliseconds of the pass `label`, if it ran and was timed.
    pub fn gpu_ms(&self, label: &str) -> Option<f64> {
        self.passes.iter().find(|p| p.ran && p.label == label).and_then(|p| p.gpu_ms)
    }

    /// Every pass that ran, in order, with its GPU milliseconds (`None` without timestamp queries):
    /// the frame's `gpu_ms` map in `timings.json`.
    pub fn gpu_ms_by_pass(&self) -> impl Iterator<Item = (&str, Option<f64>)> + Clone {
        self.passes.iter().filter(|p| p.ran).map(|p| (p.label.as_str(), p.gpu_ms))
    }

    /// The sum of the GPU milliseconds of the passes that ran; `None` if any of them is untimed.
    pub fn total_gpu_ms(&self) -> Option<f64> {
        self.gpu_ms_by_pass().map(|(_, ms)| ms).sum()
    }
}

/// Serializes `(key, value)` pairs as one JSON object in their order; a key seen before gets
/// `#2`, `#3`, … appended, so that no pair is lost.
pub(crate) struct OrderedMap<I>(pub I);

impl<'a, V: Serialize + 'a, I: Clone + Iterator<Item = (&'a str, V)>> Serialize for OrderedMap<I> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(None)?;
        let mut seen: Vec<&str> = Vec::new();
        for (key, value) in self.0.clone() {
            let repeats = seen.iter().filter(|k| **k == key).count();
            seen.push(key);
            if repeats == 0 {
                map.serialize_entry(key, &value)?;
            } else {
                map.serialize_entry(&format!("{key}#{}", repeats + 1), &value)?;
            }
        }
        map.end()
    }
}

impl Serialize for FrameTiming {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(None)?;
        map.serialize_entry("frame", &self.frame)?;
        map.serialize_entry("gpu_ms", &OrderedMap(self.gpu_ms_by_pass()))?;
        let left_out = self.passes.iter().filter(|p| !p.ran).map(|p| (p.label.as_str(), p.note.as_str()));
        map.serialize_entry("left_out", &OrderedMap(left_out))?;
        let notes = self.passes.iter().filter(|p| p.ran && !p.note.is_empty()).map(|p| (p.label.as_str(), p.note.as_str()));
        if notes.clone().next().is_some() {
            map.serialize_entry("notes", &OrderedMap(notes))?;
        }
        if !self.counters.is_empty() {
            map.serialize_entry("counters", &OrderedMap(self.counters.iter().map(|(n, v)| (n.as_str(), *v))))?;
        }
        map.end()
    }
}

/// One pass of a [`FrameTiming`].
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PassTiming {
    /// The pass label (also its wgpu label and timing span).
    pub label: String,
    /// Whether it ran (false: the graph culled it, see `note`).
    pub ran: bool,
    /// Why it was left out, when it was; how it was specialized, when it ran.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
    /// GPU time of the pass in milliseconds; absent without timestamp queries.
    pub gpu_ms: Option<f64>,
}

impl FrameTimings {
    fn push(&mut self, gpu: &GpuContext, timer: &mut GpuTimer, frame: u64, mut report: FrameReport) {
        if self.wait_each_frame {
            let times = report.wait_for_timings(gpu, timer);
            self.record(frame, &mut report, times);
        } else {
            self.pending.push_back((frame, report));
            self.collect(gpu, timer);
        }
        if self.keep > 0 && self.frames.len() > self.keep {
            let excess = self.frames.len() - self.keep;
            self.frames.drain(..excess);
        }
    }

    /// Moves every frame whose timestamps have arrived into `frames`, without blocking.
    pub fn collect(&mut self, gpu: &GpuContext, timer: &mut GpuTimer) {
        while let Some((frame, report)) = self.pending.front_mut() {
            let frame = *frame;
            let times = if gpu.timestamps {
                match report.try_timings(gpu, timer) {
                    Some(t) => Some(t),
                    None if self.pending.len() > 8 => None,
                    None => return,
                }
            } else {
                None
            };
            let (_, mut report) = self.pending.pop_front().expect("front exists");
            self.record(frame, &mut report, times);
        }
    }

    fn record(&mut self, frame: u64, report: &mut FrameReport, times: Option<Vec<(String, f64)>>) {
        if let Some(spans) = report.take_gpu_spans() {
            crate::trace::record_gpu_frame(frame, spans);
        }
        let passes = report
            .passes
            .iter()
            .map(|p| PassTiming {
                label: p.label.clone(),
                ran: p.ran,
                note: p.note.clone(),
                gpu_ms: times.as_ref().and_then(|t| t.iter().find(|(l, _)| *l == p.label).map(|(_, ms)| *ms)),
            })
            .collect();
        let mut counters = Vec::new();
        self.pending_counters.retain(|(f, name, value)| {
            let mine = *f == frame;
            if mine {
                counters.push((name.clone(), *value));
            }
            mine.not()
        });
        self.frames.push(FrameTiming { frame, passes, counters });
    }

    /// Records a per-frame count of frame `frame` (it may arrive before or after the frame's
    /// timings; a readback a few frames late is fine).
    pub fn record_counter(&mut self, frame: u64, name: &str, value: f64) {
        if let Some(f) = self.frames.iter_mut().rev().find(|f| f.frame == frame) {
            f.counters.push((name.into(), value));
        } else if self.frames.last().is_none_or(|f| f.frame < frame) {
            self.pending_counters.push((frame, name.into(), value));
        }
    }

    /// The value of counter `name` of each recorded frame that has one.
    pub fn counter(&self, name: &str) -> Vec<(u64, f64)> {
        self.frames.iter().filter_map(|f| f.counters.iter().find(|(n, _)| n == name).map(|(_, v)| (f.frame, *v))).collect()
    }

    /// Mean GPU milliseconds of each pass over the recorded frames, in pass order.
    pub fn mean_ms(&self) -> Vec<(String, Option<f64>)> {
        let mut out: Vec<(String, f64, usize)> = Vec::new();
        for f in &self.frames {
            for p in f.passes.iter().filter(|p| p.ran) {
                let i = out.iter().position(|(l, ..)| *l == p.label).unwrap_or_else(|| {
                    out.push((p.label.clone(), 0.0, 0));
                    out.len() - 1
                });
                if let Some(ms) = p.gpu_ms {
                    out[i].1 += ms;
                    out[i].2 += 1;
                }
            }
        }
        out.into_iter().map(|(l, sum, n)| (l, (n > 0).then(|| sum / n as f64))).collect()
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
        let auto_exposure = self.add_auto_exposure(&mut graph, &hdr);
        let (gpu, pipelines, size) = (self.gpu.clone(), &self.pipelines, self.size());
        {
            let mut pass = graph.add_pass("tonemap");
            let input = pass.read(&hdr);
            let out = pass.write(&mut ldr);
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
        if let Some(overlay) = self.overlay.as_ref().map(|o| o.0.clone()) {
            let mut pass = graph.add_pass(overlay.label());
            pass.read(&ldr);
            let out = pass.write(&mut ldr);
            pass.render(move |ctx| overlay.record(ctx.gpu, ctx.encoder, ctx.view(out), (size.width, size.height)));
        }
        graph.export(&hdr);
        graph.export(&ldr);
        let surface = self.surface.as_ref();
        let surface_texture = surface.and_then(|s| acquire_surface(&gpu, s));
        if let (Some(target), Some(frame)) = (surface, &surface_texture) {
            let mut swap = graph.import_texture("surface", &frame.texture);
            let mut pass = graph.add_pass("present_blit");
            let input = pass.read(&ldr);
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

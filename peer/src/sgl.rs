//! sgl-3d's dynamic GI on our device: the scene loaded as one static model, its volume placed on
//! our probe grid, frames rendered headless into an offscreen texture, GPU pass times from its own
//! timestamp queries (`sgl_3d::timing::GpuTiming`), and the HDR composite (linear radiance before
//! exposure, anti-aliasing and tone mapping) read back.

use engine::gpu::GpuContext;
use glam::Vec3;
use sgl_3d::diagnostics::{DiagnosticTarget, DynamicGiReport};
use sgl_3d::settings::{
    AmbientOcclusionQuality, Antialiasing, Bloom, DynamicGiQuality, MotionBlur, SceneResolution, ScreenSpaceReflections, Settings,
};
use sgl_3d::{Backdrop, DynamicGiVolume, FrameInput, InstanceState, LightId, Mobility, ModelMesh, PreparedModel, Renderer, Scene};

use crate::convert::{self, Converted};

/// sgl-3d's timing groups of its dynamic GI stage (its README, "GPU pass timing").
pub const UPDATE_GROUPS: [&str; 3] = ["dynamic GI allocation", "dynamic GI rays", "dynamic GI blend"];

/// What one sgl-3d run is asked to do.
pub struct SglRun<'a> {
    pub converted: &'a Converted,
    pub width: u32,
    pub height: u32,
    pub frames: u32,
    /// Most rays a probe traces on a turn: 128 (its `Low`) or 256 (`High`).
    pub quality: DynamicGiQuality,
    /// The probe lattice: first probe, spacing, counts.
    pub volume: DynamicGiVolume,
    /// Change a light by one part in a million every frame, so the volume never pauses.
    pub keep_awake: bool,
    /// Count its rays (`Diagnostics::dynamic_gi`): a run that is observed is not timed, as sgl-3d
    /// asks (the observation adds work to the trace).
    pub observe: bool,
}

/// One frame's GPU times.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct SglFrame {
    pub frame: u64,
    /// The frame's GPU time (`FrameTime::total_ms`).
    pub frame_ms: f64,
    /// The dynamic GI groups' sum; `None` when the stage did not run (paused).
    pub update_ms: Option<f64>,
}

/// What a run gives back.
pub struct SglResult {
    pub frames: Vec<SglFrame>,
    pub reports: Vec<DynamicGiReport>,
    /// Linear RGBA radiance of the last frame, row-major from the top-left.
    pub hdr: Vec<f32>,
}

/// The settings that leave the HDR composite with direct light, emission and the volume's indirect
/// light alone: no anti-aliasing (its composite is not jittered), no reflections, no ambient
/// occlusion, no fog, no bloom, no motion blur, the full resolution.
pub fn settings(quality: DynamicGiQuality, observe: bool) -> Settings {
    let mut settings = Settings {
        scene_resolution: SceneResolution::Full,
        antialiasing: Antialiasing::Off,
        bloom: Bloom::Off,
        ambient_occlusion: AmbientOcclusionQuality::Off,
        screen_space_reflections: ScreenSpaceReflections::Off,
        atmosphere: false,
        volume_paths: false,
        motion_blur: MotionBlur::Off,
        dynamic_gi: quality,
        ..Default::default()
    };
    settings.diagnostics.dynamic_gi = observe;
    settings
}

/// sgl-3d's lattice for our volume over `bounds` with `counts` probes: ours sit at the centres of
/// `counts` equal cells of the box.
pub fn lattice(bounds: (Vec3, Vec3), counts: [u32; 3]) -> DynamicGiVolume {
    let spacing = (bounds.1 - bounds.0) / Vec3::from_array(counts.map(|c| c as f32));
    DynamicGiVolume { origin: bounds.0 + 0.5 * spacing, spacing, probes: counts }
}

fn scene_error(what: &str, e: impl std::fmt::Debug) -> String {
    format!("sgl-3d: {what}: {e:?}")
}

/// Loads the converted scene into a new sgl-3d scene on our device.
fn load(gpu: &GpuContext, c: &Converted, volume: DynamicGiVolume) -> Result<(Scene, Vec<LightId>), String> {
    let (device, queue) = (&gpu.device, &gpu.queue);
    let mut scene = Scene::new(device, queue);
    let materials = scene.add_materials(device, queue, &c.materials, &c.images).map_err(|e| scene_error("add_materials", e))?;
    let meshes = c
        .meshes
        .iter()
        .map(|(vertices, indices, material)| ModelMesh {
            vertices: vertices.clone(),
            indices: indices.clone(),
            material: materials[*material],
            deformation: Default::default(),
        })
        .collect();
    let prepared = PreparedModel::new(meshes).map_err(|e| scene_error("PreparedModel::new", e))?;
    let model = scene.add_model(device, queue, prepared).map_err(|e| scene_error("add_model", e))?;
    scene.add_instance(device, queue, InstanceState::new(model), Mobility::Static).map_err(|e| scene_error("add_instance", e))?;
    let mut lights = Vec::new();
    for light in &c.lights {
        lights.push(scene.add_light(device, queue, *light).map_err(|e| scene_error("add_light", e))?);
    }
    scene.set_dynamic_gi_volume(device, Some(volume)).map_err(|e| scene_error("set_dynamic_gi_volume", e))?;
    Ok((scene, lights))
}

/// Renders `run.frames` frames and reads the last one back.
pub fn run(gpu: &GpuContext, run: &SglRun) -> Result<SglResult, String> {
    let mut renderer = SglRenderer::new(gpu, run)?;
    for _ in 0..run.frames {
        renderer.step(gpu)?;
    }
    renderer.finish(gpu)
}

/// sgl-3d on one scene, stepped a frame at a time ([`SglRenderer::step`]), so that its frames can
/// take turns with other renderers' on the same device.
pub struct SglRenderer<'a> {
    converted: &'a Converted,
    keep_awake: bool,
    observe: bool,
    scene: Scene,
    light_ids: Vec<LightId>,
    settings: Settings,
    size: [u32; 2],
    renderer: Renderer,
    /// The offscreen texture it renders into (kept alive for `output_view`).
    _output: wgpu::Texture,
    output_view: wgpu::TextureView,
    timing: Option<sgl_3d::timing::GpuTiming>,
    camera: sgl_3d::Camera,
    frame: u32,
    frames: Vec<SglFrame>,
    reports: Vec<DynamicGiReport>,
    dynamic_gi_in_effect: DynamicGiQuality,
}

impl<'a> SglRenderer<'a> {
    /// Loads `run.converted` into a new sgl-3d scene and renderer on our device (`run.frames` is
    /// left to the caller: one [`SglRenderer::step`] a frame).
    pub fn new(gpu: &GpuContext, run: &SglRun<'a>) -> Result<Self, String> {
        let (device, queue) = (&gpu.device, &gpu.queue);
        let c = run.converted;
        let (scene, light_ids) = load(gpu, c, run.volume)?;
        let settings = settings(run.quality, run.observe);
        let size = [run.width, run.height];
        let format = wgpu::TextureFormat::Rgba16Float;
        let renderer = Renderer::new(device, queue, format, size, 1.0, &settings).map_err(|e| scene_error("Renderer::new", e))?;
        let dynamic_gi_in_effect = renderer.dynamic_gi_in_effect(&settings);
        let output = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("peer_sgl_output"),
            size: wgpu::Extent3d { width: run.width, height: run.height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let output_view = output.create_view(&Default::default());
        let timing = if run.observe { None } else { sgl_3d::timing::GpuTiming::new(device, queue) };
        let (world, yfov, znear) = c.camera;
        let camera = convert::camera(world, yfov, znear, run.width as f32 / run.height as f32);
        Ok(Self {
            converted: c,
            keep_awake: run.keep_awake,
            observe: run.observe,
            scene,
            light_ids,
            settings,
            size,
            renderer,
            _output: output,
            output_view,
            timing,
            camera,
            frame: 0,
            frames: Vec::new(),
            reports: Vec::new(),
            dynamic_gi_in_effect,
        })
    }

    /// The dynamic GI quality sgl-3d runs on this device (`Off` where its binding tier has none).
    pub fn dynamic_gi_in_effect(&self) -> DynamicGiQuality {
        self.dynamic_gi_in_effect
    }

    /// The GPU times of the frames whose timestamps have come back.
    fn collect(&mut self, gpu: &GpuContext) {
        let Some(t) = self.timing.as_mut() else { return };
        for f in t.begin_frame(&gpu.device, &gpu.queue) {
            let update: Vec<f64> = f.passes.iter().filter(|p| UPDATE_GROUPS.contains(&p.name)).map(|p| p.ms).collect();
            let update_ms = (!update.is_empty()).then(|| update.iter().sum());
            self.frames.push(SglFrame { frame: f.frame, frame_ms: f.total_ms, update_ms });
        }
    }

    /// Renders the next frame and waits for the device to finish it.
    pub fn step(&mut self, gpu: &GpuContext) -> Result<(), String> {
        let (device, queue) = (&gpu.device, &gpu.queue);
        let (c, frame) = (self.converted, self.frame);
        if self.keep_awake && frame > 0 {
            nudge(gpu, &mut self.scene, c, &self.light_ids, frame)?;
        }
        self.renderer.resize(device, self.size, 1.0, &self.settings);
        self.collect(gpu);
        let mut input = FrameInput::new(self.camera);
        input.camera_cut = frame == 0;
        input.elapsed_seconds = f64::from(frame) / 60.0;
        input.backdrop = Backdrop::Color([0.0; 3]);
        for (slot, sun) in input.directional_lights.iter_mut().zip(&c.suns) {
            let mut sun = *sun;
            if self.keep_awake && frame % 2 == 1 && c.lights.is_empty() {
                sun.illuminance *= 1.0 + 1e-6;
            }
            *slot = Some(sun);
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("peer_sgl_frame") });
        self.renderer.render(device, queue, &mut encoder, &mut self.scene, &input, &self.settings, &self.output_view, self.timing.as_ref());
        queue.submit([encoder.finish()]);
        if let Some(t) = self.timing.as_mut() {
            t.submitted(queue);
        }
        self.renderer.finish_frame(&mut self.scene);
        // One frame in flight at a time, as our headless runner has: every frame's query set comes
        // back (GpuTiming leaves a frame untimed while all four are in flight), and the GPU times
        // are those of the frame alone.
        gpu.wait_idle();
        if self.observe {
            self.reports.extend(self.renderer.take_dynamic_gi_reports(device));
        }
        self.frame += 1;
        Ok(())
    }

    /// Collects the last frames' timings and reads the last frame's HDR composite back.
    pub fn finish(mut self, gpu: &GpuContext) -> Result<SglResult, String> {
        // The last frames' timings come back once their work has completed.
        if self.timing.is_some() {
            for _ in 0..4 {
                gpu.wait_idle();
                self.collect(gpu);
            }
        }
        if self.observe {
            gpu.wait_idle();
            self.reports.extend(self.renderer.take_dynamic_gi_reports(&gpu.device));
        }
        let composite = self.renderer.diagnostic_target(DiagnosticTarget::Composite).ok_or("sgl-3d: no HDR composite")?;
        let hdr = read_rgba16f(gpu, composite.texture())?;
        Ok(SglResult { frames: self.frames, reports: self.reports, hdr })
    }
}

/// Changes the first point or spot light by one part in a million on odd frames (back on even
/// ones), so sgl-3d sees an edit and its volume does not pause; without one, the first directional
/// light (in `run`).
fn nudge(gpu: &GpuContext, scene: &mut Scene, c: &Converted, ids: &[LightId], frame: u32) -> Result<(), String> {
    if let (Some(&id), Some(light)) = (ids.first(), c.lights.first()) {
        let mut light = *light;
        if frame % 2 == 1 {
            light.intensity *= 1.0 + 1e-6;
        }
        scene.set_light(&gpu.queue, id, light).map_err(|e| scene_error("set_light", e))?;
    }
    Ok(())
}

/// Reads an RGBA16F texture back as linear RGBA f32.
fn read_rgba16f(gpu: &GpuContext, texture: &wgpu::Texture) -> Result<Vec<f32>, String> {
    let (width, height) = (texture.width(), texture.height());
    if texture.format() != wgpu::TextureFormat::Rgba16Float {
        return Err(format!("sgl-3d's composite is {:?}, expected Rgba16Float", texture.format()));
    }
    let row = width * 8;
    let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("peer_sgl_readback"),
        size: u64::from(padded * height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(height) },
        },
        texture.size(),
    );
    gpu.queue.submit([encoder.finish()]);
    let slice = buffer.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    gpu.wait_idle();
    let data = slice.get_mapped_range().map_err(|e| format!("reading sgl-3d's composite back: {e:?}"))?;
    let mut out = Vec::with_capacity((width * height * 4) as usize);
    for y in 0..height {
        let start = (y * padded) as usize;
        let bytes = &data[start..start + row as usize];
        out.extend(bytes.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()));
    }
    drop(data);
    buffer.unmap();
    Ok(out)
}

/// Medians of a run's frames, from frame `skip` on: the update over the frames where the stage
/// ran, the frame over all, and how many of them ran it.
pub fn summary(frames: &[SglFrame], skip: u64) -> (Option<f64>, Option<f64>, usize, usize) {
    let kept: Vec<&SglFrame> = frames.iter().filter(|f| f.frame >= skip).collect();
    let mut updates: Vec<f64> = kept.iter().filter_map(|f| f.update_ms).collect();
    let mut totals: Vec<f64> = kept.iter().map(|f| f.frame_ms).collect();
    let ran = updates.len();
    (lab::median(&mut updates), lab::median(&mut totals), ran, kept.len())
}

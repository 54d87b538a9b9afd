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
    pub dynamic_gi_in_effect: DynamicGiQuality,
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
    let materials = scene.add_materials(device, queue, &c.materials, &[]).map_err(|e| scene_error("add_materials", e))?;
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
    let (device, queue) = (&gpu.device, &gpu.queue);
    let c = run.converted;
    let (mut scene, light_ids) = load(gpu, c, run.volume)?;
    let settings = settings(run.quality, run.observe);
    let size = [run.width, run.height];
    let format = wgpu::TextureFormat::Rgba16Float;
    let mut renderer = Renderer::new(device, queue, format, size, 1.0, &settings).map_err(|e| scene_error("Renderer::new", e))?;
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
    let mut timing = if run.observe { None } else { sgl_3d::timing::GpuTiming::new(device, queue) };
    let (world, yfov, znear) = c.camera;
    let camera = convert::camera(world, yfov, znear, run.width as f32 / run.height as f32);
    let mut frames = Vec::new();
    let mut reports = Vec::new();
    let collect = |frames: &mut Vec<SglFrame>, done: &mut dyn Iterator<Item = sgl_3d::timing::FrameTime>| {
        for f in done {
            let update: Vec<f64> = f.passes.iter().filter(|p| UPDATE_GROUPS.contains(&p.name)).map(|p| p.ms).collect();
            let update_ms = (!update.is_empty()).then(|| update.iter().sum());
            frames.push(SglFrame { frame: f.frame, frame_ms: f.total_ms, update_ms });
        }
    };
    for frame in 0..run.frames {
        if run.keep_awake && frame > 0 {
            nudge(gpu, &mut scene, c, &light_ids, frame)?;
        }
        renderer.resize(device, size, 1.0, &settings);
        if let Some(t) = timing.as_mut() {
            collect(&mut frames, &mut t.begin_frame(device, queue));
        }
        let mut input = FrameInput::new(camera);
        input.camera_cut = frame == 0;
        input.elapsed_seconds = f64::from(frame) / 60.0;
        input.backdrop = Backdrop::Color([0.0; 3]);
        for (slot, sun) in input.directional_lights.iter_mut().zip(&c.suns) {
            let mut sun = *sun;
            if run.keep_awake && frame % 2 == 1 && c.lights.is_empty() {
                sun.illuminance *= 1.0 + 1e-6;
            }
            *slot = Some(sun);
        }
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("peer_sgl_frame") });
        renderer.render(device, queue, &mut encoder, &mut scene, &input, &settings, &output_view, timing.as_ref());
        queue.submit([encoder.finish()]);
        if let Some(t) = timing.as_mut() {
            t.submitted(queue);
        }
        renderer.finish_frame(&mut scene);
        // One frame in flight at a time, as our headless runner has: every frame's query set comes
        // back (GpuTiming leaves a frame untimed while all four are in flight), and the GPU times
        // are those of the frame alone.
        gpu.wait_idle();
        if run.observe {
            reports.extend(renderer.take_dynamic_gi_reports(device));
        }
    }
    // The last frames' timings come back once their work has completed.
    if let Some(t) = timing.as_mut() {
        for _ in 0..4 {
            gpu.wait_idle();
            collect(&mut frames, &mut t.begin_frame(device, queue));
        }
    }
    if run.observe {
        gpu.wait_idle();
        reports.extend(renderer.take_dynamic_gi_reports(device));
    }
    let composite = renderer.diagnostic_target(DiagnosticTarget::Composite).ok_or("sgl-3d: no HDR composite")?;
    let hdr = read_rgba16f(gpu, composite.texture())?;
    Ok(SglResult { frames, reports, hdr, dynamic_gi_in_effect })
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

//! Rendering a scene without a window: what `game_demo render` and the image tests use.

use std::path::Path;

use bevy_app::App;
use bevy_ecs::world::World;
use glam::Vec3;
use serde::Serialize;

use crate::app::{EnginePlugin, Time, finish_plugins, run_headless};
use crate::gpu::GpuContext;
use crate::gpu::readback::{read_rgba32f, read_texture};
use crate::render::{FrameTiming, FrameTimings, RenderOutputs, RenderPlugin, RenderSize};
use crate::scene::{Camera, NodeContent, SceneDescription, Transform};

/// How to render headless.
#[derive(Clone, Debug)]
pub struct HeadlessSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Frames to run; the image is the last one.
    pub frames: u32,
    /// Seconds per frame of the fixed clock.
    pub step: f64,
}

impl Default for HeadlessSettings {
    fn default() -> Self {
        Self { width: 640, height: 480, frames: 1, step: 1.0 / 60.0 }
    }
}

/// The last frame of a headless run.
pub struct RenderedFrame {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Linear radiance, RGBA, row-major from the top-left.
    pub hdr: Vec<f32>,
    /// Tonemapped sRGB, RGBA8.
    pub ldr: Vec<u8>,
    /// Per-pass timings of the frames run, oldest first (GPU times absent without timestamp queries).
    pub timings: Vec<FrameTiming>,
    /// The name of the adapter that rendered it.
    pub adapter: String,
}

/// Errors of a headless render.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The image is empty or larger than the device's largest 2D texture.
    #[error("image size {width}×{height} is not supported: each side must be between 1 and {max}")]
    BadSize {
        /// The width asked for, in pixels.
        width: u32,
        /// The height asked for, in pixels.
        height: u32,
        /// The device's largest texture side, in texels.
        max: u32,
    },
    /// `frames` was 0.
    #[error("frame count must be at least 1")]
    NoFrames,
    /// An output file could not be written.
    #[error("cannot write {path}: {message}")]
    Write {
        /// The file.
        path: String,
        /// What the encoder or the file system said.
        message: String,
    },
}

/// Adds a camera that frames the scene's bounds in a three-quarter view from the front (+Z) and
/// above, for scenes that have none.
pub fn add_default_camera(scene: &mut SceneDescription) {
    let (lo, hi) = scene.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let center = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let camera = Camera::default();
    let distance = radius / (camera.yfov * 0.5).sin();
    let eye = center + Vec3::new(0.35, 0.6, 1.0).normalize() * distance;
    let transform = Transform::from_translation(eye).looking_at(center, Vec3::Y);
    scene.add_node("default_camera", transform, None, vec![NodeContent::Camera(Camera { znear: (radius * 1e-3).max(1e-6), ..camera })]);
}

/// An app with the engine and the camera path rendering `size` pixels headless: a fixed clock of
/// `step` seconds, BLAS builds waited for, per-frame timings waited for. Spawn a scene and run it.
pub fn headless_app(gpu: &GpuContext, size: RenderSize, step: f64) -> App {
    let mut app = App::new();
    app.insert_resource(Time::fixed(step)).insert_resource(crate::rt::WaitForBlasBuilds(true));
    app.add_plugins((EnginePlugin, RenderPlugin { gpu: gpu.clone(), size }));
    app.world_mut().resource_mut::<FrameTimings>().wait_each_frame = true;
    app
}

/// Renders `scene` for `settings.frames` frames with a fixed time step and returns the last frame.
pub fn render_scene(gpu: &GpuContext, scene: SceneDescription, settings: &HeadlessSettings) -> Result<RenderedFrame, RenderError> {
    render_scene_with(gpu, scene, settings, |_| {})
}

/// [`render_scene`] with a chance to add plugins and settings to the app before it runs (another
/// frame script, for instance).
pub fn render_scene_with(
    gpu: &GpuContext,
    scene: SceneDescription,
    settings: &HeadlessSettings,
    configure: impl FnOnce(&mut App),
) -> Result<RenderedFrame, RenderError> {
    render_scene_and_inspect(gpu, scene, settings, configure, |_| {})
}

/// [`render_scene_with`], then a look at the app's world after the last frame (to read back what a
/// plugin keeps on the GPU, say).
pub fn render_scene_and_inspect(
    gpu: &GpuContext,
    scene: SceneDescription,
    settings: &HeadlessSettings,
    configure: impl FnOnce(&mut App),
    inspect: impl FnOnce(&mut bevy_ecs::world::World),
) -> Result<RenderedFrame, RenderError> {
    if settings.frames == 0 {
        return Err(RenderError::NoFrames);
    }
    let mut app = scene_app(gpu, scene, settings, configure)?;
    run_headless(&mut app, settings.frames);
    let world = app.world_mut();
    let timings = std::mem::take(&mut world.resource_mut::<FrameTimings>().frames);
    let frame = RenderedFrame { timings, ..read_frame(gpu, world) };
    inspect(world);
    Ok(frame)
}

/// A headless app ([`headless_app`]) at the settings' size with `configure` applied and `scene`
/// spawned (with a default camera if it has none), ready to run: all at once with
/// [`run_headless`], or frame by frame with [`run_frames`].
pub fn scene_app(
    gpu: &GpuContext,
    mut scene: SceneDescription,
    settings: &HeadlessSettings,
    configure: impl FnOnce(&mut App),
) -> Result<App, RenderError> {
    let max = gpu.device.limits().max_texture_dimension_2d;
    if settings.width == 0 || settings.height == 0 || settings.width > max || settings.height > max {
        return Err(RenderError::BadSize { width: settings.width, height: settings.height, max });
    }
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    let mut app = headless_app(gpu, RenderSize { width: settings.width, height: settings.height }, settings.step);
    configure(&mut app);
    scene.spawn(app.world_mut());
    Ok(app)
}

/// Runs `frames` frames of `app`, one at a time. After each, `after_frame(frame, world)` (frame
/// counted from 0) can read the frame (see [`read_hdr`]; the frame's GPU timings are the last of
/// [`FrameTimings`]) and change the world before the next one. Stops early if the app exits.
pub fn run_frames(app: &mut App, frames: u32, mut after_frame: impl FnMut(u32, &mut World)) {
    finish_plugins(app);
    for frame in 0..frames {
        app.update();
        if app.should_exit().is_some() {
            return;
        }
        after_frame(frame, app.world_mut());
    }
}

/// The linear radiance of the last frame (RGBA, row-major from the top-left).
pub fn read_hdr(gpu: &GpuContext, world: &World) -> Vec<f32> {
    read_rgba32f(gpu, &world.resource::<RenderOutputs>().hdr)
}

/// The tonemapped sRGB image of the last frame (RGBA8, row-major from the top-left).
pub fn read_ldr(gpu: &GpuContext, world: &World) -> Vec<u8> {
    read_texture(gpu, &world.resource::<RenderOutputs>().ldr)
}

/// The last frame's images, with the timings recorded so far.
pub fn read_frame(gpu: &GpuContext, world: &World) -> RenderedFrame {
    let size = world.resource::<RenderOutputs>().size;
    RenderedFrame {
        width: size.width,
        height: size.height,
        hdr: read_hdr(gpu, world),
        ldr: read_ldr(gpu, world),
        timings: world.resource::<FrameTimings>().frames.clone(),
        adapter: gpu.adapter_name(),
    }
}

/// `timings.json`: the adapter, the image size, each pass's mean GPU milliseconds over the frames
/// (`mean_gpu_ms`, pass label → milliseconds, in pass order; `null` without timestamp queries) and
/// every frame's ([`FrameTiming`]: `gpu_ms`, pass label → milliseconds, and the passes left out).
#[derive(Serialize)]
struct TimingsFile<'a> {
    adapter: &'a str,
    width: u32,
    height: u32,
    #[serde(serialize_with = "as_map")]
    mean_gpu_ms: Vec<(String, Option<f64>)>,
    frames: &'a [FrameTiming],
}

fn as_map<S: serde::Serializer>(pairs: &[(String, Option<f64>)], serializer: S) -> Result<S::Ok, S::Error> {
    crate::render::OrderedMap(pairs.iter().map(|(k, v)| (k.as_str(), *v))).serialize(serializer)
}

impl RenderedFrame {
    /// Writes `image.png` (tonemapped sRGB), `image.exr` (linear radiance) and `timings.json` into `dir`.
    pub fn write(&self, dir: &Path) -> Result<(), RenderError> {
        let io = |path: &Path, e: &dyn std::fmt::Display| RenderError::Write { path: path.display().to_string(), message: e.to_string() };
        std::fs::create_dir_all(dir).map_err(|e| io(dir, &e))?;
        let png = dir.join("image.png");
        image::save_buffer(&png, &self.ldr, self.width, self.height, image::ExtendedColorType::Rgba8).map_err(|e| io(&png, &e))?;
        let exr = dir.join("image.exr");
        let rgb: Vec<f32> = self.hdr.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
        image::Rgb32FImage::from_raw(self.width, self.height, rgb)
            .ok_or_else(|| io(&exr, &"pixel count does not match the size"))?
            .save(&exr)
            .map_err(|e| io(&exr, &e))?;
        let json = dir.join("timings.json");
        let mut timings = FrameTimings::default();
        timings.frames = self.timings.clone();
        let file = TimingsFile {
            adapter: &self.adapter,
            width: self.width,
            height: self.height,
            mean_gpu_ms: timings.mean_ms(),
            frames: &self.timings,
        };
        let text = serde_json::to_string_pretty(&file).map_err(|e| io(&json, &e))?;
        std::fs::write(&json, text).map_err(|e| io(&json, &e))?;
        Ok(())
    }
}

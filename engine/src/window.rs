//! The windowed runner (winit 0.30): one window, the camera path presented to its surface, wall-clock
//! time. A window resized to zero or minimized skips frames instead of failing.

use std::sync::Arc;

use bevy_app::App;
use bevy_ecs::world::World;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::app::{EnginePlugin, GpuLost, Time, finish_plugins};
use crate::gpu::{GpuContext, GpuOptions};
use crate::headless::add_default_camera;
use crate::render::{RenderPlugin, RenderSize, SurfaceTarget, blit_program};
use crate::scene::SceneDescription;

/// Why the window could not run.
#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    #[error("cannot open a window (is a display available? set DISPLAY or WAYLAND_DISPLAY): {0}")]
    EventLoop(String),
    #[error("cannot create the window or its surface: {0}")]
    Surface(String),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error("the GPU device was lost {count} times in a row (last: {reason}); giving up")]
    DeviceLost { count: u32, reason: String },
}

/// Opens a window showing `scene` until it is closed or Esc is pressed.
pub fn run_windowed(mut scene: SceneDescription) -> Result<(), WindowError> {
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    let event_loop = EventLoop::new().map_err(|e| WindowError::EventLoop(e.to_string()))?;
    let mut runner = WindowedRunner { scene, state: None, error: None, recoveries: 0 };
    event_loop.run_app(&mut runner).map_err(|e| WindowError::EventLoop(e.to_string()))?;
    runner.error.map_or(Ok(()), Err)
}

struct WindowState {
    window: Arc<Window>,
    app: App,
}

struct WindowedRunner {
    /// The scene, kept to rebuild the app on a new device after a lost one.
    scene: SceneDescription,
    state: Option<WindowState>,
    error: Option<WindowError>,
    /// Devices reopened since the last frame that rendered.
    recoveries: u32,
}

impl WindowedRunner {
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<WindowState, WindowError> {
        let attributes = Window::default_attributes().with_title("game_demo").with_inner_size(winit::dpi::LogicalSize::new(1280, 720));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| WindowError::Surface(e.to_string()))?);
        self.build(window, Time::real())
    }

    fn build(&self, window: Arc<Window>, time: Time) -> Result<WindowState, WindowError> {
        let mut app = windowed_app(&window, time)?.app;
        self.scene.clone().spawn(app.world_mut());
        finish_plugins(&mut app);
        window.request_redraw();
        Ok(WindowState { window, app })
    }

    /// After a frame: a lost surface is replaced; a lost device is reopened and the scene rebuilt
    /// on it, the clock going on (at most [`MAX_DEVICE_RECOVERIES`] times in a row).
    fn recover(&mut self) -> Result<(), WindowError> {
        let Some(state) = &mut self.state else { return Ok(()) };
        let Some(lost) = check_surface_and_device(state.app.world_mut(), &state.window, &mut self.recoveries)? else { return Ok(()) };
        log::warn!("the GPU device was lost ({}): opening a new one and rebuilding the scene", lost.reason);
        let time = state.app.world().resource::<Time>().continuing();
        let window = state.window.clone();
        self.state = None;
        self.state = Some(self.build(window, time)?);
        Ok(())
    }
}

/// An app presenting to a window: the GPU (an adapter that can present to the window), the
/// window's surface configured for the tonemapped image, and the engine with the camera path.
pub struct WindowedApp {
    pub app: App,
    pub gpu: GpuContext,
    /// The surface's format (not sRGB: the image is already encoded).
    pub format: wgpu::TextureFormat,
}

/// Builds a [`WindowedApp`] for `window` on the clock `time` (real time for play, a fixed step
/// for scripted runs that must match headless ones). Keeps the timings of the last 600 frames.
pub fn windowed_app(window: &Arc<Window>, time: Time) -> Result<WindowedApp, WindowError> {
    let instance = GpuContext::create_instance();
    let surface = instance.create_surface(window.clone()).map_err(|e| WindowError::Surface(e.to_string()))?;
    let gpu = GpuContext::new(GpuOptions { compatible_surface: Some(&surface), instance: Some(instance.clone()), ..Default::default() })?;
    let size = window.inner_size();
    let caps = surface.get_capabilities(&gpu.adapter);
    // The image is sRGB-encoded by the tonemapper: present it through a non-sRGB format.
    let format = caps
        .formats
        .iter()
        .copied()
        .find(|f| !f.is_srgb())
        .or(caps.formats.first().copied())
        .ok_or_else(|| WindowError::Surface("the surface supports no format".into()))?;
    let mut config = surface
        .get_default_config(&gpu.adapter, size.width.max(1), size.height.max(1))
        .ok_or_else(|| WindowError::Surface("the surface is not supported by the adapter".into()))?;
    config.format = format;
    surface.configure(&gpu.device, &config);
    let blit = blit_program(&gpu, format).map_err(|e| WindowError::Surface(e.to_string()))?;

    let mut app = App::new();
    app.insert_resource(time);
    app.add_plugins((EnginePlugin, RenderPlugin { gpu: gpu.clone(), size: RenderSize { width: config.width, height: config.height } }));
    app.insert_resource(SurfaceTarget { surface, config, blit: Arc::new(blit), lost: Default::default() });
    app.world_mut().resource_mut::<crate::render::FrameTimings>().keep = 600;
    Ok(WindowedApp { app, gpu, format })
}

/// Follows a window's new size: reconfigures the surface and the render size. A zero-sized
/// (minimized) window keeps its last configuration; its frames are skipped by the runner. A window
/// larger than the GPU's largest texture renders at that largest size (the surface stretches it).
pub fn resize_surface(world: &mut World, size: PhysicalSize<u32>) {
    if size.width == 0 || size.height == 0 || world.contains_resource::<GpuLost>() {
        return;
    }
    let gpu = world.resource::<GpuContext>().clone();
    let max = gpu.device.limits().max_texture_dimension_2d;
    let (width, height) = (size.width.min(max), size.height.min(max));
    if (width, height) != (size.width, size.height) {
        log::warn!(
            "the window is {}×{} pixels, more than the GPU's largest texture ({max}): rendering {width}×{height}",
            size.width,
            size.height
        );
    }
    let mut target = world.resource_mut::<SurfaceTarget>();
    target.config.width = width;
    target.config.height = height;
    target.surface.configure(&gpu.device, &target.config);
    world.insert_resource(RenderSize { width, height });
}

/// Creates a new surface for `window` when the last one was lost ([`SurfaceTarget::lost`]),
/// configured as the old one was. Returns whether it replaced one.
pub fn replace_lost_surface(world: &mut World, window: &Arc<Window>) -> Result<bool, WindowError> {
    let Some(target) = world.get_resource::<SurfaceTarget>() else { return Ok(false) };
    if !target.lost.load(std::sync::atomic::Ordering::Relaxed) || world.contains_resource::<GpuLost>() {
        return Ok(false);
    }
    let gpu = world.resource::<GpuContext>().clone();
    let surface = gpu.instance.create_surface(window.clone()).map_err(|e| WindowError::Surface(e.to_string()))?;
    let mut target = world.resource_mut::<SurfaceTarget>();
    surface.configure(&gpu.device, &target.config);
    target.surface = surface;
    target.lost.store(false, std::sync::atomic::Ordering::Relaxed);
    log::warn!("the lost surface was replaced by a new one");
    Ok(true)
}

/// How many times in a row a runner reopens the GPU after losing it before it gives up.
pub const MAX_DEVICE_RECOVERIES: u32 = 3;

/// What a windowed runner checks after each frame: a lost surface is replaced
/// ([`replace_lost_surface`]); a lost device is returned for the runner to rebuild its app on a new
/// one, counted in `recoveries` (reset by a frame that rendered), and an error once it has been
/// lost more than [`MAX_DEVICE_RECOVERIES`] times in a row.
pub fn check_surface_and_device(world: &mut World, window: &Arc<Window>, recoveries: &mut u32) -> Result<Option<GpuLost>, WindowError> {
    replace_lost_surface(world, window)?;
    let Some(lost) = world.get_resource::<GpuLost>().cloned() else {
        *recoveries = 0;
        return Ok(None);
    };
    *recoveries += 1;
    if *recoveries > MAX_DEVICE_RECOVERIES {
        return Err(WindowError::DeviceLost { count: *recoveries, reason: lost.reason });
    }
    Ok(Some(lost))
}

impl ApplicationHandler for WindowedRunner {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.state.is_some() {
            return;
        }
        match self.open(event_loop) {
            Ok(state) => self.state = Some(state),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(state) = &mut self.state else { return };
        match event {
            WindowEvent::CloseRequested
            | WindowEvent::KeyboardInput {
                event: KeyEvent { logical_key: Key::Named(NamedKey::Escape), state: ElementState::Pressed, .. },
                ..
            } => event_loop.exit(),
            WindowEvent::Resized(size) => {
                resize_surface(state.app.world_mut(), size);
                state.window.request_redraw();
            }
            WindowEvent::RedrawRequested => {
                let size = state.window.inner_size();
                if size.width > 0 && size.height > 0 {
                    state.app.update();
                }
                let window = state.window.clone();
                if let Err(e) = self.recover() {
                    self.error = Some(e);
                    event_loop.exit();
                    return;
                }
                window.request_redraw();
            }
            _ => {}
        }
    }
}

//! The windowed runner (winit 0.30): one window presenting the camera path, on wall-clock time or a
//! fixed step. An app brings its plugins, systems, input and overlay through [`WindowHooks`]; the
//! runner keeps the surface: a window resized to zero or minimized skips its frames, a lost surface
//! is replaced, and a lost GPU device is reopened and the app rebuilt on it.
//!
//! ```no_run
//! use engine::window::{WindowContext, WindowHooks, run_window};
//! struct Viewer(engine::scene::SceneDescription);
//! impl WindowHooks for Viewer {
//!     fn build(&mut self, window: &mut WindowContext) -> Result<(), String> {
//!         self.0.clone().spawn(window.app.world_mut());
//!         Ok(())
//!     }
//! }
//! run_window(Viewer(engine::import::load_scene(std::path::Path::new("scene.glb")).unwrap())).unwrap();
//! ```

use std::sync::Arc;

use bevy_app::App;
use bevy_ecs::world::World;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{DeviceEvent, DeviceId, ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowAttributes, WindowId};

use crate::app::{EnginePlugin, GpuLost, Time, finish_plugins};
use crate::gpu::{GpuContext, GpuOptions};
use crate::headless::add_default_camera;
use crate::render::{RenderPlugin, RenderSize, SurfaceTarget, blit_program};
use crate::scene::SceneDescription;

/// Why the window could not run.
#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    /// winit could not open its event loop (no display), with its message.
    #[error("cannot open a window (is a display available? set DISPLAY or WAYLAND_DISPLAY): {0}")]
    EventLoop(String),
    /// The window, its surface or the surface's blit pipeline could not be made, with the reason.
    #[error("cannot create the window or its surface: {0}")]
    Surface(String),
    /// No GPU could present to the window.
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    /// The device was lost more than [`MAX_DEVICE_RECOVERIES`] times in a row (each loss reopens it
    /// and rebuilds the app).
    #[error("the GPU device was lost {count} times in a row (last: {reason}); giving up")]
    DeviceLost {
        /// Losses in a row.
        count: u32,
        /// Why the last one happened, as wgpu said.
        reason: String,
    },
    /// An error of the app's hooks.
    #[error("{0}")]
    App(String),
}

/// A UI living in the app (a plugin's debug overlay, say) that takes the window's input: the
/// runner hands it every window event before the app's [`WindowHooks`] see it, and calls it before
/// each frame's update. Insert it as a [`WindowUiHook`] resource (the `ddgi_overlay` plugin does,
/// for its egui); a windowless app never calls it.
pub trait WindowUi: Send + Sync + 'static {
    /// A window event. Returns whether the UI used it (a click on its window, a key typed into a
    /// field): the hooks then see [`WindowContext::event_consumed_by_ui`] true and should not act on
    /// it too.
    fn window_event(&mut self, window: &Window, world: &mut World, event: &WindowEvent) -> bool;
    /// Before each frame's update (after [`WindowHooks::before_frame`]): take this frame's input.
    fn before_frame(&mut self, window: &Window, world: &mut World);
}

/// The app's [`WindowUi`], as a resource the windowed runner looks for.
#[derive(bevy_ecs::prelude::Resource)]
pub struct WindowUiHook(pub Box<dyn WindowUi>);

/// How many times in a row the runner reopens the GPU after losing it before it gives up.
pub const MAX_DEVICE_RECOVERIES: u32 = 3;

/// What an app adds to the windowed runner. Only [`WindowHooks::build`] is required; the other
/// hooks default to nothing (and Esc closing the window).
pub trait WindowHooks: 'static {
    /// The window to open. Default: titled "engine", 1280×720 logical pixels.
    fn attributes(&self) -> WindowAttributes {
        Window::default_attributes().with_title("engine").with_inner_size(winit::dpi::LogicalSize::new(1280, 720))
    }

    /// The app's clock. Default: wall-clock time; a fixed step makes a windowed run render frame for
    /// frame what a headless one does.
    fn time(&self) -> Time {
        Time::real()
    }

    /// Adds the app's plugins, systems, scene and overlay (a [`WindowUiHook`] for its input and an
    /// [`crate::render::ImageOverlayHook`] for its draws, which a UI plugin inserts itself) to
    /// `window.app`, which already has the engine, the camera path and the window's surface; the
    /// runner finishes the plugins afterwards. Called when the window opens and again on a new GPU
    /// device after a lost one, the clock going on.
    fn build(&mut self, window: &mut WindowContext) -> Result<(), String>;

    /// The GPU device was lost: `window.app` is dropped next and [`WindowHooks::build`] called on a
    /// new device. Keep here what must outlive the app (where the player stands, say).
    fn device_lost(&mut self, _window: &mut WindowContext) {}

    /// A window event, before the runner handles it (it handles closing, resizing and redrawing).
    /// Default: Esc exits.
    fn window_event(&mut self, window: &mut WindowContext, event: &WindowEvent) {
        if let WindowEvent::KeyboardInput {
            event: KeyEvent { logical_key: Key::Named(NamedKey::Escape), state: ElementState::Pressed, .. },
            ..
        } = event
        {
            window.exit();
        }
    }

    /// A device event (raw mouse motion, say).
    fn device_event(&mut self, _window: &mut WindowContext, _event: &DeviceEvent) {}

    /// Before each frame's update: input into resources, the overlay's UI.
    fn before_frame(&mut self, _window: &mut WindowContext) {}

    /// After each redraw, before lost surfaces and devices are dealt with: `rendered` is false when
    /// the window had no pixels and the frame was skipped. An error ends the run with it.
    fn after_redraw(&mut self, _window: &mut WindowContext, _rendered: bool) -> Result<(), String> {
        Ok(())
    }
}

/// Opens a window driven by `hooks` and runs it until it is closed or a hook calls
/// [`WindowContext::exit`].
pub fn run_window(hooks: impl WindowHooks) -> Result<(), WindowError> {
    let event_loop = EventLoop::new().map_err(|e| WindowError::EventLoop(e.to_string()))?;
    let mut runner = Runner { hooks, state: None, error: None, recoveries: 0 };
    event_loop.run_app(&mut runner).map_err(|e| WindowError::EventLoop(e.to_string()))?;
    runner.error.map_or(Ok(()), Err)
}

/// Opens a window showing `scene` (with a default camera if it has none) until it is closed or Esc
/// is pressed.
pub fn run_windowed(mut scene: SceneDescription) -> Result<(), WindowError> {
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    run_window(SceneViewer(scene))
}

/// The scene viewer: the scene, kept to spawn it again on a new device.
struct SceneViewer(SceneDescription);

impl WindowHooks for SceneViewer {
    fn attributes(&self) -> WindowAttributes {
        Window::default_attributes().with_title("game_demo").with_inner_size(winit::dpi::LogicalSize::new(1280, 720))
    }

    fn build(&mut self, window: &mut WindowContext) -> Result<(), String> {
        self.0.clone().spawn(window.app.world_mut());
        Ok(())
    }
}

/// The window and the app presenting to it, as the hooks see them.
pub struct WindowContext {
    /// The winit window.
    pub window: Arc<Window>,
    /// The engine, the camera path and the window's surface, plus what the hooks built.
    pub app: App,
    /// The GPU (an adapter that can present to the window).
    pub gpu: GpuContext,
    /// The surface's format (not sRGB: the image is already encoded).
    pub format: wgpu::TextureFormat,
    /// The window's size as last reported (zero while minimized).
    size: PhysicalSize<u32>,
    /// Whether the app's [`WindowUi`] used the event being handled.
    ui_consumed: bool,
    frames: u32,
    skipped: u32,
    exit: bool,
}

impl WindowContext {
    /// Frames rendered since the window opened, across rebuilds on new devices.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Redraws skipped because the window had no pixels, since it opened.
    pub fn skipped_redraws(&self) -> u32 {
        self.skipped
    }

    /// Whether the app's [`WindowUi`] used the window event the hooks are handling (always false
    /// without one).
    pub fn event_consumed_by_ui(&self) -> bool {
        self.ui_consumed
    }

    /// The window's size as last reported.
    pub fn size(&self) -> PhysicalSize<u32> {
        self.size
    }

    /// Follows a new window size, as a `Resized` event does: the surface and the render size are
    /// reconfigured; at zero pixels the configuration stays and frames are skipped until the
    /// window has pixels again.
    pub fn resize(&mut self, size: PhysicalSize<u32>) {
        self.size = size;
        resize_surface(self.app.world_mut(), size);
        self.window.request_redraw();
    }

    /// Ends the run after the current event.
    pub fn exit(&mut self) {
        self.exit = true;
    }
}

struct Runner<H> {
    hooks: H,
    state: Option<WindowContext>,
    error: Option<WindowError>,
    /// Devices reopened since the last frame that rendered.
    recoveries: u32,
}

impl<H: WindowHooks> Runner<H> {
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<WindowContext, WindowError> {
        let window = Arc::new(event_loop.create_window(self.hooks.attributes()).map_err(|e| WindowError::Surface(e.to_string()))?);
        let size = window.inner_size();
        self.build(window, self.hooks.time(), size, 0, 0)
    }

    /// A new app on a new device for `window`, built by the hooks; `frames` and `skipped` go on.
    fn build(
        &mut self,
        window: Arc<Window>,
        time: Time,
        size: PhysicalSize<u32>,
        frames: u32,
        skipped: u32,
    ) -> Result<WindowContext, WindowError> {
        let (app, gpu, format) = windowed_app(&window, time)?;
        let mut state = WindowContext { window, app, gpu, format, size, ui_consumed: false, frames, skipped, exit: false };
        self.hooks.build(&mut state).map_err(WindowError::App)?;
        finish_plugins(&mut state.app);
        state.window.request_redraw();
        Ok(state)
    }

    /// One redraw: a frame when the window has pixels, a skip (counted) when it has none; then the
    /// hooks' look at it, and lost surfaces and devices dealt with.
    fn redraw(&mut self) -> Result<(), WindowError> {
        let Some(state) = &mut self.state else { return Ok(()) };
        let rendered = state.size.width > 0 && state.size.height > 0;
        if rendered {
            self.hooks.before_frame(state);
            let window = state.window.clone();
            if state.app.world().contains_resource::<WindowUiHook>() {
                state
                    .app
                    .world_mut()
                    .resource_scope(|world, mut ui: bevy_ecs::change_detection::Mut<WindowUiHook>| ui.0.before_frame(&window, world));
            }
            state.app.update();
            state.frames += 1;
        } else {
            state.skipped += 1;
        }
        self.hooks.after_redraw(state, rendered).map_err(WindowError::App)?;
        if state.exit {
            return Ok(());
        }
        self.recover()
    }

    /// A lost surface is replaced; a lost device is reopened and the app rebuilt on it, the clock
    /// going on (at most [`MAX_DEVICE_RECOVERIES`] times in a row).
    fn recover(&mut self) -> Result<(), WindowError> {
        let Some(state) = &mut self.state else { return Ok(()) };
        replace_lost_surface(state.app.world_mut(), &state.window)?;
        let Some(lost) = state.app.world().get_resource::<GpuLost>().cloned() else {
            self.recoveries = 0;
            return Ok(());
        };
        self.recoveries += 1;
        if self.recoveries > MAX_DEVICE_RECOVERIES {
            return Err(WindowError::DeviceLost { count: self.recoveries, reason: lost.reason });
        }
        log::warn!("the GPU device was lost ({}): opening a new one and rebuilding the app", lost.reason);
        self.hooks.device_lost(state);
        let time = state.app.world().resource::<Time>().continuing();
        let (window, size, frames, skipped) = (state.window.clone(), state.size, state.frames, state.skipped);
        // The old surface goes before a new one is created on the same window.
        self.state = None;
        self.state = Some(self.build(window, time, size, frames, skipped)?);
        Ok(())
    }
}

impl<H: WindowHooks> ApplicationHandler for Runner<H> {
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

    fn device_event(&mut self, event_loop: &ActiveEventLoop, _id: DeviceId, event: DeviceEvent) {
        let Some(state) = &mut self.state else { return };
        self.hooks.device_event(state, &event);
        if state.exit {
            event_loop.exit();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(state) = &mut self.state else { return };
        let window = state.window.clone();
        state.ui_consumed = state.app.world().contains_resource::<WindowUiHook>()
            && state
                .app
                .world_mut()
                .resource_scope(|world, mut ui: bevy_ecs::change_detection::Mut<WindowUiHook>| ui.0.window_event(&window, world, &event));
        self.hooks.window_event(state, &event);
        let result = match event {
            WindowEvent::CloseRequested => {
                state.exit();
                Ok(())
            }
            WindowEvent::Resized(size) => {
                state.resize(size);
                Ok(())
            }
            WindowEvent::RedrawRequested => self.redraw(),
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.error = Some(e);
            event_loop.exit();
            return;
        }
        let Some(state) = &self.state else { return };
        if state.exit {
            event_loop.exit();
        } else if matches!(event, WindowEvent::RedrawRequested) {
            state.window.request_redraw();
        }
    }
}

/// An app presenting to `window` on the clock `time`: the GPU (an adapter that can present to the
/// window), the window's surface configured for the tonemapped image, the engine with the camera
/// path, the timings of the last 600 frames kept. Returns the app, the GPU and the surface's format.
fn windowed_app(window: &Arc<Window>, time: Time) -> Result<(App, GpuContext, wgpu::TextureFormat), WindowError> {
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
    Ok((app, gpu, format))
}

/// Follows a window's new size: reconfigures the surface and the render size. A zero-sized
/// (minimized) window keeps its last configuration; its frames are skipped by the runner. A window
/// larger than the GPU's largest texture renders at that largest size (the surface stretches it).
fn resize_surface(world: &mut World, size: PhysicalSize<u32>) {
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
/// configured as the old one was.
fn replace_lost_surface(world: &mut World, window: &Arc<Window>) -> Result<(), WindowError> {
    let Some(target) = world.get_resource::<SurfaceTarget>() else { return Ok(()) };
    if !target.lost.load(std::sync::atomic::Ordering::Relaxed) || world.contains_resource::<GpuLost>() {
        return Ok(());
    }
    let gpu = world.resource::<GpuContext>().clone();
    let surface = gpu.instance.create_surface(window.clone()).map_err(|e| WindowError::Surface(e.to_string()))?;
    let mut target = world.resource_mut::<SurfaceTarget>();
    surface.configure(&gpu.device, &target.config);
    target.surface = surface;
    target.lost.store(false, std::sync::atomic::Ordering::Relaxed);
    log::warn!("the lost surface was replaced by a new one");
    Ok(())
}

//! `game_demo play` in a window: first-person controls, the egui overlay (F1), screenshots (F12).
//!
//! Controls: click the view to grab the mouse; WASD walk, Shift run, Space jump, mouse look; E
//! opens or closes the door (back to its automatic cycle with R); Esc releases the mouse, a second
//! Esc quits. With the overlay open the mouse is free: click a probe sphere to inspect it.
//!
//! With `--script` the window runs the level's scripted tour on the fixed clock, frame for frame
//! what the headless mode renders, saves a screenshot at a chosen frame and exits: the test under
//! Xvfb compares the two.

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use bevy_app::App;
use engine::app::Time;
use engine::gpu::GpuContext;
use engine::render::{SurfaceOverlay, SurfaceOverlayHook};
use engine::window::{WindowError, WindowedApp, check_surface_and_device, resize_surface, windowed_app};
use glam::Vec2;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{DeviceEvent, DeviceId, ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{CursorGrabMode, Window, WindowId};

use super::controller::{Player, PlayerInput, ScriptedTour};
use super::level::DoorControl;
use super::overlay::{OverlayState, overlay_ui, pick_probe_in_world};
use super::{PlayOptions, save_screenshot, setup_play};

/// Mouse-look sensitivity, radians per pixel of mouse motion.
const LOOK_RADIANS_PER_PIXEL: f32 = 0.0025;

/// A scripted windowed run (tests): the fixed clock, the level's tour, a screenshot, then exit.
pub struct WindowScript {
    pub frames: u32,
    pub screenshot: PathBuf,
    /// Inject faults on the way ([`FAULTS`]): the window minimized to zero size, resized to two
    /// pixels and back, the surface lost, the GPU device lost. Each must be survived.
    pub faults: bool,
}

/// A fault of the scripted run, and the frame after which it is injected.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Fault {
    /// A `Resized` of zero pixels (what a minimized window reports), then this many redraws, then
    /// the old size again.
    Minimize {
        redraws: u32,
    },
    /// The window resized to two by two pixels by the window system, and back after 4 frames.
    Shrink,
    Restore,
    /// The surface reports itself lost.
    SurfaceLost,
    /// The GPU device is lost (destroyed, as a driver reset would).
    DeviceLost,
}

/// The scripted faults, by frame (the script's --frames must pass the last one).
const FAULTS: [(u32, Fault); 5] =
    [(6, Fault::Minimize { redraws: 5 }), (10, Fault::Shrink), (14, Fault::Restore), (18, Fault::SurfaceLost), (22, Fault::DeviceLost)];

/// Opens the demo's window and runs it until it is closed.
pub fn run_window(options: PlayOptions, script: Option<WindowScript>) -> Result<(), String> {
    let event_loop = EventLoop::new().map_err(|e| WindowError::EventLoop(e.to_string()).to_string())?;
    let mut runner = Runner { options, script, state: None, error: None, recoveries: 0, faults: Vec::new() };
    event_loop.run_app(&mut runner).map_err(|e| e.to_string())?;
    runner.error.map_or(Ok(()), Err)
}

struct Runner {
    options: PlayOptions,
    script: Option<WindowScript>,
    state: Option<State>,
    error: Option<String>,
    /// Devices reopened since the last frame that rendered.
    recoveries: u32,
    /// The scripted faults still to inject.
    faults: Vec<(u32, Fault)>,
}

/// What outlives the app when it is rebuilt on a new device: where the player stands, the tour,
/// the door's override, the overlay's settings and the frame count.
struct Resume {
    player: Option<Player>,
    tour: Option<ScriptedTour>,
    door: Option<DoorControl>,
    overlay: OverlayState,
    frames: u32,
}

struct State {
    window: Arc<Window>,
    /// The window's size as last reported (zero while minimized: frames are skipped).
    size: PhysicalSize<u32>,
    /// Redraws skipped while the window had no pixels.
    skipped: u32,
    app: App,
    gpu: GpuContext,
    egui: egui::Context,
    egui_winit: egui_winit::State,
    painter: Arc<EguiPainter>,
    overlay: OverlayState,
    keys: HashSet<KeyCode>,
    look: Vec2,
    jump: bool,
    grabbed: bool,
    cursor: Vec2,
    last_frame: Option<Instant>,
    frames: u32,
    screenshot_requested: bool,
}

/// egui's draws, recorded as the overlay pass after the frame's blit.
struct EguiPainter {
    renderer: Mutex<egui_wgpu::Renderer>,
    frame: Mutex<Option<EguiFrame>>,
}

struct EguiFrame {
    jobs: Vec<egui::ClippedPrimitive>,
    textures: egui::TexturesDelta,
    pixels_per_point: f32,
}

impl Drop for EguiFrame {
    /// A frame dropped unpresented (the window closing) lets its texture updates go.
    fn drop(&mut self) {
        self.textures.clear();
    }
}

impl SurfaceOverlay for EguiPainter {
    fn label(&self) -> &'static str {
        "egui_overlay"
    }

    fn record(&self, gpu: &GpuContext, encoder: &mut engine::wgpu::CommandEncoder, target: &engine::wgpu::TextureView, size: (u32, u32)) {
        let Some(frame) = self.frame.lock().unwrap_or_else(|e| e.into_inner()).take() else { return };
        let mut renderer = self.renderer.lock().unwrap_or_else(|e| e.into_inner());
        for (id, deltas) in &frame.textures.set {
            for delta in deltas {
                renderer.update_texture(&gpu.device, &gpu.queue, *id, delta);
            }
        }
        let screen = egui_wgpu::ScreenDescriptor { size_in_pixels: [size.0, size.1], pixels_per_point: frame.pixels_per_point };
        renderer.update_buffers(&gpu.device, &gpu.queue, encoder, &frame.jobs, &screen);
        {
            let pass = encoder.begin_render_pass(&engine::wgpu::RenderPassDescriptor {
                label: Some("egui_overlay"),
                color_attachments: &[Some(engine::wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: engine::wgpu::Operations { load: engine::wgpu::LoadOp::Load, store: engine::wgpu::StoreOp::Store },
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

impl Runner {
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<State, String> {
        let (width, height) = (self.options.width, self.options.height);
        let faults = self.script.as_ref().is_some_and(|s| s.faults);
        if faults {
            self.faults = FAULTS.to_vec();
        }
        let attributes = Window::default_attributes()
            .with_title("game_demo — DDGI (F1: overlay)")
            .with_inner_size(winit::dpi::PhysicalSize::new(width, height))
            .with_resizable(self.script.is_none() || faults);
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| format!("cannot create the window: {e}"))?);
        // A scripted run renders frame for frame what the headless mode does.
        let time = if self.script.is_some() { Time::fixed(super::STEP_SECONDS) } else { Time::real() };
        self.build(window, time, None)
    }

    /// The app, the overlay and the level on `window`; `resume` carries the state of an app that
    /// lost its device.
    fn build(&self, window: Arc<Window>, time: Time, resume: Option<Resume>) -> Result<State, String> {
        let WindowedApp { mut app, gpu, format } = windowed_app(&window, time).map_err(|e| e.to_string())?;
        if self.script.is_some() {
            app.insert_resource(engine::rt::WaitForBlasBuilds(true));
            app.world_mut().resource_mut::<engine::render::FrameTimings>().wait_each_frame = true;
        }
        setup_play(&mut app, &self.options, self.script.is_some())?;

        let renderer = egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        let painter = Arc::new(EguiPainter { renderer: Mutex::new(renderer), frame: Mutex::new(None) });
        app.insert_resource(SurfaceOverlayHook(painter.clone()));
        let egui = egui::Context::default();
        let max_texture = gpu.device.limits().max_texture_dimension_2d as usize;
        let egui_winit = egui_winit::State::new(
            egui.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(max_texture),
        );
        let (overlay, frames) = match resume {
            Some(resume) => {
                let world = app.world_mut();
                if let Some(player) = resume.player {
                    let mut players = world.query::<&mut Player>();
                    for mut p in players.iter_mut(world) {
                        *p = player.clone();
                    }
                }
                if let Some(tour) = resume.tour {
                    world.insert_resource(tour);
                }
                if let Some(door) = resume.door {
                    world.insert_resource(door);
                }
                (resume.overlay, resume.frames)
            }
            None => (OverlayState::default(), 0),
        };
        window.request_redraw();
        Ok(State {
            size: window.inner_size(),
            skipped: 0,
            window,
            app,
            gpu,
            egui,
            egui_winit,
            painter,
            overlay,
            keys: HashSet::new(),
            look: Vec2::ZERO,
            jump: false,
            grabbed: false,
            cursor: Vec2::ZERO,
            last_frame: None,
            frames,
            screenshot_requested: false,
        })
    }

    /// After a frame: a lost surface is replaced; a lost device is reopened and the level rebuilt
    /// on it where the player stood, its clock going on (at most [`engine::window::MAX_DEVICE_RECOVERIES`] times
    /// in a row).
    fn recover(&mut self) -> Result<(), String> {
        let Some(state) = &mut self.state else { return Ok(()) };
        let lost = check_surface_and_device(state.app.world_mut(), &state.window, &mut self.recoveries).map_err(|e| e.to_string())?;
        let Some(lost) = lost else { return Ok(()) };
        log::warn!("the GPU device was lost ({}): opening a new one and rebuilding the level where the player stood", lost.reason);
        let mut old = self.state.take().expect("state checked above");
        let world = old.app.world_mut();
        let time = world.resource::<Time>().continuing();
        let player = world.query::<&Player>().iter(world).next().cloned();
        let resume = Resume {
            player,
            tour: world.remove_resource::<ScriptedTour>(),
            door: world.remove_resource::<DoorControl>(),
            overlay: std::mem::take(&mut old.overlay),
            frames: old.frames,
        };
        let window = old.window.clone();
        drop(old);
        self.state = Some(self.build(window, time, Some(resume))?);
        log::warn!("the level runs on a new GPU device");
        Ok(())
    }

    /// Injects the scripted faults due after the frame just drawn.
    fn inject_faults(&mut self) -> Result<(), String> {
        let Some(frames) = self.state.as_ref().map(|s| s.frames) else { return Ok(()) };
        let due: Vec<Fault> = self.faults.iter().filter(|(f, _)| *f <= frames).map(|(_, fault)| *fault).collect();
        self.faults.retain(|(f, _)| *f > frames);
        for fault in due {
            log::warn!("fault injected after frame {frames}: {fault:?}");
            let Some(state) = &mut self.state else { return Ok(()) };
            match fault {
                Fault::Minimize { redraws } => {
                    let size = state.size;
                    self.handle_resize(PhysicalSize::new(0, 0));
                    for _ in 0..redraws {
                        self.draw_if_visible();
                    }
                    let state = self.state.as_ref().expect("a state");
                    if state.frames != frames {
                        return Err(format!("the minimized window rendered {} frames", state.frames - frames));
                    }
                    log::warn!("{} redraws skipped while minimized", state.skipped);
                    self.handle_resize(size);
                }
                Fault::Shrink => {
                    let _ = state.window.request_inner_size(PhysicalSize::new(2, 2));
                }
                Fault::Restore => {
                    let _ = state.window.request_inner_size(PhysicalSize::new(self.options.width, self.options.height));
                }
                Fault::SurfaceLost => {
                    state.app.world().resource::<engine::render::SurfaceTarget>().lost.store(true, std::sync::atomic::Ordering::Relaxed);
                }
                Fault::DeviceLost => state.gpu.simulate_device_loss(),
            }
        }
        Ok(())
    }

    fn handle_resize(&mut self, size: PhysicalSize<u32>) {
        let Some(state) = &mut self.state else { return };
        state.size = size;
        resize_surface(state.app.world_mut(), size);
        state.window.request_redraw();
    }

    /// One redraw: a frame when the window has pixels, nothing (counted) when it has none.
    fn draw_if_visible(&mut self) -> Option<Result<(), String>> {
        let scripted = self.script.is_some();
        let state = self.state.as_mut()?;
        if state.size.width == 0 || state.size.height == 0 {
            state.skipped += 1;
            return None;
        }
        Some(state.redraw(scripted))
    }
}

impl State {
    fn set_grab(&mut self, grab: bool) {
        if grab {
            let ok = self.window.set_cursor_grab(CursorGrabMode::Locked).or_else(|_| self.window.set_cursor_grab(CursorGrabMode::Confined));
            if let Err(e) = ok {
                log::warn!("cannot grab the mouse: {e}");
            }
        } else {
            let _ = self.window.set_cursor_grab(CursorGrabMode::None);
        }
        self.window.set_cursor_visible(!grab);
        self.grabbed = grab;
    }

    fn player_input(&mut self) -> PlayerInput {
        let key = |k: KeyCode| self.keys.contains(&k);
        let axis = |plus: bool, minus: bool| f32::from(u8::from(plus)) - f32::from(u8::from(minus));
        PlayerInput {
            forward: axis(key(KeyCode::KeyW) || key(KeyCode::ArrowUp), key(KeyCode::KeyS) || key(KeyCode::ArrowDown)),
            right: axis(key(KeyCode::KeyD) || key(KeyCode::ArrowRight), key(KeyCode::KeyA) || key(KeyCode::ArrowLeft)),
            jump: std::mem::take(&mut self.jump) || key(KeyCode::Space),
            run: key(KeyCode::ShiftLeft) || key(KeyCode::ShiftRight),
            look: std::mem::take(&mut self.look) * LOOK_RADIANS_PER_PIXEL * Vec2::new(-1.0, -1.0),
        }
    }

    /// One frame: input, the overlay's UI, the app's update (render and present).
    fn redraw(&mut self, scripted: bool) -> Result<(), String> {
        let now = Instant::now();
        let dt = self.last_frame.map_or(0.0, |l| (now - l).as_secs_f64());
        self.last_frame = Some(now);
        self.overlay.frame(dt);
        if !scripted {
            let input = self.player_input();
            self.app.world_mut().insert_resource(input);
        }
        // The overlay's UI (an empty frame when hidden, so egui's textures stay in step).
        let raw = self.egui_winit.take_egui_input(&self.window);
        let world = self.app.world_mut();
        let overlay = &mut self.overlay;
        let output = self.egui.run_pass(raw, |ctx| overlay_ui(ctx, overlay, world));
        self.egui_winit.handle_platform_output(&self.window, output.platform_output);
        let jobs = self.egui.tessellate(output.shapes, output.pixels_per_point);
        {
            // A frame that was never presented (surface unavailable) keeps its texture updates:
            // they go first.
            let mut pending = self.painter.frame.lock().unwrap_or_else(|e| e.into_inner());
            let mut textures = pending.take().map(|mut f| std::mem::take(&mut f.textures)).unwrap_or_default();
            textures.append(output.textures_delta);
            *pending = Some(EguiFrame { jobs, textures, pixels_per_point: output.pixels_per_point });
        }
        self.app.update();
        self.frames += 1;
        if std::mem::take(&mut self.overlay.screenshot_requested) || std::mem::take(&mut self.screenshot_requested) {
            let path = PathBuf::from("screenshots").join(format!("screenshot_{:05}.png", self.frames));
            match save_screenshot(&self.gpu, self.app.world(), &path) {
                Ok(()) => log::warn!("screenshot: {}", path.display()),
                Err(e) => log::error!("screenshot failed: {e}"),
            }
        }
        Ok(())
    }
}

impl ApplicationHandler for Runner {
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

    fn device_event(&mut self, _event_loop: &ActiveEventLoop, _id: DeviceId, event: DeviceEvent) {
        let Some(state) = &mut self.state else { return };
        if let DeviceEvent::MouseMotion { delta } = event
            && state.grabbed
        {
            state.look += Vec2::new(delta.0 as f32, delta.1 as f32);
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(state) = &mut self.state else { return };
        let scripted = self.script.is_some();
        let egui_consumed = state.overlay.visible && state.egui_winit.on_window_event(&state.window, &event).consumed;
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else { return };
                let pressed = event.state == ElementState::Pressed;
                if pressed && !event.repeat {
                    match code {
                        KeyCode::Escape if state.grabbed => state.set_grab(false),
                        KeyCode::Escape => event_loop.exit(),
                        KeyCode::F1 => {
                            state.overlay.visible = !state.overlay.visible;
                            if state.overlay.visible {
                                state.set_grab(false);
                            }
                        }
                        KeyCode::F12 => state.screenshot_requested = true,
                        KeyCode::KeyE if !egui_consumed => {
                            let open = super::level::door_is_open(state.app.world_mut());
                            state.app.world_mut().insert_resource(DoorControl { manual: Some(!open) });
                        }
                        KeyCode::KeyR if !egui_consumed => {
                            state.app.world_mut().insert_resource(DoorControl { manual: None });
                        }
                        KeyCode::Space if !egui_consumed => state.jump = true,
                        _ => {}
                    }
                }
                if pressed && !egui_consumed {
                    state.keys.insert(code);
                } else if !pressed {
                    state.keys.remove(&code);
                }
            }
            WindowEvent::CursorMoved { position, .. } => state.cursor = Vec2::new(position.x as f32, position.y as f32),
            WindowEvent::MouseInput { state: ElementState::Pressed, button: MouseButton::Left, .. } if !egui_consumed => {
                if state.overlay.visible {
                    if !state.egui.egui_wants_pointer_input() {
                        pick_probe_in_world(state.app.world_mut(), state.cursor);
                    }
                } else if !state.grabbed && !scripted {
                    state.set_grab(true);
                }
            }
            WindowEvent::Focused(false) => {
                state.keys.clear();
                if state.grabbed {
                    state.set_grab(false);
                }
            }
            WindowEvent::Resized(size) => self.handle_resize(size),
            WindowEvent::RedrawRequested => {
                match self.draw_if_visible() {
                    Some(Err(e)) => {
                        self.error = Some(e);
                        event_loop.exit();
                        return;
                    }
                    Some(Ok(())) => {
                        let state = self.state.as_ref().expect("a state");
                        if let Some(script) = &self.script
                            && state.frames >= script.frames
                        {
                            if let Err(e) = save_screenshot(&state.gpu, state.app.world(), &script.screenshot) {
                                self.error = Some(e);
                            }
                            event_loop.exit();
                            return;
                        }
                    }
                    None => {}
                }
                if let Err(e) = self.inject_faults().and_then(|()| self.recover()) {
                    self.error = Some(e);
                    event_loop.exit();
                    return;
                }
                if let Some(state) = &self.state {
                    state.window.request_redraw();
                }
            }
            _ => {}
        }
    }
}

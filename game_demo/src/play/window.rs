//! `game_demo play` in a window: first-person controls, the egui overlay (F1), screenshots (F12).
//!
//! Controls: click the view to grab the mouse; WASD walk, Shift run, Space jump, mouse look; E
//! opens or closes the door (back to its automatic cycle with R); Esc releases the mouse, a second
//! Esc quits. With the overlay open the mouse is free: click a probe sphere to inspect it.
//!
//! The window, its surface and lost devices are the engine's runner's ([`engine::window`]); this
//! module is the demo's [`WindowHooks`]. With `--script` the window runs the level's scripted tour on the fixed clock, frame for frame
//! what the headless mode renders, saves a screenshot at a chosen frame and exits: the test under
//! Xvfb compares the two.

use std::collections::HashSet;
use std::path::PathBuf;

use ddgi_overlay::DdgiOverlay;
use engine::app::Time;
use engine::window::{WindowContext, WindowHooks};
use glam::Vec2;
use winit::dpi::PhysicalSize;
use winit::event::{DeviceEvent, ElementState, MouseButton, WindowEvent};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{CursorGrabMode, Window, WindowAttributes};

use super::controller::{Player, PlayerInput, ScriptedTour};
use super::level::DoorControl;
use super::overlay::ScreenshotRequest;
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
    let faults = if script.as_ref().is_some_and(|s| s.faults) { FAULTS.to_vec() } else { Vec::new() };
    let hooks = DemoWindow {
        options,
        script,
        faults,
        minimized: None,
        resume: None,
        keys: HashSet::new(),
        look: Vec2::ZERO,
        jump: false,
        grabbed: false,
        screenshot_requested: false,
    };
    engine::window::run_window(hooks).map_err(|e| e.to_string())
}

/// The demo's hooks into the engine's windowed runner.
struct DemoWindow {
    options: PlayOptions,
    script: Option<WindowScript>,
    /// The scripted faults still to inject.
    faults: Vec<(u32, Fault)>,
    /// A scripted minimize under way.
    minimized: Option<Minimized>,
    /// What the app that lost its device leaves to the next one.
    resume: Option<Resume>,
    keys: HashSet<KeyCode>,
    look: Vec2,
    jump: bool,
    grabbed: bool,
    screenshot_requested: bool,
}

/// A minimized window ([`Fault::Minimize`]): the size to restore, the frames it had rendered (it
/// must render none while minimized), the skipped redraws before, and the redraws still to skip.
struct Minimized {
    size: PhysicalSize<u32>,
    frames: u32,
    skipped: u32,
    redraws: u32,
}

/// What outlives the app when it is rebuilt on a new device: where the player stands, the tour and
/// the door's override.
struct Resume {
    player: Option<Player>,
    tour: Option<ScriptedTour>,
    door: Option<DoorControl>,
}

impl WindowHooks for DemoWindow {
    fn attributes(&self) -> WindowAttributes {
        let faults = self.script.as_ref().is_some_and(|s| s.faults);
        Window::default_attributes()
            .with_title("game_demo — DDGI (F1: overlay)")
            .with_inner_size(PhysicalSize::new(self.options.width, self.options.height))
            .with_resizable(self.script.is_none() || faults)
    }

    /// A scripted run renders frame for frame what the headless mode does.
    fn time(&self) -> Time {
        if self.script.is_some() { Time::fixed(super::STEP_SECONDS) } else { Time::real() }
    }

    /// The level and the overlay; after a lost device, the level as the last app left it.
    fn build(&mut self, window: &mut WindowContext) -> Result<(), String> {
        let app = &mut window.app;
        if self.script.is_some() {
            app.insert_resource(engine::rt::WaitForBlasBuilds(true));
            app.world_mut().resource_mut::<engine::render::FrameTimings>().wait_each_frame = true;
        }
        setup_play(app, &self.options, self.script.is_some())?;

        super::add_overlay(app);
        if let Some(resume) = self.resume.take() {
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
            log::warn!("the level runs on a new GPU device");
        }
        Ok(())
    }

    /// Keeps where the player stood, the tour and the door's override for the next app.
    fn device_lost(&mut self, window: &mut WindowContext) {
        let world = window.app.world_mut();
        let player = world.query::<&Player>().iter(world).next().cloned();
        self.resume = Some(Resume { player, tour: world.remove_resource::<ScriptedTour>(), door: world.remove_resource::<DoorControl>() });
    }

    fn device_event(&mut self, _window: &mut WindowContext, event: &DeviceEvent) {
        if let DeviceEvent::MouseMotion { delta } = event
            && self.grabbed
        {
            self.look += Vec2::new(delta.0 as f32, delta.1 as f32);
        }
    }

    fn window_event(&mut self, window: &mut WindowContext, event: &WindowEvent) {
        let scripted = self.script.is_some();
        // The overlay (ddgi_overlay) saw the event first: F1 has toggled it, a click in the view
        // with it open has picked a probe.
        let egui_consumed = window.event_consumed_by_ui();
        let overlay_visible = window.app.world().get_resource::<DdgiOverlay>().is_some_and(|o| o.visible);
        match event {
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else { return };
                let pressed = event.state == ElementState::Pressed;
                if pressed && !event.repeat {
                    match code {
                        KeyCode::Escape if self.grabbed => self.set_grab(&window.window, false),
                        KeyCode::Escape => window.exit(),
                        KeyCode::F1 if overlay_visible => self.set_grab(&window.window, false),
                        KeyCode::F12 => self.screenshot_requested = true,
                        KeyCode::KeyE if !egui_consumed => {
                            let open = super::level::door_is_open(window.app.world_mut());
                            window.app.world_mut().insert_resource(DoorControl { manual: Some(!open) });
                        }
                        KeyCode::KeyR if !egui_consumed => {
                            window.app.world_mut().insert_resource(DoorControl { manual: None });
                        }
                        KeyCode::Space if !egui_consumed => self.jump = true,
                        _ => {}
                    }
                }
                if pressed && !egui_consumed {
                    self.keys.insert(code);
                } else if !pressed {
                    self.keys.remove(&code);
                }
            }
            WindowEvent::MouseInput { state: ElementState::Pressed, button: MouseButton::Left, .. }
                if !egui_consumed && !overlay_visible && !self.grabbed && !scripted =>
            {
                self.set_grab(&window.window, true);
            }
            WindowEvent::Focused(false) => {
                self.keys.clear();
                if self.grabbed {
                    self.set_grab(&window.window, false);
                }
            }
            _ => {}
        }
    }

    /// The player's input (the overlay takes its own through the engine's runner).
    fn before_frame(&mut self, window: &mut WindowContext) {
        if self.script.is_none() {
            let input = self.player_input();
            window.app.world_mut().insert_resource(input);
        }
    }

    /// Screenshots (F12, the overlay's button, the script's last frame) and the scripted faults.
    fn after_redraw(&mut self, window: &mut WindowContext, rendered: bool) -> Result<(), String> {
        if rendered {
            let button = window.app.world_mut().get_resource_mut::<ScreenshotRequest>().is_some_and(|mut r| std::mem::take(&mut r.0));
            if button || std::mem::take(&mut self.screenshot_requested) {
                let path = PathBuf::from("screenshots").join(format!("screenshot_{:05}.png", window.frames()));
                match save_screenshot(&window.gpu, window.app.world(), &path) {
                    Ok(()) => log::warn!("screenshot: {}", path.display()),
                    Err(e) => log::error!("screenshot failed: {e}"),
                }
            }
            if let Some(script) = &self.script
                && window.frames() >= script.frames
            {
                window.exit();
                return save_screenshot(&window.gpu, window.app.world(), &script.screenshot);
            }
        }
        self.inject_faults(window, rendered)
    }
}

impl DemoWindow {
    fn set_grab(&mut self, window: &Window, grab: bool) {
        if grab {
            let ok = window.set_cursor_grab(CursorGrabMode::Locked).or_else(|_| window.set_cursor_grab(CursorGrabMode::Confined));
            if let Err(e) = ok {
                log::warn!("cannot grab the mouse: {e}");
            }
        } else {
            let _ = window.set_cursor_grab(CursorGrabMode::None);
        }
        window.set_cursor_visible(!grab);
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

    /// Injects the scripted faults due after the redraw just done. A minimize lasts its redraws
    /// (the runner skips them: the window has no pixels); the faults after it wait until it ends.
    fn inject_faults(&mut self, window: &mut WindowContext, rendered: bool) -> Result<(), String> {
        if let Some(minimized) = &mut self.minimized {
            if rendered {
                return Err(format!("the minimized window rendered {} frames", window.frames() - minimized.frames));
            }
            minimized.redraws -= 1;
            if minimized.redraws > 0 {
                return Ok(());
            }
            log::warn!("{} redraws skipped while minimized", window.skipped_redraws() - minimized.skipped);
            window.resize(minimized.size);
            self.minimized = None;
        }
        let frames = window.frames();
        while let Some(&(due, fault)) = self.faults.first()
            && due <= frames
        {
            self.faults.remove(0);
            log::warn!("fault injected after frame {frames}: {fault:?}");
            match fault {
                Fault::Minimize { redraws } => {
                    self.minimized = Some(Minimized { size: window.size(), frames, skipped: window.skipped_redraws(), redraws });
                    window.resize(PhysicalSize::new(0, 0));
                    return Ok(());
                }
                Fault::Shrink => {
                    let _ = window.window.request_inner_size(PhysicalSize::new(2, 2));
                }
                Fault::Restore => {
                    let _ = window.window.request_inner_size(PhysicalSize::new(self.options.width, self.options.height));
                }
                Fault::SurfaceLost => {
                    window.app.world().resource::<engine::render::SurfaceTarget>().lost.store(true, std::sync::atomic::Ordering::Relaxed);
                }
                Fault::DeviceLost => window.gpu.simulate_device_loss(),
            }
        }
        Ok(())
    }
}

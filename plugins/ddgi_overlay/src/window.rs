//! The overlay's input in a window (feature `window`): the engine's windowed runner hands it every
//! window event and asks for each frame's input ([`engine::window::WindowUi`]). F1 shows or hides
//! the overlay; while shown, egui takes the events it wants, and a click in the view (not on a
//! window of the overlay) selects the probe under the cursor.

use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::window::WindowUi;
use glam::Vec2;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::Window;

use crate::{DdgiOverlay, OverlayUi};

/// The key that shows and hides the overlay.
pub const TOGGLE_KEY: KeyCode = KeyCode::F1;

/// egui's window-system state for the overlay, made on the first event (it needs the window).
#[derive(Default)]
pub struct OverlayInput {
    winit: Option<egui_winit::State>,
    cursor: Vec2,
}

impl OverlayInput {
    fn state(&mut self, window: &Window, world: &World) -> Option<&mut egui_winit::State> {
        if self.winit.is_none() {
            let context = world.get_resource::<OverlayUi>()?.context.clone();
            let max_texture = world.get_resource::<GpuContext>().map(|g| g.device.limits().max_texture_dimension_2d as usize);
            self.winit = Some(egui_winit::State::new(
                context,
                egui::ViewportId::ROOT,
                window,
                Some(window.scale_factor() as f32),
                None,
                max_texture,
            ));
        }
        self.winit.as_mut()
    }
}

impl WindowUi for OverlayInput {
    fn window_event(&mut self, window: &Window, world: &mut World, event: &WindowEvent) -> bool {
        let visible = world.get_resource::<DdgiOverlay>().is_some_and(|o| o.visible);
        let Some(state) = self.state(window, world) else { return false };
        let consumed = visible && state.on_window_event(window, event).consumed;
        match event {
            WindowEvent::KeyboardInput { event, .. }
                if event.physical_key == PhysicalKey::Code(TOGGLE_KEY) && event.state == ElementState::Pressed && !event.repeat =>
            {
                if let Some(mut overlay) = world.get_resource_mut::<DdgiOverlay>() {
                    overlay.visible = !overlay.visible;
                }
            }
            WindowEvent::CursorMoved { position, .. } => self.cursor = Vec2::new(position.x as f32, position.y as f32),
            WindowEvent::MouseInput { state: ElementState::Pressed, button: MouseButton::Left, .. } if visible && !consumed => {
                let over_ui = world.get_resource::<OverlayUi>().is_some_and(|ui| ui.context.egui_wants_pointer_input());
                if !over_ui {
                    crate::picking::pick_probe_in_world(world, self.cursor);
                    return true;
                }
            }
            _ => {}
        }
        consumed
    }

    fn before_frame(&mut self, window: &Window, world: &mut World) {
        let Some(state) = self.state(window, world) else { return };
        let input = state.take_egui_input(window);
        let Some(mut ui) = world.get_resource_mut::<OverlayUi>() else { return };
        if let Some(output) = ui.platform_output.take() {
            state.handle_platform_output(window, output);
        }
        ui.input = Some(input);
    }
}

//! # The DDGI overlay
//!
//! A debug overlay for any app built on the engine with DDGI, added in one line:
//!
//! ```no_run
//! # let mut app = bevy_app::App::new();
//! app.add_plugins(ddgi_overlay::DdgiOverlayPlugin);
//! ```
//!
//! F1 shows it (in a window; [`DdgiOverlay::visible`] in code). Drawn with egui over the finished
//! image (the engine's [`engine::render::ImageOverlayHook`]), so the window shows it and the frames
//! an app saves hold it; in a window it takes its input through the engine's
//! [`engine::window::WindowUiHook`]. Its windows:
//!
//! - **DDGI**: every volume and cascade, one selected at a time (the probe views and the panels
//!   below follow the selection); the image the frame script writes ([`ddgi::DdgiOutput`]); the
//!   probe views — ddgi's spheres by irradiance, state, rays or error, and this crate's
//!   [`DdgiVisualizerViews`] (spheres coloured by mean hit distance, relocation offsets as lines,
//!   the volume's bounds as a wireframe, pass `ddgi_visualizer`); probes per state, rays traced,
//!   GPU memory; pause, step and reset of the probe updates ([`ddgi::DdgiUpdateControl`]); every
//!   [`ddgi::DdgiVolume`] and [`ddgi::DdgiAdaptive`] field, each with its documentation as its
//!   tooltip ([`fields`]); the settings saved to and loaded from JSON ([`settings`]).
//! - **Performance**: GPU time per pass, a rolling graph of the frame and the probe update, frames
//!   per second and the frame's counters.
//! - **Probe**: the clicked probe's values and maps (click a sphere with the overlay open).
//! - **Atlases**: the selected volume's irradiance and distance atlases.
//!
//! Apps add windows of their own through [`DdgiOverlayPanels`] (the demo adds its navigation mesh
//! and entity inspector).

#![warn(missing_docs)]

pub mod fields;
pub mod painter;
pub mod picking;
pub mod settings;
pub mod ui;
pub mod visualizer;
#[cfg(feature = "window")]
pub mod window;

use std::path::PathBuf;
use std::sync::Arc;

use bevy_app::{App, Last, Plugin};
use bevy_ecs::prelude::*;
use ddgi::DdgiProbeView;
use engine::gpu::GpuContext;
use engine::render::{ImageOverlayHook, RenderSize};

pub use picking::{camera_ray, pick_probe, pick_probe_in_world};
pub use ui::overlay_ui;
pub use visualizer::DdgiVisualizerViews;

/// The overlay: egui over the image, the DDGI probe views and their pass. See the crate's
/// documentation. Needs the engine's render plugin (a GPU) for its draws; without one the UI still
/// runs (nothing is drawn) and a warning says so.
pub struct DdgiOverlayPlugin;

impl Plugin for DdgiOverlayPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<DdgiOverlay>()
            .init_resource::<DdgiProbeView>()
            .init_resource::<DdgiVisualizerViews>()
            .init_resource::<DdgiOverlayPanels>();
        let mut ui = OverlayUi { context: egui::Context::default(), painter: None, input: None, platform_output: None };
        match app.world().get_resource::<GpuContext>().cloned() {
            Some(gpu) => {
                let painter = Arc::new(painter::EguiPainter::new(&gpu));
                app.insert_resource(ImageOverlayHook(painter.clone()));
                ui.painter = Some(painter);
                if let Err(e) = visualizer::add_visualizer(app) {
                    log::warn!("the DDGI overlay's probe views are off: {e}");
                }
            }
            None => log::warn!("DdgiOverlayPlugin needs the engine's RenderPlugin (a GPU) to draw; the overlay is not drawn"),
        }
        app.insert_resource(ui);
        #[cfg(feature = "window")]
        app.insert_resource(engine::window::WindowUiHook(Box::new(window::OverlayInput::default())));
        app.add_systems(Last, (visualizer::sync_visualizer_views, run_ddgi_overlay));
    }
}

/// What the overlay shows and remembers between frames. Insert or change it to drive the overlay
/// from code (`visible`, say, to draw it into saved frames).
#[derive(Resource)]
pub struct DdgiOverlay {
    /// Whether the overlay is drawn (F1 in a window). Hidden, it draws nothing and takes no input.
    pub visible: bool,
    /// Whether the selected volume's atlases are shown.
    pub show_atlases: bool,
    /// The file the settings are saved to and loaded from.
    pub settings_path: PathBuf,
    /// Screen pixels per egui point when no window says (headless): larger makes the overlay
    /// larger in saved frames.
    pub headless_pixels_per_point: f32,
    /// The last save's or load's outcome, shown under the buttons.
    pub settings_status: Option<Result<String, String>>,
    pub(crate) history: ui::History,
    pub(crate) atlases: Option<ui::AtlasImages>,
    pub(crate) atlas_age: f64,
}

impl Default for DdgiOverlay {
    fn default() -> Self {
        Self {
            visible: false,
            show_atlases: false,
            settings_path: PathBuf::from("ddgi_settings.json"),
            headless_pixels_per_point: 1.0,
            settings_status: None,
            history: ui::History::default(),
            atlases: None,
            atlas_age: f64::INFINITY,
        }
    }
}

impl DdgiOverlay {
    /// Whether the atlases of the selected volume have been read back into egui textures.
    pub fn has_atlas_images(&self) -> bool {
        self.atlases.is_some()
    }

    /// Frames whose GPU timings the performance graph holds.
    pub fn timed_frames(&self) -> usize {
        self.history.gpu_ms.len()
    }
}

/// A window of the app's own in the overlay, drawn after the overlay's own windows while it is
/// visible (the demo's navigation mesh and entity inspector).
pub trait OverlayPanel: Send + Sync + 'static {
    /// Builds the panel's egui windows (or shapes) for one frame, from and into `world`.
    fn ui(&mut self, ctx: &egui::Context, world: &mut World);
}

impl<F: FnMut(&egui::Context, &mut World) + Send + Sync + 'static> OverlayPanel for F {
    fn ui(&mut self, ctx: &egui::Context, world: &mut World) {
        self(ctx, world)
    }
}

/// The app's own panels in the overlay ([`OverlayPanel`]), in drawing order.
#[derive(Resource, Default)]
pub struct DdgiOverlayPanels(pub Vec<Box<dyn OverlayPanel>>);

impl DdgiOverlayPanels {
    /// Adds a panel.
    pub fn add(&mut self, panel: impl OverlayPanel) -> &mut Self {
        self.0.push(Box::new(panel));
        self
    }
}

/// The overlay's egui: its context, its painter, this frame's input (from the window, if any)
/// and the last frame's platform output (for the window).
#[derive(Resource)]
pub struct OverlayUi {
    /// The egui context the overlay runs in (panels of [`DdgiOverlayPanels`] get it too).
    pub context: egui::Context,
    pub(crate) painter: Option<Arc<painter::EguiPainter>>,
    /// This frame's input, set by the window before the update; `None`: none (headless).
    pub input: Option<egui::RawInput>,
    /// What egui asked of the window at the last frame (cursor, clipboard); the window takes it.
    pub platform_output: Option<egui::PlatformOutput>,
}

/// `Last`: runs the overlay's egui for the frame — with the window's input or, headless, an input
/// covering the image — and hands its shapes to the painter, which draws them over the image.
pub fn run_ddgi_overlay(world: &mut World) {
    let Some(mut ui) = world.remove_resource::<OverlayUi>() else { return };
    let raw = ui.input.take().unwrap_or_else(|| headless_input(world));
    let mut panels = world.remove_resource::<DdgiOverlayPanels>().unwrap_or_default();
    let context = ui.context.clone();
    let output = context.run_pass(raw, |ctx| overlay_ui(ctx, world, &mut panels));
    world.insert_resource(panels);
    let jobs = context.tessellate(output.shapes, output.pixels_per_point);
    match &ui.painter {
        Some(painter) => painter.submit(jobs, output.textures_delta, output.pixels_per_point),
        None => {
            let mut delta = output.textures_delta;
            delta.clear();
        }
    }
    ui.platform_output = Some(output.platform_output);
    world.insert_resource(ui);
}

/// The input of a frame without a window: the image's size at
/// [`DdgiOverlay::headless_pixels_per_point`], the app's clock, the GPU's largest texture.
fn headless_input(world: &World) -> egui::RawInput {
    let size = world.get_resource::<RenderSize>().copied().unwrap_or(RenderSize { width: 1280, height: 720 });
    let ppp = world.get_resource::<DdgiOverlay>().map_or(1.0, |o| o.headless_pixels_per_point).clamp(0.25, 8.0);
    let mut raw = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(size.width as f32 / ppp, size.height as f32 / ppp))),
        time: world.get_resource::<engine::app::Time>().map(|t| t.elapsed_seconds),
        max_texture_side: world.get_resource::<GpuContext>().map(|g| g.device.limits().max_texture_dimension_2d as usize),
        ..Default::default()
    };
    raw.viewports.entry(egui::ViewportId::ROOT).or_default().native_pixels_per_point = Some(ppp);
    raw
}

//! The overlay's windows, built from (and into) the world for one frame: [`overlay_ui`] needs no
//! window or GPU surface, so tests build it headless.

use std::collections::VecDeque;

use bevy_ecs::prelude::*;
use ddgi::cascades::{DdgiCascade, DdgiFirstCameraCascades};
use ddgi::debug_view::selected_volume;
use ddgi::{DdgiGpuVolumes, DdgiOutput, DdgiProbe, DdgiProbeColor, DdgiProbeState, DdgiProbeView, DdgiUpdateControl, DdgiVolume};
use engine::gpu::GpuContext;
use engine::render::FrameTimings;
use glam::UVec2;

use crate::visualizer::DdgiVisualizerViews;
use crate::{DdgiOverlay, DdgiOverlayPanels, fields, settings};

/// Frames kept for the rolling graphs.
const HISTORY: usize = 240;
/// Seconds between atlas readbacks while the probe or atlas window is open (a readback waits for
/// the GPU).
const ATLAS_REFRESH_SECONDS: f64 = 0.5;
/// The passes of the probe update (everything DDGI does before the camera's gather).
use ddgi::is_probe_update_pass;

/// The frame rate and GPU time history of the performance window.
#[derive(Default)]
pub(crate) struct History {
    /// Wall-clock seconds of the last frames (frames per second).
    frame_seconds: VecDeque<f64>,
    last_instant: Option<std::time::Instant>,
    /// Total GPU milliseconds of the last frames, and the DDGI probe update's share.
    pub(crate) gpu_ms: VecDeque<(f64, f64)>,
    last_timing_frame: Option<u64>,
}

impl History {
    fn frame(&mut self) -> f64 {
        let now = std::time::Instant::now();
        let seconds = self.last_instant.map_or(0.0, |l| (now - l).as_secs_f64());
        self.last_instant = Some(now);
        self.frame_seconds.push_back(seconds);
        if self.frame_seconds.len() > HISTORY {
            self.frame_seconds.pop_front();
        }
        seconds
    }

    fn fps(&self) -> f64 {
        let total: f64 = self.frame_seconds.iter().sum();
        if total > 0.0 { self.frame_seconds.len() as f64 / total } else { 0.0 }
    }

    fn collect(&mut self, world: &World) {
        let Some(timings) = world.get_resource::<FrameTimings>() else { return };
        let since = self.last_timing_frame;
        for f in timings.frames.iter().filter(|f| since.is_none_or(|last| f.frame > last)) {
            let total: f64 = f.passes.iter().filter_map(|p| p.gpu_ms).sum();
            let ddgi: f64 = f.passes.iter().filter(|p| is_probe_update_pass(&p.label)).filter_map(|p| p.gpu_ms).sum();
            self.gpu_ms.push_back((total, ddgi));
            self.last_timing_frame = Some(f.frame);
        }
        while self.gpu_ms.len() > HISTORY {
            self.gpu_ms.pop_front();
        }
    }
}

/// Builds the overlay's windows for one frame from (and into) `world`, then the app's
/// `panels`. Hidden ([`DdgiOverlay::visible`] false), it only keeps its timing history.
pub fn overlay_ui(ctx: &egui::Context, world: &mut World, panels: &mut DdgiOverlayPanels) {
    let Some(mut state) = world.remove_resource::<DdgiOverlay>() else { return };
    let seconds = state.history.frame();
    state.atlas_age += seconds;
    state.history.collect(world);
    if state.visible {
        windows(ctx, &mut state, world);
    }
    world.insert_resource(state);
    if world.get_resource::<DdgiOverlay>().is_some_and(|s| s.visible) {
        for panel in &mut panels.0 {
            panel.ui(ctx, world);
        }
    }
}

fn windows(ctx: &egui::Context, state: &mut DdgiOverlay, world: &mut World) {
    egui::Window::new("Performance").default_pos([10.0, 10.0]).show(ctx, |ui| performance_ui(ui, state, world));
    egui::Window::new("DDGI").default_pos([300.0, 10.0]).default_height(600.0).show(ctx, |ui| {
        egui::ScrollArea::vertical().show(ui, |ui| ddgi_ui(ui, state, world));
    });
    let view = world.get_resource::<DdgiProbeView>().copied().unwrap_or_default();
    let selected_entity =
        world.get_resource::<DdgiGpuVolumes>().and_then(|v| selected_volume(&v.volumes, Some(&view)).map(|i| v.volumes[i].0));
    if let (Some(index), Some(volume)) = (view.selected, selected_entity) {
        let mut open = true;
        egui::Window::new("Probe").open(&mut open).default_pos([590.0, 10.0]).show(ctx, |ui| probe_ui(ui, state, world, volume, index));
        if !open && let Some(mut view) = world.get_resource_mut::<DdgiProbeView>() {
            view.selected = None;
        }
    }
    if state.show_atlases {
        let mut open = true;
        egui::Window::new("Atlases").open(&mut open).default_pos([590.0, 300.0]).show(ctx, |ui| atlases_ui(ui, state));
        state.show_atlases = open;
    }
    if (view.selected.is_some() || state.show_atlases) && state.atlas_age >= ATLAS_REFRESH_SECONDS {
        refresh_atlases(ctx, state, world);
    }
}

/// One row of the volume list: the volume's entity, its name and whether it is a cascade.
struct VolumeRow {
    entity: Entity,
    name: String,
    cascade: bool,
}

/// Every volume that lights the scene (gather order), then those a settings error keeps off.
fn volume_rows(world: &mut World) -> (Vec<VolumeRow>, Vec<(Entity, String)>) {
    let mut cascades = world.query::<&DdgiCascade>();
    let lit: Vec<(Entity, glam::UVec3, f32)> = world
        .get_resource::<DdgiGpuVolumes>()
        .map(|v| v.volumes.iter().map(|(e, g)| (*e, g.layout.counts, g.layout.spacing.min_element())).collect())
        .unwrap_or_default();
    let mut rows = Vec::new();
    let mut fixed = 0;
    for (entity, counts, spacing) in lit {
        let (name, cascade) = match cascades.get(world, entity) {
            Ok(c) => (format!("cascade {} ({}×{}×{}, {spacing:.2} m)", c.level, counts.x, counts.y, counts.z), true),
            Err(_) => {
                fixed += 1;
                (format!("volume {} ({}×{}×{}, {spacing:.2} m)", fixed - 1, counts.x, counts.y, counts.z), false)
            }
        };
        rows.push(VolumeRow { entity, name, cascade });
    }
    let mut off = Vec::new();
    let mut volumes = world.query::<(Entity, &DdgiVolume)>();
    let entities: Vec<Entity> = volumes.iter(world).map(|(e, _)| e).filter(|e| !rows.iter().any(|r| r.entity == *e)).collect();
    if let Some(gpu) = world.get_resource::<DdgiGpuVolumes>() {
        for e in entities {
            off.push((e, gpu.error(e).unwrap_or("not prepared yet").to_string()));
        }
    }
    (rows, off)
}

/// Every volume that lights the scene, in gather order, under the name the overlay lists it by
/// (`volume 0 (4×4×4, 0.50 m)`, `cascade 1 (16×8×16, 3.00 m)`).
pub fn volume_names(world: &mut World) -> Vec<(Entity, String)> {
    volume_rows(world).0.into_iter().map(|r| (r.entity, r.name)).collect()
}

fn ddgi_ui(ui: &mut egui::Ui, state: &mut DdgiOverlay, world: &mut World) {
    let (rows, off) = volume_rows(world);
    let mut view = world.get_resource::<DdgiProbeView>().copied().unwrap_or_default();
    let selected = world.get_resource::<DdgiGpuVolumes>().and_then(|v| selected_volume(&v.volumes, Some(&view))).and_then(|i| rows.get(i));
    let selected_entity = selected.map(|r| r.entity);
    ui.label(egui::RichText::new("volumes").strong());
    for row in &rows {
        if ui.selectable_label(selected_entity == Some(row.entity), &row.name).clicked() && selected_entity != Some(row.entity) {
            view.volume = Some(row.entity);
            view.selected = None;
        }
    }
    for (entity, error) in &off {
        ui.colored_label(egui::Color32::RED, format!("{entity}: off: {error}"));
    }
    if rows.is_empty() && off.is_empty() {
        ui.label("no DDGI volume");
    }
    ui.separator();
    if let Some(mut output) = world.get_resource_mut::<DdgiOutput>() {
        ui.horizontal_wrapped(|ui| {
            ui.label("image:");
            for mode in DdgiOutput::ALL {
                ui.selectable_value(&mut *output, mode, mode.name());
            }
        });
    }
    let mut views = world.get_resource::<DdgiVisualizerViews>().copied().unwrap_or_default();
    ui.horizontal_wrapped(|ui| {
        ui.label("probe spheres:");
        for color in DdgiProbeColor::ALL {
            ui.selectable_value(&mut view.color, color, color.name());
        }
    });
    ui.add(egui::Slider::new(&mut view.radius, 0.02..=0.5).text("sphere radius (cells)"));
    if view.color == DdgiProbeColor::Error {
        ui.add(egui::Slider::new(&mut view.max_error, 1e-3..=1.0).logarithmic(true).text("error scale"));
    }
    ui.horizontal_wrapped(|ui| {
        ui.checkbox(&mut views.distance_spheres, "distance spheres")
            .on_hover_text("Probes coloured by mean hit distance in each direction: blue near, red at 1.5 cell diagonals");
        ui.checkbox(&mut views.relocation_offsets, "relocation offsets").on_hover_text("Lines from each grid point to its relocated probe");
        ui.checkbox(&mut views.bounds, "bounds").on_hover_text("The volume's box as a wireframe");
        ui.checkbox(&mut state.show_atlases, "atlases");
    });
    views.radius = view.radius;
    if world.get_resource::<DdgiProbeView>() != Some(&view) {
        world.insert_resource(view);
    }
    if world.get_resource::<DdgiVisualizerViews>() != Some(&views) {
        world.insert_resource(views);
    }
    ui.separator();
    controls_ui(ui, world, selected_entity);
    if let Some(entity) = selected_entity {
        stats_ui(ui, world, entity);
    }
    ui.separator();
    if let Some(row) = selected {
        egui::CollapsingHeader::new("settings").default_open(false).show(ui, |ui| settings_ui(ui, world, row));
    }
    save_load_ui(ui, state, world);
    if let Some(gpu) = world.get_resource::<DdgiGpuVolumes>() {
        for w in gpu.warnings() {
            ui.colored_label(egui::Color32::YELLOW, w);
        }
    }
    ui.weak("click a probe to inspect it");
}

/// Pause, step and reset ([`DdgiUpdateControl`]).
fn controls_ui(ui: &mut egui::Ui, world: &mut World, selected: Option<Entity>) {
    let Some(mut control) = world.get_resource_mut::<DdgiUpdateControl>() else { return };
    ui.horizontal(|ui| {
        let paused = control.paused;
        if ui.button(if paused { "resume" } else { "pause" }).on_hover_text("Pause or resume every volume's probe updates").clicked() {
            control.set_paused(!paused);
        }
        if ui.add_enabled(paused, egui::Button::new("step")).on_hover_text("One probe update while paused").clicked() {
            control.step();
        }
        if let Some(entity) = selected
            && ui.button("reset").on_hover_text("Clear the selected volume's maps: every probe fresh, as a new volume").clicked()
        {
            control.reset(entity);
        }
        if paused {
            ui.colored_label(egui::Color32::YELLOW, "paused");
        }
    });
}

/// The selected volume's probes per state, rays and GPU memory.
fn stats_ui(ui: &mut egui::Ui, world: &World, entity: Entity) {
    let Some(volumes) = world.get_resource::<DdgiGpuVolumes>() else { return };
    let Some(volume) = volumes.get(entity) else { return };
    let counts = volume.probe_state_counts();
    let index = volumes.volumes.iter().position(|(e, _)| *e == entity).unwrap_or(0);
    let counter = ddgi::rays_counter(index, volumes.volumes.len());
    let rays = world.get_resource::<FrameTimings>().and_then(|t| t.counter(&counter).last().map(|(frame, rays)| (*frame, *rays)));
    let layout = &volume.layout;
    egui::Grid::new("ddgi_stats").num_columns(2).show(ui, |ui| {
        let mut row = |k: &str, v: String| {
            ui.label(k);
            ui.monospace(v);
            ui.end_row();
        };
        row("probes", format!("{} ({}×{}×{})", layout.probe_count, layout.counts.x, layout.counts.y, layout.counts.z));
        row("active / inactive", format!("{} / {}", counts.active, counts.inactive));
        row("fresh / resting / pinned", format!("{} / {} / {}", counts.fresh, counts.resting, counts.pinned));
        row(
            "rays this frame",
            match rays {
                Some((frame, rays)) => format!("{rays:.0} (frame {frame})"),
                None => format!("{} (probe readback)", counts.rays),
            },
        );
        row("GPU memory", format!("{:.2} MiB", volume.memory_bytes() as f64 / (1024.0 * 1024.0)));
        row("frames", format!("{}", volume.frames));
        let period = volume.settings.update_period.max(1) * volume.calm.period;
        row(
            "update period",
            if volume.calm.period > 1 { format!("every {period} frames (calm)") } else { format!("every {period} frames") },
        );
    });
}

/// Every setting of the selected volume; a cascade's are its cascades' shared settings.
fn settings_ui(ui: &mut egui::Ui, world: &mut World, row: &VolumeRow) {
    if row.cascade {
        ui.weak("A cascade's settings are its cascades' (DdgiCascades::volume): edits apply to every cascade; bounds, probe counts and update periods are set per cascade.");
        let Some(mut shared) = world.get_resource_mut::<DdgiFirstCameraCascades>() else {
            ui.label("these cascades are on a camera's DdgiCascades component: edit it there");
            return;
        };
        let mut volume = shared.0.volume.clone();
        if fields::edit_volume(ui, "cascades", &mut volume) {
            match volume.validate() {
                Ok(()) => shared.0.volume = volume,
                Err(e) => {
                    ui.colored_label(egui::Color32::RED, e.to_string());
                }
            }
        }
        return;
    }
    let Some(mut current) = world.get_mut::<DdgiVolume>(row.entity) else { return };
    let mut volume = current.clone();
    if fields::edit_volume(ui, "volume", &mut volume) {
        match volume.validate() {
            Ok(()) => *current = volume,
            Err(e) => {
                ui.colored_label(egui::Color32::RED, e.to_string());
            }
        }
    }
}

/// The settings file: its path, save and load, and the outcome.
fn save_load_ui(ui: &mut egui::Ui, state: &mut DdgiOverlay, world: &mut World) {
    ui.horizontal(|ui| {
        let mut path = state.settings_path.display().to_string();
        ui.label("settings file");
        if ui.text_edit_singleline(&mut path).changed() {
            state.settings_path = path.into();
        }
    });
    ui.horizontal(|ui| {
        let file = state.settings_path.display().to_string();
        if ui.button("save").clicked() {
            let settings = settings::collect(world);
            state.settings_status =
                Some(settings::save(&settings, &state.settings_path).map(|()| format!("saved {file}")).map_err(|e| e.to_string()));
        }
        if ui.button("load").clicked() {
            let result = settings::load(&state.settings_path).and_then(|s| settings::apply(world, &s, &file));
            state.settings_status = Some(result.map(|()| format!("loaded {file}")).map_err(|e| e.to_string()));
        }
    });
    match &state.settings_status {
        Some(Ok(message)) => {
            ui.label(message);
        }
        Some(Err(message)) => {
            ui.colored_label(egui::Color32::RED, message);
        }
        None => {}
    }
}

/// The atlases read back and uploaded to egui, and the tile geometry to crop a probe's maps.
pub(crate) struct AtlasImages {
    /// The whole atlases, shrunk by an integer factor when wider than egui's largest texture.
    irradiance: egui::TextureHandle,
    distance: egui::TextureHandle,
    irradiance_size: UVec2,
    distance_size: UVec2,
    /// The selected probe's maps (its tiles, borders included), and which probe they show.
    probe_irradiance: egui::TextureHandle,
    probe_distance: egui::TextureHandle,
    probe: u32,
    /// The volume they are of.
    volume: Entity,
}

/// An RGBA8 image, row-major.
struct Rgba {
    size: UVec2,
    pixels: Vec<u8>,
}

impl Rgba {
    /// Every `k`-th texel so that neither side exceeds `max_side`.
    fn fit(&self, max_side: usize) -> egui::ColorImage {
        let k = (self.size.x.max(self.size.y) as usize).div_ceil(max_side.max(1)).max(1) as u32;
        let size = UVec2::new(self.size.x.div_ceil(k), self.size.y.div_ceil(k));
        let mut out = Vec::with_capacity((size.x * size.y * 4) as usize);
        for y in 0..size.y {
            for x in 0..size.x {
                let i = ((y * k * self.size.x + x * k) * 4) as usize;
                out.extend_from_slice(&self.pixels[i..i + 4]);
            }
        }
        egui::ColorImage::from_rgba_unmultiplied([size.x as usize, size.y as usize], &out)
    }

    /// The `n + 2` texels square tile of probe `probe` (tiles of `n + 2` texels, `tiles` per row).
    fn tile(&self, probe: u32, n: u32, tiles: u32) -> egui::ColorImage {
        let tiles = tiles.max(1);
        let side = n + 2;
        let origin = UVec2::new(probe % tiles, probe / tiles) * side;
        let mut out = Vec::with_capacity((side * side * 4) as usize);
        for y in 0..side {
            for x in 0..side {
                let (px, py) = (origin.x + x, origin.y + y);
                if px < self.size.x && py < self.size.y {
                    let i = ((py * self.size.x + px) * 4) as usize;
                    out.extend_from_slice(&self.pixels[i..i + 4]);
                } else {
                    out.extend_from_slice(&[0, 0, 0, 255]);
                }
            }
        }
        egui::ColorImage::from_rgba_unmultiplied([side as usize, side as usize], &out)
    }
}

fn performance_ui(ui: &mut egui::Ui, state: &mut DdgiOverlay, world: &World) {
    ui.label(format!("{:.1} frames/s", state.history.fps()));
    let Some(timings) = world.get_resource::<FrameTimings>() else { return };
    let Some(last) = timings.frames.iter().rev().find(|f| f.passes.iter().any(|p| p.gpu_ms.is_some())) else {
        ui.label("no GPU timings (the adapter has no timestamp queries)");
        return;
    };
    egui::Grid::new("passes").striped(true).show(ui, |ui| {
        ui.strong("pass");
        ui.strong("GPU ms");
        ui.end_row();
        for p in &last.passes {
            ui.label(&p.label);
            match (p.ran, p.gpu_ms) {
                (true, Some(ms)) => ui.label(format!("{ms:.3}")),
                (true, None) => ui.label("–"),
                (false, _) => ui.weak("left out"),
            };
            ui.end_row();
        }
        let total: f64 = last.passes.iter().filter_map(|p| p.gpu_ms).sum();
        ui.strong("total");
        ui.strong(format!("{total:.3}"));
        ui.end_row();
    });
    for (name, value) in &last.counters {
        ui.label(format!("{name}: {value:.0}"));
    }
    // Rolling graph: total GPU time (white) and the probe update (orange), last HISTORY frames.
    let (response, painter) = ui.allocate_painter(egui::vec2(280.0, 90.0), egui::Sense::hover());
    let rect = response.rect;
    painter.rect_filled(rect, 2.0, egui::Color32::from_black_alpha(160));
    let peak = state.history.gpu_ms.iter().map(|(t, _)| *t).fold(0.0f64, f64::max).max(1e-3);
    let line = |pick: fn(&(f64, f64)) -> f64| -> Vec<egui::Pos2> {
        let n = state.history.gpu_ms.len().max(2) - 1;
        state
            .history
            .gpu_ms
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let x = rect.left() + rect.width() * i as f32 / n as f32;
                let y = rect.bottom() - rect.height() * (pick(v) / peak) as f32;
                egui::pos2(x, y)
            })
            .collect()
    };
    painter.add(egui::Shape::line(line(|v| v.0), egui::Stroke::new(1.5, egui::Color32::WHITE)));
    painter.add(egui::Shape::line(line(|v| v.1), egui::Stroke::new(1.5, egui::Color32::from_rgb(255, 160, 40))));
    painter.text(rect.left_top(), egui::Align2::LEFT_TOP, format!("{peak:.2} ms"), egui::FontId::monospace(10.0), egui::Color32::GRAY);
    ui.horizontal(|ui| {
        ui.colored_label(egui::Color32::WHITE, "— frame");
        ui.colored_label(egui::Color32::from_rgb(255, 160, 40), "— probe update");
    });
}

fn probe_ui(ui: &mut egui::Ui, state: &mut DdgiOverlay, world: &mut World, volume: Entity, index: u32) {
    let mut query = world.query::<&DdgiProbe>();
    let Some(probe) = query.iter(world).find(|p| p.volume == volume && p.index == index).cloned() else {
        ui.label(format!("probe {index} is gone"));
        return;
    };
    egui::Grid::new("probe_values").show(ui, |ui| {
        let row = |ui: &mut egui::Ui, k: &str, v: String| {
            ui.label(k);
            ui.monospace(v);
            ui.end_row();
        };
        row(ui, "index", probe.index.to_string());
        row(ui, "grid", format!("{} {} {}", probe.grid.x, probe.grid.y, probe.grid.z));
        row(ui, "position", format!("{:.2} {:.2} {:.2}", probe.position.x, probe.position.y, probe.position.z));
        row(ui, "offset", format!("{:.3} {:.3} {:.3}", probe.offset.x, probe.offset.y, probe.offset.z));
        row(ui, "state", if probe.state == DdgiProbeState::Active { "active".into() } else { "inactive".into() });
        row(ui, "rays", probe.ray_count.to_string());
        row(ui, "temporal error", format!("{:.4}", probe.error));
        row(ui, "resting for", format!("{} frames", probe.resting_frames));
    });
    let Some(atlases) = &state.atlases else {
        ui.label("reading the maps back…");
        return;
    };
    ui.horizontal(|ui| {
        ui.vertical(|ui| {
            ui.label("irradiance");
            ui.image((atlases.probe_irradiance.id(), egui::vec2(128.0, 128.0)));
        });
        ui.vertical(|ui| {
            ui.label("distance (mean)");
            ui.image((atlases.probe_distance.id(), egui::vec2(128.0, 128.0)));
        });
    });
    if atlases.probe != index || atlases.volume != volume {
        ui.weak("(maps of the next readback)");
    }
}

fn atlases_ui(ui: &mut egui::Ui, state: &mut DdgiOverlay) {
    let Some(atlases) = &state.atlases else {
        ui.label("reading the atlases back…");
        return;
    };
    let fit = |size: UVec2| {
        let scale = (512.0 / size.x.max(1) as f32).min(256.0 / size.y.max(1) as f32).max(0.01);
        egui::vec2(size.x as f32 * scale, size.y as f32 * scale)
    };
    egui::ScrollArea::both().show(ui, |ui| {
        ui.label(format!("irradiance {}×{}", atlases.irradiance_size.x, atlases.irradiance_size.y));
        ui.image((atlases.irradiance.id(), fit(atlases.irradiance_size)));
        ui.label(format!("distance {}×{} (mean, normalized)", atlases.distance_size.x, atlases.distance_size.y));
        ui.image((atlases.distance.id(), fit(atlases.distance_size)));
    });
}

/// Reads the selected volume's atlases back and uploads them to egui as display images: irradiance
/// tonemapped (x / (1 + x) at the camera's exposure, sRGB), distance as grey over the volume's
/// distance scale.
fn refresh_atlases(ctx: &egui::Context, state: &mut DdgiOverlay, world: &mut World) {
    state.atlas_age = 0.0;
    let exposure = crate::picking::view_camera(world).map_or(1.0, |(c, _)| c.exposure);
    let (Some(gpu), Some(volumes)) = (world.get_resource::<GpuContext>(), world.get_resource::<DdgiGpuVolumes>()) else { return };
    let view = world.get_resource::<DdgiProbeView>().copied();
    let Some(selected) = selected_volume(&volumes.volumes, view.as_ref()) else { return };
    let (volume_entity, volume) = (volumes.volumes[selected].0, &volumes.volumes[selected].1);
    let irradiance = ddgi::atlas::read_irradiance(gpu, volume);
    let distance = ddgi::atlas::read_distance(gpu, volume);
    let encode = |x: f32| {
        let t = (x * exposure).max(0.0);
        engine::color::srgb8(t / (1.0 + t))
    };
    let irradiance_rgba: Vec<u8> = irradiance
        .texels
        .iter()
        .flat_map(|e| [encode(e.x / std::f32::consts::PI), encode(e.y / std::f32::consts::PI), encode(e.z / std::f32::consts::PI), 255])
        .collect();
    let scale = volume.layout.distance_scale();
    let distance_rgba: Vec<u8> = distance
        .texels
        .iter()
        .flat_map(|d| {
            let g = ddgi::atlas::distance_grey(*d, scale);
            [g, g, g, 255]
        })
        .collect();
    let irradiance = Rgba { size: irradiance.size, pixels: irradiance_rgba };
    let distance = Rgba { size: distance.size, pixels: distance_rgba };
    let layout = &volume.layout;
    let probe = world.get_resource::<DdgiProbeView>().and_then(|v| v.selected).unwrap_or(0).min(layout.probe_count.saturating_sub(1));
    let max_side = ctx.input(|i| i.max_texture_side);
    let nearest = egui::TextureOptions::NEAREST;
    let images = [
        irradiance.fit(max_side),
        distance.fit(max_side),
        irradiance.tile(probe, layout.irradiance_texels, layout.tiles_per_row),
        distance.tile(probe, layout.distance_texels, layout.tiles_per_row),
    ];
    match &mut state.atlases {
        Some(a) => {
            let [i, d, pi, pd] = images;
            a.irradiance.set(i, nearest);
            a.distance.set(d, nearest);
            a.probe_irradiance.set(pi, nearest);
            a.probe_distance.set(pd, nearest);
            a.irradiance_size = irradiance.size;
            a.distance_size = distance.size;
            a.probe = probe;
            a.volume = volume_entity;
        }
        None => {
            let [i, d, pi, pd] = images;
            state.atlases = Some(AtlasImages {
                irradiance: ctx.load_texture("ddgi_irradiance_atlas", i, nearest),
                distance: ctx.load_texture("ddgi_distance_atlas", d, nearest),
                irradiance_size: irradiance.size,
                distance_size: distance.size,
                probe_irradiance: ctx.load_texture("ddgi_probe_irradiance", pi, nearest),
                probe_distance: ctx.load_texture("ddgi_probe_distance", pd, nearest),
                probe,
                volume: volume_entity,
            });
        }
    }
}

//! The probe debug overlay (egui, F1): GPU time per pass (table and rolling graph) and frames per
//! second; DDGI's settings live; view modes; probes drawn as spheres coloured by irradiance, state,
//! ray budget or temporal error; a clicked probe's maps and values; the atlases; an entity
//! inspector; a screenshot button.
//!
//! [`overlay_ui`] builds the UI from the world for one frame: it needs no window or GPU surface,
//! so the tests run it headless. [`pick_probe`] finds the probe under the cursor.

use std::collections::VecDeque;

use bevy_ecs::prelude::*;
use ddgi::{DdgiGpuVolumes, DdgiOutput, DdgiProbe, DdgiProbeColor, DdgiProbeState, DdgiProbeView, DdgiVolume};
use engine::gpu::GpuContext;

use super::controller::NavMeshResource;
use super::navmesh::FaceKind;
use engine::render::gpu_scene::clip_from_world;
use engine::render::{FrameTimings, RenderSize};
use engine::scene::{Camera, DirectionalLight, GlobalTransform, MeshInstance, Name, PointLight, SpotLight, Transform};
use glam::{EulerRot, Mat4, Quat, UVec2, Vec2, Vec3, Vec4};

/// Frames kept for the rolling graphs.
const HISTORY: usize = 240;
/// Seconds between atlas readbacks while the probe or atlas window is open (a readback waits for
/// the GPU).
const ATLAS_REFRESH_SECONDS: f64 = 0.5;

/// What the overlay remembers between frames.
pub struct OverlayState {
    pub visible: bool,
    /// Wall-clock seconds of the last frames (frames per second).
    frame_seconds: VecDeque<f64>,
    /// Total GPU milliseconds of the last frames, and the DDGI probe update's share.
    gpu_ms: VecDeque<(f64, f64)>,
    last_timing_frame: Option<u64>,
    pub selected_entity: Option<Entity>,
    pub show_atlases: bool,
    /// Draw the navigation mesh's faces over the view.
    pub show_navmesh: bool,
    atlases: Option<AtlasImages>,
    atlas_age: f64,
    /// Set by the screenshot button; the runner takes it.
    pub screenshot_requested: bool,
}

impl Default for OverlayState {
    fn default() -> Self {
        Self {
            visible: false,
            frame_seconds: VecDeque::new(),
            gpu_ms: VecDeque::new(),
            last_timing_frame: None,
            selected_entity: None,
            show_atlases: false,
            show_navmesh: false,
            atlases: None,
            atlas_age: f64::INFINITY,
            screenshot_requested: false,
        }
    }
}

/// The atlases read back and uploaded to egui, and the tile geometry to crop a probe's maps.
struct AtlasImages {
    /// The whole atlases, shrunk by an integer factor when wider than egui's largest texture.
    irradiance: egui::TextureHandle,
    distance: egui::TextureHandle,
    irradiance_size: UVec2,
    distance_size: UVec2,
    /// The selected probe's maps (its tiles, borders included), and which probe they show.
    probe_irradiance: egui::TextureHandle,
    probe_distance: egui::TextureHandle,
    probe: u32,
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

impl OverlayState {
    /// Records a frame's wall time (call once per frame).
    pub fn frame(&mut self, seconds: f64) {
        self.frame_seconds.push_back(seconds);
        if self.frame_seconds.len() > HISTORY {
            self.frame_seconds.pop_front();
        }
        self.atlas_age += seconds;
    }

    fn fps(&self) -> f64 {
        let total: f64 = self.frame_seconds.iter().sum();
        if total > 0.0 { self.frame_seconds.len() as f64 / total } else { 0.0 }
    }
}

/// Builds the overlay's UI for one frame from (and into) `world`.
pub fn overlay_ui(ctx: &egui::Context, state: &mut OverlayState, world: &mut World) {
    collect_timings(state, world);
    if !state.visible {
        return;
    }
    egui::Window::new("Performance").default_pos([10.0, 10.0]).show(ctx, |ui| performance_ui(ui, state, world));
    egui::Window::new("DDGI").default_pos([10.0, 330.0]).show(ctx, |ui| ddgi_ui(ui, state, world));
    let selected_probe = world.get_resource::<DdgiProbeView>().and_then(|v| v.selected);
    if let Some(index) = selected_probe {
        let mut open = true;
        egui::Window::new("Probe").open(&mut open).default_pos([330.0, 10.0]).show(ctx, |ui| probe_ui(ui, state, world, index));
        if !open && let Some(mut view) = world.get_resource_mut::<DdgiProbeView>() {
            view.selected = None;
        }
    }
    if state.show_atlases {
        let mut open = true;
        egui::Window::new("Atlases").open(&mut open).default_pos([330.0, 300.0]).show(ctx, |ui| atlases_ui(ui, state, world));
        state.show_atlases = open;
    }
    egui::Window::new("Inspector").default_pos([900.0, 10.0]).show(ctx, |ui| inspector_ui(ui, state, world));
    if state.show_navmesh {
        draw_navmesh(ctx, world);
    }
    if (selected_probe.is_some() || state.show_atlases) && state.atlas_age >= ATLAS_REFRESH_SECONDS {
        refresh_atlases(ctx, state, world);
    }
}

fn collect_timings(state: &mut OverlayState, world: &World) {
    let Some(timings) = world.get_resource::<FrameTimings>() else { return };
    let since = state.last_timing_frame;
    for f in timings.frames.iter().filter(|f| since.is_none_or(|last| f.frame > last)) {
        let total: f64 = f.passes.iter().filter_map(|p| p.gpu_ms).sum();
        let ddgi: f64 = f.passes.iter().filter(|p| is_probe_update(&p.label)).filter_map(|p| p.gpu_ms).sum();
        state.gpu_ms.push_back((total, ddgi));
        state.last_timing_frame = Some(f.frame);
    }
    while state.gpu_ms.len() > HISTORY {
        state.gpu_ms.pop_front();
    }
}

/// Passes of the probe update (everything DDGI does before the camera's gather).
fn is_probe_update(label: &str) -> bool {
    label.starts_with("ddgi_")
        && !label.starts_with("ddgi_gather")
        && !label.starts_with("ddgi_composite")
        && !label.starts_with("ddgi_probe_spheres")
}

fn performance_ui(ui: &mut egui::Ui, state: &mut OverlayState, world: &World) {
    ui.label(format!("{:.1} frames/s", state.fps()));
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
    let peak = state.gpu_ms.iter().map(|(t, _)| *t).fold(0.0f64, f64::max).max(1e-3);
    let line = |pick: fn(&(f64, f64)) -> f64| -> Vec<egui::Pos2> {
        let n = state.gpu_ms.len().max(2) - 1;
        state
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
    if ui.button("Screenshot (F12)").clicked() {
        state.screenshot_requested = true;
    }
}

fn ddgi_ui(ui: &mut egui::Ui, state: &mut OverlayState, world: &mut World) {
    if let Some(mut output) = world.get_resource_mut::<DdgiOutput>() {
        ui.horizontal_wrapped(|ui| {
            ui.label("view:");
            for mode in DdgiOutput::ALL {
                ui.selectable_value(&mut *output, mode, mode.name());
            }
        });
    }
    let mut view = world.get_resource::<DdgiProbeView>().copied().unwrap_or_default();
    ui.horizontal_wrapped(|ui| {
        ui.label("probes:");
        for color in DdgiProbeColor::ALL {
            ui.selectable_value(&mut view.color, color, color.name());
        }
    });
    ui.add(egui::Slider::new(&mut view.radius, 0.02..=0.5).text("sphere radius (cells)"));
    if view.color == DdgiProbeColor::Error {
        ui.add(egui::Slider::new(&mut view.max_error, 1e-3..=1.0).logarithmic(true).text("error scale"));
    }
    ui.horizontal(|ui| {
        ui.checkbox(&mut state.show_atlases, "show atlases");
        ui.checkbox(&mut state.show_navmesh, "show navigation mesh");
    });
    if world.get_resource::<DdgiProbeView>() != Some(&view) {
        world.insert_resource(view);
    }
    let mut query = world.query::<&mut DdgiVolume>();
    for mut volume in query.iter_mut(world) {
        let mut v = volume.clone();
        ui.separator();
        ui.add(egui::Slider::new(&mut v.hysteresis, 0.0..=1.0).text("hysteresis"));
        ui.add(egui::Slider::new(&mut v.rays_per_probe, 1..=1024).logarithmic(true).text("rays per probe"));
        ui.add(egui::Slider::new(&mut v.normal_bias, 0.0..=1.0).text("normal bias"));
        ui.add(egui::Slider::new(&mut v.view_bias, 0.0..=1.0).text("view bias"));
        ui.label("visibility weights:");
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut v.weights.backface, "back-face");
            ui.checkbox(&mut v.weights.chebyshev, "Chebyshev");
            ui.checkbox(&mut v.weights.normal_bias, "normal bias");
            ui.checkbox(&mut v.weights.crush, "crush");
            ui.checkbox(&mut v.weights.trilinear, "trilinear");
        });
        ui.horizontal_wrapped(|ui| {
            ui.checkbox(&mut v.adaptive.enabled, "adaptive rays");
            ui.checkbox(&mut v.relocation, "relocation");
            ui.checkbox(&mut v.classification, "classification");
        });
        if let Err(e) = v.validate() {
            ui.colored_label(egui::Color32::RED, e.to_string());
        } else if *volume != v {
            *volume = v;
        }
    }
    if let Some(error) = world.get_resource::<DdgiGpuVolumes>().and_then(|v| v.first_error().map(str::to_owned)) {
        ui.colored_label(egui::Color32::RED, error);
    }
    ui.label("click a probe to inspect it");
}

fn probe_ui(ui: &mut egui::Ui, state: &mut OverlayState, world: &mut World, index: u32) {
    let mut query = world.query::<&DdgiProbe>();
    let Some(probe) = query.iter(world).find(|p| p.index == index).cloned() else {
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
    if atlases.probe != index {
        ui.weak("(maps of the next readback)");
    }
}

fn atlases_ui(ui: &mut egui::Ui, state: &mut OverlayState, _world: &mut World) {
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

/// Reads the first volume's atlases back and uploads them to egui as display images: irradiance
/// tonemapped (x / (1 + x) at the camera's exposure, sRGB), distance as grey over the volume's
/// distance scale.
fn refresh_atlases(ctx: &egui::Context, state: &mut OverlayState, world: &mut World) {
    state.atlas_age = 0.0;
    let exposure = view_camera(world).map_or(1.0, |(c, _)| c.exposure);
    let (Some(gpu), Some(volumes)) = (world.get_resource::<GpuContext>(), world.get_resource::<DdgiGpuVolumes>()) else { return };
    let Some((_, volume)) = volumes.volumes.first() else { return };
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
            });
        }
    }
}

/// The navigation mesh's faces projected over the view: walkable green, door yellow, blocked red.
fn draw_navmesh(ctx: &egui::Context, world: &mut World) {
    let Some(size) = world.get_resource::<RenderSize>().copied() else { return };
    let Some((camera, transform)) = view_camera(world) else { return };
    let Some(navmesh) = world.get_resource::<NavMeshResource>() else { return };
    let clip = clip_from_world(&camera, &transform, size);
    let points_per_pixel = 1.0 / ctx.pixels_per_point();
    let project = |p: Vec2| {
        let c = clip * Vec4::new(p.x, NAVMESH_DRAW_HEIGHT, p.y, 1.0);
        (c.w > 1e-3).then(|| {
            egui::pos2((c.x / c.w + 1.0) * 0.5 * size.width as f32, (1.0 - c.y / c.w) * 0.5 * size.height as f32) * points_per_pixel
        })
    };
    let painter = ctx.layer_painter(egui::LayerId::background());
    for (corners, kind) in navmesh.0.triangles() {
        let color = match kind {
            FaceKind::Walkable => egui::Color32::from_rgba_unmultiplied(40, 220, 60, 160),
            FaceKind::Door => egui::Color32::from_rgba_unmultiplied(240, 220, 40, 200),
            FaceKind::Blocked => egui::Color32::from_rgba_unmultiplied(230, 40, 40, 90),
        };
        let Some(points) = corners.iter().map(|&c| project(c)).collect::<Option<Vec<_>>>() else { continue };
        painter.add(egui::Shape::closed_line(points, egui::Stroke::new(1.0, color)));
    }
}

/// The camera the image is rendered from (the renderer takes the first one).
fn view_camera(world: &mut World) -> Option<(Camera, GlobalTransform)> {
    let mut cameras = world.query::<(&Camera, &GlobalTransform)>();
    cameras.iter(world).next().map(|(c, t)| (*c, *t))
}

/// Height (m) at which the navigation mesh is drawn: just above the ground and the house's floor.
const NAVMESH_DRAW_HEIGHT: f32 = 0.2;

/// Entities a user would select: named, with a transform, and not a probe or a mesh primitive.
fn inspectable(world: &mut World) -> Vec<(Entity, String)> {
    let mut query = world.query_filtered::<(Entity, &Name), (With<Transform>, Without<DdgiProbe>, Without<MeshInstance>)>();
    let mut list: Vec<(Entity, String)> = query.iter(world).map(|(e, n)| (e, n.0.clone())).collect();
    list.sort_by(|a, b| a.1.cmp(&b.1));
    list
}

fn inspector_ui(ui: &mut egui::Ui, state: &mut OverlayState, world: &mut World) {
    let list = inspectable(world);
    egui::ScrollArea::vertical().max_height(160.0).id_salt("entities").show(ui, |ui| {
        for (entity, name) in &list {
            if ui.selectable_label(state.selected_entity == Some(*entity), name).clicked() {
                state.selected_entity = Some(*entity);
            }
        }
    });
    let Some(entity) = state.selected_entity.filter(|e| world.get_entity(*e).is_ok()) else {
        state.selected_entity = None;
        ui.label("select an entity to move it or change its light");
        return;
    };
    ui.separator();
    if let Some(mut transform) = world.get_mut::<Transform>(entity) {
        let mut t = *transform;
        ui.horizontal(|ui| {
            ui.label("position");
            ui.add(egui::DragValue::new(&mut t.translation.x).speed(0.05));
            ui.add(egui::DragValue::new(&mut t.translation.y).speed(0.05));
            ui.add(egui::DragValue::new(&mut t.translation.z).speed(0.05));
        });
        let (y, x, z) = t.rotation.to_euler(EulerRot::YXZ);
        let mut degrees = [y.to_degrees(), x.to_degrees(), z.to_degrees()];
        ui.horizontal(|ui| {
            ui.label("yaw pitch roll");
            for d in &mut degrees {
                ui.add(egui::DragValue::new(d).speed(0.5).suffix("°"));
            }
        });
        t.rotation = Quat::from_euler(EulerRot::YXZ, degrees[0].to_radians(), degrees[1].to_radians(), degrees[2].to_radians());
        if t.translation.is_finite() && t.rotation.is_finite() && !approx_same(&t, &transform) {
            *transform = t;
        }
    }
    light_ui(ui, world, entity);
}

fn approx_same(a: &Transform, b: &Transform) -> bool {
    a.translation.abs_diff_eq(b.translation, 1e-6) && a.rotation.abs_diff_eq(b.rotation, 1e-6) && a.scale.abs_diff_eq(b.scale, 1e-6)
}

/// Colour and intensity of the selected entity's light, if it has one.
fn light_ui(ui: &mut egui::Ui, world: &mut World, entity: Entity) {
    let edit = |ui: &mut egui::Ui, color: &mut Vec3, intensity: &mut f32, unit: &str| {
        let mut rgb = color.to_array();
        let mut changed = false;
        ui.horizontal(|ui| {
            ui.label("colour");
            changed |= ui.color_edit_button_rgb(&mut rgb).changed();
            ui.label("intensity");
            changed |= ui.add(egui::DragValue::new(intensity).speed(0.1).range(0.0..=1e6).suffix(unit)).changed();
        });
        *color = Vec3::from_array(rgb);
        changed
    };
    if let Some(mut light) = world.get_mut::<PointLight>(entity) {
        let (mut c, mut i) = (light.color, light.intensity);
        if edit(ui, &mut c, &mut i, " W/sr") {
            (light.color, light.intensity) = (c, i);
        }
    } else if let Some(mut light) = world.get_mut::<SpotLight>(entity) {
        let (mut c, mut i) = (light.color, light.intensity);
        if edit(ui, &mut c, &mut i, " W/sr") {
            (light.color, light.intensity) = (c, i);
        }
    } else if let Some(mut light) = world.get_mut::<DirectionalLight>(entity) {
        let (mut c, mut i) = (light.color, light.intensity);
        if edit(ui, &mut c, &mut i, " W/m²") {
            (light.color, light.intensity) = (c, i);
        }
    }
}

/// The probe whose sphere (of `radius`) the cursor is over: the nearest along the camera ray
/// through pixel `cursor` (pixels from the top-left of a `size` image). Probes are
/// `(index, world position)`.
pub fn pick_probe(
    camera: &Camera,
    transform: &GlobalTransform,
    size: RenderSize,
    cursor: Vec2,
    probes: impl IntoIterator<Item = (u32, Vec3)>,
    radius: f32,
) -> Option<u32> {
    let (origin, direction) = camera_ray(camera, transform, size, cursor)?;
    let mut best: Option<(f32, u32)> = None;
    for (index, center) in probes {
        // Ray-sphere: |o + t d − c|² = r², nearest t ≥ 0.
        let oc = origin - center;
        let b = oc.dot(direction);
        let c = oc.length_squared() - radius * radius;
        let discriminant = b * b - c;
        if discriminant < 0.0 {
            continue;
        }
        let root = discriminant.sqrt();
        let t = if -b - root >= 0.0 { -b - root } else { -b + root };
        if t >= 0.0 && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, index));
        }
    }
    best.map(|(_, i)| i)
}

/// The world-space ray (origin on the near plane, unit direction) through the centre of pixel
/// `cursor`, with the renderer's own projection.
pub fn camera_ray(camera: &Camera, transform: &GlobalTransform, size: RenderSize, cursor: Vec2) -> Option<(Vec3, Vec3)> {
    let clip = clip_from_world(camera, transform, size);
    let world_from_clip: Mat4 = clip.inverse();
    let ndc = Vec2::new(2.0 * cursor.x / size.width.max(1) as f32 - 1.0, 1.0 - 2.0 * cursor.y / size.height.max(1) as f32);
    // Reverse-Z: depth 1 is the near plane, smaller depths are farther.
    let unproject = |depth: f32| {
        let p: Vec4 = world_from_clip * Vec4::new(ndc.x, ndc.y, depth, 1.0);
        (p.w.abs() > 1e-30).then(|| p.truncate() / p.w)
    };
    let near = unproject(1.0)?;
    let far = unproject(0.01)?;
    let direction = (far - near).try_normalize()?;
    Some((near, direction))
}

/// Selects the probe under the cursor of the first volume (click in the view with the overlay
/// open). Returns the index picked, if any.
pub fn pick_probe_in_world(world: &mut World, cursor: Vec2) -> Option<u32> {
    let size = *world.get_resource::<RenderSize>()?;
    let (camera, transform) = view_camera(world)?;
    let (spacing, first) = {
        let volumes = world.get_resource::<DdgiGpuVolumes>()?;
        let (entity, volume) = volumes.volumes.first()?;
        (volume.layout.spacing.min_element(), *entity)
    };
    let view = world.get_resource::<DdgiProbeView>().copied().unwrap_or_default();
    let mut probes = world.query::<&DdgiProbe>();
    let list: Vec<(u32, Vec3)> = probes.iter(world).filter(|p| p.volume == first).map(|p| (p.index, p.position)).collect();
    let picked = pick_probe(&camera, &transform, size, cursor, list, view.radius.clamp(0.0, 0.5) * spacing);
    if let Some(mut v) = world.get_resource_mut::<DdgiProbeView>() {
        v.selected = picked;
    }
    picked
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera_at(eye: Vec3, target: Vec3) -> (Camera, GlobalTransform) {
        let t = Transform::from_translation(eye).looking_at(target, Vec3::Y);
        (Camera::default(), GlobalTransform(t.to_affine()))
    }

    /// The pixel a world point projects to.
    fn project(camera: &Camera, transform: &GlobalTransform, size: RenderSize, p: Vec3) -> Vec2 {
        let c = clip_from_world(camera, transform, size) * p.extend(1.0);
        let ndc = c.truncate() / c.w;
        Vec2::new((ndc.x + 1.0) * 0.5 * size.width as f32, (1.0 - ndc.y) * 0.5 * size.height as f32)
    }

    #[test]
    fn picking_returns_the_probe_under_the_cursor() {
        let size = RenderSize { width: 640, height: 360 };
        let (camera, transform) = camera_at(Vec3::new(0.3, 1.6, 6.0), Vec3::new(0.0, 1.0, 0.0));
        // A 5 × 3 × 5 grid of probes 1 m apart.
        let probes: Vec<(u32, Vec3)> =
            (0..75u32).map(|i| (i, Vec3::new((i % 5) as f32 - 2.0, ((i / 5) % 3) as f32, (i / 15) as f32 - 2.0))).collect();
        let mut hits = 0;
        for &(index, p) in &probes {
            let pixel = project(&camera, &transform, size, p);
            if pixel.x < 0.0 || pixel.y < 0.0 || pixel.x >= 640.0 || pixel.y >= 360.0 {
                continue;
            }
            let picked = pick_probe(&camera, &transform, size, pixel, probes.iter().copied(), 0.1)
                .expect("a probe's own centre pixel picks something");
            // The picked probe is this one, or one in front of it along the same ray.
            let (_, q) = probes[picked as usize];
            let eye = transform.translation();
            if picked != index {
                assert!((q - eye).length() < (p - eye).length(), "probe {picked} picked behind probe {index}");
            } else {
                hits += 1;
            }
        }
        assert!(hits > 40, "only {hits} probes pickable at their own pixel");
        // The sky above the grid picks nothing.
        assert_eq!(pick_probe(&camera, &transform, size, Vec2::new(320.0, 2.0), probes.iter().copied(), 0.1), None);
        // Just outside a lone probe's sphere picks nothing; just inside picks it.
        let lone = [(7u32, Vec3::new(0.0, 1.0, 0.0))];
        let center = project(&camera, &transform, size, lone[0].1);
        assert_eq!(pick_probe(&camera, &transform, size, center, lone, 0.1), Some(7));
        assert_eq!(pick_probe(&camera, &transform, size, center + Vec2::new(40.0, 0.0), lone, 0.1), None);
    }

    /// The overlay builds every window of its UI from a running level (DDGI, probes read back,
    /// atlases uploaded as egui textures) without errors, and its settings reach the renderer: the
    /// probe spheres and the albedo view run as passes of the next frame.
    #[test]
    fn overlay_builds_its_ui_from_a_running_level() {
        let Some(gpu) = GpuContext::for_tests("overlay_builds_its_ui_from_a_running_level") else { return };
        let options = crate::play::PlayOptions {
            width: 128,
            height: 72,
            probe_counts: crate::play::level::level_probe_counts(4.0),
            cascade_spacing: crate::play::PROBE_SPACING,
            rays_per_probe: 16,
            adaptive: true,
            use_assets: false,
            cascades: 0,
            taa: true,
        };
        let mut app = engine::headless::headless_app(&gpu, RenderSize { width: 128, height: 72 }, crate::play::STEP_SECONDS);
        crate::play::setup_play(&mut app, &options, true).expect("the level builds");
        engine::headless::run_frames(&mut app, 4, |_, _| {});
        let ctx = egui::Context::default();
        let mut state = OverlayState { visible: true, show_atlases: true, show_navmesh: true, ..Default::default() };
        let world = app.world_mut();
        world.resource_mut::<DdgiProbeView>().selected = Some(0);
        let input = || egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(1280.0, 720.0))),
            ..Default::default()
        };
        let mut shapes = 0;
        for _ in 0..3 {
            state.frame(1.0 / 60.0);
            let mut output = ctx.run_pass(input(), |ctx| overlay_ui(ctx, &mut state, world));
            shapes = output.shapes.len();
            output.textures_delta.clear();
        }
        assert!(shapes > 50, "the overlay drew only {shapes} shapes");
        assert!(state.atlases.is_some(), "the atlases were not read back into textures");
        assert!(!state.gpu_ms.is_empty(), "no frame timings collected");
        // Switch the probe view and the image through the same resources the UI edits.
        world.resource_mut::<DdgiProbeView>().color = DdgiProbeColor::State;
        *world.resource_mut::<DdgiOutput>() = DdgiOutput::Albedo;
        engine::headless::run_frames(&mut app, 1, |_, _| {});
        let timings = app.world().resource::<FrameTimings>();
        let last = timings.frames.last().expect("a frame");
        let ran = |label: &str| last.passes.iter().any(|p| p.label == label && p.ran);
        assert!(ran("ddgi_probe_spheres"), "the probe spheres did not run: {:?}", last.passes);
        assert!(!ran("ddgi_gather"), "the albedo view still gathered the indirect light");
    }

    #[test]
    fn picking_prefers_the_nearer_of_two_probes_on_one_ray() {
        let size = RenderSize { width: 320, height: 240 };
        let (camera, transform) = camera_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO);
        let probes = [(1u32, Vec3::new(0.0, 0.0, -2.0)), (2u32, Vec3::ZERO)];
        assert_eq!(pick_probe(&camera, &transform, size, Vec2::new(160.0, 120.0), probes, 0.2), Some(2));
    }
}

//! The demo's own windows in the DDGI overlay (`ddgi_overlay`, F1): the navigation mesh drawn over
//! the view, an entity inspector (move or turn any named entity, change a light's colour and
//! intensity) and a screenshot button. They are added to the overlay as an
//! [`ddgi_overlay::OverlayPanel`]; the overlay itself (GPU times, every DDGI volume and setting,
//! probe views and picking) is the plugin's.

use bevy_ecs::prelude::*;
use ddgi::DdgiProbe;
use engine::render::RenderSize;
use engine::render::gpu_scene::clip_from_world;
use engine::scene::{DirectionalLight, MeshInstance, Name, PointLight, SpotLight, Transform};
use glam::{EulerRot, Quat, Vec2, Vec3, Vec4};

use super::controller::NavMeshResource;
use super::navmesh::FaceKind;

/// A screenshot asked for by the overlay's button; the window's runner takes it.
#[derive(Resource, Default)]
pub struct ScreenshotRequest(pub bool);

/// The demo's panels and what they remember between frames.
#[derive(Default)]
pub struct DemoPanels {
    pub selected_entity: Option<Entity>,
    /// Draw the navigation mesh's faces over the view.
    pub show_navmesh: bool,
}

impl ddgi_overlay::OverlayPanel for DemoPanels {
    fn ui(&mut self, ctx: &egui::Context, world: &mut World) {
        egui::Window::new("Level").default_pos([900.0, 10.0]).show(ctx, |ui| {
            ui.horizontal(|ui| {
                ui.checkbox(&mut self.show_navmesh, "navigation mesh");
                if ui.button("screenshot (F12)").clicked() {
                    world.get_resource_or_insert_with(ScreenshotRequest::default).0 = true;
                }
            });
            ui.separator();
            inspector_ui(ui, self, world);
        });
        if self.show_navmesh {
            draw_navmesh(ctx, world);
        }
    }
}

/// The navigation mesh's faces projected over the view: walkable green, door yellow, blocked red.
fn draw_navmesh(ctx: &egui::Context, world: &mut World) {
    let Some(size) = world.get_resource::<RenderSize>().copied() else { return };
    let Some((camera, transform)) = ddgi_overlay::picking::view_camera(world) else { return };
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

/// Height (m) at which the navigation mesh is drawn: just above the ground and the house's floor.
const NAVMESH_DRAW_HEIGHT: f32 = 0.2;

/// Entities a user would select: named, with a transform, and not a probe or a mesh primitive.
fn inspectable(world: &mut World) -> Vec<(Entity, String)> {
    let mut query = world.query_filtered::<(Entity, &Name), (With<Transform>, Without<DdgiProbe>, Without<MeshInstance>)>();
    let mut list: Vec<(Entity, String)> = query.iter(world).map(|(e, n)| (e, n.0.clone())).collect();
    list.sort_by(|a, b| a.1.cmp(&b.1));
    list
}

fn inspector_ui(ui: &mut egui::Ui, state: &mut DemoPanels, world: &mut World) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use engine::gpu::GpuContext;

    /// The level with the DDGI overlay and the demo's panels builds every window from a running
    /// level (the overlay's atlases read back, the navigation mesh drawn), and the overlay is drawn
    /// into the image.
    #[test]
    fn the_demo_panels_build_in_the_overlay() {
        let Some(gpu) = GpuContext::for_tests("the_demo_panels_build_in_the_overlay") else { return };
        let options = crate::play::PlayOptions {
            width: 128,
            height: 72,
            probe_counts: crate::play::level::level_probe_counts(4.0),
            rays_per_probe: 16,
            use_assets: false,
            ..Default::default()
        };
        let mut app = engine::headless::headless_app(&gpu, RenderSize { width: 128, height: 72 }, crate::play::STEP_SECONDS);
        crate::play::setup_play(&mut app, &options, true).expect("the level builds");
        crate::play::add_overlay(&mut app);
        app.world_mut().resource_mut::<ddgi_overlay::DdgiOverlay>().visible = true;
        engine::headless::run_frames(&mut app, 3, |_, _| {});
        let world = app.world_mut();
        let ctx = egui::Context::default();
        let mut panels = DemoPanels { show_navmesh: true, ..Default::default() };
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(1280.0, 720.0))),
            ..Default::default()
        };
        let mut output = ctx.run_pass(input, |ctx| ddgi_overlay::OverlayPanel::ui(&mut panels, ctx, world));
        assert!(output.shapes.len() > 20, "the demo's panels drew only {} shapes", output.shapes.len());
        output.textures_delta.clear();
        let timings = app.world().resource::<engine::render::FrameTimings>();
        let last = timings.frames.last().expect("a frame");
        assert!(last.passes.iter().any(|p| p.label == "egui_overlay" && p.ran), "the overlay was not drawn: {:?}", last.passes);
    }
}

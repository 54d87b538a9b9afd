//! Every field of [`DdgiVolume`], [`DdgiAdaptive`] and [`DdgiWeights`] as an editor, with the
//! field's rustdoc comment as its tooltip.
//!
//! The tooltips come from ddgi itself ([`ddgi::field_docs`]), which parses the doc comments of its
//! own `volume.rs` once, so a tooltip cannot drift from the docs; [`field_docs`] and
//! [`parse_field_docs`] are re-exported here. The tests check that the editors, the parsed docs
//! and the serialized settings list the same fields ([`VOLUME_FIELDS`], [`ADAPTIVE_FIELDS`],
//! [`WEIGHT_FIELDS`]).

pub use ddgi::field_docs::{field_docs, parse_field_docs};
use ddgi::volume::{MAX_HIT_OCCLUSION_RAYS, MAX_MAP_TEXELS, MAX_RAYS_PER_PROBE};
use ddgi::{DdgiAdaptive, DdgiVolume, DdgiWeights};
use glam::{DVec3, UVec3, Vec3};

/// One editable field: its name (as in Rust and in the saved JSON) and its editor, which returns
/// whether it changed the value.
pub struct Field<T> {
    /// The field's name.
    pub name: &'static str,
    /// Draws the editor of the field of `T`; true when the user changed it.
    pub edit: fn(&mut egui::Ui, &mut T) -> bool,
}

fn f32_range(ui: &mut egui::Ui, v: &mut f32, lo: f32, hi: f32, speed: f64) -> bool {
    ui.add(egui::DragValue::new(v).range(lo..=hi).speed(speed).max_decimals(4)).changed()
}

fn u32_range(ui: &mut egui::Ui, v: &mut u32, lo: u32, hi: u32) -> bool {
    ui.add(egui::DragValue::new(v).range(lo..=hi).speed(0.25)).changed()
}

fn toggle(ui: &mut egui::Ui, v: &mut bool) -> bool {
    ui.checkbox(v, "").changed()
}

/// `None` as an unchecked box ("auto"), `Some` as a checked box and the value's editor.
fn optional<T: Clone>(ui: &mut egui::Ui, v: &mut Option<T>, on: T, edit: impl FnOnce(&mut egui::Ui, &mut T) -> bool) -> bool {
    let mut some = v.is_some();
    let mut changed = false;
    ui.horizontal(|ui| {
        let label = if some { "" } else { "auto" };
        if ui.checkbox(&mut some, label).changed() {
            *v = some.then(|| on.clone());
            changed = true;
        }
        if let Some(value) = v.as_mut() {
            changed |= edit(ui, value);
        }
    });
    changed
}

fn uvec3(ui: &mut egui::Ui, v: &mut UVec3, lo: u32, hi: u32) -> bool {
    let mut changed = false;
    for c in [&mut v.x, &mut v.y, &mut v.z] {
        changed |= u32_range(ui, c, lo, hi);
    }
    changed
}

fn vec3(ui: &mut egui::Ui, v: &mut Vec3, speed: f64) -> bool {
    let mut changed = false;
    for c in [&mut v.x, &mut v.y, &mut v.z] {
        changed |= ui.add(egui::DragValue::new(c).range(0.0..=1e6).speed(speed).max_decimals(3)).changed();
    }
    changed
}

fn dvec3(ui: &mut egui::Ui, v: &mut DVec3) -> bool {
    let mut changed = false;
    for c in [&mut v.x, &mut v.y, &mut v.z] {
        changed |= ui.add(egui::DragValue::new(c).speed(0.05).max_decimals(3)).changed();
    }
    changed
}

/// The editors of every [`DdgiVolume`] field but `adaptive` and `weights` (their own tables), in
/// the struct's order.
pub const VOLUME_FIELDS: &[Field<DdgiVolume>] = &[
    Field {
        name: "bounds",
        edit: |ui, v| {
            optional(ui, &mut v.bounds, (DVec3::ZERO, DVec3::ONE), |ui, (lo, hi)| {
                ui.vertical(|ui| ui.horizontal(|ui| dvec3(ui, lo)).inner | ui.horizontal(|ui| dvec3(ui, hi)).inner).inner
            })
        },
    },
    Field { name: "probe_counts", edit: |ui, v| optional(ui, &mut v.probe_counts, UVec3::splat(8), |ui, c| uvec3(ui, c, 1, 256)) },
    Field { name: "rays_per_probe", edit: |ui, v| u32_range(ui, &mut v.rays_per_probe, 1, MAX_RAYS_PER_PROBE) },
    Field { name: "irradiance_texels", edit: |ui, v| u32_range(ui, &mut v.irradiance_texels, 1, MAX_MAP_TEXELS) },
    Field { name: "distance_texels", edit: |ui, v| u32_range(ui, &mut v.distance_texels, 1, MAX_MAP_TEXELS) },
    Field { name: "hysteresis", edit: |ui, v| f32_range(ui, &mut v.hysteresis, 0.0, 1.0, 0.002) },
    Field { name: "normal_bias", edit: |ui, v| f32_range(ui, &mut v.normal_bias, 0.0, 1.0, 0.002) },
    Field { name: "view_bias", edit: |ui, v| f32_range(ui, &mut v.view_bias, 0.0, 1.0, 0.002) },
    Field { name: "distance_sharpness", edit: |ui, v| f32_range(ui, &mut v.distance_sharpness, 0.1, 500.0, 0.5) },
    Field {
        name: "max_ray_distance",
        edit: |ui, v| optional(ui, &mut v.max_ray_distance, 100.0, |ui, d| f32_range(ui, d, 1e-3, 1e6, 0.1)),
    },
    Field { name: "sky_radiance", edit: |ui, v| optional(ui, &mut v.sky_radiance, Vec3::ONE, |ui, c| vec3(ui, c, 0.01)) },
    Field { name: "relocation", edit: |ui, v| toggle(ui, &mut v.relocation) },
    Field { name: "classification", edit: |ui, v| toggle(ui, &mut v.classification) },
    Field { name: "firefly_threshold", edit: |ui, v| f32_range(ui, &mut v.firefly_threshold, 0.0, 1000.0, 0.1) },
    Field { name: "backface_threshold", edit: |ui, v| f32_range(ui, &mut v.backface_threshold, 0.0, 1.0, 0.005) },
    Field { name: "min_frontface_distance", edit: |ui, v| f32_range(ui, &mut v.min_frontface_distance, 0.0, 1.0, 0.005) },
    Field { name: "recheck_interval", edit: |ui, v| u32_range(ui, &mut v.recheck_interval, 0, 10_000) },
    Field { name: "recheck_rays", edit: |ui, v| u32_range(ui, &mut v.recheck_rays, 1, MAX_RAYS_PER_PROBE) },
    Field { name: "seed", edit: |ui, v| ui.add(egui::DragValue::new(&mut v.seed).speed(1.0)).changed() },
    Field { name: "warm_up", edit: |ui, v| toggle(ui, &mut v.warm_up) },
    Field { name: "update_period", edit: |ui, v| u32_range(ui, &mut v.update_period, 1, 1024) },
    Field { name: "update_phase", edit: |ui, v| u32_range(ui, &mut v.update_phase, 0, 1023) },
    Field { name: "persistent_trace", edit: |ui, v| toggle(ui, &mut v.persistent_trace) },
    Field { name: "hit_occlusion_rays", edit: |ui, v| u32_range(ui, &mut v.hit_occlusion_rays, 0, MAX_HIT_OCCLUSION_RAYS) },
    Field { name: "hit_occlusion_reach", edit: |ui, v| f32_range(ui, &mut v.hit_occlusion_reach, 0.01, 4.0, 0.01) },
];

/// The editors of every [`DdgiAdaptive`] field, in the struct's order.
pub const ADAPTIVE_FIELDS: &[Field<DdgiAdaptive>] = &[
    Field { name: "enabled", edit: |ui, a| toggle(ui, &mut a.enabled) },
    Field { name: "min_rays", edit: |ui, a| u32_range(ui, &mut a.min_rays, 1, MAX_RAYS_PER_PROBE) },
    Field { name: "error_target", edit: |ui, a| f32_range(ui, &mut a.error_target, 1e-4, 2.0, 0.001) },
    Field { name: "decay", edit: |ui, a| f32_range(ui, &mut a.decay, 0.0, 1.0, 0.002) },
    Field { name: "error_smoothing", edit: |ui, a| f32_range(ui, &mut a.error_smoothing, 0.0, 1.0, 0.002) },
    Field { name: "error_floor", edit: |ui, a| f32_range(ui, &mut a.error_floor, 0.0, 10.0, 1e-4) },
    Field { name: "dark_fraction", edit: |ui, a| f32_range(ui, &mut a.dark_fraction, 0.0, 1.0, 1e-4) },
    Field { name: "frame_budget", edit: |ui, a| optional(ui, &mut a.frame_budget, 1 << 18, |ui, b| u32_range(ui, b, 1, u32::MAX)) },
    Field { name: "max_rest_frames", edit: |ui, a| u32_range(ui, &mut a.max_rest_frames, 0, 0xffff) },
    Field { name: "rest_error", edit: |ui, a| f32_range(ui, &mut a.rest_error, 0.0, 10.0, 0.005) },
    Field { name: "hysteresis_exponent", edit: |ui, a| f32_range(ui, &mut a.hysteresis_exponent, 0.0, 1.0, 0.005) },
    Field { name: "rest_smoothing", edit: |ui, a| optional(ui, &mut a.rest_smoothing, 0.97, |ui, s| f32_range(ui, s, 0.0, 0.999, 0.001)) },
    Field { name: "max_update_period", edit: |ui, a| u32_range(ui, &mut a.max_update_period, 1, 64) },
    Field { name: "calm_error", edit: |ui, a| f32_range(ui, &mut a.calm_error, 0.0, 10.0, 0.005) },
    Field { name: "drift_rate", edit: |ui, a| f32_range(ui, &mut a.drift_rate, 1.0, 64.0, 0.05) },
];

/// The editors of every [`DdgiWeights`] field, in the struct's order.
pub const WEIGHT_FIELDS: &[Field<DdgiWeights>] = &[
    Field { name: "backface", edit: |ui, w| toggle(ui, &mut w.backface) },
    Field { name: "chebyshev", edit: |ui, w| toggle(ui, &mut w.chebyshev) },
    Field { name: "normal_bias", edit: |ui, w| toggle(ui, &mut w.normal_bias) },
    Field { name: "crush", edit: |ui, w| toggle(ui, &mut w.crush) },
    Field { name: "trilinear", edit: |ui, w| toggle(ui, &mut w.trilinear) },
];

/// A grid of `fields` of `value`: each name (its doc as tooltip) and its editor. Returns whether
/// any changed.
pub fn edit_fields<T>(ui: &mut egui::Ui, id: &str, struct_name: &str, fields: &[Field<T>], value: &mut T) -> bool {
    let docs = field_docs(struct_name);
    let mut changed = false;
    egui::Grid::new(id).num_columns(2).striped(true).show(ui, |ui| {
        for field in fields {
            let doc = docs.get(field.name).map_or("(undocumented)", String::as_str);
            ui.label(field.name).on_hover_text(doc);
            ui.horizontal(|ui| changed |= (field.edit)(ui, value)).response.on_hover_text(doc);
            ui.end_row();
        }
    });
    changed
}

/// The editors of a whole [`DdgiVolume`]: its own fields, then `weights` and `adaptive` in
/// sections whose headers carry those fields' docs. Returns whether anything changed.
pub fn edit_volume(ui: &mut egui::Ui, id: &str, volume: &mut DdgiVolume) -> bool {
    let docs = field_docs("DdgiVolume");
    let mut changed = edit_fields(ui, &format!("{id}_volume"), "DdgiVolume", VOLUME_FIELDS, volume);
    let header = |ui: &mut egui::Ui, name: &str| {
        ui.label(egui::RichText::new(name).strong()).on_hover_text(docs.get(name).map_or("", String::as_str));
    };
    header(ui, "weights");
    changed |= edit_fields(ui, &format!("{id}_weights"), "DdgiWeights", WEIGHT_FIELDS, &mut volume.weights);
    header(ui, "adaptive");
    changed |= edit_fields(ui, &format!("{id}_adaptive"), "DdgiAdaptive", ADAPTIVE_FIELDS, &mut volume.adaptive);
    changed
}

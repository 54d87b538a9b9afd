//! The scene-fitted choice between one volume and camera-following cascades ([`DdgiLighting`]).
//!
//! One volume of the default grid ([`crate::auto_probe_counts`]: 16 probes along the scene's
//! longest side) is the best DDGI can do for a room, a house or a cathedral: every probe updates
//! every frame and nothing fades between grids. Over a village or a valley the same 16 probes sit
//! tens of metres apart, and a room gets no probe of its own: it takes the light of the probes
//! outside, through its walls. So the rule: one volume while its probes are at most
//! [`MAX_FITTED_SPACING`] apart, otherwise cascades centred on the camera
//! ([`DdgiLighting::fitted`]).

use bevy_ecs::prelude::*;
use engine::render::gpu_scene::GpuScene;
use engine::scene::{Assets, Mesh, Name, RenderOrigin};
use glam::{DVec3, UVec3, Vec3};

use crate::cascades::{DdgiCascades, DdgiFirstCameraCascades, MAX_CASCADES};
use crate::resources::DdgiGpuVolumes;
use crate::volume::{DdgiVolume, auto_probe_counts, volume_extent};

/// Largest probe spacing, in world units (metres), at which the scene-fitted default keeps one
/// volume over the scene; beyond it, [`DdgiLighting::fitted`] picks cascades. Why 4 m: rooms are
/// 3–6 m across and storeys about 3 m high, so probes further apart leave most rooms without a
/// probe inside them, and a room then takes the light of the probes outside its walls (measured in
/// BENCHMARKS.md, "Defaults that fit the scene": the thin-wall room seen from its door is 4.2×
/// too bright at 10 m spacing, a house of a 1.6 km village 1.9× at 100 m), while interiors fitted
/// at 2.5–3 m (the 46 m cathedral, Šibenik, the thin-wall room's 40 m ground) are lit better by
/// one volume than by cascades (no blend bands, every probe updated every frame).
pub const MAX_FITTED_SPACING: f32 = 4.0;

/// Finest probe spacing the scene-fitted cascades aim for, in world units: as many cascades (up to
/// [`MAX_CASCADES`]) as it takes for the finest one's spacing to be at most this, the coarsest as
/// wide as the scene.
pub const FITTED_FINEST_SPACING: f32 = 1.0;

/// Probes of each scene-fitted cascade.
pub const FITTED_CASCADE_PROBES: UVec3 = UVec3::new(16, 8, 16);

/// How DDGI lights a scene. [`crate::use_ddgi_lighting`] applies it; `Default` is the
/// scene-fitted rule with the default volume settings.
#[derive(Resource, Clone, Debug, PartialEq)]
pub enum DdgiLighting {
    /// The scene-fitted rule ([`DdgiLighting::fitted`]), decided on the first frame the scene has
    /// geometry (and not again), from this volume's settings; its `bounds` (when set) stand for
    /// the scene's. A volume whose `probe_counts` is set is an explicit grid: one volume.
    Fitted(DdgiVolume),
    /// One volume (its `bounds`, or the scene's).
    Volume(DdgiVolume),
    /// Cascades that follow the first camera.
    Cascades(DdgiCascades),
}

impl Default for DdgiLighting {
    fn default() -> Self {
        DdgiLighting::Fitted(DdgiVolume::default())
    }
}

impl DdgiLighting {
    /// The scene-fitted choice for a scene of world-space box `scene` with `volume`'s settings:
    /// one volume when `volume` has an explicit grid (`probe_counts`), or when the default grid
    /// over the box ([`auto_probe_counts`]) spaces its probes at most [`MAX_FITTED_SPACING`] apart
    /// along every axis; otherwise cascades of [`FITTED_CASCADE_PROBES`] with `volume`'s settings,
    /// the coarsest as wide as the box's wider horizontal side ([`DdgiCascades::fitted`]), as few
    /// as give a finest spacing of at most [`FITTED_FINEST_SPACING`] (at most [`MAX_CASCADES`]).
    /// A box that is not finite gets one volume (whose layout reports it).
    pub fn fitted(scene: (DVec3, DVec3), volume: DdgiVolume) -> DdgiLighting {
        let spacing = fitted_spacing(scene);
        // A box that is not finite is left to the volume, which names it in its error.
        if volume.probe_counts.is_some() || !spacing.is_finite() || spacing <= MAX_FITTED_SPACING {
            return DdgiLighting::Volume(volume);
        }
        let size = scene.1 - scene.0;
        let extent = size.x.max(size.z).max(0.0) as f32;
        let across = FITTED_CASCADE_PROBES.x.min(FITTED_CASCADE_PROBES.z) as f32;
        let count =
            (1..=MAX_CASCADES).find(|&n| extent / (across * (1u32 << (n - 1)) as f32) <= FITTED_FINEST_SPACING).unwrap_or(MAX_CASCADES);
        DdgiLighting::Cascades(DdgiCascades::fitted(count, FITTED_CASCADE_PROBES, extent, DdgiVolume { bounds: None, ..volume }))
    }

    /// This lighting with the rule applied for a scene of world-space box `scene` (a `Fitted`
    /// volume with bounds is fitted to them instead); `Volume` and `Cascades` stay as they are.
    pub fn resolve(self, scene: (DVec3, DVec3)) -> DdgiLighting {
        match self {
            DdgiLighting::Fitted(volume) => {
                let bounds = volume.bounds.unwrap_or(scene);
                DdgiLighting::fitted(bounds, volume)
            }
            other => other,
        }
    }

    /// One line saying what it is, for logs and reports.
    pub fn describe(&self) -> String {
        match self {
            DdgiLighting::Fitted(_) => "the scene-fitted default (not decided yet)".into(),
            DdgiLighting::Volume(v) => match v.probe_counts {
                Some(c) => format!("one volume of {}×{}×{} probes", c.x, c.y, c.z),
                None => "one volume of the fitted grid".into(),
            },
            DdgiLighting::Cascades(c) => {
                let p = c.probe_counts;
                let count = c.count.map_or("as many as the scene needs".to_string(), |n| n.to_string());
                format!("{count} camera-following cascades of {}×{}×{} probes, the finest {:.2} apart", p.x, p.y, p.z, c.spacing)
            }
        }
    }
}

/// The largest probe spacing of one volume of the default grid ([`auto_probe_counts`]) over
/// `scene`, as [`crate::DdgiLayout::new`] would place it (NaN for a box that is not finite).
pub fn fitted_spacing(scene: (DVec3, DVec3)) -> f32 {
    let size = (scene.1 - scene.0).as_vec3();
    if !size.is_finite() {
        return f32::NAN;
    }
    let extent = volume_extent(size.max(Vec3::ZERO));
    (extent / auto_probe_counts(extent).as_vec3()).max_element()
}

/// Prepare stage, first: applies [`DdgiLighting`] (inserted by [`crate::use_ddgi_lighting`]) once
/// the scene has geometry — spawns the volume, or gives the cascades to the first camera — and
/// logs the choice.
pub fn apply_ddgi_lighting(
    mut commands: Commands,
    lighting: Option<Res<DdgiLighting>>,
    mut applied: Local<bool>,
    scene: Res<GpuScene>,
    meshes: Res<Assets<Mesh>>,
    origin: Option<Res<RenderOrigin>>,
    mut state: ResMut<DdgiGpuVolumes>,
) {
    let Some(lighting) = lighting else { return };
    if *applied {
        return;
    }
    let origin = origin.map_or(DVec3::ZERO, |o| o.origin);
    let resolved = match lighting.clone() {
        DdgiLighting::Fitted(volume) => {
            let scene_box = volume.bounds.or_else(|| state.scene_box_or_compute(&scene, &meshes, origin));
            // No geometry yet: decide on a later frame.
            let Some(scene_box) = scene_box else { return };
            let resolved = DdgiLighting::fitted(scene_box, volume);
            log::info!(
                "DDGI, fitted to the scene ({:.1} × {:.1} × {:.1}; one volume's probes {:.2} apart, at most {MAX_FITTED_SPACING} for one volume): {}",
                (scene_box.1 - scene_box.0).x,
                (scene_box.1 - scene_box.0).y,
                (scene_box.1 - scene_box.0).z,
                fitted_spacing(scene_box),
                resolved.describe()
            );
            resolved
        }
        other => other,
    };
    *applied = true;
    match resolved.clone() {
        DdgiLighting::Volume(volume) | DdgiLighting::Fitted(volume) => {
            commands.spawn((volume, Name("ddgi_volume".into())));
        }
        DdgiLighting::Cascades(cascades) => commands.insert_resource(DdgiFirstCameraCascades(cascades)),
    }
    commands.insert_resource(resolved);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn box_of(x: f64, y: f64, z: f64) -> (DVec3, DVec3) {
        (DVec3::ZERO, DVec3::new(x, y, z))
    }

    #[test]
    fn interiors_get_one_volume_and_a_village_gets_cascades() {
        // A 46 m church and a 40 m ground under a room: 2.9 m and 2.5 m spacing, one volume.
        for b in [box_of(46.0, 18.0, 20.0), box_of(40.0, 3.0, 40.0), box_of(6.0, 3.0, 6.0)] {
            assert!(matches!(DdgiLighting::fitted(b, DdgiVolume::default()), DdgiLighting::Volume(_)), "{b:?}");
        }
        // Just past the threshold: 65 m → 4.06 m apart.
        let DdgiLighting::Cascades(c) = DdgiLighting::fitted(box_of(65.0, 10.0, 65.0), DdgiVolume::default()) else {
            panic!("a 65 m scene gets cascades")
        };
        assert!(c.spacing <= FITTED_FINEST_SPACING && c.spacing > FITTED_FINEST_SPACING / 2.0, "{}", c.spacing);
        // 1.6 km: as `--cascades 8`, the finest 0.78 m.
        let DdgiLighting::Cascades(c) = DdgiLighting::fitted(box_of(1600.0, 40.0, 1600.0), DdgiVolume::default()) else {
            panic!("a village gets cascades")
        };
        assert_eq!(c, DdgiCascades::fitted(8, FITTED_CASCADE_PROBES, 1600.0, DdgiVolume::default()));
        c.validate().expect("valid cascades");
        // A tall tower is too coarse along y alone.
        assert!(fitted_spacing(box_of(10.0, 200.0, 10.0)) > MAX_FITTED_SPACING);
        assert!(matches!(DdgiLighting::fitted(box_of(10.0, 200.0, 10.0), DdgiVolume::default()), DdgiLighting::Cascades(_)));
    }

    #[test]
    fn an_explicit_grid_is_one_volume_and_bad_boxes_do_not_panic() {
        let explicit = DdgiVolume { probe_counts: Some(UVec3::new(4, 2, 4)), ..Default::default() };
        assert!(matches!(DdgiLighting::fitted(box_of(1600.0, 40.0, 1600.0), explicit), DdgiLighting::Volume(_)));
        // Explicit bounds of a fitted volume stand for the scene's.
        let small = DdgiVolume { bounds: Some(box_of(8.0, 3.0, 8.0)), ..Default::default() };
        assert!(matches!(DdgiLighting::Fitted(small).resolve(box_of(1600.0, 40.0, 1600.0)), DdgiLighting::Volume(_)));
        for b in [box_of(0.0, 0.0, 0.0), box_of(f64::NAN, 1.0, 1.0), box_of(f64::INFINITY, 1.0, 1.0), box_of(-5.0, 1.0, 1.0)] {
            let l = DdgiLighting::fitted(b, DdgiVolume::default());
            assert!(matches!(l, DdgiLighting::Volume(_)), "{b:?}: {l:?}");
        }
    }
}

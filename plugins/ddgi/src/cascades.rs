//! Probe volumes that follow the camera: [`DdgiCascades`] on a camera (or as a resource, for the
//! first camera) keeps N nested volumes centred on it, each with twice the probe spacing of the one
//! inside it, each kept over the scene (a box wider than the scene along an axis is centred on it
//! there: [`DdgiCascades::level_bounds`]). When the camera crosses a cell of a cascade, that
//! cascade *scrolls*: its bounds move by whole cells, which the prepare stage turns into a
//! toroidal shift of the probe indices ([`crate::DdgiLayout::scroll`]) — the probes that stay keep
//! their maps, the planes that entered are reset and converge fast
//! ([`crate::DdgiVolume::warm_up`]). The gather takes the finest cascade that covers a point and
//! blends into the next one across a band of [`DdgiCascades::blend_cells`] cells (the coarsest
//! lights points at full weight to its edge); far cascades update less often; fixed volumes keep
//! working and are gathered first.

use bevy_ecs::prelude::*;
use engine::render::gpu_scene::GpuScene;
use engine::scene::{Assets, Camera, GlobalTransform, Mesh, Name, RenderOrigin};
use glam::{DVec3, UVec3};

pub use crate::cascade_volume::DdgiCascade;
use crate::resources::DdgiGpuVolumes;
use crate::volume::{DdgiVolume, MAX_PROBES};

/// Most cascades.
pub const MAX_CASCADES: u32 = 8;

/// Nested probe volumes centred on a camera. Put it on a camera entity, or insert
/// [`DdgiFirstCameraCascades`] to give it to the first camera ([`crate::use_ddgi_cascades`]).
///
/// Cost: each cascade is a volume of `probe_counts` probes, so `count` times the probes of one; far
/// cascades update only every few frames (`max_update_period`), and with adaptive budgets
/// (`volume.adaptive`) quiet probes rest. Memory: `count` times one volume's.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Component, Clone, Debug, PartialEq)]
pub struct DdgiCascades {
    /// Number of cascades, 1–8. `None`: as many as it takes for the coarsest cascade to reach the
    /// whole scene from anywhere in it (half its width at least the scene's largest extent).
    pub count: Option<u32>,
    /// Probes of each cascade along x, y and z. More: finer light near the camera and a wider
    /// reach, at proportionally more rays and memory.
    pub probe_counts: UVec3,
    /// Probe spacing of the finest cascade, in world units; cascade k has `spacing · 2^k`.
    pub spacing: f32,
    /// Width of the band, in cells of the finer cascade, over which a cascade fades into the next
    /// one out (inside its outer probes). Wider: smoother transitions, less of each cascade used
    /// at its full resolution.
    pub blend_cells: f32,
    /// Longest update period of a cascade, in frames: cascade k ≥ 1 updates every
    /// `min(2^(k−1), max_update_period)` frames (the first two every frame). 1: all every frame.
    pub max_update_period: u32,
    /// Rays per frame over every cascade that updates in that frame (adaptive budgets): one pool,
    /// divided among those cascades in proportion to the rays their probes' errors asked for at
    /// their last update (read back from the GPU, a frame or two late; evenly until it has come
    /// back), so that when the total asked for exceeds the pool every cascade is cut by the same
    /// factor and a cascade whose light changes takes rays from the quiet ones. `None`: each
    /// cascade's `volume.adaptive.frame_budget`. Cost: the trace time of at most this many rays a
    /// frame; fewer rays than asked for converge more slowly.
    pub frame_budget: Option<u32>,
    /// The settings every cascade's volume starts from (rays, hysteresis, weights, adaptive
    /// budgets, relocation, classification); its `bounds`, `probe_counts` and update period are
    /// set per cascade.
    pub volume: DdgiVolume,
}

impl Default for DdgiCascades {
    fn default() -> Self {
        Self {
            count: None,
            probe_counts: UVec3::new(16, 8, 16),
            spacing: 1.0,
            blend_cells: 2.0,
            max_update_period: 8,
            frame_budget: None,
            volume: DdgiVolume { warm_up: true, ..Default::default() },
        }
    }
}

impl DdgiCascades {
    /// Checks the settings; the first problem is returned with its field and value.
    pub fn validate(&self) -> Result<(), crate::DdgiSettingsError> {
        let invalid = |field, value: String, reason| crate::DdgiSettingsError::InvalidCascades { field, value, reason };
        if let Some(n) = self.count
            && !(1..=MAX_CASCADES).contains(&n)
        {
            return Err(invalid("count", n.to_string(), "must be between 1 and 8"));
        }
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            return Err(invalid("spacing", format!("{:?}", self.spacing), "must be finite and positive"));
        }
        if !(self.blend_cells.is_finite() && self.blend_cells > 0.0) {
            return Err(invalid("blend_cells", format!("{:?}", self.blend_cells), "must be finite and positive"));
        }
        let c = self.probe_counts;
        if c.min_element() < 2 || u64::from(c.x) * u64::from(c.y) * u64::from(c.z) > u64::from(MAX_PROBES) {
            return Err(invalid("probe_counts", format!("{c:?}"), "needs at least 2 probes per axis"));
        }
        if f64::from(self.blend_cells) * 2.0 >= f64::from(c.min_element() - 1) {
            return Err(invalid("blend_cells", format!("{:?}", self.blend_cells), "must be under half the probes of the shortest axis"));
        }
        if self.max_update_period == 0 {
            return Err(invalid("max_update_period", "0".into(), "must be at least 1"));
        }
        self.volume.validate()
    }

    /// `count` cascades of `probe_counts` probes whose coarsest one is as wide as `extent` (the
    /// scene's largest horizontal extent, say) on its narrower horizontal axis, with `volume`'s
    /// settings: the finest spacing is `extent / (probes · 2^(count − 1))`.
    pub fn fitted(count: u32, probe_counts: UVec3, extent: f32, volume: DdgiVolume) -> Self {
        let count = count.clamp(1, MAX_CASCADES);
        let across = probe_counts.x.min(probe_counts.z).max(1) as f32;
        let spacing = (extent.max(1e-6) / (across * (1u32 << (count - 1)) as f32)).max(1e-6);
        Self { count: Some(count), probe_counts, spacing, volume: DdgiVolume { warm_up: true, ..volume }, ..Default::default() }
    }

    /// Probe spacing of cascade `level`.
    pub fn level_spacing(&self, level: u32) -> f64 {
        f64::from(self.spacing) * f64::from(1u32 << level.min(31))
    }

    /// Update period of cascade `level`.
    pub fn update_period(&self, level: u32) -> u32 {
        if level < 2 { 1 } else { (1u32 << (level - 1).min(20)).min(self.max_update_period.max(1)) }
    }

    /// The number of cascades for a scene whose largest extent is `extent` ([`DdgiCascades::count`]).
    pub fn resolved_count(&self, extent: Option<f32>) -> u32 {
        if let Some(n) = self.count {
            return n.clamp(1, MAX_CASCADES);
        }
        let reach = f64::from(self.probe_counts.min_element()) * f64::from(self.spacing) * 0.5;
        let extent = f64::from(extent.unwrap_or(0.0).max(0.0));
        (1..=MAX_CASCADES).find(|&n| reach * f64::from(1u32 << (n - 1)) >= extent).unwrap_or(MAX_CASCADES)
    }

    /// The world-space box of cascade `level` for a camera at `camera` (world coordinates), given
    /// its current box's lowest corner (`None`: not placed yet) and the scene's world-space bounds
    /// (`None`: unknown): the grid snapped to whole cells around the camera, moved only when the
    /// camera is more than three quarters of a cell from its centre (so that a camera on a cell
    /// boundary does not scroll back and forth), then kept over the scene — along an axis where
    /// the box is wider than the scene it is centred on the scene, elsewhere it does not reach past
    /// the scene's side by more than the cells it needs to light that side at full weight (none
    /// for the `outermost` cascade, which lights points at full weight up to its box). So no
    /// probe is spent in empty space the camera looks over (half of a camera-centred box is under
    /// the ground or in the sky), and a cascade as wide as the scene covers all of it wherever the
    /// camera stands. The camera stays inside the box when it is inside the scene.
    pub fn level_bounds(
        &self,
        level: u32,
        outermost: bool,
        camera: DVec3,
        current: Option<DVec3>,
        scene: Option<(DVec3, DVec3)>,
    ) -> (DVec3, DVec3) {
        let cell = self.level_spacing(level);
        let half = self.probe_counts.as_dvec3() * 0.5 * cell;
        let size = half * 2.0;
        let mut lo = match current {
            Some(lo) if ((camera - (lo + half)).abs().cmple(DVec3::splat(0.75 * cell))).all() => lo,
            _ => ((camera - half) / cell).round() * cell,
        };
        if let Some((scene_lo, scene_hi)) = scene.filter(|(a, b)| a.is_finite() && b.is_finite() && a.cmple(*b).all()) {
            // Past the scene's side: half a cell to the outer probe, then the blend band.
            let margin = if outermost { 0.0 } else { (0.5 + f64::from(self.blend_cells)).ceil() * cell };
            for axis in 0..3 {
                let (a, b) = (scene_lo[axis] - margin, scene_hi[axis] + margin);
                lo[axis] = if size[axis] >= b - a {
                    ((0.5 * (a + b) - half[axis]) / cell).round() * cell
                } else {
                    // Whole cells, so that the box still scrolls; inside [a, b] after rounding.
                    lo[axis].clamp((a / cell).floor() * cell, ((b - size[axis]) / cell).ceil() * cell)
                };
            }
        }
        (lo, lo + size)
    }
}

/// Cascades for the first camera that has no [`DdgiCascades`] of its own.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct DdgiFirstCameraCascades(pub DdgiCascades);

/// Prepare stage, before the volumes are prepared: spawns each camera's cascades (again when their
/// settings change), places every cascade's box around its camera, and sets its update period and
/// share of the frame budget.
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn follow_ddgi_cascades(
    mut commands: Commands,
    shared: Option<Res<DdgiFirstCameraCascades>>,
    with_cascades: Query<(Entity, &DdgiCascades, &GlobalTransform), With<Camera>>,
    cameras: Query<(Entity, &GlobalTransform), With<Camera>>,
    mut volumes: Query<(Entity, &DdgiCascade, &mut DdgiVolume)>,
    origin: Option<Res<RenderOrigin>>,
    time: Option<Res<engine::app::Time>>,
    scene: Res<GpuScene>,
    meshes: Res<Assets<Mesh>>,
    mut state: ResMut<DdgiGpuVolumes>,
    mut errors: Local<Vec<String>>,
) {
    let origin = origin.map_or(DVec3::ZERO, |o| o.origin);
    let frame = time.map_or(0, |t| t.frame);
    let mut followed: Vec<(Entity, DdgiCascades, DVec3)> =
        with_cascades.iter().map(|(e, c, t)| (e, c.clone(), origin + t.translation().as_dvec3())).collect();
    if let Some(shared) = shared
        && let Some((e, t)) = cameras.iter().find(|(e, _)| !followed.iter().any(|(f, _, _)| f == e))
    {
        followed.push((e, shared.0.clone(), origin + t.translation().as_dvec3()));
    }
    // The scene's world-space box: prepare keeps it up to date (computed here on the first frame,
    // before prepare has).
    let scene_box = if followed.is_empty() { None } else { state.scene_box_or_compute(&scene, &meshes, origin) };
    let extent = scene_box.map(|(lo, hi)| (hi - lo).max_element() as f32);
    for (camera, cascades, position) in followed {
        if let Err(e) = cascades.validate() {
            let message = format!("DDGI cascades of camera {camera}: {e}; they are off");
            if !errors.contains(&message) {
                log::error!("{message}");
                errors.push(message);
            }
            for (entity, c, _) in &volumes {
                if c.camera == camera {
                    commands.entity(entity).try_despawn();
                }
            }
            continue;
        }
        let count = cascades.resolved_count(extent);
        let mine: Vec<Entity> = volumes.iter().filter(|(_, c, _)| c.camera == camera).map(|(e, _, _)| e).collect();
        let template = |level: u32| DdgiVolume {
            probe_counts: Some(cascades.probe_counts),
            update_period: cascades.update_period(level),
            update_phase: level,
            bounds: None,
            ..cascades.volume.clone()
        };
        // The cascades are respawned when their number or blend band changes; every other setting
        // is copied into them each frame (prepare rebuilds a volume whose grid changed, and scrolls
        // one whose box moved by whole cells).
        let stale = mine.len() != count as usize
            || volumes
                .iter()
                .filter(|(_, c, _)| c.camera == camera)
                .any(|(_, c, _)| c.level >= count || c.blend_cells != cascades.blend_cells);
        if stale {
            for &e in &mine {
                commands.entity(e).try_despawn();
            }
            for level in 0..count {
                let (lo, hi) = cascades.level_bounds(level, level + 1 == count, position, None, scene_box);
                let volume = DdgiVolume { bounds: Some((lo, hi)), ..template(level) };
                let cascade = DdgiCascade { camera, level, blend_cells: cascades.blend_cells, outermost: level + 1 == count };
                commands.spawn((volume, cascade, Name(format!("ddgi_cascade_{level}"))));
            }
            continue;
        }
        // The cascades that update this frame share the frame budget in proportion to the rays
        // each asked for at its last update.
        let updates = |k: u32| (frame + u64::from(k)).is_multiple_of(u64::from(cascades.update_period(k)));
        let demands: Vec<(u32, Option<f64>)> = volumes
            .iter()
            .filter(|(_, c, _)| c.camera == camera && updates(c.level))
            .map(|(e, c, _)| (c.level, state.volumes.iter().find(|(v, _)| *v == e).and_then(|(_, g)| g.demanded_rays)))
            .collect();
        for (_, c, mut volume) in volumes.iter_mut().filter(|(_, c, _)| c.camera == camera) {
            let current = volume.bounds.map(|(lo, _)| lo);
            let (lo, hi) = cascades.level_bounds(c.level, c.outermost, position, current, scene_box);
            let t = template(c.level);
            let budget = match cascades.frame_budget {
                Some(total) if updates(c.level) => Some(budget_share(total, c.level, &demands)),
                _ => cascades.volume.adaptive.frame_budget,
            };
            let next =
                DdgiVolume { bounds: Some((lo, hi)), adaptive: crate::DdgiAdaptive { frame_budget: budget, ..t.adaptive.clone() }, ..t };
            if *volume != next {
                *volume = next;
            }
        }
    }
}

/// Cascade `level`'s share of a frame budget of `total` rays, given what every cascade that updates
/// this frame asked for at its last update (`(level, rays)`; `None` where nothing has come back
/// yet): in proportion to those rays, so that one factor scales all of them when together they ask
/// for more than `total`; evenly while any of them has no figure yet. Never below a quarter of the
/// even share, so that a cascade that rested at its last update but has just scrolled (its demand
/// is a frame or two old) is not starved; the shares may then add up to a little over `total`.
pub fn budget_share(total: u32, level: u32, demands: &[(u32, Option<f64>)]) -> u32 {
    let n = demands.len().max(1) as f64;
    let even = f64::from(total) / n;
    let known: Option<Vec<(u32, f64)>> = demands.iter().map(|&(k, d)| d.filter(|d| d.is_finite() && *d >= 0.0).map(|d| (k, d))).collect();
    let share = match known {
        Some(known) => {
            let sum: f64 = known.iter().map(|(_, d)| d).sum();
            let mine = known.iter().find(|(k, _)| *k == level).map_or(0.0, |(_, d)| *d);
            // Nobody asked for anything (all resting): the pool stays evenly split.
            if sum > 0.0 { (f64::from(total) * mine / sum).max(0.25 * even) } else { even }
        }
        None => even,
    };
    share.round().clamp(1.0, f64::from(total.max(1))) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cascade_box_stays_over_the_scene_and_around_the_camera() {
        // A 40 × 18 × 20 m interior, the camera near one end at eye height (the cathedral's case).
        let cascades = DdgiCascades::fitted(2, UVec3::new(16, 8, 16), 40.0, DdgiVolume::default());
        let scene = (DVec3::new(-10.0, 0.0, -20.0), DVec3::new(10.0, 18.0, 20.0));
        let camera = DVec3::new(0.0, 1.7, 18.0);
        // The coarsest (2.5 m cells, 40 × 20 × 40 m) covers the whole scene wherever the camera is.
        let (lo, hi) = cascades.level_bounds(1, true, camera, None, Some(scene));
        assert!(lo.cmple(scene.0).all() && hi.cmpge(scene.1).all(), "{lo} {hi}");
        // Camera-centred it would have left the far end and the vault out.
        let (lo_free, hi_free) = cascades.level_bounds(1, true, camera, None, None);
        assert!(lo_free.z > scene.0.z && hi_free.y < scene.1.y);
        // The finer one (1.25 m cells, 20 × 10 × 20 m) keeps the camera, stays on whole cells, and
        // reaches past the floor by the cells that light it at full weight, not by half its height.
        let cell = cascades.level_spacing(0);
        let (lo, hi) = cascades.level_bounds(0, false, camera, None, Some(scene));
        assert!(lo.cmple(camera).all() && hi.cmpge(camera).all(), "{lo} {hi}");
        assert!(((lo / cell).round() * cell - lo).abs().max_element() < 1e-9);
        let margin = (0.5 + f64::from(cascades.blend_cells)).ceil() * cell;
        assert!(lo.y >= scene.0.y - margin - 1e-9 && lo.y <= scene.0.y - (0.5 + f64::from(cascades.blend_cells)) * cell, "{lo}");
        assert!(hi.z <= scene.1.z + margin + 1e-9);
        // No scene (or a broken one): centred on the camera as before.
        let nan = Some((DVec3::NAN, DVec3::ONE));
        assert_eq!(cascades.level_bounds(0, false, camera, None, nan), cascades.level_bounds(0, false, camera, None, None));
    }

    #[test]
    fn the_frame_budget_follows_what_each_cascade_asked_for() {
        // Nothing read back yet: even.
        assert_eq!(budget_share(900, 0, &[(0, None), (1, Some(10.0)), (2, None)]), 300);
        // Together they ask for 2× the pool: each is cut to half of what it asked for.
        let demands = [(0, Some(1200.0)), (1, Some(600.0))];
        assert_eq!(budget_share(900, 0, &demands), 600);
        assert_eq!(budget_share(900, 1, &demands), 300);
        // A resting cascade keeps a quarter of the even share; all resting: even.
        assert_eq!(budget_share(1000, 1, &[(0, Some(5000.0)), (1, Some(0.0))]), 125);
        assert_eq!(budget_share(1000, 1, &[(0, Some(0.0)), (1, Some(0.0))]), 500);
        // Nonsense read back (NaN) counts as unknown; the share is never 0 nor over the pool.
        assert_eq!(budget_share(10, 0, &[(0, Some(f64::NAN)), (1, Some(1.0))]), 5);
        assert_eq!(budget_share(1, 3, &[(0, Some(1e9)), (3, Some(0.0))]), 1);
        assert_eq!(budget_share(100, 0, &[(0, Some(1.0))]), 100);
    }
}

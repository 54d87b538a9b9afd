//! Prepare stage ([`prepare_ddgi_volumes`]), in its steps: the scene's warnings, the volumes that
//! went away, what changed in the scene, each volume built (or rebuilt, or scrolled when its bounds
//! moved by whole cells) with its probe entities, and each volume's frame: its schedule, its
//! wake-up boxes and its uniform.

use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::render::gpu_scene::GpuScene;
use engine::rng::SplitMix64;
use engine::scene::RenderOrigin;
use engine::scene::{Assets, Image, Material, Mesh};
use glam::{DVec3, IVec3, Mat3, Quat, Vec3};

use super::{DdgiGpuVolumes, VolumeGpu, divergence_warnings};
use crate::cascade_volume::DdgiCascade;
use crate::gpu::DdgiVolumeGpu;
use crate::volume::{DdgiLayout, DdgiLimits, DdgiProbe, DdgiProbeState, DdgiVolume};

/// Whether `new` bounds are `old` moved by whole cells of a grid of `counts` (the same size, every
/// corner within a thousandth of a cell of a whole step): the cells moved, or `None`.
pub fn scroll_cells(old: (DVec3, DVec3), new: (DVec3, DVec3), counts: glam::UVec3) -> Option<IVec3> {
    let size = old.1 - old.0;
    let new_size = new.1 - new.0;
    let cell = size / counts.max(glam::UVec3::ONE).as_dvec3();
    if cell.min_element() <= 0.0 || ((new_size - size).abs().cmpgt(cell * 1e-3)).any() {
        return None;
    }
    let steps = (new.0 - old.0) / cell;
    let whole = steps.round();
    ((steps - whole).abs().max_element() < 1e-3 && whole.abs().max_element() < 1e9).then(|| whole.as_ivec3())
}

fn random_rotation(rng: &mut SplitMix64) -> Mat3 {
    // Shoemake's uniform random unit quaternion.
    let (u1, u2, u3) = (rng.unit(), rng.unit() * std::f32::consts::TAU, rng.unit() * std::f32::consts::TAU);
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    Mat3::from_quat(Quat::from_xyzw(a * u2.sin(), a * u2.cos(), b * u3.sin(), b * u3.cos()).normalize())
}

/// Whether two settings update the probes alike, but for their bounds (a move of the bounds
/// rebuilds or scrolls the volume) and their frame budget (cascades share one, re-divided each frame).
fn same_behaviour(a: &DdgiVolume, b: &DdgiVolume) -> bool {
    let plain = |v: &DdgiVolume| DdgiVolume {
        bounds: None,
        adaptive: crate::DdgiAdaptive { frame_budget: None, ..v.adaptive.clone() },
        ..v.clone()
    };
    plain(a) == plain(b)
}

/// Whether two settings need the same resources (probe layout, ray count, map sizes).
fn same_resources(a: &DdgiVolume, b: &DdgiVolume) -> bool {
    a.bounds == b.bounds && same_grid(a, b)
}

/// The same grid but for its place: same counts, rays, map sizes and seed, and the same trace
/// (the persistent one has its hit buffer).
fn same_grid(a: &DdgiVolume, b: &DdgiVolume) -> bool {
    a.persistent_trace == b.persistent_trace
        && a.probe_counts == b.probe_counts
        && a.rays_per_probe == b.rays_per_probe
        && a.irradiance_texels == b.irradiance_texels
        && a.distance_texels == b.distance_texels
        && a.seed == b.seed
}

/// What this frame brings to every volume: when and where it is, and what changed in the scene.
struct PrepareFrame {
    frame: u64,
    /// The render origin (world position).
    origin: DVec3,
    limits: DdgiLimits,
    /// Instances came or went.
    structure_changed: bool,
    /// The light of the whole scene changed: a light, the sky, a mesh, material or image.
    lighting_changed: bool,
    /// The boxes of the instances that moved, where they were and where they are now (render space).
    movers: Vec<(Vec3, Vec3)>,
}

/// Prepare stage: creates (or re-creates, when the layout changes) each volume's resources and its
/// probe entities, and writes this frame's uniform (a new random rotation of the rays, re-check
/// flag).
#[allow(clippy::too_many_arguments)]
pub fn prepare_ddgi_volumes(
    mut commands: Commands,
    gpu: Res<GpuContext>,
    scene: Res<GpuScene>,
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<Material>>,
    images: Res<Assets<Image>>,
    volumes: Query<(Entity, &DdgiVolume, Option<&DdgiCascade>)>,
    mut state: ResMut<DdgiGpuVolumes>,
    render_origin: Option<Res<RenderOrigin>>,
    time: Option<Res<engine::app::Time>>,
    sky: Option<Res<engine::render::Sky>>,
) {
    let state = &mut *state;
    let origin = render_origin.map_or(DVec3::ZERO, |o| o.origin);
    if !volumes.is_empty() {
        warn_of_divergence(state, &materials, &images);
    }
    drop_removed_volumes(&mut commands, state, |e| volumes.get(e).is_ok());
    let mut list: Vec<(Entity, &DdgiVolume, Option<&DdgiCascade>)> = volumes.iter().collect();
    list.sort_by_key(|(e, _, _)| *e);
    let generations = [meshes.generation(), materials.generation(), images.generation()];
    let (structure_changed, lighting_changed, movers) = scene_changes(state, &scene, &meshes, generations, sky.map(|s| *s), origin);
    let frame = time.map_or(0, |t| t.frame);
    let now = PrepareFrame { frame, origin, limits: DdgiLimits::of(&gpu.device), structure_changed, lighting_changed, movers };
    for (entity, volume, cascade) in list {
        let existing = state.volumes.iter().position(|(e, _)| *e == entity);
        // Bounds moved by whole cells of the same grid scroll it instead of building it anew.
        let scroll = existing.and_then(|i| {
            let (old, counts) = (&state.volumes[i].1.settings, state.volumes[i].1.layout.counts);
            match (old.bounds, volume.bounds) {
                (Some(a), Some(b)) if a != b && same_grid(old, volume) => scroll_cells(a, b, counts),
                _ => None,
            }
        });
        let rebuild = scroll.is_none() && existing.is_none_or(|i| !same_resources(&state.volumes[i].1.settings, volume));
        let settings_changed = existing.is_some_and(|i| !same_behaviour(&state.volumes[i].1.settings, volume));
        if rebuild && !rebuild_volume(&mut commands, &gpu, &scene, &meshes, state, (entity, volume), existing, &now) {
            continue;
        }
        let Some((_, v)) = state.volumes.iter_mut().find(|(e, _)| *e == entity) else { continue };
        prepare_volume_frame(&gpu, v, (entity, volume, cascade), scroll, rebuild || settings_changed, &now);
    }
    state.volumes.sort_by_key(|(_, v)| v.order);
}

/// Warns (once per material) of the materials that make a closed scene diverge, when the
/// materials have changed since the last check.
fn warn_of_divergence(state: &mut DdgiGpuVolumes, materials: &Assets<Material>, images: &Assets<Image>) {
    if state.warned_generation == Some(materials.generation()) {
        return;
    }
    state.warned_generation = Some(materials.generation());
    let warnings = divergence_warnings(materials, images);
    for w in warnings.iter().filter(|w| !state.warnings.contains(w)) {
        log::warn!("DDGI: {w}");
    }
    state.warnings = warnings;
}

/// Drops the volumes whose entity no longer holds a volume (`exists` false), and their probe entities.
fn drop_removed_volumes(commands: &mut Commands, state: &mut DdgiGpuVolumes, exists: impl Fn(Entity) -> bool) {
    state.volumes.retain(|(e, v)| {
        let keep = exists(*e);
        if !keep {
            for &probe in &v.probe_entities {
                commands.entity(probe).try_despawn();
            }
        }
        keep
    });
}

/// What changed in the scene since the last frame — whether instances came or went, whether the
/// light changed, the boxes of the instances that moved — keeping the scene's box up to date.
fn scene_changes(
    state: &mut DdgiGpuVolumes,
    scene: &GpuScene,
    meshes: &Assets<Mesh>,
    generations: [u64; 3],
    sky: Option<engine::render::Sky>,
    origin: DVec3,
) -> (bool, bool, Vec<(Vec3, Vec3)>) {
    let scene_changed = {
        let c = scene.instance_changes();
        c.structure_changed || !c.moved.is_empty()
    };
    let structure_changed = scene.instance_changes().structure_changed;
    let movers = state.mover_boxes(scene, meshes);
    // The light of the whole scene changed: every volume's calm update period drops to 1.
    let lighting = (scene.light_data.clone(), sky, generations);
    let lighting_changed = state.last_lighting.as_ref() != Some(&lighting);
    state.last_lighting = Some(lighting);
    if scene_changed || !state.scene_extent_known {
        state.scene_box = state.scene_world_bounds(scene, meshes, origin);
        state.scene_extent_known = true;
    }
    (structure_changed, lighting_changed, movers)
}

/// Builds `entity`'s volume anew (its old resources and probe entities dropped): its layout, its
/// resources and a probe entity per probe. Returns false, with the error logged once, when its
/// settings do not lay out (the volume is off).
#[allow(clippy::too_many_arguments)]
fn rebuild_volume(
    commands: &mut Commands,
    gpu: &GpuContext,
    scene: &GpuScene,
    meshes: &Assets<Mesh>,
    state: &mut DdgiGpuVolumes,
    (entity, volume): (Entity, &DdgiVolume),
    existing: Option<usize>,
    now: &PrepareFrame,
) -> bool {
    let origin = now.origin;
    // `DdgiVolume::bounds` are in the world; the scene's (from the instances) in render space.
    let bounds = match volume.bounds {
        Some((lo, hi)) => Some(((lo - origin).as_vec3(), (hi - origin).as_vec3())),
        None => state.scene_bounds(scene, meshes),
    };
    let layout = bounds.ok_or(crate::volume::DdgiSettingsError::NoBounds).and_then(|b| DdgiLayout::new(volume, b, now.limits));
    let old = existing.map(|i| state.volumes.remove(i));
    if let Some((_, old)) = &old {
        for &probe in &old.probe_entities {
            commands.entity(probe).try_despawn();
        }
    }
    let layout = match layout {
        Ok(l) => {
            state.errors.remove(&entity);
            l
        }
        Err(e) => {
            let message = e.to_string();
            if state.errors.get(&entity) != Some(&message) {
                log::error!("DDGI volume {entity}: {message}; the volume is off");
            }
            state.errors.insert(entity, message);
            return false;
        }
    };
    let mut v = VolumeGpu::new(gpu, volume, layout, origin);
    v.probe_entities = (0..v.layout.probe_count)
        .map(|i| {
            commands
                .spawn(DdgiProbe {
                    volume: entity,
                    grid: v.layout.probe_grid(i),
                    index: i,
                    offset: Vec3::ZERO,
                    position: v.layout.grid_position(i),
                    state: DdgiProbeState::Active,
                    ray_count: volume.rays_per_probe,
                    error: 0.0,
                    resting_frames: 0,
                })
                .id()
        })
        .collect();
    state.volumes.push((entity, v));
    true
}

/// One volume's frame: its settings and gather place, the render origin followed, the scroll
/// (`scroll`, cells), the probes that wake around movers, whether it updates and re-checks, and
/// its uniform. `rebuilt_or_changed`: the volume was built anew or its settings changed.
fn prepare_volume_frame(
    gpu: &GpuContext,
    v: &mut VolumeGpu,
    (entity, volume, cascade): (Entity, &DdgiVolume, Option<&DdgiCascade>),
    scroll: Option<IVec3>,
    rebuilt_or_changed: bool,
    now: &PrepareFrame,
) {
    let (frame, limits) = (now.frame, now.limits);
    v.settings = volume.clone();
    v.order = (cascade.map_or(0, |c| c.level + 1), entity);
    v.cascade_blend = cascade.map_or(0.0, |c| c.blend_cells.max(1e-3));
    v.cascade_outermost = cascade.is_some_and(|c| c.outermost);
    let origin_moved = now.origin != v.render_origin;
    v.follow_render_origin(now.origin, limits);
    let scrolled = scroll.is_some_and(|cells| v.scroll(gpu, cells, limits) > 0 || cells != IVec3::ZERO);
    let interval = u64::from(volume.recheck_interval);
    let wake = wake_boxes(&v.layout, &now.movers);
    let wake_all = wake.len() / 2 > crate::gpu::MAX_WAKE_BOXES as usize;
    let wake_boxes = if wake_all { 0 } else { (wake.len() / 2) as u32 };
    if wake_boxes > 0 {
        gpu.queue.write_buffer(&v.buffers.wake, 0, bytemuck::cast_slice(&wake));
    }
    // Light that changed everywhere (a light, the sky, a material or mesh, instances added or
    // removed, the volume's settings) wakes every resting probe this frame: a volume whose
    // probes all rest would otherwise see the change only as each one's rest ends.
    let changed_everywhere = rebuilt_or_changed || now.lighting_changed || now.structure_changed;
    // The calm update period: anything seen to change here updates this frame and drops it to 1.
    let changed = changed_everywhere || scrolled || origin_moved || !wake.is_empty();
    if changed || !crate::calm::DdgiCalm::applies(&volume.adaptive) {
        v.calm.reset(frame);
    }
    let period = u64::from(volume.update_period.max(1));
    v.calm.scheduled = (frame + u64::from(volume.update_phase)).is_multiple_of(period);
    v.updates_this_frame = scrolled || v.frames < 2 || (v.calm.scheduled && v.calm.due());
    v.recheck_pending |= now.structure_changed || wake_all || (interval > 0 && v.frames.is_multiple_of(interval));
    let recheck = v.recheck_pending;
    let rotation = random_rotation(&mut v.rng);
    let mut uniform =
        DdgiVolumeGpu::new(volume, &v.layout, rotation, volume.sky_radiance, recheck, (v.cascade_blend, v.cascade_outermost), wake_boxes);
    uniform.wake_resting = u32::from(changed_everywhere);
    gpu.queue.write_buffer(&v.buffers.uniform, 0, bytemuck::bytes_of(&uniform));
}

/// The boxes (two corners each) in which probes wake this frame: probes within a spacing of an
/// instance that moved (where it was or is now). Only when instances came or went, or too many
/// moved, does every switched-off probe re-check.
fn wake_boxes(layout: &DdgiLayout, movers: &[(Vec3, Vec3)]) -> Vec<[f32; 4]> {
    let grow = Vec3::splat(layout.spacing.max_element());
    let (lo, hi) = (layout.bounds.0 - grow, layout.bounds.1 + grow);
    movers
        .iter()
        .filter(|(a, b)| a.cmple(hi).all() && b.cmpge(lo).all())
        .flat_map(|(a, b)| [(*a - grow).extend(0.0).to_array(), (*b + grow).extend(0.0).to_array()])
        .collect()
}

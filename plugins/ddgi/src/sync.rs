//! The probes as entities: their GPU state mirrored into [`DdgiProbe`] components through the
//! engine's asynchronous readback, and pins written back.

use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use glam::Vec3;

use crate::gpu::{DdgiCounters, DdgiProbeData, NO_PIN, PIN_ACTIVE, PIN_INACTIVE};
use crate::resources::DdgiGpuVolumes;
use crate::volume::{DdgiProbe, DdgiProbePin, DdgiProbeState};

/// The suffix of volume `index`'s pass labels, graph resources and counters when there are
/// `volumes` volumes: `_k` when there are several, none for one (`ddgi_gather_2`, `ddgi_rays`).
pub fn volume_suffix(index: usize, volumes: usize) -> String {
    if volumes > 1 { format!("_{index}") } else { String::new() }
}

/// The name of volume `index`'s counter of rays traced in a frame ([`read_back_ddgi_probes`]).
pub fn rays_counter(index: usize, volumes: usize) -> String {
    format!("ddgi_rays{}", volume_suffix(index, volumes))
}

/// The rays DDGI traced in the frame `timing` records, every volume together (the `ddgi_rays`
/// counters); `None` when none has come back for it.
pub fn rays_traced(timing: &engine::render::FrameTiming) -> Option<f64> {
    let rays: Vec<f64> = timing
        .counters
        .iter()
        .filter(|(name, _)| name.strip_prefix("ddgi_rays").is_some_and(|rest| rest.is_empty() || rest.starts_with('_')))
        .map(|(_, v)| *v)
        .collect();
    (!rays.is_empty()).then(|| rays.iter().sum())
}

/// Prepare stage: copies the probe states that have come back from the GPU into the
/// [`DdgiProbe`] components (only those that changed, so change detection stays meaningful), and
/// the rays traced and the probes updated per frame into the frame timings (`ddgi_rays`,
/// `ddgi_probes_updated`: 0 on a frame that left the volume's update out; `ddgi_update_period`:
/// the frames between the volume's updates at that frame), and judges whether the volume is calm
/// ([`crate::DdgiAdaptive::max_update_period`]).
pub fn read_back_ddgi_probes(
    gpu: Res<GpuContext>,
    mut volumes: ResMut<DdgiGpuVolumes>,
    mut probes: Query<&mut DdgiProbe>,
    mut timings: ResMut<engine::render::FrameTimings>,
) {
    let count = volumes.volumes.len();
    for (k, (_, v)) in volumes.volumes.iter_mut().enumerate() {
        for (frame, bytes) in v.counter_readback.poll(&gpu) {
            if let Ok(c) = bytemuck::try_pod_read_unaligned::<DdgiCounters>(&bytes[..size_of::<DdgiCounters>().min(bytes.len())]) {
                timings.record_counter(frame, &rays_counter(k, count), f64::from(c.total_rays));
                timings.record_counter(frame, &format!("ddgi_probes_updated{}", volume_suffix(k, count)), f64::from(c.updated_probes));
                // Without a frame budget the scale is never written (and 1 when nothing was cut).
                let scale = if c.budget_scale.is_finite() && c.budget_scale > 0.0 && c.budget_scale < 1.0 { c.budget_scale } else { 1.0 };
                v.demanded_rays = Some(f64::from(c.total_rays) / f64::from(scale));
            }
        }
        // Frames whose update the period left out traced nothing: 0 rays, 0 probes updated (so
        // that a mean over frames counts them); every frame: the frames between updates.
        for (frame, updated, between) in std::mem::take(&mut v.calm.unreported) {
            if !updated {
                timings.record_counter(frame, &rays_counter(k, count), 0.0);
                timings.record_counter(frame, &format!("ddgi_probes_updated{}", volume_suffix(k, count)), 0.0);
            }
            timings.record_counter(frame, &format!("ddgi_update_period{}", volume_suffix(k, count)), f64::from(between));
        }
        let Some((frame, bytes)) = v.readback.poll(&gpu).pop() else { continue };
        let data: Vec<DdgiProbeData> = bytemuck::pod_collect_to_vec(&bytes);
        if data.len() < v.layout.probe_count as usize {
            continue;
        }
        v.probe_data = data;
        let adaptive = v.settings.adaptive.clone();
        v.calm.observe(frame, &v.probe_data[..v.layout.probe_count as usize], &adaptive);
        for (i, &entity) in v.probe_entities.iter().enumerate() {
            let Ok(mut probe) = probes.get_mut(entity) else { continue };
            let d = v.probe_data[i];
            let offset = Vec3::from_array(d.offset);
            let next = DdgiProbe {
                grid: v.layout.probe_grid(i as u32),
                offset,
                position: v.layout.grid_position(i as u32) + offset,
                state: v.probe_state(i),
                ray_count: d.ray_count,
                error: d.error,
                resting_frames: d.rest >> 16,
                ..probe.clone()
            };
            probe.set_if_neq(next);
        }
    }
}

/// Prepare stage: writes the pins of probes whose [`DdgiProbePin`] was added, changed or removed
/// into the GPU's probe data.
pub fn upload_ddgi_probe_pins(
    gpu: Res<GpuContext>,
    mut volumes: ResMut<DdgiGpuVolumes>,
    pins: Query<(&DdgiProbe, &DdgiProbePin), Changed<DdgiProbePin>>,
    mut unpinned: RemovedComponents<DdgiProbePin>,
    probes: Query<&DdgiProbe>,
) {
    let write = |probe: &DdgiProbe, pin: Option<&DdgiProbePin>| {
        let Some(v) = volumes.get(probe.volume) else { return };
        if probe.index >= v.layout.probe_count {
            return;
        }
        let rays = pin.and_then(|p| p.rays).unwrap_or(NO_PIN);
        let state = match pin.and_then(|p| p.state) {
            Some(DdgiProbeState::Active) => PIN_ACTIVE,
            Some(DdgiProbeState::Inactive) => PIN_INACTIVE,
            None => 0,
        };
        let offset = u64::from(probe.index) * size_of::<DdgiProbeData>() as u64 + std::mem::offset_of!(DdgiProbeData, pinned_rays) as u64;
        gpu.queue.write_buffer(&v.probes, offset, bytemuck::cast_slice(&[rays, state]));
    };
    let mut pinned = Vec::new();
    for (probe, pin) in &pins {
        write(probe, Some(pin));
        pinned.push(probe.volume);
    }
    for entity in unpinned.read() {
        if let Ok(probe) = probes.get(entity) {
            write(probe, None);
            pinned.push(probe.volume);
        }
    }
    // A pin changes what its probe does: its volume updates every frame until calm again.
    for (entity, v) in volumes.volumes.iter_mut() {
        if pinned.contains(entity) {
            v.calm.reset_next();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rays_are_counted_per_volume_and_summed_over_them() {
        assert_eq!(rays_counter(0, 1), "ddgi_rays");
        assert_eq!(rays_counter(2, 3), "ddgi_rays_2");
        let counters = |c: &[(&str, f64)]| engine::render::FrameTiming {
            frame: 7,
            passes: Vec::new(),
            counters: c.iter().map(|(n, v)| (n.to_string(), *v)).collect(),
        };
        assert_eq!(rays_traced(&counters(&[("ddgi_rays", 5.0), ("ddgi_probes_updated", 2.0)])), Some(5.0));
        assert_eq!(rays_traced(&counters(&[("ddgi_rays_0", 5.0), ("ddgi_rays_1", 3.0), ("ddgi_probes_updated_0", 1.0)])), Some(8.0));
        assert_eq!(rays_traced(&counters(&[("ddgi_probes_updated", 2.0), ("ddgi_raysx", 1.0)])), None);
    }
}

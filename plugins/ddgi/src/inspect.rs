//! What a debug UI reads of the volumes and what it may do to their probes: pause the updates, step
//! one update while paused, reset a volume's probes ([`DdgiUpdateControl`]); count the probes per
//! state ([`DdgiProbeStateCounts`]); the GPU memory a volume holds ([`VolumeGpu::memory_bytes`]).
//! Any app may use them: the overlay (`ddgi_overlay`) is one.

use bevy_ecs::prelude::*;

use crate::gpu::{NO_PIN, PROBE_FRESH, PROBE_INACTIVE};
use crate::resources::{DdgiGpuVolumes, VolumeGpu};

/// Pause, step and reset of the probe updates. A paused volume keeps its maps and probe states
/// bit for bit (the trace and the probe update are left out of the frame; the gather still reads
/// them); [`DdgiUpdateControl::step`] lets each paused volume update once more; a reset volume is
/// rebuilt as a new one would be (maps cleared, every probe fresh, its probe entities spawned again,
/// its ray rotations from the seed again).
#[derive(Resource, Clone, Debug, Default, PartialEq, Eq)]
pub struct DdgiUpdateControl {
    /// Whether the probe updates of every volume are paused.
    pub paused: bool,
    /// Updates still to run while paused (one per frame), asked for by [`DdgiUpdateControl::step`].
    pub steps: u32,
    /// Volumes to reset at the next frame, by entity.
    pub resets: Vec<Entity>,
}

impl DdgiUpdateControl {
    /// Pauses (`true`) or resumes (`false`) every volume's probe updates.
    pub fn set_paused(&mut self, paused: bool) {
        self.paused = paused;
        if !paused {
            self.steps = 0;
        }
    }

    /// While paused, lets every volume update once more, at the next frame (a volume whose update
    /// period skips that frame updates anyway). Does nothing when not paused.
    pub fn step(&mut self) {
        if self.paused {
            self.steps += 1;
        }
    }

    /// Resets the probes of the volume on `entity` at the next frame, as if it were new.
    pub fn reset(&mut self, entity: Entity) {
        if !self.resets.contains(&entity) {
            self.resets.push(entity);
        }
    }
}

/// Prepare stage, before the volumes are prepared: drops the GPU state of every volume asked to be
/// reset (and despawns its probe entities), so that prepare builds it anew, as it builds a new
/// volume.
pub fn reset_ddgi_volumes(mut commands: Commands, mut control: ResMut<DdgiUpdateControl>, mut volumes: ResMut<DdgiGpuVolumes>) {
    if control.resets.is_empty() {
        return;
    }
    let resets = std::mem::take(&mut control.resets);
    volumes.volumes.retain(|(entity, v)| {
        let reset = resets.contains(entity);
        if reset {
            for &probe in &v.probe_entities {
                commands.entity(probe).try_despawn();
            }
        }
        !reset
    });
}

/// Prepare stage, after the volumes are prepared: while paused, no volume updates this frame
/// unless a step is due, when every volume does.
pub fn pause_ddgi_updates(mut control: ResMut<DdgiUpdateControl>, mut volumes: ResMut<DdgiGpuVolumes>) {
    if !control.paused {
        return;
    }
    let step = control.steps > 0;
    control.steps = control.steps.saturating_sub(1);
    for (_, v) in volumes.volumes.iter_mut() {
        v.updates_this_frame = step;
        // Resumed or stepped, a volume updates at every frame until it is calm again.
        v.calm.reset_next();
    }
}

/// How many probes of a volume are in each state, as of the last probe data read back (a few
/// frames late). A probe counts once in `active` or `inactive`, and may also count as fresh,
/// resting or pinned.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DdgiProbeStateCounts {
    /// Probes that take part in lighting.
    pub active: u32,
    /// Probes switched off (inside geometry, nothing in reach, dark, or pinned off).
    pub inactive: u32,
    /// Probes whose maps hold nothing yet: new, scrolled in, or switched back on.
    pub fresh: u32,
    /// Active probes resting (adaptive budgets: converged, skipping their next updates).
    pub resting: u32,
    /// Probes with a pinned ray count or state ([`crate::DdgiProbePin`]).
    pub pinned: u32,
    /// Rays the probes traced in the frame read back.
    pub rays: u64,
}

impl VolumeGpu {
    /// The probes per state, from the last probe data read back.
    pub fn probe_state_counts(&self) -> DdgiProbeStateCounts {
        let mut c = DdgiProbeStateCounts::default();
        for p in self.probe_data.iter().take(self.layout.probe_count as usize) {
            if p.state & PROBE_INACTIVE != 0 {
                c.inactive += 1;
            } else {
                c.active += 1;
                if p.rest >> 16 > 0 {
                    c.resting += 1;
                }
            }
            c.fresh += u32::from(p.state & PROBE_FRESH != 0);
            c.pinned += u32::from(p.pinned_rays != NO_PIN || p.pinned_state != 0);
            c.rays += u64::from(p.ray_count);
        }
        c
    }

    /// Bytes of GPU memory the volume holds: the sum of the sizes of its buffers (as created,
    /// [`engine::wgpu::Buffer::size`]) and of its two atlases (texels × bytes per texel of their format).
    pub fn memory_bytes(&self) -> u64 {
        self.gpu_resources().iter().map(|(_, bytes)| bytes).sum()
    }

    /// Every GPU buffer and texture of the volume with its size in bytes, by its label.
    pub fn gpu_resources(&self) -> Vec<(&'static str, u64)> {
        let texture = |t: &engine::wgpu::Texture| {
            let bytes = u64::from(t.format().block_copy_size(None).unwrap_or(0));
            u64::from(t.width()) * u64::from(t.height()) * u64::from(t.depth_or_array_layers()) * bytes
        };
        let buffers = self.buffers.entries().into_iter().map(|(name, buffer, _)| (name, buffer.size()));
        buffers.chain([("ddgi_irradiance", texture(&self.irradiance)), ("ddgi_distance", texture(&self.distance))]).collect()
    }
}

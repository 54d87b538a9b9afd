//! A volume's probes as entities ([`DdgiProbe`]), whether each lights ([`DdgiProbeState`]) and the
//! pin that holds one's rays or state ([`DdgiProbePin`]).

use bevy_ecs::prelude::*;
use glam::{UVec3, Vec3};

/// Whether a probe takes part in lighting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DdgiProbeState {
    /// Traces its rays every frame and is sampled.
    #[default]
    Active,
    /// Switched off by classification: traces only on re-check frames, never sampled.
    Inactive,
}

/// One probe of a volume, as an entity. The GPU owns the truth; these components mirror it through
/// an asynchronous readback, a few frames late, and never stall a frame.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct DdgiProbe {
    /// The entity holding the [`DdgiVolume`](crate::DdgiVolume).
    pub volume: Entity,
    /// Grid coordinates.
    pub grid: UVec3,
    /// Index in the volume's probe arrays and atlases: `x + counts.x · (y + counts.y · z)`.
    pub index: u32,
    /// World-space offset from the grid position, from relocation.
    pub offset: Vec3,
    /// World position (grid position + offset).
    pub position: Vec3,
    /// Whether it takes part in lighting (classification's verdict, or its pin).
    pub state: DdgiProbeState,
    /// Rays traced in the frame read back.
    pub ray_count: u32,
    /// Temporal error (smoothed SMAPE in YCoCg between each frame's estimate and the maps).
    pub error: f32,
    /// Frames this probe will rest after the frame read back before it updates again (adaptive
    /// budgets: a converged probe keeps its maps and weight and traces nothing while it rests);
    /// 0: it is due next frame (or switched off, or never rests).
    pub resting_frames: u32,
}

/// Insert beside a [`DdgiProbe`] to pin the probe: a fixed ray count and/or a state, whatever its
/// error and classification say. Remove it to unpin.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq)]
pub struct DdgiProbePin {
    /// Rays every frame, whatever the adaptive budget says (held to the volume's
    /// `rays_per_probe`); `None`: the budget decides.
    pub rays: Option<u32>,
    /// On or off, whatever classification says; `None`: classification decides.
    pub state: Option<DdgiProbeState>,
}

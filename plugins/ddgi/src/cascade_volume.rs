//! The component that makes a volume one of a camera's cascades ([`DdgiCascade`]): the cascades
//! ([`crate::cascades`]) spawn it, prepare ([`crate::resources`]) reads it for the gather order and
//! the blend band, so that neither of the two needs the other.

use bevy_ecs::prelude::*;

/// One volume of a camera's cascades (spawned by [`crate::cascades::follow_ddgi_cascades`]).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct DdgiCascade {
    /// The camera the cascade follows.
    pub camera: Entity,
    /// 0 for the finest.
    pub level: u32,
    /// The blend band, in this cascade's cells.
    pub blend_cells: f32,
    /// The coarsest of its camera's cascades: nothing takes over at its edge, so it lights points
    /// at full weight up to half a cell beyond its outer probes, as a fixed volume does.
    pub outermost: bool,
}

//! Sky light where no volume reaches ([`DdgiSkyLight`]), which the gather and the composite trace.

use bevy_ecs::prelude::*;

/// Sky light beyond the volumes: a surface point that no volume or cascade covers (or covers only
/// in part, across a volume's fading edge) gets, for the share left uncovered, the sky's light
/// through its visibility: π × the mean over `rays` short cosine-distributed rays from the point
/// of the sky's radiance ([`engine::render::Sky`]) along those that reach `max_distance` without a
/// hit (ambient occlusion that keeps the sky's direction: a physical sky lights from above). Such points are never black under a lit sky, and the light fades into
/// the volumes' own with no seam. The rays are traced only at uncovered pixels, and not at all
/// when the sky is black.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct DdgiSkyLight {
    /// Visibility rays per uncovered pixel (0: off, such points get no indirect light). More: less
    /// noise, proportionally more cost at those pixels.
    pub rays: u32,
    /// Reach of the visibility rays, in world units; `None`: a tenth of the scene's largest extent.
    /// Longer: large occluders darken more (a cave, an overhang); shorter: only contact shadows.
    pub max_distance: Option<f32>,
}

impl Default for DdgiSkyLight {
    fn default() -> Self {
        Self { rays: 8, max_distance: None }
    }
}

/// Most visibility rays of [`DdgiSkyLight`] and of [`DdgiContactOcclusion`](crate::DdgiContactOcclusion) per pixel.
pub const MAX_SKY_RAYS: u32 = 64;

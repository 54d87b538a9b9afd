//! The components a scene's entities carry besides their placement: cameras, lights, mesh
//! instances, orbits and names, and [`animate_orbits`], which moves the orbiting ones.

use bevy_ecs::prelude::*;
use glam::Vec3;

use super::{Handle, Material, Mesh, Transform};

/// A perspective camera looking along its local -Z axis.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct Camera {
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// Distance of the near plane; the far plane is at infinity (reverse-Z depth).
    pub znear: f32,
    /// Linear scale applied to radiance before tonemapping; 1 keeps the radiometric values as they are.
    pub exposure: f32,
}

impl Default for Camera {
    fn default() -> Self {
        Self { yfov: 50f32.to_radians(), znear: 0.05, exposure: 1.0 }
    }
}

/// A light infinitely far away. `intensity` is the irradiance (W/m²) on a surface facing it; it shines
/// along the entity's local -Z axis.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct DirectionalLight {
    /// Linear RGB colour; multiplied by `intensity`.
    pub color: Vec3,
    /// Irradiance (W/m²) on a surface facing the light, per unit of `color`.
    pub intensity: f32,
}

/// A point light. `intensity` is radiant intensity (W/sr): irradiance `intensity·cosθ/d²` at distance d.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct PointLight {
    /// Linear RGB colour; multiplied by `intensity`.
    pub color: Vec3,
    /// Radiant intensity (W/sr) per unit of `color`.
    pub intensity: f32,
    /// Distance past which the light is cut off smoothly (glTF's window); `None` is unlimited.
    pub range: Option<f32>,
}

/// A spot light shining along the entity's local -Z axis, with glTF's smooth cone falloff between
/// `inner_cone_angle` and `outer_cone_angle` (radians, from the axis).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Transform)]
pub struct SpotLight {
    /// Linear RGB colour; multiplied by `intensity`.
    pub color: Vec3,
    /// Radiant intensity (W/sr) on the axis, per unit of `color`.
    pub intensity: f32,
    /// Distance (world units) past which the light is cut off smoothly (glTF's window); `None` is
    /// unlimited.
    pub range: Option<f32>,
    /// Angle (radians, from the axis) inside which the cone is at full intensity.
    pub inner_cone_angle: f32,
    /// Angle (radians, from the axis) past which the cone gives no light; at least `inner_cone_angle`.
    pub outer_cone_angle: f32,
}

/// Draws a shared mesh asset with a shared material at the entity's [`GlobalTransform`](super::GlobalTransform).
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
#[require(Transform)]
pub struct MeshInstance {
    /// The mesh drawn, in the world's [`Assets<Mesh>`](super::Assets).
    pub mesh: Handle<Mesh>,
    /// The material it is drawn with, in the world's [`Assets<Material>`](super::Assets).
    pub material: Handle<Material>,
}

/// Moves an entity along a circle over time (used by built-in scenes for moving lights).
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// Centre of the circle (parent space, world units); the circle lies in the horizontal (xz) plane.
    pub center: Vec3,
    /// Radius of the circle (world units).
    pub radius: f32,
    /// Seconds per revolution.
    pub period: f32,
    /// Point the entity's -Z axis at, if any, while it moves.
    pub look_at: Option<Vec3>,
}

/// A name for an entity, from the imported node or given by the scene builder.
#[derive(Component, Clone, Debug, PartialEq, Eq)]
pub struct Name(pub String);

/// Moves entities with an [`Orbit`] along their circle, from the engine's fixed-step [`crate::app::Time`].
pub fn animate_orbits(time: Res<crate::app::Time>, mut query: Query<(&Orbit, &mut Transform)>) {
    for (orbit, mut transform) in &mut query {
        let angle = std::f32::consts::TAU * (time.elapsed_seconds / orbit.period.max(1e-3) as f64) as f32;
        let (s, c) = angle.sin_cos();
        let position = orbit.center + Vec3::new(c * orbit.radius, 0.0, s * orbit.radius);
        let mut t = Transform { translation: position, ..*transform };
        if let Some(target) = orbit.look_at {
            let up = if (target - position).normalize_or_zero().y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
            t = t.looking_at(target, up);
        }
        *transform = t;
    }
}

//! What the demo animates over time, at a given moment: the sun's day–night cycle ([`DayNight`],
//! its [`SunState`]) and the colour-cycling light ([`ColorCycle`]).

use std::f32::consts::TAU;

use bevy_ecs::component::Component;
use engine::scene::Transform;
use engine::sky::{PhysicalSky, Sky};
use glam::Vec3;

/// A day–night cycle on the sun.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct DayNight {
    /// Seconds per day.
    pub period: f32,
    /// Fraction of the day at t = 0 (0 sunrise, 0.25 noon, 0.5 sunset, 0.5..1 night).
    pub phase: f32,
    /// Irradiance (W/m²) of the sun at its highest.
    pub max_intensity: f32,
    /// Angle between the sun's path and the zenith (towards the south, +Z).
    pub tilt: f32,
}

impl Default for DayNight {
    fn default() -> Self {
        Self { period: 240.0, phase: 0.1, max_intensity: 6.0, tilt: 35f32.to_radians() }
    }
}

/// The sun and sky at one moment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SunState {
    pub transform: Transform,
    pub color: Vec3,
    pub intensity: f32,
    /// Preetham's sky for this sun (its brightness that of the sun at its highest, fading through
    /// twilight by itself while the sun's light is already off).
    pub sky: Sky,
    /// Unit vector towards the sun.
    pub to_sun: Vec3,
}

/// Hermite interpolation from 0 at `e0` to 1 at `e1` (the sun's fades, the door's motion).
pub fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl DayNight {
    pub fn state(&self, t: f64) -> SunState {
        let day = ((t / self.period.max(1e-3) as f64) + self.phase as f64).rem_euclid(1.0) as f32;
        let a = TAU * day;
        let (sin_a, cos_a) = a.sin_cos();
        let (sin_t, cos_t) = self.tilt.sin_cos();
        // Rises in the east (+X), culminates towards the south (+Z), sets in the west.
        let to_sun = Vec3::new(cos_a, sin_a * cos_t, sin_a * sin_t).normalize_or(Vec3::Y);
        let elevation = to_sun.y;
        let intensity = self.max_intensity * smoothstep(0.0, 0.2, elevation);
        let noon = Vec3::new(1.0, 0.95, 0.85);
        let dusk = Vec3::new(1.0, 0.42, 0.15);
        let color = dusk.lerp(noon, smoothstep(0.0, 0.45, elevation));
        let sky = Sky::Physical(PhysicalSky {
            sun_direction: Some(to_sun),
            sun_irradiance: Some(self.max_intensity),
            night: Vec3::new(0.004, 0.006, 0.015),
            ..Default::default()
        });
        let transform = Transform::from_translation(to_sun * 30.0).looking_at(Vec3::ZERO, Vec3::Y);
        SunState { transform, color, intensity: if elevation > 0.0 { intensity } else { 0.0 }, sky, to_sun }
    }
}

/// Cycles a point light's hue.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct ColorCycle {
    /// Seconds per turn of the colour wheel.
    pub period: f32,
    pub saturation: f32,
    /// The light's intensity (W/sr).
    pub intensity: f32,
}

impl Default for ColorCycle {
    fn default() -> Self {
        Self { period: 15.0, saturation: 0.8, intensity: 8.0 }
    }
}

impl ColorCycle {
    /// A colour of maximum component 1 with the hue at `t` seconds.
    pub fn color_at(&self, t: f64) -> Vec3 {
        let hue = (t / self.period.max(1e-3) as f64).rem_euclid(1.0) as f32;
        let rgb = Vec3::new(hue, hue + 2.0 / 3.0, hue + 1.0 / 3.0).map(|h| {
            let x = (h.fract() * 6.0 - 3.0).abs() - 1.0;
            x.clamp(0.0, 1.0)
        });
        Vec3::ONE.lerp(rgb, self.saturation.clamp(0.0, 1.0))
    }
}

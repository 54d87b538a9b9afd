//! The sky: what rays that leave the scene see (probe rays, path-tracer paths, the background).
//!
//! [`Sky::Uniform`] is one radiance in every direction (black by default: the closed test rooms and
//! every still evaluation). [`Sky::Physical`] is Preetham, Shirley and Smits' analytic daylight sky
//! ("A Practical Analytic Model for Daylight", SIGGRAPH 1999): the Perez distribution of luminance
//! and chromaticity over the sky for a sun direction and an atmospheric turbidity, with a sun disk
//! in the background. It follows the scene's sun (the first directional light) unless given a
//! direction of its own, so a day–night cycle that turns the sun turns the sky with it.
//!
//! The GPU evaluates the same formula from the coefficients computed here ([`GpuSky`], in the view
//! uniform; `sky_radiance` in `shaders/scene.inc.wgsl`), and [`Sky::radiance`] is its CPU
//! mirror, which the tests compare with the GPU's background.

use bevy_ecs::prelude::*;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Angular radius of the sun's disk (0.2666°, as seen from the earth).
pub const SUN_ANGULAR_RADIUS: f32 = 0.004_653;

/// Illuminance (klux) of the sun that a directional light's irradiance of 1 stands for: the sky's
/// luminance is scaled by the light's irradiance over this (a clear noon sun gives about 100 klux).
pub const SUN_REFERENCE_KLUX: f32 = 100.0;

/// What the scene's escaping rays see (a resource; absent: [`Sky::default`], black).
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub enum Sky {
    /// The same radiance (linear RGB, W/(m²·sr)) in every direction, no sun disk.
    Uniform(Vec3),
    /// Preetham's analytic daylight sky.
    Physical(PhysicalSky),
}

impl Default for Sky {
    fn default() -> Self {
        Sky::Uniform(Vec3::ZERO)
    }
}

/// Preetham's analytic sky. Cost on the GPU: a few exponentials per ray that misses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhysicalSky {
    /// Atmospheric turbidity: 2 is a very clear sky, 3 a clear one, 6 hazy, 10 a light haze of
    /// industrial air (valid 1.7–10; clamped). More: a whiter, brighter sky and a wider glow
    /// around the sun.
    pub turbidity: f32,
    /// Unit vector towards the sun; `None`: against the first directional light's direction.
    pub sun_direction: Option<Vec3>,
    /// The sun's irradiance (W/m², a directional light's `color × intensity` luminance) that
    /// scales the sky; `None`: the first directional light's. The sky's luminance in kcd/m² times
    /// this over [`SUN_REFERENCE_KLUX`] is its radiance, so a sun of irradiance E gives a clear
    /// noon sky of about E/10 W/(m²·sr) at the zenith.
    pub sun_irradiance: Option<f32>,
    /// Multiplies the sky's radiance (1: physical relative to the sun).
    pub intensity: f32,
    /// Draws the sun's disk in the background (camera rays; bounced rays and probe rays never see
    /// it: the directional light already delivers the sun's light to every surface).
    pub sun_disk: bool,
    /// Radiance of the night sky, the floor the sky never falls under (the sun below the horizon).
    pub night: Vec3,
    /// Below the horizon the sky shows the horizon's radiance times this (an unseen ground's
    /// albedo), blended over the last two degrees.
    pub ground_albedo: Vec3,
}

impl Default for PhysicalSky {
    fn default() -> Self {
        Self {
            turbidity: 2.5,
            sun_direction: None,
            sun_irradiance: None,
            intensity: 1.0,
            sun_disk: true,
            night: Vec3::new(0.0008, 0.0012, 0.003),
            ground_albedo: Vec3::splat(0.3),
        }
    }
}

/// `GpuSky` of `shaders/scene.inc.wgsl` (part of the view uniform): everything the shader
/// needs, computed once a frame here.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuSky {
    /// Perez coefficients A–E: `.x` for luminance Y, `.y` and `.z` for chromaticities x and y.
    /// A: darkening or brightening towards the horizon.
    pub perez_a: [f32; 4],
    /// Perez B: the luminance gradient near the horizon.
    pub perez_b: [f32; 4],
    /// Perez C: the relative intensity of the circumsolar region.
    pub perez_c: [f32; 4],
    /// Perez D: the width of the circumsolar region.
    pub perez_d: [f32; 4],
    /// Perez E: the relative backscattered light.
    pub perez_e: [f32; 4],
    /// Zenith Y (radiance units, twilight and intensity applied), x, y; `.w`: 1 for the physical
    /// sky, 0 for the uniform one.
    pub zenith: [f32; 4],
    /// 1 / F(0, θs) per channel (Y, x, y), the normalization of the Perez function.
    pub normalization: [f32; 4],
    /// Towards the sun; `.w`: the cosine of the disk's angular radius (2: no disk).
    pub sun_direction: [f32; 4],
    /// Radiance of the sun's disk.
    pub sun_radiance: [f32; 4],
    /// The uniform sky's radiance, or the physical sky's night floor.
    pub uniform: [f32; 4],
    /// What the horizon's radiance is multiplied by below it (RGB, [`PhysicalSky::ground_albedo`];
    /// unused by the uniform sky); `.w` unused.
    pub ground_albedo: [f32; 4],
}

/// The scene's sun as the sky sees it: a unit vector towards it and its irradiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector towards the sun (world space, y up).
    pub direction: Vec3,
    /// The sun's irradiance (W/m², the luminance of a directional light's `color × intensity`).
    pub irradiance: f32,
}

fn perez(t: f32) -> [[f32; 5]; 3] {
    [
        [0.1787 * t - 1.4630, -0.3554 * t + 0.4275, -0.0227 * t + 5.3251, 0.1206 * t - 2.5771, -0.0670 * t + 0.3703],
        [-0.0193 * t - 0.2592, -0.0665 * t + 0.0008, -0.0004 * t + 0.2125, -0.0641 * t - 0.8989, -0.0033 * t + 0.0452],
        [-0.0167 * t - 0.2608, -0.0950 * t + 0.0092, -0.0079 * t + 0.2102, -0.0441 * t - 1.6537, -0.0109 * t + 0.0529],
    ]
}

/// The Perez function F(θ, γ) for coefficients `c` (θ from the zenith as its cosine, γ from the sun).
fn perez_f(c: &[f32; 5], cos_theta: f32, gamma: f32, cos_gamma: f32) -> f32 {
    (1.0 + c[0] * (c[1] / cos_theta.max(0.01)).exp()) * (1.0 + c[2] * (c[3] * gamma).exp() + c[4] * cos_gamma * cos_gamma)
}

/// Linear Rec. 709 from CIE xyY.
fn xyy_to_rgb(x: f32, y: f32, luminance: f32) -> Vec3 {
    let y = y.max(1e-4);
    let (cx, cz) = (x / y * luminance, (1.0 - x - y) / y * luminance);
    let xyz = Vec3::new(cx, luminance, cz);
    Vec3::new(
        3.240_454 * xyz.x - 1.537_138_5 * xyz.y - 0.498_531_4 * xyz.z,
        -0.969_266 * xyz.x + 1.876_010_8 * xyz.y + 0.041_556 * xyz.z,
        0.055_643_4 * xyz.x - 0.204_025_9 * xyz.y + 1.057_225_2 * xyz.z,
    )
}

fn smoothstep(lo: f32, hi: f32, x: f32) -> f32 {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn sanitize(v: Vec3) -> Vec3 {
    Vec3::select(v.cmpge(Vec3::ZERO), v.min(Vec3::splat(3.0e38)), Vec3::ZERO)
}

impl Sky {
    /// The sky's parameters for the GPU, with `sun` the scene's sun (the first directional light,
    /// if any).
    pub fn gpu(&self, sun: Option<Sun>) -> GpuSky {
        let mut g = GpuSky { sun_direction: [0.0, 1.0, 0.0, 2.0], ..GpuSky::zeroed() };
        let s = match self {
            Sky::Uniform(radiance) => {
                g.uniform = sanitize(*radiance).extend(0.0).to_array();
                return g;
            }
            Sky::Physical(s) => s,
        };
        let fallback = Sun { direction: Vec3::new(0.0, std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2), irradiance: 1.0 };
        let sun = sun.unwrap_or(fallback);
        let direction = s.sun_direction.unwrap_or(sun.direction).normalize_or(fallback.direction);
        let irradiance = s.sun_irradiance.unwrap_or(sun.irradiance);
        let irradiance = if irradiance.is_finite() { irradiance.max(0.0) } else { 0.0 };
        let t = if s.turbidity.is_finite() { s.turbidity.clamp(1.7, 10.0) } else { 2.5 };
        let intensity = if s.intensity.is_finite() { s.intensity.max(0.0) } else { 1.0 };
        // Preetham's model holds for a sun above the horizon: below it the sun's angle is held at
        // the horizon and the sky fades through twilight (down to 6° under) to the night floor.
        let elevation = direction.y.clamp(-1.0, 1.0).asin();
        let theta_s = (std::f32::consts::FRAC_PI_2 - elevation).clamp(0.0, std::f32::consts::FRAC_PI_2 - 0.01);
        let twilight = smoothstep(-6f32.to_radians(), 2f32.to_radians(), elevation);
        let chi = (4.0 / 9.0 - t / 120.0) * (std::f32::consts::PI - 2.0 * theta_s);
        let zenith_kcd = ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192).max(0.0);
        let (t2, s1, s2, s3) = (t * t, theta_s, theta_s * theta_s, theta_s * theta_s * theta_s);
        let zenith_x = t2 * (0.00166 * s3 - 0.00375 * s2 + 0.00209 * s1)
            + t * (-0.02903 * s3 + 0.06377 * s2 - 0.03202 * s1 + 0.00394)
            + (0.11693 * s3 - 0.21196 * s2 + 0.06052 * s1 + 0.25886);
        let zenith_y = t2 * (0.00275 * s3 - 0.00610 * s2 + 0.00317 * s1)
            + t * (-0.04214 * s3 + 0.08970 * s2 - 0.04153 * s1 + 0.00516)
            + (0.15346 * s3 - 0.26756 * s2 + 0.06670 * s1 + 0.26688);
        let c = perez(t);
        let normalization = c.map(|c| 1.0 / perez_f(&c, 1.0, theta_s, theta_s.cos()).max(1e-6));
        let column = |k: usize| [c[0][k], c[1][k], c[2][k], 0.0];
        let scale = irradiance / SUN_REFERENCE_KLUX * intensity * twilight;
        g.perez_a = column(0);
        g.perez_b = column(1);
        g.perez_c = column(2);
        g.perez_d = column(3);
        g.perez_e = column(4);
        g.zenith = [zenith_kcd * scale, zenith_x, zenith_y, 1.0];
        g.normalization = [normalization[0], normalization[1], normalization[2], 0.0];
        // The sun's colour is the light's; its disk delivers the light's irradiance over its solid angle.
        let disk = 2.0 * std::f32::consts::PI * (1.0 - SUN_ANGULAR_RADIUS.cos());
        let show_disk = s.sun_disk && direction.y > -SUN_ANGULAR_RADIUS;
        g.sun_direction = direction.extend(if show_disk { SUN_ANGULAR_RADIUS.cos() } else { 2.0 }).to_array();
        g.sun_radiance = [irradiance / disk, irradiance / disk, irradiance / disk, 0.0];
        g.uniform = sanitize(s.night).extend(0.0).to_array();
        g.ground_albedo = sanitize(s.ground_albedo).extend(0.0).to_array();
        g
    }

    /// Radiance of the sky seen along unit direction `dir` (the CPU mirror of `sky_radiance` in
    /// scene.inc.wgsl), without the sun's disk.
    pub fn radiance(&self, sun: Option<Sun>, dir: Vec3) -> Vec3 {
        radiance(&self.gpu(sun), dir, false)
    }

    /// [`Sky::radiance`] with the sun's disk (what camera rays see: the background).
    pub fn background(&self, sun: Option<Sun>, dir: Vec3) -> Vec3 {
        radiance(&self.gpu(sun), dir, true)
    }
}

/// The sky's radiance along `dir` from its GPU parameters: exactly what the shader computes.
pub fn radiance(g: &GpuSky, dir: Vec3, with_disk: bool) -> Vec3 {
    let uniform = Vec3::from_slice(&g.uniform[..3]);
    if g.zenith[3] == 0.0 {
        return uniform;
    }
    let dir = dir.normalize_or(Vec3::Y);
    let to_sun = Vec3::from_slice(&g.sun_direction[..3]);
    // Above the horizon the Perez function; below it the horizon's radiance at that azimuth dimmed
    // by the ground's albedo, blended over the last two degrees.
    let horizon = Vec3::new(dir.x, 0.0, dir.z).normalize_or(Vec3::X);
    let up = Vec3::new(dir.x, dir.y.max(0.0), dir.z).normalize_or(horizon);
    let cos_gamma = up.dot(to_sun).clamp(-1.0, 1.0);
    let gamma = cos_gamma.acos();
    let cos_theta = up.y.max(0.0);
    let channel = |k: usize| {
        let c = [g.perez_a[k], g.perez_b[k], g.perez_c[k], g.perez_d[k], g.perez_e[k]];
        perez_f(&c, cos_theta, gamma, cos_gamma) * g.normalization[k]
    };
    let luminance = g.zenith[0] * channel(0);
    let (x, y) = (g.zenith[1] * channel(1), g.zenith[2] * channel(2));
    let sky = sanitize(xyy_to_rgb(x, y, luminance));
    let below = smoothstep(0.0, 2f32.to_radians().sin(), -dir.y);
    let ground = Vec3::from_slice(&g.ground_albedo[..3]);
    let mut out = sky * (Vec3::ONE + (ground - Vec3::ONE) * below);
    if with_disk && dir.dot(to_sun) >= g.sun_direction[3] {
        out += Vec3::from_slice(&g.sun_radiance[..3]);
    }
    sanitize(out).max(uniform)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sun_at(elevation_degrees: f32) -> Sun {
        let e = elevation_degrees.to_radians();
        Sun { direction: Vec3::new(e.cos(), e.sin(), 0.0), irradiance: 5.0 }
    }

    fn directions() -> impl Iterator<Item = Vec3> {
        (0..64).flat_map(|i| (0..32).map(move |j| (i, j))).map(|(i, j)| {
            let (phi, z) = (i as f32 / 64.0 * std::f32::consts::TAU, -1.0 + 2.0 * (j as f32 + 0.5) / 32.0);
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), z, r * phi.sin())
        })
    }

    #[test]
    fn the_sky_is_positive_and_finite_for_every_sun_elevation() {
        let sky = Sky::Physical(PhysicalSky::default());
        for elevation in (-90..=90).step_by(3) {
            for turbidity in [1.0, 2.5, 6.0, 10.0, 40.0] {
                let sky = Sky::Physical(PhysicalSky { turbidity, ..PhysicalSky::default() });
                for dir in directions() {
                    let l = sky.background(Some(sun_at(elevation as f32)), dir);
                    assert!(l.is_finite() && l.min_element() > 0.0, "elevation {elevation}°, T {turbidity}, {dir}: {l}");
                }
            }
        }
        // Nonsense settings still give a finite, positive sky.
        let odd =
            Sky::Physical(PhysicalSky { turbidity: f32::NAN, intensity: f32::INFINITY, night: Vec3::splat(-1.0), ..Default::default() });
        let l = odd.radiance(Some(Sun { direction: Vec3::ZERO, irradiance: f32::NAN }), Vec3::Y);
        assert!(l.is_finite() && l.min_element() >= 0.0, "{l}");
        let _ = sky;
    }

    #[test]
    fn the_daylight_sky_is_blue_brightest_near_the_sun_and_dark_at_night() {
        let sky = Sky::Physical(PhysicalSky::default());
        let sun = sun_at(60.0);
        let noon = Some(sun);
        let zenith = sky.radiance(noon, Vec3::Y);
        assert!(zenith.z > zenith.x, "a clear sky is blue at the zenith: {zenith}");
        let near_sun = sky.radiance(noon, Vec3::new(60f32.to_radians().cos(), 55f32.to_radians().sin(), 0.0).normalize());
        let away = sky.radiance(noon, Vec3::new(-1.0, 0.3, 0.0).normalize());
        assert!(near_sun.y > 2.0 * away.y, "near the sun {near_sun}, opposite {away}");
        // About a tenth of the sun's irradiance per steradian at a clear zenith (Preetham's noon
        // zenith is 6–9 kcd/m² against a 100 klux sun).
        assert!((0.2..1.0).contains(&zenith.y), "zenith {zenith} under a sun of 5 W/m²");
        // The sun's disk shows in the background only.
        let to_sun = sun.direction;
        assert!(sky.background(noon, to_sun).y > 1e4 * sky.radiance(noon, to_sun).y);
        // Night: the floor; the uniform sky: one value everywhere.
        let night = sky.radiance(Some(sun_at(-30.0)), Vec3::Y);
        assert_eq!(night, PhysicalSky::default().night);
        assert_eq!(Sky::Uniform(Vec3::ONE).background(noon, -Vec3::Y), Vec3::ONE);
        // Below the horizon: the horizon dimmed by the ground.
        let horizon = sky.radiance(noon, Vec3::new(0.0, 0.001, 1.0).normalize());
        let below = sky.radiance(noon, Vec3::new(0.0, -0.5, 1.0).normalize());
        assert!((below - horizon * 0.3).abs().max_element() < 0.02 * horizon.max_element(), "{below} against {horizon}");
    }
}

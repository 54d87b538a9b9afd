//! The surface reflection model: glTF's metallic-roughness BRDF. A Lambertian diffuse lobe for the
//! base colour of dielectrics, and a GGX specular lobe (Trowbridge–Reitz distribution, Smith's
//! height-correlated visibility, Schlick's Fresnel) whose energy lost to single scattering is
//! given back (Fdez-Agüera 2019 / Turquin 2019: the lobe times 1 + F0 (1/E − 1), E its directional
//! albedo), so that a white rough metal reflects all it receives. The diffuse lobe is weighted by
//! what the specular lobe leaves, 1 − E_s(n·v) (E_s its directional albedo), so that no
//! surface reflects more than it receives, at grazing angles too.
//!
//! `shaders/brdf.inc.wgsl` evaluates the same functions on the GPU (the raster's direct
//! light, DDGI's probe rays and gather, the path tracer's sampling); this module is their CPU
//! mirror and computes the one table they share: the split-sum terms A and B of the specular lobe's
//! directional albedo `E = F0·A + F90·B` over (n·v, roughness) ([`dfg_table`]).
//!
//! A material with `metallic = 0` and `specular = 0` has no specular lobe at all: exactly the
//! Lambertian surface every built-in scene uses.

use glam::{Vec2, Vec3};

/// Samples of the table along n·v and along roughness.
pub const DFG_SIZE: usize = 32;
/// Smallest perceptual roughness (a perfect mirror's lobe is a delta no raster can resolve).
pub const MIN_ROUGHNESS: f32 = 0.045;
/// Dielectric reflectance at normal incidence at `specular = 1` (an index of refraction of 1.5).
pub const DIELECTRIC_F0: f32 = 0.04;

/// What the BRDF needs of a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Linear base colour: the albedo of a dielectric, the reflectance at normal incidence of a metal.
    pub base_color: Vec3,
    /// Metalness in [0, 1]: 0 dielectric, 1 metal; values between blend the two.
    pub metallic: f32,
    /// Perceptual roughness (GGX's α is its square).
    pub roughness: f32,
    /// Weight of a dielectric's specular lobe (KHR_materials_specular's factor; 0: Lambertian).
    pub specular: f32,
}

impl Surface {
    /// Specular reflectance at normal incidence: 4 % times `specular` for a dielectric, the base colour
    /// for a metal.
    pub fn f0(&self) -> Vec3 {
        Vec3::splat(DIELECTRIC_F0 * self.specular).lerp(self.base_color, self.metallic)
    }

    /// Specular reflectance at grazing incidence: `specular` for a dielectric, 1 for a metal.
    pub fn f90(&self) -> f32 {
        self.specular + (1.0 - self.specular) * self.metallic
    }

    /// The Lambertian lobe's albedo: the base colour, none of it for a metal.
    pub fn diffuse_color(&self) -> Vec3 {
        self.base_color * (1.0 - self.metallic)
    }

    /// Whether the surface has a specular lobe at all (metallic or a non-zero `specular`); without one
    /// it is purely Lambertian.
    pub fn has_specular(&self) -> bool {
        self.metallic > 0.0 || self.specular > 0.0
    }

    fn alpha(&self) -> f32 {
        let r = self.roughness.clamp(MIN_ROUGHNESS, 1.0);
        r * r
    }
}

/// GGX normal distribution D(h) for cos θh = `n_h`.
pub fn ggx_d(n_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = n_h * n_h * (a2 - 1.0) + 1.0;
    a2 / (std::f32::consts::PI * d * d).max(1e-30)
}

/// Smith's height-correlated visibility G₂ / (4 n·l n·v).
pub fn smith_visibility(n_l: f32, n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_l * (n_v * n_v * (1.0 - a2) + a2).sqrt();
    let gl = n_v * (n_l * n_l * (1.0 - a2) + a2).sqrt();
    0.5 / (gv + gl).max(1e-30)
}

/// Smith's masking G₁(v) for cos θv = `n_v` (the visible normals' distribution, for sampling).
pub fn smith_g1(n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    2.0 * n_v / (n_v + (a2 + (1.0 - a2) * n_v * n_v).sqrt()).max(1e-30)
}

fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// The split-sum terms (A, B) of the specular lobe at `n_v` and perceptual `roughness`: its
/// directional albedo is `F0·A + F90·B`. Numerical integration by importance-sampling D (Karis
/// 2013) with `samples` Hammersley points.
pub fn integrate_dfg(n_v: f32, roughness: f32, samples: u32) -> Vec2 {
    let n_v = n_v.clamp(1e-4, 1.0);
    let r = roughness.clamp(MIN_ROUGHNESS, 1.0);
    let alpha = r * r;
    let v = Vec3::new((1.0 - n_v * n_v).sqrt(), 0.0, n_v);
    let (mut a, mut b) = (0.0f64, 0.0f64);
    for i in 0..samples {
        let u = Vec2::new((i as f32 + 0.5) / samples as f32, (i.reverse_bits() as f64 / 4294967296.0) as f32);
        // GGX-distributed half vector.
        let phi = 2.0 * std::f32::consts::PI * u.y;
        let cos_h = ((1.0 - u.x) / (1.0 + (alpha * alpha - 1.0) * u.x)).max(0.0).sqrt();
        let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
        let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
        let l = 2.0 * v.dot(h) * h - v;
        let (n_l, n_h, v_h) = (l.z, h.z, v.dot(h).max(0.0));
        if n_l > 0.0 {
            // f·cos / pdf with pdf = D·n·h / (4 v·h): V · 4 · n·l · v·h / n·h.
            let weight = (smith_visibility(n_l, n_v, alpha) * 4.0 * n_l * v_h / n_h.max(1e-6)) as f64;
            let fc = schlick_weight(v_h) as f64;
            a += (1.0 - fc) * weight;
            b += fc * weight;
        }
    }
    Vec2::new((a / samples as f64) as f32, (b / samples as f64) as f32)
}

/// The table the shaders read: `DFG_SIZE × DFG_SIZE` (A, B) pairs, row r (roughness
/// `r / (DFG_SIZE − 1)`) after row, column c at n·v = `c / (DFG_SIZE − 1)`.
pub fn dfg_table() -> &'static [[f32; 2]] {
    static TABLE: std::sync::LazyLock<Vec<[f32; 2]>> = std::sync::LazyLock::new(|| {
        let step = 1.0 / (DFG_SIZE - 1) as f32;
        (0..DFG_SIZE * DFG_SIZE)
            .map(|i| integrate_dfg((i % DFG_SIZE) as f32 * step, (i / DFG_SIZE) as f32 * step, 1024).to_array())
            .collect()
    });
    &TABLE
}

/// (A, B) at `n_v` and perceptual `roughness`, bilinear in the table (what `brdf_dfg` does on the GPU).
pub fn dfg(n_v: f32, roughness: f32) -> Vec2 {
    let table = dfg_table();
    let last = (DFG_SIZE - 1) as f32;
    let x = (n_v.clamp(0.0, 1.0) * last).min(last);
    let y = (roughness.clamp(0.0, 1.0) * last).min(last);
    let (x0, y0) = (x.floor().min(last - 1.0), y.floor().min(last - 1.0));
    let (fx, fy) = (x - x0, y - y0);
    let at = |c: f32, r: f32| Vec2::from_array(table[r as usize * DFG_SIZE + c as usize]);
    let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
    let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
    top.lerp(bottom, fy)
}

/// The specular lobe's directional albedo E at `n_v` (F0 and F90 weighted), and the factor that
/// gives the energy single scattering loses back: 1 + F0 (1 / E₁ − 1), E₁ = A + B the albedo of a
/// white lobe.
pub fn specular_albedo(surface: &Surface, n_v: f32) -> (Vec3, Vec3) {
    let ab = dfg(n_v, surface.roughness);
    let f0 = surface.f0();
    let compensation = Vec3::ONE + f0 * (1.0 / (ab.x + ab.y).max(1e-4) - 1.0);
    ((f0 * ab.x + Vec3::splat(surface.f90() * ab.y)) * compensation, compensation)
}

/// The BRDF f(l, v) (without the cosine), for unit normal `n`, towards-viewer `v` and
/// towards-light `l`.
pub fn eval(surface: &Surface, n: Vec3, v: Vec3, l: Vec3) -> Vec3 {
    let diffuse = surface.diffuse_color() / std::f32::consts::PI;
    if !surface.has_specular() {
        return diffuse;
    }
    let (n_l, n_v) = (n.dot(l), n.dot(v).max(1e-4));
    if n_l <= 0.0 {
        return Vec3::ZERO;
    }
    let h = (v + l).normalize_or(n);
    let (n_h, v_h) = (n.dot(h).max(0.0), v.dot(h).max(0.0));
    let alpha = surface.alpha();
    let fw = schlick_weight(v_h);
    let f = surface.f0() * (1.0 - fw) + Vec3::splat(surface.f90() * fw);
    let (albedo, compensation) = specular_albedo(surface, n_v);
    let specular = f * ggx_d(n_h, alpha) * smith_visibility(n_l, n_v, alpha) * compensation;
    diffuse * (Vec3::ONE - albedo).max(Vec3::ZERO) + specular
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f cos dω over the hemisphere: the share of uniform light reflected towards `n_v`. Half the
    /// samples follow the cosine, half the GGX lobe's normals, combined by the mixture's density
    /// (so that neither a sharp lobe nor the diffuse one is missed).
    fn albedo(surface: &Surface, n_v: f32) -> Vec3 {
        let v = Vec3::new((1.0 - n_v * n_v).sqrt(), 0.0, n_v);
        let alpha = surface.alpha();
        let samples = 1u32 << 16;
        let mut sum = Vec3::ZERO;
        for i in 0..samples {
            let u = Vec2::new((i as f32 + 0.5) / samples as f32, (i.reverse_bits() as f64 / 4294967296.0) as f32);
            let phi = std::f32::consts::TAU * u.y;
            let l = if i % 2 == 0 {
                let (r, z) = (u.x.sqrt(), (1.0 - u.x).max(0.0).sqrt());
                Vec3::new(r * phi.cos(), r * phi.sin(), z)
            } else {
                let cos_h = ((1.0 - u.x) / (1.0 + (alpha * alpha - 1.0) * u.x)).max(0.0).sqrt();
                let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
                let h = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                2.0 * v.dot(h) * h - v
            };
            if l.z <= 0.0 {
                continue;
            }
            let h = (v + l).normalize();
            let pdf_ggx = ggx_d(h.z, alpha) * h.z / (4.0 * v.dot(h).max(1e-6));
            let pdf = 0.5 * l.z / std::f32::consts::PI + 0.5 * pdf_ggx;
            sum += eval(surface, Vec3::Z, v, l) * l.z / pdf.max(1e-12);
        }
        sum / samples as f32
    }

    #[test]
    fn a_white_rough_metal_reflects_all_it_receives() {
        for roughness in [0.2f32, 0.5, 0.8, 1.0] {
            for n_v in [0.2f32, 0.5, 0.9] {
                let metal = Surface { base_color: Vec3::ONE, metallic: 1.0, roughness, specular: 1.0 };
                let e = albedo(&metal, n_v);
                assert!((e.x - 1.0).abs() < 0.03, "roughness {roughness}, n·v {n_v}: albedo {e}");
                // Without the compensation the lobe loses energy, most at high roughness.
                let single = integrate_dfg(n_v, roughness, 4096);
                assert!(single.x + single.y <= 1.0 + 1e-3, "{single}");
            }
        }
        let single = integrate_dfg(0.5, 1.0, 4096);
        assert!(single.x + single.y < 0.8, "GGX at roughness 1 loses a fifth or more to single scattering: {single}");
    }

    #[test]
    fn a_dielectric_never_reflects_more_than_it_receives_and_specular_zero_is_lambert() {
        for roughness in [0.1f32, 0.5, 1.0] {
            for n_v in [0.1f32, 0.5, 1.0] {
                let white = Surface { base_color: Vec3::ONE, metallic: 0.0, roughness, specular: 1.0 };
                let e = albedo(&white, n_v);
                assert!(e.x < 1.02 && e.x > 0.9, "roughness {roughness}, n·v {n_v}: albedo {e}");
            }
        }
        let lambert = Surface { base_color: Vec3::new(0.5, 0.25, 1.0), metallic: 0.0, roughness: 0.3, specular: 0.0 };
        assert!(!lambert.has_specular());
        let f = eval(&lambert, Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.3, 0.1, 0.9).normalize());
        assert_eq!(f, lambert.base_color / std::f32::consts::PI);
    }

    #[test]
    fn the_table_matches_direct_integration_and_known_values() {
        for (n_v, r) in [(0.13f32, 0.37f32), (0.5, 0.5), (0.91, 0.82), (1.0, 1.0), (0.3, 0.08)] {
            let (table, direct) = (dfg(n_v, r), integrate_dfg(n_v, r, 4096));
            assert!((table - direct).abs().max_element() < 0.02, "n·v {n_v}, roughness {r}: table {table}, direct {direct}");
        }
        // A smooth lobe at normal incidence reflects F0 (A → 1, B → 0).
        let smooth = dfg(1.0, 0.0);
        assert!((smooth.x - 1.0).abs() < 0.02 && smooth.y < 0.02, "{smooth}");
    }
}

//! The sRGB transfer function on the CPU, between linear values and 8-bit sRGB: for what runs in
//! the app (atlas dumps, mean texture colours, overlays) and for the metrics' tonemapper; the AgX
//! display transform and photographic exposure (EV100), mirrored by `engine/shaders/tonemap.wgsl`.

use glam::{Mat3, Vec3};

/// A linear value clamped to [0, 1], sRGB-encoded to 8 bits.
pub fn srgb8(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// An 8-bit sRGB value decoded to linear, in [0, 1] (the inverse of [`srgb8`]).
pub fn srgb8_to_linear(v: u8) -> f32 {
    let c = f32::from(v) / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// AgX's inset matrix (Troy Sobotka's AgX, in the minimal form of Benjamin Wrensch): columns.
const AGX_INSET: [f32; 9] =
    [0.842_479_06, 0.042_328_242, 0.042_375_655, 0.078_433_6, 0.878_468_64, 0.078_433_6, 0.079_223_745, 0.079_166_13, 0.879_143];
/// Its inverse (the outset), columns.
const AGX_OUTSET: [f32; 9] =
    [1.196_879, -0.052_896_852, -0.052_971_635, -0.098_020_88, 1.151_903_1, -0.098_043_45, -0.099_029_74, -0.098_961_18, 1.151_073_7];
/// The exposure range AgX maps onto [0, 1], in stops around middle grey.
const AGX_MIN_EV: f32 = -12.473_93;
const AGX_MAX_EV: f32 = 4.026_069;

/// AgX's sigmoid on the log-encoded value (a 6th-order fit of its contrast curve).
fn agx_contrast(x: f32) -> f32 {
    let (x2, x4) = (x * x, x * x * x * x);
    15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x - 0.00232
}

/// The AgX display transform of exposed linear radiance `c` (Rec. 709 primaries): display-linear
/// RGB in [0, 1], ready for the sRGB encoding. Bright light rolls off into white instead of
/// clipping, and saturated highlights desaturate as film does, so an emissive panel or a sunlit wall
/// keeps its shape where a clamp burns it to flat white. 0 maps to 0; it is monotone along grey; NaN,
/// infinite or negative input is treated as 0 (and infinity as the brightest white).
pub fn agx(c: Vec3) -> Vec3 {
    let finite = |v: f32| if v.is_nan() { 0.0 } else { v.clamp(0.0, f32::MAX) };
    let c = Vec3::new(finite(c.x), finite(c.y), finite(c.z));
    let inset = Mat3::from_cols_array(&AGX_INSET) * c;
    let encoded =
        inset.max(Vec3::splat(1e-10)).to_array().map(|v| (v.log2().clamp(AGX_MIN_EV, AGX_MAX_EV) - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV));
    let curved = Vec3::from_array(encoded.map(agx_contrast));
    let outset = Mat3::from_cols_array(&AGX_OUTSET) * curved;
    Vec3::from_array(outset.to_array().map(|v| v.clamp(0.0, 1.0).powf(2.2)))
}

/// The exposure (the linear scale of [`crate::scene::Camera::exposure`]) of a camera at exposure
/// value `ev100` (ISO 100): 1 / (1.2 · 2^EV100), so that the brightest radiance it records without
/// saturating a sensor is 1.2 · 2^EV100 (Lagarde and de Rousiers, "Moving Frostbite to PBR", 2014).
/// One EV more halves the exposure. Sunny daylight is about EV100 15, a lit interior 7–9; our scenes'
/// radiance is scaled so that exposure 1 (EV100 ≈ −0.26) shows them.
pub fn exposure_from_ev100(ev100: f32) -> f32 {
    1.0 / (1.2 * ev100.clamp(-60.0, 60.0).exp2())
}

#[cfg(test)]
mod agx_tests {
    use super::*;

    #[test]
    fn agx_maps_black_to_black_is_monotone_along_grey_and_never_nan() {
        assert_eq!(agx(Vec3::ZERO), Vec3::ZERO);
        let mut last = -1.0;
        for k in 0..=4000 {
            // Grey from 1e-6 to 1e4, in small steps of stops.
            let v = 10f32.powf(-6.0 + 10.0 * k as f32 / 4000.0);
            let out = agx(Vec3::splat(v));
            assert!(out.is_finite() && out.min_element() >= 0.0 && out.max_element() <= 1.0, "{v}: {out}");
            // Grey stays grey, and brighter grey is never darker.
            assert!((out.x - out.y).abs() < 2e-3 && (out.y - out.z).abs() < 2e-3, "{v}: {out}");
            assert!(out.y >= last - 1e-6, "not monotone at {v}: {} after {last}", out.y);
            last = out.y;
        }
        assert!(last > 0.95, "very bright grey is near white: {last}");
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0, f32::MAX] {
            assert!(agx(Vec3::new(bad, 0.5, 1.0)).is_finite(), "{bad}");
        }
        // Middle grey (0.18) lands in the middle of the display range, not crushed or blown.
        let mid = agx(Vec3::splat(0.18)).y;
        assert!((0.1..0.4).contains(&mid), "{mid}");
    }

    #[test]
    fn one_ev_halves_the_exposure() {
        for ev in [-4.0, 0.0, 7.5, 15.0] {
            let ratio = exposure_from_ev100(ev) / exposure_from_ev100(ev + 1.0);
            assert!((ratio - 2.0).abs() < 1e-5, "{ev}: {ratio}");
        }
        assert!((exposure_from_ev100(0.0) - 1.0 / 1.2).abs() < 1e-7);
        assert!(exposure_from_ev100(f32::INFINITY).is_finite() && exposure_from_ev100(f32::NEG_INFINITY).is_finite());
    }
}

//! The sRGB transfer function on the CPU, between linear values and 8-bit sRGB: for what runs in
//! the app (atlas dumps, mean texture colours, overlays) and for the metrics' tonemapper.

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

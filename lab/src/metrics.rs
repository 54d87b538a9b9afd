//! Image error metrics against a reference: FLIP (NVIDIA's perceptual metric, on tonemapped sRGB at
//! a fixed exposure), RMSE and relative MSE on linear radiance, and FLIP error maps in the magma
//! colour map.

use engine::color::srgb8;

/// A FLIP error map: one error in [0, 1] per pixel ([`flip_rgb8`], [`magma`]).
pub use nv_flip::FlipImageFloat;

/// Errors of one image against a reference.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ErrorMetrics {
    /// Mean FLIP over the pixels, in [0, 1], on both images tonemapped at the same exposure.
    pub mean_flip: f32,
    /// Root mean square error of linear radiance over all RGB channels.
    pub rmse: f64,
    /// Mean of (test − reference)² / (reference² + ε) over all RGB channels: scale-free.
    pub relative_mse: f64,
}

/// The ε of [`relative_mse`], which keeps near-black reference pixels from dominating.
pub const RELATIVE_MSE_EPSILON: f64 = 1e-2;

/// Linear RGBA radiance → sRGB-encoded RGB8: exposure, clamp to [0, 1], sRGB transfer function
/// (the camera path's tonemapper, on the CPU). Non-finite values count as black.
pub fn tonemap_to_srgb8(rgba: &[f32], exposure: f32) -> Vec<u8> {
    let encode = |c: f32| srgb8(if c.is_finite() { c * exposure } else { 0.0 });
    rgba.chunks_exact(4).flat_map(|p| [encode(p[0]), encode(p[1]), encode(p[2])]).collect()
}

/// Mean FLIP between two sRGB RGB8 images of `width × height`, and the per-pixel error map.
pub fn flip_rgb8(reference: &[u8], test: &[u8], width: u32, height: u32) -> (f32, FlipImageFloat) {
    let reference = nv_flip::FlipImageRgb8::with_data(width, height, reference);
    let test = nv_flip::FlipImageRgb8::with_data(width, height, test);
    let map = nv_flip::flip(reference, test, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    (nv_flip::FlipPool::from_image(&map).mean(), map)
}

/// A FLIP error map as RGB8 in the magma colour map (black: no error, yellow-white: large).
pub fn magma(map: &FlipImageFloat) -> Vec<u8> {
    map.apply_color_lut(&nv_flip::magma_lut()).to_vec()
}

fn rgb_pairs<'a>(reference: &'a [f32], test: &'a [f32]) -> impl Iterator<Item = (f64, f64)> + 'a {
    reference.chunks_exact(4).zip(test.chunks_exact(4)).flat_map(|(r, t)| (0..3).map(move |c| (f64::from(r[c]), f64::from(t[c]))))
}

/// Root mean square error of linear RGBA radiance (alpha ignored). Images must have the same size.
pub fn rmse(reference: &[f32], test: &[f32]) -> f64 {
    assert_eq!(reference.len(), test.len(), "images differ in size");
    let (sum, n) = rgb_pairs(reference, test).fold((0.0, 0usize), |(s, n), (r, t)| (s + (t - r) * (t - r), n + 1));
    if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
}

/// Relative mean square error of linear RGBA radiance (alpha ignored), with [`RELATIVE_MSE_EPSILON`].
pub fn relative_mse(reference: &[f32], test: &[f32]) -> f64 {
    assert_eq!(reference.len(), test.len(), "images differ in size");
    let (sum, n) =
        rgb_pairs(reference, test).fold((0.0, 0usize), |(s, n), (r, t)| (s + (t - r) * (t - r) / (r * r + RELATIVE_MSE_EPSILON), n + 1));
    if n == 0 { 0.0 } else { sum / n as f64 }
}

/// Every metric of a linear RGBA image against a reference of the same size.
pub fn compare(reference: &[f32], test: &[f32], width: u32, height: u32, exposure: f32) -> ErrorMetrics {
    let (mean_flip, _) = flip_rgb8(&tonemap_to_srgb8(reference, exposure), &tonemap_to_srgb8(test, exposure), width, height);
    ErrorMetrics { mean_flip, rmse: rmse(reference, test), relative_mse: relative_mse(reference, test) }
}

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

/// The display [`video_jod`] models: ColorVideoVDP's 24-inch 1920×1080 monitor of 200 cd/m² peak,
/// seen from 0.6 m under office light (250 lux); an image smaller than the display covers as many
/// of its pixels as it has.
pub const VIDEO_DISPLAY: &str = "standard_fhd";
/// Frames per second at which [`video_jod`] plays a sequence: the frame rate the methods are
/// meant to run at.
pub const VIDEO_FPS: f32 = 60.0;
/// The most memory ColorVideoVDP may take for one prediction (its working planes grow with the
/// pixels: about 1.7 GB at 1920×1080 and 60 frames per second; 53 MB at 256×256).
const VIDEO_MEMORY_LIMIT: usize = 4 << 30;

/// The perceived quality of a sequence of sRGB RGB8 frames (`width × height` each) against a
/// reference sequence of the same length, in ColorVideoVDP's just-objectionable differences (JOD:
/// 10 is no visible difference; 1 JOD less is chosen as worse by 75% of observers), seen on
/// [`VIDEO_DISPLAY`] at [`VIDEO_FPS`]. It weighs what changes from frame to frame (flicker,
/// noise that crawls) by the eye's temporal sensitivity, beside what differs in each frame. A
/// sequence of one frame is judged as an image.
pub fn video_jod(test: &[&[u8]], reference: &[&[u8]], width: u32, height: u32) -> Result<f32, String> {
    if test.len() != reference.len() {
        return Err(format!("video JOD: {} test frames against {} reference frames", test.len(), reference.len()));
    }
    let frame = |rgb: &[u8]| {
        let data = rgb.iter().map(|&v| f32::from(v) / 255.0).collect();
        colorvideovdp::Image::new(width as usize, height as usize, 3, data).map_err(|e| format!("video JOD, {width}×{height} frame: {e}"))
    };
    let test = test.iter().map(|f| frame(f)).collect::<Result<Vec<_>, _>>()?;
    let reference = reference.iter().map(|f| frame(f)).collect::<Result<Vec<_>, _>>()?;
    let display = colorvideovdp::DisplayModel::from_name(VIDEO_DISPLAY).map_err(|e| format!("video JOD, display {VIDEO_DISPLAY}: {e}"))?;
    let options = colorvideovdp::Options::default().with_memory_limit_bytes(VIDEO_MEMORY_LIMIT);
    let metric = colorvideovdp::Cvvdp::new(display, options).map_err(|e| format!("video JOD: {e}"))?;
    let prediction = metric
        .predict_video(&test, &reference, VIDEO_FPS, colorvideovdp::Color::Srgb)
        .map_err(|e| format!("video JOD of {} frames of {width}×{height}: {e}", test.len()))?;
    Ok(prediction.jod)
}

/// [`video_jod`] of `frames` against a still reference (`still` in every frame).
pub fn video_jod_against_still(frames: &[&[u8]], still: &[u8], width: u32, height: u32) -> Result<f32, String> {
    video_jod(frames, &vec![still; frames.len()], width, height)
}

/// The per-pixel mean of the encoded values of sRGB RGB8 frames of the same size, rounded: a
/// still of what the sequence shows on average, against which [`video_jod_against_still`] sees only what changes
/// from frame to frame. `None` without frames.
pub fn mean_frame(frames: &[&[u8]]) -> Option<Vec<u8>> {
    let first = frames.first()?;
    let mut sum = vec![0u32; first.len()];
    for frame in frames {
        for (s, &v) in sum.iter_mut().zip(frame.iter()) {
            *s += u32::from(v);
        }
    }
    let n = frames.len() as u32;
    Some(sum.into_iter().map(|s| ((s + n / 2) / n) as u8).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    const SIZE: u32 = 64;

    /// A lit scene's linear RGBA radiance: a smooth gradient with a few edges, in [0.05, 0.8].
    fn scene() -> Vec<f32> {
        (0..SIZE * SIZE)
            .flat_map(|i| {
                let (x, y) = ((i % SIZE) as f32 / SIZE as f32, (i / SIZE) as f32 / SIZE as f32);
                let edge = if (x * 4.0).fract() < 0.5 { 0.2 } else { 0.0 };
                [0.05 + 0.4 * x + edge, 0.1 + 0.5 * y, 0.3 + edge, 1.0]
            })
            .collect()
    }

    /// `frames` frames of `scene` whose brightness alternates between 1 + `amount` and 1 - `amount`.
    fn flickering(scene: &[f32], frames: usize, amount: f32) -> Vec<Vec<u8>> {
        (0..frames)
            .map(|f| {
                let gain = if f % 2 == 0 { 1.0 + amount } else { 1.0 - amount };
                let frame: Vec<f32> = scene.iter().map(|v| v * gain).collect();
                tonemap_to_srgb8(&frame, 1.0)
            })
            .collect()
    }

    #[test]
    fn a_sequence_equal_to_its_reference_scores_ten_and_flicker_lowers_it_the_more_it_flickers() {
        let still = tonemap_to_srgb8(&scene(), 1.0);
        let frames = 12;
        let same = vec![still.as_slice(); frames];
        let jod = video_jod_against_still(&same, &still, SIZE, SIZE).expect("jod");
        assert!((jod - 10.0).abs() < 1e-4, "no difference is 10 JOD: {jod}");
        let mut last = jod;
        for percent in [1.0, 3.0, 10.0, 30.0] {
            let sequence = flickering(&scene(), frames, percent / 100.0);
            let refs: Vec<&[u8]> = sequence.iter().map(Vec::as_slice).collect();
            let jod = video_jod_against_still(&refs, &still, SIZE, SIZE).expect("jod");
            assert!(jod < last, "±{percent}% flicker: {jod} JOD, not under the {last} of less flicker");
            last = jod;
            // Against its own mean the sequence differs only in time: still visible.
            let mean = mean_frame(&refs).expect("frames");
            let temporal = video_jod_against_still(&refs, &mean, SIZE, SIZE).expect("jod");
            assert!(temporal < 10.0 - 1e-3, "±{percent}%: {temporal} JOD against its own mean");
        }
        assert!(last < 8.0, "±30% flicker at 60 frames per second is plainly visible: {last} JOD");
    }

    #[test]
    fn video_jod_says_what_is_wrong_with_its_input() {
        let still = tonemap_to_srgb8(&scene(), 1.0);
        let error = video_jod(&[&still, &still], &[&still], SIZE, SIZE).expect_err("lengths differ");
        assert!(error.contains("2 test frames against 1"), "{error}");
        let error = video_jod(&[&still[..30]], &[&still[..30]], 2, 5).expect_err("too small");
        assert!(error.contains("2×5"), "{error}");
        assert_eq!(mean_frame(&[&[0, 10, 255], &[1, 20, 255]]), Some(vec![1, 15, 255]));
        assert_eq!(mean_frame(&[]), None);
    }
}

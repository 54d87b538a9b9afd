//! Error metrics: zero for identical images, the expected values for known perturbations.

use lab::metrics::{RELATIVE_MSE_EPSILON, compare, flip_rgb8, magma, relative_mse, rmse, tonemap_to_srgb8};

/// A smooth test image of linear radiance (RGBA), with values from dark to above 1.
fn image(width: u32, height: u32) -> Vec<f32> {
    (0..width * height)
        .flat_map(|i| {
            let (x, y) = ((i % width) as f32 / width as f32, (i / width) as f32 / height as f32);
            [x * 1.5, y, 0.25 + 0.5 * x * y, 1.0]
        })
        .collect()
}

#[test]
fn identical_images_have_zero_error() {
    let a = image(64, 48);
    let m = compare(&a, &a, 64, 48, 1.0);
    assert_eq!(m.mean_flip, 0.0);
    assert_eq!(m.rmse, 0.0);
    assert_eq!(m.relative_mse, 0.0);
}

#[test]
fn a_constant_offset_gives_that_offset_as_rmse_and_the_formula_as_relative_mse() {
    let a = image(32, 32);
    let delta = 0.05f32;
    let b: Vec<f32> = a.chunks_exact(4).flat_map(|p| [p[0] + delta, p[1] + delta, p[2] + delta, p[3] + 7.0]).collect();
    assert!((rmse(&a, &b) - f64::from(delta)).abs() < 1e-6, "{}", rmse(&a, &b));
    let expected: f64 = a
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .map(|r| f64::from(delta).powi(2) / (f64::from(r).powi(2) + RELATIVE_MSE_EPSILON))
        .sum::<f64>()
        / (32.0 * 32.0 * 3.0);
    // The offset itself went through f32 additions: allow their rounding.
    assert!((relative_mse(&a, &b) - expected).abs() < 1e-5 * expected, "{} vs {expected}", relative_mse(&a, &b));
    // Doubling the offset quadruples both mean square errors.
    let c: Vec<f32> = a.iter().zip(&b).map(|(x, y)| x + 2.0 * (y - x)).collect();
    assert!((rmse(&a, &c) / rmse(&a, &b) - 2.0).abs() < 1e-4);
}

#[test]
fn flip_grows_with_the_perturbation_and_its_map_is_magma() {
    let a = image(64, 64);
    let small: Vec<f32> = a.iter().map(|v| v * 1.05).collect();
    let large: Vec<f32> = a.iter().map(|v| v * 1.5).collect();
    let (fs, fl) = (compare(&a, &small, 64, 64, 1.0).mean_flip, compare(&a, &large, 64, 64, 1.0).mean_flip);
    assert!(0.0 < fs && fs < fl && fl < 1.0, "small {fs}, large {fl}");
    let (_, map) = flip_rgb8(&tonemap_to_srgb8(&a, 1.0), &tonemap_to_srgb8(&large, 1.0), 64, 64);
    assert_eq!(magma(&map).len(), 64 * 64 * 3);
}

#[test]
fn tonemapping_matches_the_srgb_transfer_function_and_survives_nan() {
    let px = [0.0, 0.5, 2.0, 1.0, f32::NAN, f32::INFINITY, -1.0, 1.0];
    assert_eq!(tonemap_to_srgb8(&px, 1.0), [0, 188, 255, 0, 0, 0]);
}

//! The path-traced references the evaluation compares with, rendered once and cached as EXR by
//! a key of what they see ([`reference_path`], [`reference`]).

use std::path::{Path, PathBuf};

use engine::glam::Vec3;
use engine::gpu::GpuContext;
use engine::scene::{NodeContent, SceneDescription};

use super::{Config, REFERENCE_SEED, render};

/// FNV-1a, 64 bits: a hash that stays the same across builds and Rust versions (a disk cache key).
fn fnv1a(words: impl IntoIterator<Item = u32>) -> u64 {
    words.into_iter().flat_map(u32::to_le_bytes).fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The cache file of a reference: by `label` (the scene's name), size, paths per pixel and a hash
/// of the view and the scene's layout — every camera's world transform and field of view, every
/// node's world transform, a directional light's colour and irradiance, and the scene's sky when it
/// has one — so that another camera, a moved or brighter sun, a moved object or another sky gets
/// another reference.
pub fn reference_path(cache: &Path, label: &str, scene: &SceneDescription, width: u32, height: u32, spp: u32) -> PathBuf {
    let mut words = Vec::new();
    for (node, world) in scene.nodes.iter().zip(scene.world_transforms()) {
        words.extend(world.to_cols_array().map(f32::to_bits));
        for content in &node.content {
            match content {
                NodeContent::Camera(camera) => words.push(camera.yfov.to_bits()),
                // Added to the key only where it differs from the white light of irradiance 1 that
                // the built-in scenes' keys were made without.
                NodeContent::DirectionalLight(light) if (light.color, light.intensity) != (Vec3::ONE, 1.0) => {
                    words.extend(light.color.to_array().map(f32::to_bits));
                    words.push(light.intensity.to_bits());
                }
                _ => {}
            }
        }
    }
    if let Some(sky) = &scene.sky {
        words.extend(format!("{sky:?}").bytes().map(u32::from));
    }
    let label = label.replace(['/', '\\', '.'], "_");
    cache.join(format!("{label}-{width}x{height}-{spp}spp-{:016x}.exr", fnv1a(words)))
}

/// The reference image (linear RGBA) of `scene` as given (see [`still`]), rendered once and
/// cached as EXR ([`reference_path`]): the path tracer at `spp` paths per pixel.
pub fn reference(
    gpu: &GpuContext,
    label: &str,
    scene: &SceneDescription,
    width: u32,
    height: u32,
    spp: u32,
    cache: &Path,
) -> Result<Vec<f32>, String> {
    let key = reference_path(cache, label, scene, width, height, spp);
    let (image, cached) = cached_image(&key, width, height, || {
        println!("reference: path tracing {spp} paths per pixel…");
        let config = Config::PathTrace { spp };
        Ok(render(gpu, scene, &config, width, height, REFERENCE_SEED, config.frames())?.hdr)
    })?;
    if cached {
        println!("reference: cached {}", key.display());
    }
    Ok(image)
}

/// The linear RGBA image cached at `key` (an EXR of `width` × `height`) and `true`, or `render`'s,
/// which is then cached there, and `false`.
pub(crate) fn cached_image(
    key: &Path,
    width: u32,
    height: u32,
    render: impl FnOnce() -> Result<Vec<f32>, String>,
) -> Result<(Vec<f32>, bool), String> {
    if let Ok(img) = image::open(key) {
        let rgb = img.to_rgb32f();
        if (rgb.width(), rgb.height()) == (width, height) {
            return Ok((rgb.pixels().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect(), true));
        }
    }
    let hdr = render()?;
    if let Some(dir) = key.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    save_exr(key, &hdr, width, height)?;
    Ok((hdr, false))
}

/// Writes the linear RGBA image `rgba` (`width` × `height`) to `path` as an RGB EXR.
pub fn save_exr(path: &Path, rgba: &[f32], width: u32, height: u32) -> Result<(), String> {
    let rgb: Vec<f32> = rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    image::Rgb32FImage::from_raw(width, height, rgb)
        .ok_or_else(|| format!("{}: the pixel count does not match {width}×{height}", path.display()))?
        .save(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use engine::glam::Vec3;
    use engine::scene::{Camera, NodeContent};

    #[test]
    fn reference_cache_key_changes_with_the_camera_and_only_with_what_the_reference_sees() {
        let cache = Path::new("cache");
        let scene = (scenes::find("cornell").expect("cornell").build)();
        let key = |s: &SceneDescription| reference_path(cache, "cornell", s, 64, 48, 256);
        assert_eq!(key(&scene), key(&scene.clone()), "same scene and camera, same key");
        let camera = scene.nodes.iter().position(|n| n.content.iter().any(|c| matches!(c, NodeContent::Camera(_)))).expect("camera");

        let mut moved = scene.clone();
        moved.nodes[camera].transform.translation += Vec3::new(0.0, 0.0, 0.01);
        assert_ne!(key(&scene), key(&moved), "a moved camera needs another reference");

        let mut zoomed = scene.clone();
        for c in &mut zoomed.nodes[camera].content {
            if let NodeContent::Camera(Camera { yfov, .. }) = c {
                *yfov *= 0.9;
            }
        }
        assert_ne!(key(&scene), key(&zoomed), "another field of view needs another reference");

        let mut sky = scene.clone();
        sky.sky = Some(engine::render::Sky::Uniform(Vec3::splat(0.5)));
        assert_ne!(key(&scene), key(&sky), "another sky needs another reference");
        let mut sun = scene.clone();
        sun.add_sun(Vec3::NEG_Y, 2.0);
        let mut brighter = scene.clone();
        brighter.add_sun(Vec3::NEG_Y, 3.0);
        assert_ne!(key(&sun), key(&brighter), "a brighter sun needs another reference");
        assert_ne!(key(&scene), reference_path(cache, "cornell", &scene, 64, 48, 512), "spp is in the key");
        assert_ne!(key(&scene), reference_path(cache, "cornell", &scene, 48, 64, 256), "size is in the key");
    }
}

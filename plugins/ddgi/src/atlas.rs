//! Reading the atlases back (tests, `--dump-atlases`, the overlay) and writing them as images.

use std::path::{Path, PathBuf};

use engine::gpu::GpuContext;
use engine::gpu::readback::read_texture;
use glam::{UVec2, Vec2, Vec3};

use crate::gpu::{DdgiRay, IRRADIANCE_GAMMA};
use crate::resources::VolumeGpu;

/// An atlas read back from the GPU, row-major from the top-left.
pub struct Atlas<T> {
    /// Width and height in texels.
    pub size: UVec2,
    /// The texels, row-major from the top-left.
    pub texels: Vec<T>,
}

impl<T: Copy> Atlas<T> {
    /// The texel at column `x`, row `y` (panics outside the atlas).
    pub fn get(&self, x: u32, y: u32) -> T {
        self.texels[(y * self.size.x + x) as usize]
    }
}

fn read_half4(gpu: &GpuContext, texture: &engine::wgpu::Texture) -> Atlas<[f32; 4]> {
    let bytes = read_texture(gpu, texture);
    let texels =
        bytes.chunks_exact(8).map(|t| std::array::from_fn(|i| half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32())).collect();
    Atlas { size: UVec2::new(texture.width(), texture.height()), texels }
}

/// The irradiance atlas, decoded to linear irradiance (W/m²), borders included.
pub fn read_irradiance(gpu: &GpuContext, volume: &VolumeGpu) -> Atlas<Vec3> {
    let raw = read_half4(gpu, &volume.irradiance);
    let decode = |v: f32| if v > 0.0 { v.powf(IRRADIANCE_GAMMA) } else { 0.0 };
    Atlas { size: raw.size, texels: raw.texels.iter().map(|t| Vec3::new(decode(t[0]), decode(t[1]), decode(t[2]))).collect() }
}

/// The distance atlas in world units: (mean distance, mean squared distance).
pub fn read_distance(gpu: &GpuContext, volume: &VolumeGpu) -> Atlas<Vec2> {
    let raw = read_half4(gpu, &volume.distance);
    let scale = volume.layout.distance_scale();
    Atlas { size: raw.size, texels: raw.texels.iter().map(|t| Vec2::new(t[0] * scale, t[1] * scale * scale)).collect() }
}

/// Texels holding NaN or an infinity in either atlas (raw, before decoding: the irradiance
/// decoding would turn a NaN into black).
pub fn count_non_finite(gpu: &GpuContext, volume: &VolumeGpu) -> usize {
    [&volume.irradiance, &volume.distance]
        .into_iter()
        .map(|texture| read_half4(gpu, texture).texels.iter().filter(|t| t.iter().any(|v| !v.is_finite())).count())
        .sum()
}

/// This frame's probe rays (direction and probe index), in the order the trace packed them.
pub fn read_rays(gpu: &GpuContext, volume: &VolumeGpu) -> Vec<DdgiRay> {
    let bytes = engine::gpu::readback::read_buffer(gpu, &volume.rays);
    bytemuck::pod_collect_to_vec(&bytes)
}

/// Mean irradiance over the interior texels of one probe's map.
pub fn probe_mean_irradiance(atlas: &Atlas<Vec3>, volume: &VolumeGpu, probe: u32) -> Vec3 {
    let n = volume.layout.irradiance_texels;
    let origin = volume.layout.tile_origin(probe, n) + UVec2::ONE;
    let mut sum = Vec3::ZERO;
    for y in 0..n {
        for x in 0..n {
            sum += atlas.get(origin.x + x, origin.y + y);
        }
    }
    sum / (n * n) as f32
}

/// A distance-atlas texel as grey: its mean distance over the volume's distance scale, 0..255.
pub fn distance_grey(texel: Vec2, distance_scale: f32) -> u8 {
    ((texel.x / distance_scale).clamp(0.0, 1.0) * 255.0) as u8
}

fn save_rgb(path: &Path, size: UVec2, rgb: &[u8]) -> Result<(), String> {
    image::save_buffer(path, rgb, size.x, size.y, image::ExtendedColorType::Rgb8).map_err(|e| format!("{}: {e}", path.display()))
}

/// Writes `irradiance.png` (radiance E/π of a white surface, sRGB) and `irradiance.exr` (linear
/// E), `distance.png` (mean distance over the distance scale, grey) and `ray_directions.png` (one
/// row per probe, one column per ray, direction × 0.5 + 0.5; rays a probe did not trace black,
/// as of the last probe readback) and `probes.csv` (one row per probe: grid coordinates, world
/// position, relocation offset, state bits, luma and rays, as of the last probe readback) into
/// `dir`.
pub fn write_atlas_images(gpu: &GpuContext, volume: &VolumeGpu, dir: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let irradiance = read_irradiance(gpu, volume);
    let path = dir.join("irradiance.png");
    let rgb: Vec<u8> = irradiance.texels.iter().flat_map(|e| (*e / std::f32::consts::PI).to_array().map(engine::color::srgb8)).collect();
    save_rgb(&path, irradiance.size, &rgb)?;
    let exr = dir.join("irradiance.exr");
    let linear: Vec<f32> = irradiance.texels.iter().flat_map(|e| e.to_array()).collect();
    image::Rgb32FImage::from_raw(irradiance.size.x, irradiance.size.y, linear)
        .ok_or("irradiance atlas size mismatch")?
        .save(&exr)
        .map_err(|e| format!("{}: {e}", exr.display()))?;
    let distance = read_distance(gpu, volume);
    let scale = volume.layout.distance_scale();
    let dpath = dir.join("distance.png");
    let grey: Vec<u8> = distance.texels.iter().flat_map(|d| [distance_grey(*d, scale); 3]).collect();
    save_rgb(&dpath, distance.size, &grey)?;
    let rays = read_rays(gpu, volume);
    let m = volume.settings.rays_per_probe;
    let probes = volume.layout.probe_count;
    let rpath = dir.join("ray_directions.png");
    // Row p: probe p's rays of the last frame (packed: they start at its ray offset), black after.
    let mut rgb = vec![0u8; (m * probes * 3) as usize];
    for (p, data) in volume.probe_data.iter().enumerate().take(probes as usize) {
        for r in 0..data.ray_count.min(m) {
            let Some(ray) = rays.get((data.ray_offset + r) as usize) else { break };
            let texel = (p * m as usize + r as usize) * 3;
            rgb[texel..texel + 3].copy_from_slice(&ray.direction.map(|c| ((c * 0.5 + 0.5).clamp(0.0, 1.0) * 255.0) as u8));
        }
    }
    save_rgb(&rpath, UVec2::new(m, probes), &rgb)?;
    let ppath = dir.join("probes.csv");
    std::fs::write(&ppath, probes_csv(volume)).map_err(|e| format!("{}: {e}", ppath.display()))?;
    Ok(vec![path, exr, dpath, rpath, ppath])
}

/// The probes of `volume` as CSV, one row each, as of the last probe readback: `index, gx, gy, gz`
/// (grid coordinates), `x, y, z` (world position in render space, relocation included), `ox, oy,
/// oz` (the relocation offset), `inactive, relocated, empty` (state bits as 0/1), `luma`, `rays`.
pub fn probes_csv(volume: &VolumeGpu) -> String {
    use crate::gpu::{PROBE_EMPTY, PROBE_INACTIVE, PROBE_RELOCATED};
    let layout = &volume.layout;
    let mut csv = String::from("index,gx,gy,gz,x,y,z,ox,oy,oz,inactive,relocated,empty,luma,rays\n");
    for (i, data) in volume.probe_data.iter().enumerate().take(layout.probe_count as usize) {
        let index = i as u32;
        let grid = layout.probe_grid(index);
        let offset = Vec3::from(data.offset);
        let p = layout.grid_position(index) + offset;
        let bit = |b: u32| u32::from(data.state & b != 0);
        csv += &format!(
            "{index},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            grid.x,
            grid.y,
            grid.z,
            p.x,
            p.y,
            p.z,
            offset.x,
            offset.y,
            offset.z,
            bit(PROBE_INACTIVE),
            bit(PROBE_RELOCATED),
            bit(PROBE_EMPTY),
            data.luma,
            data.ray_count
        );
    }
    csv
}

//! The texture atlases of the scene on the GPU: every image shelf-packed into one texture.

use crate::gpu::GpuContext;
use crate::scene::Image;

/// A texture holding `packed`: sRGB-encoded colour (decoded by the sampler) or linear data.
pub(super) fn create_atlas_texture(gpu: &GpuContext, packed: &PackedAtlas, format: wgpu::TextureFormat) -> wgpu::Texture {
    let size = wgpu::Extent3d { width: packed.width, height: packed.height, depth_or_array_layers: 1 };
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(if format.is_srgb() { "texture_atlas" } else { "data_atlas" }),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    gpu.queue.write_texture(
        texture.as_image_copy(),
        &packed.rgba8,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(packed.width * 4), rows_per_image: None },
        size,
    );
    texture
}

/// Every image of the scene packed into one texture, so that raster and compute passes sample any
/// texture through one binding.
pub(crate) struct PackedAtlas {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The texels, RGBA8 row-major from the top-left.
    pub rgba8: Vec<u8>,
    /// Per image: (x, y, width, height) in atlas coordinates [0, 1].
    pub rects: Vec<[f32; 4]>,
}

/// Shelf-packs images (tallest first) into an atlas at most `max_dim` on a side, halving every image
/// until they fit when they do not.
pub(crate) fn pack_atlas(images: &[&Image], max_dim: u32) -> PackedAtlas {
    let mut scale_down = 0u32;
    loop {
        let sizes: Vec<(u32, u32)> = images.iter().map(|i| ((i.width >> scale_down).max(1), (i.height >> scale_down).max(1))).collect();
        if let Some(layout) = shelf_pack(&sizes, max_dim) {
            return fill_atlas(images, &sizes, layout);
        }
        scale_down += 1;
        log::warn!("texture atlas: images do not fit in {max_dim}², halving them (÷{})", 1 << scale_down);
    }
}

struct ShelfLayout {
    width: u32,
    height: u32,
    origins: Vec<(u32, u32)>,
}

fn shelf_pack(sizes: &[(u32, u32)], max_dim: u32) -> Option<ShelfLayout> {
    const PAD: u32 = 1;
    let width = sizes.iter().map(|s| s.0 + 2 * PAD).max().unwrap_or(1).max(1024).min(max_dim);
    if sizes.iter().any(|s| s.0 + 2 * PAD > width) {
        return None;
    }
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(sizes[i].1));
    let mut origins = vec![(0, 0); sizes.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for i in order {
        let (w, h) = (sizes[i].0 + 2 * PAD, sizes[i].1 + 2 * PAD);
        if x + w > width {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        origins[i] = (x + PAD, y + PAD);
        x += w;
        shelf = shelf.max(h);
    }
    let height = (y + shelf).max(1);
    (height <= max_dim).then_some(ShelfLayout { width, height, origins })
}

fn fill_atlas(images: &[&Image], sizes: &[(u32, u32)], layout: ShelfLayout) -> PackedAtlas {
    let (aw, ah) = (layout.width, layout.height);
    let mut rgba8 = vec![255u8; (aw * ah * 4) as usize];
    let mut rects = Vec::with_capacity(images.len());
    for ((image, &(w, h)), &(ox, oy)) in images.iter().zip(sizes).zip(&layout.origins) {
        let pixel = |x: u32, y: u32| -> [u8; 4] {
            // Nearest sample of the (possibly halved) image; out-of-range data reads as white.
            let sx = (x * image.width.max(1) / w).min(image.width.saturating_sub(1));
            let sy = (y * image.height.max(1) / h).min(image.height.saturating_sub(1));
            let i = ((sy * image.width + sx) * 4) as usize;
            image.rgba8.get(i..i + 4).and_then(|s| s.try_into().ok()).unwrap_or([255; 4])
        };
        // One texel of padding around each image repeats its edge, so bilinear taps stay inside.
        for y in 0..h + 2 {
            for x in 0..w + 2 {
                let (dx, dy) = (ox + x - 1, oy + y - 1);
                let p = pixel(x.saturating_sub(1).min(w - 1), y.saturating_sub(1).min(h - 1));
                let o = ((dy * aw + dx) * 4) as usize;
                rgba8[o..o + 4].copy_from_slice(&p);
            }
        }
        rects.push([ox as f32 / aw as f32, oy as f32 / ah as f32, w as f32 / aw as f32, h as f32 / ah as f32]);
    }
    PackedAtlas { width: aw, height: ah, rgba8, rects }
}

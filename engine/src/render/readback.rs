//! Copying textures back to the CPU (headless output, tests).

use crate::gpu::GpuContext;

/// Reads a whole 2D texture of a non-block format into tightly packed rows.
pub fn read_texture(gpu: &GpuContext, texture: &wgpu::Texture) -> Vec<u8> {
    let (width, height) = (texture.width(), texture.height());
    let texel = texture.format().block_copy_size(None).expect("a colour format");
    let row = width * texel;
    let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("texture_readback"),
        size: u64::from(padded) * u64::from(height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("texture_readback") });
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: None },
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    gpu.queue.submit([encoder.finish()]);
    buffer.slice(..).map_async(wgpu::MapMode::Read, |r| {
        if let Err(e) = r {
            log::error!("texture readback failed: {e}");
        }
    });
    gpu.wait_idle();
    let mapped = buffer.slice(..).get_mapped_range().expect("the readback buffer was mapped");
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        let start = y * padded as usize;
        out.extend_from_slice(&mapped[start..start + row as usize]);
    }
    drop(mapped);
    buffer.unmap();
    out
}

/// Reads an `Rgba32Float` texture as floats.
pub fn read_rgba32f(gpu: &GpuContext, texture: &wgpu::Texture) -> Vec<f32> {
    assert_eq!(texture.format(), wgpu::TextureFormat::Rgba32Float, "read_rgba32f needs an Rgba32Float texture");
    bytemuck::pod_collect_to_vec(&read_texture(gpu, texture))
}

/// Reads a whole buffer (it needs `COPY_SRC` usage). Blocks until the GPU is idle.
pub fn read_buffer(gpu: &GpuContext, source: &wgpu::Buffer) -> Vec<u8> {
    let size = source.size();
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("buffer_readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("buffer_readback") });
    encoder.copy_buffer_to_buffer(source, 0, &buffer, 0, size);
    gpu.queue.submit([encoder.finish()]);
    buffer.slice(..).map_async(wgpu::MapMode::Read, |r| {
        if let Err(e) = r {
            log::error!("buffer readback failed: {e}");
        }
    });
    gpu.wait_idle();
    let out = buffer.slice(..).get_mapped_range().expect("the readback buffer was mapped").to_vec();
    buffer.unmap();
    out
}

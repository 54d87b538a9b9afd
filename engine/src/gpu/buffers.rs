//! GPU buffers the engine's modules share: the adapter's storage-buffer limit, [`GrowableBuffer`]
//! (a buffer that grows with its contents) and [`Uploads`] (small scattered updates staged through
//! one encoder).

use bevy_ecs::prelude::*;

use super::GpuContext;

/// The largest storage buffer the adapter binds (bytes): `min(max_storage_buffer_binding_size,
/// max_buffer_size)`.
pub fn max_storage_buffer_bytes(device: &wgpu::Device) -> u64 {
    let l = device.limits();
    l.max_storage_buffer_binding_size.min(l.max_buffer_size)
}

/// A storage or uniform buffer that grows when its contents do. Never empty: an empty array is
/// bound as one zeroed element, so shaders can always bind it.
pub(crate) struct GrowableBuffer {
    /// The current buffer; replaced (its contents not kept) when a write grows it.
    pub buffer: wgpu::Buffer,
    label: &'static str,
    usage: wgpu::BufferUsages,
}

impl GrowableBuffer {
    /// A 256-byte buffer of `usage` (plus `COPY_DST`).
    pub fn new(device: &wgpu::Device, label: &'static str, usage: wgpu::BufferUsages) -> Self {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: 256, usage, mapped_at_creation: false });
        Self { buffer, label, usage }
    }

    /// Writes `bytes` at offset 0, reallocating (and returning true) when the buffer is too small.
    pub fn write(&mut self, gpu: &GpuContext, bytes: &[u8]) -> bool {
        let needed = (bytes.len() as u64).max(256).next_multiple_of(4);
        let grew = needed > self.buffer.size();
        if grew {
            // Doubling, but never past what the adapter can bind when the data itself fits.
            let limit = max_storage_buffer_bytes(&gpu.device) / 4 * 4;
            let size = needed.next_power_of_two().min(limit.max(needed));
            self.buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(self.label),
                size,
                usage: self.usage,
                mapped_at_creation: false,
            });
        }
        if !bytes.is_empty() {
            gpu.queue.write_buffer(&self.buffer, 0, bytes);
        }
        grew
    }
}

/// Changed elements whose gap is at most this many bytes are uploaded in one copy, with the
/// unchanged ones between them.
const MERGE_GAP_BYTES: usize = 1024;

/// Small scattered buffer updates, staged through a [`wgpu::util::StagingBelt`] and recorded as
/// copies in one encoder that the render stage submits first
/// ([`flush_uploads`](crate::render::gpu_scene::flush_uploads)). Cheaper than one
/// `queue.write_buffer` (each a staging allocation) per changed range.
#[derive(Resource)]
pub struct Uploads {
    belt: wgpu::util::StagingBelt,
    encoder: Option<wgpu::CommandEncoder>,
    /// Encoders submitted so far ([`Uploads::submissions`]).
    submitted: u64,
}

impl Uploads {
    /// An empty queue of uploads with a 1 MiB staging belt.
    pub fn new(gpu: &GpuContext) -> Self {
        Self { belt: wgpu::util::StagingBelt::new(gpu.device.clone(), 1 << 20), encoder: None, submitted: 0 }
    }

    /// Copies `bytes` (a multiple of 4 long) to `buffer` at `offset` before this frame's passes run.
    pub fn write(&mut self, gpu: &GpuContext, buffer: &wgpu::Buffer, offset: u64, bytes: &[u8]) {
        let Some(size) = wgpu::BufferSize::new(bytes.len() as u64) else { return };
        let encoder = self
            .encoder
            .get_or_insert_with(|| gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("uploads") }));
        self.belt.write_buffer(encoder, buffer, offset, size).copy_from_slice(bytes);
    }

    /// The encoder the copies are recorded in (created if none is yet), for GPU work that must follow
    /// this frame's uploads and precede its passes (the TLAS refit on the GPU): what is recorded in it
    /// after a copy runs after that copy.
    pub fn encoder(&mut self, gpu: &GpuContext) -> &mut wgpu::CommandEncoder {
        self.encoder.get_or_insert_with(|| gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("uploads") }))
    }

    /// Uploads the elements of `data` listed in `dirty` (sorted and deduplicated here) to `buffer`:
    /// runs less than 1 KiB apart are merged, and when the runs cover most of the array it
    /// is copied whole.
    pub fn write_dirty_ranges<T: bytemuck::Pod>(&mut self, gpu: &GpuContext, buffer: &wgpu::Buffer, data: &[T], dirty: &mut Vec<usize>) {
        dirty.sort_unstable();
        dirty.dedup();
        let gap = (MERGE_GAP_BYTES / size_of::<T>().max(1)).max(1);
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for &i in dirty.iter().filter(|&&i| i < data.len()) {
            match runs.last_mut() {
                Some((_, end)) if i <= *end + gap => *end = i + 1,
                _ => runs.push((i, i + 1)),
            }
        }
        let covered: usize = runs.iter().map(|(a, b)| b - a).sum();
        if covered * 2 > data.len() {
            runs = vec![(0, data.len())];
        }
        let size = size_of::<T>() as u64;
        for (a, b) in runs {
            self.write(gpu, buffer, a as u64 * size, bytemuck::cast_slice(&data[a..b]));
        }
    }

    /// Submits the recorded copies (render stage, before any pass).
    pub fn flush(&mut self, gpu: &GpuContext) {
        if let Some(encoder) = self.encoder.take() {
            self.belt.finish();
            gpu.queue.submit([encoder.finish()]);
            self.belt.recall();
            self.submitted += 1;
        }
    }

    /// How many encoders [`Uploads::flush`] has submitted: what was recorded in
    /// [`Uploads::encoder`] while this read `n` has been submitted once it reads more than `n`
    /// (a buffer copied into there may then be mapped).
    pub fn submissions(&self) -> u64 {
        self.submitted
    }
}

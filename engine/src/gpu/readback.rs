//! Copying GPU data back to the CPU: blocking reads of a texture or buffer (headless output, tests,
//! tools) and [`ReadbackRing`], the asynchronous ring that per-frame mirrors use.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use crate::gpu::GpuContext;

/// Reads a whole 2D texture of a non-block format into tightly packed rows. Blocks until the GPU is idle.
pub fn read_texture(gpu: &GpuContext, texture: &wgpu::Texture) -> Vec<u8> {
    let (width, height) = (texture.width(), texture.height());
    let texel = texture.format().block_copy_size(None).expect("a colour format");
    let row = width * texel;
    let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let mapped = read_now(gpu, "texture_readback", u64::from(padded) * u64::from(height), |encoder, buffer| {
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: None },
            },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
    });
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        let start = y * padded as usize;
        out.extend_from_slice(&mapped[start..start + row as usize]);
    }
    out
}

/// Reads an `Rgba32Float` texture as floats.
pub fn read_rgba32f(gpu: &GpuContext, texture: &wgpu::Texture) -> Vec<f32> {
    assert_eq!(texture.format(), wgpu::TextureFormat::Rgba32Float, "read_rgba32f needs an Rgba32Float texture");
    bytemuck::pod_collect_to_vec(&read_texture(gpu, texture))
}

/// Reads a whole buffer (it needs `COPY_SRC` usage). Blocks until the GPU is idle.
pub fn read_buffer(gpu: &GpuContext, source: &wgpu::Buffer) -> Vec<u8> {
    read_now(gpu, "buffer_readback", source.size(), |encoder, buffer| encoder.copy_buffer_to_buffer(source, 0, buffer, 0, source.size()))
}

/// A one-slot [`ReadbackRing`] filled by `copy`, waited for.
fn read_now(gpu: &GpuContext, label: &'static str, size: u64, copy: impl FnOnce(&mut wgpu::CommandEncoder, &wgpu::Buffer)) -> Vec<u8> {
    let _span = tracing::info_span!("readback", buffer = label, bytes = size).entered();
    let mut ring = ReadbackRing::new(label, 1);
    ring.request_with(gpu, size, 0, copy);
    gpu.wait_idle();
    ring.poll(gpu).pop().map(|(_, bytes)| bytes).unwrap_or_else(|| panic!("{label}: the readback copy was not mapped"))
}

// ---------------------------------------------------------------------------------------------
// Asynchronous readback: nothing waits.

const SLOT_IDLE: u8 = 0;
const SLOT_PENDING: u8 = 1;
const SLOT_READY: u8 = 2;
/// Its copy is recorded in a caller's encoder ([`ReadbackRing::record`]), not yet submitted.
const SLOT_RECORDED: u8 = 3;

struct ReadbackSlot {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
    frame: u64,
    /// With [`SLOT_RECORDED`]: the caller's submission count when the copy was recorded; the slot
    /// is mapped once a later count is seen ([`ReadbackRing::poll_recorded`]).
    recorded_at: u64,
}

/// A ring of mappable copies of a buffer, for state the CPU mirrors a few frames late (DDGI's probe
/// states and counters): a copy is requested per frame while a slot is free, and read when the GPU
/// has filled it. Nothing waits; a frame whose slots are all in flight is skipped.
pub struct ReadbackRing {
    label: &'static str,
    capacity: usize,
    slots: Vec<ReadbackSlot>,
}

impl ReadbackRing {
    /// A ring of `capacity` copies (made at the first request, as large as the source; made anew
    /// when the source's size changes).
    pub fn new(label: &'static str, capacity: usize) -> Self {
        Self { label, capacity, slots: Vec::new() }
    }

    /// Copies `source` (which needs `COPY_SRC`) into a free slot, tagged with `frame`.
    pub fn request(&mut self, gpu: &GpuContext, source: &wgpu::Buffer, frame: u64) {
        let size = source.size();
        self.request_with(gpu, size, frame, |encoder, slot| encoder.copy_buffer_to_buffer(source, 0, slot, 0, size.min(slot.size())));
    }

    /// Fills a free slot of `size` bytes with the commands `copy` records (a buffer or texture
    /// copy into the slot's buffer), tagged with `frame`.
    pub fn request_with(&mut self, gpu: &GpuContext, size: u64, frame: u64, copy: impl FnOnce(&mut wgpu::CommandEncoder, &wgpu::Buffer)) {
        let label = self.label;
        let Some(slot) = self.idle_slot(gpu, size) else { return };
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
        copy(&mut encoder, &slot.buffer);
        gpu.queue.submit([encoder.finish()]);
        slot.frame = frame;
        map_slot(slot);
    }

    /// Records a copy of `source` (which needs `COPY_SRC`) into a free slot, tagged with `frame`, in
    /// the caller's `encoder` (no submit of its own), whose submissions the caller counts: the
    /// count is `submissions` now. The slot is mapped by [`ReadbackRing::poll_recorded`] once the
    /// count has moved on. Returns whether a slot was free.
    pub fn record(
        &mut self,
        gpu: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        frame: u64,
        submissions: u64,
    ) -> bool {
        let size = source.size();
        let Some(slot) = self.idle_slot(gpu, size) else { return false };
        encoder.copy_buffer_to_buffer(source, 0, &slot.buffer, 0, size);
        slot.frame = frame;
        slot.recorded_at = submissions;
        slot.state.store(SLOT_RECORDED, Ordering::Release);
        true
    }

    /// [`ReadbackRing::record`]'s counterpart of [`ReadbackRing::poll`]: maps the recorded copies
    /// whose encoder has been submitted (the caller's count is now `submissions`) and returns
    /// every copy that has arrived, oldest first. Polls the device only while a map asked for
    /// earlier is outstanding.
    pub fn poll_recorded(&mut self, gpu: &GpuContext, submissions: u64) -> Vec<(u64, Vec<u8>)> {
        if self.slots.iter().any(|s| s.state.load(Ordering::Acquire) == SLOT_PENDING) {
            let _ = gpu.device.poll(wgpu::PollType::Poll);
        }
        let out = self.take_arrived();
        for slot in self.slots.iter_mut().filter(|s| s.state.load(Ordering::Acquire) == SLOT_RECORDED && submissions > s.recorded_at) {
            map_slot(slot);
        }
        out
    }

    /// A free slot of `size` bytes (the ring made at the first request, and made anew when the
    /// size changes).
    fn idle_slot(&mut self, gpu: &GpuContext, size: u64) -> Option<&mut ReadbackSlot> {
        if self.slots.first().is_some_and(|s| s.buffer.size() != size) {
            // The source changed size: copies of the old size still in flight are dropped.
            self.slots.clear();
        }
        if self.slots.is_empty() {
            self.slots = (0..self.capacity)
                .map(|_| ReadbackSlot {
                    buffer: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some(self.label),
                        size,
                        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    }),
                    state: Arc::new(AtomicU8::new(SLOT_IDLE)),
                    frame: 0,
                    recorded_at: 0,
                })
                .collect();
        }
        self.slots.iter_mut().find(|s| s.state.load(Ordering::Acquire) == SLOT_IDLE)
    }

    /// Every copy that has arrived, as (frame, bytes), oldest first.
    pub fn poll(&mut self, gpu: &GpuContext) -> Vec<(u64, Vec<u8>)> {
        let _ = gpu.device.poll(wgpu::PollType::Poll);
        self.take_arrived()
    }

    /// The copies mapped since the last look, as (frame, bytes), oldest first; their slots freed.
    fn take_arrived(&mut self) -> Vec<(u64, Vec<u8>)> {
        let mut out = Vec::new();
        for slot in &mut self.slots {
            if slot.state.load(Ordering::Acquire) != SLOT_READY {
                continue;
            }
            if let Ok(view) = slot.buffer.slice(..).get_mapped_range() {
                out.push((slot.frame, view.to_vec()));
            }
            slot.buffer.unmap();
            slot.state.store(SLOT_IDLE, Ordering::Release);
        }
        out.sort_by_key(|(f, _)| *f);
        out
    }
}

/// Asks for `slot`'s buffer to be mapped (its copy submitted); the callback marks it ready, or idle
/// when the map failed.
fn map_slot(slot: &mut ReadbackSlot) {
    slot.state.store(SLOT_PENDING, Ordering::Release);
    let flag = slot.state.clone();
    slot.buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        flag.store(if r.is_ok() { SLOT_READY } else { SLOT_IDLE }, Ordering::Release);
    });
}

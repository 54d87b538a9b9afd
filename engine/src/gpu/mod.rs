//! The GPU plumbing every other module builds on: the context (adapter choice, device and queue:
//! [`GpuContext`]), shared buffers (`GrowableBuffer`, [`Uploads`], the storage-buffer limit),
//! reading GPU data back ([`readback`]) and recording a compute dispatch ([`dispatch`]).

mod buffers;
mod context;
pub mod readback;

pub(crate) use buffers::GrowableBuffer;
pub use buffers::{Uploads, max_storage_buffer_bytes};
pub use context::{GpuContext, GpuError, GpuOptions, ValidationErrors};

/// Records one compute pass with the given bind groups (0, 1, …).
pub fn dispatch(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    (x, y): (u32, u32),
) {
    let mut cp = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
    cp.set_pipeline(pipeline);
    for (i, g) in groups.iter().enumerate() {
        cp.set_bind_group(i as u32, *g, &[]);
    }
    cp.dispatch_workgroups(x.max(1), y.max(1), 1);
}

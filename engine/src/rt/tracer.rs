//! Arbitrary rays traced on the GPU ([`RayTracer`], `trace_rays.wgsl`) for the CPU-reference tests
//! and the trace benchmark, and the workgroup split the ray shaders expect.

use super::{RayTracingScene, cpu};
use crate::gpu::GpuContext;
use crate::render::GpuScene;

/// Traces arbitrary rays with `engine/shaders/trace_rays.wgsl`: the GPU side of the CPU-reference tests and
/// of the trace benchmark.
pub struct RayTracer {
    /// The `trace_rays` compute pipeline and its bindings.
    pub program: crate::shader::Program<wgpu::ComputePipeline>,
}

/// Workgroups of 64 threads covering `count` items, split into (x ≤ 65535, y) as the shader expects.
pub fn ray_workgroups(count: u32) -> (u32, u32) {
    let groups = count.div_ceil(64).max(1);
    (groups.min(65535), groups.div_ceil(65535))
}

impl RayTracer {
    /// Builds the pipeline of `trace_rays.wgsl`.
    pub fn new(gpu: &GpuContext) -> Result<Self, crate::shader::ShaderError> {
        Ok(Self { program: crate::shader::compute_program(&gpu.device, "trace_rays.wgsl", "main", "trace_rays")? })
    }

    /// Bind groups for tracing `rays` into `results` (both storage buffers) with `params` (uniform).
    pub fn bind_groups(
        &self,
        gpu: &GpuContext,
        scene: &GpuScene,
        rt: &RayTracingScene,
        params: &wgpu::Buffer,
        rays: &wgpu::Buffer,
        results: &wgpu::Buffer,
    ) -> [wgpu::BindGroup; 2] {
        [
            self.program.bind_group(&gpu.device, 0, &rt.scene_bindings(scene)),
            self.program.bind_group(
                &gpu.device,
                1,
                &[
                    ("trace_params", params.as_entire_binding()),
                    ("trace_rays", rays.as_entire_binding()),
                    ("trace_results", results.as_entire_binding()),
                ],
            ),
        ]
    }

    /// Traces `rays` (closest hit, and any hit when asked) and reads the results back. Blocks.
    pub fn trace(
        &self,
        gpu: &GpuContext,
        scene: &GpuScene,
        rt: &RayTracingScene,
        rays: &[cpu::GpuRay],
        with_any_hit: bool,
    ) -> Vec<cpu::TraceResult> {
        use wgpu::util::DeviceExt;
        let count = rays.len() as u32;
        let params = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("trace_params"),
            contents: bytemuck::cast_slice(&[count, u32::from(with_any_hit), 0, 0]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let ray_buffer = gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("trace_rays"),
            contents: if rays.is_empty() { &[0; 32] } else { bytemuck::cast_slice(rays) },
            usage: wgpu::BufferUsages::STORAGE,
        });
        let size = (rays.len().max(1) * size_of::<cpu::TraceResult>()) as u64;
        let results = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace_results"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("trace_results_readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let groups = self.bind_groups(gpu, scene, rt, &params, &ray_buffer, &results);
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("trace_rays") });
        crate::gpu::dispatch(&mut encoder, "trace_rays", &self.program.pipeline, &[&groups[0], &groups[1]], ray_workgroups(count));
        encoder.copy_buffer_to_buffer(&results, 0, &readback, 0, size);
        gpu.queue.submit([encoder.finish()]);
        readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        gpu.wait_idle();
        let mapped = readback.slice(..).get_mapped_range().expect("mapped after wait");
        let mut out: Vec<cpu::TraceResult> = bytemuck::pod_collect_to_vec(&mapped);
        drop(mapped);
        readback.unmap();
        out.truncate(rays.len());
        out
    }
}

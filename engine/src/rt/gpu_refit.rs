//! The TLAS refit on the GPU ([`super::TlasRefit::Gpu`]): the buffers and dispatches of
//! `engine/shaders/tlas_refit.wgsl`. The binary TLAS's topology (inner nodes, leaves, parents) and
//! the wide nodes' sources and children are uploaded once per TLAS build, with every node's box;
//! a refit then uploads only the moved leaves' boxes (32 bytes each) and a 16-byte count. The
//! refit also sums the TLAS's SAH cost; every [`TLAS_GPU_COST_READ_EVERY`] refits a copy of the sum
//! rides in the uploads' encoder and the CPU maps it a frame or two later
//! ([`GpuRefit::poll_cost`]), to decide on a rebuild without refitting its own copy.

use std::time::Duration;

use bytemuck::{Pod, Zeroable};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use wgpu::util::DeviceExt;

use super::{NONE, ray_workgroups};
use crate::gpu::GpuContext;
use crate::gpu::Uploads;
use crate::gpu::readback::ReadbackRing;
use crate::shader::{Program, ShaderError, compute_program};

/// The label of the refit's compute pass (and its pipelines').
pub const TLAS_REFIT_PASS: &str = "tlas_refit";

/// Fixed-point units in one node's share of the SAH cost that the refit sums (its half area over
/// the root's, at most 1). Mirrors WGSL `COST_SCALE`.
pub const TLAS_REFIT_COST_SCALE: u32 = 1 << 20;

/// The GPU refit's SAH cost is read back once every this many refits: often enough that a TLAS whose
/// quality decayed is rebuilt a few frames late (its bounds exact meanwhile: no hit is missed), and
/// rarely enough that mapping the copy costs the CPU little per frame.
pub const TLAS_GPU_COST_READ_EVERY: u32 = 4;

/// The GPU refit's counts for this frame. Mirrors WGSL `TlasRefitParams`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Eq)]
pub struct TlasRefitParams {
    /// Moved leaves in `tlas_refit_moved`.
    pub moved: u32,
    /// Inner nodes of the binary TLAS.
    pub inner: u32,
    /// Leaves of the binary TLAS.
    pub leaves: u32,
    /// Wide nodes.
    pub wide: u32,
}

/// A moved leaf's world box, as order-preserving integers ([`to_ordered`]). Mirrors WGSL
/// `TlasRefitLeaf`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq, Eq)]
pub struct TlasRefitLeaf {
    /// The box's minimum.
    pub lo: [u32; 3],
    /// The Bvh2 leaf node.
    pub leaf: u32,
    /// The box's maximum.
    pub hi: [u32; 3],
    pub _pad: u32,
}

impl TlasRefitLeaf {
    /// Leaf `leaf` with box `aabb`.
    pub fn new(leaf: u32, aabb: &Aabb) -> Self {
        let (lo, hi) = node_box(aabb);
        Self { lo, hi, leaf, _pad: 0 }
    }
}

/// A float as an integer of the same order (for the shader's atomicMin/atomicMax): positive
/// floats with the sign bit set, negative ones inverted.
pub fn to_ordered(f: f32) -> u32 {
    let b = f.to_bits();
    if b & 0x8000_0000 != 0 { !b } else { b | 0x8000_0000 }
}

/// The cost's fixed-point sum (low word, high word) as a number.
fn cost_from_bytes(bytes: &[u8]) -> Option<f64> {
    let [low, high]: [u32; 2] = bytemuck::pod_read_unaligned(bytes.get(..8)?);
    Some(((u64::from(high) << 32) | u64::from(low)) as f64 / f64::from(TLAS_REFIT_COST_SCALE))
}

fn node_box(aabb: &Aabb) -> ([u32; 3], [u32; 3]) {
    (aabb.min.to_array().map(to_ordered), aabb.max.to_array().map(to_ordered))
}

/// The refit's pipelines and buffers.
pub(super) struct GpuRefit {
    /// `clear_and_scatter`, `propagate`, `measure`, `encode`.
    programs: [Program<wgpu::ComputePipeline>; 4],
    params: wgpu::Buffer,
    /// The SAH cost's fixed-point sum (two words), and its copies for the CPU, each tagged with the
    /// TLAS it measured ([`GpuRefit::poll_cost`]).
    cost: wgpu::Buffer,
    cost_readback: ReadbackRing,
    /// Counts the TLASes loaded.
    generation: u64,
    /// Refits recorded since a copy of the cost was last recorded.
    refits_since_copy: u32,
    /// The moved leaves of a frame; grown (by doubling) when a frame has more.
    moved: wgpu::Buffer,
    /// Everything else, sized for the TLAS at [`GpuRefit::load`].
    tlas: Option<TlasBuffers>,
    counts: TlasRefitParams,
}

/// The buffers of one TLAS, and the bind groups over them.
struct TlasBuffers {
    inner: wgpu::Buffer,
    leaves: wgpu::Buffer,
    parents: wgpu::Buffer,
    wide: wgpu::Buffer,
    boxes: wgpu::Buffer,
    groups: Option<[wgpu::BindGroup; 4]>,
}

impl GpuRefit {
    /// Builds the four pipelines of `tlas_refit.wgsl`.
    pub fn new(gpu: &GpuContext) -> Result<Self, ShaderError> {
        let program = |entry: &str| compute_program(&gpu.device, "tlas_refit.wgsl", entry, TLAS_REFIT_PASS);
        let programs = [program("clear_and_scatter")?, program("propagate")?, program("measure")?, program("encode")?];
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Ok(Self {
            programs,
            params: buffer("tlas_refit_params", size_of::<TlasRefitParams>() as u64, wgpu::BufferUsages::UNIFORM),
            cost: buffer("tlas_refit_cost", 8, wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC),
            cost_readback: ReadbackRing::new("tlas_refit_cost_readback", 2),
            generation: 0,
            refits_since_copy: 0,
            moved: buffer("tlas_refit_moved", 1024 * size_of::<TlasRefitLeaf>() as u64, wgpu::BufferUsages::STORAGE),
            tlas: None,
            counts: TlasRefitParams::zeroed(),
        })
    }

    /// Uploads a TLAS: its inner nodes, leaves and parents, each wide node's source and children
    /// (`NONE` for an empty slot), and every node's current box.
    pub fn load(&mut self, gpu: &GpuContext, bvh: &Bvh2, wide_source: &[u32], wide_children: &[[u32; 8]], tlas_nodes: &wgpu::Buffer) {
        let (mut inner, mut leaves) = (Vec::new(), Vec::new());
        let mut boxes: Vec<[u32; 8]> = Vec::with_capacity(bvh.nodes.len());
        for (i, node) in bvh.nodes.iter().enumerate() {
            if node.is_leaf() { &mut leaves } else { &mut inner }.push(i as u32);
            let (lo, hi) = node_box(node.aabb());
            boxes.push([lo[0], lo[1], lo[2], 0, hi[0], hi[1], hi[2], 0]);
        }
        let parents: Vec<u32> = (0..bvh.nodes.len()).map(|i| if i == 0 { NONE } else { bvh.parents[i] }).collect();
        let wide: Vec<u32> =
            wide_source.iter().zip(wide_children).flat_map(|(&s, c)| std::iter::once(s).chain(c.iter().copied())).collect();
        let storage = |label: &str, words: &[u32]| {
            gpu.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                // A binding is never empty.
                contents: bytemuck::cast_slice(if words.is_empty() { &[0u32] } else { words }),
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        self.generation += 1;
        self.counts = TlasRefitParams { moved: 0, inner: inner.len() as u32, leaves: leaves.len() as u32, wide: wide_source.len() as u32 };
        let mut tlas = TlasBuffers {
            inner: storage("tlas_refit_inner", &inner),
            leaves: storage("tlas_refit_leaves", &leaves),
            parents: storage("tlas_refit_parents", &parents),
            wide: storage("tlas_refit_wide", &wide),
            boxes: storage("tlas_refit_boxes", bytemuck::cast_slice(&boxes)),
            groups: None,
        };
        tlas.groups = Some(self.bind_groups(gpu, &tlas, tlas_nodes));
        self.tlas = Some(tlas);
    }

    fn bind_groups(&self, gpu: &GpuContext, tlas: &TlasBuffers, tlas_nodes: &wgpu::Buffer) -> [wgpu::BindGroup; 4] {
        let resources = [
            ("tlas_refit_params", self.params.as_entire_binding()),
            ("tlas_refit_moved", self.moved.as_entire_binding()),
            ("tlas_refit_inner", tlas.inner.as_entire_binding()),
            ("tlas_refit_leaves", tlas.leaves.as_entire_binding()),
            ("tlas_refit_parents", tlas.parents.as_entire_binding()),
            ("tlas_refit_wide", tlas.wide.as_entire_binding()),
            ("tlas_refit_boxes", tlas.boxes.as_entire_binding()),
            ("tlas_nodes", tlas_nodes.as_entire_binding()),
            ("tlas_refit_cost", self.cost.as_entire_binding()),
        ];
        self.programs.each_ref().map(|p| p.bind_group(&gpu.device, 0, &resources))
    }

    /// Stages `leaves` and this frame's counts in `uploads` and records the refit's pass after them.
    pub fn record(&mut self, gpu: &GpuContext, uploads: &mut Uploads, leaves: &[TlasRefitLeaf], tlas_nodes: &wgpu::Buffer) {
        let bytes: &[u8] = bytemuck::cast_slice(leaves);
        if bytes.len() as u64 > self.moved.size() {
            self.moved = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tlas_refit_moved"),
                size: (bytes.len() as u64).next_power_of_two(),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            if let Some(tlas) = &self.tlas {
                let groups = self.bind_groups(gpu, tlas, tlas_nodes);
                self.tlas.as_mut().expect("loaded").groups = Some(groups);
            }
        }
        self.counts.moved = leaves.len() as u32;
        uploads.write(gpu, &self.moved, 0, bytes);
        uploads.write(gpu, &self.params, 0, bytemuck::bytes_of(&self.counts));
        let submissions = uploads.submissions();
        let encoder = uploads.encoder(gpu);
        self.dispatch(encoder);
        // Every few refits, a copy of the cost for the CPU after the dispatches (no submit of its own).
        self.refits_since_copy += 1;
        if self.refits_since_copy >= TLAS_GPU_COST_READ_EVERY
            && self.cost_readback.record(gpu, encoder, &self.cost, self.generation, submissions)
        {
            self.refits_since_copy = 0;
        }
    }

    /// The SAH cost (the summed half areas of the binary TLAS's inner nodes over its root's) that an
    /// earlier GPU refit of this TLAS measured, when a reading of it has arrived since the last call
    /// (readings of an earlier TLAS are dropped). Maps the copies whose encoder has been submitted.
    /// Nothing waits: a reading is a frame or two old.
    pub fn poll_cost(&mut self, gpu: &GpuContext, uploads: &Uploads) -> Option<f64> {
        let arrived = self.cost_readback.poll_recorded(gpu, uploads.submissions());
        let (_, bytes) = arrived.into_iter().rev().find(|(generation, _)| *generation == self.generation)?;
        cost_from_bytes(&bytes)
    }

    /// The SAH cost the GPU's last refit measured, read now. Blocks until the GPU is idle. For tests.
    pub fn read_cost_now(&self, gpu: &GpuContext) -> Option<f64> {
        cost_from_bytes(&crate::gpu::readback::read_buffer(gpu, &self.cost))
    }

    /// The four dispatches, in one compute pass (wgpu orders their storage accesses).
    fn dispatch(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(groups) = self.tlas.as_ref().and_then(|t| t.groups.as_ref()) else { return };
        let c = self.counts;
        // At least one thread: the first clears the cost's sum.
        let threads = [c.inner.max(c.moved).max(1), c.leaves, c.inner, c.wide];
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(TLAS_REFIT_PASS), timestamp_writes: None });
        for ((program, group), threads) in self.programs.iter().zip(groups).zip(threads) {
            let (x, y) = ray_workgroups(threads);
            pass.set_pipeline(&program.pipeline);
            pass.set_bind_group(0, group, &[]);
            pass.dispatch_workgroups(x, y, 1);
        }
    }

    /// The dispatches of the last refit again, between two timestamps; their GPU time. Blocks.
    pub fn time(&self, gpu: &GpuContext) -> Option<Duration> {
        if !gpu.timestamps {
            return None;
        }
        let queries = gpu.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("tlas_refit_timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let resolve = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tlas_refit_timestamps"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(TLAS_REFIT_PASS) });
        encoder.write_timestamp(&queries, 0);
        self.dispatch(&mut encoder);
        encoder.write_timestamp(&queries, 1);
        encoder.resolve_query_set(&queries, 0..2, &resolve, 0);
        gpu.queue.submit([encoder.finish()]);
        let ticks: [u64; 2] = bytemuck::pod_read_unaligned(crate::gpu::readback::read_buffer(gpu, &resolve).get(..16)?);
        Some(Duration::from_nanos((ticks[1].saturating_sub(ticks[0]) as f64 * f64::from(gpu.timestamp_period)) as u64))
    }
}

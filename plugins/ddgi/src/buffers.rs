//! The one table of a volume's GPU buffers: each by its WGSL name (group 1,
//! `ddgi_common.inc.wgsl`) with its size from the layout, its usage and whether the frame exports
//! it (it lives on into the next frame). The buffers are made from it (`VolumeBuffers::new`),
//! imported into a frame's graph from it ([`crate::VolumeHandles`]) and counted from it
//! ([`crate::VolumeGpu::gpu_resources`]).

use engine::wgpu;
use engine::wgpu::BufferUsages as B;

use crate::gpu::{DdgiCounters, DdgiVolumeGpu, MAX_WAKE_BOXES};
use crate::volume::DdgiLayout;

/// Declares [`VolumeBuffers`] from the table: a field per row, made with its label, size (at least
/// 16 bytes) and usage, and listed by WGSL name in [`VolumeBuffers::entries`].
macro_rules! volume_buffers {
    ($($(#[$doc:meta])* $vis:vis $field:ident: $name:literal, $size:expr, $usage:expr, exported: $exported:literal;)*) => {
        /// The GPU buffers of one volume, by the table in `buffers.rs`.
        pub struct VolumeBuffers {
            $($(#[$doc])* $vis $field: wgpu::Buffer,)*
        }

        impl VolumeBuffers {
            /// Makes every buffer of a volume laid out as `layout`, sized by it.
            pub(crate) fn new(device: &wgpu::Device, layout: &DdgiLayout) -> Self {
                let buffer = |label: &str, size: u64, usage: B| {
                    device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: size.max(16), usage, mapped_at_creation: false })
                };
                Self { $($field: buffer($name, ($size)(layout), $usage),)* }
            }

            /// Every buffer by its WGSL name, in the table's order, with whether the frame exports it.
            pub fn entries(&self) -> Vec<(&'static str, &wgpu::Buffer, bool)> {
                vec![$(($name, &self.$field, $exported),)*]
            }
        }
    };
}

volume_buffers! {
    /// This frame's uniform (WGSL `DdgiVolumeGpu`: grid, settings, ray rotation).
    pub(crate) uniform: "ddgi_volume", |_: &DdgiLayout| size_of::<DdgiVolumeGpu>() as u64, B::UNIFORM | B::COPY_DST, exported: false;
    /// A [`crate::gpu::DdgiProbeData`] per probe, by probe index: offsets, states, errors, ray
    /// counts, pins.
    pub probes: "ddgi_probes", |l: &DdgiLayout| l.sizes.probes, B::STORAGE | B::COPY_SRC | B::COPY_DST, exported: true;
    /// The budget pass's results ([`DdgiCounters`]): the indirect dispatches of the ray passes and
    /// of the per-probe passes, the ray count and the count of probes with rays.
    pub counters: "ddgi_counters", |_: &DdgiLayout| size_of::<DdgiCounters>() as u64, B::STORAGE | B::INDIRECT | B::COPY_SRC, exported: false;
    /// The budget pass's per-block sums (one `DdgiBlock` per 256 probes).
    pub(crate) blocks: "ddgi_blocks", |l: &DdgiLayout| l.sizes.blocks, B::STORAGE, exported: false;
    /// The probes with rays this frame, listed by the budget pass for the per-probe passes: a `u32`
    /// probe index each, in ascending order, the first [`DdgiCounters::updated_probes`] valid.
    pub updated: "ddgi_updated", |l: &DdgiLayout| l.sizes.probe_words, B::STORAGE | B::COPY_SRC, exported: false;
    /// Each probe's luma (−1: switched off) as the budget pass found it, for the dark test.
    pub(crate) lit: "ddgi_lit", |l: &DdgiLayout| l.sizes.probe_words, B::STORAGE, exported: false;
    /// This frame's boxes around movers (two vec4 corners each, [`MAX_WAKE_BOXES`]).
    pub(crate) wake: "ddgi_wake", |_: &DdgiLayout| u64::from(MAX_WAKE_BOXES) * 32, B::STORAGE | B::COPY_DST, exported: false;
    /// The frame's packed probe rays, a [`crate::gpu::DdgiRay`] each ([`crate::atlas::read_rays`]).
    pub(crate) rays: "ddgi_rays", |l: &DdgiLayout| l.sizes.rays, B::STORAGE | B::COPY_SRC, exported: false;
    /// Each ray's shading: radiance (rgb) and stored distance (w: `t`, `−BACKFACE_SCALE · t` for
    /// a back face, `MISS` for a miss).
    pub(crate) radiance: "ddgi_radiance", |l: &DdgiLayout| l.sizes.rays, B::STORAGE | B::COPY_SRC, exported: false;
    /// The persistent trace's closest hits, a [`crate::gpu::DdgiHit`] each
    /// ([`crate::DdgiVolume::persistent_trace`]; 16 bytes, unused, when it is off).
    pub(crate) hits: "ddgi_hits", |l: &DdgiLayout| l.sizes.hits, B::STORAGE, exported: false;
    /// The maps at full precision (see `ddgi_common.inc.wgsl`): irradiance and its smoothed change (two
    /// vec4 per texel) and distance moments (vec2 per texel), in probe order.
    pub irradiance_history: "ddgi_irradiance_history", |l: &DdgiLayout| l.sizes.irradiance_history, B::STORAGE | B::COPY_SRC, exported: true;
    /// The distance moments at full precision: (mean, mean square) of the hit distance over the
    /// layout's distance scale, a vec2 per texel, in probe order.
    pub distance_history: "ddgi_distance_history", |l: &DdgiLayout| l.sizes.distance_history, B::STORAGE | B::COPY_SRC, exported: true;
}

//! A volume's settings resolved against its bounds and the adapter ([`DdgiLayout`]): where every
//! probe and atlas tile is, the size of every per-volume buffer ([`DdgiBufferSizes`]) and the
//! adapter limits they must fit in ([`DdgiLimits`]).

use glam::{UVec2, UVec3, Vec3};

use super::{DdgiSettingsError, DdgiVolume, auto_probe_counts, invalid, volume_extent};

/// A volume's settings resolved against its bounds and the adapter: where every probe and tile is.
#[derive(Clone, Debug, PartialEq)]
pub struct DdgiLayout {
    /// Position of probe (0, 0, 0).
    pub origin: Vec3,
    /// Distance between neighbouring probes along each axis (world units): one cell.
    pub spacing: Vec3,
    /// Probes along each axis.
    pub counts: UVec3,
    /// Probes in all (`counts.x · counts.y · counts.z`).
    pub probe_count: u32,
    /// The box (min, max) the probes fill, cell-centred; a flat box is given some thickness.
    pub bounds: (Vec3, Vec3),
    /// Probe tiles per atlas row.
    pub tiles_per_row: u32,
    /// Side of a probe's irradiance map, in texels (without its border).
    pub irradiance_texels: u32,
    /// Side of a probe's distance map, in texels (without its border).
    pub distance_texels: u32,
    /// Size of the irradiance atlas, in texels (tiles of `(irradiance_texels + 2)²`).
    pub irradiance_atlas: UVec2,
    /// Size of the distance atlas, in texels (tiles of `(distance_texels + 2)²`).
    pub distance_atlas: UVec2,
    /// The size of every per-volume buffer: the limit checks and the allocation both read them here.
    pub sizes: DdgiBufferSizes,
    /// Toroidal shift of the probe indices of a volume that has scrolled: the probe at grid
    /// coordinates `c` is stored at the index of `(c + scroll) mod counts` ([`DdgiLayout::probe_index`]).
    /// Scrolling by whole cells moves the grid without moving any probe's data.
    pub scroll: UVec3,
}

/// Bytes of each per-volume GPU buffer, computed once per layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DdgiBufferSizes {
    /// Probe data (`DdgiProbeData` per probe).
    pub probes: u64,
    /// Each of the two per-ray buffers (rays, shaded radiance): probes × rays_per_probe × 16 bytes.
    pub rays: u64,
    /// Full-precision irradiance maps (`DdgiTexel` per texel).
    pub irradiance_history: u64,
    /// Full-precision distance moments (two floats per texel).
    pub distance_history: u64,
    /// The budget pass's per-block sums (`DdgiBlock` per [`crate::gpu::BUDGET_BLOCK`] probes).
    pub blocks: u64,
    /// Each of the per-probe word lists (probes with rays this frame; each probe's luma).
    pub probe_words: u64,
    /// The persistent trace's hits (`DdgiHit` per ray: probes × rays_per_probe × 24 bytes) when
    /// [`DdgiVolume::persistent_trace`] is on, else 0.
    pub hits: u64,
}

impl DdgiBufferSizes {
    fn new(probe_count: u32, volume: &DdgiVolume) -> Self {
        use crate::gpu::{BUDGET_BLOCK, DdgiBlock, DdgiHit, DdgiProbeData, DdgiTexel};
        let probes = u64::from(probe_count);
        let texels = |n: u32| probes * u64::from(n) * u64::from(n);
        Self {
            probes: probes * size_of::<DdgiProbeData>() as u64,
            rays: probes * u64::from(volume.rays_per_probe) * BYTES_PER_RAY,
            irradiance_history: texels(volume.irradiance_texels) * size_of::<DdgiTexel>() as u64,
            distance_history: texels(volume.distance_texels) * 8,
            blocks: u64::from(probe_count.div_ceil(BUDGET_BLOCK)) * size_of::<DdgiBlock>() as u64,
            probe_words: probes * 4,
            hits: if volume.persistent_trace { probes * u64::from(volume.rays_per_probe) * size_of::<DdgiHit>() as u64 } else { 0 },
        }
    }

    /// The storage buffers that may outgrow the adapter's binding limit, with what they are.
    fn storage_buffers(&self) -> [(&'static str, u64); 5] {
        // The sizes the labels name.
        const _: () = assert!(
            size_of::<crate::gpu::DdgiProbeData>() == 64
                && size_of::<crate::gpu::DdgiTexel>() == 32
                && size_of::<crate::gpu::DdgiHit>() == 24
        );
        [
            ("probe buffer (probes × 64 bytes)", self.probes),
            ("per-ray buffer (probes × rays_per_probe × 16 bytes)", self.rays),
            ("irradiance map buffer (probes × irradiance_texels² × 32 bytes)", self.irradiance_history),
            ("distance map buffer (probes × distance_texels² × 8 bytes)", self.distance_history),
            ("persistent trace's hit buffer (probes × rays_per_probe × 24 bytes)", self.hits),
        ]
    }
}

/// Adapter limits a layout must fit in.
#[derive(Clone, Copy, Debug)]
pub struct DdgiLimits {
    /// Largest side of a 2D texture, in texels (the atlases' height).
    pub max_texture_dimension: u32,
    /// Largest storage buffer the adapter binds, in bytes.
    pub max_storage_buffer_bytes: u64,
}

impl DdgiLimits {
    /// The limits of `device`.
    pub fn of(device: &engine::wgpu::Device) -> Self {
        let l = device.limits();
        Self {
            max_texture_dimension: l.max_texture_dimension_2d,
            max_storage_buffer_bytes: l.max_storage_buffer_binding_size.min(l.max_buffer_size),
        }
    }
}

/// Bytes per ray in each of the two per-ray buffers (rays, shaded radiance).
pub const BYTES_PER_RAY: u64 = 16;

impl DdgiLayout {
    /// Lays out `volume`'s probes in `bounds`: cell-centred probes, atlases of tiles `(n + 2)²` in
    /// rows as wide as the adapter allows.
    pub fn new(volume: &DdgiVolume, bounds: (Vec3, Vec3), limits: DdgiLimits) -> Result<Self, DdgiSettingsError> {
        volume.validate()?;
        let (lo, hi) = bounds;
        if !(lo.is_finite() && hi.is_finite() && hi.cmpge(lo).all()) {
            return Err(invalid("bounds", bounds, "must be finite with max ≥ min on every axis"));
        }
        let counts = volume.probe_counts;
        let extent = volume_extent(hi - lo);
        let center = (lo + hi) * 0.5;
        let (lo, hi) = (center - extent * 0.5, center + extent * 0.5);
        let counts = counts.unwrap_or_else(|| auto_probe_counts(extent));
        let spacing = extent / counts.as_vec3();
        let probe_count = counts.x * counts.y * counts.z;
        let largest_tile = volume.irradiance_texels.max(volume.distance_texels) + 2;
        let tiles_per_row = (limits.max_texture_dimension / largest_tile).clamp(1, probe_count);
        let rows = probe_count.div_ceil(tiles_per_row);
        let atlas = |n: u32| UVec2::new(tiles_per_row * (n + 2), rows * (n + 2));
        let (irradiance_atlas, distance_atlas) = (atlas(volume.irradiance_texels), atlas(volume.distance_texels));
        let tallest = irradiance_atlas.y.max(distance_atlas.y);
        if tallest > limits.max_texture_dimension {
            return Err(DdgiSettingsError::OverLimit {
                what: "probe atlas",
                needed: u64::from(tallest),
                limit: u64::from(limits.max_texture_dimension),
                unit: "texels of height",
            });
        }
        let sizes = DdgiBufferSizes::new(probe_count, volume);
        for (what, needed) in sizes.storage_buffers() {
            if needed > limits.max_storage_buffer_bytes {
                return Err(DdgiSettingsError::OverLimit { what, needed, limit: limits.max_storage_buffer_bytes, unit: "bytes" });
            }
        }
        Ok(Self {
            origin: lo + spacing * 0.5,
            spacing,
            counts,
            probe_count,
            bounds: (lo, hi),
            tiles_per_row,
            irradiance_texels: volume.irradiance_texels,
            distance_texels: volume.distance_texels,
            irradiance_atlas,
            distance_atlas,
            sizes,
            scroll: UVec3::ZERO,
        })
    }

    /// Grid coordinates (from `origin`) of the probe stored at `index`.
    pub fn probe_grid(&self, index: u32) -> UVec3 {
        let c = self.counts.max(UVec3::ONE);
        let stored = UVec3::new(index % c.x, (index / c.x) % c.y, index / (c.x * c.y));
        (stored + c - self.scroll % c) % c
    }

    /// Index of the probe at grid coordinates `grid` (each below the counts).
    pub fn probe_index(&self, grid: UVec3) -> u32 {
        let c = self.counts.max(UVec3::ONE);
        let stored = (grid + self.scroll % c) % c;
        stored.x + c.x * (stored.y + c.y * stored.z)
    }

    /// Hit distances are clamped to this for the distance moments, and stored divided by it: 1.5
    /// cell diagonals (farther tells visibility nothing more, Majercik et al.).
    pub fn distance_scale(&self) -> f32 {
        (self.spacing.length() * 1.5).max(f32::MIN_POSITIVE)
    }

    /// World position of a probe before relocation.
    pub fn grid_position(&self, index: u32) -> Vec3 {
        self.origin + self.spacing * self.probe_grid(index).as_vec3()
    }

    /// Top-left texel of a probe's tile (border included) in an atlas of `n × n` maps.
    pub fn tile_origin(&self, index: u32, n: u32) -> UVec2 {
        UVec2::new(index % self.tiles_per_row, index / self.tiles_per_row) * (n + 2)
    }
}

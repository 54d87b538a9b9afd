//! Host mirrors of the WGSL structs in `shaders/ddgi.inc.wgsl` and `shaders/ddgi_gather.wgsl`.
//! [`GPU_STRUCTS`] lists them for the test that compares their sizes with naga's layout.

use bytemuck::{Pod, Zeroable};

use crate::volume::{DdgiLayout, DdgiVolume};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiVolumeGpu {
    pub origin: [f32; 3],
    pub rays_per_probe: u32,
    pub spacing: [f32; 3],
    pub probe_count: u32,
    pub counts: [u32; 3],
    pub flags: u32,
    /// Columns of a 3×3 matrix, each padded to 16 bytes.
    pub ray_rotation: [[f32; 4]; 3],
    pub sky_radiance: [f32; 3],
    pub hysteresis: f32,
    pub normal_bias: f32,
    pub view_bias: f32,
    pub distance_sharpness: f32,
    pub max_ray_distance: f32,
    pub distance_scale: f32,
    pub irradiance_texels: u32,
    pub distance_texels: u32,
    pub tiles_per_row: u32,
    pub firefly_threshold: f32,
    pub backface_threshold: f32,
    pub min_frontface_distance: f32,
    pub recheck: u32,
    pub irradiance_atlas_size: [f32; 2],
    pub distance_atlas_size: [f32; 2],
    pub min_rays: u32,
    pub recheck_rays: u32,
    pub error_target: f32,
    pub error_decay: f32,
    pub error_smoothing: f32,
    pub error_floor: f32,
    pub dark_fraction: f32,
    pub frame_budget: u32,
    pub max_rest_frames: u32,
    pub rest_error: f32,
    pub hysteresis_exponent: f32,
    pub rest_smoothing: f32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiProbeData {
    pub offset: [f32; 3],
    pub state: u32,
    pub error: f32,
    pub ray_count: u32,
    pub ray_offset: u32,
    pub luma: f32,
    /// [`NO_PIN`] or a ray count.
    pub pinned_rays: u32,
    /// 0, [`PIN_ACTIVE`] or [`PIN_INACTIVE`].
    pub pinned_state: u32,
    /// Rays of the classifications in a row that found no surface in the probe's region.
    pub empty_rays: u32,
    /// Resting: bits 0–15 the rest period in frames, bits 16–31 the frames left to rest.
    pub rest: u32,
    /// The error that decides resting with `rest_smoothing` (the same SMAPE, slower smoothing).
    pub settled_error: f32,
    /// Irradiance updates since the probe was last fresh.
    pub updates: u32,
    pub _pad: [u32; 2],
}

impl DdgiProbeData {
    /// A new probe: no offset, fresh (its first update takes the new value), not pinned.
    pub const NEW: Self = Self {
        offset: [0.0; 3],
        state: PROBE_FRESH,
        error: 0.0,
        ray_count: 0,
        ray_offset: 0,
        luma: 0.0,
        pinned_rays: NO_PIN,
        pinned_state: 0,
        empty_rays: 0,
        rest: 0,
        settled_error: 0.0,
        updates: 0,
        _pad: [0; 2],
    };
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiCounters {
    /// Workgroups of the indirect dispatch of the ray passes.
    pub dispatch: [u32; 3],
    pub total_rays: u32,
    /// Workgroups of the indirect dispatch of the per-probe passes (one per probe with rays).
    pub probe_dispatch: [u32; 3],
    pub updated_probes: u32,
    pub max_luma: f32,
    pub budget_scale: f32,
    pub _pad: [u32; 2],
}

/// One block of 256 probes in the budget pass's prefix sums (written and read on the GPU only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiBlock {
    pub rays: u32,
    pub unscaled_rays: u32,
    pub max_luma: f32,
    pub offset: u32,
    pub probes: u32,
    pub probe_offset: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiRay {
    pub direction: [f32; 3],
    pub probe: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiGatherParams {
    pub first_volume: u32,
    /// `composite_debug`: 1 direct light only, 2 albedo, 3 normals.
    pub debug_view: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

/// Parameters of the probe debug view (`ddgi_probes.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DdgiProbeViewParams {
    /// 1 irradiance, 2 state, 3 ray budget, 4 temporal error.
    pub mode: u32,
    /// The highlighted probe; `u32::MAX`: none.
    pub selected: u32,
    /// Sphere radius in world units.
    pub radius: f32,
    /// Ray count drawn as the hottest colour.
    pub max_rays: f32,
    /// Temporal error drawn as the hottest colour.
    pub max_error: f32,
    pub _pad0: u32,
    pub _pad1: u32,
    pub _pad2: u32,
}

pub const WEIGHT_BACKFACE: u32 = 1;
pub const WEIGHT_CHEBYSHEV: u32 = 2;
pub const WEIGHT_NORMAL_BIAS: u32 = 4;
pub const WEIGHT_CRUSH: u32 = 8;
pub const WEIGHT_TRILINEAR: u32 = 16;
pub const RELOCATION: u32 = 32;
pub const CLASSIFICATION: u32 = 64;
pub const ADAPTIVE: u32 = 128;

pub const NO_PIN: u32 = u32::MAX;
pub const PIN_ACTIVE: u32 = 1;
pub const PIN_INACTIVE: u32 = 2;

pub const PROBE_INACTIVE: u32 = 1;
pub const PROBE_FRESH: u32 = 2;
/// Hit distance of a miss in the shaded-ray buffer.
pub const MISS: f32 = 3.0e38;
/// Irradiance is stored as `E^(1/gamma)`.
pub const IRRADIANCE_GAMMA: f32 = 5.0;

/// Longest ray when the volume sets none (finite, below the miss marker).
pub const UNBOUNDED_RAY: f32 = 1.0e30;

impl DdgiVolumeGpu {
    /// The uniform of one frame: `rotation` turns the ray directions, `sky` is the miss radiance.
    pub fn new(volume: &DdgiVolume, layout: &DdgiLayout, rotation: glam::Mat3, sky: glam::Vec3, recheck: bool) -> Self {
        let w = volume.weights;
        let a = &volume.adaptive;
        let flags = [
            (w.backface, WEIGHT_BACKFACE),
            (w.chebyshev, WEIGHT_CHEBYSHEV),
            (w.normal_bias, WEIGHT_NORMAL_BIAS),
            (w.crush, WEIGHT_CRUSH),
            (w.trilinear, WEIGHT_TRILINEAR),
            (volume.relocation, RELOCATION),
            (volume.classification, CLASSIFICATION),
            (volume.adaptive.enabled, ADAPTIVE),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .fold(0, |acc, (_, bit)| acc | bit);
        let min_spacing = layout.spacing.min_element();
        let column = |c: glam::Vec3| [c.x, c.y, c.z, 0.0];
        Self {
            origin: layout.origin.to_array(),
            rays_per_probe: volume.rays_per_probe,
            spacing: layout.spacing.to_array(),
            probe_count: layout.probe_count,
            counts: layout.counts.to_array(),
            flags,
            ray_rotation: [column(rotation.x_axis), column(rotation.y_axis), column(rotation.z_axis)],
            sky_radiance: sky.to_array(),
            hysteresis: volume.hysteresis,
            normal_bias: volume.normal_bias * min_spacing,
            view_bias: volume.view_bias * min_spacing,
            distance_sharpness: volume.distance_sharpness,
            max_ray_distance: volume.max_ray_distance.unwrap_or(UNBOUNDED_RAY).min(UNBOUNDED_RAY),
            distance_scale: layout.distance_scale(),
            irradiance_texels: layout.irradiance_texels,
            distance_texels: layout.distance_texels,
            tiles_per_row: layout.tiles_per_row,
            firefly_threshold: volume.firefly_threshold,
            backface_threshold: volume.backface_threshold,
            min_frontface_distance: volume.min_frontface_distance * min_spacing,
            recheck: u32::from(recheck),
            irradiance_atlas_size: layout.irradiance_atlas.as_vec2().to_array(),
            distance_atlas_size: layout.distance_atlas.as_vec2().to_array(),
            min_rays: a.min_rays.clamp(1, volume.rays_per_probe),
            recheck_rays: volume.recheck_rays.clamp(1, volume.rays_per_probe),
            error_target: a.error_target,
            error_decay: a.decay,
            error_smoothing: a.error_smoothing,
            error_floor: a.error_floor,
            dark_fraction: if a.enabled { a.dark_fraction } else { 0.0 },
            frame_budget: if a.enabled { a.frame_budget.unwrap_or(0) } else { 0 },
            max_rest_frames: if a.enabled { a.max_rest_frames.min(0xffff) } else { 0 },
            rest_error: a.rest_error,
            hysteresis_exponent: a.hysteresis_exponent,
            rest_smoothing: a.rest_smoothing.unwrap_or(-1.0),
        }
    }
}

/// One texel of the full-precision irradiance maps (WGSL `DdgiTexel`): the irradiance, the fast
/// moving average of the change each frame's estimate asks (the error) and, as bfloat16, the slow
/// one (the settled error).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiTexel {
    pub irradiance: [f32; 3],
    pub settle_rg: u32,
    pub change: [f32; 3],
    pub settle_b: u32,
}

/// (WGSL struct name, size of the Rust mirror, a shader file that declares it).
pub const GPU_STRUCTS: &[(&str, usize, &str)] = &[
    ("DdgiVolumeGpu", size_of::<DdgiVolumeGpu>(), "ddgi.inc.wgsl"),
    ("DdgiProbeData", size_of::<DdgiProbeData>(), "ddgi.inc.wgsl"),
    ("DdgiTexel", size_of::<DdgiTexel>(), "ddgi.inc.wgsl"),
    ("DdgiRay", size_of::<DdgiRay>(), "ddgi.inc.wgsl"),
    ("DdgiCounters", size_of::<DdgiCounters>(), "ddgi.inc.wgsl"),
    ("DdgiBlock", size_of::<DdgiBlock>(), "ddgi.inc.wgsl"),
    ("DdgiGatherParams", size_of::<DdgiGatherParams>(), "ddgi_gather.wgsl"),
    ("DdgiProbeViewParams", size_of::<DdgiProbeViewParams>(), "ddgi_probes.wgsl"),
];

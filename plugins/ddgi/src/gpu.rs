//! Host mirrors of the DDGI WGSL structs (`plugins/ddgi/shaders/`) and the constants the host
//! shares with the shaders. [`gpu_structs`] lists the mirrors for the test that compares each
//! field's offset with naga's layout; the constants are written into the generated WGSL module
//! `ddgi_constants.inc.wgsl` ([`wgsl_constants`]), so each is defined once, here.

use bytemuck::{Pod, Zeroable};

use crate::volume::{DdgiLayout, DdgiVolume};

/// The uniform of one volume (WGSL `DdgiVolumeGpu`, `ddgi_volume`): its grid, settings and this
/// frame's ray rotation, as [`DdgiVolumeGpu::new`] derives them from a [`DdgiVolume`] and its
/// [`DdgiLayout`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct DdgiVolumeGpu {
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
    /// [`DdgiVolume::normal_bias`] as it is (a share of the cell's extent along the normal: the
    /// sampling function scales it, `ddgi_cell_extent`).
    pub normal_bias: f32,
    /// [`DdgiVolume::view_bias`] as it is (a share of the cell's extent along the view direction).
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
    /// Toroidal shift of a scrolled volume's probe indices ([`DdgiLayout::scroll`]).
    pub scroll: [u32; 3],
    /// A cascade's blend band in cells; 0 for a fixed volume.
    pub cascade_blend: f32,
    /// Boxes in `ddgi_wake` this frame (around the instances that moved).
    pub wake_boxes: u32,
    /// Non-zero: every resting probe updates this frame (light changed everywhere).
    pub wake_resting: u32,
    /// [`crate::DdgiAdaptive::drift_rate`] (1 with the fixed budget: off).
    pub drift_rate: f32,
    /// [`crate::DdgiVolume::hit_occlusion_rays`] (0: off), and their reach in world units.
    pub hit_occlusion_rays: u32,
    pub hit_occlusion_reach: f32,
    /// Non-zero: the coarsest cascade of its camera ([`crate::DdgiCascade::outermost`]), weighted
    /// as a fixed volume at its edge.
    pub cascade_outermost: u32,
    pub _pad4: u32,
    pub _pad5: u32,
}

/// One probe's GPU state (WGSL `DdgiProbeData`, `ddgi_probes`): relocation and classification
/// write the offset and state, the irradiance update the error, the budget pass the rays; the
/// pins come from the application ([`crate::DdgiProbePin`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiProbeData {
    /// Relocation offset from the grid position, in world units (within ±0.45 of a cell).
    pub offset: [f32; 3],
    /// `PROBE_*` bits: [`PROBE_INACTIVE`], [`PROBE_FRESH`], [`PROBE_RELOCATED`],
    /// [`PROBE_RECHECK`], [`PROBE_EMPTY`], [`PROBE_SEEN`].
    pub state: u32,
    /// Temporal error: the mean over the map's texels of the SMAPE, in YCoCg, between the map and
    /// the map plus the smoothed change that each frame's estimate asks of it.
    pub error: f32,
    /// Rays traced for the probe this frame (0: resting or switched off).
    pub ray_count: u32,
    /// Where the probe's rays start among the frame's packed rays.
    pub ray_offset: u32,
    /// Mean luma (YCoCg Y, W/m²) of the irradiance the probe's rays last saw.
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
    /// Padding to the WGSL layout.
    pub _pad0: u32,
    /// Padding to the WGSL layout.
    pub _pad1: u32,
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
        _pad0: 0,
        _pad1: 0,
    };
}

/// What the budget pass leaves for the rest of the frame (WGSL `DdgiCounters`, `ddgi_counters`);
/// read back for the `ddgi_rays` counter.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiCounters {
    /// Workgroups of the indirect dispatch of the ray passes.
    pub dispatch: [u32; 3],
    /// Rays traced this frame, over every probe of the volume.
    pub total_rays: u32,
    /// Workgroups of the indirect dispatch of the per-probe passes (one per probe with rays).
    pub probe_dispatch: [u32; 3],
    /// Probes with rays this frame (updated by the per-probe passes).
    pub updated_probes: u32,
    /// The brightest probe's luma (W/m²), against which [`crate::DdgiAdaptive::dark_fraction`]
    /// judges dark probes.
    pub max_luma: f32,
    /// The share of each probe's rays kept this frame under the frame budget (1: none cut).
    pub budget_scale: f32,
    /// Padding to the WGSL layout.
    pub _pad0: u32,
    /// Padding to the WGSL layout.
    pub _pad1: u32,
    /// Workgroups of the indirect dispatch of the persistent trace
    /// ([`crate::DdgiVolume::persistent_trace`]): one per [`PERSISTENT_TRACE_GROUP`] rays, at most
    /// [`PERSISTENT_TRACE_GROUPS`].
    pub persistent_dispatch: [u32; 3],
    /// Padding to the WGSL layout.
    pub _pad2: u32,
}

/// One block of 256 probes in the budget pass's prefix sums (written and read on the GPU only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct DdgiBlock {
    pub rays: u32,
    pub unscaled_rays: u32,
    pub max_luma: f32,
    pub offset: u32,
    pub probes: u32,
    pub probe_offset: u32,
}

/// One probe ray of the frame's packed rays (WGSL `DdgiRay`, `ddgi_rays`), as the trace generated
/// it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiRay {
    /// Unit direction in world space: a spherical Fibonacci direction under the frame's rotation.
    pub direction: [f32; 3],
    /// The index of the probe that traces it.
    pub probe: u32,
}

/// One probe ray's closest hit as the persistent trace found it (WGSL `DdgiHit`, `ddgi_hits`), for
/// the shading pass `ddgi_shade` ([`crate::DdgiVolume::persistent_trace`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct DdgiHit {
    /// Hit distance (the ray's maximum when it missed).
    pub t: f32,
    /// Instance slot, or `u32::MAX` for a miss.
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
    /// 1 when the ray met the side the triangle's winding faces, else 0.
    pub front_face: u32,
    /// Weights of the triangle's vertices 1 and 2.
    pub barycentrics: [f32; 2],
}

/// Parameters of the camera's gather and composite (WGSL `DdgiGatherParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct DdgiGatherParams {
    pub first_volume: u32,
    /// `composite_debug`: 1 direct light only, 2 albedo, 3 normals, 4 contact occlusion.
    pub debug_view: u32,
    /// Visibility rays of the sky light at uncovered pixels ([`crate::DdgiSkyLight`]; 0: off).
    pub sky_rays: u32,
    /// Their reach in world units.
    pub sky_distance: f32,
    /// Contact occlusion of the indirect light ([`crate::DdgiContactOcclusion`]): rays (0: off),
    /// radius, and the side of the blocks traced at one pixel each (1: every pixel).
    pub ao_rays: u32,
    pub ao_radius: f32,
    pub ao_scale: u32,
    pub _pad1: u32,
}

/// Parameters of the probe debug view (`ddgi_probe_spheres.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub(crate) struct DdgiProbeViewParams {
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

// Constants shared with the WGSL: each is defined here once and written into the generated
// module `ddgi_constants.inc.wgsl` ([`wgsl_constants`]) under the name `DDGI_<NAME>`.

// `DdgiVolumeGpu::flags` bits: the sampling function's weights (`DdgiWeights`) and features.

/// The wrap-shading back-face weight.
pub(crate) const WEIGHT_BACKFACE: u32 = 1;
/// The Chebyshev visibility weight.
pub(crate) const WEIGHT_CHEBYSHEV: u32 = 2;
/// The normal and view bias of the lookup point.
pub(crate) const WEIGHT_NORMAL_BIAS: u32 = 4;
/// The log-perception crush of small weights.
pub(crate) const WEIGHT_CRUSH: u32 = 8;
/// Trilinear interpolation.
pub(crate) const WEIGHT_TRILINEAR: u32 = 16;
/// Probe relocation ([`crate::DdgiVolume::relocation`]).
pub(crate) const RELOCATION: u32 = 32;
/// Probe classification ([`crate::DdgiVolume::classification`]).
pub(crate) const CLASSIFICATION: u32 = 64;
/// Adaptive ray budgets ([`crate::DdgiAdaptive`]).
pub(crate) const ADAPTIVE: u32 = 128;
/// A fresh probe's first updates blend as a running mean ([`crate::DdgiVolume::warm_up`]).
pub(crate) const WARM_UP: u32 = 256;
/// Probe rays that miss see `DdgiVolumeGpu::sky_radiance` instead of the scene's sky.
pub(crate) const SKY_OVERRIDE: u32 = 512;

/// [`DdgiProbeData::pinned_rays`] of a probe whose ray count is not pinned.
pub const NO_PIN: u32 = u32::MAX;
/// No probe (a neighbour beyond the grid's edge).
pub const NO_PROBE: u32 = u32::MAX;
/// [`DdgiProbeData::pinned_state`] of a probe pinned on: classification never switches it off.
pub const PIN_ACTIVE: u32 = 1;
/// [`DdgiProbeData::pinned_state`] of a probe pinned off: it traces no rays and gets no weight.
pub const PIN_INACTIVE: u32 = 2;

/// `DdgiProbeData::state` bits. Switched off (inside geometry, no surface in reach, or dark).
pub const PROBE_INACTIVE: u32 = 1;
/// The probe's maps hold nothing worth keeping: its next update takes the new value at once.
pub const PROBE_FRESH: u32 = 2;
/// Relocation moved the probe through a back face this frame (set by relocation, read and cleared
/// by classification): a probe switched off inside geometry then traces its re-check rays at the
/// next frame from its new place, not at the next periodic re-check, so it escapes (and lights
/// again) within a frame per wall.
pub const PROBE_RELOCATED: u32 = 4;
/// Switched off while relocation had moved it through a back face (set by classification from
/// [`PROBE_RELOCATED`]): the budget gives it its re-check rays at the next frame.
pub const PROBE_RECHECK: u32 = 8;
/// Switched off because its rays found no surface in its region ([`EMPTY_RAYS`]).
pub const PROBE_EMPTY: u32 = 16;
/// Set by the camera's gather on a probe that is off for an empty region, or on its way there,
/// when a pixel in its cage faces it: a visible surface depends on it. The budget gives such an
/// off probe its re-check rays at the next frame, and classification then counts its region as
/// not empty (and clears the mark), so the probes the view needs come back within a frame.
pub const PROBE_SEEN: u32 = 32;

/// A probe counts as affecting no surface only after this many of its rays, over classifications
/// in a row (each frame's rays rotated anew), found none in its region: one frame's few rays
/// (adaptive budgets) can miss a small surface at the edge of the region; 512 directions miss a
/// surface covering 1% of the sphere with a probability of 0.6%.
pub const EMPTY_RAYS: u32 = 512;
/// Probes per block of the budget pass's prefix sums (its workgroup size).
pub const BUDGET_BLOCK: u32 = 256;
/// Rays per workgroup of the trace (one thread each).
pub const RAY_GROUP: u32 = 64;
/// Threads per workgroup of the persistent trace ([`crate::DdgiVolume::persistent_trace`]): the
/// best of `game_demo bench trace --persistent-groups` (128 against 64 and 256; BENCHMARKS.md,
/// "Ray-tracing core: closest-hit throughput of probe-like rays").
pub const PERSISTENT_TRACE_GROUP: u32 = 128;
/// Most workgroups of the persistent trace: enough to fill the GPU, which wgpu cannot tell us (it
/// exposes no count of multiprocessors). 4,224 = 32 workgroups for each of the 132
/// multiprocessors of the GPU it was tuned on, the best of `bench trace` there (about 1.5 times
/// as fast as a thread a ray at 32³ probes × 256 rays; BENCHMARKS.md, "Ray-tracing core:
/// closest-hit throughput of probe-like rays"); fewer rays than 128 a workgroup get
/// `ceil(rays / 128)` workgroups (the budget pass sizes the dispatch from the frame's ray count).
pub const PERSISTENT_TRACE_GROUPS: u32 = 4224;
/// Most boxes around moved instances whose probes a frame wakes locally; more movers than this in
/// a volume wake it all (a re-check of every switched-off probe, as for added or removed instances).
pub const MAX_WAKE_BOXES: u32 = 256;

/// A probe's settled error as a share of its error ([`crate::DdgiAdaptive::drift_rate`]): at or
/// under this it is noise (its slow average keeps about 0.54 of the fast one's noise at the default
/// smoothings), and the probe blends at its usual rate.
pub const DRIFT_SHARE_LOW: f32 = 0.6;
/// From this share on the probe is drifting (its map moves the same way update after update) and
/// blends at the full `drift_rate`; between the two, the rate rises linearly.
pub const DRIFT_SHARE_FULL: f32 = 0.9;

/// Hit distance of a miss in the shaded-ray buffer.
pub const MISS: f32 = 3.0e38;
/// Back-face hits are stored as `-BACKFACE_SCALE · t`: the distance maps see the wall closer, so
/// Chebyshev rejects probes behind walls; relocation recovers t.
pub const BACKFACE_SCALE: f32 = 0.2;
/// Irradiance is stored as `E^(1/gamma)`: perceptual precision in half floats, no banding in the dark.
pub const IRRADIANCE_GAMMA: f32 = 5.0;
/// Largest irradiance (W/m²) a probe map holds, and largest radiance of a shaded probe ray: the
/// documented clamp that keeps a diverging scene finite. 1e24^(1/5) ≈ 63,096 stays under the
/// largest half float (65,504), so no atlas texel can be infinite, and 4,096 rays of it sum
/// without overflow. Only a scene whose light grows without bound (a closed box of albedo 1 that
/// emits) ever reaches it.
pub const MAX_IRRADIANCE: f32 = 1.0e24;

/// Every constant above as `(WGSL name, value)`.
const SHARED_CONSTANTS: &[(&str, WgslValue)] = &[
    ("DDGI_WEIGHT_BACKFACE", WgslValue::U32(WEIGHT_BACKFACE)),
    ("DDGI_WEIGHT_CHEBYSHEV", WgslValue::U32(WEIGHT_CHEBYSHEV)),
    ("DDGI_WEIGHT_NORMAL_BIAS", WgslValue::U32(WEIGHT_NORMAL_BIAS)),
    ("DDGI_WEIGHT_CRUSH", WgslValue::U32(WEIGHT_CRUSH)),
    ("DDGI_WEIGHT_TRILINEAR", WgslValue::U32(WEIGHT_TRILINEAR)),
    ("DDGI_RELOCATION", WgslValue::U32(RELOCATION)),
    ("DDGI_CLASSIFICATION", WgslValue::U32(CLASSIFICATION)),
    ("DDGI_ADAPTIVE", WgslValue::U32(ADAPTIVE)),
    ("DDGI_WARM_UP", WgslValue::U32(WARM_UP)),
    ("DDGI_SKY_OVERRIDE", WgslValue::U32(SKY_OVERRIDE)),
    ("DDGI_NO_PIN", WgslValue::U32(NO_PIN)),
    ("DDGI_NO_PROBE", WgslValue::U32(NO_PROBE)),
    ("DDGI_PIN_ACTIVE", WgslValue::U32(PIN_ACTIVE)),
    ("DDGI_PIN_INACTIVE", WgslValue::U32(PIN_INACTIVE)),
    ("DDGI_PROBE_INACTIVE", WgslValue::U32(PROBE_INACTIVE)),
    ("DDGI_PROBE_FRESH", WgslValue::U32(PROBE_FRESH)),
    ("DDGI_PROBE_RELOCATED", WgslValue::U32(PROBE_RELOCATED)),
    ("DDGI_PROBE_RECHECK", WgslValue::U32(PROBE_RECHECK)),
    ("DDGI_PROBE_EMPTY", WgslValue::U32(PROBE_EMPTY)),
    ("DDGI_PROBE_SEEN", WgslValue::U32(PROBE_SEEN)),
    ("DDGI_EMPTY_RAYS", WgslValue::U32(EMPTY_RAYS)),
    ("DDGI_BUDGET_BLOCK", WgslValue::U32(BUDGET_BLOCK)),
    ("DDGI_RAY_GROUP", WgslValue::U32(RAY_GROUP)),
    ("DDGI_PERSISTENT_TRACE_GROUP", WgslValue::U32(PERSISTENT_TRACE_GROUP)),
    ("DDGI_PERSISTENT_TRACE_GROUPS", WgslValue::U32(PERSISTENT_TRACE_GROUPS)),
    ("DDGI_MAX_WAKE_BOXES", WgslValue::U32(MAX_WAKE_BOXES)),
    ("DDGI_DRIFT_SHARE_LOW", WgslValue::F32(DRIFT_SHARE_LOW)),
    ("DDGI_DRIFT_SHARE_FULL", WgslValue::F32(DRIFT_SHARE_FULL)),
    ("DDGI_MISS", WgslValue::F32(MISS)),
    ("DDGI_BACKFACE_SCALE", WgslValue::F32(BACKFACE_SCALE)),
    ("DDGI_IRRADIANCE_GAMMA", WgslValue::F32(IRRADIANCE_GAMMA)),
    ("DDGI_MAX_IRRADIANCE", WgslValue::F32(MAX_IRRADIANCE)),
];

#[derive(Clone, Copy, Debug, PartialEq)]
enum WgslValue {
    U32(u32),
    F32(f32),
}

/// The WGSL module `ddgi_constants.inc.wgsl`: every constant the passes share with the host,
/// written from its Rust definition above.
pub fn wgsl_constants() -> String {
    let mut out = String::from("// Generated by plugins/ddgi/src/gpu.rs (wgsl_constants): edit the Rust constants there.\n");
    for (name, value) in SHARED_CONSTANTS {
        // `{:?}` writes the shortest decimal that reads back as the same f32 (e.g. 3e38, 0.2, 5.0).
        let line = match value {
            WgslValue::U32(v) => format!("const {name}: u32 = {v}u;\n"),
            WgslValue::F32(v) => format!("const {name}: f32 = {v:?};\n"),
        };
        out.push_str(&line);
    }
    out
}

/// Longest ray when the volume sets none (finite, below the miss marker).
pub const UNBOUNDED_RAY: f32 = 1.0e30;

impl DdgiVolumeGpu {
    /// The uniform of one frame: `rotation` turns the ray directions, `sky` is the miss radiance
    /// when the volume has its own (else misses see the scene's sky).
    /// The settings are taken as [`DdgiVolume::validate`] passed them (no clamping here); the budget
    /// pass bounds the ray counts by `rays_per_probe` itself.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        volume: &DdgiVolume,
        layout: &DdgiLayout,
        rotation: glam::Mat3,
        sky: Option<glam::Vec3>,
        recheck: bool,
        cascade: (f32, bool),
        wake_boxes: u32,
    ) -> Self {
        let (cascade_blend, cascade_outermost) = cascade;
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
            (volume.warm_up, WARM_UP),
            (sky.is_some(), SKY_OVERRIDE),
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
            sky_radiance: sky.unwrap_or_default().to_array(),
            hysteresis: volume.hysteresis,
            normal_bias: volume.normal_bias,
            view_bias: volume.view_bias,
            distance_sharpness: volume.distance_sharpness,
            max_ray_distance: volume.max_ray_distance.unwrap_or(UNBOUNDED_RAY),
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
            min_rays: a.min_rays.clamp(1, volume.rays_per_probe.max(1)),
            recheck_rays: volume.recheck_rays,
            error_target: a.error_target,
            error_decay: a.decay,
            error_smoothing: a.error_smoothing,
            error_floor: a.error_floor,
            dark_fraction: if a.enabled { a.dark_fraction } else { 0.0 },
            frame_budget: if a.enabled { a.frame_budget.unwrap_or(0) } else { 0 },
            max_rest_frames: if a.enabled { a.max_rest_frames } else { 0 },
            rest_error: a.rest_error,
            hysteresis_exponent: a.hysteresis_exponent,
            rest_smoothing: a.rest_smoothing.unwrap_or(-1.0),
            scroll: layout.scroll.to_array(),
            cascade_blend,
            wake_boxes,
            wake_resting: 0,
            drift_rate: if a.enabled { a.drift_rate } else { 1.0 },
            hit_occlusion_rays: volume.hit_occlusion_rays,
            hit_occlusion_reach: volume.hit_occlusion_reach * min_spacing,
            cascade_outermost: u32::from(cascade_outermost),
            _pad4: 0,
            _pad5: 0,
        }
    }
}

/// One texel of the full-precision irradiance maps (WGSL `DdgiTexel`): the irradiance, the fast
/// moving average of the change each frame's estimate asks (the error) and, as bfloat16, the slow
/// one (the settled error).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub(crate) struct DdgiTexel {
    pub irradiance: [f32; 3],
    pub settle_rg: u32,
    pub change: [f32; 3],
    pub settle_b: u32,
}

/// The host mirrors of the DDGI WGSL structs, for the test that checks every field's offset
/// against naga's layout ([`engine::shader::check_struct_layout`]).
pub fn gpu_structs() -> Vec<engine::shader::HostStruct> {
    use engine::gpu_struct_layout as layout;
    vec![
        layout!(DdgiVolumeGpu in "ddgi_common.inc.wgsl" {
            origin, rays_per_probe, spacing, probe_count, counts, flags, ray_rotation, sky_radiance, hysteresis, normal_bias,
            view_bias, distance_sharpness, max_ray_distance, distance_scale, irradiance_texels, distance_texels, tiles_per_row,
            firefly_threshold, backface_threshold, min_frontface_distance, recheck, irradiance_atlas_size, distance_atlas_size,
            min_rays, recheck_rays, error_target, error_decay, error_smoothing, error_floor, dark_fraction, frame_budget,
            max_rest_frames, rest_error, hysteresis_exponent, rest_smoothing, scroll, cascade_blend, wake_boxes, wake_resting, drift_rate,
            hit_occlusion_rays, hit_occlusion_reach, cascade_outermost, _pad4, _pad5,
        }),
        layout!(DdgiProbeData in "ddgi_common.inc.wgsl" {
            offset, state, error, ray_count, ray_offset, luma, pinned_rays, pinned_state, empty_rays, rest, settled_error, updates,
            _pad0, _pad1,
        }),
        layout!(DdgiTexel in "ddgi_common.inc.wgsl" { irradiance, settle_rg, change, settle_b }),
        layout!(DdgiRay in "ddgi_common.inc.wgsl" { direction, probe }),
        layout!(DdgiCounters in "ddgi_common.inc.wgsl" {
            dispatch, total_rays, probe_dispatch, updated_probes, max_luma, budget_scale, _pad0, _pad1, persistent_dispatch, _pad2,
        }),
        layout!(DdgiHit in "ddgi_common.inc.wgsl" { t, instance, primitive, front_face, barycentrics }),
        layout!(DdgiBlock in "ddgi_common.inc.wgsl" { rays, unscaled_rays, max_luma, offset, probes, probe_offset }),
        layout!(DdgiGatherParams in "ddgi_camera.inc.wgsl" { first_volume, debug_view, sky_rays, sky_distance, ao_rays, ao_radius, ao_scale, _pad1 }),
        layout!(DdgiProbeViewParams in "ddgi_probe_spheres.wgsl" { mode, selected, radius, max_rays, max_error, _pad0, _pad1, _pad2 }),
    ]
}

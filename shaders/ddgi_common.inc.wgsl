// DDGI: the probe volume, its probes, atlases and per-frame buffers, and the helpers every DDGI pass
// shares. Host mirrors of these structs are in plugins/ddgi/src/gpu.rs (a test compares every
// field's offset); every DDGI binding (group 1) is declared here and nowhere else. The constants
// (DDGI_*) are generated from their Rust definitions in gpu.rs (module ddgi_constants.inc.wgsl).
//
// Probe p sits at grid coordinates (x, y, z) with p = x + counts.x · (y + counts.y · z), at
// origin + spacing · (x, y, z) + its relocation offset. Each probe owns one tile of each atlas: an
// octahedral map of N × N interior texels (N = irradiance_texels or distance_texels) framed by a
// one-texel border that repeats the map's opposite edges, so bilinear filtering wraps correctly.
#include "rt_alpha.inc.wgsl"
#include "ddgi_constants.inc.wgsl"

struct DdgiVolumeGpu {
    // World position of probe (0, 0, 0), before relocation.
    origin: vec3<f32>,
    rays_per_probe: u32,
    spacing: vec3<f32>,
    probe_count: u32,
    counts: vec3<u32>,
    // DDGI_WEIGHT_* and DDGI_* flags.
    flags: u32,
    // This frame's random rotation of the ray directions (columns).
    ray_rotation: mat3x3<f32>,
    sky_radiance: vec3<f32>,
    hysteresis: f32,
    // World-space offsets along the normal and towards the viewer before sampling.
    normal_bias: f32,
    view_bias: f32,
    // Exponent of the cosine weighting of the distance update.
    distance_sharpness: f32,
    max_ray_distance: f32,
    // Hit distances are clamped to this for the moments, and stored divided by it.
    distance_scale: f32,
    irradiance_texels: u32,
    distance_texels: u32,
    // Probe tiles per atlas row.
    tiles_per_row: u32,
    // A sample brighter than (1 + firefly_threshold) times the texel's luminance moves it only a
    // quarter of the way (0: off).
    firefly_threshold: f32,
    // Fraction of back-face hits above which a probe counts as inside geometry.
    backface_threshold: f32,
    // Relocation keeps probes at least this far from front faces.
    min_frontface_distance: f32,
    // 1 on frames when inactive probes trace too (to be re-classified).
    recheck: u32,
    // Atlas sizes in texels.
    irradiance_atlas_size: vec2<f32>,
    distance_atlas_size: vec2<f32>,
    // Adaptive budgets (DDGI_ADAPTIVE): rays of a quiet probe, rays of an inactive probe on
    // re-check frames, the smoothed error at which a probe gets the full budget, the factor by
    // which a quiet probe's budget shrinks per frame, the error's temporal smoothing, the floor of
    // SMAPE's denominator (W/m²), the share of the brightest probe's luma under which a probe and
    // its neighbours count as dark, and the total rays per frame (0: no limit).
    min_rays: u32,
    recheck_rays: u32,
    error_target: f32,
    error_decay: f32,
    error_smoothing: f32,
    error_floor: f32,
    dark_fraction: f32,
    frame_budget: u32,
    // Resting (adaptive budgets): the longest rest of a quiet probe between two updates, in frames
    // (≤ 1: no resting), and the share of error_target under which a probe counts as quiet.
    max_rest_frames: u32,
    rest_error: f32,
    // With adaptive budgets, 1 − hysteresis scales with (rays / rays_per_probe)^this.
    hysteresis_exponent: f32,
    // Weight of the old value in the slower average of each texel's change (settled_error); < 0:
    // resting decided by the error itself.
    rest_smoothing: f32,
    // Toroidal addressing of a volume that scrolls: the probe at grid coordinates c (from the
    // volume's origin) lives at index ddgi_probe_index(c), its coordinates shifted by `scroll`
    // modulo the counts. (0, 0, 0) for a volume that never scrolled.
    scroll: vec3<u32>,
    // A cascade's blend band, in cells: its weight falls from 1 to 0 over this many cells inside
    // its outer probes, and it fills only what the volumes gathered before it left (nested
    // blending). 0: a fixed volume (weight 1 inside its bounds, fading one cell outside).
    cascade_blend: f32,
    // Boxes in ddgi_wake this frame.
    wake_boxes: u32,
    // Non-zero: every resting probe updates this frame (light changed everywhere).
    wake_resting: u32,
    // With adaptive budgets, the most a drifting probe's 1 − hysteresis is multiplied by (≤ 1: off).
    drift_rate: f32,
    // Near-field occlusion rays at each probe ray's hit (0: off), and their reach in world units.
    hit_occlusion_rays: u32,
    hit_occlusion_reach: f32,
    // Non-zero: the coarsest cascade of its camera. Nothing takes over at its edge, so the gather
    // weights it as a fixed volume there (full weight up to half a cell beyond its outer probes).
    cascade_outermost: u32,
    _pad4: u32,
    _pad5: u32,
}

// Per-probe state: relocation and classification write offset and state, the irradiance update
// the error, the budget pass the rays; the pins come from the application.
struct DdgiProbeData {
    // Relocation offset from the grid position, in world units (within ±0.45 of a cell).
    offset: vec3<f32>,
    // DDGI_PROBE_* bits.
    state: u32,
    // Temporal error: the mean over the map's texels of the SMAPE, in YCoCg, between the map and
    // the map plus the smoothed change that each frame's estimate asks of it.
    error: f32,
    // Rays this frame, and where they start among the frame's packed rays.
    ray_count: u32,
    ray_offset: u32,
    // Mean luma (YCoCg Y) of the irradiance the probe's rays last saw (W/m²).
    luma: f32,
    // Pinned by the application: a ray count (DDGI_NO_PIN: none) and a state (DDGI_PIN_*).
    pinned_rays: u32,
    pinned_state: u32,
    // Rays of the classifications in a row that found no front face in the probe's region (see
    // DDGI_EMPTY_RAYS).
    empty_rays: u32,
    // Resting (adaptive budgets): bits 0–15 the probe's rest period (an update every that many
    // frames; 0 or 1: every frame), bits 16–31 the frames left before its next update.
    rest: u32,
    // The error that decides resting when rest_smoothing ≥ 0: as `error`, over a slower average of
    // the change, which keeps less of the noise and all of a map's convergence.
    settled_error: f32,
    // Irradiance updates since the probe was last fresh (corrects the slow average's start).
    updates: u32,
    _pad0: u32,
    _pad1: u32,
}

// What the budget pass leaves for the rest of the frame: the indirect dispatch of the ray passes
// and the number of rays, the indirect dispatch of the per-probe passes (one workgroup per probe
// updated this frame, listed in ddgi_updated) and their number, the brightest probe's luma, and the
// indirect dispatch of the persistent trace (trace_rays_persistent: a workgroup per
// DDGI_PERSISTENT_TRACE_GROUP rays, at most DDGI_PERSISTENT_TRACE_GROUPS).
struct DdgiCounters {
    dispatch: vec3<u32>,
    total_rays: u32,
    probe_dispatch: vec3<u32>,
    updated_probes: u32,
    max_luma: f32,
    // The share of each probe's rays kept this frame under the frame budget.
    budget_scale: f32,
    _pad0: u32,
    _pad1: u32,
    persistent_dispatch: vec3<u32>,
    _pad2: u32,
}

// One block of 256 probes in the budget's prefix sum: its rays (after and before the frame
// budget), its brightest probe, where its rays start, its probes with rays this frame and where
// they start in ddgi_updated.
struct DdgiBlock {
    rays: u32,
    unscaled_rays: u32,
    max_luma: f32,
    offset: u32,
    probes: u32,
    probe_offset: u32,
}

// One probe ray of the frame's packed rays: its direction and its probe.
struct DdgiRay {
    direction: vec3<f32>,
    probe: u32,
}

@group(1) @binding(0) var<uniform> ddgi_volume: DdgiVolumeGpu;
@group(1) @binding(1) var<storage, read_write> ddgi_probes: array<DdgiProbeData>;
@group(1) @binding(2) var ddgi_irradiance: texture_2d<f32>;
@group(1) @binding(3) var ddgi_distance: texture_2d<f32>;
@group(1) @binding(4) var ddgi_sampler: sampler;
@group(1) @binding(5) var<storage, read_write> ddgi_rays: array<DdgiRay>;

// One probe ray's closest hit as the persistent trace found it (`trace_rays_persistent`), for the
// shading pass (`ddgi_shade`): RayHit's fields, front_face as 0 or 1 (a bool cannot live in a
// buffer).
struct DdgiHit {
    t: f32,
    instance: u32,
    primitive: u32,
    front_face: u32,
    barycentrics: vec2<f32>,
}

// The frame's hits, one a packed ray, written and read only when the volume traces with the
// persistent kernel (DdgiVolume::persistent_trace).
@group(1) @binding(17) var<storage, read_write> ddgi_hits: array<DdgiHit>;
// Shaded rays: (radiance, stored distance: t, -DDGI_BACKFACE_SCALE·t or DDGI_MISS).
@group(1) @binding(7) var<storage, read_write> ddgi_radiance: array<vec4<f32>>;
// One irradiance texel at full precision: the irradiance; the exponential moving average of each
// frame's estimate minus the map (smoothing error_smoothing), from which the probe's temporal
// error comes; and the same, slower (rest_smoothing), from which its settled error comes, as
// bfloat16 (see ddgi_pack_bf16) in the two words the vec3s leave free (red and green, then blue).
struct DdgiTexel {
    irradiance: vec3<f32>,
    settle_rg: u32,
    change: vec3<f32>,
    settle_b: u32,
}

// The maps at full float precision, texel t of probe p at p · n² + t: the updates blend into these
// (a half-float atlas would stall once a frame's change falls under half a unit in the last place,
// up to several percent short of the target at hysteresis 0.97), and the probe update encodes them
// into the atlases that sampling reads. Irradiance linear (rgb); distance moments over distance_scale.
@group(1) @binding(8) var<storage, read_write> ddgi_irradiance_history: array<DdgiTexel>;
@group(1) @binding(9) var<storage, read_write> ddgi_distance_history: array<vec2<f32>>;
// The atlases as the probe update writes them (the trace's shading samples them through bindings 2, 3).
@group(1) @binding(10) var ddgi_irradiance_out: texture_storage_2d<rgba16float, write>;
@group(1) @binding(6) var ddgi_distance_out: texture_storage_2d<rgba16float, write>;
@group(1) @binding(11) var<storage, read_write> ddgi_counters: DdgiCounters;
// The same buffer read-only, for the ray passes, which also take their indirect dispatch from it
// (a dispatch may not write a buffer it reads its arguments from).
@group(1) @binding(12) var<storage, read> ddgi_counters_in: DdgiCounters;
@group(1) @binding(13) var<storage, read_write> ddgi_blocks: array<DdgiBlock>;
// The probes with rays this frame (ddgi_counters.updated_probes of them), in probe order: the
// per-probe passes run one workgroup for each, so a resting or switched-off probe costs them
// nothing.
@group(1) @binding(14) var<storage, read_write> ddgi_updated: array<u32>;
// Each probe's luma as the budget pass found it (the last update's), −1 when switched off: the
// classification's dark test reads its neighbours here, not in ddgi_probes, which other workgroups
// of the same dispatch are rewriting (their order would decide the result).
@group(1) @binding(15) var<storage, read_write> ddgi_lit: array<f32>;

// Boxes (min, max corners in render space) around the instances that moved this frame, grown by a
// probe spacing: the probes inside them wake (a switched-off probe traces its re-check rays, a
// resting one updates), and no other probe needs to.
@group(1) @binding(16) var<storage, read> ddgi_wake: array<vec4<f32>>;

fn ddgi_near_mover(position: vec3<f32>) -> bool {
    for (var b = 0u; b < min(ddgi_volume.wake_boxes, DDGI_MAX_WAKE_BOXES); b++) {
        let lo = ddgi_wake[2u * b].xyz;
        let hi = ddgi_wake[2u * b + 1u].xyz;
        if all(position >= lo) && all(position <= hi) {
            return true;
        }
    }
    return false;
}

fn ddgi_has(flag: u32) -> bool {
    return (ddgi_volume.flags & flag) != 0u;
}

// ---------------------------------------------------------------------------------------------
// Directions

fn ddgi_sign_not_zero(v: vec2<f32>) -> vec2<f32> {
    return select(vec2<f32>(-1.0), vec2<f32>(1.0), v >= vec2<f32>(0.0));
}

// Unit direction -> octahedral coordinates in [-1, 1]² (Cigolle et al. 2014).
fn ddgi_oct_encode(d: vec3<f32>) -> vec2<f32> {
    let l1 = abs(d.x) + abs(d.y) + abs(d.z);
    var uv = d.xy / max(l1, 1e-20);
    if d.z < 0.0 {
        uv = (vec2<f32>(1.0) - abs(uv.yx)) * ddgi_sign_not_zero(uv);
    }
    return uv;
}

fn ddgi_oct_decode(uv: vec2<f32>) -> vec3<f32> {
    var d = vec3<f32>(uv, 1.0 - abs(uv.x) - abs(uv.y));
    if d.z < 0.0 {
        d = vec3<f32>((vec2<f32>(1.0) - abs(d.yx)) * ddgi_sign_not_zero(d.xy), d.z);
    }
    return safe_normalize(d, vec3<f32>(0.0, 0.0, 1.0));
}

// Direction of interior texel `texel` of an N × N octahedral map.
fn ddgi_texel_direction(texel: vec2<u32>, n: u32) -> vec3<f32> {
    let uv = (vec2<f32>(texel) + 0.5) / f32(n) * 2.0 - 1.0;
    return ddgi_oct_decode(uv);
}

// Direction i of n spherical Fibonacci points (Keinert et al. 2015): even cover of the sphere.
fn ddgi_spherical_fibonacci(i: u32, n: u32) -> vec3<f32> {
    let golden = 0.618033988749895;
    let phi = 2.0 * PI * fract(f32(i) * golden);
    let cos_theta = 1.0 - (2.0 * f32(i) + 1.0) / f32(max(n, 1u));
    let sin_theta = sqrt(clamp(1.0 - cos_theta * cos_theta, 0.0, 1.0));
    return vec3<f32>(cos(phi) * sin_theta, sin(phi) * sin_theta, cos_theta);
}

// ---------------------------------------------------------------------------------------------
// Probes

// Grid coordinates (from the volume's origin) of the probe stored at index p.
fn ddgi_probe_coords(p: u32) -> vec3<u32> {
    let c = max(ddgi_volume.counts, vec3<u32>(1u));
    let stored = vec3<u32>(p % c.x, (p / c.x) % c.y, p / (c.x * c.y));
    return (stored + c - ddgi_volume.scroll % c) % c;
}

// Index of the probe at grid coordinates `coords` (each below the counts).
fn ddgi_probe_index(coords: vec3<u32>) -> u32 {
    let c = max(ddgi_volume.counts, vec3<u32>(1u));
    let stored = (coords + ddgi_volume.scroll % c) % c;
    return stored.x + c.x * (stored.y + c.y * stored.z);
}

fn ddgi_probe_position(p: u32) -> vec3<f32> {
    return ddgi_volume.origin + ddgi_volume.spacing * vec3<f32>(ddgi_probe_coords(p)) + ddgi_probes[p].offset;
}

// Step k (0–5) towards one of a probe's six face neighbours: −x, +x, −y, +y, −z, +z.
fn ddgi_face_step(k: u32) -> vec3<i32> {
    var step = vec3<i32>(0);
    step[k / 2u] = select(-1, 1, (k & 1u) == 1u);
    return step;
}

// The probe one `step` from probe p, or DDGI_NO_PROBE past the grid's edge.
fn ddgi_neighbour(p: u32, step: vec3<i32>) -> u32 {
    let q = vec3<i32>(ddgi_probe_coords(p)) + step;
    if any(q < vec3<i32>(0)) || any(q >= vec3<i32>(ddgi_volume.counts)) {
        return DDGI_NO_PROBE;
    }
    return ddgi_probe_index(vec3<u32>(q));
}

fn ddgi_probe_active(p: u32) -> bool {
    return (ddgi_probes[p].state & DDGI_PROBE_INACTIVE) == 0u;
}

// Two floats as bfloat16 (the upper halves of their f32 bits, rounded): 8 significant bits, enough
// for an error measure. Half floats would need the SHADER_FLOAT16_IN_FLOAT32 capability.
// Magnitudes are clamped to 1e30 so that rounding cannot carry into infinity.
fn ddgi_pack_bf16(v: vec2<f32>) -> u32 {
    let c = clamp(select(vec2<f32>(0.0), v, v == v), vec2<f32>(-1e30), vec2<f32>(1e30));
    let bits = bitcast<vec2<u32>>(c) + vec2<u32>(0x8000u);
    return (bits.x >> 16u) | (bits.y & 0xffff0000u);
}

fn ddgi_unpack_bf16(w: u32) -> vec2<f32> {
    return vec2<f32>(bitcast<f32>(w << 16u), bitcast<f32>(w & 0xffff0000u));
}

// YCoCg luma of a linear RGB colour.
fn ddgi_luma(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.25, 0.5, 0.25));
}

// Symmetric mean absolute percentage error between two colours in YCoCg (Vardis et al.): per
// channel |a − b| / ((|a| + |b|) / 2 + floor), luma weighted 2:1:1 against the two chroma channels.
// 0 for identical colours, symmetric, and bounded by 2 however dark they are (the floor keeps
// near-black texels from exploding the ratio).
fn ddgi_smape_ycocg(a: vec3<f32>, b: vec3<f32>, floor_value: f32) -> f32 {
    let to_ycocg = mat3x3<f32>(vec3<f32>(0.25, 0.5, -0.25), vec3<f32>(0.5, 0.0, 0.5), vec3<f32>(0.25, -0.5, -0.25));
    let x = to_ycocg * a;
    let y = to_ycocg * b;
    let e = abs(x - y) / ((abs(x) + abs(y)) * 0.5 + max(floor_value, 0.0) + 1e-30);
    return clamp(dot(e, vec3<f32>(0.5, 0.25, 0.25)), 0.0, 2.0);
}

// Top-left texel of probe p's tile (border included) in an atlas of tiles (n + 2)².
fn ddgi_tile_origin(p: u32, n: u32) -> vec2<u32> {
    let tiles = max(ddgi_volume.tiles_per_row, 1u);
    return vec2<u32>(p % tiles, p / tiles) * (n + 2u);
}

// Atlas uv of direction d in probe p's map.
fn ddgi_atlas_uv(p: u32, d: vec3<f32>, n: u32, atlas_size: vec2<f32>) -> vec2<f32> {
    let oct = ddgi_oct_encode(d) * 0.5 + 0.5;
    let texel = vec2<f32>(ddgi_tile_origin(p, n) + vec2<u32>(1u)) + oct * f32(n);
    return texel / atlas_size;
}

fn ddgi_encode_irradiance(e: vec3<f32>) -> vec3<f32> {
    let c = min(sanitize_radiance(e), vec3<f32>(DDGI_MAX_IRRADIANCE));
    return select(vec3<f32>(0.0), pow(c, vec3<f32>(1.0 / DDGI_IRRADIANCE_GAMMA)), c > vec3<f32>(0.0));
}

fn ddgi_decode_irradiance(v: vec3<f32>) -> vec3<f32> {
    let c = clamp(v, vec3<f32>(0.0), vec3<f32>(HALF_MAX));
    return select(vec3<f32>(0.0), pow(c, vec3<f32>(DDGI_IRRADIANCE_GAMMA)), c > vec3<f32>(0.0));
}

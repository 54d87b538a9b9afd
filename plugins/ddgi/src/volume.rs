//! The settings of a probe volume ([`DdgiVolume`]), its probes as entities ([`DdgiProbe`]) and the
//! grid layout both resolve to ([`DdgiLayout`]).

use bevy_ecs::prelude::*;
use glam::{DVec3, UVec3, Vec3};

/// Which weights the sampling function applies when it blends the 8 probes around a point. Each
/// can be switched off, for the ablation `none → back-face → Chebyshev → normal bias`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DdgiWeights {
    /// Wrap-shading weight: probes behind the surface fade out. Costs a dot product per probe.
    pub backface: bool,
    /// Chebyshev visibility test on the distance moments: probes that cannot see the point are
    /// rejected (the main defence against light leaking through walls). Costs a distance-atlas
    /// fetch per probe.
    pub chebyshev: bool,
    /// Offsets the lookup point along the normal and towards the viewer
    /// ([`DdgiVolume::normal_bias`], [`DdgiVolume::view_bias`]) before the other weights, so that a
    /// surface does not shadow itself in the distance maps.
    pub normal_bias: bool,
    /// Log-perception crush: weights under 0.2 are crushed cubically, so faint leaks vanish.
    pub crush: bool,
    /// Trilinear weight by the point's position in the probe cage (without it, the 8 probes count
    /// alike and the field is blocky).
    pub trilinear: bool,
}

impl DdgiWeights {
    /// Every weight on: the default, the full sampling function of the papers.
    pub const ALL: Self = Self { backface: true, chebyshev: true, normal_bias: true, crush: true, trilinear: true };
    /// Trilinear interpolation alone: the start of the visibility ablation.
    pub const NONE: Self = Self { backface: false, chebyshev: false, normal_bias: false, crush: false, trilinear: true };
}

impl Default for DdgiWeights {
    fn default() -> Self {
        Self::ALL
    }
}

/// Adaptive ray budgets (on by default; [`DdgiAdaptive::off`] for the fixed budget): rays go where
/// the lighting changes, and probes that contribute nothing stop costing anything. Measured in
/// BENCHMARKS.md ("Adaptive probes against fixed budgets", the six evaluation scenes after 120
/// frames): as accurate or more than the fixed budget everywhere — much more where light builds up over many bounces (a probe still
/// converging blends faster), at fewer rays.
///
/// Each probe's *temporal error*: per texel of its irradiance map, the change each frame's estimate
/// asks of the texel, smoothed over frames (so that noise averages out and a lasting change stands
/// out), measured as the SMAPE in YCoCg between the texel and the texel plus that change; averaged
/// over the map. A probe
/// gets `min_rays + (rays_per_probe − min_rays) · min(error / error_target, 1)` rays: at once when
/// its error rises, shrinking by `decay` per frame when it falls. A probe over the error target at
/// its full budget blends at twice the rate (1 − h doubled) until its error falls, so it follows a
/// change sooner. A probe whose error at an update is under `rest_error · error_target` rests (see
/// `max_rest_frames`): in a static scene most probes end up updating once every few frames, and a
/// resting probe's maps do not move at all, so fewer rays do not mean more flicker (measured: the
/// static phases of six scenes flicker 0.38–1.04 times as much as with the fixed budget). The
/// hysteresis can also rise with fewer rays (`hysteresis_exponent`), which calms a quiet probe's
/// maps further but slows how it follows light that builds up over many bounces. Probes that, like
/// their six neighbours, see almost no light are switched off (and woken by the re-checks).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Clone, Debug, PartialEq)]
pub struct DdgiAdaptive {
    /// Whether the budgets adapt (and probes rest or go dark); false: the fixed budget, every
    /// active probe tracing the volume's `rays_per_probe` every frame.
    pub enabled: bool,
    /// Fewest rays of an active probe (≥ 1; at most the volume's `rays_per_probe`, which it is
    /// held to when larger).
    pub min_rays: u32,
    /// Smoothed error at which a probe gets the volume's full `rays_per_probe`. Lower: more rays
    /// everywhere (closer to a fixed budget).
    pub error_target: f32,
    /// Factor by which a quiet probe's budget shrinks per frame, in [0, 1].
    pub decay: f32,
    /// Weight of the old value in the exponential moving average of each texel's change, in
    /// [0, 1]: higher averages the noise of small budgets out better but sees a change later.
    pub error_smoothing: f32,
    /// Added to SMAPE's denominator (W/m²), so near-black texels do not explode the ratio.
    pub error_floor: f32,
    /// A probe is dark, and switched off, when it and its six neighbours see less luma than this
    /// share of the brightest probe's.
    pub dark_fraction: f32,
    /// Largest total of rays per frame; over it, every probe's share shrinks in proportion (so
    /// the budget goes where the error asked for it). `None`: no limit.
    pub frame_budget: Option<u32>,
    /// Longest rest of a quiet probe, in the volume's updates (frames while it updates every
    /// frame; see `max_update_period`) (≤ 1: probes never rest). A probe whose error at
    /// an update is under `rest_error × error_target` has converged: it keeps its maps and skips
    /// its next updates (no rays, no per-probe pass), for a period that doubles at each quiet
    /// update up to this. A neighbour's error over the target wakes it at once, as does an
    /// instance moving within a spacing of it and any change of light the CPU sees (a light, the
    /// sky, a material or mesh, instances added or removed, the volume's settings). Longer: fewer
    /// rays and less GPU time in static scenes; a change the CPU cannot see reaches a resting
    /// probe only through its neighbours or its next update.
    pub max_rest_frames: u32,
    /// Share of `error_target` under which a probe's error counts as quiet (lets it rest); with
    /// `rest_smoothing`, its settled error instead. Lower: only well-converged probes rest.
    /// Measured in BENCHMARKS.md ("Adaptive probes against fixed budgets"): in the open, sunlit
    /// demo level 0.5 traces 2.63× fewer rays
    /// than the fixed budget at 3.5% less error where the default 0.35 traces 1.96× fewer at 3.4%
    /// more, but on a dense cathedral grid (32×16×32) 0.5 costs 7.2% more error.
    pub rest_error: f32,
    /// How a probe's hysteresis follows its share of the rays, in [0, 1]: 1 − h scales with
    /// `(rays / rays_per_probe)^hysteresis_exponent`. 1 keeps the noise of an awake quiet probe's
    /// maps at the full budget's, but it then follows slow changes (light still building up over
    /// many bounces) as many times slower as it has fewer rays; 0 (the default) keeps the
    /// volume's hysteresis, so every probe follows light at the fixed budget's pace (an awake
    /// probe with an eighth of the rays is √8 times noisier; resting probes do not move at all).
    /// Measured in BENCHMARKS.md (after the cathedral's sun turns, 720 frames): the error is
    /// back within 10% of its settled value after 195 / 302 / 418 frames at exponents 0 / ¼ / ½,
    /// 232 with the fixed budget; static error and flicker at 0 stay within 3% and under the fixed
    /// budget's. No cost either way.
    pub hysteresis_exponent: f32,
    /// `Some(s)` (the default, 0.97): resting is decided by a *settled* error — the same SMAPE
    /// over a slower moving average of each texel's change (weight `s` of the old value, in
    /// [0, 1)) — under `rest_error × error_target`, with the error itself under `error_target`.
    /// Noise is zero-mean, so the slower average keeps less of it (√((1 − s) / (1 + s)) of one
    /// frame's: 0.12 at 0.97 against 0.23 at the error's 0.9), while a map still converging
    /// changes the same way frame after frame and keeps its full measure; a probe that sees a few
    /// bright hits can then rest once its map has converged, where its noise alone keeps it awake.
    /// The average is corrected for its start (as Adam's moments are), so a fresh probe does not
    /// look settled. The price: the slow average needs about three times as many updates as the
    /// fast one to register a small lasting change; a change of light the CPU sees wakes every
    /// resting probe at once, which keeps the recovery fast. The settled error also judges calm
    /// phases (see `calm_error`). Measured in BENCHMARKS.md ("Adaptive probes against fixed
    /// budgets"; static phases against the fixed budget in the five evaluation scenes at their own grids and a denser cathedral
    /// grid, calm phases still judged on the error alone): FLIP within 5% of the fixed budget's in
    /// all six (the default rule, `None`, +7.1% on the denser grid), 1.8–15× fewer rays and
    /// 1.0–5.3× less probe-update time (`None`: 1.7–14×, 1.0–4.7×), recovery after a change in
    /// fewer frames than the fixed budget in all six. `None`: the error itself decides, and the
    /// slow average is not kept. Cost: a few instructions per texel in the irradiance update (not
    /// timed apart), no memory (bfloat16 in the texel's spare words).
    pub rest_smoothing: Option<f32>,
    /// Longest *volume* update period in calm phases, in frames (1: the volume updates every
    /// frame, as without it). While the volume is calm — its active probes past their first
    /// update (but for a few a re-check switched back on) and their mean error under
    /// `calm_error` × `error_target`, at
    /// [`CALM_UPDATES`] updates in a row — its period doubles (1 → 2 → 4 …, up to this): on the
    /// frames between, the whole probe update (`ddgi_budget`, `ddgi_trace`, `ddgi_probe_update`)
    /// is left out and the gather reads the last maps. Anything the CPU sees change drops the
    /// period to 1 on that frame, which updates: a light (moved, recoloured, added or removed),
    /// the sky, a material or mesh, an instance added or removed or moving within a probe spacing
    /// of the volume, the volume's settings, bounds, scroll or render origin, a pin, a reset or a
    /// step; an update that is not calm drops it to 1 as well. Counted in updates as the rest of
    /// the adaptive state is: a resting probe rests `max_rest_frames` of the volume's updates, so
    /// up to `max_rest_frames × max_update_period` frames; hysteresis and error smoothing act per
    /// update. Effect: in a still scene, the per-pass floors of small updates (a partial wave's
    /// latency: about half of a small update's GPU time, whatever its rays) are paid once every
    /// few frames, and rays per frame fall by the same factor; a change the CPU cannot see (none
    /// in this engine: lights, sky, materials and instances are all watched) would wait up to
    /// this many frames, and a probe the camera comes to need (switched off for an empty
    /// region) comes back within as many. Cost: none (a few CPU instructions per frame).
    pub max_update_period: u32,
    /// Share of `error_target` under which the mean error of a volume's active probes counts as
    /// calm (see `max_update_period`); with `rest_smoothing`, the smaller of the mean of their
    /// errors and the mean of their settled errors, so that a volume whose maps have converged
    /// goes calm though its probes' noise keeps their errors up. Measured with that reading in
    /// BENCHMARKS.md ("Adaptive probes against fixed budgets"; static phases against the fixed
    /// budget, the error alone in brackets): the demo level 9.98× fewer rays and 6.41× less probe-update time at 6.7% less
    /// error (3.34×, 1.82×, 0.6% less: it was never calm), the cathedral 8.68× and 5.98× at +1.1%
    /// (4.45×, 2.16×, +3.8%), the other scenes as before; on a denser cathedral grid (32×16×32),
    /// which goes calm while its light still builds up, +5.6% (+3.9%) for 8.76× and 7.02× (7.68×,
    /// 5.35×). Higher: the period grows in noisier volumes too (a few probes that see a small
    /// bright light keep their errors near the target for a long time: `color_bleed`'s 8 probes
    /// sit at 0.65–1.0 of it through their first 240 frames and go calm only after that), but
    /// also sooner after a change, while light still builds up over bounces, which then converges
    /// that many times slower. Measured at 128² (`eval --time-series`, 256-spp reference; static
    /// FLIP against the fixed budget's, the error alone judging): Cornell's box
    /// (8×8×8) +2.5% at 0.5 (15.9× fewer rays a frame), +6.6% at 1.0; `color_bleed` (2×2×2) never
    /// calm in 240 frames at 0.5 (1.5× fewer), −0.7% at 1.0 (5.3× fewer). No cost.
    pub calm_error: f32,
    /// How much faster a *drifting* probe blends, in [1, 64] (1: off, the default). With
    /// `rest_smoothing`, a probe whose settled error is most of its error — its map moves the same
    /// way update after update, as while light still builds up over many bounces; noise leaves the
    /// slow average about half of the fast one's — multiplies its 1 − hysteresis by up to this
    /// (fully from a share of 0.9, none under 0.6: [`crate::gpu::DRIFT_SHARE_FULL`],
    /// [`crate::gpu::DRIFT_SHARE_LOW`]), so multi-bounce light converges that many times sooner
    /// while noise keeps the usual blending (tested: 4.5× closer after 60 frames at 4, the
    /// converged maps' flicker 1.33× the usual, 4.2× if every probe blended at 4×).
    ///
    /// Off by default because converging sooner is not always closer to the truth: where DDGI's
    /// own converged answer carries more indirect light than a path tracer finds, a volume that
    /// gets there sooner is further off earlier. Measured in BENCHMARKS.md ("Tried, not the
    /// default: drifting probes blend faster"; static FLIP after 240 frames against the fixed
    /// budget's, rays and probe-update time fewer): at 4,
    /// `color_bleed` (8 probes in a closed box, light building up for hundreds of frames) −3.2%,
    /// 12.5× and 4.1× (off: −3.8%, 2.0×, 1.05×) and Cornell's box −0.9%, 27×, 4.2× (off: +1.5%,
    /// 15×, 4.1×), but the cathedral +17% (off: +1.1%), the demo level +21% (off: −6.7%) and
    /// `door_room` +7.5% (off: +4.1%), whose fixed budgets are still on their way to a worse
    /// answer at 240 frames (the cathedral's FLIP 0.0549 then, 0.0722 at 720); at 2, the level
    /// +4.3% but the cathedral +14%. Recovery after a change was faster in all five. Cost: a few
    /// instructions per probe update.
    pub drift_rate: f32,
}

/// Calm updates in a row at one volume update period before it doubles
/// ([`DdgiAdaptive::max_update_period`]).
pub const CALM_UPDATES: u32 = 8;

impl Default for DdgiAdaptive {
    fn default() -> Self {
        Self {
            enabled: true,
            min_rays: 16,
            error_target: 0.1,
            decay: 0.9,
            error_smoothing: 0.9,
            error_floor: 1e-3,
            dark_fraction: 1e-3,
            frame_budget: None,
            max_rest_frames: 8,
            rest_error: 0.35,
            hysteresis_exponent: 0.0,
            rest_smoothing: Some(0.97),
            max_update_period: 4,
            calm_error: 0.5,
            drift_rate: 1.0,
        }
    }
}

impl DdgiAdaptive {
    /// Adaptive budgets on, with the default parameters.
    pub fn on() -> Self {
        Self { enabled: true, ..Default::default() }
    }

    /// The fixed budget: every active probe traces `rays_per_probe` rays every update.
    pub fn off() -> Self {
        Self { enabled: false, ..Default::default() }
    }
}

/// A volume of irradiance probes. Add it to an entity to light the scene inside its bounds with
/// dynamic diffuse global illumination; several volumes may coexist (each pixel blends the volumes
/// that contain it; a volume's probe rays read only its own probes).
///
/// Cost grows with `probe count × rays_per_probe` (tracing, shading) and with
/// `probe count × texels²` (the map updates); the camera's gather costs 8 probe lookups per pixel
/// whatever the grid.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize), serde(default, deny_unknown_fields))]
#[derive(Component, Clone, Debug, PartialEq)]
pub struct DdgiVolume {
    /// World-space box the probes fill, `(min, max)`, in double precision (world coordinates, not
    /// render space: see [`engine::scene::RenderOrigin`]; a box 100 km out keeps its place to the
    /// micrometre); `None`: the bounds of the scene's instances. Probes sit at the centres of
    /// `probe_counts` equal cells of the box.
    pub bounds: Option<(DVec3, DVec3)>,
    /// Probes along x, y and z (any size ≥ 1, not only powers of two); `None` (the default): the
    /// grid [`auto_probe_counts`] fits to the box (16 along its longest side, at least 8 along
    /// the others unless they are thin). More
    /// probes: finer light and sharper shadows of it, proportionally more rays, memory and update
    /// time.
    pub probe_counts: Option<UVec3>,
    /// Rays each probe traces per frame. More rays: less noise, proportionally more trace and
    /// shading time.
    pub rays_per_probe: u32,
    /// Side of each probe's octahedral irradiance map, in texels (default 8). Atlas memory and the
    /// irradiance update grow with its square.
    pub irradiance_texels: u32,
    /// Side of each probe's octahedral distance map (mean and mean² of hit distances, default 16).
    pub distance_texels: u32,
    /// Weight of the old value when blending in a frame's rays, in [0, 1]: close to 1 is stable but
    /// slow to follow changes; 0 takes each frame's (noisy) value as is.
    pub hysteresis: f32,
    /// Offset of the lookup point along the surface normal, as a fraction of the cell's extent
    /// along the normal (the spacing along an axis-aligned normal: a wall's lookup moves by a share
    /// of the spacing across it, whatever the cell's height). Too small: self-shadowing blotches,
    /// and probes just behind a thin wall pass the visibility test; too large: the lookup leaves
    /// a narrow space. Cost: two vector lengths a lookup (not timed apart).
    pub normal_bias: f32,
    /// Offset of the lookup point towards the viewer, as a fraction of the cell's extent along the
    /// view direction (as `normal_bias`).
    pub view_bias: f32,
    /// Exponent of the cosine weighting of hit distances in the distance update (50 in the
    /// literature): higher keeps visibility edges sharp.
    pub distance_sharpness: f32,
    /// Longest probe ray in world units (at most 1e30); `None`: unbounded. Shorter rays are cheaper in large
    /// scenes and miss (seeing the sky) beyond it.
    pub max_ray_distance: Option<f32>,
    /// Radiance of probe rays that escape the scene, the same in every direction; `None`: the
    /// engine's [`engine::render::Sky`] along each ray.
    pub sky_radiance: Option<Vec3>,
    /// The sampling function's weights.
    pub weights: DdgiWeights,
    /// Moves probes out of walls and away from surfaces, within their cell (Majercik et al. 2021).
    pub relocation: bool,
    /// Switches off probes inside geometry or with no surface in reach; they trace no rays except
    /// on re-check frames and get no weight in the sampling function.
    pub classification: bool,
    /// A new irradiance sample brighter than `1 + firefly_threshold` times the texel's current
    /// luminance moves it only a quarter of the way (damps fireflies from rare very bright hits).
    /// 0 switches it off.
    pub firefly_threshold: f32,
    /// Share of back-face hits above which a probe counts as inside geometry.
    pub backface_threshold: f32,
    /// Relocation keeps probes at least this far from front faces, as a fraction of the smallest
    /// probe spacing.
    pub min_frontface_distance: f32,
    /// Inactive probes trace again every this many frames (and all of them when instances are
    /// added or removed) so that they wake when the scene changes. Around an instance that moves,
    /// only the probes within a probe spacing of where it was or is now wake, in the frame it
    /// moves — a switched-off one traces its re-check rays, a resting one updates — unless more
    /// than [`crate::gpu::MAX_WAKE_BOXES`] instances moved in the volume, when every switched-off
    /// probe re-checks. 0: only then.
    pub recheck_interval: u32,
    /// Rays of an inactive probe on a re-check frame.
    pub recheck_rays: u32,
    /// Adaptive per-probe ray budgets and the switching off of dark probes.
    pub adaptive: DdgiAdaptive,
    /// Seed of the per-frame random rotation of the ray directions.
    pub seed: u64,
    /// A fresh probe (new, scrolled in, or switched back on) blends its first updates as a running
    /// mean of its estimates — the k-th weighs 1/k — until that is slower than `hysteresis`
    /// (G3D's just-woken probes converge this way): after k updates its maps hold k frames' worth
    /// of rays instead of mostly the first frame's. Off (the default for a fixed volume, whose
    /// behaviour it keeps), a fresh probe takes its first estimate and then the hysteresis.
    /// On in [`crate::DdgiCascades`]' volumes, whose scrolled-in probes must converge fast. No cost.
    pub warm_up: bool,
    /// Update the probes only every this many frames (≥ 1; the gather still reads them every
    /// frame): far cascades change slowly on screen and need fewer updates. A volume updates
    /// whatever its period on the frame it scrolls and in its first frames.
    pub update_period: u32,
    /// Which frames of the period update: those where `(frame + update_phase) % update_period == 0`
    /// (cascades take different phases so their updates do not fall on the same frames).
    pub update_phase: u32,
    /// Traces the probe rays with persistent threads (off by default): the pass `ddgi_trace`
    /// only finds each ray's closest hit, a workgroup of [`crate::gpu::PERSISTENT_TRACE_GROUP`]
    /// lanes walking a share of the rays, a lane taking its next ray inside the traversal loop
    /// when its walk ends (so that a warp's lanes do not idle while its slowest finishes); the
    /// hits go through a buffer (`ddgi_hits`, 24 bytes a ray) to the pass `ddgi_shade`, which
    /// shades them a thread a ray. Off, `ddgi_trace` traces and shades each ray in one thread.
    /// Both give the same rays, hits and shading. Cost: 24 bytes of GPU memory a ray, and one
    /// more dispatch (which a small update, latency-bound, pays for). Effect (`game_demo bench
    /// ddgi --persistent-trace`, both ways in one run; the figures in BENCHMARKS.md, "DDGI: full
    /// probe update throughput"): the closest hits take about half the time, but the shading pass
    /// walks its shadow rays a thread a ray, so the whole probe update gains only a few per cent.
    pub persistent_trace: bool,
    /// Near-field occlusion at the probe rays' hits (0, the default: off): rays, each of
    /// `hit_occlusion_reach`, traced from each hit over its hemisphere (cosine-distributed). The
    /// probes' irradiance at a hit is the light of the open space around the probes, so in a
    /// corner, a crevice or under a ledge it counts light that nearby surfaces block, and each
    /// bounce passes that excess on; DDGI's converged maps then hold more indirect light than a
    /// path tracer finds. With these rays a blocked share of the hemisphere sees, instead of the
    /// probes' light, a nearby surface taken to reflect like the hit's own (its emission plus its
    /// albedo times the probes' light), which keeps a closed emitting room (a furnace) exact.
    /// Measured in BENCHMARKS.md ("Where the converged excess of indirect light comes from"): at
    /// 128² (cathedral 16×8×12 × 32 rays, the fixed budget after 720 frames, against a 512-path
    /// path tracer) 8 rays take the converged image's mean luminance from 1.039× the path
    /// tracer's to 1.020× (reach 0.5) or 1.007× (reach 1), FLIP −8% / −12%; with `eval
    /// --time-series` (fixed budget, the error settled 240 frames after a change) the cathedral's
    /// FLIP −13% and the demo level's −10%, at about 2.4 times the probe-update time. One ray
    /// does as well as eight (1.008× at reach 1): each frame's probe rays point elsewhere, so the
    /// hysteresis averages the blocked share. Off by default: that one ray's cost is not yet
    /// measured, and on a coarse grid the reach, a share of the spacing, takes far walls for near
    /// surfaces (color_bleed's 2×2×2 probes: darker, FLIP +6%). Cost: that many more any-hit rays
    /// per probe ray (short ones), in `ddgi_trace` or `ddgi_shade`.
    pub hit_occlusion_rays: u32,
    /// Reach of the hit occlusion rays, as a share of the smallest probe spacing (> 0): the
    /// surfaces nearer than this to a hit count as blocking it. Longer: more of the probes'
    /// over-count removed, and more of the far field wrongly taken for a near surface.
    pub hit_occlusion_reach: f32,
}

impl Default for DdgiVolume {
    fn default() -> Self {
        Self {
            bounds: None,
            probe_counts: None,
            rays_per_probe: 128,
            irradiance_texels: 8,
            distance_texels: 16,
            hysteresis: 0.97,
            normal_bias: 0.04,
            view_bias: 0.15,
            distance_sharpness: 50.0,
            max_ray_distance: None,
            sky_radiance: None,
            weights: DdgiWeights::ALL,
            relocation: true,
            classification: true,
            firefly_threshold: 8.0,
            backface_threshold: 0.25,
            min_frontface_distance: 0.1,
            recheck_interval: 16,
            recheck_rays: 16,
            adaptive: DdgiAdaptive::default(),
            seed: 0xdd61,
            warm_up: false,
            update_period: 1,
            update_phase: 0,
            persistent_trace: false,
            hit_occlusion_rays: 0,
            hit_occlusion_reach: 0.5,
        }
    }
}

/// Largest number of probes in one volume.
pub const MAX_PROBES: u32 = 1 << 22;
/// Largest number of hit occlusion rays per probe ray ([`DdgiVolume::hit_occlusion_rays`]).
pub const MAX_HIT_OCCLUSION_RAYS: u32 = 64;
/// Largest number of rays per probe.
pub const MAX_RAYS_PER_PROBE: u32 = 4096;
/// Largest side of a probe map.
pub const MAX_MAP_TEXELS: u32 = 64;

/// Probes along the longest side of a volume whose grid is left to [`auto_probe_counts`].
pub const AUTO_PROBES_LONGEST: u32 = 16;
/// Fewest probes [`auto_probe_counts`] puts along a side at least an eighth as long as the longest.
pub const AUTO_PROBES_MIN: u32 = 8;

/// The grid of a volume of `extent` whose [`DdgiVolume::probe_counts`] is `None`: 16 probes along
/// its longest side and in proportion along the others, but at least 8 along any side an eighth as
/// long or more (a field 44 m wide and 7 m high gets 16×8×16, not 16×3×16: the light changes most
/// near the ground, and a flat grid holds it in two layers), and at least 2 along a thinner one (a
/// floor gets a grid two probes thick). Measured in BENCHMARKS.md (FLIP against the path tracer
/// with the fixed budget): the densities of 16 along the longest side beat 8 and 32 in the
/// door room, the demo level and Cornell's box, and 16×8×16 beat the demo level's own
/// 1.5-metre grid (26×5×26, 0.0339 against 0.0400). At most 16³ = 4,096 probes: 524,288 rays a
/// frame at 128 rays a probe (fewer with adaptive budgets), 1.3 MiB of atlases.
pub fn auto_probe_counts(extent: Vec3) -> UVec3 {
    let extent = Vec3::select(extent.is_finite_mask(), extent.max(Vec3::ZERO), Vec3::ZERO);
    let longest = extent.max_element();
    if longest <= 0.0 {
        return UVec3::splat(2);
    }
    let proportional = (extent / longest * AUTO_PROBES_LONGEST as f32).round().as_uvec3();
    let floor = UVec3::select(extent.cmpge(Vec3::splat(longest / 8.0)), UVec3::splat(AUTO_PROBES_MIN), UVec3::splat(2));
    proportional.max(floor).min(UVec3::splat(AUTO_PROBES_LONGEST))
}

/// The extent a volume of box size `size` (non-negative) is laid out over: a flat scene (a single
/// floor) still gets a volume with some thickness, a thousandth of its largest side.
pub(crate) fn volume_extent(size: Vec3) -> Vec3 {
    size.max(Vec3::splat(size.max_element().max(1e-6) * 1e-3))
}

impl DdgiVolume {
    /// Checks every setting; the first problem found is returned with its field and value.
    pub fn validate(&self) -> Result<(), DdgiSettingsError> {
        if let Some(c) = self.probe_counts {
            if c.min_element() == 0 {
                return Err(invalid("probe_counts", c, "every axis needs at least one probe"));
            }
            if u64::from(c.x) * u64::from(c.y) * u64::from(c.z) > u64::from(MAX_PROBES) {
                return Err(invalid("probe_counts", c, "more than 4,194,304 probes"));
            }
        }
        if !(1..=MAX_RAYS_PER_PROBE).contains(&self.rays_per_probe) {
            return Err(invalid("rays_per_probe", self.rays_per_probe, "must be between 1 and 4096"));
        }
        if !(1..=MAX_MAP_TEXELS).contains(&self.irradiance_texels) {
            return Err(invalid("irradiance_texels", self.irradiance_texels, "must be between 1 and 64"));
        }
        if !(1..=MAX_MAP_TEXELS).contains(&self.distance_texels) {
            return Err(invalid("distance_texels", self.distance_texels, "must be between 1 and 64"));
        }
        if !(0.0..=1.0).contains(&self.hysteresis) {
            return Err(invalid("hysteresis", self.hysteresis, "must be between 0 and 1"));
        }
        if self.hit_occlusion_rays > MAX_HIT_OCCLUSION_RAYS {
            return Err(invalid("hit_occlusion_rays", self.hit_occlusion_rays, "must be at most 64"));
        }
        if !(self.hit_occlusion_reach.is_finite() && self.hit_occlusion_reach > 0.0) {
            return Err(invalid("hit_occlusion_reach", self.hit_occlusion_reach, "must be finite and positive"));
        }
        let non_negative = [
            ("normal_bias", self.normal_bias),
            ("view_bias", self.view_bias),
            ("firefly_threshold", self.firefly_threshold),
            ("min_frontface_distance", self.min_frontface_distance),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(invalid(field, value, "must be finite and not negative"));
            }
        }
        let a = &self.adaptive;
        let fractions =
            [("adaptive.decay", a.decay), ("adaptive.error_smoothing", a.error_smoothing), ("adaptive.dark_fraction", a.dark_fraction)];
        for (field, value) in fractions {
            if !(0.0..=1.0).contains(&value) {
                return Err(invalid(field, value, "must be between 0 and 1"));
            }
        }
        if !(a.error_target.is_finite() && a.error_target > 0.0) {
            return Err(invalid("adaptive.error_target", a.error_target, "must be finite and positive"));
        }
        if !(a.error_floor.is_finite() && a.error_floor >= 0.0) {
            return Err(invalid("adaptive.error_floor", a.error_floor, "must be finite and not negative"));
        }
        // Above rays_per_probe it is held there (a volume of 8 rays a probe keeps the default 16).
        if a.enabled && a.min_rays == 0 {
            return Err(invalid("adaptive.min_rays", a.min_rays, "must be at least 1"));
        }
        if !(a.rest_error.is_finite() && a.rest_error >= 0.0) {
            return Err(invalid("adaptive.rest_error", a.rest_error, "must be finite and not negative"));
        }
        if let Some(s) = a.rest_smoothing
            && !(0.0..1.0).contains(&s)
        {
            return Err(invalid("adaptive.rest_smoothing", s, "must be in [0, 1)"));
        }
        if !(0.0..=1.0).contains(&a.hysteresis_exponent) {
            return Err(invalid("adaptive.hysteresis_exponent", a.hysteresis_exponent, "must be in [0, 1]"));
        }
        if a.max_rest_frames > 0xffff {
            return Err(invalid("adaptive.max_rest_frames", a.max_rest_frames, "must be at most 65535"));
        }
        if !(1..=64).contains(&a.max_update_period) {
            return Err(invalid("adaptive.max_update_period", a.max_update_period, "must be between 1 and 64 frames"));
        }
        if !(a.drift_rate.is_finite() && (1.0..=64.0).contains(&a.drift_rate)) {
            return Err(invalid("adaptive.drift_rate", a.drift_rate, "must be between 1 and 64"));
        }
        if !(a.calm_error.is_finite() && a.calm_error >= 0.0) {
            return Err(invalid("adaptive.calm_error", a.calm_error, "must be finite and not negative"));
        }
        if a.frame_budget == Some(0) {
            return Err(invalid("adaptive.frame_budget", 0, "must be positive (None: no limit)"));
        }
        if !(1..=1024).contains(&self.update_period) {
            return Err(invalid("update_period", self.update_period, "must be between 1 and 1024 frames"));
        }
        if self.recheck_rays == 0 {
            return Err(invalid("recheck_rays", 0, "must be at least 1"));
        }
        if !(self.distance_sharpness.is_finite() && self.distance_sharpness > 0.0) {
            return Err(invalid("distance_sharpness", self.distance_sharpness, "must be finite and positive"));
        }
        if !(0.0..=1.0).contains(&self.backface_threshold) {
            return Err(invalid("backface_threshold", self.backface_threshold, "must be between 0 and 1"));
        }
        if let Some(d) = self.max_ray_distance
            && !(d.is_finite() && d > 0.0 && d <= crate::gpu::UNBOUNDED_RAY)
        {
            return Err(invalid("max_ray_distance", d, "must be positive and at most 1e30 (None: unbounded)"));
        }
        if let Some(sky) = self.sky_radiance
            && !(sky.is_finite() && sky.min_element() >= 0.0)
        {
            return Err(invalid("sky_radiance", sky, "must be finite and not negative"));
        }
        if let Some((lo, hi)) = self.bounds
            && !(lo.is_finite() && hi.is_finite() && hi.cmpge(lo).all())
        {
            return Err(invalid("bounds", (lo, hi), "must be finite with max ≥ min on every axis"));
        }
        Ok(())
    }
}

mod error;
mod layout;
mod probe;

pub use error::DdgiSettingsError;
use error::invalid;
pub use layout::{BYTES_PER_RAY, DdgiBufferSizes, DdgiLayout, DdgiLimits};
pub use probe::{DdgiProbe, DdgiProbePin, DdgiProbeState};

// Auto-exposure (engine::render::exposure): its parameters and the bins of log₂ luminance that
// exposure_histogram.wgsl counts and exposure_adapt.wgsl averages.
#include "scene.inc.wgsl"

const EXPOSURE_BINS: u32 = 64u;

struct ExposureParams {
    min_ev100: f32,
    max_ev100: f32,
    low_percentile: f32,
    high_percentile: f32,
    compensation: f32,
    speed_brighten: f32,
    speed_darken: f32,
    delta_seconds: f32,
}

@group(1) @binding(0) var<uniform> exposure_params: ExposureParams;

// log₂ luminance spans [min EV100 − 3, max EV100 − 3] (EV100 = log₂ L + 3), a stop either side.
fn exposure_log_range() -> vec2<f32> {
    let offset = log2(100.0 / 12.5);
    return vec2<f32>(exposure_params.min_ev100 - offset - 1.0, exposure_params.max_ev100 - offset + 1.0);
}

fn exposure_bin(l: f32) -> u32 {
    if !(l > 0.0) {
        return 0u;
    }
    let range = exposure_log_range();
    let t = (log2(l) - range.x) / max(range.y - range.x, 1e-6);
    return u32(clamp(t * f32(EXPOSURE_BINS), 0.0, f32(EXPOSURE_BINS - 1u)));
}

fn exposure_bin_log_luminance(i: u32) -> f32 {
    let range = exposure_log_range();
    return range.x + (f32(i) + 0.5) / f32(EXPOSURE_BINS) * (range.y - range.x);
}

// Pass `exposure_adapt` (auto-exposure): the mean log₂ luminance of the histogram's pixels between
// the two percentiles, as an exposure value (EV100 = log₂ L + log₂(100 / 12.5)), less the
// compensation, clamped to the range; the camera's exposure value moves towards it at the set speed
// (jumps on the first frame). Writes (EV100, exposure, 1, 0) for the tonemapper.
#include "exposure.inc.wgsl"

@group(1) @binding(1) var<storage, read> exposure_histogram: array<u32, EXPOSURE_BINS>;
@group(1) @binding(2) var<storage, read_write> exposure_state: vec4<f32>;

@compute @workgroup_size(1)
fn main() {
    var total = 0.0;
    for (var i = 0u; i < EXPOSURE_BINS; i++) {
        total += f32(exposure_histogram[i]);
    }
    let lo = total * exposure_params.low_percentile;
    let hi = total * exposure_params.high_percentile;
    var below = 0.0;
    var weight = 0.0;
    var sum = 0.0;
    for (var i = 0u; i < EXPOSURE_BINS; i++) {
        let n = f32(exposure_histogram[i]);
        // The share of this bin's pixels inside [lo, hi] of the sorted pixels.
        let w = clamp(below + n, lo, hi) - clamp(below, lo, hi);
        sum += w * exposure_bin_log_luminance(i);
        weight += w;
        below += n;
    }
    let previous = exposure_state;
    var target_ev = previous.x;
    if weight > 0.0 {
        let ev = sum / weight + log2(100.0 / 12.5) - exposure_params.compensation;
        target_ev = clamp(ev, exposure_params.min_ev100, exposure_params.max_ev100);
    }
    var ev = target_ev;
    if previous.z > 0.5 && previous.x == previous.x {
        let dt = exposure_params.delta_seconds;
        // A higher target: the scene got brighter.
        ev = previous.x + clamp(target_ev - previous.x, -exposure_params.speed_darken * dt, exposure_params.speed_brighten * dt);
    }
    ev = clamp(ev, exposure_params.min_ev100, exposure_params.max_ev100);
    exposure_state = vec4<f32>(ev, 1.0 / (1.2 * exp2(ev)), 1.0, 0.0);
}

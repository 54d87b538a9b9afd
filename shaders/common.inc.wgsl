// Shared constants and numerically guarded helpers.

const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
// Largest finite half float: radiance written to f16 targets is clamped below it.
const HALF_MAX: f32 = 65504.0;

// Normalizes v, or returns `fallback` when v is zero, tiny or not finite.
fn safe_normalize(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let len2 = dot(v, v);
    if !(len2 > 1e-30) || !(len2 < 1e30) {
        return fallback;
    }
    return v * inverseSqrt(len2);
}

// Largest radiance the shaders keep: +inf (an overflow of finite inputs) clamps to it, so a very
// bright value stays very bright instead of turning black.
const RADIANCE_MAX: f32 = 3.0e38;

// Replaces NaN and negative values by zero and clamps to a finite maximum (+inf included).
fn sanitize_radiance(c: vec3<f32>) -> vec3<f32> {
    // NaN fails every comparison, so select() keeps it out.
    return select(vec3<f32>(0.0), min(c, vec3<f32>(RADIANCE_MAX)), c >= vec3<f32>(0.0));
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// The sRGB transfer function (linear -> encoded), per channel, for values in [0, 1].
fn srgb_encode(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(max(c, vec3<f32>(0.0031308)), vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

// A 32-bit integer hash (lowbias32, Chris Wellons): decorrelates neighbouring inputs.
fn hash_lowbias32(x_in: u32) -> u32 {
    var x = x_in;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

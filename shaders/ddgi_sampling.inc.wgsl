// DDGI sampling: the irradiance at a surface point from the 8 probes of the cage around it, with
// every weight (back-face, Chebyshev visibility, crush, trilinear) and the normal/view bias. The
// probe rays' shading and the camera's gather use it, and any crate's WGSL may include it to light
// its own surfaces by a volume's probes: bind group 1 with the volume's sampling resources
// (`ddgi_volume`, `ddgi_probes`, `ddgi_irradiance`, `ddgi_distance`, `ddgi_sampler`; see
// ddgi::VolumeGpu::sampling_bindings) and call ddgi_sample_irradiance.
#include "ddgi_common.inc.wgsl"


// Point p in grid units (probe (0, 0, 0) at the origin, one unit per cell).
fn ddgi_grid_coords(p: vec3<f32>) -> vec3<f32> {
    return (p - ddgi_volume.origin) / max(ddgi_volume.spacing, vec3<f32>(1e-30));
}

// The cage (the grid cell whose 8 corner probes light a point) around `grid` (grid units): its
// lowest corner, clamped so that the cage stays inside the grid (points beyond the outer probes
// take the outer cell).
fn ddgi_cage_base(grid: vec3<f32>) -> vec3<i32> {
    let max_base = vec3<i32>(max(ddgi_volume.counts, vec3<u32>(2u)) - vec3<u32>(2u));
    return clamp(vec3<i32>(floor(grid)), vec3<i32>(0), max_base);
}

// The extent of a cell along unit direction d (world units): its spacing along an axis, and between
// the spacings for other directions. The normal and view biases are shares of it, so that on a
// cell much longer than it is high (a grid over a wide flat scene) a wall's lookup point moves off
// the wall by a share of the spacing across the wall, not of the cell's height (measured on
// door_room_thin: BENCHMARKS.md, "Thin walls at every grid").
fn ddgi_cell_extent(d: vec3<f32>) -> f32 {
    return length(d * ddgi_volume.spacing);
}

// Corner i (0–7) of a cage: its offset from the lowest corner.
fn ddgi_cage_step(i: u32) -> vec3<u32> {
    return vec3<u32>(i & 1u, (i >> 1u) & 1u, (i >> 2u) & 1u);
}

// The probe at corner `step` of the cage at `base` (a grid one probe thick repeats its layer).
fn ddgi_cage_probe(base: vec3<i32>, step: vec3<u32>) -> u32 {
    return ddgi_probe_index(min(vec3<u32>(base) + step, ddgi_volume.counts - vec3<u32>(1u)));
}

// Irradiance arriving at point `p` with unit normal `n`, seen from direction `to_viewer` (unit, from
// p towards the camera or ray origin), from the volume's probes. Each weight can be switched off:
// back-face (wrap shading), Chebyshev visibility on the distance moments, crush of small weights,
// trilinear; the normal/view bias moves the lookup point off the surface first.
fn ddgi_sample_irradiance(p: vec3<f32>, n: vec3<f32>, to_viewer: vec3<f32>) -> vec3<f32> {
    return ddgi_sample_irradiance_pair(p, n, to_viewer, n, false).normal;
}

// Irradiance at a point from the probes for its normal and, with `reflected`, for a second
// direction too (a glossy surface's reflection: the irradiance maps are the radiance a rough lobe
// sees), with the same weights.
struct DdgiIrradiancePair {
    normal: vec3<f32>,
    reflected: vec3<f32>,
}

fn ddgi_sample_irradiance_pair(p: vec3<f32>, n: vec3<f32>, to_viewer: vec3<f32>, r: vec3<f32>, reflected: bool) -> DdgiIrradiancePair {
    let v = ddgi_volume;
    var biased = p;
    if ddgi_has(DDGI_WEIGHT_NORMAL_BIAS) {
        biased = p + n * (v.normal_bias * ddgi_cell_extent(n)) + to_viewer * (v.view_bias * ddgi_cell_extent(to_viewer));
    }
    let grid = ddgi_grid_coords(biased);
    let base = ddgi_cage_base(grid);
    let alpha = clamp(grid - vec3<f32>(base), vec3<f32>(0.0), vec3<f32>(1.0));
    var sum = vec3<f32>(0.0);
    var sum_reflected = vec3<f32>(0.0);
    var total = 0.0;
    for (var i = 0u; i < 8u; i++) {
        let step = ddgi_cage_step(i);
        let probe = ddgi_cage_probe(base, step);
        if !ddgi_probe_active(probe) {
            continue;
        }
        let probe_position = ddgi_probe_position(probe);
        var weight = 1.0;
        if ddgi_has(DDGI_WEIGHT_BACKFACE) {
            // Wrap shading: probes behind the surface fade out smoothly instead of being cut off.
            let to_probe = safe_normalize(probe_position - p, n);
            let wrap = (dot(to_probe, n) + 1.0) * 0.5;
            weight *= wrap * wrap + 0.2;
        }
        if ddgi_has(DDGI_WEIGHT_CHEBYSHEV) {
            let from_probe = biased - probe_position;
            let distance = length(from_probe);
            let dir = safe_normalize(from_probe, n);
            let uv = ddgi_atlas_uv(probe, dir, v.distance_texels, v.distance_atlas_size);
            let moments = textureSampleLevel(ddgi_distance, ddgi_sampler, uv, 0.0).xy * vec2<f32>(v.distance_scale, v.distance_scale * v.distance_scale);
            let mean = moments.x;
            if distance > mean {
                // One-tailed Chebyshev bound on the probability that the point is visible.
                let variance = abs(mean * mean - moments.y);
                let d = distance - mean;
                var visibility = clamp(variance / max(variance + d * d, 1e-30), 0.0, 1.0);
                visibility = visibility * visibility * visibility;
                weight *= max(visibility, 0.05);
            }
        }
        // Never exactly zero, so that a point whose probes all fail a test still gets something.
        weight = max(weight, 1e-6);
        if ddgi_has(DDGI_WEIGHT_CRUSH) {
            // Log-perception: crush tiny weights (they would otherwise leak faint light).
            let threshold = 0.2;
            if weight < threshold {
                weight *= weight * weight / (threshold * threshold);
            }
        }
        if ddgi_has(DDGI_WEIGHT_TRILINEAR) {
            let t = mix(vec3<f32>(1.0) - alpha, alpha, vec3<f32>(step));
            weight *= t.x * t.y * t.z;
        }
        let uv = ddgi_atlas_uv(probe, n, v.irradiance_texels, v.irradiance_atlas_size);
        let irradiance = ddgi_decode_irradiance(textureSampleLevel(ddgi_irradiance, ddgi_sampler, uv, 0.0).rgb);
        sum += weight * irradiance;
        total += weight;
        if reflected {
            let uv_r = ddgi_atlas_uv(probe, r, v.irradiance_texels, v.irradiance_atlas_size);
            sum_reflected += weight * ddgi_decode_irradiance(textureSampleLevel(ddgi_irradiance, ddgi_sampler, uv_r, 0.0).rgb);
        }
    }
    if !(total > 0.0) {
        return DdgiIrradiancePair(vec3<f32>(0.0), vec3<f32>(0.0));
    }
    return DdgiIrradiancePair(sanitize_radiance(sum / total), sanitize_radiance(sum_reflected / total));
}


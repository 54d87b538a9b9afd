// DDGI pass `ddgi_probe_update`: one pass of two dispatches, each with one workgroup per probe traced this
// frame (resting and switched-off probes cost nothing): blending the shaded rays into the irradiance
// map, then into the distance map, writing both maps with their borders into the atlases,
// relocating the probe out of geometry and classifying it as active or inactive. One pass, not
// five: at the published grids each pass cost 0.02–0.08 ms on an H200 however little it did, more
// than the work itself.
#include "ddgi_common.inc.wgsl"

const DDGI_GROUP: u32 = 64u;

var<workgroup> wg_direction: array<vec3<f32>, 64>;
var<workgroup> wg_value: array<vec4<f32>, 64>;
var<workgroup> wg_probe: DdgiProbeData;
var<workgroup> wg_error: array<vec3<f32>, 64>;

// The probe of a workgroup: the per-probe passes are dispatched indirectly, one workgroup for each
// probe with rays this frame (listed by the budget pass; two-dimensional beyond 65,535). Past the
// list: DDGI_NO_PROBE, which every caller rejects as ≥ probe_count.
fn ddgi_group_probe(group: vec3<u32>) -> u32 {
    let i = group.x + group.y * 65535u;
    if i >= ddgi_counters_in.updated_probes {
        return DDGI_NO_PROBE;
    }
    return ddgi_updated[i];
}

// The probe's data, the same in every thread of the workgroup (so barriers stay in uniform flow).
fn ddgi_uniform_probe(probe: u32, local: u32) -> DdgiProbeData {
    if local == 0u {
        wg_probe = ddgi_probes[probe];
    }
    return workgroupUniformLoad(&wg_probe);
}

// Loads rays [base, base + 64) of the probe `data` into workgroup memory: direction and
// (radiance, stored t).
fn ddgi_load_rays(data: DdgiProbeData, base: u32, local: u32) {
    let r = base + local;
    if r < data.ray_count {
        let i = data.ray_offset + r;
        wg_direction[local] = ddgi_rays[i].direction;
        wg_value[local] = ddgi_radiance[i];
    }
}

// The hysteresis of a probe this frame: with adaptive budgets a probe over the error target at its
// full budget follows the change faster, so does a drifting one (drift_rate), and
// (hysteresis_exponent > 0) a probe with fewer rays than the full budget weighs its noisier
// estimate less.
fn ddgi_hysteresis(data: DdgiProbeData) -> f32 {
    if (data.state & DDGI_PROBE_FRESH) != 0u {
        return 0.0;
    }
    var h = clamp(ddgi_volume.hysteresis, 0.0, 1.0);
    if ddgi_has(DDGI_WARM_UP) {
        // The first updates after the probe was fresh blend as a running mean of its estimates (the
        // k-th weighs 1/k), until that is slower than the hysteresis: a reset probe converges as
        // fast as its noise allows instead of keeping most of its first estimate for long.
        let k = f32(data.updates) + 1.0;
        h = min(h, k / (k + 1.0));
    }
    if !ddgi_has(DDGI_ADAPTIVE) {
        return h;
    }
    // 1 − h in proportion to the share of rays would keep the variance of the maps, (1 − h) / r,
    // but a quiet probe would then follow slow changes (multi-bounce light still building up) as
    // many times slower; hysteresis_exponent trades the two. Its default, 0, follows light at the
    // fixed budget's pace: resting, not the hysteresis, keeps quiet probes still.
    let share = clamp(f32(data.ray_count) / f32(max(ddgi_volume.rays_per_probe, 1u)), 0.0, 1.0);
    // A probe whose lighting is changing (its error over the target, its budget full) follows the
    // change at twice the rate, and settles back once the error falls.
    var rate = select(1.0, 2.0, data.error > ddgi_volume.error_target && share >= 1.0);
    // A drifting probe (drift_rate > 1, with the settled error kept): its settled error, over the
    // slow average of the change, is nearly its whole error when the map moves the same way frame
    // after frame (light still building up over bounces), a small share when the change is noise
    // (about √((1 − 0.97) / (1 + 0.97)) / √((1 − 0.9) / (1 + 0.9)) ≈ 0.54 of it at the defaults).
    // From DDGI_DRIFT_SHARE_LOW to DDGI_DRIFT_SHARE_FULL of it, the rate rises to drift_rate.
    if ddgi_volume.drift_rate > 1.0 && ddgi_volume.rest_smoothing >= 0.0 && data.error > 0.0 {
        let share_settled = data.settled_error / data.error;
        let drift = clamp((share_settled - DDGI_DRIFT_SHARE_LOW) / (DDGI_DRIFT_SHARE_FULL - DDGI_DRIFT_SHARE_LOW), 0.0, 1.0);
        rate = max(rate, 1.0 + (ddgi_volume.drift_rate - 1.0) * drift);
    }
    let slowing = pow(max(share, 1e-6), clamp(ddgi_volume.hysteresis_exponent, 0.0, 1.0));
    return 1.0 - min((1.0 - h) * slowing * rate, 1.0);
}

fn ddgi_texel_coords(texel: u32, n: u32) -> vec2<u32> {
    return vec2<u32>(texel % n, texel / n);
}

// Irradiance: the cosine-weighted mean of the rays' radiance over each texel's hemisphere, times
// π, blended with the old value by the hysteresis (linear irradiance; stored perceptually encoded).
fn ddgi_update_irradiance(probe: u32, data: DdgiProbeData, local: u32) {
    let state = data.state;
    let n = ddgi_volume.irradiance_texels;
    let m = data.ray_count;
    let h = ddgi_hysteresis(data);
    let fresh = (state & DDGI_PROBE_FRESH) != 0u;
    // (Σ SMAPE, texels measured, Σ settled SMAPE) of this thread's texels.
    var error = vec3<f32>(0.0);
    // The slow average (rest_smoothing ≥ 0, the default; off, its words pass through untouched)
    // and its start correction (its first values are shrunk towards 0 by s^updates).
    let settling = ddgi_volume.rest_smoothing >= 0.0;
    let slow_s = clamp(ddgi_volume.rest_smoothing, 0.0, 0.999);
    let slow_correction = 1.0 / max(1.0 - pow(slow_s, f32(data.updates + 1u)), 1e-3);
    for (var first = 0u; first < n * n; first += DDGI_GROUP) {
        let texel = first + local;
        let valid = texel < n * n;
        let direction = ddgi_texel_direction(ddgi_texel_coords(texel, n), n);
        var sum = vec4<f32>(0.0);
        for (var base = 0u; base < m; base += DDGI_GROUP) {
            ddgi_load_rays(data, base, local);
            workgroupBarrier();
            let count = min(DDGI_GROUP, m - base);
            for (var j = 0u; j < count; j++) {
                let w = max(dot(direction, wg_direction[j]), 0.0);
                sum += vec4<f32>(wg_value[j].rgb * w, w);
            }
            workgroupBarrier();
        }
        if valid {
            let slot = probe * n * n + texel;
            let history = ddgi_irradiance_history[slot];
            let old = history.irradiance;
            var change = vec3<f32>(0.0);
            // The slow average's words (bfloat16: an error measure needs no more, and the texel
            // keeps its 32 bytes), zeroed on a fresh probe; rewritten only when it is on.
            var settle_rg = select(history.settle_rg, 0u, fresh);
            var settle_b = select(history.settle_b, 0u, fresh);
            var result = old;
            // A texel no ray reached this frame keeps its value.
            if sum.w > 1e-6 {
                var sample = PI * sum.rgb / sum.w;
                if fresh {
                    result = sample;
                } else {
                    // What this frame's estimate asks of the map, smoothed over frames so that
                    // noise averages out and a lasting change stands out.
                    let smoothing = clamp(ddgi_volume.error_smoothing, 0.0, 1.0);
                    change = mix(sample - old, history.change, smoothing);
                    // The same, slower: noise averages out further, a map still converging keeps
                    // its full measure.
                    var settled = 0.0;
                    if settling {
                        let previous = vec3<f32>(ddgi_unpack_bf16(settle_rg), ddgi_unpack_bf16(settle_b).x);
                        let slow = mix(sample - old, previous, slow_s);
                        settled = ddgi_smape_ycocg(old + slow * slow_correction, old, ddgi_volume.error_floor);
                        settle_rg = ddgi_pack_bf16(slow.rg);
                        settle_b = ddgi_pack_bf16(vec2<f32>(slow.b, 0.0));
                    }
                    error += vec3<f32>(ddgi_smape_ycocg(old + change, old, ddgi_volume.error_floor), 1.0, settled);
                    let threshold = ddgi_volume.firefly_threshold;
                    if threshold > 0.0 && luminance(old) > 0.0 && luminance(sample) > (1.0 + threshold) * luminance(old) {
                        sample = old + (sample - old) * 0.25;
                    }
                    result = mix(sample, old, h);
                }
            }
            let finite_change = clamp(select(vec3<f32>(0.0), change, change == change), vec3<f32>(-DDGI_MAX_IRRADIANCE), vec3<f32>(DDGI_MAX_IRRADIANCE));
            ddgi_irradiance_history[slot] = DdgiTexel(min(sanitize_radiance(result), vec3<f32>(DDGI_MAX_IRRADIANCE)), settle_rg, finite_change, settle_b);
        }
    }
    // The probe's temporal error: the mean over the texels that got rays. A fresh probe starts at
    // the target (its maps hold nothing to compare with).
    wg_error[local] = error;
    workgroupBarrier();
    for (var stride = DDGI_GROUP / 2u; stride > 0u; stride /= 2u) {
        if local < stride {
            wg_error[local] += wg_error[local + stride];
        }
        workgroupBarrier();
    }
    if local == 0u {
        let total = wg_error[0];
        var e = ddgi_volume.error_target;
        var settled = ddgi_volume.error_target;
        if !fresh {
            e = select(data.error, total.x / total.y, total.y > 0.0);
            settled = select(data.settled_error, total.z / total.y, total.y > 0.0);
        }
        ddgi_probes[probe].error = select(0.0, e, e == e);
        ddgi_probes[probe].settled_error = select(0.0, settled, settled == settled);
        ddgi_probes[probe].updates = select(min(data.updates + 1u, 0xffffu), 0u, fresh);
    }
}

// Distance: cosine-power-weighted mean of the hit distance and of its square (clamped to
// distance_scale and stored divided by it), blended by the hysteresis.
fn ddgi_update_distance(probe: u32, data: DdgiProbeData, local: u32) {
    let n = ddgi_volume.distance_texels;
    let m = data.ray_count;
    let h = ddgi_hysteresis(data);
    let scale = max(ddgi_volume.distance_scale, 1e-30);
    let sharpness = max(ddgi_volume.distance_sharpness, 1e-3);
    // Rays whose weight cos^sharpness would be under 2^-20 are skipped (most of them at the usual
    // sharpness of 50: only rays within 40° of the texel count), which saves the power function.
    let cutoff = exp2(-20.0 / sharpness);
    // Each thread sums four texels at once (the 16 × 16 map in one sweep of the rays): each ray is
    // loaded into workgroup memory, and read from it, once per sweep. Four named sums, not an array:
    // a private array indexed in a loop may live in (slow) local memory.
    let last = n * n - 1u;
    for (var first = 0u; first < n * n; first += 4u * DDGI_GROUP) {
        let t = vec4<u32>(first + local, first + DDGI_GROUP + local, first + 2u * DDGI_GROUP + local, first + 3u * DDGI_GROUP + local);
        let d0 = ddgi_texel_direction(ddgi_texel_coords(min(t.x, last), n), n);
        let d1 = ddgi_texel_direction(ddgi_texel_coords(min(t.y, last), n), n);
        let d2 = ddgi_texel_direction(ddgi_texel_coords(min(t.z, last), n), n);
        let d3 = ddgi_texel_direction(ddgi_texel_coords(min(t.w, last), n), n);
        var s0 = vec3<f32>(0.0);
        var s1 = vec3<f32>(0.0);
        var s2 = vec3<f32>(0.0);
        var s3 = vec3<f32>(0.0);
        for (var base = 0u; base < m; base += DDGI_GROUP) {
            ddgi_load_rays(data, base, local);
            workgroupBarrier();
            let count = min(DDGI_GROUP, m - base);
            for (var j = 0u; j < count; j++) {
                let r = wg_direction[j];
                let c = vec4<f32>(dot(d0, r), dot(d1, r), dot(d2, r), dot(d3, r));
                if any(c > vec4<f32>(cutoff)) {
                    let d = min(abs(wg_value[j].w), scale) / scale;
                    let moments = vec3<f32>(d, d * d, 1.0);
                    // cos^sharpness where over the cutoff, 0 elsewhere.
                    let w = select(vec4<f32>(0.0), exp2(sharpness * log2(max(c, vec4<f32>(1e-30)))), c > vec4<f32>(cutoff));
                    s0 += w.x * moments;
                    s1 += w.y * moments;
                    s2 += w.z * moments;
                    s3 += w.w * moments;
                }
            }
            workgroupBarrier();
        }
        ddgi_store_distance(probe, t.x, n, s0, h);
        ddgi_store_distance(probe, t.y, n, s1, h);
        ddgi_store_distance(probe, t.z, n, s2, h);
        ddgi_store_distance(probe, t.w, n, s3, h);
    }
}

// Blends texel `texel`'s weighted moment sums (Σ w·d, Σ w·d², Σ w) into its distance map.
fn ddgi_store_distance(probe: u32, texel: u32, n: u32, sum: vec3<f32>, h: f32) {
    if texel >= n * n {
        return;
    }
    let slot = probe * n * n + texel;
    let old = ddgi_distance_history[slot];
    var result = old;
    if sum.z > 1e-6 {
        result = mix(sum.xy / sum.z, old, h);
    }
    ddgi_distance_history[slot] = clamp(select(old, result, result == result), vec2<f32>(0.0), vec2<f32>(1.0));
}

// The interior texel whose value border texel `t` of an (n + 2)² tile repeats: each edge of the
// octahedral map continues mirrored around its midpoint, and each corner takes the opposite corner.
fn ddgi_border_source(t: vec2<u32>, n: u32) -> vec2<u32> {
    let last = n + 1u;
    let on_x = t.x == 0u || t.x == last;
    let on_y = t.y == 0u || t.y == last;
    if on_x && on_y {
        return vec2<u32>(select(1u, n, t.x == 0u), select(1u, n, t.y == 0u));
    }
    if on_y {
        return vec2<u32>(last - t.x, select(n, 1u, t.y == 0u));
    }
    if on_x {
        return vec2<u32>(select(n, 1u, t.x == 0u), last - t.y);
    }
    return t;
}

// Writes probe `probe`'s irradiance map (perceptually encoded) or distance map into its atlas tile,
// the border filled from the mirrored interior. Tiles of probes that did not trace keep what they
// hold.
fn ddgi_store_tile(probe: u32, local: u32, irradiance: bool) {
    let n = select(ddgi_volume.distance_texels, ddgi_volume.irradiance_texels, irradiance);
    let side = n + 2u;
    let corner = ddgi_tile_origin(probe, n);
    for (var t = local; t < side * side; t += DDGI_GROUP) {
        let texel = vec2<u32>(t % side, t / side);
        let source = ddgi_border_source(texel, n) - vec2<u32>(1u);
        let slot = probe * n * n + source.y * n + source.x;
        if irradiance {
            let value = ddgi_encode_irradiance(ddgi_irradiance_history[slot].irradiance);
            textureStore(ddgi_irradiance_out, corner + texel, vec4<f32>(value, 1.0));
        } else {
            textureStore(ddgi_distance_out, corner + texel, vec4<f32>(ddgi_distance_history[slot], 0.0, 1.0));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// What a probe's rays saw this frame, reduced over the workgroup.

struct DdgiRayStatistics {
    backface_count: u32,
    // (unit direction, distance); distance DDGI_MISS when there is none.
    closest_backface: vec4<f32>,
    closest_frontface: vec4<f32>,
    // Misses count as front faces at the maximum ray distance.
    farthest_frontface: vec4<f32>,
    // A front face in the region whose shading reads the probe (see ddgi_ray_statistics).
    frontface_in_cell: u32,
    // Σ YCoCg luma of the rays' radiance.
    luma_sum: f32,
}

var<workgroup> wg_statistics: array<DdgiRayStatistics, 64>;

fn ddgi_ray_statistics(probe: u32, data: DdgiProbeData, local: u32) -> DdgiRayStatistics {
    // The region whose shading reads this probe: a cell to each side, and a cell and a half towards
    // the volume's border from the second layer in (points beyond the outer probes clamp to the
    // outer two layers).
    let coords = ddgi_probe_coords(probe);
    let far = vec3<f32>(1.0) + 0.5 * vec3<f32>(coords == vec3<u32>(1u));
    let near_end = vec3<f32>(1.0) + 0.5 * vec3<f32>(coords + vec3<u32>(2u) == ddgi_volume.counts);
    let reach_lo = ddgi_volume.spacing * far;
    let reach_hi = ddgi_volume.spacing * near_end;
    var s = DdgiRayStatistics(0u, vec4<f32>(0.0, 0.0, 1.0, DDGI_MISS), vec4<f32>(0.0, 0.0, 1.0, DDGI_MISS), vec4<f32>(0.0, 0.0, 1.0, -1.0), 0u, 0.0);
    for (var r = local; r < data.ray_count; r += DDGI_GROUP) {
        let i = data.ray_offset + r;
        let direction = ddgi_rays[i].direction;
        let shaded = ddgi_radiance[i];
        s.luma_sum += ddgi_luma(shaded.rgb);
        let stored = shaded.w;
        if stored < 0.0 {
            s.backface_count += 1u;
            let d = -stored / DDGI_BACKFACE_SCALE;
            if d < s.closest_backface.w {
                s.closest_backface = vec4<f32>(direction, d);
            }
            continue;
        }
        let d = min(stored, ddgi_volume.max_ray_distance);
        if stored < DDGI_MISS {
            if d < s.closest_frontface.w {
                s.closest_frontface = vec4<f32>(direction, d);
            }
            // The region is the grid point's (the cage corners sit at grid points), not the
            // relocated probe's: measured from the probe, it would shift with the offset.
            let hit = data.offset + direction * d;
            if all(hit >= -reach_lo) && all(hit <= reach_hi) {
                s.frontface_in_cell = 1u;
            }
        }
        if d > s.farthest_frontface.w {
            s.farthest_frontface = vec4<f32>(direction, d);
        }
    }
    // A tree reduction, six steps of halving: one thread merging the 64 entries in turn was a
    // serial chain of workgroup-memory reads. (Of two rays at exactly the same distance, either
    // may be kept.)
    wg_statistics[local] = s;
    workgroupBarrier();
    for (var stride = DDGI_GROUP / 2u; stride > 0u; stride /= 2u) {
        if local < stride {
            wg_statistics[local] = ddgi_merge_statistics(wg_statistics[local], wg_statistics[local + stride]);
        }
        workgroupBarrier();
    }
    return wg_statistics[0];
}

// The statistics of two sets of rays together (`a`'s ray on ties).
fn ddgi_merge_statistics(a: DdgiRayStatistics, b: DdgiRayStatistics) -> DdgiRayStatistics {
    var total = a;
    total.backface_count += b.backface_count;
    total.luma_sum += b.luma_sum;
    total.frontface_in_cell = max(total.frontface_in_cell, b.frontface_in_cell);
    if b.closest_backface.w < total.closest_backface.w {
        total.closest_backface = b.closest_backface;
    }
    if b.closest_frontface.w < total.closest_frontface.w {
        total.closest_frontface = b.closest_frontface;
    }
    if b.farthest_frontface.w > total.farthest_frontface.w {
        total.farthest_frontface = b.farthest_frontface;
    }
    return total;
}

fn ddgi_inside_geometry(s: DdgiRayStatistics, rays: u32) -> bool {
    return f32(s.backface_count) > ddgi_volume.backface_threshold * f32(rays);
}

// Relocation (Majercik et al. 2021): a probe inside geometry moves through the nearest back face;
// one too close to a front face moves away from it; one in free space drifts back to its grid
// point. The offset stays inside an ellipsoid of 0.45 cells around the grid point. Returns whether
// it moved the probe out of geometry.
fn ddgi_relocate(probe: u32, data: DdgiProbeData, s: DdgiRayStatistics) -> bool {
    let offset = data.offset;
    let min_distance = ddgi_volume.min_frontface_distance;
    var moved = offset;
    let inside = ddgi_inside_geometry(s, data.ray_count) && s.closest_backface.w < DDGI_MISS;
    if inside {
        moved = offset + s.closest_backface.xyz * (s.closest_backface.w + min_distance * 0.5);
    } else if s.closest_frontface.w < min_distance {
        if dot(s.closest_frontface.xyz, s.farthest_frontface.xyz) <= 0.0 {
            moved = offset + s.farthest_frontface.xyz * min(max(s.farthest_frontface.w, 0.0), min_distance);
        }
    } else if s.closest_frontface.w > min_distance {
        let length_offset = length(offset);
        if length_offset > 0.0 {
            let back = min(s.closest_frontface.w - min_distance, length_offset);
            moved = offset - offset / length_offset * back;
        }
    }
    let normalized = moved / max(ddgi_volume.spacing, vec3<f32>(1e-30));
    if dot(normalized, normalized) < 0.45 * 0.45 && all(moved == moved) {
        ddgi_probes[probe].offset = moved;
        return inside;
    }
    return false;
}

// The mean hit distance in probe p's distance map towards direction d, filtered bilinearly as a
// sample of its atlas tile would be (the border texels repeat their mirrored interior texels).
fn ddgi_mean_distance(p: u32, d: vec3<f32>) -> f32 {
    let n = ddgi_volume.distance_texels;
    // In tile texels (texel j centred at j + 0.5, the interior from 1): the sample at 1 + oct · n.
    let x = (ddgi_oct_encode(d) * 0.5 + 0.5) * f32(n) + 0.5;
    let base = clamp(floor(x), vec2<f32>(0.0), vec2<f32>(f32(n)));
    let f = clamp(x - base, vec2<f32>(0.0), vec2<f32>(1.0));
    var mean = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let corner = vec2<u32>(k & 1u, k >> 1u);
        let source = ddgi_border_source(vec2<u32>(base) + corner, n) - vec2<u32>(1u);
        let w = select(1.0 - f, f, corner == vec2<u32>(1u));
        mean += w.x * w.y * ddgi_distance_history[p * n * n + source.y * n + source.x].x;
    }
    return mean * ddgi_volume.distance_scale;
}

// Whether probe p and those of its six neighbours that can light what it lights (active, not behind
// a wall) saw less than `threshold` of luma (the neighbours at their last update: ddgi_lit).
fn ddgi_dark_around(p: u32, own_luma: f32, threshold: f32) -> bool {
    if own_luma >= threshold {
        return false;
    }
    for (var k = 0u; k < 6u; k++) {
        let step = ddgi_face_step(k);
        let q = ddgi_neighbour(p, step);
        if q != DDGI_NO_PROBE {
            // A neighbour behind a wall (the probe's mean distance towards it is shorter than the
            // step) lights nothing this probe does; one switched off lights nothing at all.
            let axis = k / 2u;
            let towards = vec3<f32>(step);
            let mean = ddgi_mean_distance(p, towards);
            if mean >= ddgi_volume.spacing[axis] && ddgi_lit[q] >= max(threshold, 0.0) {
                return false;
            }
        }
    }
    return true;
}

// Classification (Majercik et al. 2021): a probe inside geometry, or with no front face within a
// cell of it (so no surface samples it), is switched off; with adaptive budgets, so is a probe
// that, like its six neighbours, sees next to no light (luma under dark_fraction of the brightest
// probe's). Off, it traces only a few rays on re-check frames, which wake it when the scene
// changes. Probes switched back on are marked fresh, so their maps restart from the new samples.
// Pinned states win. `state` is the probe's state after relocation.
fn ddgi_classify(probe: u32, data: DdgiProbeData, state: u32, s: DdgiRayStatistics) {
    // The mean irradiance-like luma the rays saw (π × their mean radiance over the sphere).
    let luma = PI * s.luma_sum / f32(data.ray_count);
    ddgi_probes[probe].luma = select(0.0, luma, luma == luma);
    var is_active = true;
    var empty_region = false;
    if ddgi_has(DDGI_CLASSIFICATION) {
        var empty = 0u;
        // A probe a camera pixel depends on (marked by the gather) is not empty, whatever its
        // rays found.
        if s.frontface_in_cell == 0u && (state & DDGI_PROBE_SEEN) == 0u {
            empty = min(data.empty_rays + data.ray_count, DDGI_EMPTY_RAYS);
        }
        ddgi_probes[probe].empty_rays = empty;
        let inside = ddgi_inside_geometry(s, data.ray_count);
        empty_region = !inside && empty >= DDGI_EMPTY_RAYS;
        is_active = !inside && !empty_region;
    }
    if is_active && ddgi_has(DDGI_ADAPTIVE) {
        is_active = !ddgi_dark_around(probe, luma, ddgi_volume.dark_fraction * ddgi_counters_in.max_luma);
    }
    if data.pinned_state == DDGI_PIN_ACTIVE || data.pinned_state == DDGI_PIN_INACTIVE {
        is_active = data.pinned_state == DDGI_PIN_ACTIVE;
    }
    var next = 0u;
    if !is_active {
        next = DDGI_PROBE_INACTIVE;
        if (state & DDGI_PROBE_RELOCATED) != 0u {
            next |= DDGI_PROBE_RECHECK;
        }
        if empty_region {
            next |= DDGI_PROBE_EMPTY;
        }
    } else if (state & DDGI_PROBE_INACTIVE) != 0u {
        next = DDGI_PROBE_FRESH;
    }
    ddgi_probes[probe].state = next;
}

// The irradiance maps, a dispatch of their own before the rest of the probe update (one workgroup
// per probe traced this frame): in one kernel with the rest, the update took 8% longer at 256 rays
// per probe on an H200 (0.875 against 0.811 ms at 32×8×32 probes), likely lower occupancy.
@compute @workgroup_size(64)
fn update_irradiance_maps(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let probe = ddgi_group_probe(group);
    if probe >= ddgi_volume.probe_count {
        return;
    }
    let data = ddgi_uniform_probe(probe, local);
    if data.ray_count == 0u || (data.state & DDGI_PROBE_INACTIVE) != 0u {
        return;
    }
    ddgi_update_irradiance(probe, data, local);
}

// The rest of the probe update: one workgroup per probe traced this frame. An active probe's rays
// update its distance map, then both its tiles; every traced probe (a switched-off one with its few
// re-check rays too) is relocated and classified.
@compute @workgroup_size(64)
fn update_probes(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) local: u32) {
    let probe = ddgi_group_probe(group);
    if probe >= ddgi_volume.probe_count {
        return;
    }
    // With the error the irradiance update just measured: the distance map's hysteresis follows it.
    let data = ddgi_uniform_probe(probe, local);
    if data.ray_count == 0u {
        return;
    }
    if (data.state & DDGI_PROBE_INACTIVE) == 0u {
        ddgi_update_distance(probe, data, local);
        // The tiles (and the dark test below) read texels that other threads of the workgroup wrote.
        storageBarrier();
        ddgi_store_tile(probe, local, true);
        ddgi_store_tile(probe, local, false);
    }
    let s = ddgi_ray_statistics(probe, data, local);
    if local != 0u {
        return;
    }
    var state = data.state;
    if ddgi_has(DDGI_RELOCATION) && ddgi_relocate(probe, data, s) {
        state |= DDGI_PROBE_RELOCATED;
    }
    ddgi_classify(probe, data, state, s);
}

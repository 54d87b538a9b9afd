// DDGI probe rays: the budget (how many rays each probe traces this frame, packed into one array
// by a prefix sum), then generation, trace and shading, one thread per packed ray, dispatched
// indirectly with the budget's count (two-dimensional beyond 65,535 workgroups).
#include "ddgi.inc.wgsl"

const DDGI_RAY_GROUP: u32 = 64u;

fn ddgi_ray_index(id: vec3<u32>) -> u32 {
    return id.x + id.y * 65535u * DDGI_RAY_GROUP;
}

fn ddgi_ray_total() -> u32 {
    return ddgi_counters_in.total_rays;
}

// ---------------------------------------------------------------------------------------------
// Budget

const DDGI_SCAN: u32 = 256u;
var<workgroup> wg_scan: array<u32, 256>;
var<workgroup> wg_max: array<f32, 256>;

// This frame's ray count of probe p, before any frame budget.
fn ddgi_probe_budget(p: u32) -> u32 {
    let v = ddgi_volume;
    let data = ddgi_probes[p];
    let max_rays = v.rays_per_probe;
    let min_rays = clamp(v.min_rays, 1u, max_rays);
    if data.pinned_state == DDGI_PIN_INACTIVE {
        return 0u;
    }
    if data.pinned_rays != DDGI_NO_PIN {
        return min(data.pinned_rays, max_rays);
    }
    if (data.state & DDGI_PROBE_INACTIVE) != 0u && data.pinned_state != DDGI_PIN_ACTIVE {
        // Switched off: a few rays on re-check frames, so that a change can wake it.
        return select(0u, clamp(v.recheck_rays, 1u, max_rays), v.recheck != 0u);
    }
    if !ddgi_has(DDGI_ADAPTIVE) || (data.state & DDGI_PROBE_FRESH) != 0u {
        return max_rays;
    }
    // The error asks for rays in proportion; a rising error gets them at once, a falling one
    // gives them back gradually.
    let wanted = f32(min_rays) + f32(max_rays - min_rays) * clamp(data.error / max(v.error_target, 1e-6), 0.0, 1.0);
    let decayed = f32(data.ray_count) * clamp(v.error_decay, 0.0, 1.0);
    return clamp(u32(ceil(max(wanted, decayed))), min_rays, max_rays);
}

// Exclusive prefix sum of `value` over the workgroup (Hillis–Steele); returns (offset, total).
fn ddgi_scan(value: u32, local: u32) -> vec2<u32> {
    wg_scan[local] = value;
    workgroupBarrier();
    for (var step = 1u; step < DDGI_SCAN; step *= 2u) {
        var add = 0u;
        if local >= step {
            add = wg_scan[local - step];
        }
        workgroupBarrier();
        wg_scan[local] += add;
        workgroupBarrier();
    }
    let inclusive = wg_scan[local];
    let total = wg_scan[DDGI_SCAN - 1u];
    workgroupBarrier();
    return vec2<u32>(inclusive - value, total);
}

// One workgroup: every probe's ray count (scaled down to the frame budget if there is one), their
// offsets in the packed ray array, the indirect dispatch of the ray passes, and the brightest
// probe's luma (for the dark test of classification).
@compute @workgroup_size(256)
fn plan_rays(@builtin(local_invocation_index) local: u32) {
    let n = ddgi_volume.probe_count;
    var total = 0u;
    var brightest = 0.0;
    for (var first = 0u; first < n; first += DDGI_SCAN) {
        let p = first + local;
        var count = 0u;
        if p < n {
            count = ddgi_probe_budget(p);
            brightest = max(brightest, ddgi_probes[p].luma);
        }
        total += ddgi_scan(count, local).y;
    }
    // Over the frame budget: every probe's share shrinks in proportion (keeping one ray for
    // probes that had any), so the budget goes where the error asked for it.
    let budget = ddgi_volume.frame_budget;
    let scale = select(1.0, f32(budget) / f32(max(total, 1u)), budget != 0u && total > budget);
    var offset = 0u;
    for (var first = 0u; first < n; first += DDGI_SCAN) {
        let p = first + local;
        var count = 0u;
        if p < n {
            count = ddgi_probe_budget(p);
            if scale < 1.0 && count > 0u {
                count = max(1u, u32(f32(count) * scale));
            }
        }
        let scan = ddgi_scan(count, local);
        if p < n {
            ddgi_probes[p].ray_count = count;
            ddgi_probes[p].ray_offset = offset + scan.x;
        }
        offset += scan.y;
    }
    wg_max[local] = brightest;
    workgroupBarrier();
    if local == 0u {
        var m = 0.0;
        for (var k = 0u; k < DDGI_SCAN; k++) {
            m = max(m, wg_max[k]);
        }
        let groups = (offset + DDGI_RAY_GROUP - 1u) / DDGI_RAY_GROUP;
        ddgi_counters.dispatch = vec3<u32>(min(groups, 65535u), max((groups + 65534u) / 65535u, 1u), 1u);
        ddgi_counters.total_rays = offset;
        ddgi_counters.max_luma = m;
    }
}

// The probe whose packed rays hold ray i: the last probe whose offset is at most i (probes with no
// rays share the offset of the next one, so the search lands on the probe that has rays).
fn ddgi_probe_of_ray(i: u32) -> u32 {
    var lo = 0u;
    var hi = ddgi_volume.probe_count;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if ddgi_probes[mid].ray_offset <= i {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// Ray generation: each probe's rays are spherical Fibonacci directions for its own ray count,
// under this frame's random rotation.
@compute @workgroup_size(64)
fn generate_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let probe = ddgi_probe_of_ray(i);
    let data = ddgi_probes[probe];
    let direction = ddgi_volume.ray_rotation * ddgi_spherical_fibonacci(i - data.ray_offset, max(data.ray_count, 1u));
    ddgi_rays[i] = DdgiRay(safe_normalize(direction, vec3<f32>(0.0, 0.0, 1.0)), probe);
}

// Trace: closest hit, back faces included (they mark probes inside geometry). Writes the surfel.
@compute @workgroup_size(64)
fn trace_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let ray_info = ddgi_rays[i];
    let ray = Ray(ddgi_probe_position(ray_info.probe), 0.0, ray_info.direction, ddgi_volume.max_ray_distance);
    let hit = trace_closest(ray);
    if hit.instance == RT_NO_HIT {
        ddgi_surfels[i] = vec4<u32>(bitcast<u32>(DDGI_MISS), 0u, 0u, 0u);
        return;
    }
    if !hit.front_face {
        ddgi_surfels[i] = vec4<u32>(bitcast<u32>(-hit.t), 0u, 0u, 0u);
        return;
    }
    let surface = hit_surface(ray, hit);
    ddgi_surfels[i] = vec4<u32>(
        bitcast<u32>(hit.t),
        pack2x16snorm(ddgi_oct_encode(surface.normal)),
        pack4x8unorm(vec4<f32>(surface.albedo, 1.0)),
        ddgi_pack_rgb9e5(surface.emissive),
    );
}

// Shading: emission + direct light (a shadow ray per light) + indirect light from the probes of the
// previous frame, all Lambertian. Misses see the sky; back faces are black.
@compute @workgroup_size(64)
fn shade_rays(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = ddgi_ray_index(id);
    if i >= ddgi_ray_total() {
        return;
    }
    let ray_info = ddgi_rays[i];
    let surfel = ddgi_surfels[i];
    let t = bitcast<f32>(surfel.x);
    if t >= DDGI_MISS {
        ddgi_radiance[i] = vec4<f32>(sanitize_radiance(ddgi_volume.sky_radiance), DDGI_MISS);
        return;
    }
    if t < 0.0 {
        ddgi_radiance[i] = vec4<f32>(0.0, 0.0, 0.0, t * DDGI_BACKFACE_SCALE);
        return;
    }
    let origin = ddgi_probe_position(ray_info.probe);
    let position = origin + ray_info.direction * t;
    let normal = ddgi_oct_decode(unpack2x16snorm(surfel.y));
    let albedo = unpack4x8unorm(surfel.z).rgb;
    var radiance = ddgi_unpack_rgb9e5(surfel.w);
    var irradiance = vec3<f32>(0.0);
    let shadow_origin = offset_ray_origin(position, normal);
    for (var l = 0u; l < view.light_count; l++) {
        let s = sample_light(lights[l], position, normal);
        if any(s.irradiance > vec3<f32>(0.0)) && !trace_any(Ray(shadow_origin, 0.0, s.to_light, s.distance * (1.0 - 1e-4))) {
            irradiance += s.irradiance;
        }
    }
    irradiance += ddgi_sample_irradiance(position, normal, -ray_info.direction);
    radiance += albedo * INV_PI * irradiance;
    ddgi_radiance[i] = vec4<f32>(sanitize_radiance(radiance), t);
}

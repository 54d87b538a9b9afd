// DDGI probe debug view: every probe of a volume drawn as a small sphere into the HDR image,
// depth-tested against the G-buffer. The sphere shows the probe's irradiance in the direction of
// each point of its surface (a white diffuse ball lit by the probe's map), or a false colour of
// its state, its ray budget or its temporal error.
#include "ddgi_common.inc.wgsl"
#include "ddgi_debug_draw.inc.wgsl"

struct DdgiProbeViewParams {
    // 1 irradiance, 2 state, 3 ray budget, 4 temporal error.
    mode: u32,
    // The selected probe (highlighted); 0xffffffff: none.
    selected: u32,
    // Sphere radius in world units.
    radius: f32,
    // Ray count shown as the hottest colour.
    max_rays: f32,
    // Temporal error shown as the hottest colour.
    max_error: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(2) @binding(0) var<uniform> ddgi_probe_view: DdgiProbeViewParams;
// The volume's probe states, read-only (vertex shaders may not bind writable storage).
@group(2) @binding(1) var<storage, read> ddgi_probe_view_probes: array<DdgiProbeData>;

struct ProbeVertex {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) @interpolate(flat) probe: u32,
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) probe: u32) -> ProbeVertex {
    // 6 · SPHERE_RINGS · SPHERE_SEGMENTS vertices per probe (ddgi_debug_draw.inc.wgsl).
    let n = ddgi_sphere_normal(vertex);
    let center = ddgi_volume.origin + ddgi_volume.spacing * vec3<f32>(ddgi_probe_coords(probe)) + ddgi_probe_view_probes[probe].offset;
    var out: ProbeVertex;
    out.clip = view_raster_position(vec4<f32>(center + n * max(ddgi_probe_view.radius, 0.0), 1.0));
    out.normal = n;
    out.probe = probe;
    return out;
}

@fragment
fn fs_main(in: ProbeVertex) -> @location(0) vec4<f32> {
    let p = in.probe;
    let probe = ddgi_probe_view_probes[p];
    let n = normalize(in.normal);
    // False colours are display-referred: divided by the exposure, they come out of the tonemapper
    // near their own value.
    let display = 1.0 / max(view.exposure, 1e-6);
    var radiance: vec3<f32>;
    switch ddgi_probe_view.mode {
        case 1u: {
            let uv = ddgi_atlas_uv(p, n, ddgi_volume.irradiance_texels, ddgi_volume.irradiance_atlas_size);
            let e = ddgi_decode_irradiance(textureSampleLevel(ddgi_irradiance, ddgi_sampler, uv, 0.0).rgb);
            radiance = e / PI;
        }
        case 2u: {
            var c = vec3<f32>(0.1, 0.85, 0.2);
            if (probe.state & DDGI_PROBE_INACTIVE) != 0u {
                c = vec3<f32>(0.85, 0.1, 0.1);
            } else if (probe.state & DDGI_PROBE_FRESH) != 0u {
                c = vec3<f32>(0.95, 0.85, 0.1);
            }
            radiance = c * display;
        }
        case 3u: {
            radiance = ddgi_heat(f32(probe.ray_count) / max(ddgi_probe_view.max_rays, 1.0)) * display;
        }
        default: {
            radiance = ddgi_heat(probe.error / max(ddgi_probe_view.max_error, 1e-6)) * display;
        }
    }
    // A lit rim on the selected probe.
    if p == ddgi_probe_view.selected {
        let to_eye = normalize(view.camera_position - (ddgi_probe_position_of(p, probe) + n * ddgi_probe_view.radius));
        let rim = pow(1.0 - clamp(dot(n, to_eye), 0.0, 1.0), 2.0);
        radiance = mix(radiance, vec3<f32>(4.0) * display, rim);
    }
    return vec4<f32>(sanitize_radiance(radiance), 1.0);
}

fn ddgi_probe_position_of(p: u32, probe: DdgiProbeData) -> vec3<f32> {
    return ddgi_volume.origin + ddgi_volume.spacing * vec3<f32>(ddgi_probe_coords(p)) + probe.offset;
}

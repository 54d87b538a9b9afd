// Pass `ddgi_visualizer`: RTXGI-style views of one DDGI volume, rasterized into the HDR image after
// the probe spheres, depth-tested against the G-buffer (reverse Z) like them. One draw per view,
// told apart by instance ranges (see DdgiVisualizerParams):
// - distance spheres: each probe as a sphere coloured by its mean hit distance in the direction of
//   each point of its surface (the distance map's mean over the volume's distance scale, blue near
//   to red far);
// - relocation offsets: a line from each probe's grid point to where relocation moved it (cyan);
// - bounds: the volume's box (the cells the probes fill) as a wireframe of 12 edges (yellow).
// Lines are screen-space quads `line_width` pixels wide, moved a little towards the camera so that
// a line lying on a surface is not hidden by it.
#include "ddgi_common.inc.wgsl"
#include "ddgi_debug_draw.inc.wgsl"

struct DdgiVisualizerParams {
    // Instances [0, spheres) are distance spheres, [offsets_begin, offsets_end) offset lines (one
    // per probe), [bounds_begin, bounds_begin + 12) the box's edges.
    spheres: u32,
    offsets_begin: u32,
    offsets_end: u32,
    bounds_begin: u32,
    // Sphere radius in world units.
    radius: f32,
    // Line width in pixels.
    line_width: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(2) @binding(0) var<uniform> ddgi_visualizer: DdgiVisualizerParams;
// The volume's probe states, read-only (vertex shaders may not bind writable storage).
@group(2) @binding(1) var<storage, read> ddgi_visualizer_probes: array<DdgiProbeData>;

// Vertices of one line: two triangles.
const LINE_VERTICES: u32 = 6u;
// The colours of the line views, display-referred (divided by the exposure).
const OFFSET_COLOR: vec3<f32> = vec3<f32>(0.0, 1.0, 1.0);
const BOUNDS_COLOR: vec3<f32> = vec3<f32>(1.0, 1.0, 0.0);
// Share of its view depth by which a line is moved towards the camera.
const LINE_DEPTH_NUDGE: f32 = 2e-3;

struct VisualizerVertex {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) color: vec3<f32>,
    // The probe of a distance sphere; 0xffffffff for a line.
    @location(2) @interpolate(flat) probe: u32,
}

fn probe_grid_point(p: u32) -> vec3<f32> {
    return ddgi_volume.origin + ddgi_volume.spacing * vec3<f32>(ddgi_probe_coords(p));
}

// Corner k (bits x, y, z) of the volume's box: the cells around the probes.
fn bounds_corner(k: u32) -> vec3<f32> {
    let lo = ddgi_volume.origin - 0.5 * ddgi_volume.spacing;
    let hi = ddgi_volume.origin + ddgi_volume.spacing * (vec3<f32>(ddgi_volume.counts) - 0.5);
    return select(lo, hi, vec3<bool>((k & 1u) != 0u, (k & 2u) != 0u, (k & 4u) != 0u));
}

// The box's edge e (0–11): four along each axis, as two corner indices.
fn bounds_edge(e: u32) -> vec2<u32> {
    let axis = e / 4u;
    let which = e % 4u;
    let bit = 1u << axis;
    // The two other axes' bits of the edge's start corner.
    let other_bits = array<vec2<u32>, 3>(vec2<u32>(2u, 4u), vec2<u32>(1u, 4u), vec2<u32>(1u, 2u));
    let others = other_bits[axis];
    let start = select(0u, others.x, (which & 1u) != 0u) | select(0u, others.y, (which & 2u) != 0u);
    return vec2<u32>(start, start | bit);
}

// Corner `vertex` (0–5) of the screen-space quad of the segment a → b.
fn line_vertex(a: vec3<f32>, b: vec3<f32>, vertex: u32) -> vec4<f32> {
    var ca = view_raster_position(vec4<f32>(a, 1.0));
    var cb = view_raster_position(vec4<f32>(b, 1.0));
    let near = 1e-4;
    if ca.w < near && cb.w < near {
        return vec4<f32>(0.0, 0.0, -1.0, 1.0);
    }
    // Clip the segment at the camera plane.
    if ca.w < near {
        ca = mix(ca, cb, (near - ca.w) / (cb.w - ca.w));
    } else if cb.w < near {
        cb = mix(cb, ca, (near - cb.w) / (ca.w - cb.w));
    }
    let size = vec2<f32>(max(view.size, vec2<u32>(1u)));
    let sa = ca.xy / ca.w * size;
    let sb = cb.xy / cb.w * size;
    let along = sb - sa;
    let dir = select(vec2<f32>(1.0, 0.0), along / length(along), length(along) > 1e-6);
    // NDC spans 2 units per `size` pixels.
    let side = vec2<f32>(-dir.y, dir.x) * ddgi_visualizer.line_width / size;
    let ends = array<u32, 6>(0u, 1u, 1u, 0u, 1u, 0u);
    let sides = array<f32, 6>(-1.0, -1.0, 1.0, -1.0, 1.0, 1.0);
    let t = ends[vertex];
    let s = sides[vertex];
    var c = select(ca, cb, t == 1u);
    c = vec4<f32>(c.xy + side * s * c.w, c.z * (1.0 + LINE_DEPTH_NUDGE), c.w);
    return c;
}

@vertex
fn vs_main(@builtin(vertex_index) vertex: u32, @builtin(instance_index) instance: u32) -> VisualizerVertex {
    var out: VisualizerVertex;
    out.probe = 0xffffffffu;
    out.normal = vec3<f32>(0.0, 1.0, 0.0);
    let display = 1.0 / max(view.exposure, 1e-6);
    if instance < ddgi_visualizer.spheres {
        // 6 · SPHERE_RINGS · SPHERE_SEGMENTS vertices per sphere (ddgi_debug_draw.inc.wgsl).
        let n = ddgi_sphere_normal(vertex);
        let center = probe_grid_point(instance) + ddgi_visualizer_probes[instance].offset;
        out.clip = view_raster_position(vec4<f32>(center + n * max(ddgi_visualizer.radius, 0.0), 1.0));
        out.normal = n;
        out.probe = instance;
        return out;
    }
    if vertex >= LINE_VERTICES {
        out.clip = vec4<f32>(0.0, 0.0, -1.0, 1.0);
        return out;
    }
    if instance >= ddgi_visualizer.offsets_begin && instance < ddgi_visualizer.offsets_end {
        let p = instance - ddgi_visualizer.offsets_begin;
        let a = probe_grid_point(p);
        out.clip = line_vertex(a, a + ddgi_visualizer_probes[p].offset, vertex);
        out.color = OFFSET_COLOR * display;
        return out;
    }
    let edge = bounds_edge(min(instance - ddgi_visualizer.bounds_begin, 11u));
    out.clip = line_vertex(bounds_corner(edge.x), bounds_corner(edge.y), vertex);
    out.color = BOUNDS_COLOR * display;
    return out;
}

@fragment
fn fs_main(in: VisualizerVertex) -> @location(0) vec4<f32> {
    if in.probe == 0xffffffffu {
        return vec4<f32>(sanitize_radiance(in.color), 1.0);
    }
    // The distance map stores the mean hit distance over the distance scale: 0 at the probe, 1 at
    // 1.5 cell diagonals (farther is clamped there).
    let n = normalize(in.normal);
    let uv = ddgi_atlas_uv(in.probe, n, ddgi_volume.distance_texels, ddgi_volume.distance_atlas_size);
    let mean = textureSampleLevel(ddgi_distance, ddgi_sampler, uv, 0.0).r;
    let display = 1.0 / max(view.exposure, 1e-6);
    return vec4<f32>(sanitize_radiance(ddgi_heat(mean) * display), 1.0);
}

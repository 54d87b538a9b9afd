// glTF's metallic-roughness BRDF (engine::brdf is its CPU mirror): Lambertian diffuse for the
// base colour of dielectrics, weighted by what the specular lobe leaves, and a GGX specular lobe
// (height-correlated Smith visibility, Schlick Fresnel) with the energy single scattering loses
// given back. A surface with metallic 0 and specular 0 has no specular lobe: the Lambertian
// surface of before, to the bit. Part of scene.inc.wgsl (each includes the other; every file is
// included once), which binds the split-sum table `brdf_dfg_table`.
#include "scene.inc.wgsl"

const BRDF_DFG_SIZE: u32 = 32u;
const BRDF_MIN_ROUGHNESS: f32 = 0.045;
const BRDF_DIELECTRIC_F0: f32 = 0.04;

struct BrdfSurface {
    base_color: vec3<f32>,
    metallic: f32,
    roughness: f32,
    specular: f32,
}

fn brdf_f0(s: BrdfSurface) -> vec3<f32> {
    return mix(vec3<f32>(BRDF_DIELECTRIC_F0 * s.specular), s.base_color, s.metallic);
}

fn brdf_f90(s: BrdfSurface) -> f32 {
    return s.specular + (1.0 - s.specular) * s.metallic;
}

fn brdf_diffuse_color(s: BrdfSurface) -> vec3<f32> {
    return s.base_color * (1.0 - s.metallic);
}

fn brdf_has_specular(s: BrdfSurface) -> bool {
    return s.metallic > 0.0 || s.specular > 0.0;
}

fn brdf_alpha(s: BrdfSurface) -> f32 {
    let r = clamp(s.roughness, BRDF_MIN_ROUGHNESS, 1.0);
    return r * r;
}

fn brdf_ggx_d(n_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = n_h * n_h * (a2 - 1.0) + 1.0;
    return a2 / max(PI * d * d, 1e-30);
}

fn brdf_smith_visibility(n_l: f32, n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let gv = n_l * sqrt(n_v * n_v * (1.0 - a2) + a2);
    let gl = n_v * sqrt(n_l * n_l * (1.0 - a2) + a2);
    return 0.5 / max(gv + gl, 1e-30);
}

fn brdf_smith_g1(n_v: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    return 2.0 * n_v / max(n_v + sqrt(a2 + (1.0 - a2) * n_v * n_v), 1e-30);
}

fn brdf_schlick_weight(cos: f32) -> f32 {
    let m = 1.0 - clamp(cos, 0.0, 1.0);
    let m2 = m * m;
    return m2 * m2 * m;
}

// The split-sum terms (A, B) at n·v and perceptual roughness, bilinear in the table.
fn brdf_dfg(n_v: f32, roughness: f32) -> vec2<f32> {
    let last = f32(BRDF_DFG_SIZE - 1u);
    let x = min(clamp(n_v, 0.0, 1.0) * last, last);
    let y = min(clamp(roughness, 0.0, 1.0) * last, last);
    let x0 = min(floor(x), last - 1.0);
    let y0 = min(floor(y), last - 1.0);
    let f = vec2<f32>(x - x0, y - y0);
    let i = u32(y0) * BRDF_DFG_SIZE + u32(x0);
    let top = mix(brdf_dfg_table[i], brdf_dfg_table[i + 1u], f.x);
    let bottom = mix(brdf_dfg_table[i + BRDF_DFG_SIZE], brdf_dfg_table[i + BRDF_DFG_SIZE + 1u], f.x);
    return mix(top, bottom, f.y);
}

// 1 + F0 (1 / E₁ − 1): the energy the lobe loses to single scattering, given back.
fn brdf_compensation(s: BrdfSurface, ab: vec2<f32>) -> vec3<f32> {
    return vec3<f32>(1.0) + brdf_f0(s) * (1.0 / max(ab.x + ab.y, 1e-4) - 1.0);
}

// The specular lobe's directional albedo at n·v (F0, F90 and the compensation applied): the share
// of uniform light it reflects; what the diffuse lobe cannot have.
fn brdf_specular_albedo(s: BrdfSurface, n_v: f32) -> vec3<f32> {
    let ab = brdf_dfg(n_v, s.roughness);
    return (brdf_f0(s) * ab.x + vec3<f32>(brdf_f90(s) * ab.y)) * brdf_compensation(s, ab);
}

// f(l, v), without the cosine: unit normal n, unit v towards the viewer, unit l towards the light.
fn brdf_eval(s: BrdfSurface, n: vec3<f32>, v: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    let diffuse = brdf_diffuse_color(s) * INV_PI;
    if !brdf_has_specular(s) {
        return diffuse;
    }
    let n_l = dot(n, l);
    let n_v = max(dot(n, v), 1e-4);
    if n_l <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = safe_normalize(v + l, n);
    let n_h = max(dot(n, h), 0.0);
    let v_h = max(dot(v, h), 0.0);
    let alpha = brdf_alpha(s);
    let fw = brdf_schlick_weight(v_h);
    let f = brdf_f0(s) * (1.0 - fw) + vec3<f32>(brdf_f90(s) * fw);
    let ab = brdf_dfg(n_v, s.roughness);
    let compensation = brdf_compensation(s, ab);
    let specular = f * brdf_ggx_d(n_h, alpha) * brdf_smith_visibility(n_l, n_v, alpha) * compensation;
    // The diffuse lobe gets what the specular one leaves (its directional albedo).
    let albedo = (brdf_f0(s) * ab.x + vec3<f32>(brdf_f90(s) * ab.y)) * compensation;
    return diffuse * max(vec3<f32>(1.0) - albedo, vec3<f32>(0.0)) + specular;
}

// An orthonormal basis around unit n (Duff et al. 2017): tangent, bitangent.
fn brdf_basis(n: vec3<f32>) -> mat3x3<f32> {
    let s = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + s * n.x * n.x * a, s * b, -s * n.x);
    let bt = vec3<f32>(b, s + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// A half vector from GGX's distribution of normals visible from v (Heitz 2018), world space.
fn brdf_sample_visible_normal(n: vec3<f32>, v: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let basis = brdf_basis(n);
    let vl = transpose(basis) * v;
    // The view direction stretched to the unit-roughness configuration.
    let vh = safe_normalize(vec3<f32>(alpha * vl.x, alpha * vl.y, max(vl.z, 1e-4)), vec3<f32>(0.0, 0.0, 1.0));
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = select(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(-vh.y, vh.x, 0.0) * inverseSqrt(max(len2, 1e-30)), len2 > 1e-12);
    let t2 = cross(vh, t1);
    let r = sqrt(u.x);
    let phi = 2.0 * PI * u.y;
    let p1 = r * cos(phi);
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    let nh = p1 * t1 + p2 * t2 + sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh;
    let hl = safe_normalize(vec3<f32>(alpha * nh.x, alpha * nh.y, max(nh.z, 0.0)), vec3<f32>(0.0, 0.0, 1.0));
    return basis * hl;
}

// Density (solid angle of l) of sampling l = reflect(−v, h) with h from brdf_sample_visible_normal.
fn brdf_visible_normal_pdf(n: vec3<f32>, v: vec3<f32>, l: vec3<f32>, alpha: f32) -> f32 {
    let h = safe_normalize(v + l, n);
    let n_v = max(dot(n, v), 1e-4);
    let v_h = max(dot(v, h), 1e-6);
    let dv = brdf_smith_g1(n_v, alpha) * v_h * brdf_ggx_d(max(dot(n, h), 0.0), alpha) / n_v;
    return dv / (4.0 * v_h);
}

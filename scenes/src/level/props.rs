//! The demo level's own low-poly props, made in code with their own materials: stone walls of
//! staggered blocks, grass platforms on dirt, grass tufts (the larger with a flower), clouds of
//! faceted puffs, a flying enemy and a blaster. The level uses them where Kenney's models are not
//! there (a checkout without the shared folder, or `--no-assets`).
//!
//! Each prop fills the box of the Kenney model it stands in for (`KitModel`'s bounds), so the level's
//! plan, footprints and tests are the same either way, and each of its pieces is a closed solid, so
//! probes can tell inside from outside. They cost a few hundred triangles each (the whole fallback
//! level about 40,000), built once when the level is, nothing per frame.

use std::f32::consts::{FRAC_PI_2, TAU};

use engine::scene::{Material, Mesh};
use engine::shapes::{box_part, icosphere, merge, prism, pyramid};
use glam::{Affine3A, Quat, Vec2, Vec3};

use super::Lcg;

/// One mesh of a prop and the material it is drawn with.
pub struct PropPiece {
    pub mesh: Mesh,
    pub material: Material,
}

/// The props' palette (linear albedos; names prefixed `prop_` so they never merge with a file's).
fn diffuse(name: &str, color: Vec3) -> Material {
    Material::diffuse(&format!("prop_{name}"), color)
}

fn stone_light() -> Material {
    diffuse("stone_light", Vec3::new(0.52, 0.5, 0.47))
}
fn stone_dark() -> Material {
    diffuse("stone_dark", Vec3::new(0.36, 0.35, 0.34))
}
fn mortar() -> Material {
    diffuse("mortar", Vec3::new(0.2, 0.19, 0.18))
}
fn capstone() -> Material {
    diffuse("capstone", Vec3::new(0.62, 0.6, 0.56))
}
fn turf() -> Material {
    diffuse("turf", Vec3::new(0.2, 0.45, 0.1))
}
fn dirt() -> Material {
    diffuse("dirt", Vec3::new(0.33, 0.2, 0.11))
}
fn blade_dark() -> Material {
    diffuse("blade_dark", Vec3::new(0.12, 0.36, 0.06))
}
fn blade_light() -> Material {
    diffuse("blade_light", Vec3::new(0.3, 0.55, 0.1))
}
fn petal() -> Material {
    diffuse("petal", Vec3::new(0.95, 0.75, 0.08))
}
fn cloud_white() -> Material {
    diffuse("cloud", Vec3::splat(0.92))
}
fn enemy_body() -> Material {
    Material { specular: 0.5, roughness: 0.5, ..diffuse("enemy_body", Vec3::new(0.32, 0.08, 0.5)) }
}
fn enemy_wing() -> Material {
    diffuse("enemy_wing", Vec3::new(0.14, 0.04, 0.24))
}
fn enemy_eye() -> Material {
    diffuse("enemy_eye", Vec3::splat(0.85))
}
fn glow(name: &str, radiance: Vec3) -> Material {
    Material::emissive(&format!("prop_{name}"), radiance)
}
fn orange() -> Material {
    diffuse("orange", Vec3::new(0.9, 0.38, 0.04))
}
fn gun_body() -> Material {
    Material { specular: 0.5, roughness: 0.45, ..diffuse("gun_body", Vec3::new(0.09, 0.1, 0.13)) }
}
fn gun_metal() -> Material {
    Material { metallic: 1.0, roughness: 0.35, specular: 1.0, ..diffuse("gun_metal", Vec3::new(0.75, 0.76, 0.78)) }
}

/// Parts gathered by material; each material's parts become one mesh.
struct Kit {
    name: &'static str,
    pieces: Vec<(Material, Vec<(Mesh, Affine3A)>)>,
}

impl Kit {
    fn new(name: &'static str) -> Self {
        Self { name, pieces: Vec::new() }
    }

    fn add(&mut self, material: Material, part: (Mesh, Affine3A)) {
        match self.pieces.iter_mut().find(|(m, _)| m.name == material.name) {
            Some((_, parts)) => parts.push(part),
            None => self.pieces.push((material, vec![part])),
        }
    }

    fn finish(self) -> Vec<PropPiece> {
        self.pieces
            .into_iter()
            .map(|(material, parts)| PropPiece { mesh: merge(&format!("{}:{}", self.name, material.name), &parts), material })
            .collect()
    }
}

/// A mesh placed where it was built.
fn here(mesh: Mesh) -> (Mesh, Affine3A) {
    (mesh, Affine3A::IDENTITY)
}

/// The rectangle `min`..`max` (x, z) with its corners cut by `c`: an octagon.
fn chamfered(min: Vec2, max: Vec2, c: f32) -> Vec<Vec2> {
    let c = c.min((max - min).min_element() * 0.45).max(0.0);
    vec![
        Vec2::new(min.x + c, min.y),
        Vec2::new(max.x - c, min.y),
        Vec2::new(max.x, min.y + c),
        Vec2::new(max.x, max.y - c),
        Vec2::new(max.x - c, max.y),
        Vec2::new(min.x + c, max.y),
        Vec2::new(min.x, max.y - c),
        Vec2::new(min.x, min.y + c),
    ]
}

/// A regular `n`-gon of circumradius `radius` about `center`, its first corner at angle `phase`.
fn ngon(center: Vec2, radius: f32, n: u32, phase: f32) -> Vec<Vec2> {
    (0..n).map(|i| center + Vec2::from_angle(phase + i as f32 * TAU / n as f32) * radius).collect()
}

/// A wall along x filling `min`..`max`: staggered stone blocks in `rows` rows standing out of a dark
/// mortar core, under a capstone.
pub fn stone_wall(min: Vec3, max: Vec3, rows: u32, seed: u64) -> Vec<PropPiece> {
    let mut kit = Kit::new("stone_wall");
    let mut rng = Lcg(seed);
    let size = max - min;
    let cap = (size.y * 0.07).min(0.1);
    let inset = (size.z * 0.1).min(0.035);
    let gap = 0.025;
    kit.add(mortar(), box_part(Vec3::new(min.x, min.y, min.z + inset), Vec3::new(max.x, max.y - cap, max.z - inset)));
    kit.add(capstone(), box_part(Vec3::new(min.x, max.y - cap, min.z), max));
    let rows = rows.max(1);
    let row = (size.y - cap) / rows as f32;
    let blocks = (size.x / 0.5).round().max(1.0);
    let block = size.x / blocks;
    for r in 0..rows {
        let y0 = min.y + r as f32 * row + if r == 0 { 0.0 } else { gap * 0.5 };
        let y1 = min.y + (r + 1) as f32 * row - gap * 0.5;
        let mut cuts = vec![min.x];
        let mut x = min.x + if r % 2 == 1 { block * 0.5 } else { block };
        while x < max.x - gap * 2.0 {
            cuts.push(x);
            x += block;
        }
        cuts.push(max.x);
        for (i, pair) in cuts.windows(2).enumerate() {
            let x0 = if i == 0 { pair[0] } else { pair[0] + gap * 0.5 };
            let x1 = if i + 2 == cuts.len() { pair[1] } else { pair[1] - gap * 0.5 };
            let (front, back) = (rng.range(0.0, inset * 0.4), rng.range(0.0, inset * 0.4));
            let material = if rng.next() < 0.5 { stone_light() } else { stone_dark() };
            kit.add(material, box_part(Vec3::new(x0, y0, min.z + front), Vec3::new(x1, y1, max.z - back)));
        }
    }
    kit.finish()
}

/// A platform filling `min`..`max`: a chamfered slab of turf on a slightly narrower block of dirt.
pub fn grass_platform(min: Vec3, max: Vec3) -> Vec<PropPiece> {
    let mut kit = Kit::new("grass_platform");
    let (lo, hi) = (Vec2::new(min.x, min.z), Vec2::new(max.x, max.z));
    let chamfer = (hi - lo).min_element() * 0.12;
    let turf_depth = (max.y - min.y) * 0.3;
    kit.add(turf(), here(prism("", &chamfered(lo, hi, chamfer), max.y - turf_depth, max.y)));
    let inset = (hi - lo).min_element() * 0.03;
    kit.add(dirt(), here(prism("", &chamfered(lo + inset, hi - inset, chamfer), min.y, max.y - turf_depth + 0.01)));
    kit.finish()
}

/// A tuft of `blades` grass blades (leaning pyramids) filling `min`..`max`; with `flower`, a stalk
/// with a yellow flower head in the middle.
pub fn grass_tuft(min: Vec3, max: Vec3, blades: u32, flower: bool, seed: u64) -> Vec<PropPiece> {
    let mut kit = Kit::new("grass_tuft");
    let mut rng = Lcg(seed);
    let center = Vec2::new(min.x + max.x, min.z + max.z) * 0.5;
    let half = Vec2::new(max.x - min.x, max.z - min.z) * 0.5;
    let height = max.y - min.y;
    let width = half.min_element() * 0.16;
    for i in 0..blades {
        let angle = (i as f32 + rng.range(-0.3, 0.3)) * TAU / blades as f32;
        let out = Vec2::from_angle(angle);
        let root = center + out * half * rng.range(0.05, 0.35);
        let tip = center + out * half * rng.range(0.85, 1.0);
        let top = if i == 0 && !flower { max.y } else { min.y + height * rng.range(0.55, 0.95) };
        let base = ngon(root, width, 3, rng.range(0.0, TAU));
        let material = if i % 2 == 0 { blade_dark() } else { blade_light() };
        kit.add(material, here(pyramid("", &base, min.y, Vec3::new(tip.x, top, tip.y))));
    }
    if flower {
        let head = half.min_element() * 0.28;
        let stalk_top = max.y - head * 1.6;
        kit.add(blade_dark(), here(prism("", &ngon(center, width * 0.35, 4, 0.0), min.y, stalk_top + head * 0.5)));
        let bloom = Affine3A::from_scale_rotation_translation(
            Vec3::new(1.0, 0.6, 1.0),
            Quat::IDENTITY,
            Vec3::new(center.x, stalk_top + head * 0.6, center.y),
        );
        kit.add(petal(), (icosphere("", head, 0), bloom));
    }
    kit.finish()
}

/// A cloud filling `min`..`max`: overlapping faceted puffs on a flat base (a cumulus: seen from
/// the ground its sunlit sides show, not a grey belly).
pub fn cloud(min: Vec3, max: Vec3) -> Vec<PropPiece> {
    // (centre, radius) in the unit box; the puffs are cut flat at `BASE` and the rest stretched
    // to fill the box.
    const BASE: f32 = 0.35;
    let puffs = [
        (Vec3::new(0.5, 0.5, 0.5), 0.5),
        (Vec3::new(0.26, 0.4, 0.55), 0.25),
        (Vec3::new(0.74, 0.38, 0.45), 0.25),
        (Vec3::new(0.5, 0.36, 0.26), 0.22),
        (Vec3::new(0.56, 0.62, 0.62), 0.3),
    ];
    let parts: Vec<(Mesh, Affine3A)> =
        puffs.iter().map(|&(center, radius)| (icosphere("", radius, 1), Affine3A::from_translation(center))).collect();
    let mut puffs = merge("", &parts);
    flatten_below(&mut puffs, BASE);
    let stretch = Affine3A::from_translation(Vec3::new(0.0, -BASE, 0.0));
    let unit_to_box = Affine3A::from_translation(min) * Affine3A::from_scale((max - min) * Vec3::new(1.0, 1.0 / (1.0 - BASE), 1.0));
    let mut kit = Kit::new("cloud");
    kit.add(cloud_white(), (puffs, unit_to_box * stretch));
    kit.finish()
}

/// Lifts every vertex under height `y` onto it and gives each triangle its flat normal again: a
/// faceted solid cut flat underneath (still closed: shared corners move together).
fn flatten_below(mesh: &mut Mesh, y: f32) {
    for p in &mut mesh.positions {
        p.y = p.y.max(y);
    }
    for tri in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let normal = (b - a).cross(c - a).try_normalize().unwrap_or(Vec3::NEG_Y);
        for &i in tri {
            mesh.normals[i as usize] = normal;
        }
    }
}

/// A flying enemy facing +Z filling `min`..`max` (made for Kenney's box, -0.6..0.6 × 0..0.875 ×
/// -0.32..0.43, and scaled to another): a purple body, swept wings, a glowing eye, a horn, a tail
/// fin and a jet underneath.
pub fn flying_enemy(min: Vec3, max: Vec3) -> Vec<PropPiece> {
    let mut kit = Kit::new("flying_enemy");
    let body = Vec3::new(0.0, 0.45, 0.05);
    kit.add(enemy_body(), (icosphere("", 0.3, 1), Affine3A::from_translation(body)));
    for side in [-1.0f32, 1.0] {
        let outline = [Vec2::new(0.2 * side, -0.15), Vec2::new(0.6 * side, -0.05), Vec2::new(0.6 * side, 0.12), Vec2::new(0.2 * side, 0.2)];
        let wing = prism("", &outline, -0.02, 0.02);
        let hinge = Vec3::new(0.2 * side, 0.49, 0.0);
        let xf =
            Affine3A::from_translation(hinge) * Affine3A::from_rotation_z(0.25 * side) * Affine3A::from_translation(-hinge.with_y(0.0));
        kit.add(enemy_wing(), (wing, xf));
    }
    let eye = Affine3A::from_scale_rotation_translation(Vec3::new(1.0, 1.0, 0.6), Quat::IDENTITY, Vec3::new(0.0, 0.5, 0.3));
    kit.add(enemy_eye(), (icosphere("", 0.13, 1), eye));
    let pupil = Affine3A::from_scale_rotation_translation(Vec3::new(1.0, 1.0, 0.5), Quat::IDENTITY, Vec3::new(0.0, 0.5, 0.37));
    kit.add(glow("enemy_pupil", Vec3::new(4.0, 0.8, 0.2)), (icosphere("", 0.06, 0), pupil));
    let square = |c: Vec2, h: f32| vec![c + Vec2::new(-h, -h), c + Vec2::new(h, -h), c + Vec2::new(h, h), c + Vec2::new(-h, h)];
    kit.add(orange(), here(pyramid("", &square(Vec2::new(0.0, 0.1), 0.05), 0.68, Vec3::new(0.0, 0.875, -0.02))));
    let fin = [Vec2::new(-0.03, -0.12), Vec2::new(0.03, -0.12), Vec2::new(0.0, -0.2)];
    kit.add(enemy_wing(), here(pyramid("", &fin, 0.62, Vec3::new(0.0, 0.74, -0.32))));
    kit.add(orange(), here(pyramid("", &ngon(Vec2::new(0.0, 0.0), 0.1, 6, 0.0), 0.22, Vec3::new(0.0, 0.0, 0.0))));
    fit(kit, Vec3::new(-0.6, 0.0, -0.32), Vec3::new(0.6, 0.875, 0.43), min, max)
}

/// A blaster pointing along +Z filling `min`..`max` (made for Kenney's box, -0.36..0.52 × 0..0.9 ×
/// -0.7..0.9): a dark body with an orange stripe, a metal barrel with a muzzle ring, a scope, a
/// grip, a glowing energy cell on its right and a guard on its left.
pub fn blaster(min: Vec3, max: Vec3) -> Vec<PropPiece> {
    let mut kit = Kit::new("blaster");
    kit.add(gun_body(), box_part(Vec3::new(-0.2, 0.35, -0.7), Vec3::new(0.2, 0.72, 0.35)));
    kit.add(gun_body(), box_part(Vec3::new(-0.09, 0.72, -0.4), Vec3::new(0.09, 0.9, 0.15)));
    kit.add(gun_body(), box_part(Vec3::new(-0.11, 0.0, -0.5), Vec3::new(0.11, 0.4, -0.22)));
    kit.add(orange(), box_part(Vec3::new(-0.21, 0.55, -0.6), Vec3::new(0.21, 0.62, 0.3)));
    // Along +Z: a column along +Y turned a quarter about X.
    let along_z = |z0: f32, z1: f32, radius: f32| {
        let xf = Affine3A::from_translation(Vec3::new(0.0, 0.55, z0)) * Affine3A::from_rotation_x(FRAC_PI_2);
        (prism("", &ngon(Vec2::ZERO, radius, 6, 0.0), 0.0, z1 - z0), xf)
    };
    kit.add(gun_metal(), along_z(0.3, 0.82, 0.11));
    kit.add(orange(), along_z(0.78, 0.9, 0.14));
    // Along +X: a column along +Y turned a quarter about Z.
    let cell = Affine3A::from_translation(Vec3::new(0.0, 0.5, -0.25)) * Affine3A::from_rotation_z(-FRAC_PI_2);
    kit.add(glow("energy_cell", Vec3::new(0.3, 1.6, 2.2)), (prism("", &ngon(Vec2::ZERO, 0.12, 6, 0.0), 0.18, 0.52), cell));
    kit.add(gun_metal(), box_part(Vec3::new(-0.36, 0.42, -0.15), Vec3::new(-0.18, 0.6, 0.2)));
    fit(kit, Vec3::new(-0.36, 0.0, -0.7), Vec3::new(0.52, 0.9, 0.9), min, max)
}

/// The kit's pieces built in the box `from_min`..`from_max`, stretched to fill `min`..`max`.
fn fit(kit: Kit, from_min: Vec3, from_max: Vec3, min: Vec3, max: Vec3) -> Vec<PropPiece> {
    let scale = (max - min) / (from_max - from_min).max(Vec3::splat(1e-6));
    let xf = Affine3A::from_translation(min) * Affine3A::from_scale(scale) * Affine3A::from_translation(-from_min);
    kit.finish()
        .into_iter()
        .map(|piece| {
            let name = piece.mesh.name.clone();
            PropPiece { mesh: merge(&name, &[(piece.mesh, xf)]), material: piece.material }
        })
        .collect()
}

//! Scenes made by others, from the shared folder beside the checkout (`scenes::files`; skipped with
//! a message when it is absent): the real Šibenik cathedral loads with its materials, its stained
//! glass as openings, and the lights and camera the file lacks, and renders lit, directly and by
//! DDGI; FlightHelmet loads with its external textures and renders with the red wall's light on
//! it; the meadow is the flower bushes' cut-out cards, instanced.

use ddgi::{DdgiLighting, DdgiOutput, DdgiVolume};
use engine::headless::{HeadlessSettings, render_scene, render_scene_with};
use engine::scene::{AlphaMode, NodeContent, SceneDescription};
use glam::Vec3;

/// The scene file called `name` in [`scenes::files::FILES`], loaded and staged; `None` (and a
/// message) when the shared folder lacks it.
fn shared_scene(test: &str, name: &str) -> Option<SceneDescription> {
    let file = scenes::files::find(name).expect("a listed scene");
    testkit::shared(test, file.path)?;
    Some(scenes::files::load(name).expect("a listed scene").unwrap_or_else(|e| panic!("{e}")))
}

fn sibenik(test: &str) -> Option<SceneDescription> {
    shared_scene(test, "sibenik")
}

/// Rec. 709 luminance weights of linear RGB.
const LUMA: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

fn pixels(hdr: &[f32]) -> impl Iterator<Item = Vec3> + '_ {
    hdr.chunks_exact(4).map(|p| Vec3::new(p[0], p[1], p[2]))
}

fn rgb_mean(hdr: &[f32]) -> Vec3 {
    pixels(hdr).sum::<Vec3>() / (hdr.len() / 4) as f32
}

fn mean_luminance(hdr: &[f32]) -> f32 {
    rgb_mean(hdr).dot(LUMA)
}

#[test]
fn sibenik_loads_with_its_textures_its_glass_as_openings_and_a_sun_a_light_and_a_camera() {
    let Some(scene) = sibenik("sibenik_loads") else { return };
    let triangles: usize = scene.meshes.iter().map(|m| m.indices.len() / 3).sum();
    assert_eq!(triangles, 73_564, "the file's triangles");
    // Colour textures: the walls', the columns' and the floor's marble (bump maps are not used).
    assert!(scene.images.len() >= 3, "{} images", scene.images.len());
    let material = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"));
    assert!(material("kamen_zid").base_color_texture.is_some() && material("pod").base_color_texture.is_some());
    assert_eq!(material("kamen_zid").alpha_mode, AlphaMode::Opaque);
    // The rose window's glass (`illum 4`) is an opening; the red pane (`d 0.8`, `illum 2`) stays.
    for glass in ["staklo_zeleno", "staklo_plavo", "staklo_zuto"] {
        assert_eq!((material(glass).alpha_mode, material(glass).base_color.w), (AlphaMode::Blend, 0.0), "{glass}");
    }
    assert_eq!(material("staklo_crveno").alpha_mode, AlphaMode::Blend);
    assert!((material("staklo_crveno").base_color.w - 0.8).abs() < 1e-6);
    let count = |pick: fn(&NodeContent) -> bool| scene.nodes.iter().flat_map(|n| &n.content).filter(|c| pick(c)).count();
    assert_eq!(count(|c| matches!(c, NodeContent::DirectionalLight(_))), 1, "a sun");
    assert_eq!(count(|c| matches!(c, NodeContent::PointLight(_))), 1, "the nave's light");
    assert_eq!(count(|c| matches!(c, NodeContent::Camera(_))), 1, "a camera");
    let (lo, hi) = scene.bounds().expect("geometry");
    let eye = scenes::files::SIBENIK_CAMERA_EYE;
    assert!(eye.cmpgt(lo).all() && eye.cmplt(hi).all() && eye.y - scenes::files::SIBENIK_FLOOR_Y < 2.0, "camera {eye} in {lo}..{hi}");
}

#[test]
fn sibenik_renders_lit_directly_and_brighter_with_ddgi() {
    let Some(scene) = sibenik("sibenik_renders_lit") else { return };
    let Some(gpu) = testkit::gpu("sibenik_renders_lit_directly_and_brighter_with_ddgi") else { return };
    let settings = HeadlessSettings { width: 64, height: 40, frames: 1, ..Default::default() };
    let direct = render_scene(&gpu, scene.clone(), &settings).expect("direct");
    assert!(direct.hdr.iter().all(|v| v.is_finite()));
    let direct_mean = mean_luminance(&direct.hdr);
    // The sun's patches and the nave light's pool: some pixels far brighter than the typical one.
    let mut lum: Vec<f32> = pixels(&direct.hdr).map(|p| p.dot(LUMA)).collect();
    lum.sort_by(f32::total_cmp);
    let (median, top) = (lum[lum.len() / 2], lum[lum.len() * 99 / 100]);
    assert!(direct_mean > 1e-3 && top > 4.0 * median.max(1e-4), "direct: mean {direct_mean}, median {median}, 99th percentile {top}");

    let lighting = DdgiLighting::Fitted(DdgiVolume { rays_per_probe: 32, ..Default::default() });
    let settings = HeadlessSettings { frames: 40, ..settings };
    let lit = render_scene_with(&gpu, scene, &settings, |app| ddgi::use_ddgi_lighting(app, lighting, DdgiOutput::Full)).expect("ddgi");
    assert!(lit.hdr.iter().all(|v| v.is_finite()));
    let ddgi_mean = mean_luminance(&lit.hdr);
    // A closed stone interior lit through its windows: bounced light is a large share of what the
    // camera sees (the path tracer, 256 paths a pixel: 1.7× the direct light at this view).
    assert!(ddgi_mean > 1.3 * direct_mean, "DDGI mean {ddgi_mean} against direct {direct_mean}");
}

#[test]
fn flight_helmet_loads_its_external_textures_and_is_lit_by_the_red_wall() {
    let Some(scene) = shared_scene("flight_helmet", "flight_helmet") else { return };
    let helmet: usize = scene.meshes.iter().filter(|m| !m.name.starts_with("corner_")).map(|m| m.indices.len() / 3).sum();
    assert_eq!(helmet, 94_722, "the file's triangles");
    // Five textured materials (base colour, normal map, occlusion-roughness-metal from 15 PNGs, all
    // 512² but the lenses' 32² normal map), the lenses blended; every normal-mapped mesh has tangents.
    assert_eq!(scene.images.len(), 15);
    assert_eq!(scene.images.iter().filter(|i| (i.width, i.height) == (512, 512)).count(), 14);
    let textured = scene.materials.iter().filter(|m| m.base_color_texture.is_some() && m.normal_texture.is_some()).count();
    assert!(textured >= 5, "{textured} materials with colour and normal textures");
    let lenses = scene.materials.iter().find(|m| m.name == "LensesMat").expect("the lenses");
    assert_eq!(lenses.alpha_mode, AlphaMode::Blend);
    assert!(scene.meshes.iter().filter(|m| !m.name.starts_with("corner_")).all(|m| m.tangents.len() == m.positions.len()));

    let Some(gpu) = testkit::gpu("flight_helmet_loads_its_external_textures_and_is_lit_by_the_red_wall") else { return };
    let settings = HeadlessSettings { width: 64, height: 48, frames: 1, ..Default::default() };
    let direct = render_scene(&gpu, scene.clone(), &settings).expect("direct");
    let lighting = DdgiLighting::Fitted(DdgiVolume { rays_per_probe: 64, ..Default::default() });
    let settings = HeadlessSettings { frames: 40, ..settings };
    let lit = render_scene_with(&gpu, scene, &settings, |app| ddgi::use_ddgi_lighting(app, lighting, DdgiOutput::Full)).expect("ddgi");
    assert!(lit.hdr.iter().all(|v| v.is_finite()));
    // What DDGI adds is the corner's bounced light: the white floor's and walls', and the red
    // wall's, so redder than white.
    let (direct, ddgi) = (rgb_mean(&direct.hdr), rgb_mean(&lit.hdr));
    let indirect = ddgi - direct;
    assert!(indirect.min_element() > 0.0 && indirect.y > 0.3 * direct.y, "indirect {indirect} against direct {direct}");
    assert!(indirect.x > 1.15 * indirect.y, "the red wall's bounce: indirect {indirect}");
}

#[test]
fn the_meadow_is_the_flower_bushes_instanced_and_cut_out() {
    let Some(scene) = shared_scene("meadow", "meadow") else { return };
    // The file's three plant meshes, shared by every copy, and the ground.
    assert_eq!(scene.meshes.len(), 4);
    let copies = scene.nodes.iter().filter(|n| n.name.starts_with("plants_")).count();
    assert_eq!(copies, 100);
    let instances = scene.nodes.iter().flat_map(|n| &n.content).filter(|c| matches!(c, NodeContent::Meshes(_))).count();
    assert_eq!(instances, 3 * copies + 1);
    let flowers = scene.materials.iter().find(|m| m.name == "Flowers").expect("the plants' material");
    assert!(flowers.alpha_mode != AlphaMode::Opaque && flowers.base_color_texture.is_some());
    // Recentred: the copies stand on the ground around the origin, not near x = 150.
    let (lo, hi) = scene.bounds().expect("geometry");
    assert!(lo.x > -40.0 && hi.x < 40.0 && lo.z > -40.0 && hi.z < 40.0 && lo.y > -0.3, "{lo}..{hi}");
}

//! The level's unit tests: it builds without the Kenney models, its DDGI box holds it, its own
//! props are closed solids filling their models' boxes, and the Kenney models load when present.

use super::kit::*;
use super::*;

fn names(desc: &SceneDescription) -> Vec<&str> {
    desc.nodes.iter().map(|n| n.name.as_str()).collect()
}

#[test]
fn builds_without_assets() {
    let level = demo_level(None);
    assert!(level.scene.images.is_empty(), "no textures without the kit");
    for mesh in &level.scene.meshes {
        assert!(mesh.positions.iter().all(|p| p.is_finite()), "mesh {} has a non-finite position", mesh.name);
        assert!(mesh.normals.iter().all(|n| n.is_finite()), "mesh {} has a non-finite normal", mesh.name);
        assert!(mesh.indices.iter().all(|&i| (i as usize) < mesh.positions.len()));
        assert!(mesh.triangle_count() > 0);
    }
    let names = names(&level.scene);
    for name in [SUN, DOOR, PLATFORM, MOVING_LIGHT, PLAYER_CAMERA, ENEMY, "house", "red_wall", "green_wall", "emissive_panel"] {
        assert_eq!(names.iter().filter(|n| **n == name).count(), 1, "node {name}");
    }
    let nodes = &level.scene.nodes;
    let node = |name: &str| nodes.iter().find(|n| n.name == name).unwrap();
    assert!(node(SUN).content.iter().any(|c| matches!(c, NodeContent::DirectionalLight(_))));
    assert!(node(MOVING_LIGHT).content.iter().any(|c| matches!(c, NodeContent::PointLight(_))) && node(MOVING_LIGHT).orbit.is_some());
    assert!(node(PLAYER_CAMERA).content.iter().any(|c| matches!(c, NodeContent::Camera(_))));
    assert!(node(ENEMY).orbit.is_some());
    assert!((node(PLAYER_CAMERA).transform.translation - level.layout.spawn - Vec3::Y * 1.6).length() < 1e-5);
    assert!(level.scene.materials.iter().any(|m| m.is_emissive()));
}

#[test]
fn gi_bounds_contain_the_level() {
    let level = demo_level(None);
    let (lo, hi) = level.layout.gi_bounds;
    let b = level.layout.bounds;
    assert!(lo.x <= b.min.x && lo.z <= b.min.y && hi.x >= b.max.x && hi.z >= b.max.y);
    // Everything on the ground but the clouds (and the ground slab itself, which runs on past
    // the fence) is inside: house, roof, props, fence, enemy.
    let world = level.scene.world_transforms();
    let mut checked = 0;
    for (node, xf) in level.scene.nodes.iter().zip(&world) {
        if node.name.starts_with("cloud") || node.name == "ground" {
            continue;
        }
        for content in &node.content {
            let NodeContent::Meshes(list) = content else { continue };
            for &(mesh, _) in list {
                for &p in &level.scene.meshes[mesh].positions {
                    let p = xf.transform_point3(p);
                    if p.y >= 0.0 {
                        assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{} vertex {p} outside {lo}..{hi}", node.name);
                        checked += 1;
                    }
                }
            }
        }
    }
    assert!(checked > 100);
    // The lift at its top, with a person on it.
    assert!(hi.y >= LIFT_HIGH + 2.0 && lo.y <= 0.0);
    for f in &level.layout.floors {
        assert!(f.height >= lo.y && f.height <= hi.y);
    }
}

const MODELS: [&KitModel; 9] =
    [&PLATFORM_SMALL, &PLATFORM_LARGE, &WALL_HIGH, &WALL_LOW, &GRASS_TUFT, &GRASS_SMALL, &CLOUD, &ENEMY_FLYING, &BLASTER];

#[test]
fn the_levels_own_props_are_closed_solids_that_fill_their_models_boxes() {
    for model in MODELS {
        let pieces = (model.prop)(model.min, model.max);
        assert!(!pieces.is_empty(), "{}: no prop", model.file);
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for piece in &pieces {
            let mesh = &piece.mesh;
            assert!(engine::shapes::is_closed(mesh), "{}: {} is not a closed solid", model.file, mesh.name);
            assert!(piece.material.name.starts_with("prop_"), "{}: material {}", model.file, piece.material.name);
            assert!(mesh.normals.len() == mesh.positions.len() && mesh.positions.iter().chain(&mesh.normals).all(|v| v.is_finite()));
            let (a, b) = mesh.bounds().unwrap();
            (lo, hi) = (lo.min(a), hi.max(b));
        }
        // Inside the model's box, and filling most of it along every axis (walls and platforms,
        // which the plan's footprints and floors stand for, fill it exactly).
        let tolerance = 1e-4;
        assert!(lo.cmpge(model.min - tolerance).all() && hi.cmple(model.max + tolerance).all(), "{}: {lo}..{hi}", model.file);
        let filled = (hi - lo) / (model.max - model.min);
        assert!(filled.min_element() > 0.8, "{}: fills {filled} of its box", model.file);
    }
    for solid in [&WALL_HIGH, &WALL_LOW, &PLATFORM_SMALL, &PLATFORM_LARGE] {
        let (lo, hi) = (solid.prop)(solid.min, solid.max)
            .iter()
            .map(|p| p.mesh.bounds().unwrap())
            .fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)));
        assert!((lo - solid.min).abs().max_element() < 1e-4 && (hi - solid.max).abs().max_element() < 1e-4, "{}", solid.file);
    }
}

#[test]
fn without_the_kenney_models_every_prop_is_the_levels_own() {
    let level = demo_level(None);
    let own: Vec<&str> = level.scene.materials.iter().filter(|m| m.name.starts_with("prop_")).map(|m| m.name.as_str()).collect();
    for name in ["prop_stone_light", "prop_turf", "prop_blade_dark", "prop_petal", "prop_cloud", "prop_enemy_body", "prop_gun_metal"] {
        assert!(own.contains(&name), "no {name} among {own:?}");
    }
    // Every prop node is placed, the decoration (grass, the blaster) included.
    let names = names(&level.scene);
    assert_eq!(names.iter().filter(|n| n.starts_with("grass") && !n.contains("_part")).count(), 60);
    assert!(names.contains(&"blaster"));
    // The props' pieces are shared between their nodes, not copied: one mesh a material a model.
    assert!(level.scene.meshes.len() < 80, "{} meshes", level.scene.meshes.len());
}

#[test]
fn loads_the_kenney_models_when_present() {
    let Some(dir) = kenney_assets_dir() else {
        eprintln!("loads_the_kenney_models_when_present: skipped: {}", crate::shared::absent(crate::shared::KENNEY_FPS));
        return;
    };
    let with = demo_level(Some(&dir));
    let without = demo_level(None);
    assert_eq!(with.layout, without.layout, "the plan must not depend on the assets");
    assert!(!with.scene.images.is_empty(), "the colormap texture was not loaded");
    assert_eq!(with.scene.images.len(), 1, "the shared colormap should be stored once");
    assert!(with.scene.triangle_count() > without.scene.triangle_count());
    assert!(with.scene.materials.iter().all(|m| !m.name.starts_with("prop_")), "a prop stood in for a Kenney model");
    for model in MODELS {
        let scene = engine::import::load_scene(&dir.join(model.file)).unwrap();
        let (lo, hi) = scene.bounds().unwrap();
        assert!(
            (lo - model.min).abs().max_element() < 0.02 && (hi - model.max).abs().max_element() < 0.02,
            "{}: bounds {lo}..{hi}, placed as {}..{}",
            model.file,
            model.min,
            model.max
        );
    }
    let missing = demo_level(Some(Path::new("/nonexistent/kenney")));
    assert_eq!(missing.scene.triangle_count(), without.scene.triangle_count());
}

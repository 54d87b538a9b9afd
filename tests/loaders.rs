//! The scene importers: the glTF fixture's hierarchy, transforms, meshes, materials, lights and
//! camera; the OBJ Cornell box; the Kenney models (from ../shared, skipped without it); and the broken-file corpus, where every
//! file must fail with a message naming the file and the problem, and nothing may panic.

use std::f32::consts::FRAC_PI_4;
use std::path::{Path, PathBuf};

use bevy_ecs::world::World;
use engine::import::{ImportError, load_scene, validate_mesh};
use engine::scene::{AlphaMode, Camera, DirectionalLight, MeshInstance, NodeContent, PointLight, SceneDescription, SpotLight, UvTransform};
use glam::{Vec2, Vec3, Vec4};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

fn load(name: &str) -> SceneDescription {
    let path = fixtures().join(name);
    load_scene(&path).unwrap_or_else(|e| panic!("{} should load: {e}", path.display()))
}

fn node(scene: &SceneDescription, name: &str) -> usize {
    scene.nodes.iter().position(|n| n.name == name).unwrap_or_else(|| panic!("no node named {name}"))
}

fn material(scene: &SceneDescription, name: &str) -> usize {
    scene.materials.iter().position(|m| m.name == name).unwrap_or_else(|| panic!("no material named {name}"))
}

fn mesh_instances(scene: &SceneDescription, node_index: usize) -> Vec<(usize, usize)> {
    scene.nodes[node_index]
        .content
        .iter()
        .flat_map(|c| match c {
            NodeContent::Meshes(list) => list.clone(),
            _ => Vec::new(),
        })
        .collect()
}

fn assert_near(actual: Vec3, expected: Vec3, what: &str) {
    assert!(actual.abs_diff_eq(expected, 1e-5), "{what}: {actual} != {expected}");
}

fn assert_valid(scene: &SceneDescription, file: &str) {
    for (i, mesh) in scene.meshes.iter().enumerate() {
        validate_mesh(mesh, Path::new(file), &format!("mesh {i}")).unwrap();
    }
    for (i, node) in scene.nodes.iter().enumerate() {
        if let Some(parent) = node.parent {
            assert!(parent < i, "{file}: node {i} comes before its parent {parent}");
        }
        for (mesh, material) in mesh_instances(scene, i) {
            assert!(mesh < scene.meshes.len() && material < scene.materials.len());
        }
    }
    for material in &scene.materials {
        for texture in [material.base_color_texture, material.emissive_texture].into_iter().flatten() {
            assert!((texture.image.index() as usize) < scene.images.len());
        }
    }
}

#[test]
fn gltf_hierarchy_transforms_and_content() {
    let scene = load("hierarchy.gltf");
    assert_valid(&scene, "hierarchy.gltf");
    assert_eq!(scene.name, "hierarchy");

    // The default scene's nodes, parents first; the node outside the scene is not imported.
    let names: Vec<&str> = scene.nodes.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["Parent", "Child", "StripNode", "StripCopy", "Camera", "PointLight", "SpotLight", "Sun", "OrthoCamera"]);
    let parent = node(&scene, "Parent");
    let child = node(&scene, "Child");
    assert_eq!(scene.nodes[parent].parent, None);
    assert_eq!(scene.nodes[child].parent, Some(parent));
    assert_eq!(scene.nodes[node(&scene, "StripNode")].parent, Some(parent));

    // Parent: T(1,0,0)·R_y(90°)·S(2); the child's (0,0,1) lands at (1,0,0) + 2·(1,0,0).
    let world = scene.world_transforms();
    assert_near(scene.nodes[parent].transform.scale, Vec3::splat(2.0), "parent scale");
    assert_near(world[child].translation.into(), Vec3::new(3.0, 0.0, 0.0), "child world position");
    assert_near(world[node(&scene, "StripNode")].translation.into(), Vec3::new(1.0, 2.0, 0.0), "strip node");
    // A node given as a matrix is decomposed.
    let camera_node = node(&scene, "Camera");
    assert_near(scene.nodes[camera_node].transform.translation, Vec3::new(0.0, 1.0, 5.0), "camera translation");

    // One mesh per (mesh, primitive) actually used, one material per glTF material plus the default.
    assert_eq!(scene.meshes.len(), 3);
    assert_eq!(scene.materials.len(), 3);
    assert_eq!(scene.images.len(), 1);
    let textured = material(&scene, "Textured");
    let glow = material(&scene, "Glow");
    let default = material(&scene, "default");
    let parts = mesh_instances(&scene, child);
    assert_eq!(parts.len(), 2, "one instance per primitive");
    assert_eq!((parts[0].1, parts[1].1), (textured, glow), "primitive → material");
    let strip = mesh_instances(&scene, node(&scene, "StripNode"));
    assert_eq!(strip, mesh_instances(&scene, node(&scene, "StripCopy")), "shared mesh is imported once");
    assert_eq!(strip.len(), 1);
    assert_eq!(strip[0].1, default);

    // Primitive 0: indexed quad with normals and UVs.
    let quad = &scene.meshes[parts[0].0];
    assert_eq!((quad.positions.len(), quad.indices.len()), (4, 6));
    assert_eq!(quad.uvs.len(), 4);
    assert!(quad.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
    // Primitive 1: non-indexed triangle without normals: indices 0..3, computed normals.
    let triangle = &scene.meshes[parts[1].0];
    assert_eq!(triangle.indices, [0, 1, 2]);
    assert!(triangle.uvs.is_empty());
    assert!(triangle.normals.iter().all(|n| n.abs_diff_eq(Vec3::Y, 1e-6)), "{:?}", triangle.normals);
    // A triangle strip of 4 vertices becomes 2 triangles facing +Z.
    let strip_mesh = &scene.meshes[strip[0].0];
    assert_eq!(strip_mesh.triangle_count(), 2);
    assert!(strip_mesh.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)), "{:?}", strip_mesh.normals);
    assert_eq!(scene.triangle_count(), 2 + 1 + 2);

    // Base colour factor and texture with KHR_texture_transform.
    let textured = &scene.materials[textured];
    assert_eq!(textured.base_color, Vec4::new(1.0, 0.5, 0.25, 1.0));
    let texture = textured.base_color_texture.expect("base colour texture");
    assert_eq!(texture.transform, UvTransform { offset: Vec2::new(0.5, 0.25), rotation: 0.3, scale: Vec2::new(2.0, 3.0) });
    // Its sampler's magFilter is NEAREST (9728); a texture without a sampler is bilinear (pbr.gltf).
    assert_eq!(texture.filter, engine::scene::TextureFilter::Nearest);
    let pbr = load("pbr.gltf");
    assert!(pbr.materials.iter().filter_map(|m| m.base_color_texture).all(|t| t.filter == engine::scene::TextureFilter::Linear));
    let image = &scene.images[texture.image.index() as usize];
    assert_eq!((image.name.as_str(), image.width, image.height), ("checker", 2, 2));
    assert_eq!(image.rgba8.len(), 16);
    assert_eq!(&image.rgba8[..8], &[255, 0, 0, 255, 0, 255, 0, 255]);
    assert!(!textured.is_emissive());

    // Emissive factor with KHR_materials_emissive_strength.
    let glow = &scene.materials[glow];
    assert_eq!(glow.emissive, Vec3::new(1.0, 0.5, 0.25));
    assert_eq!(glow.emissive_strength, 5.0);
    assert!(glow.is_emissive());
    let default = &scene.materials[default];
    assert_eq!((default.base_color, default.emissive), (Vec4::ONE, Vec3::ZERO));

    // Lights keep glTF's intensities; the spot's outer cone defaults to π/4.
    let content = |name: &str| scene.nodes[node(&scene, name)].content.clone();
    assert_eq!(
        content("PointLight"),
        [NodeContent::PointLight(PointLight { color: Vec3::new(1.0, 0.9, 0.8), intensity: 100.0, range: Some(20.0) })]
    );
    assert_eq!(
        content("SpotLight"),
        [NodeContent::SpotLight(SpotLight {
            color: Vec3::ONE,
            intensity: 50.0,
            range: None,
            inner_cone_angle: 0.2,
            outer_cone_angle: FRAC_PI_4
        })]
    );
    assert_eq!(content("Sun"), [NodeContent::DirectionalLight(DirectionalLight { color: Vec3::ONE, intensity: 3.0 })]);
    // The spot light is turned to shine down.
    let spot_forward = world[node(&scene, "SpotLight")].transform_vector3(Vec3::NEG_Z);
    assert_near(spot_forward, Vec3::NEG_Y, "spot light direction");

    // Perspective camera; the orthographic one is skipped.
    assert_eq!(content("Camera"), [NodeContent::Camera(Camera { yfov: 0.8, znear: 0.1, exposure: 1.0 })]);
    assert!(content("OrthoCamera").is_empty());
    assert!(scene.has_camera());
}

#[test]
fn glb_matches_gltf() {
    // The same scene with its buffer in the GLB binary chunk and its image in a buffer view.
    let gltf = load("hierarchy.gltf");
    let glb = load("hierarchy.glb");
    assert_eq!(glb.name, "hierarchy");
    assert_eq!(glb.nodes, gltf.nodes);
    assert_eq!(glb.meshes, gltf.meshes);
    assert_eq!(glb.materials, gltf.materials);
    assert_eq!(glb.images, gltf.images);
}

#[test]
fn imported_scene_spawns() {
    let scene = load("hierarchy.gltf");
    let mut world = World::new();
    scene.spawn(&mut world);
    let instances = world.query::<&MeshInstance>().iter(&world).count();
    assert_eq!(instances, 2 + 1 + 1, "two primitives on Child, one strip on each of two nodes");
}

#[test]
fn obj_cornell_box() {
    let scene = load("cornell_box.obj");
    assert_valid(&scene, "cornell_box.obj");
    assert_eq!(scene.name, "cornell_box");
    let names: Vec<&str> = scene.nodes.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["floor", "ceiling", "back_wall", "left_wall", "right_wall", "short_box", "tall_box", "light"]);
    assert!(scene.nodes.iter().all(|n| n.parent.is_none()));
    // 5 walls and the light are quads, each box has 5 quads.
    assert_eq!(scene.triangle_count(), 6 * 2 + 2 * 5 * 2);

    let kd = |name: &str| scene.materials[material(&scene, name)].base_color;
    assert_eq!(kd("red"), Vec4::new(0.63, 0.065, 0.05, 1.0));
    assert_eq!(kd("green"), Vec4::new(0.14, 0.45, 0.091, 1.0));
    assert_eq!(kd("white"), Vec4::new(0.725, 0.71, 0.68, 1.0));
    let light = &scene.materials[material(&scene, "light")];
    assert_eq!(light.emissive, Vec3::new(17.0, 12.0, 4.0));
    assert!(light.is_emissive());
    assert_eq!(scene.materials.iter().filter(|m| m.is_emissive()).count(), 1);

    let material_of = |node_name: &str| {
        let instances = mesh_instances(&scene, node(&scene, node_name));
        assert_eq!(instances.len(), 1);
        scene.materials[instances[0].1].name.clone()
    };
    assert_eq!(material_of("left_wall"), "red");
    assert_eq!(material_of("right_wall"), "green");
    assert_eq!(material_of("light"), "light");
    assert_eq!(material_of("tall_box"), "white");

    // Walls face the inside of the room, the light faces down.
    let normal_of = |node_name: &str| scene.meshes[mesh_instances(&scene, node(&scene, node_name))[0].0].normals[0];
    assert_near(normal_of("floor"), Vec3::Y, "floor normal");
    assert_near(normal_of("ceiling"), Vec3::NEG_Y, "ceiling normal");
    assert_near(normal_of("back_wall"), Vec3::NEG_Z, "back wall normal");
    assert_near(normal_of("right_wall"), Vec3::X, "right wall normal");
    assert_near(normal_of("light"), Vec3::NEG_Y, "light normal");
    let (lo, hi) = scene.bounds().expect("bounds");
    assert_near(lo, Vec3::ZERO, "lower bound");
    assert_near(hi, Vec3::new(0.556, 0.5488, 0.5592), "upper bound");
}

/// Every broken fixture, with a word its error message must contain.
const BROKEN: &[(&str, &str)] = &[
    ("truncated.glb", "truncated"),
    ("bad_header.glb", "smaller than the 12-byte header"),
    ("invalid_json.gltf", "invalid glTF JSON"),
    ("empty.gltf", "file is empty"),
    ("empty.obj", "file is empty"),
    ("unknown_extension.fbx", "unsupported file extension \".fbx\""),
    ("index_out_of_range.gltf", "index 999 out of range for 3 vertices"),
    ("nan_position.gltf", "vertex 1 has non-finite position (NaN, 0, 0)"),
    ("missing_buffer.gltf", "'does_not_exist.bin' not found"),
    ("short_buffer.gltf", "too short"),
    ("missing_texture.gltf", "texture image 'textures/missing.png' not found"),
    ("bad_image.gltf", "cannot decode image"),
    ("lines_mode.gltf", "unsupported primitive mode Lines"),
    ("node_cycle.gltf", "more than once"),
    ("bad_accessor_index.gltf", "refers to accessor 7"),
    ("accessor_out_of_bounds.gltf", "do not fit in buffer view"),
    ("huge_count.gltf", "exceeds the limit"),
    ("bad_face_index.obj", "line 7: f vertex index 9 out of range"),
    ("missing_mtl.obj", "material library 'does_not_exist.mtl' not found"),
    ("missing_texture.obj", "texture image 'textures/missing_diffuse.png' not found"),
    ("bad_color.obj", "line 2: 'Kd' needs 3 numbers"),
    // Hostile files (issue 8): non-finite values, counts that overflow, wrong magic, binary junk.
    ("infinite_translation.gltf", "node 0 'Tri': non-finite translation (inf, 0, 0)"),
    ("infinite_light.gltf", "light 0: invalid intensity inf"),
    ("infinite_emissive_strength.gltf", "material 0 'Blinding': invalid emissiveStrength inf"),
    ("bad_metallic.gltf", "material 0 'Metal': metallicFactor 2 is not between 0 and 1"),
    ("bad_base64.gltf", "invalid base64"),
    ("count_overflow.gltf", "4294967295 exceeds the limit"),
    ("wrong_magic.glb", "magic \"glTX\""),
    ("empty.glb", "file is empty"),
    ("inf_position.obj", "vertex 1 has non-finite position (inf, 0, 0)"),
    ("nan_normal.obj", "vertex 0 has non-finite normal (NaN, 0, 1)"),
    ("huge_index.obj", "line 5: f vertex index 4294967296 out of range"),
    ("negative_index.obj", "line 5: f vertex index -7 out of range"),
    ("binary_garbage.obj", "not UTF-8 text"),
];

#[test]
fn broken_files_name_the_file_and_the_problem() {
    let dir = fixtures().join("broken");
    for (name, detail) in BROKEN {
        let path = dir.join(name);
        assert!(path.exists(), "fixture {} is missing", path.display());
        let error = match load_scene(&path) {
            Ok(_) => panic!("{name} loaded, but it is broken"),
            Err(error) => error,
        };
        let message = error.to_string();
        assert!(message.contains(name), "{name}: message does not name the file: {message}");
        assert!(message.contains(detail), "{name}: message lacks {detail:?}: {message}");
        assert_eq!(error.file(), path.as_path());
    }
    // The resolved location of a missing reference is given too.
    let error = load_scene(&dir.join("missing_texture.gltf")).unwrap_err();
    assert!(
        matches!(&error, ImportError::MissingFile { resolved, .. } if resolved.is_absolute() && resolved.ends_with("textures/missing.png")),
        "{error:?}"
    );
    // A file that does not exist at all.
    let error = load_scene(&dir.join("no_such_file.gltf")).unwrap_err();
    assert!(matches!(error, ImportError::Io { .. }) && error.to_string().contains("no_such_file.gltf"), "{error}");
}

/// Loads `path` inside `catch_unwind`; fails the test on a panic.
fn load_without_panic(path: &Path) -> Result<SceneDescription, ImportError> {
    std::panic::catch_unwind(|| load_scene(path)).unwrap_or_else(|_| panic!("load_scene panicked on {}", path.display()))
}

#[test]
fn broken_files_never_panic() {
    let mut count = 0;
    for entry in std::fs::read_dir(fixtures().join("broken")).unwrap() {
        let path = entry.unwrap().path();
        // Companion files (.mtl) are rejected by extension; everything in the corpus fails.
        assert!(load_without_panic(&path).is_err(), "{} loaded", path.display());
        count += 1;
    }
    assert!(count >= BROKEN.len());
}

#[test]
fn every_truncation_of_a_valid_file_fails_cleanly() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("loaders-truncated-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, step) in [("hierarchy.glb", 7), ("hierarchy.gltf", 97), ("cornell_box.obj", 1)] {
        let bytes = std::fs::read(fixtures().join(name)).unwrap();
        let extension = Path::new(name).extension().unwrap();
        let path = dir.join("truncated").with_extension(extension);
        if extension == "obj" {
            std::fs::copy(fixtures().join("cornell_box.mtl"), dir.join("cornell_box.mtl")).unwrap();
        }
        for length in (0..bytes.len()).step_by(step) {
            std::fs::write(&path, &bytes[..length]).unwrap();
            let result = load_without_panic(&path);
            // A cut OBJ may still be a valid (smaller) OBJ; cut glTF/GLB files never are.
            if extension != "obj" {
                assert!(result.is_err(), "{name} cut to {length} bytes loaded");
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// glTF's metallic-roughness model with every texture kind (`tests/fixtures/pbr.gltf`, written by
/// `tools/make_pbr_fixture.py`): factors, KHR_materials_specular, the metallic-roughness, normal
/// (with its scale and KHR_texture_transform) and emissive textures, tangents from the file or
/// from MikkTSpace.
#[test]
fn gltf_pbr_materials_with_every_texture_kind() {
    let scene = load("pbr.gltf");
    assert_valid(&scene, "pbr.gltf");
    let metal = &scene.materials[material(&scene, "Metal")];
    assert_eq!((metal.metallic, metal.roughness, metal.specular, metal.normal_scale), (1.0, 0.4, 1.0, 0.8));
    let image_name = |t: Option<engine::scene::TextureRef>| scene.images[t.expect("texture").image.index() as usize].name.clone();
    assert_eq!(image_name(metal.base_color_texture), "color");
    assert_eq!(image_name(metal.metallic_roughness_texture), "metal_rough");
    assert_eq!(image_name(metal.normal_texture), "normal");
    assert_eq!(image_name(metal.emissive_texture), "emissive");
    let normal = metal.normal_texture.unwrap().transform;
    assert_eq!((normal.offset, normal.scale), (glam::Vec2::new(0.25, 0.5), glam::Vec2::splat(2.0)));
    // The images keep their bytes: the metallic-roughness texture is data (no colour decoding).
    assert_eq!(&scene.images[metal.metallic_roughness_texture.unwrap().image.index() as usize].rgba8[..4], &[0, 128, 255, 255]);
    let satin = &scene.materials[material(&scene, "Satin")];
    assert_eq!((satin.metallic, satin.roughness, satin.specular), (0.0, 0.7, 0.5));
    // Tangents: u runs along +x and v along −y, so MikkTSpace's tangent is +x and, glTF's bitangent
    // being w · cross(normal, tangent) = w · (+y), its handedness w is −1. The other quad's file
    // gives tangents of its own (turned 10°), kept as they are.
    let turned = Vec4::new(10f32.to_radians().cos(), 10f32.to_radians().sin(), 0.0, -1.0);
    for (node, expected) in [("MikkQuad", Vec4::new(1.0, 0.0, 0.0, -1.0)), ("TangentQuad", turned)] {
        let (mesh, _) = mesh_instances(&scene, self::node(&scene, node))[0];
        let tangents = &scene.meshes[mesh].tangents;
        assert_eq!(tangents.len(), 4, "{node}");
        for t in tangents {
            assert!((*t - expected).length() < 1e-4, "{node}: tangent {t}, expected {expected}");
        }
    }
    // A material without a normal map gets no tangents computed (hierarchy.gltf).
    let plain = load("hierarchy.gltf");
    assert!(plain.meshes.iter().all(|m| m.tangents.is_empty()));
}

/// The MTL PBR extension (`Pm` metallic, `Pr` roughness) in the glossy Cornell box the Mitsuba
/// check uses: its metals get glTF's specular lobe, its walls stay Lambertian.
#[test]
fn obj_metals_from_the_mtl_pbr_extension() {
    let scene = load("cornell_box_glossy.obj");
    let get = |name: &str| &scene.materials[material(&scene, name)];
    let (silver, gold, white) = (get("silver"), get("gold"), get("white"));
    assert_eq!((silver.metallic, silver.roughness, silver.specular), (1.0, 0.35, 1.0));
    assert_eq!((gold.metallic, gold.roughness), (1.0, 0.2));
    assert_eq!((white.metallic, white.roughness, white.specular), (0.0, 1.0, 0.0), "no Pm/Pr: Lambertian");
}

#[test]
fn kenney_models() {
    // Kenney's CC0 models in the shared folder beside the checkout (the repository holds none).
    let Some(dir) = testkit::shared("kenney_models", scenes::shared::KENNEY_FPS) else { return };
    let mut models: Vec<PathBuf> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|e| e == "glb")).collect();
    models.sort();
    assert!(!models.is_empty(), "no .glb files in {}", dir.display());
    for path in &models {
        let scene = load_scene(path).unwrap_or_else(|e| panic!("{e}"));
        let name = path.display();
        assert_valid(&scene, &name.to_string());
        // Kenney's materials: glTF dielectrics (metallic 0, roughness left at its default of 1),
        // with glTF's specular lobe and no data textures.
        for m in &scene.materials {
            assert_eq!((m.metallic, m.roughness, m.specular), (0.0, 1.0, 1.0), "{name}: {}", m.name);
            assert!(m.metallic_roughness_texture.is_none() && m.normal_texture.is_none(), "{name}: {}", m.name);
        }
        assert!(scene.triangle_count() > 0, "{name}: no triangles");
        assert!(!scene.nodes.is_empty(), "{name}: no nodes");
        let textures: Vec<_> = scene.materials.iter().filter_map(|m| m.base_color_texture).collect();
        assert!(!textures.is_empty(), "{name}: no base colour texture");
        for texture in textures {
            // The files carry KHR_texture_transform with only a texCoord: the identity transform.
            assert_eq!(texture.transform, UvTransform::default(), "{name}");
            let image = &scene.images[texture.image.index() as usize];
            assert_eq!(image.name, "colormap", "{name}: Textures/colormap.png");
            assert!(image.width > 0 && image.height > 0, "{name}: empty image");
            assert_eq!(image.rgba8.len(), (image.width * image.height * 4) as usize, "{name}");
        }
        assert_eq!(scene.images.len(), 1, "{name}: the shared colormap is decoded once");
    }
}

#[test]
fn loading_from_bytes_matches_loading_the_file() {
    for name in ["hierarchy.gltf", "hierarchy.glb", "cornell_box.obj"] {
        let path = fixtures().join(name);
        let bytes = std::fs::read(&path).unwrap();
        let from_bytes = engine::import::load_scene_from_bytes(&path, &bytes).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(from_bytes, load(name), "{name}");
    }
    // Referenced files are resolved from the path given: elsewhere, they are missing (by name).
    let bytes = std::fs::read(fixtures().join("cornell_box.obj")).unwrap();
    let error = engine::import::load_scene_from_bytes(Path::new("/nonexistent/cornell_box.obj"), &bytes).unwrap_err();
    assert!(matches!(error, ImportError::MissingFile { .. }) && error.to_string().contains("cornell_box.mtl"), "{error}");
}

#[test]
fn scene_validation_names_the_item_field_and_value() {
    let mut scene = load("hierarchy.gltf");
    assert_eq!(scene.validate(), Ok(()));
    let light = node(&scene, "PointLight");
    scene.nodes[light].content =
        vec![NodeContent::PointLight(PointLight { color: Vec3::new(1.0, f32::NAN, 1.0), intensity: 1.0, range: None })];
    let message = scene.validate().unwrap_err().to_string();
    assert!(message.contains("'PointLight'") && message.contains("color") && message.contains("NaN"), "{message}");

    let mut scene = load("hierarchy.gltf");
    scene.materials[0].emissive_strength = f32::INFINITY;
    let message = scene.validate().unwrap_err().to_string();
    assert!(message.contains(&scene.materials[0].name) && message.contains("emissive_strength = inf"), "{message}");

    let mut scene = load("hierarchy.gltf");
    scene.nodes[0].transform.scale = Vec3::new(1.0, f32::NEG_INFINITY, 1.0);
    let message = scene.validate().unwrap_err().to_string();
    assert!(message.contains("'Parent'") && message.contains("transform.scale") && message.contains("-inf"), "{message}");

    let mut scene = load("hierarchy.gltf");
    scene.meshes[1].normals[0] = Vec3::new(f32::NAN, 0.0, 1.0);
    let message = scene.validate().unwrap_err().to_string();
    assert!(message.contains("mesh 1") && message.contains("normals[0]") && message.contains("NaN"), "{message}");
}

#[test]
fn a_failed_load_leaves_the_previous_scene_intact() {
    use engine::import::{SceneLoadError, load_scene_into};
    use engine::scene::{Name, SceneRoot};
    let mut world = World::new();
    let names = |world: &mut World| {
        let mut v: Vec<String> = world.query::<&Name>().iter(world).map(|n| n.0.clone()).collect();
        v.sort();
        v
    };
    let first = load_scene_into(&mut world, &fixtures().join("hierarchy.gltf")).expect("loads");
    let before = names(&mut world);
    assert!(before.contains(&"Parent".to_string()));
    // Every broken file: an error, and the world exactly as it was.
    for (name, _) in BROKEN {
        let path = fixtures().join("broken").join(name);
        let error = load_scene_into(&mut world, &path).expect_err(name);
        assert!(error.to_string().contains(name), "{error}");
        assert_eq!(names(&mut world), before, "{name} changed the world");
        assert!(world.get_entity(first).is_ok(), "{name} removed the scene");
    }
    // A file that imports but holds data the renderer cannot take is refused too.
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("loaders-into-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let camera = dir.join("nan_camera.gltf");
    let text = std::fs::read_to_string(fixtures().join("hierarchy.gltf")).unwrap();
    assert!(text.contains("\"yfov\": 0.8"));
    std::fs::write(&camera, text.replace("\"yfov\": 0.8", "\"yfov\": 1e39")).unwrap();
    let error = load_scene_into(&mut world, &camera).expect_err("infinite field of view");
    assert!(matches!(error, SceneLoadError::Import(_) | SceneLoadError::Data { .. }), "{error:?}");
    assert!(error.to_string().contains("nan_camera.gltf") && error.to_string().contains("inf"), "{error}");
    assert_eq!(names(&mut world), before);
    std::fs::remove_dir_all(&dir).ok();
    // A good file replaces the scene: one root, the new one.
    let second = load_scene_into(&mut world, &fixtures().join("cornell_box.obj")).expect("loads");
    assert!(world.get_entity(first).is_err(), "the old scene is gone");
    let roots: Vec<String> = world.query::<&SceneRoot>().iter(&world).map(|r| r.name.clone()).collect();
    assert_eq!(roots, ["cornell_box"]);
    assert!(world.get_entity(second).is_ok());
}

/// OBJ's `d` (dissolve) and `Tr` (one minus it) set the alpha; a material that is see-through is
/// BLEND (cut below 0.5), an opaque one stays opaque, and a `Tr` out of range is named.
#[test]
fn obj_dissolve_and_transparency_set_the_alpha_mode() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("obj_alpha");
    std::fs::create_dir_all(&dir).unwrap();
    let mtl = "newmtl glass\nKd 1 1 1\nd 0.3\n\nnewmtl leaf\nKd 0 1 0\nTr 0.1\n\nnewmtl stone\nKd 0.5 0.5 0.5\n";
    std::fs::write(dir.join("alpha.mtl"), mtl).unwrap();
    let mut obj = String::from("mtllib alpha.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for m in ["glass", "leaf", "stone"] {
        obj += &format!("usemtl {m}\nf 1 2 3\n");
    }
    std::fs::write(dir.join("alpha.obj"), &obj).unwrap();
    let scene = load_scene(&dir.join("alpha.obj")).unwrap_or_else(|e| panic!("{e}"));
    let get = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"));
    assert_eq!((get("glass").alpha_mode, get("glass").base_color.w), (AlphaMode::Blend, 0.3));
    assert_eq!(get("leaf").alpha_mode, AlphaMode::Blend);
    assert!((get("leaf").base_color.w - 0.9).abs() < 1e-6);
    assert_eq!((get("stone").alpha_mode, get("stone").base_color.w), (AlphaMode::Opaque, 1.0));
    std::fs::write(dir.join("alpha.mtl"), "newmtl glass\nTr 2\n").unwrap();
    std::fs::write(dir.join("alpha.obj"), "mtllib alpha.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl glass\nf 1 2 3\n").unwrap();
    let error = load_scene(&dir.join("alpha.obj")).expect_err("Tr 2 is refused").to_string();
    assert!(error.contains("Tr") && error.contains("glass") && error.contains("alpha.obj"), "{error}");
}

/// MTL glass (`illum` 4, 6, 7 or 9) is an opening: BLEND at alpha 0, cut from every ray; `d` and
/// `Tr` give the alpha of other materials; a plain material stays opaque.
#[test]
fn obj_glass_is_an_opening_and_dissolve_is_alpha() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("obj_glass");
    std::fs::create_dir_all(&dir).unwrap();
    let mtl = "newmtl window\nKd 0 0 0\nTf 0.5 0.5 0.5\nillum 6\n\nnewmtl stained\nKd 0 0 0\nTf 0.1 0.6 0.1\nillum 4\n\n\
               newmtl pane\nKd 0.4 0.1 0\nd 0.8\nillum 2\n\nnewmtl veil\nKd 1 1 1\nTr 0.75\n\nnewmtl stone\nKd 0.7 0.7 0.6\nTf 1 1 1\nillum 2\n";
    std::fs::write(dir.join("glass.mtl"), mtl).unwrap();
    let mut obj = String::from("mtllib glass.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for m in ["window", "stained", "pane", "veil", "stone"] {
        obj.push_str(&format!("usemtl {m}\nf 1 2 3\n"));
    }
    std::fs::write(dir.join("glass.obj"), obj).unwrap();
    let scene = load_scene(&dir.join("glass.obj")).unwrap_or_else(|e| panic!("{e}"));
    let get = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"));
    for (name, mode, alpha) in [
        ("window", AlphaMode::Blend, 0.0),
        ("stained", AlphaMode::Blend, 0.0),
        ("pane", AlphaMode::Blend, 0.8),
        ("veil", AlphaMode::Blend, 0.25),
        ("stone", AlphaMode::Opaque, 1.0),
    ] {
        assert_eq!(get(name).alpha_mode, mode, "{name}");
        assert!((get(name).base_color.w - alpha).abs() < 1e-6, "{name}: alpha {}", get(name).base_color.w);
    }
}

/// OBJ's `map_d`: the mask's alpha (its grey level when it has no alpha channel, its alpha channel
/// when it has one) is baked into the base colour texture at `map_Kd`'s resolution, the colours
/// kept; a mask without `map_Kd` gives a white texture of the mask's size; the material is cut
/// (BLEND); a missing mask is named.
#[test]
fn obj_map_d_cuts_the_base_colour_texture() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("obj_map_d");
    std::fs::create_dir_all(&dir).unwrap();
    // A 4×4 red-green gradient and a 2×2 grey checkerboard mask (no alpha channel).
    let color = image::RgbImage::from_fn(4, 4, |x, y| image::Rgb([60 * x as u8, 60 * y as u8, 7]));
    color.save(dir.join("leaf.png")).unwrap();
    let grey = image::GrayImage::from_fn(2, 2, |x, y| image::Luma([if (x + y) % 2 == 0 { 255 } else { 0 }]));
    grey.save(dir.join("mask.png")).unwrap();
    // A mask with an alpha channel: its alpha counts, not its (white) colour.
    let rgba = image::RgbaImage::from_fn(2, 1, |x, _| image::Rgba([255, 255, 255, if x == 0 { 0 } else { 200 }]));
    rgba.save(dir.join("alpha_mask.png")).unwrap();
    let mtl = "newmtl leaf\nKd 1 1 1\nmap_Kd leaf.png\nmap_d mask.png\n\nnewmtl fence\nKd 1 1 1\nmap_d -imfchan l alpha_mask.png\n";
    std::fs::write(dir.join("masked.mtl"), mtl).unwrap();
    let obj =
        "mtllib masked.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl leaf\nf 1/1 2/2 3/3\nusemtl fence\nf 1/1 2/2 3/3\n";
    std::fs::write(dir.join("masked.obj"), obj).unwrap();
    let scene = load_scene(&dir.join("masked.obj")).unwrap_or_else(|e| panic!("{e}"));
    let get = |name: &str| scene.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("no material {name}"));
    let texture = |name: &str| &scene.images[get(name).base_color_texture.as_ref().expect("a base colour texture").image.index() as usize];

    assert_eq!(get("leaf").alpha_mode, AlphaMode::Blend);
    let leaf = texture("leaf");
    assert_eq!((leaf.width, leaf.height), (4, 4), "map_Kd's resolution");
    for y in 0..4u32 {
        for x in 0..4u32 {
            let t = &leaf.rgba8[4 * (y * 4 + x) as usize..][..4];
            let expected_alpha = if (x / 2 + y / 2) % 2 == 0 { 255 } else { 0 };
            assert_eq!(t, [60 * x as u8, 60 * y as u8, 7, expected_alpha], "texel ({x}, {y})");
        }
    }
    assert_eq!(get("fence").alpha_mode, AlphaMode::Blend);
    let fence = texture("fence");
    assert_eq!((fence.width, fence.height), (2, 1));
    assert_eq!(fence.rgba8, [255, 255, 255, 0, 255, 255, 255, 200]);

    std::fs::write(dir.join("masked.mtl"), "newmtl leaf\nmap_d missing_mask.png\n").unwrap();
    std::fs::write(dir.join("masked.obj"), "mtllib masked.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl leaf\nf 1 2 3\n").unwrap();
    let error = load_scene(&dir.join("masked.obj")).expect_err("a missing mask is refused").to_string();
    assert!(error.contains("missing_mask.png") && error.contains("masked.obj"), "{error}");
}

// ---------------------------------------------------------------------------------------------
// Every importer path a real file uses (issue 46): small files written here, and the shared
// folder's externally authored scenes where they carry the feature (skipped without it).

/// A glTF file a test writes: an external `.bin` buffer with one buffer view per accessor, and the
/// JSON of its views and accessors.
#[derive(Default)]
struct GltfWriter {
    bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl GltfWriter {
    /// Appends `bytes` as a buffer view (4-byte aligned, with `byteStride` when given) and returns
    /// its index.
    fn view(&mut self, bytes: &[u8], stride: Option<usize>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let stride = stride.map_or(String::new(), |s| format!(r#", "byteStride": {s}"#));
        self.views.push(format!(r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}{stride}}}"#, self.bin.len(), bytes.len()));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    /// Adds an accessor (`extra`: more JSON members, each with its leading comma) and returns its index.
    fn accessor(&mut self, view: Option<usize>, component_type: u32, count: usize, kind: &str, extra: &str) -> usize {
        let view = view.map_or(String::new(), |v| format!(r#""bufferView": {v}, "#));
        self.accessors.push(format!(r#"{{{view}"componentType": {component_type}, "count": {count}, "type": "{kind}"{extra}}}"#));
        self.accessors.len() - 1
    }

    /// A FLOAT accessor of `kind` over a new view of `values`.
    fn floats(&mut self, values: &[f32], components: usize, kind: &str) -> usize {
        let view = self.view(&f32_bytes(values), None);
        self.accessor(Some(view), FLOAT, values.len() / components, kind, "")
    }

    /// A POSITION accessor (with the `min` and `max` glTF requires).
    fn positions(&mut self, positions: &[Vec3]) -> usize {
        let (lo, hi) = positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let values: Vec<f32> = positions.iter().flat_map(|p| p.to_array()).collect();
        let view = self.view(&f32_bytes(&values), None);
        let bounds = format!(r#", "min": [{}, {}, {}], "max": [{}, {}, {}]"#, lo.x, lo.y, lo.z, hi.x, hi.y, hi.z);
        self.accessor(Some(view), FLOAT, positions.len(), "VEC3", &bounds)
    }

    /// Writes `dir/name.gltf` (`body`: the JSON members other than the asset, views, accessors and
    /// buffers) and `dir/name.bin`, and returns the `.gltf`'s path.
    fn write(&self, dir: &Path, name: &str, body: &str) -> PathBuf {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join(format!("{name}.bin")), &self.bin).unwrap();
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, {body}, "bufferViews": [{}], "accessors": [{}],
            "buffers": [{{"byteLength": {}, "uri": "{name}.bin"}}]}}"#,
            self.views.join(", "),
            self.accessors.join(", "),
            self.bin.len()
        );
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, json).unwrap();
        path
    }
}

/// glTF's component types.
const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A folder of this test binary's temporary files.
fn temp_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("loaders-{name}-{}", std::process::id()))
}

/// The one triangle of most written files: (0,0,0), (1,0,0), (0,1,0), facing +z.
const TRIANGLE: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

/// The meshes a node draws, as (mesh, material) pairs, by the node's name.
fn drawn(scene: &SceneDescription, node_name: &str) -> Vec<(usize, usize)> {
    mesh_instances(scene, node(scene, node_name))
}

/// Reads the dense FLOAT VEC2 accessor `index` of a glTF file beside its `.bin` buffers (an oracle
/// independent of the importer).
fn read_vec2_accessor(gltf: &Path, index: usize) -> Vec<Vec2> {
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(gltf).unwrap()).unwrap();
    let accessor = &json["accessors"][index];
    assert_eq!((accessor["componentType"].as_u64(), accessor["type"].as_str()), (Some(5126), Some("VEC2")));
    assert!(accessor.get("sparse").is_none());
    let view = &json["bufferViews"][accessor["bufferView"].as_u64().unwrap() as usize];
    let buffer = &json["buffers"][view["buffer"].as_u64().unwrap() as usize];
    let bytes = std::fs::read(gltf.parent().unwrap().join(buffer["uri"].as_str().unwrap())).unwrap();
    let stride = view.get("byteStride").and_then(|s| s.as_u64()).unwrap_or(8) as usize;
    let start = view.get("byteOffset").and_then(|o| o.as_u64()).unwrap_or(0) as usize
        + accessor.get("byteOffset").and_then(|o| o.as_u64()).unwrap_or(0) as usize;
    let f = |at: usize| f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap());
    (0..accessor["count"].as_u64().unwrap() as usize).map(|i| Vec2::new(f(start + i * stride), f(start + i * stride + 4))).collect()
}

/// Khronos' MorphStressTest: its material `Base` samples the base colour with TEXCOORD_0 and the
/// occlusion (which the engine has no slot for) with TEXCOORD_1; the mesh gets TEXCOORD_0's values.
#[test]
fn morph_stress_test_gets_the_set_its_base_colour_samples() {
    let Some(path) = testkit::shared("morph_stress_test", "scenes/morph-stress-test/MorphStressTest.gltf") else { return };
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "MorphStressTest.gltf");
    let base = material(&scene, "Base");
    let texture = scene.materials[base].base_color_texture.expect("Base's base colour texture");
    assert_eq!(scene.images[texture.image.index() as usize].name, "TinyGrid");
    let (mesh, _) = scene
        .nodes
        .iter()
        .enumerate()
        .flat_map(|(i, _)| mesh_instances(&scene, i))
        .find(|&(_, m)| m == base)
        .expect("a mesh drawn with Base");
    // meshes[0].primitives[0]: TEXCOORD_0 is accessor 2, TEXCOORD_1 accessor 3.
    let (set0, set1) = (read_vec2_accessor(&path, 2), read_vec2_accessor(&path, 3));
    assert_ne!(set0, set1, "the file's two sets differ, so the test can tell them apart");
    assert_eq!(scene.meshes[mesh].uvs, set0);
}

/// A primitive's `uvs` come from the set its material's textures sample: `texCoord` 1, or
/// KHR_texture_transform's `texCoord` override; an occlusion texture does not count; a set the
/// primitive lacks leaves it without texture coordinates (and a warning).
#[test]
fn gltf_uvs_come_from_the_set_the_textures_sample() {
    let dir = temp_dir("uv-sets");
    std::fs::create_dir_all(&dir).unwrap();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 100, 50, 255])).save(dir.join("grid.png")).unwrap();
    let set0 = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
    let set1 = [Vec2::new(0.25, 0.5), Vec2::new(0.75, 0.5), Vec2::new(0.5, 1.0)];
    let mut w = GltfWriter::default();
    let position = w.positions(&TRIANGLE);
    let uv0 = w.floats(&set0.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>(), 2, "VEC2");
    let uv1 = w.floats(&set1.iter().flat_map(|v| v.to_array()).collect::<Vec<_>>(), 2, "VEC2");
    let names = ["SecondSet", "Override", "FirstSet", "MissingSet"];
    let meshes: Vec<String> = (0..names.len())
        .map(|m| format!(r#"{{"primitives": [{{"attributes": {{"POSITION": {position}, "TEXCOORD_0": {uv0}, "TEXCOORD_1": {uv1}}}, "material": {m}}}]}}"#))
        .collect();
    let nodes: Vec<String> = names.iter().enumerate().map(|(m, name)| format!(r#"{{"name": "{name}", "mesh": {m}}}"#)).collect();
    let body = format!(
        r#""extensionsUsed": ["KHR_texture_transform"],
        "nodes": [{}], "meshes": [{}],
        "materials": [
            {{"name": "SecondSet", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0, "texCoord": 1}}}}}},
            {{"name": "Override", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0,
                "extensions": {{"KHR_texture_transform": {{"texCoord": 1}}}}}}}}}},
            {{"name": "FirstSet", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}},
                "occlusionTexture": {{"index": 0, "texCoord": 1}}}},
            {{"name": "MissingSet", "emissiveFactor": [1, 1, 1], "emissiveTexture": {{"index": 0, "texCoord": 2}}}}],
        "textures": [{{"source": 0}}], "images": [{{"uri": "grid.png"}}]"#,
        nodes.join(", "),
        meshes.join(", ")
    );
    let path = w.write(&dir, "uv_sets", &body);
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "uv_sets.gltf");
    let uvs = |name: &str| scene.meshes[drawn(&scene, name)[0].0].uvs.clone();
    assert_eq!(uvs("SecondSet"), set1, "baseColorTexture.texCoord 1");
    assert_eq!(uvs("Override"), set1, "KHR_texture_transform's texCoord 1");
    assert_eq!(uvs("FirstSet"), set0, "the occlusion texture's set does not count");
    assert!(uvs("MissingSet").is_empty(), "TEXCOORD_2 is not in the primitive");
    // The texture itself is imported whichever set it samples.
    for name in names {
        let m = &scene.materials[material(&scene, name)];
        assert!(m.base_color_texture.or(m.emissive_texture).is_some(), "{name}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Checks computed normals: every one is finite and of unit length, and
/// the normals at a triangle's corners agree with the triangle's winding (the mean of their dot
/// products with its unit face normal is above `min_mean`). Degenerate triangles are left out.
fn assert_normals_follow_the_winding(scene: &SceneDescription, file: &str, min_mean: f32) {
    let (mut sum, mut corners) = (0.0f64, 0usize);
    for mesh in &scene.meshes {
        for n in &mesh.normals {
            assert!(n.is_finite() && (n.length() - 1.0).abs() < 1e-4, "{file} {}: normal {n}", mesh.name);
        }
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
            let Some(face) = (b - a).cross(c - a).try_normalize() else { continue };
            for &i in tri {
                sum += f64::from(mesh.normals[i as usize].dot(face));
                corners += 1;
            }
        }
    }
    assert!(corners > 0, "{file}: no triangles");
    let mean = sum / corners as f64;
    assert!(mean > f64::from(min_mean), "{file}: mean dot of vertex and face normals {mean}");
}

/// Files without normals get them computed: Khronos' Fox (centimetre scale, not indexed) and
/// SimpleSkin (an indexed flat strip).
#[test]
fn files_without_normals_get_unit_normals_that_follow_the_winding() {
    if let Some(path) = testkit::shared("fox_normals", "scenes/fox/Fox.glb") {
        let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_valid(&scene, "Fox.glb");
        assert_eq!(scene.triangle_count(), 576);
        // Centimetres, as the file is: the fox is about 79 units tall, not rescaled.
        let (lo, hi) = scene.meshes[0].bounds().expect("geometry");
        assert!((hi.y - lo.y - 79.03).abs() < 0.1, "height {}", hi.y - lo.y);
        // Not indexed: each corner's normal is its triangle's own.
        assert_normals_follow_the_winding(&scene, "Fox.glb", 0.999);
        let texture = scene.materials[material(&scene, "fox_material")].base_color_texture.expect("base colour texture");
        assert!(scene.images[texture.image.index() as usize].width > 0);
        assert_eq!(scene.meshes[0].uvs.len(), scene.meshes[0].positions.len());
    }
    if let Some(path) = testkit::shared("simple_skin_normals", "scenes/simple-skin/SimpleSkin.gltf") {
        let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_valid(&scene, "SimpleSkin.gltf");
        assert_eq!(scene.triangle_count(), 8);
        assert_normals_follow_the_winding(&scene, "SimpleSkin.gltf", 0.9);
    }
}

/// Khronos' FlightHelmet: external PNG textures (base colour, normal, occlusion-roughness-metal;
/// 512² but one) on six materials, the file's tangents for its normal maps, blended lenses.
#[test]
fn flight_helmet_resolves_its_external_png_textures() {
    let Some(path) = testkit::shared("flight_helmet", "scenes/flight-helmet/FlightHelmet.gltf") else { return };
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "FlightHelmet.gltf");
    assert_eq!(scene.triangle_count(), 94_722);
    // Six materials (the hose and the rubber-wood parts share one texture set), five texture sets.
    assert_eq!(scene.materials.len(), 6);
    assert_eq!(scene.images.len(), 15, "every PNG decoded once");
    for image in &scene.images {
        // Every texture is 512², but the lenses' flat normal map, which is 32².
        let side = if image.name == "FlightHelmet_Materials_LensesMat_Normal.png" { 32 } else { 512 };
        assert_eq!((image.width, image.height), (side, side), "{}", image.name);
        assert_eq!(image.rgba8.len(), (side * side * 4) as usize, "{}", image.name);
    }
    let image_name = |t: Option<engine::scene::TextureRef>| scene.images[t.expect("texture").image.index() as usize].name.clone();
    for m in &scene.materials {
        let set = match m.name.as_str() {
            "HoseMat" => "RubberWoodMat",
            name => name,
        };
        assert_eq!(image_name(m.base_color_texture), format!("FlightHelmet_Materials_{set}_BaseColor.png"), "{}", m.name);
        assert_eq!(image_name(m.normal_texture), format!("FlightHelmet_Materials_{set}_Normal.png"), "{}", m.name);
        assert_eq!(image_name(m.metallic_roughness_texture), format!("FlightHelmet_Materials_{set}_OcclusionRoughMetal.png"), "{}", m.name);
        let expected = if m.name == "LensesMat" { AlphaMode::Blend } else { AlphaMode::Opaque };
        assert_eq!(m.alpha_mode, expected, "{}", m.name);
    }
    for (i, node) in scene.nodes.iter().enumerate() {
        for (mesh, _) in mesh_instances(&scene, i) {
            let mesh = &scene.meshes[mesh];
            assert_eq!(mesh.tangents.len(), mesh.positions.len(), "{}: tangents for its normal map", node.name);
            assert_eq!(mesh.uvs.len(), mesh.positions.len(), "{}", node.name);
        }
    }
}

/// Šibenik's MTL: every `map_Kd` resolves to its PNG (three, each decoded once); its `bump` and
/// `map_bump` statements are ignored without an error (no normal maps, the bump PNGs not decoded).
#[test]
fn sibenik_mtl_textures_resolve_and_bump_maps_are_ignored() {
    let Some(path) = testkit::shared("sibenik_mtl", "scenes/sibenik/sibenik.obj") else { return };
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let mut names: Vec<&str> = scene.images.iter().map(|i| i.name.as_str()).collect();
    names.sort_unstable();
    assert_eq!(names, ["KAMEN-stup.png", "kamen.png", "mramor6x6.png"]);
    let textured = ["kamen_zid", "stupovi", "pod", "pod_rub", "kamen_zid_prozor", "zid_vani", "kamen_zid_parapet", "rozeta"];
    for m in &scene.materials {
        assert_eq!(m.base_color_texture.is_some(), textured.contains(&m.name.as_str()), "{}", m.name);
        assert!(m.normal_texture.is_none(), "{}: bump maps are not imported", m.name);
    }
}

/// Vertex colours (COLOR_0) become a factor of the material's base colour: one colour exactly,
/// varying ones by their mean over the surface; white ones leave the material as it is.
#[test]
fn gltf_vertex_colours_multiply_the_base_colour() {
    let mut w = GltfWriter::default();
    let position = w.positions(&TRIANGLE);
    let repeat = |values: &[f32]| -> Vec<f32> { values.iter().copied().cycle().take(values.len() * 3).collect() };
    let float3 = w.floats(&repeat(&[0.5, 0.25, 1.0]), 3, "VEC3");
    let float4 = w.floats(&repeat(&[1.0, 0.5, 0.5, 0.5]), 4, "VEC4");
    let bytes4 = {
        let view = w.view(&[255, 128, 0, 255].repeat(3), None);
        w.accessor(Some(view), UNSIGNED_BYTE, 3, "VEC4", r#", "normalized": true"#)
    };
    let shorts3 = {
        // VEC3 of 16 bits: 6 bytes, padded to a stride of 8 (vertex attributes are 4-byte aligned).
        let element: Vec<u8> = [65535u16, 32768, 0, 0].iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = w.view(&element.repeat(3), Some(8));
        w.accessor(Some(view), UNSIGNED_SHORT, 3, "VEC3", r#", "normalized": true"#)
    };
    let white = w.floats(&repeat(&[1.0, 1.0, 1.0]), 3, "VEC3");
    // Two triangles, red (area 0.5) and blue (area 1.5): the mean is a quarter red, three quarters blue.
    let pair = w.positions(&[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(0.0, 0.0, 1.0), Vec3::new(3.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0)]);
    let varying = w.floats(&[[1.0, 0.0, 0.0].repeat(3), [0.0, 0.0, 1.0].repeat(3)].concat(), 3, "VEC3");
    let cases = [("Float3", float3), ("Float4", float4), ("Bytes4", bytes4), ("Shorts3", shorts3), ("White", white)];
    let mut meshes: Vec<String> = cases
        .iter()
        .map(|(_, color)| format!(r#"{{"primitives": [{{"attributes": {{"POSITION": {position}, "COLOR_0": {color}}}, "material": 0}}]}}"#))
        .collect();
    meshes.push(format!(r#"{{"primitives": [{{"attributes": {{"POSITION": {pair}, "COLOR_0": {varying}}}, "material": 0}}]}}"#));
    meshes.push(format!(r#"{{"primitives": [{{"attributes": {{"POSITION": {position}}}, "material": 0}}]}}"#));
    meshes.push(format!(r#"{{"primitives": [{{"attributes": {{"POSITION": {position}, "COLOR_0": {float3}}}}}]}}"#));
    let names: Vec<&str> = cases.iter().map(|(n, _)| *n).chain(["Varying", "Plain", "DefaultMaterial"]).collect();
    let nodes: Vec<String> = names.iter().enumerate().map(|(m, name)| format!(r#"{{"name": "{name}", "mesh": {m}}}"#)).collect();
    let body = format!(
        r#""nodes": [{}], "meshes": [{}],
        "materials": [{{"name": "Paint", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.6, 0.4, 1.0]}}}}]"#,
        nodes.join(", "),
        meshes.join(", ")
    );
    let path = w.write(&temp_dir("vertex-colours"), "colours", &body);
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "colours.gltf");
    let base_color = |name: &str| scene.materials[drawn(&scene, name)[0].1].base_color;
    let paint = Vec4::new(0.8, 0.6, 0.4, 1.0);
    let expected = [
        ("Float3", paint * Vec4::new(0.5, 0.25, 1.0, 1.0)),
        ("Float4", paint * Vec4::new(1.0, 0.5, 0.5, 0.5)),
        ("Bytes4", paint * Vec4::new(1.0, 128.0 / 255.0, 0.0, 1.0)),
        ("Shorts3", paint * Vec4::new(1.0, 32768.0 / 65535.0, 0.0, 1.0)),
        ("Varying", paint * Vec4::new(0.25, 0.0, 0.75, 1.0)),
        ("White", paint),
        ("Plain", paint),
        ("DefaultMaterial", Vec4::new(0.5, 0.25, 1.0, 1.0)),
    ];
    for (name, color) in expected {
        assert!(base_color(name).abs_diff_eq(color, 1e-6), "{name}: base colour {} != {color}", base_color(name));
    }
    // White vertex colours draw with the material itself; the same colour shares one copy.
    assert_eq!(drawn(&scene, "White")[0].1, drawn(&scene, "Plain")[0].1);
    assert_eq!(scene.materials[drawn(&scene, "Plain")[0].1].name, "Paint");
    assert_ne!(drawn(&scene, "Float3")[0].1, drawn(&scene, "Plain")[0].1);
    // The copy keeps the rest of the material.
    let float3 = &scene.materials[drawn(&scene, "Float3")[0].1];
    assert!(float3.name.starts_with("Paint"), "{}", float3.name);
    // The geometry is the same with or without colours.
    assert_eq!(scene.meshes[drawn(&scene, "Float3")[0].0].positions, TRIANGLE);
}

/// A vertex colour that is negative, or of a type glTF does not allow, is refused by name.
#[test]
fn gltf_bad_vertex_colours_are_refused_by_name() {
    for (name, component_type, kind, bytes, detail) in [
        ("negative_colour", FLOAT, "VEC3", f32_bytes(&[0.5, -1.0, 0.0].repeat(3)), "vertex 0 has an invalid colour (0.5, -1, 0, 1)"),
        ("int_colour", UNSIGNED_BYTE, "VEC3", [255u8, 0, 0, 0].repeat(3), "unsupported element type"),
        ("scalar_colour", FLOAT, "SCALAR", f32_bytes(&[1.0; 3]), "unsupported element type"),
    ] {
        let mut w = GltfWriter::default();
        let position = w.positions(&TRIANGLE);
        let stride = (component_type == UNSIGNED_BYTE).then_some(4);
        let view = w.view(&bytes, stride);
        let color = w.accessor(Some(view), component_type, 3, kind, "");
        let body = format!(
            r#""nodes": [{{"mesh": 0}}], "meshes": [{{"name": "Painted", "primitives": [{{"attributes": {{"POSITION": {position}, "COLOR_0": {color}}}}}]}}]"#
        );
        let path = w.write(&temp_dir("bad-colours"), name, &body);
        let message = load_scene(&path).expect_err(name).to_string();
        assert!(message.contains(&format!("{name}.gltf")), "{message}");
        assert!(message.contains("mesh 'Painted' primitive 0 COLOR_0") && message.contains(detail), "{message}");
    }
}

/// Index buffers of 8, 16 and 32 bits give the same triangles.
#[test]
fn gltf_index_buffers_of_8_16_and_32_bits_give_the_same_triangles() {
    let mut w = GltfWriter::default();
    let position = w.positions(&[Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)]);
    let quad: [u32; 6] = [0, 1, 2, 2, 1, 3];
    let bytes: Vec<u8> = quad.iter().map(|&i| i as u8).collect();
    let shorts: Vec<u8> = quad.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect();
    let ints: Vec<u8> = quad.iter().flat_map(|i| i.to_le_bytes()).collect();
    let mut meshes = Vec::new();
    for (component_type, data) in [(UNSIGNED_BYTE, bytes), (UNSIGNED_SHORT, shorts), (UNSIGNED_INT, ints)] {
        let view = w.view(&data, None);
        let indices = w.accessor(Some(view), component_type, 6, "SCALAR", "");
        meshes.push(format!(r#"{{"primitives": [{{"attributes": {{"POSITION": {position}}}, "indices": {indices}}}]}}"#));
    }
    let body = format!(
        r#""nodes": [{{"name": "U8", "mesh": 0}}, {{"name": "U16", "mesh": 1}}, {{"name": "U32", "mesh": 2}}], "meshes": [{}]"#,
        meshes.join(", ")
    );
    let path = w.write(&temp_dir("indices"), "indices", &body);
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "indices.gltf");
    for name in ["U8", "U16", "U32"] {
        let mesh = &scene.meshes[drawn(&scene, name)[0].0];
        assert_eq!(mesh.indices, quad, "{name}");
        assert!(mesh.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)), "{name}");
    }
}

/// A sparse accessor without a buffer view: zeros, then the substitutions.
#[test]
fn gltf_sparse_positions_without_a_buffer_view() {
    let mut w = GltfWriter::default();
    let indices = w.view(&[1u16, 2].iter().flat_map(|i| i.to_le_bytes()).collect::<Vec<_>>(), None);
    let values = w.view(&f32_bytes(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]), None);
    let sparse = format!(
        r#", "min": [0, 0, 0], "max": [1, 1, 0],
        "sparse": {{"count": 2, "indices": {{"bufferView": {indices}, "componentType": {UNSIGNED_SHORT}}}, "values": {{"bufferView": {values}}}}}"#
    );
    let position = w.accessor(None, FLOAT, 3, "VEC3", &sparse);
    let body = format!(r#""nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {position}}}}}]}}]"#);
    let path = w.write(&temp_dir("sparse"), "sparse", &body);
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "sparse.gltf");
    assert_eq!(scene.meshes[0].positions, TRIANGLE);
    assert_eq!(scene.meshes[0].indices, [0, 1, 2]);
    assert!(scene.meshes[0].normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
}

/// KHR_texture_transform is stored on every texture slot; KHR_materials_emissive_strength scales
/// the emission, and a negative or infinite strength is refused naming the file, the material and
/// the value.
#[test]
fn gltf_texture_transform_and_emissive_strength() {
    let dir = temp_dir("transform-strength");
    std::fs::create_dir_all(&dir).unwrap();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([255, 255, 255, 255])).save(dir.join("white.png")).unwrap();
    let mut w = GltfWriter::default();
    let position = w.positions(&TRIANGLE);
    let uv = w.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 2, "VEC2");
    let material = |strength: &str| {
        format!(
            r#"{{"name": "Lamp",
            "pbrMetallicRoughness": {{
                "baseColorTexture": {{"index": 0, "extensions": {{"KHR_texture_transform": {{"offset": [0.5, -0.25], "rotation": 1.5, "scale": [2, 4]}}}}}},
                "metallicRoughnessTexture": {{"index": 0}}}},
            "normalTexture": {{"index": 0, "extensions": {{"KHR_texture_transform": {{"offset": [0.1, 0.2], "rotation": -0.5}}}}}},
            "emissiveTexture": {{"index": 0, "extensions": {{"KHR_texture_transform": {{"scale": [0.5, 0.25]}}}}}},
            "emissiveFactor": [1, 0.5, 0],
            "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": {strength}}}}}}}"#
        )
    };
    let body = |strength: &str| {
        format!(
            r#""extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength"],
            "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {position}, "TEXCOORD_0": {uv}}}, "material": 0}}]}}],
            "materials": [{}], "textures": [{{"source": 0}}], "images": [{{"uri": "white.png"}}]"#,
            material(strength)
        )
    };
    let path = w.write(&dir, "lamp", &body("7.5"));
    let scene = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_valid(&scene, "lamp.gltf");
    let lamp = &scene.materials[self::material(&scene, "Lamp")];
    let transform = |t: Option<engine::scene::TextureRef>| t.expect("texture").transform;
    assert_eq!(
        transform(lamp.base_color_texture),
        UvTransform { offset: Vec2::new(0.5, -0.25), rotation: 1.5, scale: Vec2::new(2.0, 4.0) }
    );
    assert_eq!(transform(lamp.metallic_roughness_texture), UvTransform::default(), "no extension: the identity");
    assert_eq!(transform(lamp.normal_texture), UvTransform { offset: Vec2::new(0.1, 0.2), rotation: -0.5, scale: Vec2::ONE });
    assert_eq!(transform(lamp.emissive_texture), UvTransform { offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::new(0.5, 0.25) });
    assert_eq!((lamp.emissive, lamp.emissive_strength), (Vec3::new(1.0, 0.5, 0.0), 7.5));
    assert!(lamp.is_emissive());
    // The radiance the renderer emits: the factor times the strength.
    assert_eq!(lamp.emissive * lamp.emissive_strength, Vec3::new(7.5, 3.75, 0.0));

    // JSON has no NaN; 1e39 overflows f32 to infinity.
    for (strength, value) in [("-2", "-2"), ("1e39", "inf")] {
        let path = w.write(&dir, "bad_lamp", &body(strength));
        let message = load_scene(&path).expect_err(strength).to_string();
        assert!(
            message.contains("bad_lamp.gltf")
                && message.contains("material 0 'Lamp'")
                && message.contains(&format!("emissiveStrength {value}")),
            "{message}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `extensionsRequired`: every extension the importer implements is accepted; any other refuses
/// the file with an error naming it and every other unknown one.
#[test]
fn gltf_required_extensions_are_checked() {
    let mut w = GltfWriter::default();
    let position = w.positions(&TRIANGLE);
    let body = |used: &str, required: &str| {
        format!(
            r#""extensionsUsed": [{used}], "extensionsRequired": [{required}],
            "nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {position}}}, "material": 0}}]}}],
            "materials": [{{"name": "Shiny", "extensions": {{"KHR_materials_specular": {{"specularFactor": 0.25}}}}}}]"#
        )
    };
    let dir = temp_dir("required");
    let supported = r#""KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_specular", "KHR_texture_transform""#;
    let scene = load_scene(&w.write(&dir, "supported", &body(supported, supported))).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.materials[material(&scene, "Shiny")].specular, 0.25, "KHR_materials_specular is read");

    let required = r#""KHR_texture_transform", "KHR_draco_mesh_compression", "EXT_meshopt_compression""#;
    let path = w.write(&dir, "unknown", &body(required, required));
    let error = load_scene(&path).expect_err("unknown required extensions");
    let message = error.to_string();
    assert!(message.starts_with(&path.display().to_string()), "{message}");
    assert!(message.contains("extensionsRequired"), "{message}");
    assert!(message.contains("KHR_draco_mesh_compression") && message.contains("EXT_meshopt_compression"), "{message}");
    assert!(!message.contains("Unsupported extension"), "the importer's own message, not the gltf crate's: {message}");
    // An unknown extension that is only used (not required) is no reason to refuse the file.
    let used_only = w.write(&dir, "used_only", &body(r#""EXT_meshopt_compression""#, ""));
    load_scene(&used_only).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).ok();
}

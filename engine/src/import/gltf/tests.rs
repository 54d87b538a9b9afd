//! The glTF importer's unit tests: texture coordinate sets, vertex colours, URIs, sparse
//! accessors, triangle fans and GLB headers.

use base64::Engine as _;
use glam::{Vec2, Vec3};

use super::buffers::{decode_data_uri, has_scheme, percent_decode, short};
use super::*;
use crate::scene::NodeContent;

/// The warnings logged on this thread while `f` runs (a logger that keeps each thread's records
/// apart, so that tests running side by side do not see each other's).
fn warnings<T>(f: impl FnOnce() -> T) -> (T, Vec<String>) {
    use std::cell::RefCell;
    struct Capture;
    thread_local!(static LOGGED: RefCell<Vec<String>> = const { RefCell::new(Vec::new()) });
    impl log::Log for Capture {
        fn enabled(&self, metadata: &log::Metadata) -> bool {
            metadata.level() <= log::Level::Warn
        }
        fn log(&self, record: &log::Record) {
            if self.enabled(record.metadata()) {
                LOGGED.with(|l| l.borrow_mut().push(record.args().to_string()));
            }
        }
        fn flush(&self) {}
    }
    static INSTALL: std::sync::Once = std::sync::Once::new();
    INSTALL.call_once(|| {
        log::set_logger(&Capture).expect("no other logger in the engine's tests");
        log::set_max_level(log::LevelFilter::Warn);
    });
    LOGGED.with(|l| l.borrow_mut().clear());
    let result = f();
    (result, LOGGED.with(|l| l.take()))
}

/// A glTF file of one data-URI buffer holding `data`, a 1×1 PNG as image 0 (texture 0), and
/// `body` (its nodes, meshes, materials and accessors; buffer views over `data`).
fn gltf_with(data: &[u8], body: &str) -> String {
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([255, 0, 0, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let encode = |bytes: &[u8]| base64::engine::general_purpose::STANDARD.encode(bytes);
    format!(
        r#"{{"asset": {{"version": "2.0"}}, {body},
            "textures": [{{"source": 0}}], "images": [{{"uri": "data:image/png;base64,{}"}}],
            "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}]}}"#,
        encode(&png),
        data.len(),
        encode(data)
    )
}

/// A triangle's positions (0..36), TEXCOORD_0 (36..60) and TEXCOORD_1 (60..84), as accessors 0, 1, 2.
fn triangle_with_two_uv_sets() -> (Vec<u8>, &'static str) {
    let values = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.5, 0.5, 1.0, 0.5, 0.5, 1.0];
    let data = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let json = r#""bufferViews": [{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 24},
                {"buffer": 0, "byteOffset": 60, "byteLength": 24}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}]"#;
    (data, json)
}

#[test]
fn texture_slots_on_different_sets_warn_once_and_use_texcoord_0() {
    let (data, accessors) = triangle_with_two_uv_sets();
    let primitive = r#"{"attributes": {"POSITION": 0, "TEXCOORD_0": 1, "TEXCOORD_1": 2}, "material": 0}"#;
    let body = format!(
        r#"{accessors}, "nodes": [{{"mesh": 0}}, {{"mesh": 1}}],
            "meshes": [{{"primitives": [{primitive}]}}, {{"primitives": [{primitive}]}}],
            "materials": [{{"name": "Mixed", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}},
                "emissiveFactor": [1, 1, 1], "emissiveTexture": {{"index": 0, "texCoord": 1}}}}]"#
    );
    let (scene, logged) = warnings(|| load(Path::new("mixed.gltf"), gltf_with(&data, &body).as_bytes()));
    let scene = scene.unwrap();
    assert_eq!(scene.meshes.len(), 2);
    for mesh in &scene.meshes {
        assert_eq!(mesh.uvs, [Vec2::ZERO, Vec2::X, Vec2::Y], "TEXCOORD_0");
    }
    let about: Vec<&String> = logged.iter().filter(|m| m.contains("different texture coordinate sets")).collect();
    assert_eq!(about.len(), 1, "once for the material, not per primitive: {logged:?}");
    let message = about[0];
    assert!(message.starts_with("mixed.gltf: material 0 'Mixed'"), "{message}");
    assert!(message.contains("baseColorTexture TEXCOORD_0") && message.contains("emissiveTexture TEXCOORD_1"), "{message}");
}

#[test]
fn a_set_the_primitive_lacks_warns_naming_the_mesh_and_leaves_no_uvs() {
    let (data, accessors) = triangle_with_two_uv_sets();
    let body = format!(
        r#"{accessors}, "nodes": [{{"mesh": 0}}],
            "meshes": [{{"name": "Panel", "primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": 0}}]}}],
            "materials": [{{"name": "Second", "normalTexture": {{"index": 0, "texCoord": 1}}}}]"#
    );
    let (scene, logged) = warnings(|| load(Path::new("lacking.gltf"), gltf_with(&data, &body).as_bytes()));
    let scene = scene.unwrap();
    assert!(scene.meshes[0].uvs.is_empty());
    assert!(scene.materials[0].normal_texture.is_some(), "the texture is still imported");
    let message = logged.iter().find(|m| m.contains("TEXCOORD_1")).unwrap_or_else(|| panic!("no warning: {logged:?}"));
    assert!(
        message.starts_with("lacking.gltf: mesh 'Panel' primitive 0 has no TEXCOORD_1")
            && message.contains("material 0 'Second' normalTexture"),
        "{message}"
    );
}

#[test]
fn varying_vertex_colours_are_averaged_with_a_warning_and_one_colour_is_not() {
    let (mut data, accessors) = triangle_with_two_uv_sets();
    // COLOR_0 at 84: red, green, blue (varying); at 120: grey three times (one colour).
    for v in [1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5] {
        data.extend(v.to_le_bytes());
    }
    let accessors = accessors
        .replace(
            r#"{"buffer": 0, "byteOffset": 60, "byteLength": 24}]"#,
            r#"{"buffer": 0, "byteOffset": 60, "byteLength": 24}, {"buffer": 0, "byteOffset": 84, "byteLength": 72}]"#,
        )
        .replace(
            r#"{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"}]"#,
            r#"{"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
                {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC3"},
                {"bufferView": 3, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"}]"#,
        );
    let body = format!(
        r#"{accessors}, "nodes": [{{"mesh": 0}}, {{"mesh": 1}}],
            "meshes": [{{"name": "Rainbow", "primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 3}}}}]}},
                {{"name": "Grey", "primitives": [{{"attributes": {{"POSITION": 0, "COLOR_0": 4}}}}]}}]"#
    );
    let (scene, logged) = warnings(|| load(Path::new("colours.gltf"), gltf_with(&data, &body).as_bytes()));
    let scene = scene.unwrap();
    let color_of = |node: usize| match &scene.nodes[node].content[..] {
        [NodeContent::Meshes(m)] => scene.materials[m[0].1].base_color,
        other => panic!("{other:?}"),
    };
    assert!(color_of(0).abs_diff_eq(Vec4::new(1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 1.0), 1e-6), "{}", color_of(0));
    assert!(color_of(1).abs_diff_eq(Vec4::new(0.5, 0.5, 0.5, 1.0), 1e-6), "{}", color_of(1));
    assert_eq!(logged.len(), 1, "{logged:?}");
    assert!(logged[0].starts_with("colours.gltf: mesh 'Rainbow' primitive 0 has per-vertex colours (COLOR_0)"), "{}", logged[0]);
    assert!(logged[0].contains("(0.333, 0.333, 0.333, 1.000)"), "{}", logged[0]);
}

#[test]
fn percent_decoding() {
    assert_eq!(percent_decode("a%20b%2Fc%zz%4"), "a b/c%zz%4");
}

#[test]
fn short_references() {
    assert_eq!(short("abc"), "abc");
    assert_eq!(short(&"x".repeat(100)).chars().count(), 49);
}

#[test]
fn data_uris() {
    assert_eq!(decode_data_uri("data:application/octet-stream;base64,AAEC").unwrap(), vec![0, 1, 2]);
    assert_eq!(decode_data_uri("data:application/octet-stream;base64,AAE").unwrap(), vec![0, 1]);
    assert_eq!(decode_data_uri("data:,a%20b").unwrap(), b"a b".to_vec());
    assert!(decode_data_uri("data:;base64,@@@").is_err());
    assert!(decode_data_uri("data:no-comma").is_err());
}

#[test]
fn schemes() {
    assert!(has_scheme("http://example.com/a.bin"));
    assert!(!has_scheme("textures/a.png"));
    assert!(!has_scheme("weird name://x.png"));
}

#[test]
fn sparse_accessor_and_triangle_fan() {
    let mut data = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0] {
        data.extend(v.to_le_bytes());
    }
    data.extend([2, 0, 0, 0]); // sparse index (u8) and padding
    for v in [2.0f32, 2.0, 0.0] {
        data.extend(v.to_le_bytes());
    }
    let uri = format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&data));
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "mode": 6}}]}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                "min": [0, 0, 0], "max": [2, 2, 0],
                "sparse": {{"count": 1, "indices": {{"bufferView": 1, "componentType": 5121}}, "values": {{"bufferView": 2}}}}}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 1}},
                {{"buffer": 0, "byteOffset": 52, "byteLength": 12}}],
            "buffers": [{{"byteLength": {}, "uri": "{uri}"}}]}}"#,
        data.len()
    );
    let scene = load(Path::new("fan.gltf"), json.as_bytes()).unwrap();
    // No scenes: every root node is imported.
    assert_eq!(scene.nodes.len(), 1);
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.positions[2], Vec3::new(2.0, 2.0, 0.0));
    assert_eq!(mesh.indices, [1, 2, 0, 2, 3, 0]);
    assert!(mesh.normals.iter().all(|n| n.abs_diff_eq(Vec3::Z, 1e-6)));
    assert_eq!(scene.materials[0].name, "default");
}

#[test]
fn glb_headers() {
    let file = Path::new("x.glb");
    assert!(split_glb(file, b"glTF").unwrap_err().to_string().contains("truncated"));
    let mut bytes = b"glTF".to_vec();
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(4u32.to_le_bytes());
    assert!(split_glb(file, &bytes).unwrap_err().to_string().contains("smaller than the 12-byte header"));
    let mut bytes = b"glTF".to_vec();
    bytes.extend(2u32.to_le_bytes());
    bytes.extend(24u32.to_le_bytes());
    bytes.extend(u32::MAX.to_le_bytes());
    bytes.extend(b"JSON");
    bytes.extend(b"{}  ");
    let message = split_glb(file, &bytes).unwrap_err().to_string();
    assert!(message.contains("only 4 remain"), "{message}");
}

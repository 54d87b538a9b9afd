//! Every WGSL file is parsed and validated by naga (no GPU needed), the embedded library matches the
//! `shaders/` folder, and every host mirror of a GPU struct has the size naga lays out for it.

use std::collections::BTreeSet;
use std::path::Path;

use engine::render::gpu_types::GPU_STRUCTS;
use engine::shader::{self, SHADER_FILES};

fn shader_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders")
}

#[test]
fn the_embedded_library_lists_every_file_of_the_shader_folder() {
    let on_disk: BTreeSet<String> = std::fs::read_dir(shader_dir())
        .expect("read shaders/")
        .map(|e| e.expect("dir entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    let embedded: BTreeSet<String> = SHADER_FILES.iter().map(|(n, _)| n.to_string()).collect();
    assert_eq!(on_disk, embedded, "engine::shader::SHADER_FILES must list exactly the files in shaders/");
    for (name, source) in SHADER_FILES {
        let disk = std::fs::read_to_string(shader_dir().join(name)).expect("read shader");
        assert_eq!(&disk, source, "{name}: embedded copy is stale");
    }
}

#[test]
fn every_wgsl_file_parses_and_validates() {
    for (name, _) in SHADER_FILES {
        // Includes are validated as part of each file that includes them, and on their own.
        let parsed = shader::parse(name).unwrap_or_else(|e| panic!("{e}"));
        if !name.ends_with(".inc.wgsl") {
            assert!(!parsed.module.entry_points.is_empty(), "{name} has no entry point");
        }
    }
}

#[test]
fn a_broken_shader_is_reported_with_file_and_line() {
    let err = naga::front::wgsl::parse_str("fn f() -> f32 { return 1.0 + ; }").expect_err("must not parse");
    let report = err.emit_to_string_with_path("fn f() -> f32 { return 1.0 + ; }", "broken.wgsl");
    assert!(report.contains("broken.wgsl:1"), "{report}");
    assert!(matches!(shader::preprocess("no_such.wgsl"), Err(shader::ShaderError::Missing(_))));
}

#[test]
fn host_structs_match_naga_layout() {
    for &(name, rust_size, file) in GPU_STRUCTS {
        let parsed = shader::parse(file).unwrap_or_else(|e| panic!("{e}"));
        let wgsl_size = parsed.struct_size(name).unwrap_or_else(|| panic!("{file} declares no struct {name}"));
        assert_eq!(rust_size as u32, wgsl_size, "{name}: Rust mirror is {rust_size} bytes, WGSL layout {wgsl_size}");
    }
}

#[test]
fn bindings_are_reflected_by_name_per_entry_point() {
    let parsed = shader::parse("direct_lighting.wgsl").expect("parse");
    let map = parsed.used_bindings(&["main"]);
    let group1 = &map.groups[&1];
    assert_eq!(group1.len(), 5, "{group1:?}");
    assert!(group1.contains_key("radiance_out"));
    // The lighting pass does not rasterize: vertices are unused and so not part of its layout.
    assert!(!map.groups[&0].contains_key("vertices"));
    let gbuffer = shader::parse("gbuffer.wgsl").expect("parse").used_bindings(&["vs_main", "fs_main"]);
    assert!(gbuffer.groups[&0].contains_key("vertices") && gbuffer.groups[&0].contains_key("materials"));
}

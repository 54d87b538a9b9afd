//! Every registered WGSL module is parsed and validated by naga (no GPU needed), the engine's and the
//! shared library's lists match their folders, every host mirror of a GPU struct has naga's field offsets, and a broken
//! shader is reported in its own file and line, included or not.

use std::path::Path;

use engine::shader::{self, ENGINE_SHADERS, ShaderError};

#[test]
fn the_engine_shader_list_matches_its_folder() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../engine/shaders");
    shader::check_shader_folder(&dir, ENGINE_SHADERS).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn the_shared_library_matches_its_folder_and_validates() {
    shader::check_shader_folder(Path::new(shaders::FOLDER), shaders::LIBRARY).unwrap_or_else(|e| panic!("{e}"));
    // The library's DDGI modules include the constants DDGI generates.
    ddgi::register_shaders().expect("register ddgi");
    for (name, _) in shaders::LIBRARY {
        assert!(name.ends_with(".inc.wgsl"), "{name}: the library holds modules, not passes");
        assert!(!ENGINE_SHADERS.iter().chain(ddgi::SHADERS).any(|(n, _)| n == name), "{name} is registered twice");
        // The traversal core calls the alpha test its includer chooses: it is validated through
        // rt_alpha.inc.wgsl and rt_opaque.inc.wgsl, each of which defines it.
        if *name == "ray_tracing.inc.wgsl" {
            assert!(shader::parse(name).is_err(), "the traversal core validates on its own: does it define the alpha test?");
            continue;
        }
        shader::parse(name).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn every_engine_module_parses_and_validates() {
    for (name, _) in ENGINE_SHADERS {
        // Includes are validated as part of each file that includes them, and on their own.
        let parsed = shader::parse(name).unwrap_or_else(|e| panic!("{e}"));
        if !name.ends_with(".inc.wgsl") {
            assert!(!parsed.module.entry_points.is_empty(), "{name} has no entry point");
        }
    }
}

#[test]
fn the_ddgi_overlay_shaders_match_their_folder_and_validate() {
    // The overlay's WGSL includes DDGI's, which the overlay registers first (as its plugin does).
    ddgi::register_shaders().expect("register ddgi");
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../plugins/ddgi_overlay/shaders");
    shader::check_shader_folder(&dir, ddgi_overlay::visualizer::SHADERS).unwrap_or_else(|e| panic!("{e}"));
    shader::register(ddgi_overlay::visualizer::SHADERS).expect("register");
    for (name, _) in ddgi_overlay::visualizer::SHADERS {
        let parsed = shader::parse(name).unwrap_or_else(|e| panic!("{e}"));
        assert!(!parsed.module.entry_points.is_empty(), "{name} has no entry point");
    }
}

#[test]
fn a_broken_shader_is_reported_in_its_own_file_and_line() {
    // A module of a few lines, with a parse error on its line 4, included after the ray-tracing
    // core (hundreds of lines): the report names the module and its own line, not the expanded one.
    shader::register(&[
        ("test_broken.inc.wgsl", "// a helper\nfn ok() -> f32 {\n    return 1.0;\n}\nfn broken() -> f32 { return 1.0 + ; }\n"),
        (
            "test_uses_broken.wgsl",
            "#include \"ray_tracing.inc.wgsl\"\n#include \"test_broken.inc.wgsl\"\n@compute @workgroup_size(1)\nfn main() {}\n",
        ),
        ("test_invalid.wgsl", "#include \"common.inc.wgsl\"\n\nfn f() -> f32 {\n    return vec2<f32>(1.0);\n}\n"),
    ])
    .expect("register");
    match shader::parse("test_uses_broken.wgsl") {
        Err(ShaderError::Parse { file, report }) => {
            assert_eq!(file, "test_uses_broken.wgsl");
            assert!(report.starts_with("test_broken.inc.wgsl:5:"), "{report}");
            assert!(report.contains("return 1.0 + ;"), "the report quotes the faulty line: {report}");
        }
        other => panic!("expected a parse error, got {:?}", other.map(|p| p.name)),
    }
    // A validation error (a vec2 returned as f32) is located the same way, after an include.
    match shader::parse("test_invalid.wgsl") {
        Err(ShaderError::Validation { report, .. }) => assert!(report.contains("test_invalid.wgsl:4:"), "{report}"),
        other => panic!("expected a validation error, got {:?}", other.map(|p| p.name)),
    }
    assert!(matches!(shader::preprocess("no_such.wgsl"), Err(ShaderError::Missing(_))));
    // A module name is taken once: another source under it is refused.
    assert!(matches!(shader::register(&[("common.inc.wgsl", "// not the engine's")]), Err(ShaderError::Conflict(_))));
}

#[test]
fn host_structs_match_naga_layout() {
    for host in engine::gpu_structs() {
        shader::check_struct_layout(&host).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn constants_shared_with_the_host_read_back_from_the_parsed_shader() {
    use engine::render::gpu_types::{LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT};
    let parsed = shader::parse("scene.inc.wgsl").expect("parse");
    for (name, host) in [("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL), ("LIGHT_POINT", LIGHT_POINT), ("LIGHT_SPOT", LIGHT_SPOT)] {
        assert_eq!(parsed.u32_constant(name), Some(host), "{name}");
    }
    let exposure = shader::parse("exposure.inc.wgsl").expect("parse");
    assert_eq!(exposure.u32_constant("EXPOSURE_BINS"), Some(engine::render::exposure::HISTOGRAM_BINS));
    assert_eq!(parsed.u32_constant("BRDF_DFG_SIZE"), Some(engine::brdf::DFG_SIZE as u32));
    let refit = shader::parse("tlas_refit.wgsl").expect("parse");
    assert_eq!(refit.u32_constant("ENCODE_INV_255_BITS"), Some(engine::rt::TLAS_ENCODE_INV_255.to_bits()));
    assert_eq!(refit.u32_constant("ENCODE_MIN_EXTENT_BITS"), Some(engine::rt::TLAS_ENCODE_MIN_EXTENT.to_bits()));
    assert_eq!(refit.u32_constant("COST_SCALE"), Some(engine::rt::TLAS_REFIT_COST_SCALE));
}

#[test]
fn bindings_are_reflected_by_name_per_entry_point() {
    let parsed = shader::parse("direct_lighting.wgsl").expect("parse");
    let map = parsed.used_bindings(&["main"]);
    let group1 = &map.groups[&1];
    assert_eq!(group1.len(), 5, "{group1:?}");
    assert!(group1.contains_key("radiance_out"));
    // The lighting pass reads vertices only for its shadow rays' alpha test; the TAA pass, which
    // traces nothing, leaves them (and every other scene binding but the view) out of its layout.
    assert!(map.groups[&0].contains_key("vertices"));
    // Built on rt_opaque.inc.wgsl instead (a GPU of WebGPU's 8 storage buffers a stage), it reads
    // neither and fits.
    let full = parsed.storage_buffers_used(&["main"]);
    let opaque = shader::parse(engine::render::register_opaque_direct_lighting().unwrap()).expect("parse");
    let opaque_map = opaque.used_bindings(&["main"]);
    assert!(!opaque_map.groups[&0].contains_key("vertices") && !opaque_map.groups[&0].contains_key("materials"));
    assert!(
        opaque.storage_buffers_used(&["main"]) <= 8 && full > 8,
        "{} and {full} storage buffers",
        opaque.storage_buffers_used(&["main"])
    );
    let taa = shader::parse("taa.wgsl").expect("parse").used_bindings(&["main"]);
    assert!(taa.groups.get(&0).is_none_or(|g| !g.contains_key("vertices") && !g.contains_key("materials")), "{:?}", taa.groups.get(&0));
    let gbuffer = shader::parse("gbuffer.wgsl").expect("parse").used_bindings(&["vs_main", "fs_main"]);
    assert!(gbuffer.groups[&0].contains_key("vertices") && gbuffer.groups[&0].contains_key("materials"));
}

/// Every compute entry point of the engine's, DDGI's and the path tracer's shaders validates as wgpu builds it with the
/// shader's own override values (naga's pipeline-constant pass): an override-sized array, or an
/// expression that folds to a division by zero, fails here rather than on the GPU.
#[test]
fn every_compute_entry_point_validates_with_its_default_overrides() {
    ddgi::register_shaders().expect("register ddgi");
    shader::register(pathtrace::SHADERS).expect("register pathtrace");
    let names = ENGINE_SHADERS
        .iter()
        .chain(ddgi::SHADERS)
        .chain(pathtrace::SHADERS)
        .map(|(name, _)| *name)
        .filter(|name| !name.ends_with(".inc.wgsl"));
    let mut checked = 0;
    for name in names {
        let parsed = shader::parse(name).unwrap_or_else(|e| panic!("{e}"));
        for ep in parsed.module.entry_points.iter().filter(|ep| ep.stage == naga::ShaderStage::Compute) {
            parsed.validate_compute_variant(&ep.name, &[]).unwrap_or_else(|e| panic!("{e}"));
            checked += 1;
        }
    }
    assert!(checked > 10, "{checked} compute entry points");
}

//! The glTF importer on arbitrary bytes, as `.glb` and as `.gltf`: it must return (Ok or an
//! error naming the file), never panic, hang or allocate without bound. Referenced files resolve
//! to a folder that does not exist, so they are reported missing.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for name in ["/nonexistent/fuzz.glb", "/nonexistent/fuzz.gltf"] {
        if let Err(e) = engine::import::load_scene_from_bytes(Path::new(name), data) {
            assert!(e.to_string().contains("fuzz.gl"), "error does not name the file: {e}");
        }
    }
});

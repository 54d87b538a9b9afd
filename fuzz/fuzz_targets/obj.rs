//! The OBJ importer on arbitrary bytes: Ok or an error naming the file, never a panic. Material
//! libraries resolve to a folder that does not exist, so they are reported missing.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(e) = engine::import::load_scene_from_bytes(Path::new("/nonexistent/fuzz.obj"), data) {
        assert!(e.to_string().contains("fuzz.obj"), "error does not name the file: {e}");
    }
});

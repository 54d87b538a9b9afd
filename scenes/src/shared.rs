//! Data made by others, which the project loads but never holds: the folder `shared/` beside the
//! checkout (`../shared/` from the repository's root), with the Kenney models of the demo level
//! ([`KENNEY_FPS`]) and externally authored scenes. Its READMEs name each item's authors and
//! licence.
//!
//! Whatever uses it works without it: the demo level builds its own props, and tests that need an
//! item skip with a message naming it (`testkit::shared`). [`SHARED_DIR_VAR`] points elsewhere (a
//! copy carried to another machine) or, set empty, hides the folder (to try a checkout without it).

use std::path::{Path, PathBuf};

/// Environment variable naming the shared folder in place of `../shared`; set but empty, there is
/// none (every item is absent).
pub const SHARED_DIR_VAR: &str = "DDGI_SHARED_DIR";

/// Kenney's Starter Kit FPS (CC0): the demo level's models and their texture.
pub const KENNEY_FPS: &str = "assets/kenney_fps";

/// The places the shared folder is looked for, in order: [`SHARED_DIR_VAR`] when set (and nothing
/// else then), else `../shared` from the working directory (a binary run from a checkout's root),
/// else `shared/` beside the checkout this crate was built in.
pub fn candidates() -> Vec<PathBuf> {
    if let Some(dir) = std::env::var_os(SHARED_DIR_VAR) {
        return if dir.is_empty() { Vec::new() } else { vec![PathBuf::from(dir)] };
    }
    vec![Path::new("..").join("shared"), Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared")]
}

/// The item `relative` of the shared folder (`assets/kenney_fps`, `scenes/sibenik`, …): the first
/// of the [`candidates`] that holds it, or `None`.
pub fn path(relative: &str) -> Option<PathBuf> {
    candidates().into_iter().map(|dir| dir.join(relative)).find(|p| p.exists())
}

/// [`path`], or `None` with a note on stderr that names the item, where it was looked for and
/// `instead`, what happens without it.
pub fn path_or_note(relative: &str, instead: &str) -> Option<PathBuf> {
    let found = path(relative);
    if found.is_none() {
        eprintln!("note: {}; {instead}", absent(relative));
    }
    found
}

/// "`../shared/<relative>` is absent (…)": the message of a missing item, naming where it was
/// looked for and how to point elsewhere.
pub fn absent(relative: &str) -> String {
    let looked: Vec<String> = candidates().iter().map(|d| d.join(relative).display().to_string()).collect();
    if looked.is_empty() {
        format!("../shared/{relative} is absent ({SHARED_DIR_VAR} is set empty)")
    } else {
        format!("../shared/{relative} is absent (looked in {}; {SHARED_DIR_VAR} names another folder)", looked.join(", "))
    }
}

//! The shared WGSL library: the modules that more than one crate's shaders include, in one folder
//! at the top of the tree, registered once (the engine's shader registry starts with them, so
//! every crate's `#include "scene.inc.wgsl"` finds them without registering anything).
//!
//! Each pass's own shader stays beside the crate that runs it (`engine/shaders/`,
//! `plugins/ddgi/shaders/`, `plugins/pathtrace/shaders/`, …). What lives here:
//! - `common.inc.wgsl`: constants and numerically guarded helpers;
//! - `scene.inc.wgsl` and `brdf.inc.wgsl`: the scene as the GPU sees it (bind group 0) and glTF's
//!   metallic-roughness BRDF;
//! - `ray_tracing.inc.wgsl`, `rt_alpha.inc.wgsl`, `rt_opaque.inc.wgsl`: the ray-tracing core (the
//!   two-level BVH's traversal, with or without the alpha test of masked materials);
//! - `ddgi_common.inc.wgsl`, `ddgi_sampling.inc.wgsl`, `ddgi_debug_draw.inc.wgsl`: DDGI's
//!   structs and bindings, its 8-probe sampling function and its debug draws. They include
//!   `ddgi_constants.inc.wgsl`, which the `ddgi` crate generates from its Rust definitions and
//!   registers (`ddgi::register_shaders`): a shader that includes them needs that call first.
//!
//! The crate holds text only (no dependencies); `engine::shader` parses, includes and validates.

/// One WGSL module: its name (what `#include` and the pipelines use) and its source.
pub type Module = (&'static str, &'static str);

/// Every module of the library, by name. A test checks that this list matches the folder.
pub const LIBRARY: &[Module] = &[
    ("common.inc.wgsl", include_str!("common.inc.wgsl")),
    ("scene.inc.wgsl", include_str!("scene.inc.wgsl")),
    ("brdf.inc.wgsl", include_str!("brdf.inc.wgsl")),
    ("ray_tracing.inc.wgsl", include_str!("ray_tracing.inc.wgsl")),
    ("rt_alpha.inc.wgsl", include_str!("rt_alpha.inc.wgsl")),
    ("rt_opaque.inc.wgsl", include_str!("rt_opaque.inc.wgsl")),
    ("ddgi_common.inc.wgsl", include_str!("ddgi_common.inc.wgsl")),
    ("ddgi_sampling.inc.wgsl", include_str!("ddgi_sampling.inc.wgsl")),
    ("ddgi_debug_draw.inc.wgsl", include_str!("ddgi_debug_draw.inc.wgsl")),
];

/// The folder the library's files are in (for a test that compares [`LIBRARY`] with it).
pub const FOLDER: &str = env!("CARGO_MANIFEST_DIR");

//! A small game engine on bevy_ecs/bevy_app and wgpu.
//!
//! - [`app`]: schedules (bevy_app's main ones plus the render stages extract → prepare → render),
//!   fixed-step time, the headless runner; [`window`]: the windowed runner and its hooks for apps.
//! - [`scene`]: the scene model as ECS components (transforms and their propagation, cameras,
//!   lights, mesh instances) and the shared asset stores.
//! - [`gpu`]: adapter choice and the device, shared buffers, readback and compute dispatch;
//!   [`shader`]: the WGSL library, validated by naga, with
//!   bindings looked up by name; [`graph`]: the render graph; [`render`]: the camera path;
//!   [`headless`]: rendering to files without a window; [`memory`]: the heap the Rust code holds;
//!   [`color`]: the sRGB transfer function on the CPU; [`sky`]: the sky (uniform or
//!   Preetham's analytic daylight) that escaping rays and the background see; [`trace`]: Chrome
//!   traces of the CPU's spans and the GPU's passes on one timeline.
//! - [`import`]: glTF and OBJ files into a scene; [`shapes`]: mesh primitives for building
//!   geometry in code.
//!
//! Cargo features, all on by default: `window` (the windowed runner, module `window`, on winit), `gltf`
//! and `obj` (the importers and their parsers), `trace` (`trace::ChromeTrace`, the trace writer,
//! and bevy's spans of every schedule and system). Without them the engine still renders headless and
//! imports nothing: loading a file of a left-out format is an error that names the feature.

#![warn(missing_docs)]

pub mod app;
pub mod brdf;
pub mod color;
pub mod gpu;
pub mod graph;
pub mod headless;
pub mod import;
pub mod memory;
pub mod render;
pub mod rng;
pub mod rt;
pub mod scene;
pub mod shader;
pub mod shapes;
pub mod sky;
pub mod trace;
#[cfg(feature = "window")]
pub mod window;

/// The host mirrors of the engine's WGSL structs, each module's list ([`render`]'s scene, TAA and
/// exposure structs, [`rt`]'s), for the test that checks every field's offset against naga's
/// layout ([`shader::check_struct_layout`]).
pub fn gpu_structs() -> Vec<shader::HostStruct> {
    [render::gpu_types::gpu_layouts(), rt::gpu_layouts(), render::taa::gpu_layouts(), render::exposure::gpu_layouts()].concat()
}

pub use bevy_app;
pub use bevy_ecs;
pub use glam;
/// naga, the shader validator behind [`shader`] (for [`shader::parse_with`]'s capabilities).
pub use naga;
pub use wgpu;
pub use winit;

//! A small game engine on bevy_ecs/bevy_app and wgpu.
//!
//! - [`app`]: schedules (bevy_app's main ones plus the render stages extract → prepare → render),
//!   fixed-step time, headless and windowed runners.
//! - [`scene`]: the scene model as ECS components (transforms and their propagation, cameras,
//!   lights, mesh instances) and the shared asset stores.
//! - [`gpu`]: adapter choice and the device; [`shader`]: the WGSL library, validated by naga, with
//!   bindings looked up by name; [`graph`]: the render graph; [`render`]: the camera path;
//!   [`headless`]: rendering to files without a window; [`memory`]: the heap the Rust code holds;
//!   [`color`]: the sRGB transfer function on the CPU.

pub mod app;
pub mod builtin;
pub mod builtin_large;
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
pub mod window;

pub use bevy_app;
pub use bevy_ecs;
pub use glam;
pub use wgpu;

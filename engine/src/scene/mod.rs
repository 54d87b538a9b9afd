//! The scene model as ECS components, the asset stores they refer to, and transform propagation.
//!
//! Radiometric convention (see the README): light intensities are radiometric and used as is. A
//! [`PointLight`] of intensity `I` gives irradiance `I·cosθ/d²` at distance `d`; a
//! [`DirectionalLight`] of intensity `E` gives irradiance `E` on a surface facing it; spot cones follow
//! glTF's `KHR_lights_punctual`; colours are linear.

mod assets;
mod components;
mod description;
mod material;
mod mesh;
mod transform;
mod validation;

pub use assets::{Assets, Handle};
pub use components::{Camera, DirectionalLight, MeshInstance, Name, Orbit, PointLight, SpotLight, animate_orbits};
pub use description::{DEFAULT_SUN_DIRECTION, DEFAULT_SUN_IRRADIANCE, NodeContent, SUN_NODE, SceneDescription, SceneNode, SceneRoot};
pub use material::{AlphaMode, Image, Material, TextureFilter, TextureRef, UvTransform};
pub use mesh::{Mesh, RECENTRE_DISTANCE, RECENTRE_EXTENTS, recentre_far_mesh};
pub use transform::{GlobalTransform, RenderOrigin, Transform, WorldAnchor, propagate_transforms};
pub use validation::{SceneDataError, affine_is_finite, validate_affine, validate_light};

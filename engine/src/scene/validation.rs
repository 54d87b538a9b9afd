//! Checks of scene data before it reaches the GPU: [`SceneDataError`], the checks of meshes,
//! materials, lights and transforms, and [`SceneDescription::validate`] with
//! [`SceneDescription::replace_in`], which spawns only a scene that passes.

use bevy_ecs::prelude::*;
use glam::{Affine3A, Vec3};

use super::{AlphaMode, Material, Mesh, NodeContent, SceneDescription, SceneRoot};

/// Scene data that must not reach the GPU: a non-finite value (NaN or ±∞) in a mesh, a material, a
/// light, a camera or a transform, or data larger than the adapter's buffers. Raised by
/// [`SceneDescription::validate`] before a scene is spawned and by the GPU upload
/// ([`crate::render::gpu_scene::GpuScene::errors`]), which leaves the offending item out.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SceneDataError {
    /// `item` names the mesh, material, light, camera or node (`mesh 'Box'`, `light entity 4v1 'Sun'`),
    /// `field` the value (`positions[17]`, `intensity`) and `value` what it holds.
    #[error("{item}: {field} = {value} is not finite")]
    NonFinite {
        /// The mesh, material, light, camera or node, e.g. `mesh 'Box'`.
        item: String,
        /// The value's field, e.g. `positions[17]`.
        field: String,
        /// What it holds, as `Debug` prints it.
        value: String,
    },
    /// A value is finite but outside its valid range (a negative intensity, a zero-length normal, …).
    #[error("{item}: {field} = {value}: {reason}")]
    OutOfRange {
        /// The mesh, material, light, camera or node, e.g. `light entity 4v1 'Sun'`.
        item: String,
        /// The value's field, e.g. `intensity`.
        field: String,
        /// What it holds, as `Debug` prints it.
        value: String,
        /// Why it is out of range, e.g. `must not be negative`.
        reason: &'static str,
    },
    /// The scene needs a GPU buffer larger than the adapter allows.
    #[error("{item}: the {buffer} needs {needed} bytes, over the adapter's limit of {limit} bytes")]
    OverLimit {
        /// What needs the buffer, e.g. `scene geometry (largest: mesh 3 'Terrain')`.
        item: String,
        /// The buffer, e.g. `vertex buffer (48 bytes per vertex)`.
        buffer: &'static str,
        /// Its size, in bytes.
        needed: u64,
        /// The largest storage buffer the adapter binds, in bytes
        /// ([`crate::gpu::max_storage_buffer_bytes`]).
        limit: u64,
    },
}

fn non_finite(item: &str, field: impl Into<String>, value: impl std::fmt::Debug) -> SceneDataError {
    SceneDataError::NonFinite { item: item.to_string(), field: field.into(), value: format!("{value:?}") }
}

impl Mesh {
    /// Checks that every position, normal and texture coordinate is finite; `item` names the mesh in
    /// the error (e.g. `mesh 'Box'`).
    pub fn validate_data(&self, item: &str) -> Result<(), SceneDataError> {
        if let Some((i, p)) = self.positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(non_finite(item, format!("positions[{i}]"), p));
        }
        if let Some((i, n)) = self.normals.iter().enumerate().find(|(_, n)| !n.is_finite()) {
            return Err(non_finite(item, format!("normals[{i}]"), n));
        }
        if let Some((i, uv)) = self.uvs.iter().enumerate().find(|(_, uv)| !uv.is_finite()) {
            return Err(non_finite(item, format!("uvs[{i}]"), uv));
        }
        Ok(())
    }
}

impl Material {
    /// Checks that colours, emission and texture transforms are finite and not negative.
    pub fn validate_data(&self, item: &str) -> Result<(), SceneDataError> {
        let vectors = [("base_color", self.base_color.to_array().to_vec()), ("emissive", self.emissive.to_array().to_vec())];
        for (field, v) in vectors {
            if v.iter().any(|c| !c.is_finite()) {
                return Err(non_finite(item, field, v));
            }
            if v.iter().any(|c| *c < 0.0) {
                return Err(SceneDataError::OutOfRange {
                    item: item.into(),
                    field: field.into(),
                    value: format!("{v:?}"),
                    reason: "must not be negative",
                });
            }
        }
        if !self.emissive_strength.is_finite() {
            return Err(non_finite(item, "emissive_strength", self.emissive_strength));
        }
        if let AlphaMode::Mask { cutoff } = self.alpha_mode
            && !cutoff.is_finite()
        {
            return Err(non_finite(item, "alpha_mode.cutoff", cutoff));
        }
        if self.emissive_strength < 0.0 {
            return Err(SceneDataError::OutOfRange {
                item: item.into(),
                field: "emissive_strength".into(),
                value: format!("{:?}", self.emissive_strength),
                reason: "must not be negative",
            });
        }
        for (field, t) in self.textures() {
            if let Some(t) = t {
                let u = t.transform;
                if !(u.offset.is_finite() && u.scale.is_finite() && u.rotation.is_finite()) {
                    return Err(non_finite(item, format!("{field}.transform"), u));
                }
            }
        }
        for (field, value) in [("metallic", self.metallic), ("roughness", self.roughness), ("specular", self.specular)] {
            if !value.is_finite() {
                return Err(non_finite(item, field, value));
            }
            if !(0.0..=1.0).contains(&value) {
                return Err(SceneDataError::OutOfRange {
                    item: item.into(),
                    field: field.into(),
                    value: format!("{value:?}"),
                    reason: "must be between 0 and 1",
                });
            }
        }
        if !self.normal_scale.is_finite() {
            return Err(non_finite(item, "normal_scale", self.normal_scale));
        }
        Ok(())
    }
}

/// Checks a light's colour, intensity, range and cone angles (`None` for the fields a kind lacks).
pub fn validate_light(
    item: &str,
    color: Vec3,
    intensity: f32,
    range: Option<f32>,
    cones: Option<(f32, f32)>,
) -> Result<(), SceneDataError> {
    if !color.is_finite() {
        return Err(non_finite(item, "color", color));
    }
    if !intensity.is_finite() {
        return Err(non_finite(item, "intensity", intensity));
    }
    if !(color * intensity).is_finite() {
        return Err(non_finite(item, "color × intensity", color * intensity));
    }
    if let Some(r) = range
        && r.is_nan()
    {
        return Err(non_finite(item, "range", r));
    }
    if let Some((inner, outer)) = cones {
        if !inner.is_finite() {
            return Err(non_finite(item, "inner_cone_angle", inner));
        }
        if !outer.is_finite() {
            return Err(non_finite(item, "outer_cone_angle", outer));
        }
    }
    Ok(())
}

/// Whether every number of `a` is finite: what [`validate_affine`] checks, without naming the
/// item (for a check on every frame's movers, which names it only when it fails).
pub fn affine_is_finite(a: &Affine3A) -> bool {
    a.matrix3.is_finite() && a.translation.is_finite()
}

/// Checks that a transform (local or world) is finite.
pub fn validate_affine(item: &str, field: &str, a: &Affine3A) -> Result<(), SceneDataError> {
    if !affine_is_finite(a) {
        return Err(non_finite(item, field, a));
    }
    Ok(())
}

impl SceneDescription {
    /// Checks every mesh, material, light, camera and transform for non-finite values (and meshes
    /// for indices out of range); the first problem found names the item, the field and the value.
    /// A scene that passes can be spawned and uploaded.
    pub fn validate(&self) -> Result<(), SceneDataError> {
        for (i, mesh) in self.meshes.iter().enumerate() {
            let item = format!("mesh {i} '{}'", mesh.name);
            mesh.validate_data(&item)?;
            if let Some((k, index)) = mesh.indices.iter().enumerate().find(|(_, x)| **x as usize >= mesh.positions.len()) {
                return Err(SceneDataError::OutOfRange {
                    item,
                    field: format!("indices[{k}]"),
                    value: index.to_string(),
                    reason: "refers to a vertex that does not exist",
                });
            }
        }
        for (i, material) in self.materials.iter().enumerate() {
            material.validate_data(&format!("material {i} '{}'", material.name))?;
        }
        for (i, node) in self.nodes.iter().enumerate() {
            let item = format!("node {i} '{}'", node.name);
            let t = &node.transform;
            if !t.translation.is_finite() {
                return Err(non_finite(&item, "transform.translation", t.translation));
            }
            if !t.rotation.is_finite() {
                return Err(non_finite(&item, "transform.rotation", t.rotation));
            }
            if !t.scale.is_finite() {
                return Err(non_finite(&item, "transform.scale", t.scale));
            }
            if let Some(p) = node.parent
                && p >= i
            {
                return Err(SceneDataError::OutOfRange {
                    item,
                    field: "parent".into(),
                    value: p.to_string(),
                    reason: "parents must come before their children",
                });
            }
            for content in &node.content {
                match content {
                    NodeContent::DirectionalLight(l) => validate_light(&item, l.color, l.intensity, None, None)?,
                    NodeContent::PointLight(l) => validate_light(&item, l.color, l.intensity, l.range, None)?,
                    NodeContent::SpotLight(l) => {
                        validate_light(&item, l.color, l.intensity, l.range, Some((l.inner_cone_angle, l.outer_cone_angle)))?
                    }
                    NodeContent::Camera(c) => {
                        for (field, v) in [("yfov", c.yfov), ("znear", c.znear), ("exposure", c.exposure)] {
                            if !v.is_finite() {
                                return Err(non_finite(&item, format!("camera.{field}"), v));
                            }
                        }
                    }
                    NodeContent::Meshes(list) => {
                        for &(mesh, material) in list {
                            if mesh >= self.meshes.len() || material >= self.materials.len() {
                                return Err(SceneDataError::OutOfRange {
                                    item,
                                    field: "meshes".into(),
                                    value: format!("({mesh}, {material})"),
                                    reason: "refers to a mesh or material that does not exist",
                                });
                            }
                        }
                    }
                    NodeContent::Empty => {}
                }
            }
        }
        for (i, world) in self.world_transforms().iter().enumerate() {
            validate_affine(&format!("node {i} '{}'", self.nodes[i].name), "world transform", world)?;
        }
        Ok(())
    }

    /// Replaces the scene in `world`: validates this scene first ([`SceneDescription::validate`]);
    /// only when it passes are the entities of every previous [`SceneRoot`] despawned and this
    /// scene spawned. A scene that fails leaves the world as it was. Returns the new root.
    pub fn replace_in(self, world: &mut World) -> Result<Entity, SceneDataError> {
        self.validate()?;
        let roots: Vec<Entity> = world.query_filtered::<Entity, With<SceneRoot>>().iter(world).collect();
        for root in roots {
            world.despawn(root);
        }
        Ok(self.spawn(world))
    }
}

//! The node hierarchy of the scene to import: each node's transform (TRS or a decomposed matrix)
//! and what it carries (meshes, a perspective camera, a `KHR_lights_punctual` light).

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

use ::gltf::json;
use ::gltf::json::extensions::scene::khr_lights_punctual::Type as LightType;
use ::gltf::json::validation::Checked;
use glam::{Mat4, Quat, Vec3};

use super::{Importer, label};
use crate::import::{ImportError, fmt_vec3};
use crate::scene::{Camera, DirectionalLight, NodeContent, PointLight, SceneNode, SpotLight, Transform};

impl Importer<'_> {
    /// Builds the node list of the scene to import, parents before children.
    pub(super) fn load_nodes(&mut self) -> Result<(), ImportError> {
        let document = self.document;
        let node_count = document.nodes().len();
        let roots: Vec<usize> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => {
                let mut is_child = vec![false; node_count];
                for node in document.nodes() {
                    for child in node.children() {
                        if let Some(flag) = is_child.get_mut(child.index()) {
                            *flag = true;
                        }
                    }
                }
                (0..node_count).filter(|&i| !is_child.get(i).copied().unwrap_or(false)).collect()
            }
        };
        let nodes: Vec<::gltf::Node> = document.nodes().collect();
        let mut visited = vec![false; node_count];
        let mut stack: Vec<(usize, Option<usize>)> = roots.iter().rev().map(|&i| (i, None)).collect();
        let mut warned_skin = false;
        while let Some((index, parent)) = stack.pop() {
            let node = nodes.get(index).ok_or_else(|| self.invalid(format!("node {index}"), "does not exist"))?;
            let what = label("node", index, node.name());
            match visited.get_mut(index) {
                Some(seen) if *seen => {
                    return Err(
                        self.invalid(what, "is reached more than once in the node hierarchy (a cycle, or a child with two parents)")
                    );
                }
                Some(seen) => *seen = true,
                None => return Err(self.invalid(what, "does not exist")),
            }
            if node.skin().is_some() && !warned_skin {
                log::warn!("{}: skins are not imported ({what} and maybe others)", self.file.display());
                warned_skin = true;
            }
            let transform = self.node_transform(node, &what)?;
            let content = self.node_content(node, &what)?;
            let name = node.name().map_or_else(|| format!("node {index}"), str::to_string);
            self.scene.nodes.push(SceneNode { name, transform, parent, content, orbit: None });
            let this = self.scene.nodes.len() - 1;
            let children: Vec<usize> = node.children().map(|c| c.index()).collect();
            stack.extend(children.into_iter().rev().map(|c| (c, Some(this))));
        }
        Ok(())
    }

    /// The node's local transform, from TRS or a decomposed matrix.
    fn node_transform(&self, node: &::gltf::Node, what: &str) -> Result<Transform, ImportError> {
        let transform = match node.transform() {
            ::gltf::scene::Transform::Matrix { matrix } => {
                let m = Mat4::from_cols_array_2d(&matrix);
                if !m.is_finite() {
                    return Err(self.invalid(what, format!("matrix has non-finite values {:?}", m.to_cols_array())));
                }
                if m.determinant().abs() < f32::MIN_POSITIVE {
                    return Err(self.invalid(what, format!("matrix is singular {:?}", m.to_cols_array())));
                }
                let (scale, rotation, translation) = m.to_scale_rotation_translation();
                Transform { translation, rotation: rotation.normalize(), scale }
            }
            ::gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                let translation = Vec3::from_array(translation);
                let scale = Vec3::from_array(scale);
                if !translation.is_finite() {
                    return Err(self.invalid(what, format!("non-finite translation {}", fmt_vec3(translation))));
                }
                if !scale.is_finite() {
                    return Err(self.invalid(what, format!("non-finite scale {}", fmt_vec3(scale))));
                }
                let quat = Quat::from_array(rotation);
                if !quat.is_finite() || quat.length() < 1e-6 {
                    return Err(self.invalid(what, format!("invalid rotation quaternion {rotation:?}")));
                }
                Transform { translation, rotation: quat.normalize(), scale }
            }
        };
        if !(transform.translation.is_finite() && transform.rotation.is_finite() && transform.scale.is_finite()) {
            return Err(self.invalid(what, format!("transform decomposes into non-finite values {transform:?}")));
        }
        Ok(transform)
    }

    /// Meshes, camera and light of a node.
    fn node_content(&mut self, node: &::gltf::Node, what: &str) -> Result<Vec<NodeContent>, ImportError> {
        let mut content = Vec::new();
        if let Some(mesh) = node.mesh() {
            let mut instances = Vec::new();
            for primitive in mesh.primitives() {
                let (mesh_index, tint) = self.primitive_mesh(&mesh, &primitive)?;
                let material_index = self.material(primitive.material(), tint)?;
                instances.push((mesh_index, material_index));
            }
            content.push(NodeContent::Meshes(instances));
        }
        let json_node = self.document.as_json().nodes.get(node.index());
        if let Some(camera) = json_node.and_then(|n| n.camera)
            && let Some(camera) = self.camera(camera.value(), what)?
        {
            content.push(NodeContent::Camera(camera));
        }
        let light = json_node.and_then(|n| n.extensions.as_ref()).and_then(|e| e.khr_lights_punctual.as_ref());
        if let Some(light) = light
            && let Some(light) = self.light(light.light.value(), what)?
        {
            content.push(light);
        }
        Ok(content)
    }

    /// A perspective camera; `None` (with a warning) for orthographic ones.
    fn camera(&self, index: usize, node: &str) -> Result<Option<Camera>, ImportError> {
        let camera = self
            .document
            .as_json()
            .cameras
            .get(index)
            .ok_or_else(|| self.invalid(node, format!("refers to camera {index}, which does not exist")))?;
        let what = label("camera", index, camera.name.as_deref());
        match (&camera.type_, &camera.perspective) {
            (Checked::Valid(json::camera::Type::Perspective), Some(p)) => {
                if !(p.yfov.is_finite() && p.yfov > 0.0 && p.yfov < PI) {
                    return Err(self.invalid(what, format!("yfov {} is not in (0, π)", p.yfov)));
                }
                if !(p.znear.is_finite() && p.znear > 0.0) {
                    return Err(self.invalid(what, format!("znear {} is not positive", p.znear)));
                }
                Ok(Some(Camera { yfov: p.yfov, znear: p.znear, exposure: 1.0 }))
            }
            (Checked::Valid(json::camera::Type::Perspective), None) => {
                Err(self.invalid(what, "type is \"perspective\" but the \"perspective\" object is missing"))
            }
            _ => {
                log::warn!("{}: {what} on {node} is not perspective; skipped", self.file.display());
                Ok(None)
            }
        }
    }

    /// A `KHR_lights_punctual` light, with glTF's intensity as is.
    fn light(&self, index: usize, node: &str) -> Result<Option<NodeContent>, ImportError> {
        let lights = self
            .document
            .as_json()
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map_or(&[][..], |l| l.lights.as_slice());
        let light = lights
            .get(index)
            .ok_or_else(|| self.invalid(node, format!("refers to light {index}, but the file has {} lights", lights.len())))?;
        let what = label("light", index, light.name.as_deref());
        let color = Vec3::from_array(light.color);
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(self.invalid(what, format!("invalid color {}", fmt_vec3(color))));
        }
        let intensity = light.intensity;
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(self.invalid(what, format!("invalid intensity {intensity}")));
        }
        if let Some(range) = light.range
            && !(range.is_finite() && range > 0.0)
        {
            return Err(self.invalid(what, format!("invalid range {range} (must be positive)")));
        }
        let content = match light.type_ {
            Checked::Valid(LightType::Directional) => NodeContent::DirectionalLight(DirectionalLight { color, intensity }),
            Checked::Valid(LightType::Point) => NodeContent::PointLight(PointLight { color, intensity, range: light.range }),
            Checked::Valid(LightType::Spot) => {
                let (inner, outer) = light.spot.as_ref().map_or((0.0, FRAC_PI_4), |s| (s.inner_cone_angle, s.outer_cone_angle));
                let valid = inner.is_finite() && outer.is_finite() && inner >= 0.0 && inner <= outer && outer <= FRAC_PI_2 + 1e-6;
                if !valid {
                    return Err(self.invalid(
                        what,
                        format!("invalid spot cone angles: innerConeAngle {inner}, outerConeAngle {outer} (need 0 ≤ inner ≤ outer ≤ π/2)"),
                    ));
                }
                NodeContent::SpotLight(SpotLight { color, intensity, range: light.range, inner_cone_angle: inner, outer_cone_angle: outer })
            }
            Checked::Invalid => {
                log::warn!("{}: {what} has an unknown type; skipped", self.file.display());
                return Ok(None);
            }
        };
        Ok(Some(content))
    }
}

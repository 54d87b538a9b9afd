//! The level's [`Builder`]: the scene being built and the floor plan gathered with it, and the
//! placing of boxes and of Kenney models (loaded once each, or the level's own props instead).

use std::path::PathBuf;

use engine::scene::{Material, NodeContent, SceneDescription, Transform};
use engine::shapes::{box_part, merge};
use glam::{Affine3A, Quat, Vec3};

use super::kit::KitModel;
use super::{Floor, Footprint};

/// Mesh parts of a loaded (or stand-in) model: (placement in the model, mesh, material).
pub(super) type Parts = Vec<(Affine3A, usize, usize)>;

pub(super) struct Builder {
    pub(super) desc: SceneDescription,
    pub(super) assets: Option<PathBuf>,
    pub(super) walls: Vec<Footprint>,
    pub(super) floors: Vec<Floor>,
    pub(super) loaded: Vec<(&'static str, Parts)>,
}

impl Builder {
    pub(super) fn material(&mut self, name: &str, color: Vec3) -> usize {
        self.material_once(Material::diffuse(name, color))
    }

    /// The material's index, adding it unless one of its name is there.
    fn material_once(&mut self, material: Material) -> usize {
        match self.desc.materials.iter().position(|m| m.name == material.name) {
            Some(i) => i,
            None => self.desc.add_material(material),
        }
    }

    /// A static box `min`..`max` in world space.
    pub(super) fn solid(&mut self, name: &str, min: Vec3, max: Vec3, material: usize) -> usize {
        self.desc.add_mesh_node(name, Transform::IDENTITY, merge(name, &[box_part(min, max)]), material)
    }

    /// The model's parts, loading it (into the scene's lists) on first use: Kenney's file, or the
    /// project's own prop of the same bounds when the file is not there.
    fn model(&mut self, model: &KitModel) -> Parts {
        if let Some((_, parts)) = self.loaded.iter().find(|(f, _)| *f == model.file) {
            return parts.clone();
        }
        let parts = self.load(model).unwrap_or_else(|| {
            (model.prop)(model.min, model.max)
                .into_iter()
                .map(|piece| (Affine3A::IDENTITY, self.desc.add_mesh(piece.mesh), self.material_once(piece.material)))
                .collect()
        });
        self.loaded.push((model.file, parts.clone()));
        parts
    }

    fn load(&mut self, model: &KitModel) -> Option<Parts> {
        let path = self.assets.as_ref()?.join(model.file);
        let scene = match engine::import::load_scene(&path) {
            Ok(scene) => scene,
            Err(e) => {
                log::warn!("demo level: {e}; using the level's own prop");
                return None;
            }
        };
        Some(self.append(scene))
    }

    /// Moves a loaded scene's meshes, materials and images into the level (sharing identical images
    /// and materials) and returns its mesh parts, flattened.
    fn append(&mut self, scene: SceneDescription) -> Parts {
        let world = scene.world_transforms();
        let images: Vec<usize> = scene
            .images
            .into_iter()
            .map(|image| match self.desc.images.iter().position(|i| *i == image) {
                Some(i) => i,
                None => {
                    self.desc.images.push(image);
                    self.desc.images.len() - 1
                }
            })
            .collect();
        let remap = |t: Option<engine::scene::TextureRef>| {
            t.and_then(|t| {
                let image = *images.get(t.image.index() as usize)?;
                Some(engine::scene::TextureRef { image: engine::scene::Handle::from_index(image as u32), ..t })
            })
        };
        let materials: Vec<usize> = scene
            .materials
            .into_iter()
            .map(|mut m| {
                m.base_color_texture = remap(m.base_color_texture);
                m.emissive_texture = remap(m.emissive_texture);
                match self.desc.materials.iter().position(|x| *x == m) {
                    Some(i) => i,
                    None => self.desc.add_material(m),
                }
            })
            .collect();
        let meshes: Vec<usize> = scene.meshes.into_iter().map(|m| self.desc.add_mesh(m)).collect();
        let mut parts = Parts::new();
        for (node, xf) in scene.nodes.iter().zip(world) {
            for content in &node.content {
                if let NodeContent::Meshes(list) = content {
                    for &(mesh, material) in list {
                        if let (Some(&mesh), Some(&material)) = (meshes.get(mesh), materials.get(material)) {
                            parts.push((xf, mesh, material));
                        }
                    }
                }
            }
        }
        parts
    }

    /// Places a model as a node named `name` (children for parts that are not at the model's
    /// origin). Returns the node.
    pub(super) fn place(&mut self, name: &str, model: &KitModel, transform: Transform) -> usize {
        self.place_with(name, model, transform, Affine3A::IDENTITY)
    }

    /// [`Builder::place`] with `pre` applied to the model inside its node.
    pub(super) fn place_with(&mut self, name: &str, model: &KitModel, transform: Transform, pre: Affine3A) -> usize {
        let parts: Parts = self.model(model).into_iter().map(|(xf, mesh, material)| (pre * xf, mesh, material)).collect();
        let at_origin: Vec<(usize, usize)> =
            parts.iter().filter(|(xf, _, _)| *xf == Affine3A::IDENTITY).map(|&(_, m, mt)| (m, mt)).collect();
        let content = if at_origin.is_empty() { vec![NodeContent::Empty] } else { vec![NodeContent::Meshes(at_origin)] };
        let node = self.desc.add_node(name, transform, None, content);
        for (i, (xf, mesh, material)) in parts.iter().filter(|(xf, _, _)| *xf != Affine3A::IDENTITY).enumerate() {
            let (scale, rotation, translation) = xf.to_scale_rotation_translation();
            let local = Transform { translation, rotation, scale };
            self.desc.add_node(&format!("{name}_part{i}"), local, Some(node), vec![NodeContent::Meshes(vec![(*mesh, *material)])]);
        }
        node
    }

    /// Places a model standing on the ground at (x, y, z), turned `yaw` about Y, scaled, and
    /// returns its world footprint (axis-aligned; yaw must be a multiple of 90°).
    pub(super) fn prop(&mut self, name: &str, model: &KitModel, at: Vec3, yaw: f32, scale: Vec3) -> Footprint {
        let transform = Transform::from_translation(at).with_rotation(Quat::from_rotation_y(yaw)).with_scale(scale);
        self.place(name, model, transform);
        let affine = transform.to_affine();
        let (a, b) = (affine.transform_point3(model.min), affine.transform_point3(model.max));
        Footprint::of_box(a.min(b), a.max(b))
    }
}

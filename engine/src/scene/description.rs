//! A scene held outside the ECS ([`SceneDescription`]): its nodes and what they carry, the default
//! daylight of a scene without lights, and its spawn into a world.

use bevy_ecs::prelude::*;
use glam::{Affine3A, DVec3, Vec3};

use super::{
    Assets, Camera, DirectionalLight, Handle, Image, Material, Mesh, MeshInstance, Name, Orbit, PointLight, SpotLight, TextureRef,
    Transform, WorldAnchor, recentre_far_mesh,
};

/// What a node of a scene description carries besides its transform.
#[derive(Clone, Debug, PartialEq)]
pub enum NodeContent {
    /// Nothing: a node that only places its children.
    Empty,
    /// One instance per primitive: (mesh, material) pairs in the scene's own asset lists.
    Meshes(Vec<(usize, usize)>),
    /// A camera.
    Camera(Camera),
    /// A directional light.
    DirectionalLight(DirectionalLight),
    /// A point light.
    PointLight(PointLight),
    /// A spot light.
    SpotLight(SpotLight),
}

/// A node of a scene description.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneNode {
    /// The node's name, given to its entity as a [`Name`].
    pub name: String,
    /// Placement relative to the parent node (or the scene's root).
    pub transform: Transform,
    /// The parent node's index in [`SceneDescription::nodes`]; `None`: a child of the scene's root.
    pub parent: Option<usize>,
    /// What the node carries: meshes, a camera, lights.
    pub content: Vec<NodeContent>,
    /// An orbit that moves the node over time, if any.
    pub orbit: Option<Orbit>,
}

/// A scene held outside the ECS: what importers and built-in scene builders produce. Nothing in the
/// world changes until [`SceneDescription::spawn`] succeeds, so a failed load leaves the previous scene
/// intact. Mesh, material and image references are indices into the description's own lists.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneDescription {
    /// The scene's name (importers: the file stem); given to its [`SceneRoot`].
    pub name: String,
    /// Every mesh, indexed by [`NodeContent::Meshes`].
    pub meshes: Vec<Mesh>,
    /// Every material, indexed by [`NodeContent::Meshes`].
    pub materials: Vec<Material>,
    /// Every image, indexed by the materials' [`TextureRef`]s.
    pub images: Vec<Image>,
    /// Nodes in an order where every parent comes before its children.
    pub nodes: Vec<SceneNode>,
    /// Where the scene's root sits in the world, in double precision (a [`WorldAnchor`] on the
    /// root entity): a scene placed 1e5 units away renders as it does at the origin.
    pub origin: DVec3,
    /// What rays that leave the scene see, when the scene says: the default daylight of a scene
    /// without lights ([`SceneDescription::light_if_lightless`]) or a command line's `--sky`.
    /// [`SceneDescription::spawn`] makes it the world's [`Sky`](crate::sky::Sky) resource, for
    /// every renderer alike; `None` leaves the world's sky as it is (black unless the app set one).
    pub sky: Option<crate::sky::Sky>,
}

/// The direction the default sun's light travels (from a sun 50° above the horizon), for a scene
/// without lights ([`SceneDescription::light_if_lightless`]).
pub const DEFAULT_SUN_DIRECTION: Vec3 = Vec3::new(0.45, -0.766, 0.459);
/// The default sun's irradiance (W/m² on a surface facing it): with Preetham's sky of the same sun,
/// a sunlit floor of albedo 0.8 reflects about 0.75 W/(m²·sr), which the renderers' default
/// exposure shows bright but unclipped.
pub const DEFAULT_SUN_IRRADIANCE: f32 = 3.0;
/// The name of the node [`SceneDescription::add_sun`] adds.
pub const SUN_NODE: &str = "sun";

/// Marks the root entity of a spawned scene; despawning it removes the whole scene.
#[derive(Component, Clone, Debug)]
pub struct SceneRoot {
    /// The scene's name, as [`SceneDescription::name`] gave it.
    pub name: String,
}

impl SceneDescription {
    /// Whether anything in the scene gives light: a directional, point or spot light, or a material
    /// that emits.
    pub fn has_lights(&self) -> bool {
        let light =
            |c: &NodeContent| matches!(c, NodeContent::DirectionalLight(_) | NodeContent::PointLight(_) | NodeContent::SpotLight(_));
        let used: Vec<usize> = self
            .nodes
            .iter()
            .flat_map(|n| &n.content)
            .filter_map(|c| if let NodeContent::Meshes(list) = c { Some(list.iter().map(|&(_, m)| m)) } else { None })
            .flatten()
            .collect();
        self.nodes.iter().flat_map(|n| &n.content).any(light)
            || used.iter().any(|&m| self.materials.get(m).is_some_and(Material::is_emissive))
    }

    /// Adds a white directional light (a root node named [`SUN_NODE`]) whose light travels along
    /// `direction` with `irradiance` W/m² on a surface facing it; returns the node.
    pub fn add_sun(&mut self, direction: Vec3, irradiance: f32) -> usize {
        let travel = direction.normalize_or(DEFAULT_SUN_DIRECTION);
        let up = if travel.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let transform = Transform::IDENTITY.looking_at(travel, up);
        let light = DirectionalLight { color: Vec3::ONE, intensity: irradiance };
        self.add_node(SUN_NODE, transform, None, vec![NodeContent::DirectionalLight(light)])
    }

    /// Gives a scene without any light ([`SceneDescription::has_lights`]) the default daylight: a
    /// sun along [`DEFAULT_SUN_DIRECTION`] of [`DEFAULT_SUN_IRRADIANCE`] and Preetham's sky of that
    /// sun as its [`SceneDescription::sky`] (unless it has one). A file exported without its lights
    /// (Šibenik, most asset-store models) then renders lit instead of black, in every mode alike.
    /// Returns whether it did; a scene with any light is left as it is.
    pub fn light_if_lightless(&mut self) -> bool {
        if self.has_lights() {
            return false;
        }
        self.add_sun(DEFAULT_SUN_DIRECTION, DEFAULT_SUN_IRRADIANCE);
        self.sky.get_or_insert(crate::sky::Sky::Physical(crate::sky::PhysicalSky::default()));
        true
    }

    /// Adds a node with no orbit and returns its index.
    pub fn add_node(&mut self, name: &str, transform: Transform, parent: Option<usize>, content: Vec<NodeContent>) -> usize {
        self.nodes.push(SceneNode { name: name.into(), transform, parent, content, orbit: None });
        self.nodes.len() - 1
    }

    /// Adds `mesh` and a root node called `name` drawing it with `material`; returns the node.
    pub fn add_mesh_node(&mut self, name: &str, transform: Transform, mesh: Mesh, material: usize) -> usize {
        let mesh = self.add_mesh(mesh);
        self.add_node(name, transform, None, vec![NodeContent::Meshes(vec![(mesh, material)])])
    }

    /// Adds `mesh` to the scene's meshes and returns its index.
    pub fn add_mesh(&mut self, mesh: Mesh) -> usize {
        self.meshes.push(mesh);
        self.meshes.len() - 1
    }

    /// Adds `material` to the scene's materials and returns its index.
    pub fn add_material(&mut self, material: Material) -> usize {
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// Triangles of every mesh, each counted once however many nodes draw it.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(Mesh::triangle_count).sum()
    }

    /// Triangles drawn when every mesh instance is counted: the sum over all nodes of the triangle
    /// counts of the meshes they draw (a mesh drawn by many nodes counts once per node, unlike
    /// [`SceneDescription::triangle_count`]). References to missing meshes count nothing.
    pub fn instanced_triangle_count(&self) -> usize {
        self.nodes
            .iter()
            .flat_map(|node| &node.content)
            .map(|content| match content {
                NodeContent::Meshes(list) => list.iter().map(|&(mesh, _)| self.meshes.get(mesh).map_or(0, Mesh::triangle_count)).sum(),
                _ => 0,
            })
            .sum()
    }

    /// Whether any node carries a camera.
    pub fn has_camera(&self) -> bool {
        self.nodes.iter().any(|n| n.content.iter().any(|c| matches!(c, NodeContent::Camera(_))))
    }

    /// World-space bounds of every mesh instance, computed from the node hierarchy.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let world = self.world_transforms();
        let mut out: Option<(Vec3, Vec3)> = None;
        for (node, xf) in self.nodes.iter().zip(&world) {
            for content in &node.content {
                let NodeContent::Meshes(list) = content else { continue };
                for &(mesh, _) in list {
                    for &p in &self.meshes[mesh].positions {
                        let p = xf.transform_point3(p);
                        out = Some(match out {
                            None => (p, p),
                            Some((lo, hi)) => (lo.min(p), hi.max(p)),
                        });
                    }
                }
            }
        }
        out
    }

    /// World transform of every node (parents come first in `nodes`).
    pub fn world_transforms(&self) -> Vec<Affine3A> {
        let mut world: Vec<Affine3A> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let parent = node.parent.map_or(Affine3A::IDENTITY, |p| world[p]);
            world.push(parent * node.transform.to_affine());
        }
        world
    }

    /// Moves the assets into the world's stores and spawns one entity per node under a [`SceneRoot`];
    /// the scene's [`SceneDescription::sky`], if any, becomes the world's. Returns the root entity.
    pub fn spawn(self, world: &mut World) -> Entity {
        if let Some(sky) = self.sky {
            world.insert_resource(sky);
        }
        let image_handles: Vec<Handle<Image>> = {
            let mut images = world.get_resource_or_insert_with(Assets::<Image>::default);
            self.images.into_iter().map(|i| images.add(i)).collect()
        };
        let remap = |t: Option<TextureRef>| t.map(|t| TextureRef { image: image_handles[t.image.index() as usize], ..t });
        let material_handles: Vec<Handle<Material>> = {
            let mut materials = world.get_resource_or_insert_with(Assets::<Material>::default);
            self.materials
                .into_iter()
                .map(|mut m| {
                    m.base_color_texture = remap(m.base_color_texture);
                    m.emissive_texture = remap(m.emissive_texture);
                    materials.add(m)
                })
                .collect()
        };
        // Meshes whose vertices lie far from their own origin are moved to it, and their instances
        // placed there instead: the vertices then keep their precision on the GPU.
        let (meshes, recentred): (Vec<Mesh>, Vec<Vec3>) = self.meshes.into_iter().map(recentre_far_mesh).unzip();
        let mesh_handles: Vec<Handle<Mesh>> = {
            let mut store = world.get_resource_or_insert_with(Assets::<Mesh>::default);
            meshes.into_iter().map(|m| store.add(m)).collect()
        };
        let mut root = world.spawn((SceneRoot { name: self.name.clone() }, Name(self.name), Transform::IDENTITY));
        if self.origin != DVec3::ZERO {
            root.insert(WorldAnchor(self.origin));
        }
        let root = root.id();
        let mut entities: Vec<Entity> = Vec::with_capacity(self.nodes.len());
        for node in self.nodes {
            let parent = node.parent.map_or(root, |p| entities[p]);
            let node_name = node.name.clone();
            let mut e = world.spawn((Name(node.name), node.transform, ChildOf(parent)));
            if let Some(orbit) = node.orbit {
                e.insert(orbit);
            }
            for content in node.content {
                match content {
                    NodeContent::Empty => {}
                    NodeContent::Camera(c) => {
                        e.insert(c);
                    }
                    NodeContent::DirectionalLight(l) => {
                        e.insert(l);
                    }
                    NodeContent::PointLight(l) => {
                        e.insert(l);
                    }
                    NodeContent::SpotLight(l) => {
                        e.insert(l);
                    }
                    NodeContent::Meshes(list) => {
                        // One child entity per primitive, named after the node.
                        let id = e.id();
                        for (primitive, (mesh, material)) in list.into_iter().enumerate() {
                            let instance = MeshInstance { mesh: mesh_handles[mesh], material: material_handles[material] };
                            let name = Name(format!("{}#{primitive}", node_name));
                            let placement = Transform::from_translation(recentred[mesh]);
                            e.world_scope(|w| {
                                w.spawn((name, placement, instance, ChildOf(id)));
                            });
                        }
                    }
                }
            }
            entities.push(e.id());
        }
        root
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::Sky;

    fn floor(material: Material) -> SceneDescription {
        let mut scene = SceneDescription::default();
        let m = scene.add_material(material);
        scene.add_mesh_node("floor", Transform::IDENTITY, crate::shapes::cuboid("floor", Vec3::new(5.0, 0.1, 5.0)), m);
        scene
    }

    #[test]
    fn only_a_scene_without_any_light_gets_the_default_daylight() {
        let mut lightless = floor(Material::diffuse("grey", Vec3::splat(0.5)));
        // An emissive material nothing draws gives no light.
        lightless.add_material(Material::emissive("unused", Vec3::ONE));
        assert!(!lightless.has_lights());
        assert!(lightless.light_if_lightless());
        assert!(lightless.has_lights() && !lightless.light_if_lightless(), "lit once, not twice");
        let sun = lightless.nodes.iter().find(|n| n.name == SUN_NODE).expect("a sun node");
        assert!(
            matches!(sun.content[..], [NodeContent::DirectionalLight(DirectionalLight { intensity, .. })] if intensity == DEFAULT_SUN_IRRADIANCE)
        );
        // The node's -Z axis is the direction the light travels.
        let travel = sun.transform.rotation * Vec3::NEG_Z;
        assert!((travel - DEFAULT_SUN_DIRECTION.normalize()).length() < 1e-5, "{travel}");
        assert!(matches!(lightless.sky, Some(Sky::Physical(_))));

        let mut glowing = floor(Material::emissive("lamp", Vec3::ONE));
        let mut lamp = floor(Material::diffuse("grey", Vec3::splat(0.5)));
        lamp.add_node(
            "lamp",
            Transform::IDENTITY,
            None,
            vec![NodeContent::PointLight(PointLight { color: Vec3::ONE, intensity: 1.0, range: None })],
        );
        for scene in [&mut glowing, &mut lamp] {
            assert!(scene.has_lights() && !scene.light_if_lightless());
            assert!(scene.sky.is_none(), "a scene with a light keeps the app's sky");
        }
        // A sky the scene already has is kept.
        let mut given = floor(Material::diffuse("grey", Vec3::splat(0.5)));
        given.sky = Some(Sky::Uniform(Vec3::splat(0.2)));
        assert!(given.light_if_lightless());
        assert_eq!(given.sky, Some(Sky::Uniform(Vec3::splat(0.2))));
    }

    #[test]
    fn spawning_a_scene_with_a_sky_sets_the_worlds() {
        let mut world = World::new();
        world.insert_resource(Sky::Uniform(Vec3::ONE));
        floor(Material::default()).spawn(&mut world);
        assert_eq!(*world.resource::<Sky>(), Sky::Uniform(Vec3::ONE), "no sky of its own: the world's stays");
        let mut scene = floor(Material::default());
        scene.sky = Some(Sky::Uniform(Vec3::splat(0.3)));
        scene.spawn(&mut world);
        assert_eq!(*world.resource::<Sky>(), Sky::Uniform(Vec3::splat(0.3)));
    }
}

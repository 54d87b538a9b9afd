//! Our scene descriptions as sgl-3d content: triangles (node transforms baked in) with their
//! materials and their base colour, emissive and metallic-roughness images as one static model,
//! point, spot and directional lights, and the camera. What has no counterpart is named in
//! [`Converted::unmatched`].

use engine::scene::{NodeContent, SceneDescription, UvTransform};
use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3};
use sgl_3d::asset::{Image, Material, Vertex};
use sgl_3d::{DirectionalLight, DirectionalShadow, Light, LightShape};

/// Reach of a point or spot light that has none of its own (ours are then unlimited; sgl-3d's
/// window needs a finite range): far beyond every built-in scene, so the window is 1 within it.
pub const UNLIMITED_RANGE: f32 = 1.0e4;

/// A scene described for sgl-3d.
pub struct Converted {
    /// One material per material of the scene, in its order.
    pub materials: Vec<Material>,
    /// The scene's images, in its order (the materials' texture indices address them).
    pub images: Vec<Image>,
    /// Triangle meshes in world space: vertices, indices and the index of their material.
    pub meshes: Vec<(Vec<Vertex>, Vec<u32>, usize)>,
    /// Point and spot lights.
    pub lights: Vec<Light>,
    /// Directional lights (sgl-3d takes at most two; the first casts the shadow).
    pub suns: Vec<DirectionalLight>,
    /// The camera's world transform (looking along its local -Z), vertical field of view (radians)
    /// and near plane.
    pub camera: (Affine3A, f32, f32),
    /// What the conversion could not carry over, one sentence each.
    pub unmatched: Vec<String>,
}

/// Converts `scene` (with a camera: see `lab::eval::still`). `shadow_distance`: the reach of the
/// directional shadow's cascades (the scene's size, so that every surface is shadowed).
pub fn convert(scene: &SceneDescription, shadow_distance: f32) -> Result<Converted, String> {
    let mut unmatched = Vec::new();
    let images = scene
        .images
        .iter()
        .map(|i| {
            image::RgbaImage::from_raw(i.width, i.height, i.rgba8.clone())
                .map(Image::Rgba8)
                .ok_or_else(|| format!("image '{}': {} bytes for {}×{} texels", i.name, i.rgba8.len(), i.width, i.height))
        })
        .collect::<Result<Vec<_>, _>>()?;
    // sgl-3d has one set of texture coordinates for all of a material's maps, with no transform:
    // each material's first map's transform is baked into its meshes' coordinates (`uv_transforms`),
    // and a map with another transform is left out.
    let mut uv_transforms = Vec::new();
    let materials = scene
        .materials
        .iter()
        .map(|m| {
            let uv = m.textures().iter().find_map(|(_, t)| t.map(|t| t.transform));
            uv_transforms.push(uv);
            let mut left_out = Vec::new();
            let mut index = |name: &'static str, t: Option<engine::scene::TextureRef>| {
                let t = t?;
                if Some(t.transform) != uv || name == "normal_texture" {
                    left_out.push(name);
                    return None;
                }
                Some(t.image.index() as usize)
            };
            let (base_texture, emissive_texture, mr_texture) = (
                index("base_color_texture", m.base_color_texture),
                index("emissive_texture", m.emissive_texture),
                index("metallic_roughness_texture", m.metallic_roughness_texture),
            );
            index("normal_texture", m.normal_texture);
            if !left_out.is_empty() {
                let why = "a normal map needs tangents the conversion does not give; another map's UV transform differs from the first's";
                unmatched.push(format!("material '{}': maps not converted ({}): {why}", m.name, left_out.join(", ")));
            }
            Material {
                base_texture,
                emissive_texture,
                mr_texture,
                name: m.name.clone(),
                base: [m.base_color.x, m.base_color.y, m.base_color.z, 1.0],
                emissive: (m.emissive * m.emissive_strength).to_array(),
                metallic: m.metallic,
                roughness: m.roughness,
                // KHR_materials_specular's factor in both: 0 is a Lambertian surface.
                specular: m.specular,
                ..Default::default()
            }
        })
        .collect();

    let mut meshes = Vec::new();
    let mut lights = Vec::new();
    let mut suns = Vec::new();
    let mut camera = None;
    for (node, world) in scene.nodes.iter().zip(scene.world_transforms()) {
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        for content in &node.content {
            match content {
                NodeContent::Meshes(pairs) => {
                    for &(mesh, material) in pairs {
                        let mesh = scene.meshes.get(mesh).ok_or_else(|| format!("node '{}': mesh {mesh} missing", node.name))?;
                        let uv = uv_transforms.get(material).copied().flatten();
                        meshes.push((world_vertices(mesh, &world, uv)?, mesh.indices.clone(), material));
                    }
                }
                NodeContent::Camera(c) => {
                    camera.get_or_insert((world, c.yfov, c.znear));
                }
                NodeContent::PointLight(p) => lights.push(Light {
                    position: world.translation.into(),
                    shape: LightShape::Point { radius: 0.0 },
                    color: p.color.to_array(),
                    intensity: p.intensity,
                    range: p.range.unwrap_or(UNLIMITED_RANGE),
                    casts_shadow: true,
                    ..Default::default()
                }),
                NodeContent::SpotLight(s) => lights.push(Light {
                    position: world.translation.into(),
                    shape: LightShape::Spot {
                        direction: forward,
                        inner_angle: s.inner_cone_angle,
                        // sgl-3d keeps the outer angle below a right angle.
                        outer_angle: s.outer_cone_angle.min(std::f32::consts::FRAC_PI_2 - 1e-3),
                        radius: 0.0,
                    },
                    color: s.color.to_array(),
                    intensity: s.intensity,
                    range: s.range.unwrap_or(UNLIMITED_RANGE),
                    casts_shadow: true,
                    ..Default::default()
                }),
                NodeContent::DirectionalLight(d) => suns.push(DirectionalLight {
                    direction: forward,
                    color: d.color.to_array(),
                    // Both: irradiance on a surface facing the light, per unit of colour.
                    illuminance: d.intensity,
                    shadow: Some(DirectionalShadow { distance: shadow_distance, cascades: 4 }),
                    // Ours is a point on the sky (hard shadows).
                    angular_diameter: 0.0,
                    ..Default::default()
                }),
                NodeContent::Empty => {}
            }
        }
    }
    if suns.len() > 2 {
        unmatched.push(format!("{} directional lights: sgl-3d takes two, the rest are left out", suns.len()));
        suns.truncate(2);
    }
    if suns.len() == 2 {
        unmatched.push("the second directional light is unshadowed in sgl-3d".into());
    }
    let camera = camera.ok_or_else(|| format!("scene '{}' has no camera", scene.name))?;
    Ok(Converted { materials, images, meshes, lights, suns, camera, unmatched })
}

/// `mesh`'s vertices moved to world space by `world` (normals by its inverse transpose), their
/// texture coordinates through `uv` (its material's maps' transform).
fn world_vertices(mesh: &engine::scene::Mesh, world: &Affine3A, uv: Option<UvTransform>) -> Result<Vec<Vertex>, String> {
    let rows = uv.map(|t| t.rows());
    let transform = |p: Vec2| rows.map_or(p, |[a, b]| Vec2::new(a.dot(p.extend(1.0)), b.dot(p.extend(1.0))));
    let mut mesh = mesh.clone();
    if mesh.normals.len() != mesh.positions.len() {
        mesh.compute_normals();
    }
    let normal_matrix = Mat3::from(world.matrix3).inverse().transpose();
    Ok(mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let n = (normal_matrix * mesh.normals[i]).normalize_or(Vec3::Y);
            Vertex {
                position: world.transform_point3(p).to_array(),
                normal: n.to_array(),
                uv: mesh.uvs.get(i).map_or([0.0; 2], |&uv| transform(uv).to_array()),
                color: [1.0; 4],
                lightmap_uv: [0.0; 2],
                lightmap_bounds: [0.0; 4],
                tangent: [0.0; 4],
            }
        })
        .collect())
}

/// sgl-3d's camera for our camera's world transform, field of view and near plane, at `aspect`:
/// the same right-handed view and infinite reverse-Z projection as ours.
pub fn camera(world: Affine3A, yfov: f32, znear: f32, aspect: f32) -> sgl_3d::Camera {
    let view = Mat4::from(world).inverse();
    sgl_3d::Camera { view, projection: sgl_3d::perspective(yfov, aspect, znear), eye: world.translation.into() }
}

#[cfg(test)]
mod tests {
    use engine::scene::{Camera, Handle, Image as OurImage, Material as OurMaterial, TextureRef, Transform};
    use glam::Vec2;

    use super::*;

    /// A textured quad: the material's base colour and emissive maps share a transform, its normal
    /// map has another.
    fn textured() -> SceneDescription {
        let mut scene = SceneDescription { name: "textured".into(), ..Default::default() };
        scene.images.push(OurImage { name: "checker".into(), width: 2, height: 1, rgba8: vec![255, 0, 0, 255, 0, 0, 255, 255] });
        let uv = UvTransform { offset: Vec2::new(0.25, 0.5), rotation: std::f32::consts::FRAC_PI_2, scale: Vec2::new(2.0, 3.0) };
        let map = Some(TextureRef { image: Handle::from_index(0), transform: uv, filter: Default::default() });
        let material = OurMaterial {
            base_color_texture: map,
            emissive_texture: map,
            normal_texture: Some(TextureRef {
                image: Handle::from_index(0),
                transform: UvTransform::default(),
                filter: Default::default(),
            }),
            ..OurMaterial::diffuse("painted", Vec3::ONE)
        };
        let material = scene.add_material(material);
        scene.add_mesh_node("quad", Transform::IDENTITY, engine::shapes::quad("quad", Vec2::ONE), material);
        scene.add_node("camera", Transform::from_xyz(0.0, 2.0, 0.0), None, vec![NodeContent::Camera(Camera::default())]);
        scene
    }

    #[test]
    fn base_colour_and_emissive_maps_carry_over_with_their_uv_transform() {
        let scene = textured();
        let converted = convert(&scene, 10.0).expect("converts");
        assert_eq!(converted.images.len(), 1);
        let Image::Rgba8(image) = &converted.images[0] else { panic!("an 8-bit image") };
        assert_eq!((image.width(), image.height(), image.as_raw().as_slice()), (2, 1, scene.images[0].rgba8.as_slice()));
        let m = &converted.materials[0];
        assert_eq!((m.base_texture, m.emissive_texture, m.normal_texture), (Some(0), Some(0), None));
        // glTF's KHR_texture_transform: scaled, then turned a quarter counter-clockwise, then moved.
        let (vertices, _, material) = &converted.meshes[0];
        assert_eq!(*material, 0);
        for (vertex, uv) in vertices.iter().zip(&scene.meshes[0].uvs) {
            let expected = Vec2::new(0.25, 0.5) + Vec2::new(3.0 * uv.y, -2.0 * uv.x);
            assert!((Vec2::from(vertex.uv) - expected).length() < 1e-5, "{uv} → {:?}, expected {expected}", vertex.uv);
        }
        assert!(
            converted.unmatched.iter().any(|u| u.contains("'painted'") && u.contains("normal_texture")),
            "the normal map is named: {:?}",
            converted.unmatched
        );
    }
}

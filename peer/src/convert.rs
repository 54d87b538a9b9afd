//! Our scene descriptions as sgl-3d content: triangles (node transforms baked in) with their
//! materials as one static model, point, spot and directional lights, and the camera. What has no
//! counterpart is named in [`Converted::unmatched`].

use engine::scene::{NodeContent, SceneDescription};
use glam::{Affine3A, Mat3, Mat4, Vec3};
use sgl_3d::asset::{Material, Vertex};
use sgl_3d::{DirectionalLight, DirectionalShadow, Light, LightShape};

/// Reach of a point or spot light that has none of its own (ours are then unlimited; sgl-3d's
/// window needs a finite range): far beyond every built-in scene, so the window is 1 within it.
pub const UNLIMITED_RANGE: f32 = 1.0e4;

/// A scene described for sgl-3d.
pub struct Converted {
    /// One material per material of the scene, in its order.
    pub materials: Vec<Material>,
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
    let materials = scene
        .materials
        .iter()
        .map(|m| {
            let textures: Vec<&str> = m.textures().iter().filter(|(_, t)| t.is_some()).map(|(n, _)| *n).collect();
            if !textures.is_empty() {
                unmatched.push(format!("material '{}': textures not converted ({})", m.name, textures.join(", ")));
            }
            Material {
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
                        meshes.push((world_vertices(mesh, &world)?, mesh.indices.clone(), material));
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
    Ok(Converted { materials, meshes, lights, suns, camera, unmatched })
}

/// `mesh`'s vertices moved to world space by `world` (normals by its inverse transpose).
fn world_vertices(mesh: &engine::scene::Mesh, world: &Affine3A) -> Result<Vec<Vertex>, String> {
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
                uv: mesh.uvs.get(i).map_or([0.0; 2], |uv| uv.to_array()),
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

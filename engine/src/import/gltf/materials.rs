//! glTF materials as scene [`Material`]s: factors, alpha mode, textures and their
//! `KHR_texture_transform`s, and the copies that vertex colours tint.

use glam::{Vec2, Vec3, Vec4};

use super::{Importer, label};
use crate::import::{ImportError, fmt_vec3};
use crate::scene::{AlphaMode, Material, UvTransform};

/// The `KHR_texture_transform` of a normal texture (the `gltf` crate reads it only on the other
/// slots); a component that is not a number is NaN, which [`Importer::texture_ref`] refuses.
fn normal_transform(normal: &::gltf::material::NormalTexture) -> Option<UvTransform> {
    normal.extension_value("KHR_texture_transform").map(|t| {
        let pair = |key: &str, default: [f32; 2]| {
            t.get(key)
                .and_then(|v| v.as_array())
                .map_or(default, |a| [0, 1].map(|i| a.get(i).and_then(|x| x.as_f64()).map_or(f32::NAN, |x| x as f32)))
        };
        UvTransform {
            offset: Vec2::from_array(pair("offset", [0.0, 0.0])),
            rotation: t.get("rotation").and_then(|v| v.as_f64()).map_or(0.0, |r| r as f32),
            scale: Vec2::from_array(pair("scale", [1.0, 1.0])),
        }
    })
}

impl Importer<'_> {
    /// The scene material of a glTF material (or of the default material), imported on first use;
    /// with `tint`, a copy whose base colour factor is multiplied by it (vertex colours).
    pub(super) fn material(&mut self, material: ::gltf::Material, tint: Option<Vec4>) -> Result<usize, ImportError> {
        let key = (material.index(), tint.map(|t| t.to_array().map(f32::to_bits)));
        if let Some(&index) = self.materials.get(&key) {
            return Ok(index);
        }
        let imported = match (key.0, tint) {
            (_, Some(tint)) => {
                let base = self.material(material.clone(), None)?;
                let mut tinted = self.scene.materials.get(base).cloned().unwrap_or_default();
                tinted.name = format!("{} × COLOR_0 ({:.3}, {:.3}, {:.3}, {:.3})", tinted.name, tint.x, tint.y, tint.z, tint.w);
                tinted.base_color *= tint;
                tinted
            }
            (None, None) => Material { name: "default".into(), ..Material::default() },
            (Some(index), None) => self.import_material(&material, index)?,
        };
        let index = self.scene.add_material(imported);
        self.materials.insert(key, index);
        Ok(index)
    }

    fn import_material(&mut self, material: &::gltf::Material, index: usize) -> Result<Material, ImportError> {
        let what = label("material", index, material.name());
        let pbr = material.pbr_metallic_roughness();
        let base_color = Vec4::from_array(pbr.base_color_factor());
        if !base_color.is_finite() {
            return Err(self.invalid(&what, format!("non-finite baseColorFactor {base_color}")));
        }
        let base_color_texture = pbr.base_color_texture().map(|info| self.texture(&info, &what, "baseColorTexture")).transpose()?;
        // Surfaces are drawn two-sided whatever `doubleSided` says (a single-sided leaf would cast
        // a shadow from one side only, which no renderer here models).
        let alpha_mode = match material.alpha_mode() {
            ::gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            ::gltf::material::AlphaMode::Mask => {
                let cutoff = material.alpha_cutoff().unwrap_or(0.5);
                if !(cutoff.is_finite() && cutoff >= 0.0) {
                    return Err(self.invalid(&what, format!("invalid alphaCutoff {cutoff}")));
                }
                AlphaMode::Mask { cutoff }
            }
            ::gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        };
        let emissive = Vec3::from_array(material.emissive_factor());
        if !emissive.is_finite() || emissive.min_element() < 0.0 {
            return Err(self.invalid(&what, format!("invalid emissiveFactor {}", fmt_vec3(emissive))));
        }
        let emissive_texture = material.emissive_texture().map(|info| self.texture(&info, &what, "emissiveTexture")).transpose()?;
        let emissive_strength = material.emissive_strength().unwrap_or(1.0);
        if !(emissive_strength.is_finite() && emissive_strength >= 0.0) {
            return Err(self.invalid(&what, format!("invalid emissiveStrength {emissive_strength} (must be finite and not negative)")));
        }
        let unit = |field: &str, v: f32| -> Result<f32, ImportError> {
            if v.is_finite() && (0.0..=1.0).contains(&v) {
                Ok(v)
            } else {
                Err(self.invalid(&what, format!("{field} {v} is not between 0 and 1")))
            }
        };
        let metallic = unit("metallicFactor", pbr.metallic_factor())?;
        let roughness = unit("roughnessFactor", pbr.roughness_factor())?;
        // KHR_materials_specular's factor (1 without the extension: glTF's dielectric).
        let specular = unit("KHR_materials_specular specularFactor", material.specular().map_or(1.0, |s| s.specular_factor()))?;
        let metallic_roughness_texture =
            pbr.metallic_roughness_texture().map(|info| self.texture(&info, &what, "metallicRoughnessTexture")).transpose()?;
        let (normal_texture, normal_scale) = match material.normal_texture() {
            Some(normal) => {
                let scale = normal.scale();
                if !scale.is_finite() {
                    return Err(self.invalid(&what, format!("non-finite normalTexture scale {scale}")));
                }
                let texture = self.texture_ref(normal.texture(), normal_transform(&normal), &what, "normalTexture")?;
                (Some(texture), scale)
            }
            None => (None, 1.0),
        };
        Ok(Material {
            name: material.name().map_or_else(|| format!("material {index}"), str::to_string),
            base_color,
            alpha_mode,
            base_color_texture,
            emissive,
            emissive_texture,
            emissive_strength,
            metallic,
            roughness,
            metallic_roughness_texture,
            specular,
            normal_texture,
            normal_scale,
        })
    }
}

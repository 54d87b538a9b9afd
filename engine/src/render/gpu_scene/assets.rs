//! Uploads of the asset stores into the scene on the GPU: geometry, the texture atlases and the
//! materials, each when its store changed.

use bytemuck::Zeroable;
use glam::Vec3;

use super::atlas::{PackedAtlas, create_atlas_texture, pack_atlas};
use super::{GpuScene, MeshRange};
use crate::gpu::{GpuContext, max_storage_buffer_bytes};
use crate::render::gpu_types::*;
use crate::scene::{Assets, Image, Material, Mesh, SceneDataError, TextureFilter, TextureRef};

impl GpuScene {
    fn upload_geometry(&mut self, gpu: &GpuContext, meshes: &Assets<Mesh>) {
        let mut vertices: Vec<GpuVertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        self.mesh_ranges.clear();
        self.geometry_errors.clear();
        for (handle, mesh) in meshes.iter() {
            let base_vertex = vertices.len() as i32;
            let first = indices.len() as u32;
            let item = format!("mesh {} '{}'", handle.index(), mesh.name);
            let bad_index = mesh.indices.iter().enumerate().find(|(_, i)| **i as usize >= mesh.positions.len()).map(|(k, i)| {
                SceneDataError::OutOfRange {
                    item: item.clone(),
                    field: format!("indices[{k}]"),
                    value: i.to_string(),
                    reason: "refers to a vertex that does not exist",
                }
            });
            if let Some(error) = mesh.validate_data(&item).err().or(bad_index) {
                // Left out: an empty range draws nothing and traces nothing.
                self.geometry_errors.push(error);
                self.mesh_ranges.push(MeshRange { indices: first..first, base_vertex });
                continue;
            }
            vertices.extend(mesh.positions.iter().enumerate().map(|(i, p)| {
                let n = mesh.normals.get(i).copied().unwrap_or(Vec3::Y);
                let uv = mesh.uvs.get(i).copied().unwrap_or_default();
                let tangent = mesh.tangents.get(i).copied().filter(|t| t.is_finite()).unwrap_or(glam::Vec4::ZERO);
                GpuVertex { position: p.to_array(), u: uv.x, normal: n.to_array(), v: uv.y, tangent: tangent.to_array() }
            }));
            indices.extend_from_slice(&mesh.indices);
            self.mesh_ranges.push(MeshRange { indices: first..indices.len() as u32, base_vertex });
        }
        let limit = max_storage_buffer_bytes(&gpu.device);
        let needs = [
            ("vertex buffer (48 bytes per vertex)", std::mem::size_of_val(vertices.as_slice()) as u64),
            ("index buffer (4 bytes per index)", std::mem::size_of_val(indices.as_slice()) as u64),
        ];
        if let Some((buffer, needed)) = needs.into_iter().find(|(_, n)| *n > limit) {
            // Nothing of it fits: draw nothing rather than bind a buffer the adapter refuses.
            let largest = meshes.iter().max_by_key(|(_, m)| m.positions.len().max(m.indices.len()));
            let item = largest.map_or("scene".to_string(), |(h, m)| format!("scene geometry (largest: mesh {} '{}')", h.index(), m.name));
            self.geometry_errors.push(SceneDataError::OverLimit { item, buffer, needed, limit });
            vertices.clear();
            indices.clear();
            for range in &mut self.mesh_ranges {
                *range = MeshRange { indices: 0..0, base_vertex: 0 };
            }
        }
        self.vertices.write(gpu, bytemuck::cast_slice(&vertices));
        self.indices.write(gpu, bytemuck::cast_slice(&indices));
    }

    /// Packs every image into the colour atlas, and into the data atlas too when `with_data` (some
    /// material samples a data texture).
    fn upload_atlas(&mut self, gpu: &GpuContext, images: &Assets<Image>, with_data: bool) {
        let max_dim = gpu.device.limits().max_texture_dimension_2d.min(8192);
        let list: Vec<&Image> = images.iter().map(|(_, i)| i).collect();
        let packed = pack_atlas(&list, max_dim);
        self.atlas = create_atlas_texture(gpu, &packed, wgpu::TextureFormat::Rgba8UnormSrgb);
        self.atlas_view = self.atlas.create_view(&Default::default());
        let white = PackedAtlas { width: 1, height: 1, rgba8: vec![255; 4], rects: Vec::new() };
        self.data_atlas = create_atlas_texture(gpu, if with_data { &packed } else { &white }, wgpu::TextureFormat::Rgba8Unorm);
        self.data_atlas_view = self.data_atlas.create_view(&Default::default());
        self.data_atlas_filled = with_data;
        self.atlas_rects = packed.rects;
    }

    fn upload_materials(&mut self, gpu: &GpuContext, materials: &Assets<Material>, images: &Assets<Image>) {
        let slot = |t: &Option<TextureRef>| -> TextureSlot {
            let Some(t) = t else { return TextureSlot::zeroed() };
            let Some(rect) = self.atlas_rects.get(t.image.index() as usize) else { return TextureSlot::zeroed() };
            let [x, y] = t.transform.rows();
            // Nearest sampling snaps to texel centres in the shader, which needs the image's size.
            let texels = match (t.filter, images.get(t.image)) {
                (TextureFilter::Nearest, Some(image)) => [image.width as f32, image.height as f32],
                _ => [0.0, 0.0],
            };
            TextureSlot { uv_x: x.extend(texels[0]).to_array(), uv_y: y.extend(texels[1]).to_array(), rect: *rect }
        };
        let mut errors = Vec::new();
        let data: Vec<GpuMaterial> = materials
            .iter()
            .map(|(h, m)| {
                let emissive = m.emissive * m.emissive_strength;
                let checked = m.validate_data(&format!("material {} '{}'", h.index(), m.name)).and_then(|()| {
                    if emissive.is_finite() {
                        Ok(())
                    } else {
                        Err(SceneDataError::NonFinite {
                            item: format!("material {} '{}'", h.index(), m.name),
                            field: "emissive × emissive_strength".into(),
                            value: format!("{emissive:?}"),
                        })
                    }
                });
                if let Err(e) = checked {
                    // Rejected: black, emitting nothing.
                    errors.push(e);
                    return GpuMaterial { base_color: [0.0, 0.0, 0.0, 1.0], ..GpuMaterial::zeroed() };
                }
                GpuMaterial {
                    base_color: m.base_color.to_array(),
                    emissive: emissive.extend(m.alpha_mode.cutoff()).to_array(),
                    pbr: [m.metallic, m.roughness, m.specular, m.normal_scale],
                    base_color_texture: slot(&m.base_color_texture),
                    emissive_texture: slot(&m.emissive_texture),
                    metallic_roughness_texture: slot(&m.metallic_roughness_texture),
                    normal_texture: slot(&m.normal_texture),
                }
            })
            .collect();
        self.material_errors = errors;
        self.alpha_tested = data.iter().map(|m| m.emissive[3] > 0.0).collect();
        self.has_alpha_test = self.alpha_tested.contains(&true);
        self.has_emissive = materials.iter().any(|(_, m)| m.emissive_strength != 0.0 && m.emissive != Vec3::ZERO);
        self.materials.write(gpu, bytemuck::cast_slice(&data));
    }
}

impl GpuScene {
    /// Uploads what changed in the asset stores since the last frame: the geometry, the atlases
    /// (images, or whether some material needs the data atlas), the materials. Returns whether the
    /// geometry changed.
    pub(super) fn upload_changed_assets(
        &mut self,
        gpu: &GpuContext,
        meshes: &Assets<Mesh>,
        materials: &Assets<Material>,
        images: &Assets<Image>,
    ) -> bool {
        let generations = (meshes.generation(), images.generation(), materials.generation());
        let seen = self.seen_generations;
        if seen.map(|s| s.0) != Some(generations.0) {
            self.upload_geometry(gpu, meshes);
        }
        let needs_data_atlas = || materials.iter().any(|(_, m)| m.metallic_roughness_texture.is_some() || m.normal_texture.is_some());
        if seen.map(|s| s.1) != Some(generations.1)
            || (seen.map(|s| s.2) != Some(generations.2) && needs_data_atlas() != self.data_atlas_filled)
        {
            self.upload_atlas(gpu, images, needs_data_atlas());
        }
        if seen.map(|s| (s.1, s.2)) != Some((generations.1, generations.2)) {
            self.upload_materials(gpu, materials, images);
        }
        self.seen_generations = Some(generations);
        seen.map(|s| s.0) != Some(generations.0)
    }
}

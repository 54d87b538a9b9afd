//! The scene on the GPU: geometry, texture atlas, materials, instances, lights and the view.
//!
//! Meshes, images and materials are uploaded when their asset store changes; instances, lights and
//! the view are written every frame (a few kilobytes for the scenes of this issue).

use std::ops::Range;

use bevy_ecs::entity::EntityHashMap;
use bevy_ecs::prelude::*;
use glam::{Affine3A, Mat4, Vec3};

use super::gpu_types::*;
use crate::gpu::{GpuContext, GrowableBuffer, Uploads, max_storage_buffer_bytes};
use crate::graph::NamedResource;
use crate::scene::{
    Assets, Camera, DirectionalLight, GlobalTransform, Image, Material, Mesh, MeshInstance, Name, PointLight, SceneDataError, SpotLight,
    TextureFilter, TextureRef, validate_affine, validate_light,
};

/// Where a mesh lives in the shared vertex and index buffers.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct MeshRange {
    /// The mesh's indices in the shared index buffer.
    pub indices: Range<u32>,
    /// Where its vertices start in the shared vertex buffer (added to each index).
    pub base_vertex: i32,
}

/// One indexed draw of one instance.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Draw {
    /// The mesh's indices in the shared index buffer.
    pub indices: Range<u32>,
    /// Where its vertices start in the shared vertex buffer.
    pub base_vertex: i32,
    /// The instance slot (the draw's instance index).
    pub instance: u32,
}

/// The size of the image the camera renders.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSize {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Everything a pass needs to look at the scene: bind group 0 of `scene.inc.wgsl`.
#[derive(Resource)]
pub struct GpuScene {
    /// The [`ViewUniform`] (WGSL `view`).
    pub(crate) view: GrowableBuffer,
    /// The [`GpuLight`]s (WGSL `lights`).
    pub(crate) lights: GrowableBuffer,
    /// The [`GpuMaterial`]s (WGSL `materials`).
    pub(crate) materials: GrowableBuffer,
    /// Every mesh's [`GpuVertex`]es, one after the other (WGSL `vertices`).
    pub(crate) vertices: GrowableBuffer,
    /// Every mesh's indices, one after the other (WGSL `indices`).
    pub(crate) indices: GrowableBuffer,
    /// A [`GpuInstance`] per instance slot (WGSL `instances`).
    pub(crate) instances: GrowableBuffer,
    /// Each instance slot's `world_from_local` of the previous frame (motion vectors).
    pub(crate) instance_history: GrowableBuffer,
    /// Every base-colour image, sRGB, packed into one texture.
    pub(crate) atlas: wgpu::Texture,
    /// The default view of `atlas`.
    pub(crate) atlas_view: wgpu::TextureView,
    /// The same images in linear 8-bit, for data textures (metallic-roughness, normal maps); 1×1
    /// while no material has one.
    pub(crate) data_atlas: wgpu::Texture,
    /// The default view of `data_atlas`.
    pub(crate) data_atlas_view: wgpu::TextureView,
    /// The BRDF's split-sum table ([`crate::brdf::dfg_table`]).
    pub(crate) brdf_table: wgpu::Buffer,
    /// The atlases' sampler.
    pub(crate) sampler: wgpu::Sampler,
    /// Where each mesh asset lives in `vertices` and `indices`, by mesh index.
    pub(crate) mesh_ranges: Vec<MeshRange>,
    /// The G-buffer's draws, one per live instance.
    pub(crate) draws: Vec<Draw>,
    slots: InstanceSlots,
    changes: InstanceChanges,
    /// How many lights `lights` holds.
    pub(crate) light_count: u32,
    /// This frame's lights as uploaded (lets accumulating renderers notice a change).
    pub light_data: Vec<GpuLight>,
    /// Which light kinds the scene has, so passes can leave out what it does not need.
    pub has_spot_lights: bool,
    /// Whether any material cuts texels by alpha (pipelines built for a scene without leave the
    /// alpha test out: `SCENE_HAS_ALPHA_TEST`).
    pub has_alpha_test: bool,
    /// Whether any material emits light (shaders may leave out the emission lookup when none does).
    pub has_emissive: bool,
    /// This frame's view as uploaded (camera matrices, position, exposure, jitter).
    pub view_uniform: ViewUniform,
    /// The last frame's unjittered `clip_from_world` (motion vectors).
    previous_clip_from_world: Option<Mat4>,
    atlas_rects: Vec<[f32; 4]>,
    /// Whether `data_atlas` holds the images (some material has a data texture).
    data_atlas_filled: bool,
    seen_generations: Option<(u64, u64, u64)>,
    frame: u32,
    /// Scene data left out of the upload, by where it was found (see [`GpuScene::errors`]).
    geometry_errors: Vec<SceneDataError>,
    material_errors: Vec<SceneDataError>,
    /// Per material index: whether it cuts texels by alpha ([`crate::scene::AlphaMode`]).
    alpha_tested: Vec<bool>,
    instance_errors: EntityHashMap<SceneDataError>,
    frame_errors: Vec<SceneDataError>,
    logged: std::collections::HashSet<String>,
}

impl GpuScene {
    /// An empty scene: no geometry, lights or instances, 1×1 white atlases, and the BRDF table.
    pub fn new(gpu: &GpuContext) -> Self {
        let storage = wgpu::BufferUsages::STORAGE;
        let white = PackedAtlas { width: 1, height: 1, rgba8: vec![255; 4], rects: Vec::new() };
        let atlas = create_atlas_texture(gpu, &white, wgpu::TextureFormat::Rgba8UnormSrgb);
        let data_atlas = create_atlas_texture(gpu, &white, wgpu::TextureFormat::Rgba8Unorm);
        let brdf_table = wgpu::util::DeviceExt::create_buffer_init(
            &gpu.device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("brdf_dfg_table"),
                contents: bytemuck::cast_slice(crate::brdf::dfg_table()),
                usage: storage,
            },
        );
        Self {
            view: GrowableBuffer::new(&gpu.device, "view_uniform", wgpu::BufferUsages::UNIFORM),
            lights: GrowableBuffer::new(&gpu.device, "lights", storage),
            materials: GrowableBuffer::new(&gpu.device, "materials", storage),
            vertices: GrowableBuffer::new(&gpu.device, "vertices", storage),
            indices: GrowableBuffer::new(&gpu.device, "indices", storage | wgpu::BufferUsages::INDEX),
            instances: GrowableBuffer::new(&gpu.device, "instances", storage),
            instance_history: GrowableBuffer::new(&gpu.device, "instance_history", storage),
            atlas_view: atlas.create_view(&Default::default()),
            atlas,
            data_atlas_view: data_atlas.create_view(&Default::default()),
            data_atlas,
            brdf_table,
            sampler: gpu.device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("atlas_sampler"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            mesh_ranges: Vec::new(),
            draws: Vec::new(),
            slots: InstanceSlots::default(),
            changes: InstanceChanges::default(),
            light_count: 0,
            light_data: Vec::new(),
            has_spot_lights: false,
            has_emissive: false,
            view_uniform: ViewUniform::zeroed(),
            previous_clip_from_world: None,
            atlas_rects: Vec::new(),
            data_atlas_filled: false,
            seen_generations: None,
            frame: 0,
            geometry_errors: Vec::new(),
            material_errors: Vec::new(),
            alpha_tested: Vec::new(),
            has_alpha_test: false,
            instance_errors: EntityHashMap::default(),
            frame_errors: Vec::new(),
            logged: Default::default(),
        }
    }

    /// Scene data the upload rejected and left out, as it stands this frame: meshes with non-finite
    /// vertices (drawn as nothing), materials with non-finite values (black), lights and cameras
    /// with non-finite values (left out), instances with non-finite transforms (not drawn), and
    /// geometry beyond the adapter's buffer limits (nothing drawn). Each is logged once.
    pub fn errors(&self) -> Vec<&SceneDataError> {
        self.geometry_errors.iter().chain(&self.material_errors).chain(self.instance_errors.values()).chain(&self.frame_errors).collect()
    }

    fn log_new_errors(&mut self) {
        let messages: Vec<String> = self.errors().iter().map(|e| e.to_string()).collect();
        for message in messages {
            if self.logged.insert(message.clone()) {
                log::error!("scene data rejected at upload: {message}");
            }
        }
    }

    /// Bind group 0 resources by their WGSL names (see [`crate::graph::RenderGraph::import_named`]).
    pub fn resources(&self) -> Vec<(&'static str, NamedResource<'_>)> {
        vec![
            ("view", NamedResource::Buffer(&self.view.buffer)),
            ("lights", NamedResource::Buffer(&self.lights.buffer)),
            ("materials", NamedResource::Buffer(&self.materials.buffer)),
            ("texture_atlas", NamedResource::Texture { texture: &self.atlas, view: &self.atlas_view }),
            ("atlas_sampler", NamedResource::Sampler(&self.sampler)),
            ("vertices", NamedResource::Buffer(&self.vertices.buffer)),
            ("instances", NamedResource::Buffer(&self.instances.buffer)),
            ("instance_history", NamedResource::Buffer(&self.instance_history.buffer)),
            ("data_atlas", NamedResource::Texture { texture: &self.data_atlas, view: &self.data_atlas_view }),
            ("brdf_dfg_table", NamedResource::Buffer(&self.brdf_table)),
            ("indices", NamedResource::Buffer(&self.indices.buffer)),
        ]
    }

    /// How the instances changed in this frame's prepare stage.
    pub fn instance_changes(&self) -> &InstanceChanges {
        &self.changes
    }

    /// Every live instance as (slot, mesh index, world transform).
    pub fn live_instances(&self) -> Vec<(u32, u32, Affine3A)> {
        self.slots.placement.iter().enumerate().filter_map(|(i, p)| p.map(|(m, w)| (i as u32, m, w))).collect()
    }

    /// Whether the instance in `slot` is drawn with a material that cuts texels by alpha (its rays
    /// test the alpha at every candidate hit; it never joins a static group).
    pub fn instance_alpha_tested(&self, slot: u32) -> bool {
        let material = self.slots.data.get(slot as usize).map(|d| d.material as usize);
        material.and_then(|m| self.alpha_tested.get(m)).copied().unwrap_or(false)
    }

    /// Mesh index and world transform of the instance in `slot`, if it is live.
    pub fn instance_placement(&self, slot: u32) -> Option<(u32, Affine3A)> {
        self.slots.placement.get(slot as usize).copied().flatten()
    }

    /// The world transform the instance in `slot` had in the previous frame, as the motion vectors
    /// use it (WGSL `instance_history`): its old one in a frame it moved, its current one once it
    /// has been still for a frame. `None` for a slot that is not live.
    pub fn previous_world_from_local(&self, slot: u32) -> Option<Mat4> {
        self.instance_placement(slot)?;
        self.slots.history.get(slot as usize).map(Mat4::from_cols_array_2d)
    }

    /// Number of instance slots (live or free); instance indices in shaders are below this.
    pub fn instance_slot_count(&self) -> usize {
        self.slots.data.len()
    }

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

/// A texture holding `packed`: sRGB-encoded colour (decoded by the sampler) or linear data.
fn create_atlas_texture(gpu: &GpuContext, packed: &PackedAtlas, format: wgpu::TextureFormat) -> wgpu::Texture {
    let size = wgpu::Extent3d { width: packed.width, height: packed.height, depth_or_array_layers: 1 };
    let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(if format.is_srgb() { "texture_atlas" } else { "data_atlas" }),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    gpu.queue.write_texture(
        texture.as_image_copy(),
        &packed.rgba8,
        wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(packed.width * 4), rows_per_image: None },
        size,
    );
    texture
}

/// Every image of the scene packed into one texture, so that raster and compute passes sample any
/// texture through one binding.
pub(crate) struct PackedAtlas {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The texels, RGBA8 row-major from the top-left.
    pub rgba8: Vec<u8>,
    /// Per image: (x, y, width, height) in atlas coordinates [0, 1].
    pub rects: Vec<[f32; 4]>,
}

/// Shelf-packs images (tallest first) into an atlas at most `max_dim` on a side, halving every image
/// until they fit when they do not.
pub(crate) fn pack_atlas(images: &[&Image], max_dim: u32) -> PackedAtlas {
    let mut scale_down = 0u32;
    loop {
        let sizes: Vec<(u32, u32)> = images.iter().map(|i| ((i.width >> scale_down).max(1), (i.height >> scale_down).max(1))).collect();
        if let Some(layout) = shelf_pack(&sizes, max_dim) {
            return fill_atlas(images, &sizes, layout);
        }
        scale_down += 1;
        log::warn!("texture atlas: images do not fit in {max_dim}², halving them (÷{})", 1 << scale_down);
    }
}

struct ShelfLayout {
    width: u32,
    height: u32,
    origins: Vec<(u32, u32)>,
}

fn shelf_pack(sizes: &[(u32, u32)], max_dim: u32) -> Option<ShelfLayout> {
    const PAD: u32 = 1;
    let width = sizes.iter().map(|s| s.0 + 2 * PAD).max().unwrap_or(1).max(1024).min(max_dim);
    if sizes.iter().any(|s| s.0 + 2 * PAD > width) {
        return None;
    }
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(sizes[i].1));
    let mut origins = vec![(0, 0); sizes.len()];
    let (mut x, mut y, mut shelf) = (0u32, 0u32, 0u32);
    for i in order {
        let (w, h) = (sizes[i].0 + 2 * PAD, sizes[i].1 + 2 * PAD);
        if x + w > width {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        origins[i] = (x + PAD, y + PAD);
        x += w;
        shelf = shelf.max(h);
    }
    let height = (y + shelf).max(1);
    (height <= max_dim).then_some(ShelfLayout { width, height, origins })
}

fn fill_atlas(images: &[&Image], sizes: &[(u32, u32)], layout: ShelfLayout) -> PackedAtlas {
    let (aw, ah) = (layout.width, layout.height);
    let mut rgba8 = vec![255u8; (aw * ah * 4) as usize];
    let mut rects = Vec::with_capacity(images.len());
    for ((image, &(w, h)), &(ox, oy)) in images.iter().zip(sizes).zip(&layout.origins) {
        let pixel = |x: u32, y: u32| -> [u8; 4] {
            // Nearest sample of the (possibly halved) image; out-of-range data reads as white.
            let sx = (x * image.width.max(1) / w).min(image.width.saturating_sub(1));
            let sy = (y * image.height.max(1) / h).min(image.height.saturating_sub(1));
            let i = ((sy * image.width + sx) * 4) as usize;
            image.rgba8.get(i..i + 4).and_then(|s| s.try_into().ok()).unwrap_or([255; 4])
        };
        // One texel of padding around each image repeats its edge, so bilinear taps stay inside.
        for y in 0..h + 2 {
            for x in 0..w + 2 {
                let (dx, dy) = (ox + x - 1, oy + y - 1);
                let p = pixel(x.saturating_sub(1).min(w - 1), y.saturating_sub(1).min(h - 1));
                let o = ((dy * aw + dx) * 4) as usize;
                rgba8[o..o + 4].copy_from_slice(&p);
            }
        }
        rects.push([ox as f32 / aw as f32, oy as f32 / ah as f32, w as f32 / aw as f32, h as f32 / ah as f32]);
    }
    PackedAtlas { width: aw, height: ah, rgba8, rects }
}

/// Instance slots: an entity keeps its slot (its index in the instance buffer and in shaders) for
/// as long as it is an instance; freed slots are reused.
#[derive(Default)]
struct InstanceSlots {
    by_entity: EntityHashMap<u32>,
    free: Vec<u32>,
    data: Vec<GpuInstance>,
    /// Each slot's `world_from_local` of the previous frame.
    history: Vec<[[f32; 4]; 4]>,
    /// Slots that moved in the previous frame: their history catches up this frame.
    moved_last_frame: Vec<u32>,
    placement: Vec<Option<(u32, Affine3A)>>,
    /// Scratch, false between frames: the slots written this frame (a mark per slot, no set).
    written: Vec<bool>,
}

impl InstanceSlots {
    /// The entity's slot, allocating one if needed, and the mesh it had before (None if new).
    fn acquire(&mut self, entity: Entity) -> (u32, Option<u32>) {
        if let Some(&slot) = self.by_entity.get(&entity) {
            return (slot, self.placement[slot as usize].map(|p| p.0));
        }
        let slot = self.free.pop().unwrap_or_else(|| {
            self.data.push(GpuInstance::zeroed());
            self.history.push([[0.0; 4]; 4]);
            self.placement.push(None);
            self.data.len() as u32 - 1
        });
        self.by_entity.insert(entity, slot);
        (slot, None)
    }

    fn release(&mut self, entity: Entity) -> Option<u32> {
        let slot = self.by_entity.remove(&entity)?;
        self.placement[slot as usize] = None;
        self.data[slot as usize] = GpuInstance { mesh: u32::MAX, ..GpuInstance::zeroed() };
        self.free.push(slot);
        Some(slot)
    }
}

/// What changed among the instances in this frame's prepare stage.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct InstanceChanges {
    /// Instances were added or removed, or changed mesh.
    pub structure_changed: bool,
    /// Slots whose transform changed (same mesh).
    pub moved: Vec<u32>,
    /// Every slot written this frame.
    pub dirty: Vec<u32>,
    /// CPU time spent updating and uploading instances this frame.
    pub cpu_time: std::time::Duration,
}

fn gpu_instance(instance: &MeshInstance, transform: &GlobalTransform) -> GpuInstance {
    let world = Mat4::from(transform.0);
    let invertible = transform.0.matrix3.determinant().abs() > 1e-30;
    // An affine inverse: cheaper than a general 4×4 one.
    let local_from_world = if invertible { Mat4::from(transform.0.inverse()) } else { Mat4::ZERO };
    GpuInstance {
        world_from_local: mat4_cols(world),
        local_from_world: mat4_cols(local_from_world),
        material: instance.material.index(),
        mesh: instance.mesh.index(),
        _pad0: 0,
        _pad1: 0,
    }
}

impl GpuScene {
    /// The previous frame's transforms: the slots written this frame hold their old transform
    /// (set as they were written); those that moved in the previous frame but not in this one
    /// are still now, so their history becomes their transform.
    fn upload_instance_history(&mut self, gpu: &GpuContext, uploads: &mut Uploads) {
        let slots = &mut self.slots;
        slots.written.resize(slots.data.len(), false);
        for &d in &self.changes.dirty {
            slots.written[d as usize] = true;
        }
        let mut changed: Vec<usize> = self.changes.dirty.iter().map(|&d| d as usize).collect();
        for &slot in &slots.moved_last_frame {
            if (slot as usize) < slots.data.len() && !slots.written[slot as usize] {
                slots.history[slot as usize] = slots.data[slot as usize].world_from_local;
                changed.push(slot as usize);
            }
        }
        for &d in &self.changes.dirty {
            slots.written[d as usize] = false;
        }
        slots.moved_last_frame.clone_from(&self.changes.dirty);
        let needed = (slots.history.len() * size_of::<[[f32; 4]; 4]>()) as u64;
        if needed > self.instance_history.buffer.size() {
            self.instance_history.write(gpu, bytemuck::cast_slice(&slots.history));
            return;
        }
        uploads.write_dirty_ranges(gpu, &self.instance_history.buffer, &slots.history, &mut changed);
    }

    fn upload_instances(&mut self, gpu: &GpuContext, uploads: &mut Uploads, dirty: &[u32]) {
        let needed = (self.slots.data.len() * size_of::<GpuInstance>()) as u64;
        if needed > self.instances.buffer.size() {
            self.instances.write(gpu, bytemuck::cast_slice(&self.slots.data));
            return;
        }
        let mut sorted: Vec<usize> = dirty.iter().map(|&d| d as usize).collect();
        uploads.write_dirty_ranges(gpu, &self.instances.buffer, &self.slots.data, &mut sorted);
    }
}

/// Render stage, first: submits the frame's staged buffer updates.
pub fn flush_uploads(gpu: Res<GpuContext>, mut uploads: ResMut<Uploads>) {
    uploads.flush(&gpu);
}

fn mat4_cols(m: Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

/// Instances that were added, moved or given another mesh or material since the last frame.
type ChangedInstance = Or<(Changed<GlobalTransform>, Changed<MeshInstance>)>;

/// Prepare stage: uploads what changed and writes this frame's instances, lights and view.
#[allow(clippy::too_many_arguments)]
pub fn prepare_gpu_scene(
    gpu: Res<GpuContext>,
    mut scene: ResMut<GpuScene>,
    mut uploads: ResMut<Uploads>,
    size: Res<RenderSize>,
    sky: Res<crate::sky::Sky>,
    taa: Option<Res<super::TaaState>>,
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<Material>>,
    images: Res<Assets<Image>>,
    instances: Query<(Entity, &MeshInstance, &GlobalTransform, Option<&Name>), ChangedInstance>,
    mut removed: RemovedComponents<MeshInstance>,
    cameras: Query<(Entity, &Camera, &GlobalTransform)>,
    directional: Query<(Entity, &DirectionalLight, &GlobalTransform)>,
    points: Query<(Entity, &PointLight, &GlobalTransform)>,
    spots: Query<(Entity, &SpotLight, &GlobalTransform)>,
    names: Query<&Name>,
) {
    let generations = (meshes.generation(), images.generation(), materials.generation());
    let seen = scene.seen_generations;
    if seen.map(|s| s.0) != Some(generations.0) {
        scene.upload_geometry(&gpu, &meshes);
    }
    let needs_data_atlas = || materials.iter().any(|(_, m)| m.metallic_roughness_texture.is_some() || m.normal_texture.is_some());
    if seen.map(|s| s.1) != Some(generations.1)
        || (seen.map(|s| s.2) != Some(generations.2) && needs_data_atlas() != scene.data_atlas_filled)
    {
        scene.upload_atlas(&gpu, &images, needs_data_atlas());
    }
    if seen.map(|s| (s.1, s.2)) != Some((generations.1, generations.2)) {
        scene.upload_materials(&gpu, &materials, &images);
    }
    scene.seen_generations = Some(generations);

    // Instances: persistent slots, written only when an instance is added, moved or removed.
    let instances_started = std::time::Instant::now();
    scene.changes = InstanceChanges::default();
    for entity in removed.read() {
        scene.instance_errors.remove(&entity);
        if let Some(slot) = scene.slots.release(entity) {
            scene.changes.structure_changed = true;
            scene.changes.dirty.push(slot);
        }
    }
    let geometry_changed = seen.map(|s| s.0) != Some(generations.0);
    for (entity, instance, transform, name) in &instances {
        // The error's text only for a transform that fails (formatting it for every mover cost
        // more than the rest of its update).
        if !crate::scene::affine_is_finite(&transform.0) {
            let item = format!("instance entity {entity}{}", name.map_or(String::new(), |n| format!(" '{}'", n.0)));
            if let Err(error) = validate_affine(&item, "world transform", &transform.0) {
                // Not drawn (and not traced) until its transform is finite again.
                scene.instance_errors.insert(entity, error);
                if let Some(slot) = scene.slots.release(entity) {
                    scene.changes.structure_changed = true;
                    scene.changes.dirty.push(slot);
                }
                continue;
            }
        }
        if !scene.instance_errors.is_empty() {
            scene.instance_errors.remove(&entity);
        }
        if scene.mesh_ranges.get(instance.mesh.index() as usize).is_none() || materials.get(instance.material).is_none() {
            log::warn!("{entity}: mesh instance refers to a missing {:?} or {:?}; not drawn", instance.mesh, instance.material);
            continue;
        }
        let (slot, previous_mesh) = scene.slots.acquire(entity);
        let data = gpu_instance(instance, transform);
        // A new instance (or one given another mesh) did not move; one that moved was where its
        // old transform put it.
        let was = if previous_mesh.is_some() { scene.slots.data[slot as usize].world_from_local } else { data.world_from_local };
        scene.slots.history[slot as usize] = was;
        scene.slots.data[slot as usize] = data;
        scene.slots.placement[slot as usize] = Some((instance.mesh.index(), transform.0));
        scene.changes.dirty.push(slot);
        if previous_mesh == Some(instance.mesh.index()) {
            scene.changes.moved.push(slot);
        } else {
            scene.changes.structure_changed = true;
        }
    }
    if scene.changes.structure_changed || geometry_changed {
        let draws = scene
            .slots
            .placement
            .iter()
            .enumerate()
            .filter_map(|(slot, p)| {
                let range = scene.mesh_ranges.get(p.as_ref()?.0 as usize)?;
                Some(Draw { indices: range.indices.clone(), base_vertex: range.base_vertex, instance: slot as u32 })
            })
            .collect();
        scene.draws = draws;
    }
    let dirty = std::mem::take(&mut scene.changes.dirty);
    scene.upload_instances(&gpu, &mut uploads, &dirty);
    scene.changes.dirty = dirty;
    scene.upload_instance_history(&gpu, &mut uploads);
    scene.changes.cpu_time = instances_started.elapsed();

    // Lights.
    let mut lights: Vec<GpuLight> = Vec::new();
    let light = |kind: u32, color: Vec3, intensity: f32, t: &GlobalTransform, range: Option<f32>| GpuLight {
        position: t.translation().to_array(),
        kind,
        direction: t.forward().to_array(),
        range: range.unwrap_or(0.0).max(0.0),
        radiance: (color * intensity).to_array(),
        spot_scale: 0.0,
        spot_offset: 0.0,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    };
    let mut frame_errors = Vec::new();
    let item = |kind: &str, e: Entity| format!("{kind} entity {e}{}", names.get(e).map_or(String::new(), |n| format!(" '{}'", n.0)));
    let mut check = |item: String, color: Vec3, intensity: f32, range: Option<f32>, cones: Option<(f32, f32)>, t: &GlobalTransform| {
        let result = validate_light(&item, color, intensity, range, cones).and_then(|()| validate_affine(&item, "world transform", &t.0));
        result.map_err(|e| frame_errors.push(e)).is_ok()
    };
    for (e, l, t) in &directional {
        if check(item("directional light", e), l.color, l.intensity, None, None, t) {
            lights.push(light(LIGHT_DIRECTIONAL, l.color, l.intensity, t, None));
        }
    }
    for (e, l, t) in &points {
        if check(item("point light", e), l.color, l.intensity, l.range, None, t) {
            lights.push(light(LIGHT_POINT, l.color, l.intensity, t, l.range));
        }
    }
    scene.has_spot_lights = !spots.is_empty();
    for (e, l, t) in &spots {
        if !check(item("spot light", e), l.color, l.intensity, l.range, Some((l.inner_cone_angle, l.outer_cone_angle)), t) {
            continue;
        }
        // glTF: attenuation = clamp(cos(angle) * scale + offset, 0, 1)², guarded for equal cones.
        let (cos_outer, cos_inner) = (l.outer_cone_angle.cos(), l.inner_cone_angle.cos());
        let scale = 1.0 / (cos_inner - cos_outer).max(1e-4);
        let mut g = light(LIGHT_SPOT, l.color, l.intensity, t, l.range);
        g.spot_scale = scale;
        g.spot_offset = -cos_outer * scale;
        lights.push(g);
    }
    // The sky follows the first directional light: towards it, at its irradiance's luminance.
    let sun = lights.iter().find(|l| l.kind == LIGHT_DIRECTIONAL).map(|l| crate::sky::Sun {
        direction: -Vec3::from_array(l.direction),
        irradiance: Vec3::from_array(l.radiance).dot(Vec3::new(0.2126, 0.7152, 0.0722)),
    });
    scene.light_count = lights.len() as u32;
    scene.lights.write(&gpu, bytemuck::cast_slice(&lights));
    scene.light_data = lights;

    // View.
    let (mut camera, mut camera_transform) =
        cameras.iter().next().map_or((Camera::default(), GlobalTransform::default()), |(_, c, t)| (*c, *t));
    if let Some((e, _, _)) = cameras.iter().next() {
        let item = item("camera", e);
        let fields = [("yfov", camera.yfov), ("znear", camera.znear), ("exposure", camera.exposure)];
        let bad = fields.iter().find(|(_, v)| !v.is_finite()).map(|(f, v)| SceneDataError::NonFinite {
            item: item.clone(),
            field: (*f).into(),
            value: format!("{v:?}"),
        });
        if let Some(error) = bad.or_else(|| validate_affine(&item, "world transform", &camera_transform.0).err()) {
            // Rendered from the default camera instead.
            frame_errors.push(error);
            (camera, camera_transform) = (Camera::default(), GlobalTransform::default());
        }
    }
    scene.frame_errors = frame_errors;
    scene.log_new_errors();
    let clip_from_world = clip_from_world(&camera, &camera_transform, *size);
    let previous_clip_from_world = scene.previous_clip_from_world.replace(clip_from_world).unwrap_or(clip_from_world);
    let position = camera_transform.translation();
    scene.view_uniform = ViewUniform {
        clip_from_world: mat4_cols(clip_from_world),
        world_from_clip: mat4_cols(clip_from_world.inverse()),
        previous_clip_from_world: mat4_cols(previous_clip_from_world),
        camera_position: position.to_array(),
        exposure: camera.exposure,
        size: [size.width, size.height],
        jitter: taa.map_or(glam::Vec2::ZERO, |t| t.jitter).to_array(),
        light_count: scene.light_count,
        frame: scene.frame,
        _pad0: 0,
        _pad1: 0,
        sky: sky.gpu(sun),
    };
    scene.frame = scene.frame.wrapping_add(1);
    let view = scene.view_uniform;
    scene.view.write(&gpu, bytemuck::bytes_of(&view));
}

use bytemuck::Zeroable;

/// The camera's projection and view: reverse-Z, infinite far plane, `size`'s aspect ratio. Cameras
/// ignore scale: the view is built from position and rotation only.
pub fn clip_from_world(camera: &Camera, transform: &GlobalTransform, size: RenderSize) -> Mat4 {
    let aspect = size.width.max(1) as f32 / size.height.max(1) as f32;
    let proj = glam::camera::rh::proj::directx::perspective_infinite_reverse(camera.yfov.clamp(1e-3, 3.1), aspect, camera.znear.max(1e-6));
    let (_, rotation, position) = transform.0.to_scale_rotation_translation();
    let world_from_view = Mat4::from_rotation_translation(rotation.normalize(), position);
    proj * world_from_view.inverse()
}

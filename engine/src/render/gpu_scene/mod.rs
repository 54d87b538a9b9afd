//! The scene on the GPU: geometry, texture atlas, materials, instances, lights and the view.
//!
//! Meshes, images and materials are uploaded when their asset store changes; instances, lights and
//! the view are written every frame (a few kilobytes for the scenes of this issue).

use std::ops::Range;

use bevy_ecs::entity::EntityHashMap;
use bevy_ecs::prelude::*;
use glam::Mat4;

mod assets;
mod atlas;
mod instances;
mod prepare;

use atlas::{PackedAtlas, create_atlas_texture};
use bytemuck::Zeroable;
pub use instances::InstanceChanges;
use instances::InstanceSlots;
pub use prepare::prepare_gpu_scene;

use super::gpu_types::*;
use crate::gpu::{GpuContext, GrowableBuffer, Uploads};
use crate::graph::NamedResource;
use crate::scene::{Camera, GlobalTransform, SceneDataError};

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
}

/// Render stage, first: submits the frame's staged buffer updates.
pub fn flush_uploads(gpu: Res<GpuContext>, mut uploads: ResMut<Uploads>) {
    uploads.flush(&gpu);
}

fn mat4_cols(m: Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

/// The camera's projection and view: reverse-Z, infinite far plane, `size`'s aspect ratio. Cameras
/// ignore scale: the view is built from position and rotation only.
pub fn clip_from_world(camera: &Camera, transform: &GlobalTransform, size: RenderSize) -> Mat4 {
    let aspect = size.width.max(1) as f32 / size.height.max(1) as f32;
    let proj = glam::camera::rh::proj::directx::perspective_infinite_reverse(camera.yfov.clamp(1e-3, 3.1), aspect, camera.znear.max(1e-6));
    let (_, rotation, position) = transform.0.to_scale_rotation_translation();
    let world_from_view = Mat4::from_rotation_translation(rotation.normalize(), position);
    proj * world_from_view.inverse()
}

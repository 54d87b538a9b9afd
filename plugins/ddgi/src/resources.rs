//! Each volume's GPU resources and state ([`VolumeGpu`]) and every volume's ([`DdgiGpuVolumes`]),
//! which prepare ([`prepare_ddgi_volumes`], in `resources/prepare.rs`) makes (or remakes when the
//! layout changes) with the probe entities, and updates each frame.

use std::collections::HashMap;

use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::gpu::readback::ReadbackRing;
use engine::render::gpu_scene::GpuScene;
use engine::rng::SplitMix64;
use engine::scene::{Assets, Image, Material, Mesh};
use engine::wgpu;
use glam::{DVec3, IVec3, Vec3};

use crate::buffers::VolumeBuffers;
use crate::gpu::{DdgiProbeData, MAX_IRRADIANCE, PROBE_INACTIVE};
use crate::volume::{DdgiLayout, DdgiLimits, DdgiProbeState, DdgiVolume};

/// Format of both atlases (irradiance perceptually encoded; distances
/// divided by the volume's distance scale, so half floats neither overflow nor lose precision at
/// any scene scale).
pub const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The GPU resources and state of one volume.
pub struct VolumeGpu {
    /// Where every probe and atlas tile is, in render space (see `world_bounds`).
    pub layout: DdgiLayout,
    /// This frame's settings (copied from the volume's component each frame; those that size the
    /// resources — grid, rays, map sizes, bounds, seed — rebuild them when they change).
    pub settings: DdgiVolume,
    /// Every buffer of the volume, by the table in [`crate::buffers`]; the volume reads as them
    /// (`volume.probes`, through `Deref`).
    pub buffers: VolumeBuffers,
    /// The atlases that sampling reads (half floats, irradiance perceptually encoded).
    pub irradiance: wgpu::Texture,
    /// The distance atlas that sampling reads ([`ATLAS_FORMAT`]): (mean, mean square) of the hit
    /// distance over the layout's distance scale ([`crate::atlas::read_distance`] decodes it).
    pub distance: wgpu::Texture,
    /// Frames rendered since the volume was made (updated or not).
    pub frames: u64,
    pub(crate) rng: SplitMix64,
    /// The probe entities, by probe index.
    pub probe_entities: Vec<Entity>,
    pub(crate) readback: ReadbackRing,
    pub(crate) counter_readback: ReadbackRing,
    /// The last probe data read back (offsets and states), by probe index.
    pub probe_data: Vec<DdgiProbeData>,
    /// The volume's box in world space, in double precision; `layout` is in render space (less
    /// the [`RenderOrigin`](engine::scene::RenderOrigin) it was laid out for, `render_origin`), and moves with it.
    pub world_bounds: (DVec3, DVec3),
    /// The world position of the render origin `layout` was laid out for.
    pub render_origin: DVec3,
    /// Whether this frame updates the probes ([`DdgiVolume::update_period`]; the gather runs
    /// every frame). Set by prepare.
    pub updates_this_frame: bool,
    /// Scrolls so far and the last one: `(frame, cells moved, probes reset)`.
    pub scrolls: u64,
    /// The last scroll, `(frame, cells moved, probes reset)`; `None` before the first.
    pub last_scroll: Option<(u64, IVec3, u32)>,
    /// Where the gather takes the volume: fixed volumes first (by entity), then cascades from the
    /// finest out ([`crate::DdgiCascade`]), and its blend band in cells (0 for a fixed volume).
    pub order: (u32, Entity),
    /// The blend band of a cascade, in cells (0 for a fixed volume).
    pub cascade_blend: f32,
    /// The coarsest cascade of its camera ([`crate::DdgiCascade::outermost`]).
    pub cascade_outermost: bool,
    /// The rays the budget pass asked for at the volume's last update that has come back from the
    /// GPU, before a frame budget scaled them down (its counters' `total_rays / budget_scale`):
    /// what the cascades' shared budget is divided by ([`crate::DdgiCascades::frame_budget`]).
    pub demanded_rays: Option<f64>,
    /// The volume-level update period of calm phases ([`crate::DdgiAdaptive::max_update_period`]).
    pub calm: crate::calm::DdgiCalm,
    /// A re-check of the switched-off probes is owed: set on re-check frames and when instances
    /// come or go, cleared by the next frame that updates (a frame the update period leaves out
    /// does not lose it).
    pub(crate) recheck_pending: bool,
}

impl std::ops::Deref for VolumeGpu {
    type Target = VolumeBuffers;

    fn deref(&self) -> &VolumeBuffers {
        &self.buffers
    }
}

impl VolumeGpu {
    fn new(gpu: &GpuContext, settings: &DdgiVolume, layout: DdgiLayout, render_origin: DVec3) -> Self {
        let device = &gpu.device;
        let buffers = VolumeBuffers::new(device, &layout);
        let initial = vec![DdgiProbeData::NEW; layout.probe_count as usize];
        gpu.queue.write_buffer(&buffers.probes, 0, bytemuck::cast_slice(&initial));
        let texture = |label: &str, size: glam::UVec2| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: size.x, height: size.y, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: ATLAS_FORMAT,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let irradiance = texture("ddgi_irradiance", layout.irradiance_atlas);
        let distance = texture("ddgi_distance", layout.distance_atlas);
        Self {
            buffers,
            irradiance,
            distance,
            frames: 0,
            rng: SplitMix64::new(settings.seed),
            probe_entities: Vec::new(),
            readback: ReadbackRing::new("ddgi_probes_readback", 3),
            counter_readback: ReadbackRing::new("ddgi_counters_readback", 8),
            probe_data: initial,
            settings: settings.clone(),
            world_bounds: (render_origin + layout.bounds.0.as_dvec3(), render_origin + layout.bounds.1.as_dvec3()),
            render_origin,
            updates_this_frame: true,
            scrolls: 0,
            last_scroll: None,
            order: (0, Entity::PLACEHOLDER),
            cascade_blend: 0.0,
            cascade_outermost: false,
            demanded_rays: None,
            calm: crate::calm::DdgiCalm::default(),
            recheck_pending: false,
            layout,
        }
    }

    /// Moves the grid by `cells` whole cells (toroidally: no probe's data moves). The probes that
    /// stay keep their maps, offsets and states; those of the planes that entered (every probe
    /// when a move reaches across the grid) are reset to new, fresh probes, which their next
    /// update (this frame: a volume always updates when it scrolls) fills from scratch. Returns
    /// how many were reset.
    fn scroll(&mut self, gpu: &GpuContext, cells: IVec3, limits: DdgiLimits) -> u32 {
        let counts = self.layout.counts.as_ivec3();
        let spacing = (self.world_bounds.1 - self.world_bounds.0) / counts.as_dvec3();
        let shift = cells.as_dvec3() * spacing;
        self.world_bounds = (self.world_bounds.0 + shift, self.world_bounds.1 + shift);
        let scroll = (self.layout.scroll.as_ivec3() + cells).rem_euclid(counts).as_uvec3();
        self.relayout(scroll, limits);
        // The probes whose grid coordinates entered: on an axis moved by k > 0, the last k planes;
        // by k < 0, the first −k.
        let entered = |g: glam::IVec3| {
            (0..3).any(|a| {
                let k = cells[a];
                (k > 0 && g[a] >= counts[a] - k) || (k < 0 && g[a] < -k)
            })
        };
        let mut reset = 0u32;
        let mut run: Option<(u32, u32)> = None;
        let stride = size_of::<DdgiProbeData>() as u64;
        let flush = |run: (u32, u32)| {
            let data = vec![DdgiProbeData::NEW; (run.1 - run.0) as usize];
            gpu.queue.write_buffer(&self.buffers.probes, u64::from(run.0) * stride, bytemuck::cast_slice(&data));
        };
        for index in 0..self.layout.probe_count {
            if !entered(self.layout.probe_grid(index).as_ivec3()) {
                continue;
            }
            reset += 1;
            self.probe_data[index as usize] = DdgiProbeData::NEW;
            run = match run {
                Some((a, b)) if b == index => Some((a, index + 1)),
                Some(r) => {
                    flush(r);
                    Some((index, index + 1))
                }
                None => Some((index, index + 1)),
            };
        }
        if let Some(r) = run {
            flush(r);
        }
        self.scrolls += 1;
        self.last_scroll = Some((self.frames, cells, reset));
        reset
    }

    /// Lays the probes out again in render space after the [`RenderOrigin`](engine::scene::RenderOrigin) moved: the same grid
    /// at the same world place, so every probe keeps its maps.
    fn follow_render_origin(&mut self, origin: DVec3, limits: DdgiLimits) {
        if origin == self.render_origin {
            return;
        }
        self.render_origin = origin;
        // The same probes in the same storage: a scrolled volume keeps its shift.
        self.relayout(self.layout.scroll, limits);
    }

    /// The layout of `world_bounds` in render space (less `render_origin`), with the toroidal
    /// shift `scroll`; the buffers stay (the grid's size does not change).
    fn relayout(&mut self, scroll: glam::UVec3, limits: DdgiLimits) {
        let bounds = ((self.world_bounds.0 - self.render_origin).as_vec3(), (self.world_bounds.1 - self.render_origin).as_vec3());
        match DdgiLayout::new(&self.settings, bounds, limits) {
            Ok(layout) => self.layout = DdgiLayout { scroll, ..layout },
            Err(e) => log::error!("DDGI volume moved: {e}"),
        }
    }

    /// The state of probe `index` in the last probe data read back (active until the first
    /// readback).
    pub fn probe_state(&self, index: usize) -> DdgiProbeState {
        match self.probe_data.get(index) {
            Some(p) if p.state & PROBE_INACTIVE != 0 => DdgiProbeState::Inactive,
            _ => DdgiProbeState::Active,
        }
    }
}

/// The GPU state of every volume, by volume entity.
#[derive(Resource, Default)]
pub struct DdgiGpuVolumes {
    /// Every volume that lights the scene, with its entity, in gather order.
    pub volumes: Vec<(Entity, VolumeGpu)>,
    /// The last settings error of each volume entity (logged once).
    errors: HashMap<Entity, String>,
    /// Local bounds of each mesh, computed once.
    mesh_bounds: HashMap<u32, Option<(Vec3, Vec3)>>,
    /// The world-space bounds of the scene's instances, kept up to date while they change (in the
    /// world, so that they stay right when the render origin moves).
    scene_box: Option<(DVec3, DVec3)>,
    /// Each instance slot's last box (render space), for the wake-up around movers.
    instance_boxes: HashMap<u32, (Vec3, Vec3)>,
    scene_extent_known: bool,
    /// Warnings about the scene ([`divergence_warnings`]) and the material generation they are of.
    warnings: Vec<String>,
    warned_generation: Option<u64>,
    /// What the light of the scene was at the last frame, to see it change (the calm update
    /// period, [`crate::DdgiAdaptive::max_update_period`]): the lights as uploaded, the sky, and
    /// the generations of the meshes, materials and images.
    last_lighting: Option<(Vec<engine::render::gpu_types::GpuLight>, Option<engine::render::Sky>, [u64; 3])>,
}

/// Materials that reflect all the light they receive (albedo 1 in some channel). A closed scene of
/// such a material that emits (or is lit) is physically divergent: every frame adds one bounce,
/// so its indirect light grows without bound, by the first bounce's irradiance each frame. DDGI
/// keeps it finite (irradiance is clamped at [`MAX_IRRADIANCE`]) but not meaningful; these
/// warnings say so, one per material.
pub fn divergence_warnings(materials: &Assets<Material>, images: &Assets<Image>) -> Vec<String> {
    materials
        .iter()
        .filter_map(|(h, m)| {
            // A texture scales the factor by its texels: its mean (linear) is the surface's albedo.
            let texture = m.base_color_texture.as_ref().map_or(Some(Vec3::ONE), |t| images.get(t.image).map(mean_linear_texel));
            let albedo = m.base_color.truncate() * texture.unwrap_or(Vec3::ONE);
            (albedo.max_element() >= 1.0 - 1e-6).then_some((h, m, albedo.min(Vec3::ONE)))
        })
        .map(|(h, m, c)| {
            format!(
                "material {} '{}' has albedo ({}, {}, {}): it reflects all the light it receives, so in a closed scene the indirect \
                 light does not converge (it grows by one bounce every frame); DDGI clamps irradiance at {MAX_IRRADIANCE:e} W/m², \
                 which keeps it finite but not physical. Use an albedo below 1",
                h.index(),
                m.name,
                c.x,
                c.y,
                c.z
            )
        })
        .collect()
}

/// The mean of an sRGB-encoded texture's texels, decoded to linear.
fn mean_linear_texel(image: &Image) -> Vec3 {
    let decode = engine::color::srgb8_to_linear;
    let texels = image.rgba8.chunks_exact(4);
    let count = texels.len().max(1) as f32;
    texels.fold(Vec3::ZERO, |sum, t| sum + Vec3::new(decode(t[0]), decode(t[1]), decode(t[2]))) / count
}

impl DdgiGpuVolumes {
    /// The GPU state of `entity`'s volume, if it lights the scene.
    pub fn get(&self, entity: Entity) -> Option<&VolumeGpu> {
        self.volumes.iter().find(|(e, _)| *e == entity).map(|(_, v)| v)
    }

    /// The settings error that keeps `entity`'s volume from lighting the scene, if any.
    pub fn error(&self, entity: Entity) -> Option<&str> {
        self.errors.get(&entity).map(String::as_str)
    }

    /// Warnings about the scene's materials while a volume is on ([`divergence_warnings`]).
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The largest extent of the scene's instances' bounds (`None`: no geometry).
    pub fn scene_extent(&self) -> Option<f32> {
        self.scene_box.map(|(lo, hi)| (hi - lo).max_element() as f32)
    }

    /// The world-space bounds of the scene's instances as prepare last saw them (`None`: not known
    /// yet, or an empty scene).
    pub fn scene_box(&self) -> Option<(DVec3, DVec3)> {
        self.scene_box
    }

    /// The world-space bounds of the scene's instances for a render origin at `origin`: as prepare
    /// last saw them, or computed now when prepare has not run yet (the systems before it on the
    /// first frame).
    pub fn scene_box_or_compute(&mut self, scene: &GpuScene, meshes: &Assets<Mesh>, origin: DVec3) -> Option<(DVec3, DVec3)> {
        self.scene_box.or_else(|| self.scene_world_bounds(scene, meshes, origin))
    }

    /// [`DdgiGpuVolumes::scene_bounds`] in world space, for a render origin at `origin`.
    fn scene_world_bounds(&mut self, scene: &GpuScene, meshes: &Assets<Mesh>, origin: DVec3) -> Option<(DVec3, DVec3)> {
        self.scene_bounds(scene, meshes).map(|(lo, hi)| (origin + lo.as_dvec3(), origin + hi.as_dvec3()))
    }

    /// Any volume's settings error (for tools that run a single volume).
    pub fn first_error(&self) -> Option<&str> {
        self.errors.values().next().map(String::as_str)
    }

    /// The render-space bounds of the scene's instances.
    pub fn scene_bounds(&mut self, scene: &GpuScene, meshes: &Assets<Mesh>) -> Option<(Vec3, Vec3)> {
        let mut out: Option<(Vec3, Vec3)> = None;
        for (_, mesh, transform) in scene.live_instances() {
            if let Some((lo, hi)) = self.instance_box(mesh, &transform, meshes) {
                out = Some(out.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
            }
        }
        out
    }

    /// The render-space box of an instance of `mesh` placed by `transform`.
    fn instance_box(&mut self, mesh: u32, transform: &glam::Affine3A, meshes: &Assets<Mesh>) -> Option<(Vec3, Vec3)> {
        let local = *self.mesh_bounds.entry(mesh).or_insert_with(|| {
            meshes.iter().find(|(h, _)| h.index() == mesh).and_then(|(_, m)| m.bounds()).filter(|(a, b)| a.is_finite() && b.is_finite())
        });
        let (lo, hi) = local?;
        let mut out: Option<(Vec3, Vec3)> = None;
        for i in 0..8 {
            let corner =
                Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z });
            let p = transform.transform_point3(corner);
            out = Some(out.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
        }
        out
    }

    /// The boxes of the instances that moved this frame, where they were and where they are now
    /// (render space), and whether instances were added or removed. Keeps every written
    /// instance's box for its next move.
    fn mover_boxes(&mut self, scene: &GpuScene, meshes: &Assets<Mesh>) -> Vec<(Vec3, Vec3)> {
        let changes = scene.instance_changes();
        let moved: std::collections::HashSet<u32> = changes.moved.iter().copied().collect();
        let mut boxes = Vec::new();
        for &slot in &changes.dirty {
            let now = scene.instance_placement(slot).and_then(|(mesh, xf)| self.instance_box(mesh, &xf, meshes));
            let before = match now {
                Some(b) => self.instance_boxes.insert(slot, b),
                None => self.instance_boxes.remove(&slot),
            };
            if moved.contains(&slot) {
                boxes.extend(now.into_iter().chain(before));
            }
        }
        boxes
    }
}

mod prepare;

pub use prepare::{prepare_ddgi_volumes, scroll_cells};

#[cfg(test)]
mod tests {
    use super::*;
    use engine::scene::{TextureRef, UvTransform};

    #[test]
    fn albedo_one_warns_unless_a_texture_darkens_it() {
        let mut images = Assets::<Image>::default();
        let grey = images.add(Image { name: "grey".into(), width: 1, height: 1, rgba8: vec![128, 128, 128, 255] });
        let white = images.add(Image { name: "white".into(), width: 2, height: 1, rgba8: vec![255; 8] });
        let textured = |name: &str, image| Material {
            name: name.into(),
            base_color_texture: Some(TextureRef { image, transform: UvTransform::default(), filter: Default::default() }),
            ..Default::default()
        };
        let mut materials = Assets::<Material>::default();
        materials.add(Material { name: "plain_white".into(), ..Default::default() });
        materials.add(textured("grey_texture", grey));
        materials.add(textured("white_texture", white));
        materials.add(Material::diffuse("half", Vec3::splat(0.5)));
        let warnings = divergence_warnings(&materials, &images);
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!(warnings[0].contains("'plain_white'") && warnings[1].contains("'white_texture'"), "{warnings:?}");
    }
}

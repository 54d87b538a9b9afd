//! The GPU side: per-volume resources, the passes of the probe update, the camera's gather and
//! composite, the `"ddgi"` frame script and the asynchronous probe readback.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::graph::{Buffer as GraphBuffer, BufferDesc, Handle, RenderGraph, Texture as GraphTexture, TextureDesc};
use engine::render::gpu_scene::GpuScene;
use engine::render::{CameraFrame, DEPTH_FORMAT, HDR_FORMAT, SkyRadiance, dispatch};
use engine::rng::SplitMix64;
use engine::scene::{Assets, Image, Material, Mesh};
use engine::shader::{Program, RenderTargets, ShaderError, compute_program, compute_program_with_constants, render_program};
use engine::wgpu;
use glam::{Mat3, Quat, Vec3};

use crate::gpu::{
    DdgiBlock, DdgiCounters, DdgiGatherParams, DdgiProbeData, DdgiProbeViewParams, DdgiTexel, DdgiVolumeGpu, NO_PIN, PIN_ACTIVE,
    PIN_INACTIVE, PROBE_INACTIVE,
};
use crate::volume::{DdgiLayout, DdgiLimits, DdgiProbe, DdgiProbePin, DdgiProbeState, DdgiVolume};

/// Format of both atlases (irradiance perceptually encoded; distances
/// divided by the volume's distance scale, so half floats neither overflow nor lose precision at
/// any scene scale).
pub const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// Probes per block of the budget pass's prefix sum (its workgroup size).
const BUDGET_BLOCK: u32 = 256;
/// Where in [`DdgiCounters`] the indirect dispatches of the ray passes and of the per-probe passes are.
const RAY_DISPATCH_OFFSET: u64 = std::mem::offset_of!(DdgiCounters, dispatch) as u64;
const PROBE_DISPATCH_OFFSET: u64 = std::mem::offset_of!(DdgiCounters, probe_dispatch) as u64;

/// What the `"ddgi"` frame script writes into the image.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DdgiOutput {
    /// Direct light plus DDGI's indirect light.
    #[default]
    Full,
    /// DDGI's indirect light alone (albedo / π × irradiance).
    Indirect,
    /// Direct light alone (the probes still update; the gather is skipped).
    Direct,
    /// The G-buffer's albedo (debug view).
    Albedo,
    /// The G-buffer's normals as colours, 0.5 + 0.5 n (debug view).
    Normals,
}

impl DdgiOutput {
    pub const ALL: [DdgiOutput; 5] = [Self::Full, Self::Direct, Self::Indirect, Self::Albedo, Self::Normals];

    pub fn name(self) -> &'static str {
        match self {
            Self::Full => "full",
            Self::Indirect => "indirect light only",
            Self::Direct => "direct light only",
            Self::Albedo => "albedo",
            Self::Normals => "normals",
        }
    }

    /// The `debug_view` of `composite_debug`, for the outputs it draws.
    fn debug_view(self) -> Option<u32> {
        match self {
            Self::Full | Self::Indirect => None,
            Self::Direct => Some(1),
            Self::Albedo => Some(2),
            Self::Normals => Some(3),
        }
    }
}

/// What the probe debug view paints on each probe's sphere.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DdgiProbeColor {
    /// No spheres (the pass is left out).
    #[default]
    Off,
    /// The probe's irradiance in the direction of each point of the sphere.
    Irradiance,
    /// Green active, red inactive (inside geometry or dark), yellow fresh.
    State,
    /// Rays this frame, blue (none) to red (`max_rays`).
    Rays,
    /// Temporal error, blue (0) to red (`max_error`).
    Error,
}

impl DdgiProbeColor {
    pub const ALL: [DdgiProbeColor; 5] = [Self::Off, Self::Irradiance, Self::State, Self::Rays, Self::Error];

    pub fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Irradiance => "irradiance",
            Self::State => "state",
            Self::Rays => "ray budget",
            Self::Error => "temporal error",
        }
    }
}

/// The probe debug view: every probe of the first volume drawn as a small sphere in the image
/// (pass `ddgi_probe_spheres`, after the composite, depth-tested against the G-buffer). Costs one
/// instanced draw of 576 vertices per probe when on, nothing when off.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct DdgiProbeView {
    pub color: DdgiProbeColor,
    /// Sphere radius as a fraction of the smallest probe spacing.
    pub radius: f32,
    /// The highlighted probe (index in the volume).
    pub selected: Option<u32>,
    /// Temporal error drawn as the hottest colour.
    pub max_error: f32,
}

impl Default for DdgiProbeView {
    fn default() -> Self {
        Self { color: DdgiProbeColor::Off, radius: 0.12, selected: None, max_error: 0.1 }
    }
}

type ComputeProgram = Arc<Program<wgpu::ComputePipeline>>;

/// Which scene features the ray passes were compiled for (spot cones and emission lookups are left
/// out of scenes that have none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Specialization {
    spot_lights: bool,
    emissive: bool,
}

impl Specialization {
    fn note(self) -> String {
        let mut parts = Vec::new();
        if !self.spot_lights {
            parts.push("no spot-cone code (no spot lights)");
        }
        if !self.emissive {
            parts.push("no emission lookup (no emissive materials)");
        }
        if parts.is_empty() { String::new() } else { format!("specialized: {}", parts.join(", ")) }
    }
}

/// Pipelines of the DDGI passes.
#[derive(Resource)]
pub struct DdgiPipelines {
    plan: ComputeProgram,
    plan_scale: ComputeProgram,
    scale: ComputeProgram,
    plan_blocks: ComputeProgram,
    place: ComputeProgram,
    specialized: HashMap<Specialization, ComputeProgram>,
    update_irradiance: ComputeProgram,
    update: ComputeProgram,
    gather: ComputeProgram,
    composite: ComputeProgram,
    composite_indirect: ComputeProgram,
    composite_debug: ComputeProgram,
    /// Built on first use (the debug view is rarely on), with its vertices per sphere.
    probe_spheres: Option<(Arc<Program<wgpu::RenderPipeline>>, u32)>,
    sampler: wgpu::Sampler,
}

impl DdgiPipelines {
    pub fn new(gpu: &GpuContext) -> Result<Self, ShaderError> {
        let p = |file: &str, entry: &str| compute_program(&gpu.device, file, entry, entry).map(Arc::new);
        Ok(Self {
            plan: p("ddgi_rays.wgsl", "plan_rays")?,
            plan_scale: p("ddgi_rays.wgsl", "plan_budget_scale")?,
            scale: p("ddgi_rays.wgsl", "scale_rays")?,
            plan_blocks: p("ddgi_rays.wgsl", "plan_ray_blocks")?,
            place: p("ddgi_rays.wgsl", "place_rays")?,
            specialized: HashMap::new(),
            update_irradiance: p("ddgi_update.wgsl", "update_irradiance_maps")?,
            update: p("ddgi_update.wgsl", "update_probes")?,
            gather: p("ddgi_gather.wgsl", "gather_irradiance")?,
            composite: p("ddgi_gather.wgsl", "composite")?,
            composite_indirect: p("ddgi_gather.wgsl", "composite_indirect")?,
            composite_debug: p("ddgi_gather.wgsl", "composite_debug")?,
            probe_spheres: None,
            sampler: gpu.device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("ddgi_sampler"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
        })
    }

    /// The probe debug view's pipeline (built on first use).
    fn probe_spheres_program(&mut self, gpu: &GpuContext) -> Result<(Arc<Program<wgpu::RenderPipeline>>, u32), ShaderError> {
        if let Some(p) = &self.probe_spheres {
            return Ok(p.clone());
        }
        let vertices = probe_sphere_vertices()?;
        let program = render_program(
            &gpu.device,
            "ddgi_probes.wgsl",
            "ddgi_probe_spheres",
            RenderTargets {
                colors: &[Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                depth: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Greater),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                primitive: wgpu::PrimitiveState { cull_mode: Some(wgpu::Face::Back), ..Default::default() },
            },
        )?;
        let program = (Arc::new(program), vertices);
        self.probe_spheres = Some(program.clone());
        Ok(program)
    }

    /// The trace-and-shading pipeline compiled for `s` (built on first use).
    fn trace_program(&mut self, gpu: &GpuContext, s: Specialization) -> Result<ComputeProgram, ShaderError> {
        if let Some(p) = self.specialized.get(&s) {
            return Ok(p.clone());
        }
        let constants =
            [("SCENE_HAS_SPOT_LIGHTS", f64::from(u8::from(s.spot_lights))), ("SCENE_HAS_EMISSIVE", f64::from(u8::from(s.emissive)))];
        let program = Arc::new(compute_program_with_constants(&gpu.device, "ddgi_rays.wgsl", "trace_rays", "trace_rays", &constants)?);
        self.specialized.insert(s, program.clone());
        Ok(program)
    }
}

/// The GPU resources and state of one volume.
pub struct VolumeGpu {
    pub layout: DdgiLayout,
    /// The settings the resources were made for.
    pub settings: DdgiVolume,
    pub uniform: wgpu::Buffer,
    pub probes: wgpu::Buffer,
    /// The budget pass's results: the indirect dispatches of the ray passes and of the per-probe
    /// passes, the ray count and the count of probes with rays.
    pub counters: wgpu::Buffer,
    /// The budget pass's per-block sums (one `DdgiBlock` per 256 probes).
    blocks: wgpu::Buffer,
    /// The probes with rays this frame, listed by the budget pass for the per-probe passes.
    updated: wgpu::Buffer,
    /// Each probe's luma (−1: switched off) as the budget pass found it, for the dark test.
    lit: wgpu::Buffer,
    pub rays: wgpu::Buffer,
    pub radiance: wgpu::Buffer,
    /// The maps at full precision (see `ddgi.inc.wgsl`): irradiance and its smoothed change (two
    /// vec4 per texel) and distance moments (vec2 per texel), in probe order.
    pub irradiance_history: wgpu::Buffer,
    pub distance_history: wgpu::Buffer,
    /// The atlases that sampling reads (half floats, irradiance perceptually encoded).
    pub irradiance: wgpu::Texture,
    pub distance: wgpu::Texture,
    views: [wgpu::TextureView; 2],
    /// Frames updated so far.
    pub frames: u64,
    rng: SplitMix64,
    /// The probe entities, by probe index.
    pub probe_entities: Vec<Entity>,
    readback: ReadbackRing,
    counter_readback: ReadbackRing,
    /// The last probe data read back (offsets and states), by probe index.
    pub probe_data: Vec<DdgiProbeData>,
}

impl VolumeGpu {
    fn new(gpu: &GpuContext, settings: &DdgiVolume, layout: DdgiLayout) -> Self {
        use wgpu::BufferUsages as B;
        let device = &gpu.device;
        let buffer = |label: &str, size: u64, usage: B| {
            device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: size.max(16), usage, mapped_at_creation: false })
        };
        let rays = u64::from(layout.probe_count) * u64::from(settings.rays_per_probe) * crate::volume::BYTES_PER_RAY;
        let probe_bytes = size_of::<DdgiProbeData>() as u64;
        let probes = buffer("ddgi_probes", u64::from(layout.probe_count) * probe_bytes, B::STORAGE | B::COPY_SRC | B::COPY_DST);
        let initial = vec![DdgiProbeData::NEW; layout.probe_count as usize];
        gpu.queue.write_buffer(&probes, 0, bytemuck::cast_slice(&initial));
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
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let views = [view(&irradiance), view(&distance)];
        let texels = |n: u32| u64::from(layout.probe_count) * u64::from(n * n);
        Self {
            uniform: buffer("ddgi_volume", size_of::<DdgiVolumeGpu>() as u64, B::UNIFORM | B::COPY_DST),
            probes,
            counters: buffer("ddgi_counters", size_of::<DdgiCounters>() as u64, B::STORAGE | B::INDIRECT | B::COPY_SRC),
            blocks: buffer("ddgi_blocks", u64::from(layout.probe_count.div_ceil(BUDGET_BLOCK)) * size_of::<DdgiBlock>() as u64, B::STORAGE),
            updated: buffer("ddgi_updated", u64::from(layout.probe_count) * 4, B::STORAGE),
            lit: buffer("ddgi_lit", u64::from(layout.probe_count) * 4, B::STORAGE),
            rays: buffer("ddgi_rays", rays, B::STORAGE | B::COPY_SRC),
            radiance: buffer("ddgi_radiance", rays, B::STORAGE | B::COPY_SRC),
            irradiance_history: buffer(
                "ddgi_irradiance_history",
                texels(layout.irradiance_texels) * size_of::<DdgiTexel>() as u64,
                B::STORAGE,
            ),
            distance_history: buffer("ddgi_distance_history", texels(layout.distance_texels) * 8, B::STORAGE),
            irradiance,
            distance,
            views,
            frames: 0,
            rng: SplitMix64::new(settings.seed),
            probe_entities: Vec::new(),
            readback: ReadbackRing::new(3),
            counter_readback: ReadbackRing::new(8),
            probe_data: initial,
            settings: settings.clone(),
            layout,
        }
    }

    /// Group 1 resources by WGSL name (each pipeline's layout takes those it uses).
    fn bindings<'a>(&'a self, sampler: &'a wgpu::Sampler) -> Vec<(&'static str, wgpu::BindingResource<'a>)> {
        let [irradiance, distance] = &self.views;
        vec![
            ("ddgi_volume", self.uniform.as_entire_binding()),
            ("ddgi_probes", self.probes.as_entire_binding()),
            ("ddgi_irradiance", wgpu::BindingResource::TextureView(irradiance)),
            ("ddgi_distance", wgpu::BindingResource::TextureView(distance)),
            ("ddgi_sampler", wgpu::BindingResource::Sampler(sampler)),
            ("ddgi_rays", self.rays.as_entire_binding()),
            ("ddgi_radiance", self.radiance.as_entire_binding()),
            ("ddgi_irradiance_history", self.irradiance_history.as_entire_binding()),
            ("ddgi_distance_history", self.distance_history.as_entire_binding()),
            ("ddgi_irradiance_out", wgpu::BindingResource::TextureView(irradiance)),
            ("ddgi_distance_out", wgpu::BindingResource::TextureView(distance)),
            ("ddgi_counters", self.counters.as_entire_binding()),
            ("ddgi_counters_in", self.counters.as_entire_binding()),
            ("ddgi_blocks", self.blocks.as_entire_binding()),
            ("ddgi_updated", self.updated.as_entire_binding()),
            ("ddgi_lit", self.lit.as_entire_binding()),
        ]
    }

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
    pub volumes: Vec<(Entity, VolumeGpu)>,
    /// The last settings error of each volume entity (logged once).
    errors: HashMap<Entity, String>,
    /// Local bounds of each mesh, computed once.
    mesh_bounds: HashMap<u32, Option<(Vec3, Vec3)>>,
    /// Warnings about the scene ([`divergence_warnings`]) and the material generation they are of.
    warnings: Vec<String>,
    warned_generation: Option<u64>,
}

/// Largest irradiance (W/m²) a probe map holds (`DDGI_MAX_IRRADIANCE` in `ddgi.inc.wgsl`): the
/// documented clamp that keeps a diverging scene finite.
pub const MAX_IRRADIANCE: f32 = 1.0e24;

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

    /// Any volume's settings error (for tools that run a single volume).
    pub fn first_error(&self) -> Option<&str> {
        self.errors.values().next().map(String::as_str)
    }

    fn scene_bounds(&mut self, scene: &GpuScene, meshes: &Assets<Mesh>) -> Option<(Vec3, Vec3)> {
        let mut out: Option<(Vec3, Vec3)> = None;
        for (_, mesh, transform) in scene.live_instances() {
            let local = *self.mesh_bounds.entry(mesh).or_insert_with(|| {
                meshes.iter().find(|(h, _)| h.index() == mesh).and_then(|(_, m)| m.bounds()).filter(|(a, b)| a.is_finite() && b.is_finite())
            });
            let Some((lo, hi)) = local else { continue };
            for i in 0..8 {
                let corner = Vec3::new(
                    if i & 1 == 0 { lo.x } else { hi.x },
                    if i & 2 == 0 { lo.y } else { hi.y },
                    if i & 4 == 0 { lo.z } else { hi.z },
                );
                let p = transform.transform_point3(corner);
                out = Some(out.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
            }
        }
        out
    }
}

fn random_rotation(rng: &mut SplitMix64) -> Mat3 {
    // Shoemake's uniform random unit quaternion.
    let (u1, u2, u3) = (rng.unit(), rng.unit() * std::f32::consts::TAU, rng.unit() * std::f32::consts::TAU);
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    Mat3::from_quat(Quat::from_xyzw(a * u2.sin(), a * u2.cos(), b * u3.sin(), b * u3.cos()).normalize())
}

/// Whether two settings need the same resources (probe layout, ray count, map sizes).
fn same_resources(a: &DdgiVolume, b: &DdgiVolume) -> bool {
    a.bounds == b.bounds
        && a.probe_counts == b.probe_counts
        && a.rays_per_probe == b.rays_per_probe
        && a.irradiance_texels == b.irradiance_texels
        && a.distance_texels == b.distance_texels
        && a.seed == b.seed
}

/// Prepare stage: creates (or re-creates, when the layout changes) each volume's resources and its
/// probe entities, and writes this frame's uniform (a new random rotation of the rays, re-check
/// flag).
#[allow(clippy::too_many_arguments)]
pub fn prepare_ddgi_volumes(
    mut commands: Commands,
    gpu: Res<GpuContext>,
    scene: Res<GpuScene>,
    sky: Res<SkyRadiance>,
    meshes: Res<Assets<Mesh>>,
    materials: Res<Assets<Material>>,
    images: Res<Assets<Image>>,
    volumes: Query<(Entity, &DdgiVolume)>,
    mut state: ResMut<DdgiGpuVolumes>,
) {
    let state = &mut *state;
    if !volumes.is_empty() && state.warned_generation != Some(materials.generation()) {
        state.warned_generation = Some(materials.generation());
        let warnings = divergence_warnings(&materials, &images);
        for w in warnings.iter().filter(|w| !state.warnings.contains(w)) {
            log::warn!("DDGI: {w}");
        }
        state.warnings = warnings;
    }
    state.volumes.retain(|(e, v)| {
        let keep = volumes.get(*e).is_ok();
        if !keep {
            for &probe in &v.probe_entities {
                commands.entity(probe).try_despawn();
            }
        }
        keep
    });
    let mut list: Vec<(Entity, &DdgiVolume)> = volumes.iter().collect();
    list.sort_by_key(|(e, _)| *e);
    let scene_changed = {
        let c = scene.instance_changes();
        c.structure_changed || !c.moved.is_empty()
    };
    for (entity, volume) in list {
        let existing = state.volumes.iter().position(|(e, _)| *e == entity);
        let rebuild = existing.is_none_or(|i| !same_resources(&state.volumes[i].1.settings, volume));
        if rebuild {
            let bounds = match volume.bounds {
                Some(b) => Some(b),
                None => state.scene_bounds(&scene, &meshes),
            };
            let layout = bounds
                .ok_or(crate::volume::DdgiSettingsError::NoBounds)
                .and_then(|b| DdgiLayout::new(volume, b, DdgiLimits::of(&gpu.device)));
            let old = existing.map(|i| state.volumes.remove(i));
            if let Some((_, old)) = &old {
                for &probe in &old.probe_entities {
                    commands.entity(probe).try_despawn();
                }
            }
            let layout = match layout {
                Ok(l) => {
                    state.errors.remove(&entity);
                    l
                }
                Err(e) => {
                    let message = e.to_string();
                    if state.errors.get(&entity) != Some(&message) {
                        log::error!("DDGI volume {entity}: {message}; the volume is off");
                    }
                    state.errors.insert(entity, message);
                    continue;
                }
            };
            let mut v = VolumeGpu::new(&gpu, volume, layout);
            v.probe_entities = (0..v.layout.probe_count)
                .map(|i| {
                    commands
                        .spawn(DdgiProbe {
                            volume: entity,
                            grid: v.layout.probe_grid(i),
                            index: i,
                            offset: Vec3::ZERO,
                            position: v.layout.grid_position(i),
                            state: DdgiProbeState::Active,
                            ray_count: volume.rays_per_probe,
                            error: 0.0,
                            resting_frames: 0,
                        })
                        .id()
                })
                .collect();
            state.volumes.push((entity, v));
            state.volumes.sort_by_key(|(e, _)| *e);
        }
        let Some((_, v)) = state.volumes.iter_mut().find(|(e, _)| *e == entity) else { continue };
        v.settings = volume.clone();
        let interval = u64::from(volume.recheck_interval);
        let recheck = scene_changed || (interval > 0 && v.frames % interval == 0);
        let rotation = random_rotation(&mut v.rng);
        let uniform = DdgiVolumeGpu::new(volume, &v.layout, rotation, volume.sky_radiance.unwrap_or(sky.0), recheck);
        gpu.queue.write_buffer(&v.uniform, 0, bytemuck::bytes_of(&uniform));
    }
}

/// Handles of one volume's persistent resources in a frame's graph.
pub struct VolumeHandles {
    pub probes: Handle<GraphBuffer>,
    pub irradiance: Handle<GraphTexture>,
    pub distance: Handle<GraphTexture>,
}

/// Adds the probe update of one volume to `graph`: budget → trace (ray generation and shading
/// included) → probe update (maps, atlas tiles, relocation, classification). `suffix` tells apart
/// the labels of several volumes.
fn add_volume_update(
    graph: &mut RenderGraph,
    gpu: &GpuContext,
    scene_bindings: &[(&'static str, wgpu::BindingResource<'_>)],
    pipelines: &mut DdgiPipelines,
    specialization: Specialization,
    volume: &VolumeGpu,
    suffix: &str,
) -> Result<VolumeHandles, ShaderError> {
    let device = &gpu.device;
    let label = |name: &str| format!("{name}{suffix}");
    let mut probes = graph.import_buffer(&label("ddgi_probes"), &volume.probes);
    let mut counters = graph.import_buffer(&label("ddgi_counters"), &volume.counters);
    let mut rays = graph.import_buffer(&label("ddgi_rays"), &volume.rays);
    let mut radiance = graph.import_buffer(&label("ddgi_radiance"), &volume.radiance);
    let mut irradiance = graph.import_texture(&label("ddgi_irradiance"), &volume.irradiance);
    let mut distance = graph.import_texture(&label("ddgi_distance"), &volume.distance);
    let mut irradiance_history = graph.import_buffer(&label("ddgi_irradiance_history"), &volume.irradiance_history);
    let mut distance_history = graph.import_buffer(&label("ddgi_distance_history"), &volume.distance_history);
    let trace = pipelines.trace_program(gpu, specialization)?;
    let sampler = &pipelines.sampler;

    // Each pass: its program, group 0 (the scene) when it uses it, group 1 (the volume).
    let groups = |program: &ComputeProgram, group1: &[(&'static str, wgpu::BindingResource<'_>)]| -> Vec<wgpu::BindGroup> {
        let mut g = Vec::new();
        if program.uses_group(0) {
            g.push(program.bind_group(device, 0, scene_bindings));
        } else {
            g.push(device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("empty"),
                layout: &program.pipeline.get_bind_group_layout(0),
                entries: &[],
            }));
        }
        g.push(program.bind_group(device, 1, group1));
        g
    };
    let common = volume.bindings(sampler);
    // The trace runs as many threads as the budget pass packed rays, the probe update one workgroup
    // per probe it gave rays (indirect dispatches, from `DdgiCounters`).
    let indirect = |programs: Vec<(ComputeProgram, Vec<wgpu::BindGroup>)>, offset: u64| {
        let args = volume.counters.clone();
        move |ctx: &mut engine::graph::PassContext<'_>| {
            let mut cp = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(ctx.label), timestamp_writes: None });
            for (program, bind) in &programs {
                cp.set_pipeline(&program.pipeline);
                for (i, g) in bind.iter().enumerate() {
                    cp.set_bind_group(i as u32, g, &[]);
                }
                cp.dispatch_workgroups_indirect(&args, offset);
            }
        }
    };
    let with_groups = |program: &ComputeProgram| (program.clone(), groups(program, &common));

    {
        let mut pass = graph.add_pass(&label("ddgi_budget"));
        pass.read(&probes);
        pass.write(&mut probes);
        pass.write(&mut counters);
        if volume.settings.adaptive.enabled {
            pass.note("adaptive: rays by each probe's temporal error");
        }
        let blocks = volume.layout.probe_count.div_ceil(BUDGET_BLOCK);
        // Without a frame budget the planned rays stand: the two scaling steps are left out.
        let frame_budget = volume.settings.adaptive.enabled && volume.settings.adaptive.frame_budget.is_some();
        let mut plan = vec![(&pipelines.plan, blocks)];
        if frame_budget {
            plan.extend([(&pipelines.plan_scale, 1), (&pipelines.scale, blocks)]);
        }
        plan.extend([(&pipelines.plan_blocks, 1), (&pipelines.place, blocks)]);
        let steps: Vec<(ComputeProgram, Vec<wgpu::BindGroup>, u32)> =
            plan.into_iter().map(|(p, n)| (p.clone(), groups(p, &common), n)).collect();
        pass.render(move |ctx| {
            let mut cp = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(ctx.label), timestamp_writes: None });
            for (program, bind, n) in &steps {
                cp.set_pipeline(&program.pipeline);
                for (i, g) in bind.iter().enumerate() {
                    cp.set_bind_group(i as u32, g, &[]);
                }
                cp.dispatch_workgroups(*n, 1, 1);
            }
        });
    }
    {
        // Shading reads the previous frame's atlases, which the probe update then overwrites.
        let mut pass = graph.add_pass(&label("ddgi_trace"));
        pass.read(&probes);
        pass.read(&counters);
        pass.read(&irradiance);
        pass.read(&distance);
        pass.write(&mut rays);
        pass.write(&mut radiance);
        pass.note(&specialization.note());
        pass.render(indirect(vec![with_groups(&trace)], RAY_DISPATCH_OFFSET));
    }
    {
        let mut pass = graph.add_pass(&label("ddgi_probe_update"));
        for r in [&probes, &counters, &rays, &radiance, &irradiance_history, &distance_history] {
            pass.read(r);
        }
        pass.write(&mut irradiance_history);
        pass.write(&mut distance_history);
        // Each atlas is read (the trace's shading) and written (here) in one frame but never in one
        // dispatch, so a single copy of each suffices.
        pass.write(&mut irradiance);
        pass.write(&mut distance);
        pass.write(&mut probes);
        if !volume.settings.relocation {
            pass.note("relocation off in the volume's settings");
        }
        if !volume.settings.classification {
            pass.note("classification off: only clears the fresh-probe flags");
        }
        // Two dispatches: the irradiance maps (and each probe's error), then the rest.
        let programs = vec![with_groups(&pipelines.update_irradiance), with_groups(&pipelines.update)];
        pass.render(indirect(programs, PROBE_DISPATCH_OFFSET));
    }
    // The maps and probe states live on into the next frame.
    graph.export(&probes);
    graph.export(&irradiance);
    graph.export(&distance);
    Ok(VolumeHandles { probes, irradiance, distance })
}

/// Render stage: the `"ddgi"` frame script — G-buffer, direct light, each volume's probe update,
/// the final gather of every volume, the composite, then the engine's tonemap and present.
pub fn render_ddgi_frame(
    mut frame: CameraFrame,
    mut pipelines: ResMut<DdgiPipelines>,
    mut volumes: ResMut<DdgiGpuVolumes>,
    output: Res<DdgiOutput>,
    probe_view: Option<Res<DdgiProbeView>>,
) {
    let size = frame.size();
    let gpu = frame.gpu.clone();
    let specialization = Specialization { spot_lights: frame.scene.has_spot_lights, emissive: frame.scene.has_emissive };
    let mut script = frame.begin();
    let mut gbuffer = frame.add_gbuffer(&mut script.graph);
    let mut direct = script.graph.create_texture(
        "ddgi_direct",
        TextureDesc {
            width: size.width,
            height: size.height,
            format: HDR_FORMAT,
            usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
        },
    );
    frame.add_direct_lighting(&mut script.graph, &gbuffer, &mut direct);
    let scene_bindings = frame.scene_bindings();
    let several = volumes.volumes.len() > 1;
    let mut handles = Vec::new();
    for (k, (_, volume)) in volumes.volumes.iter().enumerate() {
        let suffix = if several { format!("_{k}") } else { String::new() };
        match add_volume_update(&mut script.graph, &gpu, &scene_bindings, &mut pipelines, specialization, volume, &suffix) {
            Ok(h) => handles.push((k, suffix, h)),
            Err(e) => log::error!("DDGI pipelines failed, the volume is off: {e}"),
        }
    }

    let pixels = u64::from(size.width.max(1)) * u64::from(size.height.max(1));
    let mut indirect = script.graph.create_buffer(
        "ddgi_indirect",
        BufferDesc { size: pixels * 16, usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST },
    );
    let device = &gpu.device;
    let params = |first: bool| {
        let p = DdgiGatherParams { first_volume: u32::from(first), debug_view: output.debug_view().unwrap_or(0), _pad1: 0, _pad2: 0 };
        let b = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ddgi_gather_params"),
            size: size_of::<DdgiGatherParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.queue.write_buffer(&b, 0, bytemuck::bytes_of(&p));
        b
    };
    let workgroups = (size.width.div_ceil(8), size.height.div_ceil(8));
    if handles.is_empty() {
        // No volume: the indirect term is zero.
        let mut pass = script.graph.add_pass("ddgi_clear_indirect");
        let out = pass.write(&mut indirect);
        pass.render(move |ctx| ctx.encoder.clear_buffer(ctx.buffer(out), 0, None));
    }
    // The debug views read no indirect light: the gather (which also marks the probes the view
    // needs, so it writes the exported probe states and would otherwise always run) is left out.
    let reads_indirect = output.debug_view().is_none();
    for (i, (k, suffix, h)) in handles.iter_mut().enumerate() {
        let volume = &volumes.volumes[*k].1;
        if !reads_indirect {
            script.graph.leave_out(&format!("ddgi_gather{suffix}"), "the view reads no indirect light");
            continue;
        }
        let mut pass = script.graph.add_pass(&format!("ddgi_gather{suffix}"));
        pass.read(&h.probes);
        // Marks the switched-off probes that the view depends on (DDGI_PROBE_SEEN).
        pass.write(&mut h.probes);
        pass.read(&h.irradiance);
        pass.read(&h.distance);
        if i > 0 {
            pass.read(&indirect);
        }
        let out = pass.write(&mut indirect);
        let (depth, normal) = (pass.read(&gbuffer.depth), pass.read(&gbuffer.normal));
        let program = pipelines.gather.clone();
        let group0 = program.bind_group(device, 0, &scene_bindings);
        let group1 = program.bind_group(device, 1, &volume.bindings(&pipelines.sampler));
        let params = params(i == 0);
        pass.render(move |ctx| {
            let group2 = program.bind_group(
                &ctx.gpu.device,
                2,
                &[
                    ("ddgi_gather_params", params.as_entire_binding()),
                    ("gbuffer_depth", wgpu::BindingResource::TextureView(ctx.view(depth))),
                    ("gbuffer_normal", wgpu::BindingResource::TextureView(ctx.view(normal))),
                    ("ddgi_indirect", ctx.buffer(out).as_entire_binding()),
                ],
            );
            dispatch(ctx.encoder, ctx.label, &program.pipeline, &[&group0, &group1, &group2], workgroups);
        });
    }
    {
        // What the composite reads depends on the output: `composite` direct + indirect,
        // `composite_indirect` the indirect light alone, `composite_debug` direct light, albedo or
        // normals. When it reads no gathered light, nobody does: the graph leaves the gather out.
        let debug = output.debug_view().is_some();
        let full = *output == DdgiOutput::Full;
        let mut pass = script.graph.add_pass("ddgi_composite");
        let mut textures = vec![("gbuffer_depth", pass.read(&gbuffer.depth)), ("gbuffer_albedo", pass.read(&gbuffer.albedo))];
        if debug {
            textures.push(("gbuffer_normal", pass.read(&gbuffer.normal)));
        }
        if full || debug {
            textures.push(("direct_in", pass.read(&direct)));
        }
        let indirect_in = (!debug).then(|| pass.read(&indirect));
        let out = pass.write(&mut script.hdr);
        if !full {
            pass.note(output.name());
        }
        let program = match (debug, full) {
            (true, _) => pipelines.composite_debug.clone(),
            (false, true) => pipelines.composite.clone(),
            (false, false) => pipelines.composite_indirect.clone(),
        };
        let group0 = program.bind_group(device, 0, &scene_bindings);
        let params = params(true);
        pass.render(move |ctx| {
            let mut entries = vec![
                ("ddgi_gather_params", params.as_entire_binding()),
                ("radiance_out", wgpu::BindingResource::TextureView(ctx.view(out))),
            ];
            entries.extend(textures.iter().map(|&(name, t)| (name, wgpu::BindingResource::TextureView(ctx.view(t)))));
            if let Some(acc) = indirect_in {
                entries.push(("ddgi_indirect", ctx.buffer(acc).as_entire_binding()));
            }
            let group2 = program.bind_group(&ctx.gpu.device, 2, &entries);
            let empty = ctx.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("empty"),
                layout: &program.pipeline.get_bind_group_layout(1),
                entries: &[],
            });
            dispatch(ctx.encoder, ctx.label, &program.pipeline, &[&group0, &empty, &group2], workgroups);
        });
    }
    if let (Some(view), Some((k, _, h))) = (probe_view.filter(|v| v.color != DdgiProbeColor::Off), handles.first()) {
        let volume = &volumes.volumes[*k].1;
        match pipelines.probe_spheres_program(&gpu) {
            Ok((program, vertices)) => add_probe_spheres(
                &mut script.graph,
                &gpu,
                (&program, vertices),
                &scene_bindings,
                &pipelines.sampler,
                volume,
                h,
                &mut gbuffer.depth,
                &mut script.hdr,
                &view,
            ),
            Err(e) => log::error!("DDGI probe view: {e}"),
        }
    }
    drop(scene_bindings);
    frame.finish(script);
    let frame_index = frame.time.frame;
    for (_, v) in volumes.volumes.iter_mut() {
        v.frames += 1;
        v.readback.request(&gpu, &v.probes, frame_index);
        v.counter_readback.request(&gpu, &v.counters, frame_index);
    }
}

/// Vertices of one probe sphere: two triangles per ring × segment of `ddgi_probes.wgsl`.
pub fn probe_sphere_vertices() -> Result<u32, ShaderError> {
    let parsed = engine::shader::parse("ddgi_probes.wgsl")?;
    let missing = |name: &str| ShaderError::Missing(format!("ddgi_probes.wgsl: const {name}"));
    let rings = parsed.u32_constant("SPHERE_RINGS").ok_or_else(|| missing("SPHERE_RINGS"))?;
    let segments = parsed.u32_constant("SPHERE_SEGMENTS").ok_or_else(|| missing("SPHERE_SEGMENTS"))?;
    Ok(6 * rings * segments)
}

/// The probe debug view's pass: one sphere per probe of `volume`, rasterized into `hdr` with the
/// G-buffer's depth.
#[allow(clippy::too_many_arguments)]
fn add_probe_spheres(
    graph: &mut RenderGraph,
    gpu: &GpuContext,
    (program, vertices): (&Arc<Program<wgpu::RenderPipeline>>, u32),
    scene_bindings: &[(&'static str, wgpu::BindingResource<'_>)],
    sampler: &wgpu::Sampler,
    volume: &VolumeGpu,
    handles: &VolumeHandles,
    depth: &mut Handle<GraphTexture>,
    hdr: &mut Handle<GraphTexture>,
    view: &DdgiProbeView,
) {
    let spacing = volume.layout.spacing.min_element().max(0.0);
    let params = DdgiProbeViewParams {
        mode: match view.color {
            DdgiProbeColor::Off | DdgiProbeColor::Irradiance => 1,
            DdgiProbeColor::State => 2,
            DdgiProbeColor::Rays => 3,
            DdgiProbeColor::Error => 4,
        },
        selected: view.selected.unwrap_or(u32::MAX),
        radius: view.radius.clamp(0.0, 0.5) * spacing,
        max_rays: volume.settings.rays_per_probe as f32,
        max_error: view.max_error,
        ..Default::default()
    };
    let uniform = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("ddgi_probe_view"),
        size: size_of::<DdgiProbeViewParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
    let mut pass = graph.add_pass("ddgi_probe_spheres");
    pass.note(view.color.name());
    pass.read(&handles.probes);
    pass.read(&handles.irradiance);
    pass.read(hdr);
    pass.read(depth);
    let color = pass.write(hdr);
    let depth = pass.write(depth);
    let program = program.clone();
    let group0 = program.bind_group(&gpu.device, 0, scene_bindings);
    let group1 = program.bind_group(&gpu.device, 1, &volume.bindings(sampler));
    let group2 = program.bind_group(
        &gpu.device,
        2,
        &[("ddgi_probe_view", uniform.as_entire_binding()), ("ddgi_probe_view_probes", volume.probes.as_entire_binding())],
    );
    let count = volume.layout.probe_count;
    pass.render(move |ctx| {
        let mut rp = ctx.encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some(ctx.label),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: ctx.view(color),
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: ctx.view(depth),
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        rp.set_pipeline(&program.pipeline);
        rp.set_bind_group(0, &group0, &[]);
        rp.set_bind_group(1, &group1, &[]);
        rp.set_bind_group(2, &group2, &[]);
        rp.draw(0..vertices, 0..count);
    });
}

// ---------------------------------------------------------------------------------------------
// Asynchronous readback of the probe states and the ray counts into the ECS.

const SLOT_IDLE: u8 = 0;
const SLOT_PENDING: u8 = 1;
const SLOT_READY: u8 = 2;

struct ReadbackSlot {
    buffer: wgpu::Buffer,
    state: Arc<AtomicU8>,
    frame: u64,
}

/// A ring of mappable copies of a buffer: a copy is requested per frame while a slot is free, and
/// read when the GPU has filled it. Nothing waits.
struct ReadbackRing {
    capacity: usize,
    slots: Vec<ReadbackSlot>,
}

impl ReadbackRing {
    fn new(capacity: usize) -> Self {
        Self { capacity, slots: Vec::new() }
    }

    fn request(&mut self, gpu: &GpuContext, source: &wgpu::Buffer, frame: u64) {
        if self.slots.is_empty() {
            self.slots = (0..self.capacity)
                .map(|_| ReadbackSlot {
                    buffer: gpu.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("ddgi_readback"),
                        size: source.size(),
                        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    }),
                    state: Arc::new(AtomicU8::new(SLOT_IDLE)),
                    frame: 0,
                })
                .collect();
        }
        let Some(slot) = self.slots.iter_mut().find(|s| s.state.load(Ordering::Acquire) == SLOT_IDLE) else { return };
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ddgi_readback") });
        encoder.copy_buffer_to_buffer(source, 0, &slot.buffer, 0, source.size());
        gpu.queue.submit([encoder.finish()]);
        slot.frame = frame;
        slot.state.store(SLOT_PENDING, Ordering::Release);
        let flag = slot.state.clone();
        slot.buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            flag.store(if r.is_ok() { SLOT_READY } else { SLOT_IDLE }, Ordering::Release);
        });
    }

    /// Every copy that has arrived, as (frame, bytes), oldest first.
    fn poll(&mut self, gpu: &GpuContext) -> Vec<(u64, Vec<u8>)> {
        let _ = gpu.device.poll(wgpu::PollType::Poll);
        let mut out = Vec::new();
        for slot in &mut self.slots {
            if slot.state.load(Ordering::Acquire) != SLOT_READY {
                continue;
            }
            if let Ok(view) = slot.buffer.slice(..).get_mapped_range() {
                out.push((slot.frame, view.to_vec()));
            }
            slot.buffer.unmap();
            slot.state.store(SLOT_IDLE, Ordering::Release);
        }
        out.sort_by_key(|(f, _)| *f);
        out
    }
}

/// Prepare stage: copies the probe states that have come back from the GPU into the
/// [`DdgiProbe`] components (only those that changed, so change detection stays meaningful), and
/// the rays traced and the probes updated per frame into the frame timings (`ddgi_rays`,
/// `ddgi_probes_updated`).
pub fn read_back_ddgi_probes(
    gpu: Res<GpuContext>,
    mut volumes: ResMut<DdgiGpuVolumes>,
    mut probes: Query<&mut DdgiProbe>,
    mut timings: ResMut<engine::render::FrameTimings>,
) {
    let several = volumes.volumes.len() > 1;
    for (k, (_, v)) in volumes.volumes.iter_mut().enumerate() {
        for (frame, bytes) in v.counter_readback.poll(&gpu) {
            if let Ok(c) = bytemuck::try_pod_read_unaligned::<DdgiCounters>(&bytes[..size_of::<DdgiCounters>().min(bytes.len())]) {
                let name = |base: &str| if several { format!("{base}_{k}") } else { base.to_string() };
                timings.record_counter(frame, &name("ddgi_rays"), f64::from(c.total_rays));
                timings.record_counter(frame, &name("ddgi_probes_updated"), f64::from(c.updated_probes));
            }
        }
        let Some((_, bytes)) = v.readback.poll(&gpu).pop() else { continue };
        let data: Vec<DdgiProbeData> = bytemuck::pod_collect_to_vec(&bytes);
        if data.len() < v.layout.probe_count as usize {
            continue;
        }
        v.probe_data = data;
        for (i, &entity) in v.probe_entities.iter().enumerate() {
            let Ok(mut probe) = probes.get_mut(entity) else { continue };
            let d = v.probe_data[i];
            let offset = Vec3::from_array(d.offset);
            let next = DdgiProbe {
                offset,
                position: v.layout.grid_position(i as u32) + offset,
                state: v.probe_state(i),
                ray_count: d.ray_count,
                error: d.error,
                resting_frames: d.rest >> 16,
                ..probe.clone()
            };
            probe.set_if_neq(next);
        }
    }
}

/// Prepare stage: writes the pins of probes whose [`DdgiProbePin`] was added, changed or removed
/// into the GPU's probe data.
pub fn upload_ddgi_probe_pins(
    gpu: Res<GpuContext>,
    volumes: Res<DdgiGpuVolumes>,
    pins: Query<(&DdgiProbe, &DdgiProbePin), Changed<DdgiProbePin>>,
    mut unpinned: RemovedComponents<DdgiProbePin>,
    probes: Query<&DdgiProbe>,
) {
    let write = |probe: &DdgiProbe, pin: Option<&DdgiProbePin>| {
        let Some(v) = volumes.get(probe.volume) else { return };
        if probe.index >= v.layout.probe_count {
            return;
        }
        let rays = pin.and_then(|p| p.rays).unwrap_or(NO_PIN);
        let state = match pin.and_then(|p| p.state) {
            Some(DdgiProbeState::Active) => PIN_ACTIVE,
            Some(DdgiProbeState::Inactive) => PIN_INACTIVE,
            None => 0,
        };
        let offset = u64::from(probe.index) * size_of::<DdgiProbeData>() as u64 + std::mem::offset_of!(DdgiProbeData, pinned_rays) as u64;
        gpu.queue.write_buffer(&v.probes, offset, bytemuck::cast_slice(&[rays, state]));
    };
    for (probe, pin) in &pins {
        write(probe, Some(pin));
    }
    for entity in unpinned.read() {
        if let Ok(probe) = probes.get(entity) {
            write(probe, None);
        }
    }
}

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
            base_color_texture: Some(TextureRef { image, transform: UvTransform::default() }),
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

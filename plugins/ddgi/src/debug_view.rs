//! What the `"ddgi"` frame script shows ([`DdgiOutput`]) and the probe debug view
//! ([`DdgiProbeView`], pass `ddgi_probe_spheres`).

use bevy_ecs::prelude::*;
use std::sync::Arc;

use engine::graph::{Bind, Handle, PassBuilder, RenderGraph, Texture as GraphTexture};
use engine::render::CameraFrame;
use engine::shader::{Program, ShaderError};
use engine::wgpu;

pub use crate::contact_occlusion::DdgiContactOcclusion;
use crate::frame::VolumeHandles;
use crate::gpu::DdgiProbeViewParams;
use crate::resources::VolumeGpu;
pub use crate::sky_light::{DdgiSkyLight, MAX_SKY_RAYS};

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
    /// The contact occlusion of [`DdgiContactOcclusion`] as grey, 1 open (debug view; white when
    /// it is off).
    Occlusion,
}

impl DdgiOutput {
    /// Every output, in the order a menu lists them.
    pub const ALL: [DdgiOutput; 6] = [Self::Full, Self::Direct, Self::Indirect, Self::Albedo, Self::Normals, Self::Occlusion];

    /// A short name for menus and logs, e.g. `indirect light only`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Full => "full",
            Self::Indirect => "indirect light only",
            Self::Direct => "direct light only",
            Self::Albedo => "albedo",
            Self::Normals => "normals",
            Self::Occlusion => "contact occlusion",
        }
    }

    /// The `debug_view` of `composite_debug`, for the outputs it draws.
    pub(crate) fn debug_view(self) -> Option<u32> {
        match self {
            Self::Full | Self::Indirect => None,
            Self::Direct => Some(1),
            Self::Albedo => Some(2),
            Self::Normals => Some(3),
            Self::Occlusion => Some(4),
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
    /// Every colouring, in the order a menu lists them.
    pub const ALL: [DdgiProbeColor; 5] = [Self::Off, Self::Irradiance, Self::State, Self::Rays, Self::Error];

    /// A short name for menus and logs, e.g. `ray budget`.
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

/// The probe debug view: every probe of one volume (`volume`, the first by default) drawn as a
/// small sphere in the image (pass `ddgi_probe_spheres`, after the composite, depth-tested against
/// the G-buffer). Costs one instanced draw of 576 vertices per probe when on, nothing when off.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct DdgiProbeView {
    /// The volume (or cascade) whose probes are drawn, by its entity; `None`, or an entity that
    /// lights nothing: the first volume in gather order. The [`DdgiDebugPasses`] draw the same one.
    pub volume: Option<Entity>,
    /// What the spheres show; [`DdgiProbeColor::Off`] draws nothing.
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
        Self { volume: None, color: DdgiProbeColor::Off, radius: 0.12, selected: None, max_error: 0.1 }
    }
}

/// Vertices of one probe sphere: two triangles per ring × segment of `ddgi_debug_draw.inc.wgsl`
/// (the sphere of the probe debug view and of any debug view that includes that module).
pub fn probe_sphere_vertices() -> Result<u32, ShaderError> {
    let parsed = engine::shader::parse("ddgi_debug_draw.inc.wgsl")?;
    let missing = |name: &str| ShaderError::Missing(format!("ddgi_debug_draw.inc.wgsl: const {name}"));
    let rings = parsed.u32_constant("SPHERE_RINGS").ok_or_else(|| missing("SPHERE_RINGS"))?;
    let segments = parsed.u32_constant("SPHERE_SEGMENTS").ok_or_else(|| missing("SPHERE_SEGMENTS"))?;
    Ok(6 * rings * segments)
}

/// The probe debug view's pass: one sphere per probe of `volume`, rasterized into `hdr` with the
/// G-buffer's depth.
#[allow(clippy::too_many_arguments)]
pub(crate) fn add_probe_spheres(
    graph: &mut RenderGraph,
    frame: &CameraFrame,
    (program, vertices): (Arc<Program<wgpu::RenderPipeline>>, u32),
    volume: &VolumeGpu,
    handles: &mut VolumeHandles,
    depth: &mut Handle<GraphTexture>,
    hdr: &mut Handle<GraphTexture>,
    view: &DdgiProbeView,
) {
    let gpu = &frame.gpu;
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
    let uniform = graph.import_buffer("ddgi_probe_view", &uniform);
    let mut pass = graph.add_pass("ddgi_probe_spheres");
    pass.note(view.color.name());
    let count = volume.layout.probe_count;
    let group2 = |pass: &mut PassBuilder<'_>, handles: &VolumeHandles| {
        vec![("ddgi_probe_view", Bind::buffer(pass.read(&uniform))), ("ddgi_probe_view_probes", Bind::buffer(pass.read(handles.probes())))]
    };
    render_over_image(pass, program, handles, group2, depth, hdr, move |rp| rp.draw(0..vertices, 0..count));
}

/// Finishes `pass`, a debug view of one volume drawn over the lit image with `program` (the probe
/// spheres, the overlay's visualizer): declares group 1 (the volume's resources, from `handles`),
/// then group 2 (the pass's own bindings, which `group2` declares on the pass), reads and writes
/// `hdr` and `depth` (the G-buffer's depth) and declares group 0 (the view's named imports). Its
/// closure begins a render pass over the image ([`engine::render::begin_pass_over_image`]), sets the
/// pipeline and the three bind groups, and records `draw`.
pub fn render_over_image(
    mut pass: PassBuilder<'_>,
    program: Arc<Program<wgpu::RenderPipeline>>,
    handles: &mut VolumeHandles,
    group2: impl FnOnce(&mut PassBuilder<'_>, &VolumeHandles) -> Vec<(&'static str, Bind)>,
    depth: &mut Handle<GraphTexture>,
    hdr: &mut Handle<GraphTexture>,
    draw: impl FnOnce(&mut wgpu::RenderPass<'_>) + 'static,
) {
    let group1 = handles.declare(&mut pass, &program.bindings, 1);
    let group2 = group2(&mut pass, handles);
    pass.read(hdr);
    pass.read(depth);
    let color = pass.write(hdr);
    let depth = pass.write(depth);
    let group0 = pass.read_named(&program.bindings, 0);
    pass.render(move |ctx| {
        let group0 = ctx.bind_group(&*program, 0, &group0);
        let group1 = ctx.bind_group(&*program, 1, &group1);
        let group2 = ctx.bind_group(&*program, 2, &group2);
        let mut rp = engine::render::begin_pass_over_image(ctx, color, depth);
        rp.set_pipeline(&program.pipeline);
        rp.set_bind_group(0, &group0, &[]);
        rp.set_bind_group(1, &group1, &[]);
        rp.set_bind_group(2, &group2, &[]);
        draw(&mut rp);
    });
}

/// A debug pass of an app or another crate drawn over one volume, after the probe spheres and before
/// the temporal anti-aliasing (e.g. `ddgi_overlay`'s visualizer). Register it in
/// [`DdgiDebugPasses`]; the `"ddgi"` frame script calls it every frame for the volume
/// [`DdgiProbeView::volume`] selects (the first volume when none is selected, nothing when there
/// is no volume).
pub trait DdgiDebugPass: Send + Sync + 'static {
    /// Adds the pass (or leaves it out) for `volume`, whose resources are `handles`: it may read
    /// and write `depth` (the G-buffer's reversed-Z depth) and `hdr` (the lit image).
    #[allow(clippy::too_many_arguments)]
    fn add(
        &self,
        graph: &mut RenderGraph,
        frame: &CameraFrame,
        volume: &VolumeGpu,
        handles: &mut VolumeHandles,
        depth: &mut Handle<GraphTexture>,
        hdr: &mut Handle<GraphTexture>,
    );
}

/// The debug passes the `"ddgi"` frame script draws over the selected volume ([`DdgiDebugPass`]),
/// in order. Absent or empty: none.
#[derive(Resource, Clone, Default)]
pub struct DdgiDebugPasses(pub Vec<Arc<dyn DdgiDebugPass>>);

/// The index in `volumes` (gather order) of the volume `view` selects: its entity's, else 0.
pub fn selected_volume(volumes: &[(Entity, VolumeGpu)], view: Option<&DdgiProbeView>) -> Option<usize> {
    if volumes.is_empty() {
        return None;
    }
    let wanted = view.and_then(|v| v.volume);
    Some(wanted.and_then(|e| volumes.iter().position(|(v, _)| *v == e)).unwrap_or(0))
}

//! RTXGI-style views of the selected volume, pass `ddgi_visualizer` (`shaders/ddgi_visualizer.wgsl`):
//! probes as spheres coloured by their mean hit distance, relocation offsets as lines from each
//! grid point to its probe, and the volume's bounds as a wireframe; rasterized into the HDR image
//! after ddgi's probe spheres, depth-tested against the G-buffer as they are. Drawn through ddgi's
//! [`DdgiDebugPasses`] for the volume [`ddgi::DdgiProbeView::volume`] selects.

use std::sync::{Arc, Mutex};

use bevy_app::App;
use bevy_ecs::prelude::*;
use bytemuck::{Pod, Zeroable};
use ddgi::debug_view::render_over_image;
use ddgi::{DdgiDebugPass, DdgiDebugPasses, VolumeGpu, VolumeHandles};
use engine::graph::{Bind, Handle, PassBuilder, RenderGraph, Texture as GraphTexture};
use engine::render::{CameraFrame, HDR_FORMAT};
use engine::shader::{Program, RenderTargets, ShaderError, render_program};
use engine::wgpu;

/// The pass label: its wgpu label, timing span and shader file (`ddgi_visualizer.wgsl`).
pub const PASS_LABEL: &str = "ddgi_visualizer";

/// The crate's WGSL, registered with the engine when the plugin is added.
pub const SHADERS: &[engine::shader::ShaderModule] = &[("ddgi_visualizer.wgsl", include_str!("../shaders/ddgi_visualizer.wgsl"))];

/// Which views the `ddgi_visualizer` pass draws over the selected volume; all off: the pass is
/// left out. Cost when on: one instanced draw of 576 vertices per probe for the spheres, 6 per
/// probe for the offsets, 72 for the bounds.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct DdgiVisualizerViews {
    /// Each probe as a sphere coloured by the mean hit distance of its distance map in the
    /// direction of each point of the sphere: blue near, red at the volume's distance scale (1.5
    /// cell diagonals, where distances are clamped).
    pub distance_spheres: bool,
    /// A cyan line from each probe's grid point to where relocation moved it.
    pub relocation_offsets: bool,
    /// The volume's box (the cells its probes fill) as a yellow wireframe.
    pub bounds: bool,
    /// Radius of the distance spheres, as a fraction of the smallest probe spacing.
    pub radius: f32,
    /// Width of the lines, in pixels.
    pub line_width: f32,
}

impl Default for DdgiVisualizerViews {
    fn default() -> Self {
        Self { distance_spheres: false, relocation_offsets: false, bounds: false, radius: 0.12, line_width: 2.0 }
    }
}

impl DdgiVisualizerViews {
    /// Whether any view is on.
    pub fn any(&self) -> bool {
        self.distance_spheres || self.relocation_offsets || self.bounds
    }
}

/// The pass's parameters (WGSL `DdgiVisualizerParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DdgiVisualizerParams {
    /// Instances `[0, spheres)` are distance spheres.
    pub spheres: u32,
    /// First instance of the offset lines (one per probe).
    pub offsets_begin: u32,
    /// End of the offset lines' instances.
    pub offsets_end: u32,
    /// First of the 12 instances of the bounds' edges.
    pub bounds_begin: u32,
    /// Sphere radius in world units.
    pub radius: f32,
    /// Line width in pixels.
    pub line_width: f32,
    /// Padding to the WGSL layout.
    pub _pad0: u32,
    /// Padding to the WGSL layout.
    pub _pad1: u32,
}

/// The host mirrors of the crate's WGSL structs, for the layout test.
pub fn gpu_structs() -> Vec<engine::shader::HostStruct> {
    vec![engine::gpu_struct_layout!(DdgiVisualizerParams in "ddgi_visualizer.wgsl" {
        spheres, offsets_begin, offsets_end, bounds_begin, radius, line_width, _pad0, _pad1
    })]
}

/// Vertices of one distance sphere (ddgi's probe sphere, [`ddgi::debug_view::probe_sphere_vertices`])
/// and of one line (`LINE_VERTICES`), read from the shaders.
pub fn vertex_counts() -> Result<(u32, u32), ShaderError> {
    let parsed = engine::shader::parse("ddgi_visualizer.wgsl")?;
    let line =
        parsed.u32_constant("LINE_VERTICES").ok_or_else(|| ShaderError::Missing("ddgi_visualizer.wgsl: const LINE_VERTICES".into()))?;
    Ok((ddgi::debug_view::probe_sphere_vertices()?, line))
}

/// The pass's pipeline, with the vertices of one sphere and of one line.
type VisualizerProgram = (Arc<Program<wgpu::RenderPipeline>>, u32, u32);

/// The pass: its pipeline (built on first use) and the views, copied in from
/// [`DdgiVisualizerViews`] each frame.
pub struct Visualizer {
    views: Mutex<DdgiVisualizerViews>,
    program: Mutex<Option<VisualizerProgram>>,
}

/// The pass object the plugin registered, to copy the views into.
#[derive(Resource, Clone)]
pub(crate) struct VisualizerPass(Arc<Visualizer>);

/// Registers the shader and adds the pass to ddgi's [`DdgiDebugPasses`].
pub(crate) fn add_visualizer(app: &mut App) -> Result<(), ShaderError> {
    ddgi::register_shaders()?;
    engine::shader::register(SHADERS)?;
    let pass = Arc::new(Visualizer { views: Mutex::new(DdgiVisualizerViews::default()), program: Mutex::new(None) });
    let world = app.world_mut();
    world.get_resource_or_insert_with(DdgiDebugPasses::default).0.push(pass.clone());
    world.insert_resource(VisualizerPass(pass));
    Ok(())
}

/// `Last`: hands this frame's [`DdgiVisualizerViews`] to the pass.
pub(crate) fn sync_visualizer_views(views: Res<DdgiVisualizerViews>, pass: Option<Res<VisualizerPass>>) {
    if let Some(pass) = pass {
        *pass.0.views.lock().unwrap_or_else(|e| e.into_inner()) = *views;
    }
}

impl Visualizer {
    fn program(&self, gpu: &engine::gpu::GpuContext) -> Result<VisualizerProgram, ShaderError> {
        let mut slot = self.program.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(p) = &*slot {
            return Ok(p.clone());
        }
        let (sphere, line) = vertex_counts()?;
        let program = render_program(
            &gpu.device,
            "ddgi_visualizer.wgsl",
            PASS_LABEL,
            RenderTargets {
                colors: &[Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                depth: Some(engine::render::depth_test()),
                // Lines are quads of either winding: no culling (the spheres are closed, so their
                // back faces lose the depth test to their front faces).
                primitive: wgpu::PrimitiveState::default(),
            },
        )?;
        let p = (Arc::new(program), sphere, line);
        *slot = Some(p.clone());
        Ok(p)
    }
}

impl DdgiDebugPass for Visualizer {
    fn add(
        &self,
        graph: &mut RenderGraph,
        frame: &CameraFrame,
        volume: &VolumeGpu,
        handles: &mut VolumeHandles,
        depth: &mut Handle<GraphTexture>,
        hdr: &mut Handle<GraphTexture>,
    ) {
        let views = *self.views.lock().unwrap_or_else(|e| e.into_inner());
        if !views.any() {
            graph.leave_out(PASS_LABEL, "no probe view of the overlay is on");
            return;
        }
        let (program, sphere_vertices, line_vertices) = match self.program(&frame.gpu) {
            Ok(p) => p,
            Err(e) => {
                log::error!("{PASS_LABEL}: {e}");
                return;
            }
        };
        let count = volume.layout.probe_count;
        let spheres = if views.distance_spheres { count } else { 0 };
        let (offsets_begin, offsets_end) = (count, if views.relocation_offsets { 2 * count } else { count });
        let bounds_begin = 2 * count;
        let params = DdgiVisualizerParams {
            spheres,
            offsets_begin,
            offsets_end,
            bounds_begin,
            radius: views.radius.clamp(0.0, 0.5) * volume.layout.spacing.min_element().max(0.0),
            line_width: views.line_width.clamp(0.5, 16.0),
            _pad0: 0,
            _pad1: 0,
        };
        let uniform = frame.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ddgi_visualizer_params"),
            size: size_of::<DdgiVisualizerParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        frame.gpu.queue.write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
        let uniform = graph.import_buffer("ddgi_visualizer_params", &uniform);
        let mut pass = graph.add_pass(PASS_LABEL);
        let on: Vec<&str> = [(views.distance_spheres, "distance"), (views.relocation_offsets, "offsets"), (views.bounds, "bounds")]
            .iter()
            .filter(|(on, _)| *on)
            .map(|(_, name)| *name)
            .collect();
        pass.note(&on.join(", "));
        let group2 = |pass: &mut PassBuilder<'_>, handles: &VolumeHandles| {
            vec![
                ("ddgi_visualizer", Bind::buffer(pass.read(&uniform))),
                ("ddgi_visualizer_probes", Bind::buffer(pass.read(handles.probes()))),
            ]
        };
        render_over_image(pass, program, handles, group2, depth, hdr, move |rp| {
            if spheres > 0 {
                rp.draw(0..sphere_vertices, 0..spheres);
            }
            if offsets_end > offsets_begin {
                rp.draw(0..line_vertices, offsets_begin..offsets_end);
            }
            if views.bounds {
                rp.draw(0..line_vertices, bounds_begin..bounds_begin + 12);
            }
        });
    }
}

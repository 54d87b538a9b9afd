//! An app pass of its own that reads the probes: fog lit by DDGI, in a frame script composed from
//! the plugin's public passes.
//!
//! ```text
//! cargo run --release -p ddgi --example custom_pass -- --scene cornell --frames 60 --out DIR
//! ```
//!
//! The frame script is the `"ddgi"` one with a last pass added: the composite writes into a texture
//! of its own, and `probe_fog` (`probe_fog.wgsl`, which includes DDGI's sampling module) marches
//! through fog from the camera to each surface, lighting the fog by the probes, into the image.

use std::path::PathBuf;

use bevy_app::App;
use bevy_ecs::prelude::*;
use ddgi::{DdgiFrame, DdgiVolume};
use engine::graph::{Bind, Handle, RenderGraph, Texture};
use engine::headless::{HeadlessSettings, render_scene_with};
use engine::render::{CameraFrame, FrameScript, GBuffer, frame_script_is};
use engine::shader::{Program, compute_program};
use engine::wgpu;

/// The example's WGSL, registered beside DDGI's (it includes `ddgi_sampling.inc.wgsl`).
pub const SHADERS: &[engine::shader::ShaderModule] = &[("probe_fog.wgsl", include_str!("probe_fog.wgsl"))];

/// Mirror of `FogParams` in `probe_fog.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FogParams {
    density: f32,
    steps: u32,
    sky_distance: f32,
    _pad: u32,
}

/// The mirror's layout, for the test that checks it against naga's.
pub fn fog_params_layout() -> engine::shader::HostStruct {
    engine::gpu_struct_layout!(FogParams in "probe_fog.wgsl" { density, steps, sky_distance, _pad })
}

/// The fog pass's pipeline and settings.
#[derive(Resource)]
struct ProbeFog {
    program: std::sync::Arc<Program<wgpu::ComputePipeline>>,
    params: FogParams,
}

#[derive(clap::Parser)]
pub struct Args {
    /// A built-in scene (cornell, door_room, …).
    #[arg(long, default_value = "cornell")]
    scene: String,
    #[arg(long, default_value_t = 60)]
    frames: u32,
    #[arg(long, default_value = "out/custom_pass")]
    out: PathBuf,
    /// Width and height of the image in pixels.
    #[arg(long, default_value_t = 256)]
    size: u32,
}

pub fn run(args: Args) -> Result<(), Box<dyn std::error::Error>> {
    let entry = scenes::find(&args.scene).ok_or(format!("no built-in scene '{}'", args.scene))?;
    let (scene, bounds) = ((entry.build)(), (entry.gi_bounds)());
    let gpu = engine::gpu::GpuContext::new(Default::default())?;
    let settings = HeadlessSettings { width: args.size, height: args.size, frames: args.frames, ..Default::default() };
    let frame = render_scene_with(&gpu, scene, &settings, |app| add_probe_fog(app, bounds))?;
    Ok(frame.write(&args.out)?)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    run(clap::Parser::parse())
}

/// DDGI with one volume, and the `"probe_fog"` frame script instead of `"ddgi"`.
fn add_probe_fog(app: &mut App, bounds: Option<(glam::Vec3, glam::Vec3)>) {
    let bounds = bounds.map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3()));
    ddgi::use_ddgi(app, DdgiVolume { bounds, ..Default::default() }, Default::default());
    let gpu = app.world().resource::<engine::gpu::GpuContext>().clone();
    let program = ddgi::register_shaders()
        .and_then(|()| engine::shader::register(SHADERS))
        .and_then(|()| compute_program(&gpu.device, "probe_fog.wgsl", "main", "probe_fog"))
        .unwrap_or_else(|e| panic!("{e}"));
    let params = FogParams { density: 0.25, steps: 24, sky_distance: 10.0, _pad: 0 };
    app.insert_resource(ProbeFog { program: program.into(), params }).insert_resource(FrameScript("probe_fog")).add_systems(
        engine::app::Render,
        render_probe_fog_frame.run_if(frame_script_is("probe_fog")).after(engine::render::gpu_scene::flush_uploads),
    );
}

/// The frame script: the DDGI passes, the composite into `lit`, then the fog into the image.
fn render_probe_fog_frame(mut frame: CameraFrame, mut ddgi: DdgiFrame, fog: Res<ProbeFog>) {
    let mut script = frame.begin();
    let gbuffer = frame.add_gbuffer(&mut script.graph);
    let mut direct = script.graph.create_texture("ddgi_direct", ddgi::frame::direct_texture(&frame));
    frame.add_direct_lighting(&mut script.graph, &gbuffer, &mut direct);
    let mut volumes = ddgi.add_volume_updates(&mut script.graph, &frame);
    let indirect = ddgi.add_gather(&mut script.graph, &frame, &mut volumes, &gbuffer);
    let mut lit = script.graph.create_texture("lit", ddgi::frame::direct_texture(&frame));
    ddgi.add_composite(&mut script.graph, &frame, &gbuffer, &direct, &indirect, &mut lit);
    if let Some(volume) = volumes.first_mut() {
        add_probe_fog_pass(&mut script.graph, &frame, &fog, volume, &gbuffer, &lit, &mut script.hdr);
    }
    frame.add_taa(&mut script.graph, &gbuffer, &mut script.hdr);
    frame.finish(script);
    ddgi.finish(&frame);
}

/// The `probe_fog` pass: reads the volume's probes through the handles it declares.
fn add_probe_fog_pass(
    graph: &mut RenderGraph,
    frame: &CameraFrame,
    fog: &ProbeFog,
    volume: &mut ddgi::VolumeHandles,
    gbuffer: &GBuffer,
    lit: &Handle<Texture>,
    hdr: &mut Handle<Texture>,
) {
    let params = frame.gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("probe_fog_params"),
        size: size_of::<FogParams>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    frame.gpu.queue.write_buffer(&params, 0, bytemuck::bytes_of(&fog.params));
    let params = graph.import_buffer("probe_fog_params", &params);
    let program = fog.program.clone();
    let mut pass = graph.add_pass("probe_fog");
    let group1 = volume.declare(&mut pass, &program.bindings, 1);
    let group2 = vec![
        ("fog", Bind::buffer(pass.read(&params))),
        ("fog_depth", Bind::texture(pass.read(&gbuffer.depth))),
        ("fog_lit", Bind::texture(pass.read(lit))),
        ("fog_out", Bind::texture(pass.write(hdr))),
    ];
    let group0 = pass.read_named(&program.bindings, 0);
    let size = frame.size();
    pass.compute(program, vec![group0, group1, group2], (size.width.div_ceil(8), size.height.div_ceil(8)));
}

//! The DDGI passes as functions any frame script calls, and the `"ddgi"` frame script built from them.
//!
//! ```text
//! all volumes: ddgi_budget ─▶ ddgi_trace ─▶ [ddgi_shade] ─▶ ddgi_probe_update
//!                                                                  (DdgiFrame::add_volume_updates;
//!                                        ddgi_shade: volumes with DdgiVolume::persistent_trace)
//! per camera:  ddgi_gather (each volume) ─▶ [ddgi_contact_occlusion] ─▶ ddgi_composite
//!                                                                  (add_gather, add_composite)
//! debug:       ddgi_probe_spheres                                  (add_probe_spheres)
//! ```
//!
//! Every resource of a volume enters the frame's graph as a handle ([`VolumeHandles`]); a pass
//! declares what its shaders use — read or written as naga finds it — and binds only what it
//! declared. A pass of the app's own that lights its surfaces by the probes includes
//! `ddgi_sampling.inc.wgsl` and binds group 1 with [`VolumeHandles::declare`].

use bevy_ecs::prelude::*;
use bevy_ecs::system::SystemParam;
use engine::graph::{
    Bind, Buffer as GraphBuffer, BufferDesc, Handle, NamedResource, NamedSet, PassBuilder, RenderGraph, Texture as GraphTexture,
    TextureDesc,
};
use engine::render::{CameraFrame, GBuffer, HDR_FORMAT};
use engine::shader::{BindingMap, ShaderError};
use engine::wgpu;

use crate::debug_view::{DdgiOutput, DdgiProbeColor, DdgiProbeView, add_probe_spheres};
use crate::gpu::{DdgiCounters, DdgiGatherParams};
use crate::pipelines::{ComputeProgram, DdgiPipelines, RayKernel, Specialization};
use crate::resources::{DdgiGpuVolumes, VolumeGpu};

/// The labels of the probe update's passes (everything DDGI does before the camera's gather), in
/// their order; `ddgi_shade` runs only when a volume traces with persistent threads
/// ([`crate::DdgiVolume::persistent_trace`]). With several volumes, each pass holds every volume's
/// dispatches under its one label.
pub const PROBE_UPDATE_PASSES: [&str; 4] = ["ddgi_budget", "ddgi_trace", "ddgi_shade", "ddgi_probe_update"];

/// Whether a pass label names a pass of the probe update ([`PROBE_UPDATE_PASSES`], with or without
/// a volume's suffix `_k`): not the gather, the composite or a debug view.
pub fn is_probe_update_pass(label: &str) -> bool {
    PROBE_UPDATE_PASSES.iter().any(|p| label.strip_prefix(p).is_some_and(|rest| rest.is_empty() || rest.starts_with('_')))
}

/// Where in [`DdgiCounters`] the indirect dispatches of the ray passes and of the per-probe passes are.
const RAY_DISPATCH_OFFSET: u64 = std::mem::offset_of!(DdgiCounters, dispatch) as u64;
const PROBE_DISPATCH_OFFSET: u64 = std::mem::offset_of!(DdgiCounters, probe_dispatch) as u64;
/// Where in [`DdgiCounters`] the indirect dispatch of the persistent trace is.
const PERSISTENT_DISPATCH_OFFSET: u64 = std::mem::offset_of!(DdgiCounters, persistent_dispatch) as u64;

/// One volume's resources in a frame's graph: every buffer of its [`VolumeGpu`] (the table in
/// [`crate::buffers`]), its two atlases and its sampler, imported as one set by their WGSL names
/// (group 1, `ddgi_common.inc.wgsl`), so that passes declare and bind them by name.
pub struct VolumeHandles {
    /// Index of the volume in [`DdgiGpuVolumes::volumes`].
    pub index: usize,
    /// Appended to pass labels when there are several volumes (`_0`, `_1`, …), else empty.
    pub suffix: String,
    /// The volume's resources by WGSL name; a pass declares them with [`VolumeHandles::declare`].
    pub resources: NamedSet,
}

/// The atlases that sampling reads, by WGSL name, and the name the probe update writes each under.
const ATLASES: [(&str, &str); 2] = [("ddgi_irradiance", "ddgi_irradiance_out"), ("ddgi_distance", "ddgi_distance_out")];

impl VolumeHandles {
    fn import(graph: &mut RenderGraph, index: usize, suffix: String, volume: &VolumeGpu, sampler: &wgpu::Sampler) -> Self {
        let mut entries: Vec<_> = volume.buffers.entries().into_iter().map(|(name, b, _)| (name, NamedResource::Buffer(b))).collect();
        entries.push(("ddgi_sampler", NamedResource::Sampler(sampler)));
        let mut resources = graph.import_named_set(&suffix, &entries);
        resources.alias("ddgi_counters_in", "ddgi_counters");
        for ((name, written_as), texture) in ATLASES.into_iter().zip([&volume.irradiance, &volume.distance]) {
            resources.insert_texture(name, graph.import_texture(&format!("{name}{suffix}"), texture));
            resources.alias(written_as, name);
        }
        Self { index, suffix, resources }
    }

    /// Per-probe state, a [`crate::gpu::DdgiProbeData`] each (WGSL `ddgi_probes`).
    pub fn probes(&self) -> &Handle<GraphBuffer> {
        self.resources.buffer("ddgi_probes").expect("every volume has its probe buffer")
    }

    /// The budget pass's results and indirect dispatches (WGSL `ddgi_counters`).
    pub fn counters(&self) -> &Handle<GraphBuffer> {
        self.resources.buffer("ddgi_counters").expect("every volume has its counters")
    }

    /// Declares on `pass` every volume resource that `bindings` (a pipeline's, or several merged)
    /// uses in `group` — a write where naga finds the shader writes it, a read otherwise — and
    /// returns the bindings to build that group from ([`engine::graph::PassContext::bind_group`]).
    pub fn declare(&mut self, pass: &mut PassBuilder<'_>, bindings: &BindingMap, group: u32) -> Vec<(&'static str, Bind)> {
        pass.declare_named(&self.resources, bindings, group)
    }

    /// Marks what lives on into the next frame: the maps, their histories and the probe states.
    fn export(&self, graph: &mut RenderGraph, volume: &VolumeGpu) {
        for (name, _, _) in volume.buffers.entries().into_iter().filter(|(_, _, exported)| *exported) {
            graph.export(self.resources.buffer(name).expect("imported from the same table"));
        }
        for (name, _) in ATLASES {
            graph.export(self.resources.texture(name).expect("imported with the buffers"));
        }
    }
}

/// The bindings of several pipelines merged (a pass of several dispatches declares them all).
fn merged(programs: &[&ComputeProgram]) -> BindingMap {
    let mut map = BindingMap::default();
    for p in programs {
        for (group, names) in &p.bindings.groups {
            map.groups.entry(*group).or_default().extend(names.iter().map(|(n, b)| (n.clone(), *b)));
        }
        map.writes.extend(p.bindings.writes.iter().cloned());
    }
    map
}

/// The DDGI resources a frame script needs, as one system parameter: take it beside
/// [`CameraFrame`] and call its `add_*` functions between `begin` and `finish`, then
/// [`DdgiFrame::finish`].
#[derive(SystemParam)]
pub struct DdgiFrame<'w> {
    /// DDGI's pipelines and sampler.
    pub pipelines: ResMut<'w, DdgiPipelines>,
    /// Every volume's GPU state.
    pub volumes: ResMut<'w, DdgiGpuVolumes>,
    /// What the composite writes: the full image, one of its parts or a debug view.
    pub output: Res<'w, DdgiOutput>,
    /// The probe spheres overlay, when the app asks for it.
    pub probe_view: Option<Res<'w, DdgiProbeView>>,
    /// Sky light where no volume reaches, when set.
    pub sky_light: Option<Res<'w, crate::DdgiSkyLight>>,
    /// Contact occlusion of the indirect light, when set.
    pub contact_occlusion: Option<Res<'w, crate::DdgiContactOcclusion>>,
    /// Debug passes of the app drawn over the selected volume, when set.
    pub debug_passes: Option<Res<'w, crate::DdgiDebugPasses>>,
}

impl DdgiFrame<'_> {
    /// Adds every volume's probe update to `graph`: budget → trace (ray generation and shading
    /// included) → probe update (maps, atlas tiles, relocation, classification). Returns each
    /// volume's handles, for the gather and for the app's own passes that sample the probes.
    ///
    /// Each stage is one pass over every volume that updates this frame, its dispatches
    /// interleaved step by step (every volume's first step, then every volume's second, …): the
    /// volumes share no buffer, so the GPU runs one volume's dispatch beside the others' instead of
    /// one after the other. That matters for cascades: a cascade's trace is a few tens of
    /// thousands of long rays, too few to fill a large GPU, and its time is the slowest ray's
    /// latency whatever the count, so several cascades traced one after the other cost that
    /// latency several times over.
    pub fn add_volume_updates(&mut self, graph: &mut RenderGraph, frame: &CameraFrame) -> Vec<VolumeHandles> {
        let specialization = Specialization {
            spot_lights: frame.scene.has_spot_lights,
            emissive: frame.scene.has_emissive,
            alpha_test: frame.scene.has_alpha_test,
        };
        let count = self.volumes.volumes.len();
        let mut handles: Vec<VolumeHandles> = Vec::new();
        let mut updating = Vec::new();
        for (k, (_, volume)) in self.volumes.volumes.iter().enumerate() {
            let suffix = crate::sync::volume_suffix(k, count);
            handles.push(VolumeHandles::import(graph, k, suffix, volume, &self.pipelines.sampler));
            if volume.updates_this_frame {
                updating.push(k);
            }
        }
        if updating.is_empty() {
            for pass in ["ddgi_budget", "ddgi_trace", "ddgi_probe_update"] {
                graph.leave_out(pass, "no volume's update period falls on this frame");
            }
            return handles;
        }
        let volumes: Vec<&VolumeGpu> = self.volumes.volumes.iter().map(|(_, v)| v).collect();
        if let Err(e) = add_volume_update_passes(graph, frame, &mut self.pipelines, specialization, &volumes, &mut handles, &updating) {
            log::error!("DDGI pipelines failed, the volumes are off: {e}");
        }
        handles
    }

    /// Adds the gather of every volume for the camera: each pixel's irradiance from the probes,
    /// weighted by how far inside each volume it lies. Returns the per-pixel accumulation
    /// `(Σ weight · irradiance, Σ weight)`, followed by the same along the reflection of each
    /// glossy pixel (a material with a specular lobe), that [`DdgiFrame::add_composite`] reads.
    /// Left out when the output reads no indirect light.
    pub fn add_gather(
        &self,
        graph: &mut RenderGraph,
        frame: &CameraFrame,
        volumes: &mut [VolumeHandles],
        gbuffer: &GBuffer,
    ) -> Handle<GraphBuffer> {
        let size = frame.size();
        let pixels = u64::from(size.width.max(1)) * u64::from(size.height.max(1));
        let mut indirect = graph.create_buffer(
            "ddgi_indirect",
            BufferDesc { size: pixels * 32, usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST },
        );
        if volumes.is_empty() {
            // No volume: the indirect term is zero.
            let mut pass = graph.add_pass("ddgi_clear_indirect");
            let out = pass.write(&mut indirect);
            pass.render(move |ctx| ctx.encoder.clear_buffer(ctx.buffer(out), 0, None));
        }
        // The debug views read no indirect light: the gather (which also marks the probes the view
        // needs, so it writes the exported probe states and would otherwise always run) is left out.
        let reads_indirect = self.output.debug_view().is_none();
        for (i, h) in volumes.iter_mut().enumerate() {
            let label = format!("ddgi_gather{}", h.suffix);
            if !reads_indirect {
                graph.leave_out(&label, "the view reads no indirect light");
                continue;
            }
            let params = self.gather_params(graph, frame, i == 0);
            let program = self.pipelines.gather.clone();
            let mut pass = graph.add_pass(&label);
            let group1 = h.declare(&mut pass, &program.bindings, 1);
            let group2 = vec![
                ("ddgi_gather_params", Bind::buffer(pass.read(&params))),
                ("gbuffer_depth", Bind::texture(pass.read(&gbuffer.depth))),
                ("gbuffer_normal", Bind::texture(pass.read(&gbuffer.normal))),
                ("gbuffer_albedo", Bind::texture(pass.read(&gbuffer.albedo))),
                ("gbuffer_emissive", Bind::texture(pass.read(&gbuffer.emissive))),
                ("ddgi_indirect", {
                    pass.read(&indirect);
                    Bind::buffer(pass.write(&mut indirect))
                }),
            ];
            let group0 = pass.read_named(&program.bindings, 0);
            pass.compute(program, vec![group0, group1, group2], workgroups(frame));
        }
        indirect
    }

    /// Adds the composite: `direct` plus the gathered indirect light (albedo / π × irradiance) into
    /// `hdr`, or what [`DdgiOutput`] asks for instead.
    pub fn add_composite(
        &self,
        graph: &mut RenderGraph,
        frame: &CameraFrame,
        gbuffer: &GBuffer,
        direct: &Handle<GraphTexture>,
        indirect: &Handle<GraphBuffer>,
        hdr: &mut Handle<GraphTexture>,
    ) {
        // What the composite reads depends on the output: `composite` direct + indirect,
        // `composite_indirect` the indirect light alone, `composite_debug` direct light, albedo or
        // normals. When it reads no gathered light, nobody does: the graph leaves the gather out.
        let output = *self.output;
        let debug = output.debug_view().is_some();
        let full = output == DdgiOutput::Full;
        let params = self.gather_params(graph, frame, true);
        let occlusion = self.add_contact_occlusion(graph, frame, gbuffer, &params);
        let mut pass = graph.add_pass("ddgi_composite");
        let mut group2 = vec![
            ("ddgi_gather_params", Bind::buffer(pass.read(&params))),
            ("gbuffer_depth", Bind::texture(pass.read(&gbuffer.depth))),
            ("gbuffer_albedo", Bind::texture(pass.read(&gbuffer.albedo))),
        ];
        // The debug views draw the normals; the sky light traces from them; glossy pixels need
        // their roughness (the normal's w) and specular weight (the emission's).
        group2.push(("gbuffer_normal", Bind::texture(pass.read(&gbuffer.normal))));
        group2.push(("gbuffer_emissive", Bind::texture(pass.read(&gbuffer.emissive))));
        if full || debug {
            group2.push(("direct_in", Bind::texture(pass.read(direct))));
        }
        if !debug {
            group2.push(("ddgi_indirect", Bind::buffer(pass.read(indirect))));
        }
        group2.push(("ddgi_occlusion", Bind::buffer(pass.read(&occlusion))));
        group2.push(("radiance_out", Bind::texture(pass.write(hdr))));
        if !full {
            pass.note(output.name());
        }
        let program = match (debug, full) {
            (true, _) => self.pipelines.composite_debug.clone(),
            (false, true) => self.pipelines.composite.clone(),
            (false, false) => self.pipelines.composite_indirect.clone(),
        };
        let group0 = pass.read_named(&program.bindings, 0);
        // Group 1 (a volume's) is unused: the composite reads only the gathered light.
        pass.compute(program, vec![group0, Vec::new(), group2], workgroups(frame));
    }

    /// Adds the probe debug view of the selected volume ([`DdgiProbeView::volume`], the first by
    /// default) when [`DdgiProbeView`] is on — one sphere per probe, rasterized into `hdr` against
    /// the G-buffer's depth — then the app's [`crate::DdgiDebugPasses`] over the same volume.
    pub fn add_probe_spheres(
        &mut self,
        graph: &mut RenderGraph,
        frame: &CameraFrame,
        volumes: &mut [VolumeHandles],
        depth: &mut Handle<GraphTexture>,
        hdr: &mut Handle<GraphTexture>,
    ) {
        let Some(selected) = crate::debug_view::selected_volume(&self.volumes.volumes, self.probe_view.as_deref()) else { return };
        let Some(handles) = volumes.iter_mut().find(|h| h.index == selected) else { return };
        let volume = &self.volumes.volumes[selected].1;
        if let Some(view) = self.probe_view.as_deref().copied().filter(|v| v.color != DdgiProbeColor::Off) {
            match self.pipelines.probe_spheres_program(&frame.gpu) {
                Ok(program) => add_probe_spheres(graph, frame, program, volume, handles, depth, hdr, &view),
                Err(e) => log::error!("DDGI probe view: {e}"),
            }
        }
        for pass in self.debug_passes.iter().flat_map(|p| p.0.iter()) {
            pass.add(graph, frame, volume, handles, depth, hdr);
        }
    }

    /// After the graph has run ([`CameraFrame::finish`]): counts the frame and asks for the probe
    /// states and counters to come back (the asynchronous readback into the probe entities).
    pub fn finish(&mut self, frame: &CameraFrame) {
        let frame_index = frame.time.frame;
        for (_, v) in self.volumes.volumes.iter_mut() {
            v.frames += 1;
            v.readback.request(&frame.gpu, &v.buffers.probes, frame_index);
            // A frame the update period skips traced nothing: its counters are the last update's
            // (read_back_ddgi_probes reports it as 0 rays).
            if v.updates_this_frame {
                v.counter_readback.request(&frame.gpu, &v.buffers.counters, frame_index);
                v.recheck_pending = false;
            }
            let between = v.settings.update_period.max(1) * v.calm.period;
            v.calm.finish_frame(frame_index, v.updates_this_frame, between);
        }
    }

    /// This frame's gather parameters, as a uniform in the graph.
    fn gather_params(&self, graph: &mut RenderGraph, frame: &CameraFrame, first: bool) -> Handle<GraphBuffer> {
        let sky = self.sky_light.as_deref().copied().unwrap_or_default();
        let reach = sky.max_distance.unwrap_or_else(|| 0.1 * self.volumes.scene_extent().unwrap_or(0.0));
        let occlusion = self.contact_occlusion.as_deref().copied().unwrap_or_default();
        // Default radius: the finest probe spacing of the volumes.
        let finest =
            self.volumes.volumes.iter().map(|(_, v)| v.layout.spacing.min_element()).filter(|s| s.is_finite() && *s > 0.0).reduce(f32::min);
        let ao_radius = occlusion.radius.or(finest).filter(|r| r.is_finite() && *r > 0.0);
        let p = DdgiGatherParams {
            first_volume: u32::from(first),
            debug_view: self.output.debug_view().unwrap_or(0),
            sky_rays: sky.rays.min(crate::debug_view::MAX_SKY_RAYS),
            sky_distance: if reach.is_finite() && reach > 0.0 { reach } else { crate::gpu::UNBOUNDED_RAY },
            ao_rays: if ao_radius.is_some() { occlusion.rays.min(crate::debug_view::MAX_SKY_RAYS) } else { 0 },
            ao_radius: ao_radius.unwrap_or(0.0),
            ao_scale: occlusion.scale(),
            _pad1: 0,
        };
        let buffer = frame.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ddgi_gather_params"),
            size: size_of::<DdgiGatherParams>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        frame.gpu.queue.write_buffer(&buffer, 0, bytemuck::bytes_of(&p));
        graph.import_buffer("ddgi_gather_params", &buffer)
    }
}

fn workgroups(frame: &CameraFrame) -> (u32, u32) {
    let size = frame.size();
    (size.width.div_ceil(8), size.height.div_ceil(8))
}

/// One dispatch of a stage: the program, its bind groups 0 (the scene) and 1 (the volume) as the
/// pass declared them, and its size — workgroups, or the volume's counters at an offset (an
/// indirect dispatch from the budget pass's results).
struct Dispatch {
    program: ComputeProgram,
    group0: Vec<(&'static str, Bind)>,
    group1: Vec<(&'static str, Bind)>,
    size: DispatchSize,
}

enum DispatchSize {
    Workgroups(u32),
    Indirect(engine::graph::Read<GraphBuffer>, u64),
}

/// One volume's dispatch of `program` in `pass`: its bindings declared, sized by the volume's
/// counters at `offset` (an indirect dispatch from the budget pass's results).
fn indirect_dispatch(pass: &mut PassBuilder<'_>, handles: &mut VolumeHandles, program: &ComputeProgram, offset: u64) -> Dispatch {
    let (group0, group1) = (pass.read_named(&program.bindings, 0), handles.declare(pass, &program.bindings, 1));
    let args = pass.read(handles.counters());
    Dispatch { program: program.clone(), group0, group1, size: DispatchSize::Indirect(args, offset) }
}

/// Records `dispatches` in one compute pass, in their order.
fn record_dispatches(dispatches: Vec<Dispatch>) -> impl FnOnce(&mut engine::graph::PassContext<'_>) {
    move |ctx: &mut engine::graph::PassContext<'_>| {
        let groups: Vec<[wgpu::BindGroup; 2]> =
            dispatches.iter().map(|d| [ctx.bind_group(&*d.program, 0, &d.group0), ctx.bind_group(&*d.program, 1, &d.group1)]).collect();
        let indirect: Vec<Option<(&wgpu::Buffer, u64)>> = dispatches
            .iter()
            .map(|d| match d.size {
                DispatchSize::Indirect(args, offset) => Some((ctx.buffer(args), offset)),
                DispatchSize::Workgroups(_) => None,
            })
            .collect();
        let mut cp = ctx.encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(ctx.label), timestamp_writes: None });
        for ((d, [group0, group1]), args) in dispatches.iter().zip(&groups).zip(indirect) {
            cp.set_pipeline(&d.program.pipeline);
            cp.set_bind_group(0, group0, &[]);
            cp.set_bind_group(1, group1, &[]);
            match (args, &d.size) {
                (Some((buffer, offset)), _) => cp.dispatch_workgroups_indirect(buffer, offset),
                (None, DispatchSize::Workgroups(n)) => cp.dispatch_workgroups(*n, 1, 1),
                (None, DispatchSize::Indirect(..)) => {}
            }
        }
    }
}

/// Adds the probe update of the volumes in `updating` (indices into `volumes` and `handles`):
/// one `ddgi_budget`, one `ddgi_trace`, (when a volume traces with persistent threads) one
/// `ddgi_shade` and one `ddgi_probe_update` pass, each holding every updating volume's dispatches
/// of that stage, step by step.
fn add_volume_update_passes(
    graph: &mut RenderGraph,
    frame: &CameraFrame,
    pipelines: &mut DdgiPipelines,
    specialization: Specialization,
    volumes: &[&VolumeGpu],
    handles: &mut [VolumeHandles],
    updating: &[usize],
) -> Result<(), ShaderError> {
    let trace = pipelines.ray_program(&frame.gpu, specialization, RayKernel::Trace)?;
    let persistent = updating.iter().any(|&k| volumes[k].settings.persistent_trace);
    let (persistent_trace, shade) = if persistent {
        (
            Some(pipelines.ray_program(&frame.gpu, specialization, RayKernel::PersistentTrace)?),
            Some(pipelines.ray_program(&frame.gpu, specialization, RayKernel::Shade)?),
        )
    } else {
        (None, None)
    };
    let skipped = volumes.len() - updating.len();
    let note_skipped = |pass: &mut PassBuilder<'_>| {
        if skipped > 0 {
            pass.note(&format!("{skipped} of {} volumes skip this frame (their update period)", volumes.len()));
        }
    };
    {
        let mut pass = graph.add_pass("ddgi_budget");
        note_skipped(&mut pass);
        if updating.iter().any(|&k| volumes[k].settings.adaptive.enabled) {
            pass.note("adaptive: rays by each probe's temporal error");
        }
        // Each volume's steps: plan, (with a frame budget: the two scaling steps), then the
        // blocks' offsets and the placing of the rays. Without a frame budget the planned rays stand.
        let mut per_volume: Vec<std::collections::VecDeque<Dispatch>> = Vec::new();
        for &k in updating {
            let volume = volumes[k];
            let blocks = volume.layout.probe_count.div_ceil(crate::gpu::BUDGET_BLOCK);
            let frame_budget = volume.settings.adaptive.enabled && volume.settings.adaptive.frame_budget.is_some();
            let mut plan = vec![(&pipelines.plan, blocks)];
            if frame_budget {
                plan.extend([(&pipelines.plan_scale, 1), (&pipelines.scale, blocks)]);
            }
            plan.extend([(&pipelines.plan_blocks, 1), (&pipelines.place, blocks)]);
            let bindings = merged(&plan.iter().map(|(p, _)| *p).collect::<Vec<_>>());
            let (group0, group1) = (pass.read_named(&bindings, 0), handles[k].declare(&mut pass, &bindings, 1));
            per_volume.push(
                plan.iter()
                    .map(|&(p, n)| Dispatch {
                        program: p.clone(),
                        group0: group0.clone(),
                        group1: group1.clone(),
                        size: DispatchSize::Workgroups(n),
                    })
                    .collect(),
            );
        }
        pass.render(record_dispatches(interleaved(per_volume)));
    }
    {
        // Shading reads the previous frame's atlases, which the probe update then overwrites. The
        // trace runs as many threads as the budget pass packed rays (an indirect dispatch); the
        // persistent trace as many workgroups as the budget pass asked (persistent_dispatch).
        let mut pass = graph.add_pass("ddgi_trace");
        note_skipped(&mut pass);
        pass.note(&specialization.note());
        if persistent {
            let n = updating.iter().filter(|&&k| volumes[k].settings.persistent_trace).count();
            pass.note(&format!("persistent threads, closest hits only (ddgi_shade shades them): {n} of {} volumes", updating.len()));
        }
        let mut dispatches = Vec::new();
        for &k in updating {
            let (program, offset) = match &persistent_trace {
                Some(p) if volumes[k].settings.persistent_trace => (p, PERSISTENT_DISPATCH_OFFSET),
                _ => (&trace, RAY_DISPATCH_OFFSET),
            };
            dispatches.push(indirect_dispatch(&mut pass, &mut handles[k], program, offset));
        }
        pass.render(record_dispatches(dispatches));
    }
    if let Some(shade) = shade {
        // The shading of the persistent trace's hits, a thread a ray (the trace's indirect dispatch).
        let mut pass = graph.add_pass("ddgi_shade");
        note_skipped(&mut pass);
        pass.note(&specialization.note());
        let dispatches = updating
            .iter()
            .filter(|&&k| volumes[k].settings.persistent_trace)
            .map(|&k| indirect_dispatch(&mut pass, &mut handles[k], &shade, RAY_DISPATCH_OFFSET))
            .collect();
        pass.render(record_dispatches(dispatches));
    }
    {
        let mut pass = graph.add_pass("ddgi_probe_update");
        note_skipped(&mut pass);
        if updating.iter().any(|&k| !volumes[k].settings.relocation) {
            pass.note("relocation off in a volume's settings");
        }
        if updating.iter().any(|&k| !volumes[k].settings.classification) {
            pass.note("classification off in a volume's settings: only clears the fresh-probe flags");
        }
        // Two dispatches a volume, one workgroup per probe the budget gave rays: the irradiance maps
        // (and each probe's error), then the rest. Each atlas is read (the trace's shading) and
        // written (here) in one frame but never in one dispatch, so a single copy of each suffices.
        let bindings = merged(&[&pipelines.update_irradiance, &pipelines.update]);
        let mut per_volume = Vec::new();
        for &k in updating {
            let (group0, group1) = (pass.read_named(&bindings, 0), handles[k].declare(&mut pass, &bindings, 1));
            let args = pass.read(handles[k].counters());
            let dispatch = |p: &ComputeProgram| Dispatch {
                program: p.clone(),
                group0: group0.clone(),
                group1: group1.clone(),
                size: DispatchSize::Indirect(args, PROBE_DISPATCH_OFFSET),
            };
            per_volume.push(std::collections::VecDeque::from([dispatch(&pipelines.update_irradiance), dispatch(&pipelines.update)]));
        }
        pass.render(record_dispatches(interleaved(per_volume)));
    }
    for &k in updating {
        handles[k].export(graph, volumes[k]);
    }
    Ok(())
}

/// The volumes' dispatches step by step: every volume's first, then every volume's second, and so
/// on (a volume with fewer steps drops out), so that consecutive dispatches belong to different
/// volumes and need no barrier between them.
fn interleaved(mut per_volume: Vec<std::collections::VecDeque<Dispatch>>) -> Vec<Dispatch> {
    let mut out = Vec::new();
    while per_volume.iter().any(|q| !q.is_empty()) {
        for q in &mut per_volume {
            if let Some(d) = q.pop_front() {
                out.push(d);
            }
        }
    }
    out
}

/// Render stage: the `"ddgi"` frame script — G-buffer, direct light, each volume's probe update,
/// the final gather of every volume, the composite, then the engine's temporal anti-aliasing,
/// tonemap and present.
pub fn render_ddgi_frame(mut frame: CameraFrame, mut ddgi: DdgiFrame) {
    let mut script = frame.begin();
    let mut gbuffer = frame.add_gbuffer(&mut script.graph);
    let mut direct = script.graph.create_texture("ddgi_direct", direct_texture(&frame));
    frame.add_direct_lighting(&mut script.graph, &gbuffer, &mut direct);
    let mut volumes = ddgi.add_volume_updates(&mut script.graph, &frame);
    let indirect = ddgi.add_gather(&mut script.graph, &frame, &mut volumes, &gbuffer);
    ddgi.add_composite(&mut script.graph, &frame, &gbuffer, &direct, &indirect, &mut script.hdr);
    ddgi.add_probe_spheres(&mut script.graph, &frame, &mut volumes, &mut gbuffer.depth, &mut script.hdr);
    frame.add_taa(&mut script.graph, &gbuffer, &mut script.hdr);
    frame.finish(script);
    ddgi.finish(&frame);
}

/// The description of a texture that holds the direct light apart (the composite adds to it).
pub fn direct_texture(frame: &CameraFrame) -> TextureDesc {
    let size = frame.size();
    TextureDesc {
        width: size.width,
        height: size.height,
        format: HDR_FORMAT,
        usage: wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING,
    }
}

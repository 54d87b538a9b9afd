//! A render graph in the manner of kajiya's: a frame is one script read top to bottom.
//!
//! The script creates transient resources, imports persistent ones (history textures, scene
//! buffers), and adds passes. A pass declares what it reads (`read(&handle)`) and what it writes
//! (`write(&mut handle)`: writing needs the handle mutably, so the borrow checker sees the data flow)
//! and gives a closure that records its commands. Passes run in the order they were added; a pass
//! none of whose outputs is read later or exported is skipped, and the report says so. Each pass that
//! runs gets a debug group and a GPU timestamp span under its label.

use std::collections::HashMap;
use std::marker::PhantomData;
use std::time::Instant;

use bevy_ecs::prelude::*;

use crate::gpu::GpuContext;
use crate::gpu::readback::ReadbackRing;

/// Marker for texture handles.
pub struct Texture;
/// Marker for buffer handles.
pub struct Buffer;

/// A resource of the frame. Not `Clone`: whoever holds it decides who may write it.
pub struct Handle<K> {
    id: usize,
    _kind: PhantomData<K>,
}

/// Read access to a resource, given to a pass closure.
pub struct Read<K> {
    id: usize,
    _kind: PhantomData<K>,
}

/// Write access to a resource, given to a pass closure.
pub struct Write<K> {
    id: usize,
    _kind: PhantomData<K>,
}

macro_rules! copy_access {
    ($t:ident) => {
        impl<K> Clone for $t<K> {
            fn clone(&self) -> Self {
                *self
            }
        }
        impl<K> Copy for $t<K> {}
    };
}
copy_access!(Read);
copy_access!(Write);

/// Anything that names a resource of kind `K` in a pass closure.
pub trait Access<K>: Copy {
    /// The resource's index in the graph.
    fn id(self) -> usize;
}
impl<K> Access<K> for Read<K> {
    fn id(self) -> usize {
        self.id
    }
}
impl<K> Access<K> for Write<K> {
    fn id(self) -> usize {
        self.id
    }
}

/// Description of a transient 2D texture (one mip, one layer).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureDesc {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texel format.
    pub format: wgpu::TextureFormat,
    /// How passes may use it; the graph pools textures by their whole description.
    pub usage: wgpu::TextureUsages,
}

/// Description of a transient buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct BufferDesc {
    /// Size in bytes.
    pub size: u64,
    /// How passes may use it; the graph pools buffers by their whole description.
    pub usage: wgpu::BufferUsages,
}

enum Source {
    TransientTexture(TextureDesc),
    TransientBuffer(BufferDesc),
    ImportedTexture(wgpu::Texture),
    ImportedBuffer(wgpu::Buffer),
}

struct ResourceNode {
    name: String,
    source: Source,
    exported: bool,
}

type PassFn = Box<dyn FnOnce(&mut PassContext<'_>)>;

struct PassNode {
    label: String,
    reads: Vec<usize>,
    writes: Vec<usize>,
    run: Option<PassFn>,
    /// Why the pass runs as it does (a specialization), or why it was left out.
    note: String,
    left_out: bool,
}

/// One frame's graph. Build it, then [`RenderGraph::execute`] it.
#[derive(Default)]
pub struct RenderGraph {
    resources: Vec<ResourceNode>,
    passes: Vec<PassNode>,
    /// Read-only imports that passes bind by their WGSL names ([`RenderGraph::import_named`]).
    named: NamedSet,
}

/// A resource that every pass of a frame may read, given by reference to [`RenderGraph::import_named`].
pub enum NamedResource<'a> {
    /// A storage or uniform buffer, bound whole.
    Buffer(&'a wgpu::Buffer),
    /// A texture and the view passes bind.
    Texture {
        /// The texture (for copies and its size).
        texture: &'a wgpu::Texture,
        /// The view bind groups take.
        view: &'a wgpu::TextureView,
    },
    /// A sampler.
    Sampler(&'a wgpu::Sampler),
}

enum Named {
    Buffer(Handle<Buffer>),
    Texture(Handle<Texture>),
    Sampler(wgpu::Sampler),
    /// Another WGSL name for the entry at this index of the set.
    Alias(usize),
}

/// Imported resources that passes bind by their WGSL names: the scene's group 0
/// ([`RenderGraph::import_named`]) or a set the script holds ([`RenderGraph::import_named_set`]),
/// which a pass reads or writes as its shader does ([`PassBuilder::declare_named`]).
#[derive(Default)]
pub struct NamedSet {
    entries: Vec<(&'static str, Named)>,
}

impl NamedSet {
    fn entry(&self, name: &str) -> Option<&Named> {
        let (_, named) = self.entries.iter().find(|(n, _)| *n == name)?;
        Some(self.resolve(named))
    }

    /// The entry an alias stands for; any other entry itself.
    fn resolve<'a>(&'a self, named: &'a Named) -> &'a Named {
        match named {
            Named::Alias(i) => &self.entries[*i].1,
            named => named,
        }
    }

    /// Binds the entry named `name` also under the WGSL name `alias` (one resource behind both).
    pub fn alias(&mut self, alias: &'static str, name: &str) {
        let i = self.entries.iter().position(|(n, _)| *n == name).unwrap_or_else(|| panic!("no entry '{name}' to alias"));
        self.entries.push((alias, Named::Alias(i)));
    }

    /// Adds a texture imported on its own ([`RenderGraph::import_texture`]) under the WGSL name `name`.
    pub fn insert_texture(&mut self, name: &'static str, handle: Handle<Texture>) {
        self.entries.push((name, Named::Texture(handle)));
    }

    /// The handle of the buffer named `name`, for a pass that declares it itself.
    pub fn buffer(&self, name: &str) -> Option<&Handle<Buffer>> {
        match self.entry(name)? {
            Named::Buffer(h) => Some(h),
            _ => None,
        }
    }

    /// The handle of the texture named `name`.
    pub fn texture(&self, name: &str) -> Option<&Handle<Texture>> {
        match self.entry(name)? {
            Named::Texture(h) => Some(h),
            _ => None,
        }
    }

    /// Declares on `node` every entry that `group` of `bindings` uses (a write too where `writes`
    /// says so) and returns them as bindings.
    fn declare(&self, node: &mut PassNode, bindings: &crate::shader::BindingMap, group: u32, writes: bool) -> Vec<(&'static str, Bind)> {
        let Some(used) = bindings.groups.get(&group) else { return Vec::new() };
        let mut out = Vec::new();
        for (name, named) in &self.entries {
            if !used.contains_key(*name) {
                continue;
            }
            let mut declare = |id: usize| {
                node.reads.push(id);
                if writes && bindings.writes.contains(*name) {
                    node.writes.push(id);
                }
                id
            };
            let bind = match self.resolve(named) {
                Named::Buffer(h) => Bind::Buffer(declare(h.id)),
                Named::Texture(h) => Bind::Texture(declare(h.id)),
                Named::Sampler(s) => Bind::Sampler(s.clone()),
                Named::Alias(_) => unreachable!("an alias names an entry that is not one"),
            };
            out.push((*name, bind));
        }
        out
    }
}

impl RenderGraph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    fn add_resource<K>(&mut self, name: &str, source: Source) -> Handle<K> {
        self.resources.push(ResourceNode { name: name.into(), source, exported: false });
        Handle { id: self.resources.len() - 1, _kind: PhantomData }
    }

    /// A texture that lives for this frame only (taken from a pool, so it costs no allocation once warm).
    pub fn create_texture(&mut self, name: &str, desc: TextureDesc) -> Handle<Texture> {
        self.add_resource(name, Source::TransientTexture(desc))
    }

    /// A buffer that lives for this frame only.
    pub fn create_buffer(&mut self, name: &str, desc: BufferDesc) -> Handle<Buffer> {
        self.add_resource(name, Source::TransientBuffer(desc))
    }

    /// A texture owned outside the graph (persistent or history data, a surface texture).
    pub fn import_texture(&mut self, name: &str, texture: &wgpu::Texture) -> Handle<Texture> {
        self.add_resource(name, Source::ImportedTexture(texture.clone()))
    }

    /// A buffer owned outside the graph.
    pub fn import_buffer(&mut self, name: &str, buffer: &wgpu::Buffer) -> Handle<Buffer> {
        self.add_resource(name, Source::ImportedBuffer(buffer.clone()))
    }

    /// Imports resources that the frame only reads and that passes bind by their WGSL names (the
    /// scene's bind group 0): a pass declares the ones its shader uses with
    /// [`PassBuilder::read_named`].
    pub fn import_named(&mut self, resources: &[(&'static str, NamedResource<'_>)]) {
        let set = self.import_named_set("", resources);
        self.named.entries.extend(set.entries);
    }

    /// Imports resources that passes bind by their WGSL names and may write (a DDGI volume's
    /// group 1), as a set the script holds: a pass declares the ones its shader uses, read or
    /// written as naga finds it, with [`PassBuilder::declare_named`]. `suffix` is appended to each
    /// resource's name in the graph (several sets of the same names).
    pub fn import_named_set(&mut self, suffix: &str, resources: &[(&'static str, NamedResource<'_>)]) -> NamedSet {
        let mut set = NamedSet::default();
        for (name, resource) in resources {
            let label = format!("{name}{suffix}");
            let named = match resource {
                NamedResource::Buffer(b) => Named::Buffer(self.import_buffer(&label, b)),
                NamedResource::Texture { texture, .. } => Named::Texture(self.import_texture(&label, texture)),
                NamedResource::Sampler(s) => Named::Sampler((*s).clone()),
            };
            set.entries.push((name, named));
        }
        set
    }

    /// Marks a resource as an output of the frame: the passes that produce it will run.
    pub fn export<K>(&mut self, handle: &Handle<K>) {
        self.resources[handle.id].exported = true;
    }

    /// Starts a pass; finish it with [`PassBuilder::render`].
    pub fn add_pass(&mut self, label: &str) -> PassBuilder<'_> {
        PassBuilder {
            graph: self,
            node: PassNode { label: label.into(), reads: Vec::new(), writes: Vec::new(), run: None, note: String::new(), left_out: false },
        }
    }

    /// Records a pass that the script chose not to run this frame, and why (the report lists it).
    pub fn leave_out(&mut self, label: &str, why: &str) {
        self.passes.push(PassNode {
            label: label.into(),
            reads: Vec::new(),
            writes: Vec::new(),
            run: None,
            note: why.into(),
            left_out: true,
        });
    }

    /// For each pass in order, whether it runs: a pass runs when something it writes is exported or
    /// read by a later pass that runs (a write that is not also a read ends the need for older data).
    pub fn live_passes(&self) -> Vec<bool> {
        let mut needed: Vec<bool> = self.resources.iter().map(|r| r.exported).collect();
        let mut live = vec![false; self.passes.len()];
        for (i, pass) in self.passes.iter().enumerate().rev() {
            if !pass.writes.iter().any(|&w| needed[w]) {
                continue;
            }
            live[i] = true;
            for &w in &pass.writes {
                needed[w] = false;
            }
            for &r in &pass.reads {
                needed[r] = true;
            }
        }
        live
    }

    /// Pass labels in script order.
    pub fn pass_labels(&self) -> Vec<&str> {
        self.passes.iter().map(|p| p.label.as_str()).collect()
    }

    /// Creates the transient resources, records every live pass into one command encoder, and submits it.
    pub fn execute(mut self, gpu: &GpuContext, pool: &mut TransientPool, timer: Option<&mut GpuTimer>) -> FrameReport {
        let live = self.live_passes();
        let mut taken_textures = Vec::new();
        let mut taken_buffers = Vec::new();
        let resolved: Vec<Resolved> = self
            .resources
            .iter()
            .map(|r| match &r.source {
                Source::TransientTexture(desc) => {
                    let t = pool.take_texture(&gpu.device, &r.name, *desc);
                    taken_textures.push((*desc, t.clone()));
                    Resolved::texture(t)
                }
                Source::ImportedTexture(t) => Resolved::texture(t.clone()),
                Source::TransientBuffer(desc) => {
                    let b = pool.take_buffer(&gpu.device, &r.name, *desc);
                    taken_buffers.push((*desc, b.clone()));
                    Resolved::Buffer(b)
                }
                Source::ImportedBuffer(b) => Resolved::Buffer(b.clone()),
            })
            .collect();

        let _execute = tracing::info_span!("graph_execute").entered();
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("render_graph") });
        let mut report = FrameReport::default();
        let timer = timer.filter(|_| gpu.timestamps);
        let ran_count = live.iter().filter(|&&l| l).count() as u32;
        let mut queries = timer;
        if let Some(t) = queries.as_mut() {
            t.reserve(&gpu.device, ran_count * 2);
        }
        let mut query_index = 0u32;
        for (pass, is_live) in self.passes.iter_mut().zip(&live) {
            if !is_live {
                let note = if pass.left_out { pass.note.clone() } else { "outputs not read this frame".into() };
                report.passes.push(PassRecord { label: pass.label.clone(), ran: false, note });
                continue;
            }
            let _record = tracing::info_span!("record_pass", pass = %pass.label).entered();
            encoder.push_debug_group(&pass.label);
            if let Some(t) = &queries {
                encoder.write_timestamp(t.query_set.as_ref().expect("reserved"), query_index);
            }
            if let Some(run) = pass.run.take() {
                let mut ctx = PassContext { label: &pass.label, encoder: &mut encoder, gpu, resources: &resolved };
                run(&mut ctx);
            }
            if let Some(t) = &queries {
                encoder.write_timestamp(t.query_set.as_ref().expect("reserved"), query_index + 1);
            }
            query_index += 2;
            encoder.pop_debug_group();
            report.passes.push(PassRecord { label: pass.label.clone(), ran: true, note: std::mem::take(&mut pass.note) });
        }
        if let Some(t) = queries.as_mut() {
            t.resolve(&mut encoder, query_index);
        }
        let command_buffer = encoder.finish();
        // The GPU cannot start the frame before this instant: the lower bound that places its
        // passes on the CPU's timeline in a Chrome trace ([`crate::trace`]).
        let submitted = (queries.is_some() && crate::trace::recording_gpu_spans()).then(Instant::now);
        gpu.queue.submit([command_buffer]);
        if let Some(t) = queries {
            let id = t.request(gpu, query_index);
            report.pending_timings =
                Some(PendingTimings { id, count: query_index, period_ns: gpu.timestamp_period, labels: report.ran_labels(), submitted });
        }
        for (desc, t) in taken_textures {
            pool.give_texture(desc, t);
        }
        for (desc, b) in taken_buffers {
            pool.give_buffer(desc, b);
        }
        report
    }
}

/// Declares one pass's reads and writes.
pub struct PassBuilder<'g> {
    graph: &'g mut RenderGraph,
    node: PassNode,
}

impl PassBuilder<'_> {
    /// Declares that the pass reads `handle`, and returns the access its closure reads it through.
    pub fn read<K>(&mut self, handle: &Handle<K>) -> Read<K> {
        self.node.reads.push(handle.id);
        Read { id: handle.id, _kind: PhantomData }
    }

    /// Declares that the pass writes `handle`, and returns the access its closure writes it through.
    pub fn write<K>(&mut self, handle: &mut Handle<K>) -> Write<K> {
        self.node.writes.push(handle.id);
        Write { id: handle.id, _kind: PhantomData }
    }

    /// Declares a read of every named import ([`RenderGraph::import_named`]) that `bindings` uses in
    /// `group`, and returns them as bindings for [`PassContext::bind_group`].
    pub fn read_named(&mut self, bindings: &crate::shader::BindingMap, group: u32) -> Vec<(&'static str, Bind)> {
        self.graph.named.declare(&mut self.node, bindings, group, false)
    }

    /// Declares every entry of `set` that `bindings` (a pipeline's, or several merged) uses in
    /// `group` — a write where naga finds the shader writes it, a read otherwise — and returns
    /// them as bindings for [`PassContext::bind_group`].
    pub fn declare_named(&mut self, set: &NamedSet, bindings: &crate::shader::BindingMap, group: u32) -> Vec<(&'static str, Bind)> {
        set.declare(&mut self.node, bindings, group, true)
    }

    /// Says how this pass was specialized for the frame (shown in the report beside its time).
    pub fn note(&mut self, text: &str) {
        self.node.note = text.into();
    }

    /// Finishes the pass with the closure that records its commands.
    pub fn render(mut self, run: impl FnOnce(&mut PassContext<'_>) + 'static) {
        self.node.run = Some(Box::new(run));
        self.graph.passes.push(self.node);
    }

    /// Finishes the pass with one dispatch of `program` over `workgroups` (x, y), bind group `i`
    /// built from `groups[i]`: one compute pass, and one bind group per group built each frame.
    pub fn compute(
        self,
        program: std::sync::Arc<crate::shader::Program<wgpu::ComputePipeline>>,
        groups: Vec<Vec<(&'static str, Bind)>>,
        workgroups: (u32, u32),
    ) {
        self.render(move |ctx| {
            let groups: Vec<wgpu::BindGroup> = groups.iter().zip(0..).map(|(g, i)| ctx.bind_group(&*program, i, g)).collect();
            crate::gpu::dispatch(ctx.encoder, ctx.label, &program.pipeline, &groups.iter().collect::<Vec<_>>(), workgroups);
        });
    }
}

enum Resolved {
    Texture(wgpu::Texture, wgpu::TextureView),
    Buffer(wgpu::Buffer),
}

impl Resolved {
    fn texture(t: wgpu::Texture) -> Self {
        let view = t.create_view(&Default::default());
        Resolved::Texture(t, view)
    }
}

/// What a pass closure records with.
pub struct PassContext<'a> {
    /// The pass label: use it for the wgpu passes the closure begins.
    pub label: &'a str,
    /// The command encoder of the frame: the closure records its passes and copies into it.
    pub encoder: &'a mut wgpu::CommandEncoder,
    /// The device, for bind groups and the like.
    pub gpu: &'a GpuContext,
    resources: &'a [Resolved],
}

impl<'a> PassContext<'a> {
    /// The texture behind a texture access.
    pub fn texture(&self, access: impl Access<Texture>) -> &'a wgpu::Texture {
        let resources: &'a [Resolved] = self.resources;
        match &resources[access.id()] {
            Resolved::Texture(t, _) => t,
            Resolved::Buffer(_) => unreachable!("texture handles only name textures"),
        }
    }

    /// The default view of a texture.
    pub fn view(&self, access: impl Access<Texture>) -> &'a wgpu::TextureView {
        let resources: &'a [Resolved] = self.resources;
        match &resources[access.id()] {
            Resolved::Texture(_, v) => v,
            Resolved::Buffer(_) => unreachable!("texture handles only name textures"),
        }
    }

    /// The buffer behind a buffer access.
    pub fn buffer(&self, access: impl Access<Buffer>) -> &'a wgpu::Buffer {
        let resources: &'a [Resolved] = self.resources;
        match &resources[access.id()] {
            Resolved::Buffer(b) => b,
            Resolved::Texture(..) => unreachable!("buffer handles only name buffers"),
        }
    }
}

/// What a pass binds to one WGSL global, by name ([`PassContext::bind_group`]): a resource the pass
/// declared (through the access [`PassBuilder::read`] or [`PassBuilder::write`] returned) or a
/// sampler. There is no way to name an undeclared graph resource here, so the graph's culling and
/// ordering see every resource a pass binds.
#[derive(Clone)]
pub enum Bind {
    /// A graph buffer, by its index in the graph (made by [`Bind::buffer`]), bound whole.
    Buffer(usize),
    /// A graph texture, by its index in the graph (made by [`Bind::texture`]), bound through its
    /// default view.
    Texture(usize),
    /// A sampler, which is not a graph resource.
    Sampler(wgpu::Sampler),
}

impl Bind {
    /// Binds the buffer that `access` names.
    pub fn buffer(access: impl Access<Buffer>) -> Self {
        Bind::Buffer(access.id())
    }

    /// Binds the default view of the texture that `access` names.
    pub fn texture(access: impl Access<Texture>) -> Self {
        Bind::Texture(access.id())
    }
}

impl<'a> PassContext<'a> {
    /// Builds bind group `group` of `program` from named bindings ([`Bind`]); like
    /// [`crate::shader::Program::bind_group`], names the pipeline does not use are ignored.
    pub fn bind_group<P: crate::shader::AutoLayout>(
        &self,
        program: &crate::shader::Program<P>,
        group: u32,
        entries: &[(&str, Bind)],
    ) -> wgpu::BindGroup {
        let resources: Vec<(&str, wgpu::BindingResource<'_>)> = entries
            .iter()
            .map(|(name, bind)| {
                let resource = match bind {
                    Bind::Buffer(id) => match &self.resources[*id] {
                        Resolved::Buffer(b) => b.as_entire_binding(),
                        Resolved::Texture(..) => unreachable!("buffer accesses only name buffers"),
                    },
                    Bind::Texture(id) => match &self.resources[*id] {
                        Resolved::Texture(_, v) => wgpu::BindingResource::TextureView(v),
                        Resolved::Buffer(_) => unreachable!("texture accesses only name textures"),
                    },
                    Bind::Sampler(s) => wgpu::BindingResource::Sampler(s),
                };
                (*name, resource)
            })
            .collect();
        program.bind_group(&self.gpu.device, group, &resources)
    }
}

/// Transient textures and buffers kept between frames for reuse.
#[derive(Resource, Default)]
pub struct TransientPool {
    textures: HashMap<TextureDesc, Vec<wgpu::Texture>>,
    buffers: HashMap<BufferDesc, Vec<wgpu::Buffer>>,
}

impl TransientPool {
    fn take_texture(&mut self, device: &wgpu::Device, name: &str, desc: TextureDesc) -> wgpu::Texture {
        self.textures.get_mut(&desc).and_then(Vec::pop).unwrap_or_else(|| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(name),
                size: wgpu::Extent3d { width: desc.width.max(1), height: desc.height.max(1), depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: desc.format,
                usage: desc.usage,
                view_formats: &[],
            })
        })
    }

    fn give_texture(&mut self, desc: TextureDesc, texture: wgpu::Texture) {
        self.textures.entry(desc).or_default().push(texture);
    }

    fn take_buffer(&mut self, device: &wgpu::Device, name: &str, desc: BufferDesc) -> wgpu::Buffer {
        self.buffers.get_mut(&desc).and_then(Vec::pop).unwrap_or_else(|| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(name),
                size: desc.size.max(4),
                usage: desc.usage,
                mapped_at_creation: false,
            })
        })
    }

    fn give_buffer(&mut self, desc: BufferDesc, buffer: wgpu::Buffer) {
        self.buffers.entry(desc).or_default().push(buffer);
    }
}

/// Whether each pass of a frame ran, and its GPU time once the timestamps have come back.
#[derive(Default)]
pub struct FrameReport {
    /// Every pass added, in order, with whether it ran.
    pub passes: Vec<PassRecord>,
    pending_timings: Option<PendingTimings>,
    /// The passes' GPU spans, kept when the timings came back while a trace records them.
    gpu_spans: Option<GpuFrameSpans>,
}

/// One pass of a frame report.
#[derive(Clone, Debug, PartialEq)]
pub struct PassRecord {
    /// The label the pass was added under.
    pub label: String,
    /// Whether the pass ran (false: the graph culled it, see `note`).
    pub ran: bool,
    /// Why it was left out, when it was; how it was specialized, when it ran.
    pub note: String,
}

impl FrameReport {
    fn ran_labels(&self) -> Vec<String> {
        self.passes.iter().filter(|p| p.ran).map(|p| p.label.clone()).collect()
    }

    /// Blocks until the GPU time of each pass that ran is known (`None` without timestamp support).
    pub fn wait_for_timings(&mut self, gpu: &GpuContext, timer: &mut GpuTimer) -> Option<Vec<(String, f64)>> {
        let pending = self.pending_timings.take()?;
        let _wait = tracing::info_span!("wait_for_gpu_timings").entered();
        gpu.wait_idle();
        let (times, spans) = timer.take(gpu, pending.id).and_then(|bytes| pending.read(&bytes))?;
        self.gpu_spans = spans;
        Some(times)
    }

    /// The timings if they have arrived, without waiting; call again later otherwise.
    pub fn try_timings(&mut self, gpu: &GpuContext, timer: &mut GpuTimer) -> Option<Vec<(String, f64)>> {
        let bytes = timer.take(gpu, self.pending_timings.as_ref()?.id)?;
        let (times, spans) = self.pending_timings.take()?.read(&bytes)?;
        self.gpu_spans = spans;
        Some(times)
    }

    /// The GPU spans of the passes that ran, once their timings have come back, if a trace was
    /// recording them when the frame was submitted ([`crate::trace::recording_gpu_spans`]).
    pub(crate) fn take_gpu_spans(&mut self) -> Option<GpuFrameSpans> {
        self.gpu_spans.take()
    }
}

/// Timestamp queries for per-pass spans, reused across frames; their values come back through a
/// [`ReadbackRing`] (a frame whose copies are all in flight gets no timings).
#[derive(Resource)]
pub struct GpuTimer {
    query_set: Option<wgpu::QuerySet>,
    capacity: u32,
    /// The queries resolved to ticks, copied into the ring after the frame's submission.
    resolved: Option<wgpu::Buffer>,
    ring: ReadbackRing,
    /// Copies that came back before their frame asked, by request id.
    arrived: HashMap<u64, Vec<u8>>,
    next_id: u64,
}

impl Default for GpuTimer {
    fn default() -> Self {
        Self {
            query_set: None,
            capacity: 0,
            resolved: None,
            ring: ReadbackRing::new("pass_timestamps_readback", 8),
            arrived: HashMap::new(),
            next_id: 0,
        }
    }
}

impl GpuTimer {
    fn reserve(&mut self, device: &wgpu::Device, count: u32) {
        if self.capacity < count.max(2) || self.query_set.is_none() {
            self.capacity = count.max(2).next_power_of_two();
            self.query_set = Some(device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass_timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: self.capacity,
            }));
            self.resolved = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pass_timestamps_resolve"),
                size: u64::from(self.capacity) * 8,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }));
        }
    }

    fn resolve(&self, encoder: &mut wgpu::CommandEncoder, count: u32) {
        if let (Some(qs), Some(resolved), true) = (&self.query_set, &self.resolved, count > 0) {
            encoder.resolve_query_set(qs, 0..count, resolved, 0);
        }
    }

    /// After the frame's submission: asks for its resolved ticks; returns the request's id.
    fn request(&mut self, gpu: &GpuContext, count: u32) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        if let (Some(resolved), true) = (&self.resolved, count > 0) {
            self.ring.request(gpu, resolved, id);
        }
        id
    }

    /// The ticks of request `id` once they have arrived (the others that arrived are kept).
    fn take(&mut self, gpu: &GpuContext, id: u64) -> Option<Vec<u8>> {
        for (frame, bytes) in self.ring.poll(gpu) {
            self.arrived.insert(frame, bytes);
        }
        // Requests older than the ring's depth never come back (dropped while every copy was in flight).
        self.arrived.retain(|&k, _| k + 64 >= id);
        self.arrived.remove(&id)
    }
}

/// Each pass's GPU milliseconds and, while a trace records them, the frame's GPU spans.
type PassTimes = (Vec<(String, f64)>, Option<GpuFrameSpans>);

struct PendingTimings {
    id: u64,
    count: u32,
    period_ns: f32,
    labels: Vec<String>,
    /// When the frame was submitted, while a trace records GPU spans.
    submitted: Option<Instant>,
}

impl PendingTimings {
    /// Each pass's milliseconds and, while a trace records them, the frame's GPU spans.
    fn read(self, bytes: &[u8]) -> Option<PassTimes> {
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(bytes.get(..self.count as usize * 8)?);
        let n = (self.count as usize / 2).min(self.labels.len());
        let times = (0..n)
            .map(|i| {
                let dt = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                (self.labels[i].clone(), dt as f64 * f64::from(self.period_ns) * 1e-6)
            })
            .collect();
        let spans = self.submitted.map(|submitted| GpuFrameSpans {
            submitted,
            observed: Instant::now(),
            period_ns: f64::from(self.period_ns),
            passes: (0..n).map(|i| (self.labels[i].clone(), ticks[2 * i], ticks[2 * i + 1].max(ticks[2 * i]))).collect(),
        });
        Some((times, spans))
    }
}

/// One frame's passes as GPU timestamps, with the CPU instants that bound them: what a Chrome
/// trace places on its GPU track ([`crate::trace`]).
#[derive(Clone, Debug)]
pub(crate) struct GpuFrameSpans {
    /// Just before the frame's commands were submitted: no pass began earlier.
    pub submitted: Instant,
    /// When the timestamps were seen on the CPU: every pass had ended by then.
    pub observed: Instant,
    /// Nanoseconds per timestamp tick.
    pub period_ns: f64,
    /// Each pass that ran: its label and its begin and end timestamps, in ticks.
    pub passes: Vec<(String, u64, u64)>,
}

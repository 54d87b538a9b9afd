//! WGSL shaders: a registry of modules that any crate adds to, `#include` resolution with a map
//! back to each module's own lines, naga validation and binding reflection.
//!
//! Each crate owns its passes' WGSL, in a folder beside its sources, and registers it with
//! [`register`]; the shared library that several crates include (the top-level `shaders/` crate,
//! [`shaders::LIBRARY`]: common, scene, BRDF, the ray-tracing core, DDGI's sampling) and the
//! engine's own passes ([`ENGINE_SHADERS`]) are always there. A module includes another by
//! name — `#include "ray_tracing.inc.wgsl"` — whichever crate registered it; modules named
//! `*.inc.wgsl` are libraries (no entry point). A naga error is reported in the included module's
//! own file and line, not in the expanded source.
//!
//! Why a registry of our own rather than a composer: `naga_oil` 0.23 (naga 30) composes into naga IR
//! and renames every imported item, which our bind-by-name reflection and pipeline-override
//! specialization would have to undo; `wesl` 0.6 needs Rust 1.97 (the workspace pins 1.95) and a
//! build script per crate. What we need — modules from several crates, includes by name, errors
//! in each module's own lines — is this file's hundred lines.
//!
//! The WGSL files are the one place where bindings are declared. Pipelines use wgpu's automatic
//! layouts, and Rust code fills a bind group by the *names* of the WGSL globals
//! ([`Program::bind_group`]): binding numbers are read off the shader with naga, never repeated in Rust.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{LazyLock, RwLock};

/// One WGSL module: the name `#include` and the pipeline constructors use, and its source.
pub type ShaderModule = (&'static str, &'static str);

/// The engine's own passes' WGSL (`engine/shaders/`): ray queries, TLAS refit, G-buffer, direct
/// light, tonemap, blit, TAA, exposure. The modules they share with other crates (scene,
/// ray-tracing core, common) are the library's ([`shaders::LIBRARY`]). A test checks that this
/// list matches the folder.
pub const ENGINE_SHADERS: &[ShaderModule] = &[
    ("trace_rays.wgsl", include_str!("../shaders/trace_rays.wgsl")),
    ("tlas_refit.wgsl", include_str!("../shaders/tlas_refit.wgsl")),
    ("gbuffer.wgsl", include_str!("../shaders/gbuffer.wgsl")),
    ("direct_lighting.wgsl", include_str!("../shaders/direct_lighting.wgsl")),
    ("tonemap.wgsl", include_str!("../shaders/tonemap.wgsl")),
    ("blit.wgsl", include_str!("../shaders/blit.wgsl")),
    ("taa.inc.wgsl", include_str!("../shaders/taa.inc.wgsl")),
    ("taa.wgsl", include_str!("../shaders/taa.wgsl")),
    ("taa_output.wgsl", include_str!("../shaders/taa_output.wgsl")),
    ("exposure.inc.wgsl", include_str!("../shaders/exposure.inc.wgsl")),
    ("exposure_histogram.wgsl", include_str!("../shaders/exposure_histogram.wgsl")),
    ("exposure_adapt.wgsl", include_str!("../shaders/exposure_adapt.wgsl")),
];

/// Every registered module by name: the shared library's and the engine's, then whatever crates added.
static REGISTRY: LazyLock<RwLock<BTreeMap<&'static str, &'static str>>> =
    LazyLock::new(|| RwLock::new(shaders::LIBRARY.iter().chain(ENGINE_SHADERS).copied().collect()));

/// A shader that failed to load; the message carries naga's report with file and line.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    /// No module of this name is registered.
    #[error("shader '{0}' is not registered (is the crate that owns it registered with engine::shader::register?)")]
    Missing(String),
    /// An `#include` names a module that is not registered.
    #[error("{file}: include of '{include}' cannot be resolved")]
    BadInclude {
        /// The module with the `#include` and the line of it, `name:line`.
        file: String,
        /// The module it names.
        include: String,
    },
    /// A module name was registered again with another source.
    #[error("shader module '{0}' is registered twice with different sources (module names are global: prefix them with the crate)")]
    Conflict(String),
    /// naga could not parse the expanded module.
    #[error("{file}: WGSL parse error:\n{report}")]
    Parse {
        /// The module parsed.
        file: String,
        /// naga's report, with the module and line of each fault (included modules too).
        report: String,
    },
    /// naga parsed the module, but its validator rejected it.
    #[error("{file}: WGSL validation error:\n{report}")]
    Validation {
        /// The module validated.
        file: String,
        /// naga's report, with the module and line of each fault (included modules too).
        report: String,
    },
}

/// Adds `modules` to the registry, so that pipelines and `#include` find them. Registering the
/// same module again is a no-op; a different source under a taken name is an error.
pub fn register(modules: &[ShaderModule]) -> Result<(), ShaderError> {
    let mut registry = REGISTRY.write().unwrap_or_else(|e| e.into_inner());
    for &(name, source) in modules {
        match registry.get(name) {
            Some(&old) if old != source => return Err(ShaderError::Conflict(name.into())),
            Some(_) => {}
            None => {
                registry.insert(name, source);
            }
        }
    }
    Ok(())
}

/// Registers a module whose source a crate generates at run time (e.g. WGSL constants written from
/// their Rust definitions, so that each has one home). Same rules as [`register`].
pub fn register_generated(name: &'static str, source: String) -> Result<(), ShaderError> {
    if let Some(old) = REGISTRY.read().unwrap_or_else(|e| e.into_inner()).get(name) {
        return if *old == source { Ok(()) } else { Err(ShaderError::Conflict(name.into())) };
    }
    // Leaked once per name: the registry lives as long as the process.
    register(&[(name, Box::leak(source.into_boxed_str()))])
}

/// The names of every registered module.
pub fn registered() -> Vec<&'static str> {
    REGISTRY.read().unwrap_or_else(|e| e.into_inner()).keys().copied().collect()
}

/// The source of a registered module.
pub fn source(name: &str) -> Result<&'static str, ShaderError> {
    REGISTRY.read().unwrap_or_else(|e| e.into_inner()).get(name).copied().ok_or_else(|| ShaderError::Missing(name.into()))
}

/// For a crate's test: `modules` lists exactly the `.wgsl` files of `dir`, with their current text.
pub fn check_shader_folder(dir: &Path, modules: &[ShaderModule]) -> Result<(), String> {
    let on_disk: std::collections::BTreeSet<String> = std::fs::read_dir(dir)
        .map_err(|e| format!("{}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    let listed: std::collections::BTreeSet<String> = modules.iter().map(|(n, _)| n.to_string()).collect();
    if on_disk != listed {
        return Err(format!("{}: the files {on_disk:?} differ from the registered list {listed:?}", dir.display()));
    }
    for (name, source) in modules {
        let disk = std::fs::read_to_string(dir.join(name)).map_err(|e| format!("{name}: {e}"))?;
        if disk != *source {
            return Err(format!("{name}: the embedded copy is stale"));
        }
    }
    Ok(())
}

/// A module with its includes expanded, and where each of its lines came from.
pub struct Preprocessed {
    /// The WGSL, every `#include` replaced by the module it names (each module once).
    pub source: String,
    /// For each line of `source`: the module it came from and its line there (1-based).
    origins: Vec<(&'static str, u32)>,
}

impl Preprocessed {
    /// The module, line and column (1-based) of byte `offset` of the expanded source.
    pub fn locate(&self, offset: usize) -> (&'static str, u32, u32) {
        let offset = offset.min(self.source.len());
        let prefix = &self.source[..offset];
        let line = prefix.matches('\n').count();
        let column = offset - prefix.rfind('\n').map_or(0, |p| p + 1) + 1;
        let (module, original) = self.origins.get(line).copied().unwrap_or(("?", 0));
        (module, original, column as u32)
    }

    /// `module:line:column: message` and the source line, for each labelled span of a naga error.
    fn report(&self, message: &str, labels: &[(naga::Span, String)]) -> String {
        let mut out = String::new();
        for (i, (span, label)) in labels.iter().enumerate() {
            let Some(range) = span.to_range() else { continue };
            let (module, line, column) = self.locate(range.start);
            let text = source(module).ok().and_then(|s| s.lines().nth(line.saturating_sub(1) as usize)).unwrap_or("");
            let head = if i == 0 { message } else { "note" };
            out.push_str(&format!("{module}:{line}:{column}: {head}: {label}\n    {}\n", text.trim_end()));
        }
        if out.is_empty() {
            out = format!("{message}\n");
        }
        out
    }
}

/// The source with every `#include "file"` line replaced by that file's text (each file at most
/// once), with a map from its lines back to each module's own.
pub fn preprocess(name: &str) -> Result<Preprocessed, ShaderError> {
    fn expand(name: &str, out: &mut Preprocessed, seen: &mut Vec<String>) -> Result<(), ShaderError> {
        if seen.iter().any(|s| s == name) {
            return Ok(());
        }
        seen.push(name.to_string());
        let (module, text) = REGISTRY
            .read()
            .unwrap_or_else(|e| e.into_inner())
            .get_key_value(name)
            .map(|(k, v)| (*k, *v))
            .ok_or_else(|| ShaderError::Missing(name.into()))?;
        for (number, line) in text.lines().enumerate() {
            if let Some(rest) = line.trim().strip_prefix("#include") {
                let include = rest.trim().trim_matches('"');
                expand(include, out, seen).map_err(|e| match e {
                    ShaderError::Missing(_) => ShaderError::BadInclude { file: format!("{name}:{}", number + 1), include: include.into() },
                    other => other,
                })?;
            } else {
                out.source.push_str(line);
                out.source.push('\n');
                out.origins.push((module, number as u32 + 1));
            }
        }
        Ok(())
    }
    let mut out = Preprocessed { source: String::new(), origins: Vec::new() };
    expand(name, &mut out, &mut Vec::new())?;
    Ok(out)
}

/// A parsed and validated shader module.
pub struct ParsedShader {
    /// The registered module's name, e.g. `taa.wgsl`.
    pub name: String,
    /// Its WGSL with the includes expanded (what the GPU compiles).
    pub source: String,
    /// naga's IR of it.
    pub module: naga::Module,
    /// naga's validation results (expression types, global uses per entry point).
    pub info: naga::valid::ModuleInfo,
}

/// Parses and validates a registered module with naga (no GPU needed). Errors name the module and
/// line where the fault is, included modules too. Validated for any device: subgroup operations
/// are refused ([`parse_with`] takes them).
pub fn parse(name: &str) -> Result<ParsedShader, ShaderError> {
    parse_with(name, naga::valid::Capabilities::default())
}

/// What naga may let a module use on `device`, as wgpu validates it: the defaults, and subgroup
/// operations where the device has [`wgpu::Features::SUBGROUP`].
pub fn device_capabilities(device: &wgpu::Device) -> naga::valid::Capabilities {
    let mut capabilities = naga::valid::Capabilities::default();
    if device.features().contains(wgpu::Features::SUBGROUP) {
        capabilities |= naga::valid::Capabilities::SUBGROUP;
    }
    capabilities
}

/// [`parse`], validated with `capabilities` (e.g. [`naga::valid::Capabilities::SUBGROUP`] for a
/// module with subgroup operations).
pub fn parse_with(name: &str, capabilities: naga::valid::Capabilities) -> Result<ParsedShader, ShaderError> {
    let expanded = preprocess(name)?;
    let module = naga::front::wgsl::parse_str(&expanded.source).map_err(|e| {
        let labels: Vec<(naga::Span, String)> = e.labels().map(|(s, l)| (s, l.to_string())).collect();
        let mut report = expanded.report(e.message(), &labels);
        for note in e.notes() {
            report.push_str(&format!("note: {note}\n"));
        }
        ShaderError::Parse { file: name.into(), report }
    })?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities).validate(&module).map_err(|e| {
        let message = with_causes(e.as_inner());
        let labels: Vec<(naga::Span, String)> = e.spans().cloned().collect();
        ShaderError::Validation { file: name.into(), report: expanded.report(&message, &labels) }
    })?;
    Ok(ParsedShader { name: name.into(), source: expanded.source, module, info })
}

/// An error's message followed by each of its causes' (naga nests the reason in `source()`).
fn with_causes(e: &dyn std::error::Error) -> String {
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        message.push_str(&format!(": {c}"));
        cause = c.source();
    }
    message
}

impl ParsedShader {
    /// The value of the module's `const NAME: u32 = …;` (literal initializers only), so that a
    /// number the host needs is written once, in the shader.
    pub fn u32_constant(&self, name: &str) -> Option<u32> {
        let (_, constant) = self.module.constants.iter().find(|(_, c)| c.name.as_deref() == Some(name))?;
        match self.module.global_expressions[constant.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => Some(v),
            naga::Expression::Literal(naga::Literal::AbstractInt(v)) => u32::try_from(v).ok(),
            _ => None,
        }
    }

    /// The members of the WGSL struct `name` with their byte offsets as naga lays them out, and the
    /// struct's size (for host-side mirror checks: [`check_struct_layout`]).
    pub fn struct_layout(&self, name: &str) -> Option<(Vec<(String, u32)>, u32)> {
        self.module.types.iter().find_map(|(_, ty)| match &ty.inner {
            naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some(name) => {
                Some((members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(), *span))
            }
            _ => None,
        })
    }

    /// The storage buffers the entry points read or write (what wgpu counts against
    /// `max_storage_buffers_per_shader_stage`).
    pub fn storage_buffers_used(&self, entry_points: &[&str]) -> u32 {
        let mut used = std::collections::BTreeSet::new();
        for (index, ep) in self.module.entry_points.iter().enumerate() {
            if !entry_points.contains(&ep.name.as_str()) {
                continue;
            }
            let info = self.info.get_entry_point(index);
            for (handle, var) in self.module.global_variables.iter() {
                if matches!(var.space, naga::AddressSpace::Storage { .. }) && !info[handle].is_empty() {
                    used.insert(handle);
                }
            }
        }
        used.len() as u32
    }

    /// The resource bindings that the given entry points use: `group → (name → binding)`.
    pub fn used_bindings(&self, entry_points: &[&str]) -> BindingMap {
        let mut groups: BTreeMap<u32, BTreeMap<String, u32>> = BTreeMap::new();
        let mut writes = std::collections::BTreeSet::new();
        for (index, ep) in self.module.entry_points.iter().enumerate() {
            if !entry_points.contains(&ep.name.as_str()) {
                continue;
            }
            let info = self.info.get_entry_point(index);
            for (handle, var) in self.module.global_variables.iter() {
                let (Some(binding), Some(name)) = (&var.binding, &var.name) else { continue };
                let usage = info[handle];
                if !usage.is_empty() {
                    groups.entry(binding.group).or_default().insert(name.clone(), binding.binding);
                }
                if usage.intersects(naga::valid::GlobalUse::WRITE | naga::valid::GlobalUse::ATOMIC) {
                    writes.insert(name.clone());
                }
            }
        }
        BindingMap { groups, writes }
    }

    /// Validates the module as the pipeline of compute entry point `entry` with `constants` for its
    /// `override` constants sees it: naga's pipeline-constant pass (the one wgpu runs when it
    /// builds the pipeline) resolves the overrides, sizes override-sized arrays and validates the
    /// result. So every variant a host builds can be checked without a GPU.
    pub fn validate_compute_variant(&self, entry: &str, constants: &[(&str, f64)]) -> Result<(), ShaderError> {
        let mut values = naga::back::PipelineConstants::default();
        for &(name, value) in constants {
            values.insert(name.to_string(), value);
        }
        naga::back::pipeline_constants::process_overrides(&self.module, &self.info, Some((naga::ShaderStage::Compute, entry)), &values)
            .map(|_| ())
            .map_err(|e| ShaderError::Validation {
                file: self.name.clone(),
                report: format!("entry point '{entry}' with {constants:?}: {}", with_causes(&e)),
            })
    }

    /// Creates the wgpu module from the preprocessed source.
    pub fn create_module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&self.name),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(&self.source)),
        })
    }
}

/// Which named globals an entry point binds, per group, and which of them it writes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BindingMap {
    /// For each bind group the entry points use: each bound global's name and its binding index.
    pub groups: BTreeMap<u32, BTreeMap<String, u32>>,
    /// The bound globals the entry points write (storage buffers and textures), as naga's analysis
    /// finds them: a render-graph pass declares these as writes, the others as reads.
    pub writes: std::collections::BTreeSet<String>,
}

/// A pipeline with the binding names its shader declares.
pub struct Program<P> {
    /// The pipeline's label (its wgpu label and the pass it is usually used by).
    pub label: String,
    /// The wgpu compute or render pipeline, with automatic bind group layouts.
    pub pipeline: P,
    /// What its entry points bind, by WGSL name.
    pub bindings: BindingMap,
}

/// Pipelines that can hand out their automatic bind group layouts.
pub trait AutoLayout {
    /// The layout wgpu derived for bind group `group` from the shader.
    fn layout(&self, group: u32) -> wgpu::BindGroupLayout;
}

impl AutoLayout for wgpu::ComputePipeline {
    fn layout(&self, group: u32) -> wgpu::BindGroupLayout {
        self.get_bind_group_layout(group)
    }
}

impl AutoLayout for wgpu::RenderPipeline {
    fn layout(&self, group: u32) -> wgpu::BindGroupLayout {
        self.get_bind_group_layout(group)
    }
}

impl<P: AutoLayout> Program<P> {
    /// Builds bind group `group` from resources given by their WGSL names. Every binding the pipeline
    /// uses must be given (a missing one is a programming error and panics with its name); names the
    /// pipeline does not use are ignored, so one list can serve several variants of a shader.
    pub fn bind_group(&self, device: &wgpu::Device, group: u32, resources: &[(&str, wgpu::BindingResource<'_>)]) -> wgpu::BindGroup {
        let wanted = self.bindings.groups.get(&group).cloned().unwrap_or_default();
        let entries: Vec<wgpu::BindGroupEntry<'_>> = wanted
            .iter()
            .map(|(name, &binding)| {
                let resource = resources
                    .iter()
                    .find(|(n, _)| n == name)
                    .unwrap_or_else(|| panic!("{}: no resource given for binding '{name}' (group {group})", self.label))
                    .1
                    .clone();
                wgpu::BindGroupEntry { binding, resource }
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&self.label),
            layout: &self.pipeline.layout(group),
            entries: &entries,
        })
    }

    /// Whether the pipeline uses bind group `group` at all.
    pub fn uses_group(&self, group: u32) -> bool {
        self.bindings.groups.contains_key(&group)
    }
}

/// Parses `file` and creates a compute pipeline for `entry` labelled `label`.
pub fn compute_program(device: &wgpu::Device, file: &str, entry: &str, label: &str) -> Result<Program<wgpu::ComputePipeline>, ShaderError> {
    compute_program_with_constants(device, file, entry, label, &[])
}

/// [`compute_program`] with values for the shader's `override` constants.
pub fn compute_program_with_constants(
    device: &wgpu::Device,
    file: &str,
    entry: &str,
    label: &str,
    constants: &[(&str, f64)],
) -> Result<Program<wgpu::ComputePipeline>, ShaderError> {
    let parsed = parse_with(file, device_capabilities(device))?;
    let module = parsed.create_module(device);
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
        cache: None,
    });
    Ok(Program { label: label.into(), pipeline, bindings: parsed.used_bindings(&[entry]) })
}

/// What a render pipeline draws into.
pub struct RenderTargets<'a> {
    /// The colour attachments, in `@location` order (format, blending, write mask).
    pub colors: &'a [Option<wgpu::ColorTargetState>],
    /// The depth attachment and its test, if any.
    pub depth: Option<wgpu::DepthStencilState>,
    /// Topology, winding and culling.
    pub primitive: wgpu::PrimitiveState,
}

/// Parses `file` and creates a render pipeline from its `vs_main` and `fs_main` entry points.
pub fn render_program(
    device: &wgpu::Device,
    file: &str,
    label: &str,
    targets: RenderTargets<'_>,
) -> Result<Program<wgpu::RenderPipeline>, ShaderError> {
    render_program_with_constants(device, file, label, targets, &[])
}

/// [`render_program`] with values for the shader's `override` constants (both stages).
pub fn render_program_with_constants(
    device: &wgpu::Device,
    file: &str,
    label: &str,
    targets: RenderTargets<'_>,
    constants: &[(&str, f64)],
) -> Result<Program<wgpu::RenderPipeline>, ShaderError> {
    let parsed = parse(file)?;
    let module = parsed.create_module(device);
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
            buffers: &[],
        },
        primitive: targets.primitive,
        depth_stencil: targets.depth,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
            targets: targets.colors,
        }),
        multiview_mask: None,
        cache: None,
    });
    Ok(Program { label: label.into(), pipeline, bindings: parsed.used_bindings(&["vs_main", "fs_main"]) })
}

/// A host mirror of a WGSL struct: its WGSL name, size and each field's offset, from
/// [`gpu_struct_layout!`](crate::gpu_struct_layout!). [`check_struct_layout`] compares it with
/// naga's layout.
#[derive(Clone, Debug)]
pub struct HostStruct {
    /// The struct's name, the same on the host and in WGSL.
    pub name: &'static str,
    /// `size_of` the host type, in bytes.
    pub size: usize,
    /// Each field's WGSL member name and byte offset in the host type, in declaration order.
    pub fields: Vec<(&'static str, usize)>,
    /// A registered module that declares the struct.
    pub module: &'static str,
}

/// The [`HostStruct`] of a `#[repr(C)]` type whose fields carry the WGSL member names:
/// `gpu_struct_layout!(DdgiRay in "ddgi_common.inc.wgsl" { direction, probe })`. Padding fields the
/// WGSL struct also declares are listed like the others.
#[macro_export]
macro_rules! gpu_struct_layout {
    ($ty:ident in $module:literal { $($field:ident),* $(,)? }) => {
        $crate::shader::HostStruct {
            name: stringify!($ty),
            size: ::core::mem::size_of::<$ty>(),
            fields: vec![$((stringify!($field), ::core::mem::offset_of!($ty, $field))),*],
            module: $module,
        }
    };
}

/// Checks a host mirror against naga's layout of the WGSL struct of the same name: the same
/// members in the same order at the same offsets, and the same size.
pub fn check_struct_layout(host: &HostStruct) -> Result<(), String> {
    let parsed = parse(host.module).map_err(|e| e.to_string())?;
    let (members, size) = parsed.struct_layout(host.name).ok_or_else(|| format!("{} declares no struct {}", host.module, host.name))?;
    let wgsl: Vec<(&str, usize)> = members.iter().map(|(n, o)| (n.as_str(), *o as usize)).collect();
    if wgsl != host.fields {
        return Err(format!("{}: Rust fields and offsets {:?} differ from WGSL's {:?}", host.name, host.fields, wgsl));
    }
    if size as usize != host.size {
        return Err(format!("{}: Rust mirror is {} bytes, WGSL layout {size}", host.name, host.size));
    }
    Ok(())
}

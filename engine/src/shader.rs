//! WGSL shaders: the embedded library, `#include` resolution, naga validation and binding reflection.
//!
//! The WGSL files are the one place where bindings are declared. Pipelines use wgpu's automatic
//! layouts, and Rust code fills a bind group by the *names* of the WGSL globals
//! ([`Program::bind_group`]): binding numbers are read off the shader with naga, never repeated in Rust.

use std::borrow::Cow;
use std::collections::BTreeMap;

/// Every WGSL file of `shaders/`, embedded. A test checks that this list matches the folder.
pub const SHADER_FILES: &[(&str, &str)] = &[
    ("common.inc.wgsl", include_str!("../../shaders/common.inc.wgsl")),
    ("scene.inc.wgsl", include_str!("../../shaders/scene.inc.wgsl")),
    ("ray_tracing.inc.wgsl", include_str!("../../shaders/ray_tracing.inc.wgsl")),
    ("trace_rays.wgsl", include_str!("../../shaders/trace_rays.wgsl")),
    ("bench_trace.wgsl", include_str!("../../shaders/bench_trace.wgsl")),
    ("pathtrace.wgsl", include_str!("../../shaders/pathtrace.wgsl")),
    ("gbuffer.wgsl", include_str!("../../shaders/gbuffer.wgsl")),
    ("direct_lighting.wgsl", include_str!("../../shaders/direct_lighting.wgsl")),
    ("tonemap.wgsl", include_str!("../../shaders/tonemap.wgsl")),
    ("blit.wgsl", include_str!("../../shaders/blit.wgsl")),
    ("ddgi.inc.wgsl", include_str!("../../shaders/ddgi.inc.wgsl")),
    ("ddgi_rays.wgsl", include_str!("../../shaders/ddgi_rays.wgsl")),
    ("ddgi_update.wgsl", include_str!("../../shaders/ddgi_update.wgsl")),
    ("ddgi_gather.wgsl", include_str!("../../shaders/ddgi_gather.wgsl")),
    ("ddgi_probes.wgsl", include_str!("../../shaders/ddgi_probes.wgsl")),
    ("ddgi_selftest.wgsl", include_str!("../../shaders/ddgi_selftest.wgsl")),
];

/// A shader that failed to load; the message carries naga's report with file and line.
#[derive(Debug, thiserror::Error)]
pub enum ShaderError {
    #[error("shader '{0}' is not in the shader library")]
    Missing(String),
    #[error("{file}: include of '{include}' cannot be resolved")]
    BadInclude { file: String, include: String },
    #[error("{file}: WGSL parse error:\n{report}")]
    Parse { file: String, report: String },
    #[error("{file}: WGSL validation error:\n{report}")]
    Validation { file: String, report: String },
}

/// The embedded source of one file.
pub fn source(name: &str) -> Result<&'static str, ShaderError> {
    SHADER_FILES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s).ok_or_else(|| ShaderError::Missing(name.into()))
}

/// The source with every `#include "file"` line replaced by that file's text (each file at most once).
pub fn preprocess(name: &str) -> Result<String, ShaderError> {
    fn expand(name: &str, out: &mut String, seen: &mut Vec<String>) -> Result<(), ShaderError> {
        if seen.iter().any(|s| s == name) {
            return Ok(());
        }
        seen.push(name.to_string());
        for line in source(name)?.lines() {
            if let Some(rest) = line.trim().strip_prefix("#include") {
                let include = rest.trim().trim_matches('"');
                expand(include, out, seen).map_err(|e| match e {
                    ShaderError::Missing(_) => ShaderError::BadInclude { file: name.into(), include: include.into() },
                    other => other,
                })?;
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
        Ok(())
    }
    let mut out = String::new();
    expand(name, &mut out, &mut Vec::new())?;
    Ok(out)
}

/// A parsed and validated shader module.
pub struct ParsedShader {
    pub name: String,
    pub source: String,
    pub module: naga::Module,
    pub info: naga::valid::ModuleInfo,
}

/// Parses and validates a file of the library with naga (no GPU needed).
pub fn parse(name: &str) -> Result<ParsedShader, ShaderError> {
    let source = preprocess(name)?;
    let module = naga::front::wgsl::parse_str(&source)
        .map_err(|e| ShaderError::Parse { file: name.into(), report: e.emit_to_string_with_path(&source, name) })?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
        .validate(&module)
        .map_err(|e| ShaderError::Validation { file: name.into(), report: e.emit_to_string_with_path(&source, name) })?;
    Ok(ParsedShader { name: name.into(), source, module, info })
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

    /// Size in bytes of the WGSL struct named `name` as naga lays it out (for host-side mirror checks).
    pub fn struct_size(&self, name: &str) -> Option<u32> {
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(self.module.to_ctx()).ok()?;
        self.module
            .types
            .iter()
            .find(|(_, ty)| ty.name.as_deref() == Some(name) && matches!(ty.inner, naga::TypeInner::Struct { .. }))
            .map(|(h, _)| layouter[h].size)
    }

    /// The resource bindings that the given entry points use: `group → (name → binding)`.
    pub fn used_bindings(&self, entry_points: &[&str]) -> BindingMap {
        let mut groups: BTreeMap<u32, BTreeMap<String, u32>> = BTreeMap::new();
        for (index, ep) in self.module.entry_points.iter().enumerate() {
            if !entry_points.contains(&ep.name.as_str()) {
                continue;
            }
            let info = self.info.get_entry_point(index);
            for (handle, var) in self.module.global_variables.iter() {
                let (Some(binding), Some(name)) = (&var.binding, &var.name) else { continue };
                if !info[handle].is_empty() {
                    groups.entry(binding.group).or_default().insert(name.clone(), binding.binding);
                }
            }
        }
        BindingMap { groups }
    }

    /// Creates the wgpu module from the preprocessed source.
    pub fn create_module(&self, device: &wgpu::Device) -> wgpu::ShaderModule {
        device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(&self.name),
            source: wgpu::ShaderSource::Wgsl(Cow::Borrowed(&self.source)),
        })
    }
}

/// Which named globals an entry point binds, per group.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BindingMap {
    pub groups: BTreeMap<u32, BTreeMap<String, u32>>,
}

/// A pipeline with the binding names its shader declares.
pub struct Program<P> {
    pub label: String,
    pub pipeline: P,
    pub bindings: BindingMap,
}

/// Pipelines that can hand out their automatic bind group layouts.
pub trait AutoLayout {
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
    let parsed = parse(file)?;
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
    pub colors: &'a [Option<wgpu::ColorTargetState>],
    pub depth: Option<wgpu::DepthStencilState>,
    pub primitive: wgpu::PrimitiveState,
}

/// Parses `file` and creates a render pipeline from its `vs_main` and `fs_main` entry points.
pub fn render_program(
    device: &wgpu::Device,
    file: &str,
    label: &str,
    targets: RenderTargets<'_>,
) -> Result<Program<wgpu::RenderPipeline>, ShaderError> {
    let parsed = parse(file)?;
    let module = parsed.create_module(device);
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: None,
        vertex: wgpu::VertexState { module: &module, entry_point: Some("vs_main"), compilation_options: Default::default(), buffers: &[] },
        primitive: targets.primitive,
        depth_stencil: targets.depth,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: targets.colors,
        }),
        multiview_mask: None,
        cache: None,
    });
    Ok(Program { label: label.into(), pipeline, bindings: parsed.used_bindings(&["vs_main", "fs_main"]) })
}

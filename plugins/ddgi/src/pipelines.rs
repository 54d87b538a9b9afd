//! The pipelines of the DDGI passes, built once when the plugin starts (the trace's specialized
//! variants and the probe debug view's on first use).

use std::collections::HashMap;
use std::sync::Arc;

use bevy_ecs::prelude::*;
use engine::gpu::GpuContext;
use engine::render::HDR_FORMAT;
use engine::shader::{Program, RenderTargets, ShaderError, compute_program, compute_program_with_constants, render_program};
use engine::wgpu;

use crate::debug_view::probe_sphere_vertices;

pub(crate) type ComputeProgram = Arc<Program<wgpu::ComputePipeline>>;

/// Which scene features the ray passes were compiled for (spot cones and emission lookups are left
/// out of scenes that have none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Specialization {
    pub spot_lights: bool,
    pub emissive: bool,
    pub alpha_test: bool,
}

impl Specialization {
    pub(crate) fn note(self) -> String {
        let mut parts = Vec::new();
        if !self.spot_lights {
            parts.push("no spot-cone code (no spot lights)");
        }
        if !self.emissive {
            parts.push("no emission lookup (no emissive materials)");
        }
        if !self.alpha_test {
            parts.push("no alpha test (no alpha-masked materials)");
        }
        if parts.is_empty() { String::new() } else { format!("specialized: {}", parts.join(", ")) }
    }
}

/// The ray passes' kernels, each compiled per [`Specialization`]: `(shader file, entry point)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum RayKernel {
    /// `ddgi_trace`, a thread a ray: trace and shading.
    Trace,
    /// `ddgi_trace` with persistent threads: closest hits only ([`crate::DdgiVolume::persistent_trace`]).
    PersistentTrace,
    /// `ddgi_shade`: the shading of the persistent trace's hits.
    Shade,
}

impl RayKernel {
    fn entry(self) -> (&'static str, &'static str) {
        match self {
            Self::Trace => ("ddgi_trace.wgsl", "trace_rays"),
            Self::PersistentTrace => ("ddgi_trace.wgsl", "trace_rays_persistent"),
            Self::Shade => ("ddgi_shade.wgsl", "shade_rays"),
        }
    }
}

/// Pipelines of the DDGI passes.
#[derive(Resource)]
pub struct DdgiPipelines {
    pub(crate) plan: ComputeProgram,
    pub(crate) plan_scale: ComputeProgram,
    pub(crate) scale: ComputeProgram,
    pub(crate) plan_blocks: ComputeProgram,
    pub(crate) place: ComputeProgram,
    specialized: HashMap<(Specialization, RayKernel), ComputeProgram>,
    pub(crate) update_irradiance: ComputeProgram,
    pub(crate) update: ComputeProgram,
    pub(crate) gather: ComputeProgram,
    pub(crate) contact_occlusion: ComputeProgram,
    pub(crate) composite: ComputeProgram,
    pub(crate) composite_indirect: ComputeProgram,
    pub(crate) composite_debug: ComputeProgram,
    /// Built on first use (the debug view is rarely on), with its vertices per sphere.
    probe_spheres: Option<(Arc<Program<wgpu::RenderPipeline>>, u32)>,
    /// The atlases' bilinear sampler (`ddgi_sampler`).
    pub sampler: wgpu::Sampler,
}

impl DdgiPipelines {
    /// Registers DDGI's shaders and builds every pass's pipeline (the trace's specialized variants
    /// and the probe debug view's later, on first use).
    pub fn new(gpu: &GpuContext) -> Result<Self, ShaderError> {
        crate::register_shaders()?;
        let p = |file: &str, entry: &str| compute_program(&gpu.device, file, entry, entry).map(Arc::new);
        Ok(Self {
            plan: p("ddgi_budget.wgsl", "plan_rays")?,
            plan_scale: p("ddgi_budget.wgsl", "plan_budget_scale")?,
            scale: p("ddgi_budget.wgsl", "scale_rays")?,
            plan_blocks: p("ddgi_budget.wgsl", "plan_ray_blocks")?,
            place: p("ddgi_budget.wgsl", "place_rays")?,
            specialized: HashMap::new(),
            update_irradiance: p("ddgi_probe_update.wgsl", "update_irradiance_maps")?,
            update: p("ddgi_probe_update.wgsl", "update_probes")?,
            gather: p("ddgi_gather.wgsl", "gather_irradiance")?,
            contact_occlusion: p("ddgi_contact_occlusion.wgsl", "contact_occlusion")?,
            composite: p("ddgi_composite.wgsl", "composite")?,
            composite_indirect: p("ddgi_composite.wgsl", "composite_indirect")?,
            composite_debug: p("ddgi_composite.wgsl", "composite_debug")?,
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
    pub(crate) fn probe_spheres_program(&mut self, gpu: &GpuContext) -> Result<(Arc<Program<wgpu::RenderPipeline>>, u32), ShaderError> {
        if let Some(p) = &self.probe_spheres {
            return Ok(p.clone());
        }
        let vertices = probe_sphere_vertices()?;
        let program = render_program(
            &gpu.device,
            "ddgi_probe_spheres.wgsl",
            "ddgi_probe_spheres",
            RenderTargets {
                colors: &[Some(wgpu::ColorTargetState { format: HDR_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                depth: Some(engine::render::depth_test()),
                primitive: wgpu::PrimitiveState { cull_mode: Some(wgpu::Face::Back), ..Default::default() },
            },
        )?;
        let program = (Arc::new(program), vertices);
        self.probe_spheres = Some(program.clone());
        Ok(program)
    }

    /// The pipeline of a ray pass's `kernel` compiled for `s` (built on first use).
    pub(crate) fn ray_program(&mut self, gpu: &GpuContext, s: Specialization, kernel: RayKernel) -> Result<ComputeProgram, ShaderError> {
        if let Some(p) = self.specialized.get(&(s, kernel)) {
            return Ok(p.clone());
        }
        let constants = [
            ("SCENE_HAS_SPOT_LIGHTS", f64::from(u8::from(s.spot_lights))),
            ("SCENE_HAS_EMISSIVE", f64::from(u8::from(s.emissive))),
            ("SCENE_HAS_ALPHA_TEST", f64::from(u8::from(s.alpha_test))),
        ];
        let (file, entry) = kernel.entry();
        let program = Arc::new(compute_program_with_constants(&gpu.device, file, entry, entry, &constants)?);
        self.specialized.insert((s, kernel), program.clone());
        Ok(program)
    }
}

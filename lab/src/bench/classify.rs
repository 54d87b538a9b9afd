//! `bench classify`: DDGI's probe classification after it has run, checked against an
//! independent test with rays traced on the GPU ([`classification_check`]).

use engine::app::run_headless;
use engine::gpu::GpuContext;
use engine::render::{GpuScene, RenderSize};
use engine::rt::RayTracingScene;
use engine::scene::SceneDescription;
use glam::{Mat4, Vec3};

/// Classification against an independent test, after DDGI (adaptive budgets on) has run: which
/// probes sit inside solid geometry, and which probes a visible surface depends on.
#[derive(Debug)]
pub struct ClassificationCheck {
    pub probes: usize,
    /// Probes whose position sees back faces in at least 90% of 64 directions and escapes in none.
    pub inside: usize,
    pub inside_off: usize,
    /// Probes, not inside, of the cage around a surface point that a camera ray hits and that
    /// they see unoccluded.
    pub needed: usize,
    pub needed_off: usize,
    /// Of those, the ones that saw light (luma above the dark threshold): switched off for
    /// another reason than darkness.
    pub needed_off_lit: usize,
    /// Each needed probe switched off, for a diagnosis: (index, grid coordinates, relocation
    /// offset in cells, share of the checker's 64 rays that hit back faces, the probe's luma, its
    /// rays in a row that found no surface in its region).
    pub needed_off_probes: Vec<(usize, glam::UVec3, Vec3, f32, f32, u32)>,
}

/// Runs `frames` frames of DDGI on `scene` with a `grid` of probes (the scene's bounds, adaptive
/// budgets on), then checks every probe's state with rays traced on the GPU: 64 spherical Fibonacci
/// rays from each probe's position (inside: ≥ 90% back faces, no miss), and for each of 64 × 64
/// camera rays, a visibility ray from each probe of the cage around its hit point.
pub fn classification_check(gpu: &GpuContext, scene: SceneDescription, grid: [u32; 3], frames: u32) -> Result<ClassificationCheck, String> {
    use engine::rt::cpu::GpuRay;
    let volume = ddgi::DdgiVolume { probe_counts: Some(grid.into()), adaptive: ddgi::DdgiAdaptive::on(), ..Default::default() };
    let mut app = engine::headless::headless_app(gpu, RenderSize { width: 64, height: 64 }, 1.0 / 60.0);
    crate::progress::show_blas_builds(&mut app);
    ddgi::use_ddgi(&mut app, volume, ddgi::DdgiOutput::Full);
    scene.spawn(app.world_mut());
    run_headless(&mut app, frames.max(1));
    let world = app.world();
    let volumes = world.resource::<ddgi::DdgiGpuVolumes>();
    let Some((_, v)) = volumes.volumes.first() else {
        return Err(volumes.first_error().unwrap_or("no DDGI volume").to_string());
    };
    let data: Vec<ddgi::gpu::DdgiProbeData> = bytemuck::pod_collect_to_vec(&engine::gpu::readback::read_buffer(gpu, &v.probes));
    let layout = v.layout.clone();
    let n = layout.probe_count as usize;
    let position = |i: usize| layout.grid_position(i as u32) + Vec3::from_array(data[i].offset);
    let off = |i: usize| data[i].state & ddgi::gpu::PROBE_INACTIVE != 0;
    let brightest = data.iter().map(|d| d.luma).fold(0.0f32, f32::max);
    let dark = |i: usize| data[i].luma < v.settings.adaptive.dark_fraction * brightest;
    let (gpu_scene, rt) = (world.resource::<GpuScene>(), world.resource::<RayTracingScene>());
    let tracer = engine::rt::RayTracer::new(gpu).map_err(|e| e.to_string())?;
    let directions = engine::rt::cpu::fibonacci_directions(64);
    let rays: Vec<GpuRay> = (0..n)
        .flat_map(|i| {
            let origin = position(i).to_array();
            directions.iter().map(move |d| GpuRay { origin, tmin: 0.0, direction: d.to_array(), tmax: 1e30 })
        })
        .collect();
    let hits = tracer.trace(gpu, gpu_scene, rt, &rays, false);
    let backface_share: Vec<f32> =
        hits.chunks_exact(64).map(|h| h.iter().filter(|r| r.instance != u32::MAX && r.flags & 1 == 0).count() as f32 / 64.0).collect();
    let inside: Vec<bool> = hits
        .chunks_exact(64)
        .map(|h| {
            let misses = h.iter().filter(|r| r.instance == u32::MAX).count();
            let back = h.iter().filter(|r| r.instance != u32::MAX && r.flags & 1 == 0).count();
            misses == 0 && back * 10 >= 9 * 64
        })
        .collect();
    // Camera rays through a 64 × 64 grid of the view.
    let view = gpu_scene.view_uniform;
    let world_from_clip = Mat4::from_cols_array_2d(&view.world_from_clip);
    let eye = Vec3::from_array(view.camera_position);
    let camera_rays: Vec<GpuRay> = (0..64 * 64)
        .map(|k| {
            let ndc = glam::Vec2::new((k % 64) as f32 + 0.5, (k / 64) as f32 + 0.5) / 64.0 * 2.0 - 1.0;
            let near = world_from_clip.project_point3(Vec3::new(ndc.x, -ndc.y, 1.0));
            GpuRay { origin: eye.to_array(), tmin: 0.0, direction: (near - eye).normalize_or(Vec3::Z).to_array(), tmax: 1e30 }
        })
        .collect();
    let mut cage_rays = Vec::new();
    let mut cage_probes = Vec::new();
    for (ray, hit) in camera_rays.iter().zip(tracer.trace(gpu, gpu_scene, rt, &camera_rays, false)) {
        if hit.instance == u32::MAX {
            continue;
        }
        let p = Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * hit.t;
        let g = ((p - layout.origin) / layout.spacing).floor().as_ivec3();
        let base = g.clamp(glam::IVec3::ZERO, (layout.counts.as_ivec3() - 2).max(glam::IVec3::ZERO));
        for corner in 0..8 {
            let c =
                (base + glam::IVec3::new(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1)).min(layout.counts.as_ivec3() - 1).as_uvec3();
            let i = (c.x + layout.counts.x * (c.y + layout.counts.y * c.z)) as usize;
            if inside[i] {
                continue;
            }
            let from = position(i);
            let to = p - Vec3::from_array(ray.direction) * 1e-3 * hit.t;
            let d = to - from;
            cage_rays.push(GpuRay { origin: from.to_array(), tmin: 0.0, direction: d.to_array(), tmax: 0.999 });
            cage_probes.push(i);
        }
    }
    let mut needed = vec![false; n];
    for (i, r) in cage_probes.iter().zip(tracer.trace(gpu, gpu_scene, rt, &cage_rays, true)) {
        if r.any_hit == 0 {
            needed[*i] = true;
        }
    }
    Ok(ClassificationCheck {
        probes: n,
        inside: inside.iter().filter(|&&x| x).count(),
        inside_off: (0..n).filter(|&i| inside[i] && off(i)).count(),
        needed: needed.iter().filter(|&&x| x).count(),
        needed_off: (0..n).filter(|&i| needed[i] && off(i)).count(),
        needed_off_lit: (0..n).filter(|&i| needed[i] && off(i) && !dark(i)).count(),
        needed_off_probes: (0..n)
            .filter(|&i| needed[i] && off(i))
            .map(|i| {
                let offset = Vec3::from_array(data[i].offset) / layout.spacing;
                (i, layout.probe_grid(i as u32), offset, backface_share[i], data[i].luma, data[i].empty_rays)
            })
            .collect(),
    })
}

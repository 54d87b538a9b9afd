//! Stiff and extreme cases on lavapipe, at tiny resolutions (32×32 images, a few probes, a few
//! frames), grouped so that the whole file runs in well under three minutes in CI: light
//! intensities from 1e-6 to 1e6, scene scales from 1e-3 to 1e4 units (probe spacing in proportion),
//! scenes 1e3 to 1e5 units from the world's origin,
//! hysteresis 0 to 1, 1 to 1024 rays per probe, 1×1×1 grids and grids far larger than the scene,
//! probe spacing thinner than walls and wider than rooms, probes and camera inside geometry,
//! degenerate and sliver triangles, albedo 0 and 1, spot lights with equal cones, emission at the
//! largest half float, probe grids beyond the adapter's buffers and non-finite scene data; and
//! the temporal anti-aliasing and contact occlusion over the stiffest of these.
//!
//! Every case asserts that neither atlas (read back raw, as half floats) nor the final HDR image
//! holds a NaN or an infinity, that irradiance stays under the analytic upper bound where there is
//! one (the white furnace `π·Le/(1 − ρ)`, the inverse-square law for a punctual light), and, in
//! static scenes whose rays all see the same radiance, that the error to the converged value never
//! grows from one frame to the next.

use ddgi::atlas::{probe_mean_irradiance, read_irradiance};
use ddgi::{DdgiGpuVolumes, DdgiOutput, DdgiVolume, use_ddgi};
use engine::gpu::GpuContext;
use engine::gpu::readback::read_texture;
use engine::headless::{add_default_camera, headless_app, read_hdr, run_frames};
use engine::render::RenderSize;
use engine::render::gpu_scene::GpuScene;
use engine::scene::{Camera, Material, Mesh, NodeContent, PointLight, SceneDescription, SpotLight, Transform};
use glam::{DVec3, UVec3, Vec3};
use testkit::{closed_room, gpu};

use std::f32::consts::PI;

const SIZE: u32 = 32;

fn material(albedo: f32, emission: f32) -> Material {
    Material {
        name: format!("albedo_{albedo}"),
        base_color: Vec3::splat(albedo).extend(1.0),
        emissive: Vec3::splat(emission),
        ..Default::default()
    }
}

/// A square floor slab of side `4·scale` (top at y = 0, albedo ρ) seen from above by the camera.
fn floor(scale: f32, albedo: f32) -> SceneDescription {
    let mut s = SceneDescription { name: "floor".into(), ..Default::default() };
    let half = 2.0 * scale;
    let mesh = s.add_mesh(engine::shapes::merge(
        "floor",
        &[engine::shapes::box_part(Vec3::new(-half, -0.1 * scale, -half), Vec3::new(half, 0.0, half))],
    ));
    let m = s.add_material(material(albedo, 0.0));
    s.add_node("floor", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(mesh, m)])]);
    let camera = Transform::from_xyz(0.0, 3.0 * scale, 0.001 * scale).looking_at(Vec3::ZERO, Vec3::Y);
    s.add_node("camera", camera, None, vec![NodeContent::Camera(Camera { yfov: 1.0, znear: 1e-3 * scale, ..Default::default() })]);
    s
}

/// A volume for tests: `counts` probes over `bounds`, `rays` rays, hysteresis `h`; relocation,
/// classification and adaptive budgets off unless a test asks (so that every probe updates every
/// frame with all its rays).
fn volume(bounds: (Vec3, Vec3), counts: UVec3, rays: u32, h: f32) -> DdgiVolume {
    DdgiVolume {
        bounds: Some((bounds.0.into(), bounds.1.into())),
        probe_counts: Some(counts),
        rays_per_probe: rays,
        hysteresis: h,
        relocation: false,
        classification: false,
        adaptive: ddgi::DdgiAdaptive::off(),
        firefly_threshold: 0.0,
        ..Default::default()
    }
}

/// What a frame left: the HDR image and the raw atlases (half floats as f32, borders included).
struct Snapshot {
    hdr: Vec<f32>,
    irradiance_raw: Vec<f32>,
    distance_raw: Vec<f32>,
    /// Decoded irradiance (W/m²) of every texel, and the mean of each probe's map.
    texels: Vec<Vec3>,
    probe_means: Vec<Vec3>,
    /// The volume's settings error, if it was refused.
    error: Option<String>,
    warnings: Vec<String>,
}

impl Snapshot {
    fn mean(&self) -> f32 {
        self.probe_means.iter().map(|e| e.x).sum::<f32>() / self.probe_means.len().max(1) as f32
    }

    fn max_texel(&self) -> f32 {
        self.texels.iter().map(|t| t.max_element()).fold(0.0, f32::max)
    }

    fn max_pixel(&self) -> f32 {
        self.hdr.chunks_exact(4).map(|p| p[0].max(p[1]).max(p[2])).fold(0.0, f32::max)
    }

    fn mean_pixel(&self) -> f32 {
        self.hdr.chunks_exact(4).map(|p| p[0]).sum::<f32>() / (self.hdr.len() / 4) as f32
    }

    fn centre_pixel(&self) -> f32 {
        let i = ((SIZE / 2) * SIZE + SIZE / 2) as usize * 4;
        self.hdr[i]
    }

    /// No NaN or infinity in either atlas or in the image.
    fn assert_finite(&self, what: &str) {
        let bad = |v: &[f32]| v.iter().position(|x| !x.is_finite());
        assert_eq!(bad(&self.irradiance_raw), None, "{what}: non-finite irradiance atlas texel");
        assert_eq!(bad(&self.distance_raw), None, "{what}: non-finite distance atlas texel");
        assert_eq!(bad(&self.hdr), None, "{what}: non-finite HDR pixel");
        assert!(self.texels.iter().all(|t| t.is_finite()), "{what}: decoded irradiance overflows");
    }
}

fn halves(bytes: &[u8]) -> Vec<f32> {
    bytes.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()).collect()
}

fn snapshot(gpu: &GpuContext, world: &mut engine::bevy_ecs::world::World) -> Snapshot {
    let hdr = read_hdr(gpu, world);
    let volumes = world.resource::<DdgiGpuVolumes>();
    let warnings = volumes.warnings().to_vec();
    let error = volumes.first_error().map(str::to_string);
    let Some((_, v)) = volumes.volumes.first() else {
        return Snapshot { hdr, irradiance_raw: vec![], distance_raw: vec![], texels: vec![], probe_means: vec![], error, warnings };
    };
    let atlas = read_irradiance(gpu, v);
    let probe_means = (0..v.layout.probe_count).map(|p| probe_mean_irradiance(&atlas, v, p)).collect();
    Snapshot {
        hdr,
        irradiance_raw: halves(&read_texture(gpu, &v.irradiance)),
        distance_raw: halves(&read_texture(gpu, &v.distance)),
        texels: atlas.texels,
        probe_means,
        error,
        warnings,
    }
}

/// Runs `scene` with `volume` for `frames` frames at 32×32 and returns a snapshot after each frame.
fn run(gpu: &GpuContext, scene: SceneDescription, volume: DdgiVolume, frames: u32) -> Vec<Snapshot> {
    run_with(gpu, scene, volume, frames, |_| {})
}

/// [`run`] with more setup of the app (e.g. contact occlusion) before the scene is spawned.
fn run_with(
    gpu: &GpuContext,
    mut scene: SceneDescription,
    volume: DdgiVolume,
    frames: u32,
    setup: impl FnOnce(&mut engine::bevy_app::App),
) -> Vec<Snapshot> {
    if !scene.has_camera() {
        add_default_camera(&mut scene);
    }
    let mut app = headless_app(gpu, RenderSize { width: SIZE, height: SIZE }, 1.0 / 60.0);
    use_ddgi(&mut app, volume, DdgiOutput::Full);
    setup(&mut app);
    scene.spawn(app.world_mut());
    let mut out = Vec::new();
    run_frames(&mut app, frames, |_, world| out.push(snapshot(gpu, world)));
    assert_eq!(out.len(), frames as usize, "the app stopped early");
    out
}

/// The mean probe irradiance approaches `target` from below without ever moving away from it:
/// `|target − E_k|` does not grow from one frame to the next (beyond `tolerance`).
fn assert_monotone_towards(frames: &[Snapshot], target: f32, tolerance: f32, what: &str) {
    let errors: Vec<f32> = frames.iter().map(|f| (target - f.mean()).abs()).collect();
    for k in 1..errors.len() {
        assert!(errors[k] <= errors[k - 1] + tolerance, "{what}: error to the converged {target} grew at frame {k}: {errors:?}");
    }
}

// ---------------------------------------------------------------------------------------------

#[test]
fn light_intensities_from_1e_minus_6_to_1e6_scale_linearly_under_the_inverse_square_bound() {
    let Some(gpu) = gpu("light_intensities") else { return };
    // A floor of albedo ρ under a point light at height h: a probe sees at most the floor's
    // radiance ρ/π · I/h², so every irradiance texel is at most ρ·I/h²; a floor pixel's radiance
    // is at most ρ/π · (1 + ρ) · I/h². Everything is linear in I, so E·h²/I is the same for every
    // intensity (and scale).
    let albedo = 0.5;
    let mut per_unit: Vec<(f32, f32, f32)> = Vec::new();
    let cases = [(1e-6f32, 1.0f32), (1e-3, 1.0), (1.0, 1.0), (1e3, 1.0), (1e6, 1.0), (1e6, 1e-3), (1e-6, 1e4)];
    for (intensity, scale) in cases {
        let what = format!("I = {intensity:e}, scale {scale:e}");
        let h = scale;
        let mut scene = floor(scale, albedo);
        let light = PointLight { color: Vec3::ONE, intensity, range: None };
        scene.add_node("light", Transform::from_xyz(0.0, h, 0.0), None, vec![NodeContent::PointLight(light)]);
        let bounds = (Vec3::new(-2.0, 0.05, -2.0) * scale, Vec3::new(2.0, 1.5, 2.0) * scale);
        let frames = run(&gpu, scene, volume(bounds, UVec3::new(3, 2, 3), 64, 0.5), 4);
        let last = frames.last().unwrap();
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            let bound = albedo * intensity / (h * h);
            assert!(f.max_texel() <= bound * 1.01, "{what}: probe irradiance {} over the bound {bound}", f.max_texel());
            let pixel_bound = albedo / PI * (1.0 + albedo) * intensity / (h * h);
            assert!(f.max_pixel() <= pixel_bound * 1.01, "{what}: pixel {} over the bound {pixel_bound}", f.max_pixel());
        }
        assert!(last.mean() > 0.0, "{what}: the probes saw nothing (flushed to zero)");
        per_unit.push((intensity, scale, last.mean() * h * h / intensity));
        // The floor under the light: ρ/π · I/h² (the camera looks straight down at it).
        let expected = albedo / PI * intensity / (h * h);
        assert!((last.centre_pixel() - expected).abs() <= 0.05 * expected, "{what}: floor {} vs {expected}", last.centre_pixel());
    }
    let reference = per_unit[2].2;
    for (intensity, scale, e) in &per_unit {
        assert!((e - reference).abs() <= 0.02 * reference, "I = {intensity:e}, scale {scale:e}: E·h²/I = {e}, at I = 1: {reference}");
    }
}

#[test]
fn furnace_converges_monotonically_at_every_scale_from_1e_minus_3_to_1e4() {
    let Some(gpu) = gpu("furnace_scales") else { return };
    // A closed room of albedo ρ emitting Le: E = π·Le/(1 − ρ) everywhere, reached one bounce per
    // frame (hysteresis 0: E_k = π·Le·(1 − ρ^k)/(1 − ρ)).
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    for scale in [1e-3f32, 1e-1, 1.0, 1e2, 1e4] {
        let what = format!("scale {scale:e}");
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0) * scale, Vec3::new(1.0, 1.5, 1.0) * scale);
        let scene = closed_room(lo, hi, 0.2 * scale, material(albedo, emission));
        let frames = run(&gpu, scene, volume((lo, hi), UVec3::splat(2), 32, 0.0), 10);
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_texel() <= converged * 1.01, "{what}, frame {k}: texel {} over π·Le/(1 − ρ) = {converged}", f.max_texel());
            assert!(f.max_pixel() <= emission / (1.0 - albedo) * 1.02, "{what}, frame {k}: pixel {}", f.max_pixel());
        }
        assert_monotone_towards(&frames, converged, 1e-3 * converged, &what);
        let last = frames.last().unwrap();
        assert!((last.mean() - converged).abs() <= 0.02 * converged, "{what}: {} vs {converged}", last.mean());
        let radiance = emission / (1.0 - albedo);
        assert!((last.mean_pixel() - radiance).abs() <= 0.03 * radiance, "{what}: image {} vs {radiance}", last.mean_pixel());
    }
}

#[test]
fn far_from_the_origin_1e3_to_1e5_the_furnace_and_the_inverse_square_law_hold_as_at_it() {
    let Some(gpu) = gpu("far_from_the_origin") else { return };
    // The scenes of the two tests above, placed 1e3, 1e4 and 1e5 units from the world's origin
    // (large-world coordinates: double-precision placement, render space rebased to the camera),
    // at scales 0.1 and 1: the same bounds hold, and the same values to float precision.
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    for offset in [glam::DVec3::new(1e3, 0.0, 0.0), glam::DVec3::new(0.0, -1e4, 1e4), glam::DVec3::splat(1e5)] {
        for scale in [1e-1f32, 1.0] {
            let what = format!("offset {offset}, scale {scale:e}");
            let at = |p: Vec3| (p.as_dvec3() + offset).as_vec3();
            let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0) * scale, Vec3::new(1.0, 1.5, 1.0) * scale);
            let mut scene = closed_room(lo, hi, 0.2 * scale, material(albedo, emission));
            scene.origin = offset;
            let frames = run(&gpu, scene, volume((at(lo), at(hi)), UVec3::splat(2), 32, 0.0), 10);
            for (k, f) in frames.iter().enumerate() {
                f.assert_finite(&format!("{what}, frame {k}"));
                assert!(f.max_texel() <= converged * 1.01, "{what}, frame {k}: texel {} over π·Le/(1 − ρ)", f.max_texel());
            }
            assert_monotone_towards(&frames, converged, 1e-3 * converged, &what);
            let last = frames.last().unwrap();
            assert!((last.mean() - converged).abs() <= 0.02 * converged, "{what}: {} vs {converged}", last.mean());
            let radiance = emission / (1.0 - albedo);
            assert!((last.mean_pixel() - radiance).abs() <= 0.03 * radiance, "{what}: image {} vs {radiance}", last.mean_pixel());

            // The floor under a point light: ρ/π · I/h² straight below it.
            let (intensity, h) = (2.0f32, scale);
            let mut scene = floor(scale, albedo);
            scene.origin = offset;
            let light = PointLight { color: Vec3::ONE, intensity, range: None };
            scene.add_node("light", Transform::from_xyz(0.0, h, 0.0), None, vec![NodeContent::PointLight(light)]);
            let bounds = (at(Vec3::new(-2.0, 0.05, -2.0) * scale), at(Vec3::new(2.0, 1.5, 2.0) * scale));
            let frames = run(&gpu, scene, volume(bounds, UVec3::new(3, 2, 3), 64, 0.5), 4);
            let last = frames.last().unwrap();
            last.assert_finite(&what);
            let expected = albedo / PI * intensity / (h * h);
            assert!((last.centre_pixel() - expected).abs() <= 0.05 * expected, "{what}: floor {} vs {expected}", last.centre_pixel());
        }
    }
}

#[test]
fn hysteresis_0_to_1_converges_monotonically_and_1_freezes_the_first_update() {
    let Some(gpu) = gpu("hysteresis_extremes") else { return };
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let mut final_errors = Vec::new();
    for h in [0.0f32, 0.5, 0.999, 1.0] {
        let what = format!("hysteresis {h}");
        let frames = run(&gpu, closed_room(lo, hi, 0.2, material(albedo, emission)), volume((lo, hi), UVec3::splat(2), 32, h), 10);
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_texel() <= converged * 1.01, "{what}, frame {k}: {}", f.max_texel());
        }
        assert_monotone_towards(&frames, converged, 1e-3 * converged, &what);
        final_errors.push((h, (converged - frames.last().unwrap().mean()).abs()));
        if h == 1.0 {
            // A fresh probe takes its first update whole (π·Le, one bounce); then nothing moves.
            for f in &frames {
                assert!(
                    (f.mean() - PI * emission).abs() <= 0.01 * PI * emission,
                    "{what}: {} vs the first bounce {}",
                    f.mean(),
                    PI * emission
                );
            }
        }
    }
    // Less hysteresis converges faster.
    for pair in final_errors.windows(2) {
        assert!(pair[0].1 <= pair[1].1 + 1e-4 * converged, "final errors by hysteresis: {final_errors:?}");
    }
    assert!(final_errors[0].1 <= 0.01 * converged, "hysteresis 0 after 10 frames: {final_errors:?}");
}

#[test]
fn one_to_1024_rays_per_probe_stay_finite_and_bounded() {
    let Some(gpu) = gpu("rays_per_probe") else { return };
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    for rays in [1u32, 4, 64, 1024] {
        let what = format!("{rays} rays");
        let frames = run(&gpu, closed_room(lo, hi, 0.2, material(albedo, emission)), volume((lo, hi), UVec3::splat(2), rays, 0.0), 6);
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_texel() <= converged * 1.01, "{what}, frame {k}: {}", f.max_texel());
        }
        let last = frames.last().unwrap();
        assert!(last.max_texel() > 0.0, "{what}: no texel was ever updated");
        if rays >= 64 {
            // Enough rays to reach every texel: every ray sees the same radiance, so no noise.
            assert_monotone_towards(&frames, converged, 1e-3 * converged, &what);
            let expected = PI * emission * (1.0 - albedo.powi(6)) / (1.0 - albedo);
            assert!((last.mean() - expected).abs() <= 0.02 * expected, "{what}: {} vs {expected}", last.mean());
        }
    }
}

#[test]
fn grids_from_one_probe_to_far_larger_than_the_scene_with_probes_and_camera_inside_walls() {
    let Some(gpu) = gpu("grid_extremes") else { return };
    // Every surface of the scene has radiance at most Le/(1 − ρ) (outer faces see a black sky), so
    // every probe and pixel stays under the furnace bound whatever the grid.
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    let radiance = emission / (1.0 - albedo);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let wall = 0.5;
    struct Case {
        what: &'static str,
        bounds: (Vec3, Vec3),
        counts: UVec3,
        camera_in_wall: bool,
        converges: bool,
    }
    let cases = [
        Case { what: "1×1×1 grid at the room's centre", bounds: (lo, hi), counts: UVec3::ONE, camera_in_wall: false, converges: true },
        Case {
            what: "grid 100× larger than the scene",
            bounds: (lo * 100.0, hi * 100.0),
            counts: UVec3::splat(2),
            camera_in_wall: false,
            converges: false,
        },
        Case {
            what: "spacing thinner than the walls",
            bounds: (lo - wall, hi + wall),
            counts: UVec3::splat(9),
            camera_in_wall: false,
            converges: false,
        },
        Case {
            what: "every probe and the camera inside a wall",
            bounds: (Vec3::new(-1.4, 0.1, -1.4), Vec3::new(-1.1, 1.4, -1.1)),
            counts: UVec3::splat(2),
            camera_in_wall: true,
            converges: false,
        },
    ];
    for case in cases {
        let mut scene = closed_room(lo, hi, wall, material(albedo, emission));
        if case.camera_in_wall {
            let node = scene.nodes.iter_mut().find(|n| n.name == "camera").unwrap();
            node.transform = Transform::from_xyz(-1.25, 0.75, -1.25).looking_at(Vec3::ZERO, Vec3::Y);
        }
        let mut v = volume(case.bounds, case.counts, 32, 0.0);
        // Relocation and classification see the walls here.
        v.relocation = true;
        v.classification = true;
        let frames = run(&gpu, scene, v, 8);
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{}, frame {k}", case.what));
            assert!(f.max_texel() <= converged * 1.01, "{}, frame {k}: texel {}", case.what, f.max_texel());
            assert!(f.max_pixel() <= radiance * 1.02, "{}, frame {k}: pixel {}", case.what, f.max_pixel());
        }
        if case.converges {
            let expected = PI * emission * (1.0 - albedo.powi(8)) / (1.0 - albedo);
            let last = frames.last().unwrap();
            assert!((last.mean() - expected).abs() <= 0.02 * expected, "{}: {} vs {expected}", case.what, last.mean());
            assert_monotone_towards(&frames, converged, 1e-3 * converged, case.what);
        }
    }
}

/// A mesh of zero-area triangles (repeated and collinear vertices) and slivers (1e-7 wide, 1 long).
fn degenerate_mesh() -> Mesh {
    let positions = vec![
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::new(-0.5, 0.7, 0.0),
        Vec3::new(0.0, 0.7, 0.0),
        Vec3::new(0.5, 0.7, 0.0),
        Vec3::new(-0.5, 0.9, 0.2),
        Vec3::new(0.5, 0.9, 0.2),
        Vec3::new(0.0, 0.9 + 1e-7, 0.2),
        Vec3::new(0.3, 0.3, -0.5),
        Vec3::new(0.3, 0.3 + 1e-7, 0.5),
        Vec3::new(0.3 + 1e-7, 0.3, 0.5),
    ];
    let indices = vec![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 0, 0, 5];
    let mut mesh = Mesh { name: "degenerate".into(), positions, indices, ..Default::default() };
    mesh.compute_normals();
    mesh
}

#[test]
fn degenerate_and_sliver_triangles_leave_the_furnace_finite_and_bounded() {
    let Some(gpu) = gpu("degenerate_triangles") else { return };
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let mut scene = closed_room(lo, hi, 0.2, material(albedo, emission));
    let mesh = scene.add_mesh(degenerate_mesh());
    scene.add_node("slivers", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(mesh, 0)])]);
    assert!(scene.validate().is_ok(), "degenerate triangles are valid scene data");
    let mut v = volume((lo, hi), UVec3::splat(3), 64, 0.0);
    v.relocation = true;
    v.classification = true;
    let frames = run(&gpu, scene, v, 8);
    for (k, f) in frames.iter().enumerate() {
        f.assert_finite(&format!("frame {k}"));
        assert!(f.max_texel() <= converged * 1.01, "frame {k}: {}", f.max_texel());
        assert!(f.max_pixel() <= emission / (1.0 - albedo) * 1.02, "frame {k}: pixel {}", f.max_pixel());
    }
}

#[test]
fn albedo_0_takes_one_bounce_and_a_closed_albedo_1_box_grows_by_one_bounce_per_frame_with_a_warning() {
    let Some(gpu) = gpu("albedo_extremes") else { return };
    let emission = 0.3f32;
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    // Albedo 0: E = π·Le from the first update on, exactly.
    let frames = run(&gpu, closed_room(lo, hi, 0.2, material(0.0, emission)), volume((lo, hi), UVec3::splat(2), 32, 0.0), 4);
    for (k, f) in frames.iter().enumerate() {
        f.assert_finite(&format!("albedo 0, frame {k}"));
        assert!((f.mean() - PI * emission).abs() <= 0.01 * PI * emission, "albedo 0, frame {k}: {}", f.mean());
        assert!(f.max_texel() <= PI * emission * 1.01, "albedo 0, frame {k}: {}", f.max_texel());
        assert!(f.warnings.is_empty(), "albedo 0 warned: {:?}", f.warnings);
    }

    // Albedo 1: the series π·Le·Σρ^i diverges. Frame k (from 1) holds k bounces: E_k = k·π·Le.
    // It stays finite, never exceeds the k-bounce bound, never falls, and is reported.
    for le in [emission, 65504.0] {
        let frames = run(&gpu, closed_room(lo, hi, 0.2, material(1.0, le)), volume((lo, hi), UVec3::splat(2), 32, 0.0), 8);
        let mut previous = 0.0;
        for (k, f) in frames.iter().enumerate() {
            let what = format!("albedo 1, Le {le}, frame {k}");
            f.assert_finite(&what);
            let bounces = (k + 1) as f32;
            assert!(f.max_texel() <= bounces * PI * le * 1.01, "{what}: {} over {bounces} bounces", f.max_texel());
            assert!(f.mean() >= previous * 0.999, "{what}: fell from {previous} to {}", f.mean());
            previous = f.mean();
            assert!(
                f.warnings.iter().any(|w| w.contains("albedo_1") && w.contains("does not converge")),
                "{what}: no divergence warning: {:?}",
                f.warnings
            );
        }
        let expected = 8.0 * PI * le;
        assert!((previous - expected).abs() <= 0.03 * expected, "albedo 1, Le {le}: {previous} after 8 frames, expected {expected}");
    }
}

#[test]
fn spot_lights_with_equal_inner_and_outer_cones_are_finite_and_light_their_axis() {
    let Some(gpu) = gpu("spot_equal_cones") else { return };
    let (albedo, intensity, h) = (0.5f32, 10.0f32, 1.0f32);
    for cone in [0.5f32, 0.0, std::f32::consts::FRAC_PI_2] {
        let what = format!("cones {cone} = {cone}");
        let mut scene = floor(1.0, albedo);
        let spot = SpotLight { color: Vec3::ONE, intensity, range: None, inner_cone_angle: cone, outer_cone_angle: cone };
        let down = Transform::from_xyz(0.0, h, 0.0).looking_at(Vec3::new(0.0, 0.0, 0.0), Vec3::Z);
        scene.add_node("spot", down, None, vec![NodeContent::SpotLight(spot)]);
        let frames = run(&gpu, scene, volume((Vec3::new(-2.0, 0.05, -2.0), Vec3::new(2.0, 1.5, 2.0)), UVec3::new(3, 2, 3), 64, 0.5), 4);
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_texel() <= albedo * intensity / (h * h) * 1.01, "{what}: {}", f.max_texel());
            assert!(f.max_pixel() <= albedo / PI * (1.0 + albedo) * intensity / (h * h) * 1.01, "{what}: {}", f.max_pixel());
        }
        let centre = frames.last().unwrap().centre_pixel();
        let direct = albedo / PI * intensity / (h * h);
        if cone > 0.0 {
            // On the axis the cone's attenuation is 1: the floor gets I/h².
            assert!((centre - direct).abs() <= 0.05 * direct, "{what}: floor under the spot {centre} vs {direct}");
        } else {
            // A cone of zero width lights nothing (and divides by nothing).
            assert!(centre <= 1e-3 * direct, "{what}: a zero cone lit the floor: {centre}");
        }
    }
}

#[test]
fn emission_at_the_largest_half_float_stays_bright_and_finite() {
    let Some(gpu) = gpu("emission_half_max") else { return };
    let albedo = 0.5f32;
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    for (emissive, strength) in [(65504.0f32, 1.0f32), (65504.0, 2.0), (6.0e4, 1.0)] {
        let what = format!("emissive {emissive} × {strength}");
        let m = Material { emissive_strength: strength, ..material(albedo, emissive) };
        let frames = run(&gpu, closed_room(lo, hi, 0.2, m), volume((lo, hi), UVec3::splat(2), 32, 0.0), 6);
        let le = emissive * strength;
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_texel() <= PI * le / (1.0 - albedo) * 1.01, "{what}: {}", f.max_texel());
            assert!(f.max_pixel() <= le / (1.0 - albedo) * 1.02, "{what}: pixel {}", f.max_pixel());
        }
        // Clamped where a format demands (the half-float G-buffer), but bright: never flushed to black.
        let last = frames.last().unwrap();
        assert!(last.mean_pixel() >= emissive, "{what}: image {} darker than the emission", last.mean_pixel());
        assert!(last.mean() >= PI * emissive, "{what}: probes {} darker than the first bounce", last.mean());
    }
}

#[test]
fn taa_and_contact_occlusion_stay_finite_and_under_the_bounds_in_the_stiff_cases() {
    let Some(gpu) = gpu("taa_and_contact_occlusion_extremes") else { return };
    // The image checked is the temporal anti-aliasing's resolved output (on by default); contact
    // occlusion's rays (2 a pixel, reaching the probe spacing) darken the indirect light only, so
    // every bound of the cases without it still holds, and in a closed furnace room, whose corners
    // it finds, the image is darker than without it (but not black).
    let occlusion = |app: &mut engine::bevy_app::App| {
        app.insert_resource(ddgi::DdgiContactOcclusion { rays: 2, ..Default::default() });
    };
    let (albedo, emission) = (0.5f32, 0.3f32);
    for (scale, le, offset) in [(1e-3f32, emission, None), (1e4, emission, None), (1.0, 65504.0 * 2.0, None), (1.0, emission, Some(1e5))] {
        let what = format!("furnace room, scale {scale:e}, Le {le}, offset {offset:?}");
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0) * scale, Vec3::new(1.0, 1.5, 1.0) * scale);
        let mut scene = closed_room(lo, hi, 0.2 * scale, material(albedo, le));
        scene.origin = offset.map_or(DVec3::ZERO, DVec3::splat);
        let mut v = volume((lo, hi), UVec3::splat(3), 32, 0.0);
        v.bounds = Some((lo.as_dvec3() + scene.origin, hi.as_dvec3() + scene.origin));
        let with = run_with(&gpu, scene.clone(), v.clone(), 6, occlusion);
        let without = run(&gpu, scene, v, 6);
        for (k, f) in with.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_pixel() <= le / (1.0 - albedo) * 1.02, "{what}, frame {k}: pixel {}", f.max_pixel());
        }
        let (a, b) = (with.last().unwrap().mean_pixel(), without.last().unwrap().mean_pixel());
        assert!(a < b * 0.999 && a > 0.5 * b, "{what}: with contact occlusion {a}, without {b}");
    }
    for (intensity, scale) in [(1e-6f32, 1e-3f32), (1e6, 1e4)] {
        let what = format!("floor under a point light, I = {intensity:e}, scale {scale:e}");
        let mut scene = floor(scale, albedo);
        let light = PointLight { color: Vec3::ONE, intensity, range: None };
        scene.add_node("light", Transform::from_xyz(0.0, scale, 0.0), None, vec![NodeContent::PointLight(light)]);
        let bounds = (Vec3::new(-2.0, 0.05, -2.0) * scale, Vec3::new(2.0, 1.5, 2.0) * scale);
        let frames = run_with(&gpu, scene, volume(bounds, UVec3::new(3, 2, 3), 64, 0.5), 4, occlusion);
        let pixel_bound = albedo / PI * (1.0 + albedo) * intensity / (scale * scale);
        for (k, f) in frames.iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
            assert!(f.max_pixel() <= pixel_bound * 1.01, "{what}, frame {k}: pixel {} over {pixel_bound}", f.max_pixel());
        }
        assert!(frames.last().unwrap().centre_pixel() > 0.0, "{what}: the lit floor went black");
    }
    // Slivers and zero-area triangles, and a closed box of albedo 1 (divergent, clamped).
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let mut slivers = closed_room(lo, hi, 0.2, material(albedo, emission));
    let mesh = slivers.add_mesh(degenerate_mesh());
    slivers.add_node("slivers", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(mesh, 0)])]);
    for (what, scene) in [("slivers", slivers), ("albedo 1", closed_room(lo, hi, 0.2, material(1.0, emission)))] {
        for (k, f) in run_with(&gpu, scene, volume((lo, hi), UVec3::splat(3), 32, 0.0), 6, occlusion).iter().enumerate() {
            f.assert_finite(&format!("{what}, frame {k}"));
        }
    }
}

#[test]
fn probe_grids_beyond_the_adapters_buffers_and_invalid_settings_are_refused_by_name() {
    let Some(gpu) = gpu("grids_beyond_limits") else { return };
    let limits = ddgi::volume::DdgiLimits::of(&gpu.device);
    let bounds = (Vec3::ZERO, Vec3::ONE);
    // 4,194,304 probes of one ray and one-texel maps: within MAX_PROBES, but 64 bytes of state each
    // is 268 MB, over lavapipe's 128 MiB per storage buffer (taken from the adapter here).
    let huge = DdgiVolume {
        probe_counts: Some(UVec3::new(256, 128, 128)),
        rays_per_probe: 1,
        irradiance_texels: 1,
        distance_texels: 1,
        ..Default::default()
    };
    let needed = 256u64 * 128 * 128 * size_of::<ddgi::gpu::DdgiProbeData>() as u64;
    match ddgi::DdgiLayout::new(&huge, bounds, limits) {
        Err(e) if needed > limits.max_storage_buffer_bytes => {
            let message = e.to_string();
            assert!(message.contains("probe buffer") && message.contains(&needed.to_string()), "{message}");
            assert!(message.contains(&limits.max_storage_buffer_bytes.to_string()), "{message}");
        }
        Err(e) => panic!("refused although it fits the adapter: {e}"),
        Ok(_) if needed > limits.max_storage_buffer_bytes => panic!("a {needed}-byte probe buffer was accepted"),
        Ok(_) => {}
    }
    // More rays than the per-ray buffer holds.
    let rays = DdgiVolume { probe_counts: Some(UVec3::splat(64)), rays_per_probe: 4096, ..Default::default() };
    let message = ddgi::DdgiLayout::new(&rays, bounds, limits).expect_err("per-ray buffer").to_string();
    assert!(message.contains("per-ray buffer") && message.contains(&(64u64.pow(3) * 4096 * 16).to_string()), "{message}");

    // Zero, negative, non-finite and out-of-range settings name their field and value.
    let cases: [(DdgiVolume, &str, &str); 7] = [
        (DdgiVolume { irradiance_texels: 0, ..Default::default() }, "irradiance_texels", "0"),
        (DdgiVolume { distance_texels: 65, ..Default::default() }, "distance_texels", "65"),
        (DdgiVolume { rays_per_probe: 4097, ..Default::default() }, "rays_per_probe", "4097"),
        (DdgiVolume { hysteresis: -0.1, ..Default::default() }, "hysteresis", "-0.1"),
        (DdgiVolume { hysteresis: f32::NAN, ..Default::default() }, "hysteresis", "NaN"),
        (DdgiVolume { max_ray_distance: Some(-1.0), ..Default::default() }, "max_ray_distance", "-1.0"),
        (DdgiVolume { bounds: Some((DVec3::ZERO, DVec3::new(1.0, f64::INFINITY, 1.0))), ..Default::default() }, "bounds", "inf"),
    ];
    for (v, field, value) in cases {
        let message = v.validate().expect_err(field).to_string();
        assert!(message.contains(field) && message.contains(value), "{field}: {message}");
    }

    // In an app the refused volume is off, the error says why, and the frame renders (no panic, no
    // validation error, finite).
    if needed > limits.max_storage_buffer_bytes {
        let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
        let frames =
            run(&gpu, closed_room(lo, hi, 0.2, material(0.5, 0.3)), DdgiVolume { bounds: Some((lo.into(), hi.into())), ..huge }, 2);
        let last = frames.last().unwrap();
        assert!(last.error.as_deref().is_some_and(|e| e.contains("probe buffer")), "{:?}", last.error);
        assert!(last.hdr.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn non_finite_scene_data_is_rejected_at_upload_by_name_field_and_value() {
    let Some(gpu) = gpu("non_finite_scene_data") else { return };
    let (lo, hi) = (Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 1.5, 1.0));
    let (albedo, emission) = (0.5f32, 0.3f32);
    let converged = PI * emission / (1.0 - albedo);
    let mut scene = closed_room(lo, hi, 0.2, material(albedo, emission));
    // A mesh with a NaN vertex, a material with an infinite emission, a light with a NaN intensity
    // and an instance with an infinite scale: each is named in the errors and left out; the rest of
    // the scene renders as if they were not there.
    let mut bad_mesh = degenerate_mesh();
    bad_mesh.name = "nan_mesh".into();
    bad_mesh.positions[4].y = f32::NAN;
    let bad_mesh = scene.add_mesh(bad_mesh);
    let bad_material =
        scene.add_material(Material { name: "inf_glow".into(), emissive: Vec3::new(f32::INFINITY, 0.0, 0.0), ..Default::default() });
    let slab = scene.add_mesh(engine::shapes::merge("slab", &[engine::shapes::box_part(Vec3::splat(-0.1), Vec3::splat(0.1))]));
    scene.add_node("nan_node", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(bad_mesh, 0)])]);
    scene.add_node("glow_node", Transform::from_xyz(0.0, 0.5, 0.0), None, vec![NodeContent::Meshes(vec![(slab, bad_material)])]);
    let light = PointLight { color: Vec3::ONE, intensity: f32::NAN, range: None };
    scene.add_node("nan_light", Transform::from_xyz(0.0, 1.0, 0.0), None, vec![NodeContent::PointLight(light)]);
    let message = scene.validate().expect_err("validation before spawning").to_string();
    assert!(message.contains("nan_mesh") && message.contains("positions[4]") && message.contains("NaN"), "{message}");

    let mut app = headless_app(&gpu, RenderSize { width: SIZE, height: SIZE }, 1.0 / 60.0);
    use_ddgi(&mut app, volume((lo, hi), UVec3::splat(2), 32, 0.0), DdgiOutput::Full);
    scene.spawn(app.world_mut());
    // An instance whose transform overflows to infinity.
    app.world_mut().spawn((
        engine::scene::Name("inf_scale".into()),
        Transform::from_xyz(0.0, 0.5, 0.0).with_scale(Vec3::splat(f32::INFINITY)),
        engine::scene::MeshInstance {
            mesh: engine::scene::Handle::from_index(slab as u32),
            material: engine::scene::Handle::from_index(0),
        },
    ));
    let mut frames = Vec::new();
    let mut errors = Vec::new();
    run_frames(&mut app, 8, |_, world| {
        frames.push(snapshot(&gpu, world));
        errors = world.resource::<GpuScene>().errors().iter().map(|e| e.to_string()).collect();
    });
    let expect = [
        ("nan_mesh", "positions[4]", "NaN"),
        ("inf_glow", "emissive", "inf"),
        ("nan_light", "intensity", "NaN"),
        ("inf_scale", "world transform", "inf"),
    ];
    for (item, field, value) in expect {
        assert!(
            errors.iter().any(|e| e.contains(item) && e.contains(field) && e.contains(value)),
            "no error names {item}, {field} and {value}: {errors:#?}"
        );
    }
    for (k, f) in frames.iter().enumerate() {
        f.assert_finite(&format!("frame {k}"));
        assert!(f.max_texel() <= converged * 1.01, "frame {k}: {}", f.max_texel());
    }
}

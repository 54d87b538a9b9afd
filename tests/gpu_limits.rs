//! Scenes beyond the GPU's buffer limits: a device opened with a small GPU's limits (1 MiB per
//! storage buffer) is given real geometry that needs more. The upload leaves it out with an error
//! naming the scene item, the buffer, the bytes needed and the limit; nothing panics (validation
//! errors panic in these tests), and the frame renders finite.

use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::{HeadlessSettings, render_scene_and_inspect};
use engine::render::gpu_scene::GpuScene;
use engine::rt::RayTracingScene;
use engine::scene::{Camera, DirectionalLight, Material, Mesh, NodeContent, SceneDescription, Transform};
use glam::{Vec2, Vec3};

const LIMIT: u64 = 1 << 20;

fn small_gpu(test: &str) -> Option<GpuContext> {
    let limits = engine::wgpu::Limits { max_storage_buffer_binding_size: LIMIT, max_buffer_size: LIMIT, ..Default::default() };
    testkit::gpu_with(test, GpuOptions { limits: Some(limits), ..Default::default() })
}

/// A flat grid of `n` × `n` quads, 10 m wide: (n + 1)² vertices of 32 bytes, 2n² triangles of 48
/// bytes in the BVH.
fn grid(n: u32) -> Mesh {
    let mut mesh = Mesh { name: "grid".into(), ..Default::default() };
    for z in 0..=n {
        for x in 0..=n {
            let uv = Vec2::new(x as f32, z as f32) / n as f32;
            mesh.positions.push(Vec3::new(uv.x - 0.5, 0.0, uv.y - 0.5) * 10.0);
            mesh.normals.push(Vec3::Y);
            mesh.uvs.push(uv);
        }
    }
    for z in 0..n {
        for x in 0..n {
            let i = z * (n + 1) + x;
            mesh.indices.extend_from_slice(&[i, i + n + 1, i + 1, i + 1, i + n + 1, i + n + 2]);
        }
    }
    mesh
}

fn grid_scene(n: u32) -> SceneDescription {
    let mut s = SceneDescription { name: "grid".into(), ..Default::default() };
    let mesh = s.add_mesh(grid(n));
    let material = s.add_material(Material::diffuse("grey", Vec3::splat(0.5)));
    s.add_node("grid", Transform::IDENTITY, None, vec![NodeContent::Meshes(vec![(mesh, material)])]);
    let camera = Transform::from_xyz(0.0, 6.0, 6.0).looking_at(Vec3::ZERO, Vec3::Y);
    s.add_node("camera", camera, None, vec![NodeContent::Camera(Camera::default())]);
    let sun = Transform::IDENTITY.looking_at(Vec3::new(-0.3, -1.0, -0.2), Vec3::Y);
    s.add_node("sun", sun, None, vec![NodeContent::DirectionalLight(DirectionalLight { color: Vec3::ONE, intensity: 3.0 })]);
    s
}

/// Renders `scene` on the small GPU and returns the upload's errors, the BVH's and the image.
fn render(gpu: &GpuContext, scene: SceneDescription) -> (Vec<String>, Option<String>, Vec<f32>) {
    let settings = HeadlessSettings { width: 32, height: 32, frames: 2, ..Default::default() };
    let mut errors = Vec::new();
    let mut bvh = None;
    let frame = render_scene_and_inspect(
        gpu,
        scene,
        &settings,
        |_| {},
        |world| {
            errors = world.resource::<GpuScene>().errors().iter().map(|e| e.to_string()).collect();
            bvh = world.resource::<RayTracingScene>().over_limit.as_ref().map(|e| e.to_string());
        },
    )
    .expect("the render runs");
    (errors, bvh, frame.hdr)
}

#[test]
fn geometry_over_the_buffer_limit_is_left_out_with_an_error_naming_mesh_buffer_and_sizes() {
    let Some(gpu) = small_gpu("geometry_over_the_buffer_limit") else { return };
    // 201² = 40,401 vertices: 1,939,248 bytes of vertices (48 each).
    let (errors, _, hdr) = render(&gpu, grid_scene(200));
    let message = errors.iter().find(|e| e.contains("vertex buffer")).unwrap_or_else(|| panic!("no vertex-buffer error: {errors:?}"));
    for part in ["mesh 0 'grid'", "1939248 bytes", &format!("limit of {LIMIT} bytes")] {
        assert!(message.contains(part), "'{part}' missing from: {message}");
    }
    assert!(hdr.iter().all(|v| v.is_finite()), "non-finite pixels");
}

#[test]
fn a_bvh_over_the_buffer_limit_is_left_out_with_an_error_and_the_scene_still_draws() {
    let Some(gpu) = small_gpu("bvh_over_the_buffer_limit") else { return };
    // 141² = 19,881 vertices (636,192 bytes: fits); 39,200 triangles of 48 bytes (1,881,600: does not).
    let (errors, bvh, hdr) = render(&gpu, grid_scene(140));
    assert!(errors.is_empty(), "the geometry fits: {errors:?}");
    let message = bvh.expect("the BVH is over the limit");
    for part in ["BVH triangle buffer", "1881600 bytes", &format!("limit of {LIMIT} bytes"), "mesh 0"] {
        assert!(message.contains(part), "'{part}' missing from: {message}");
    }
    assert!(hdr.iter().all(|v| v.is_finite()), "non-finite pixels");
    // The grid is still rasterized and lit (nothing is traced, so nothing shadows it).
    let mean = hdr.chunks_exact(4).map(|p| p[1]).sum::<f32>() / (hdr.len() / 4) as f32;
    assert!(mean > 0.01, "the grid is not drawn: mean green {mean}");
}

//! Support for the workspace tests: GPU access under the CI rules, FLIP comparisons and golden images.
//!
//! Golden images live in `tests/golden/`. Re-bless them with `BLESS=1 make test` (or `BLESS=1 cargo
//! test`); a failing comparison writes `<name>_actual.png` and `<name>_flip.png` (the error map, magma
//! colour map) beside the reference.

use std::path::{Path, PathBuf};

pub use engine::gpu::GpuContext;

/// A GPU context whose validation errors panic, or `None` (test skipped) when there is no adapter
/// outside CI. Under `CI=true` a missing adapter fails the test.
pub fn gpu(test: &str) -> Option<GpuContext> {
    GpuContext::for_tests(test)
}

/// Mean FLIP error between two RGBA8 sRGB images of the same size, and the per-pixel error map.
pub fn flip(reference: &[u8], test: &[u8], width: u32, height: u32) -> (f32, lab::metrics::FlipImageFloat) {
    let rgb = |rgba: &[u8]| -> Vec<u8> { rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
    lab::metrics::flip_rgb8(&rgb(reference), &rgb(test), width, height)
}

pub fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("golden")
}

/// Compares an RGBA8 image with `tests/golden/<name>.png` by mean FLIP; fails above `max_mean_flip`.
/// With `BLESS=1` the image becomes the new reference instead.
pub fn assert_golden(name: &str, width: u32, height: u32, rgba: &[u8], max_mean_flip: f32) -> f32 {
    let dir = golden_dir();
    let reference_path = dir.join(format!("{name}.png"));
    if std::env::var("BLESS").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(&dir).expect("create tests/golden");
        image::save_buffer(&reference_path, rgba, width, height, image::ExtendedColorType::Rgba8).expect("write golden image");
        eprintln!("blessed {}", reference_path.display());
        return 0.0;
    }
    let reference = image::open(&reference_path)
        .unwrap_or_else(|e| panic!("{}: {e} (run with BLESS=1 to create it)", reference_path.display()))
        .to_rgba8();
    assert_eq!((reference.width(), reference.height()), (width, height), "{name}: golden image size differs");
    let (mean, map) = flip(reference.as_raw(), rgba, width, height);
    if mean > max_mean_flip {
        let actual = dir.join(format!("{name}_actual.png"));
        image::save_buffer(&actual, rgba, width, height, image::ExtendedColorType::Rgba8).expect("write actual image");
        let flip_path = dir.join(format!("{name}_flip.png"));
        image::save_buffer(&flip_path, &lab::metrics::magma(&map), width, height, image::ExtendedColorType::Rgb8).expect("write FLIP map");
        panic!(
            "{name}: mean FLIP {mean:.4} > {max_mean_flip} against {}; wrote {} and {}",
            reference_path.display(),
            actual.display(),
            flip_path.display()
        );
    }
    mean
}

/// Geometry helpers shared by the CPU-side ray tests.
pub mod cpu_rays {
    use glam::Vec3;

    /// Hits within this distance of the ray origin are ignored (the origin may sit on a surface).
    pub const RAY_EPSILON: f32 = 1e-4;
    /// Barycentric tolerance, so rays through shared edges do not slip between two triangles.
    pub const BARYCENTRIC_SLACK: f32 = 1e-5;

    /// Möller–Trumbore, two-sided: the distance along `dir` to triangle `abc`, if it is hit beyond
    /// [`RAY_EPSILON`].
    pub fn intersect(origin: Vec3, dir: Vec3, [a, b, c]: [Vec3; 3]) -> Option<f32> {
        let e1 = b - a;
        let e2 = c - a;
        let p = dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = origin - a;
        let u = s.dot(p) * inv;
        if !(-BARYCENTRIC_SLACK..=1.0 + BARYCENTRIC_SLACK).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = dir.dot(q) * inv;
        if v < -BARYCENTRIC_SLACK || u + v > 1.0 + BARYCENTRIC_SLACK {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > RAY_EPSILON).then_some(t)
    }

    pub use engine::rt::cpu::fibonacci_directions;
}

/// How far from 1 a unit normal's length may be.
pub const MESH_UNIT_TOLERANCE: f32 = 1e-4;

/// Asserts the mesh invariants of [`engine::scene::Mesh`] and that every triangle is wound
/// counter-clockwise seen from the side its vertex normals face.
pub fn assert_valid_mesh(scene: &str, mesh: &engine::scene::Mesh) {
    let name = &mesh.name;
    assert!(!mesh.positions.is_empty(), "{scene}/{name}: empty mesh");
    assert_eq!(mesh.normals.len(), mesh.positions.len(), "{scene}/{name}: one normal per vertex");
    assert!(mesh.uvs.is_empty() || mesh.uvs.len() == mesh.positions.len(), "{scene}/{name}: uvs either absent or one per vertex");
    assert!(mesh.positions.iter().all(|p| p.is_finite()), "{scene}/{name}: non-finite position");
    assert!(mesh.uvs.iter().all(|uv| uv.is_finite()), "{scene}/{name}: non-finite uv");
    for n in &mesh.normals {
        assert!(n.is_finite() && (n.length() - 1.0).abs() < MESH_UNIT_TOLERANCE, "{scene}/{name}: normal {n} is not unit length");
    }
    assert!(!mesh.indices.is_empty(), "{scene}/{name}: no triangles");
    assert_eq!(mesh.indices.len() % 3, 0, "{scene}/{name}: index count not a multiple of 3");
    let count = mesh.positions.len() as u32;
    assert!(mesh.indices.iter().all(|&i| i < count), "{scene}/{name}: index out of range");
    for tri in mesh.indices.chunks_exact(3) {
        let [a, b, c] = [tri[0], tri[1], tri[2]].map(|i| mesh.positions[i as usize]);
        let face = (b - a).cross(c - a);
        assert!(face.length() > 1e-8, "{scene}/{name}: degenerate triangle {tri:?}");
        for &i in tri {
            assert!(face.dot(mesh.normals[i as usize]) > 0.0, "{scene}/{name}: triangle {tri:?} is wound against its normals");
        }
    }
}

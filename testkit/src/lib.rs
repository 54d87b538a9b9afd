//! Shared test support, a dev-dependency of every crate's tests: GPU access under the CI rules
//! ([`gpu`]), FLIP comparisons ([`flip`], [`mean_flip`]), golden images ([`assert_golden`]),
//! path-traced reference images ([`path_traced_reference`]), test scenes ([`closed_room`]) and the
//! shared data beside the checkout ([`shared`]).
//!
//! **Re-blessing.** Every reference image lives in `tests/golden/` and is re-made by one command,
//! `make bless` (`BLESS=1 cargo test --workspace`): golden images from the renderer under test, and
//! the path-traced references (`<scene>_pathtrace_reference.png`) from the path tracer at
//! [`REFERENCE_SPP`] paths per pixel. A failing golden comparison writes `<name>_actual.png` and
//! `<name>_flip.png` (the FLIP error map) beside the reference.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::{HeadlessSettings, render_scene_with};
use engine::scene::{Camera, Material, NodeContent, SceneDescription, Transform};
use glam::Vec3;

/// A GPU context whose validation errors panic, or `None` when there is no adapter: the test is then
/// skipped with a `<test>: skipped: no GPU adapter` line that shows even when the test passes. Under
/// `CI=true` a missing adapter fails the test.
pub fn gpu(test: &str) -> Option<GpuContext> {
    GpuContext::for_tests(test)
}

/// [`gpu`] with other options (smaller limits, say); validation errors still panic.
pub fn gpu_with(test: &str, options: GpuOptions<'_>) -> Option<GpuContext> {
    GpuContext::for_tests_with(test, options)
}

/// The item `relative` of the shared folder beside the checkout (`../shared/<relative>`, see
/// [`scenes::shared`]), or `None` after a `<test>: skipped: ../shared/<relative> is absent (…)` line:
/// tests of data the repository does not hold skip with that message, never silently.
pub fn shared(test: &str, relative: &str) -> Option<PathBuf> {
    let found = scenes::shared::path(relative);
    if found.is_none() {
        eprintln!("{test}: skipped: {}", scenes::shared::absent(relative));
    }
    found
}

/// Whether references are being re-made (`BLESS=1`) instead of compared with.
pub fn blessing() -> bool {
    std::env::var("BLESS").is_ok_and(|v| v == "1")
}

/// Mean FLIP error between two RGBA8 sRGB images of the same size, and the per-pixel error map.
pub fn flip(reference: &[u8], test: &[u8], width: u32, height: u32) -> (f32, lab::metrics::FlipImageFloat) {
    let rgb = |rgba: &[u8]| -> Vec<u8> { rgba.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect() };
    lab::metrics::flip_rgb8(&rgb(reference), &rgb(test), width, height)
}

/// Mean FLIP error between two RGBA8 sRGB images of the same size.
pub fn mean_flip(reference: &[u8], test: &[u8], width: u32, height: u32) -> f32 {
    flip(reference, test, width, height).0
}

/// `tests/golden/` of the workspace, where every reference image lives.
pub fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/golden")
}

/// Compares an RGBA8 image with `tests/golden/<name>.png` by mean FLIP; fails above `max_mean_flip`,
/// writing `<name>_actual.png` and `<name>_flip.png` beside the reference. With `BLESS=1` the image
/// becomes the new reference instead. Returns the mean FLIP.
pub fn assert_golden(name: &str, width: u32, height: u32, rgba: &[u8], max_mean_flip: f32) -> f32 {
    let dir = golden_dir();
    let reference_path = dir.join(format!("{name}.png"));
    if blessing() {
        std::fs::create_dir_all(&dir).expect("create tests/golden");
        image::save_buffer(&reference_path, rgba, width, height, image::ExtendedColorType::Rgba8).expect("write golden image");
        eprintln!("blessed {}", reference_path.display());
        return 0.0;
    }
    let reference = image::open(&reference_path)
        .unwrap_or_else(|e| panic!("{}: {e} (run `make bless` to create it)", reference_path.display()))
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

/// Paths per pixel of the path-traced references: their own noise is far below the bounds of the
/// tests that use them.
pub const REFERENCE_SPP: u32 = 4096;
/// Paths per pixel the path tracer adds each frame while making a reference.
const REFERENCE_SPP_PER_FRAME: u32 = 16;

/// The path-traced reference of the built-in `scene` at `size`×`size` pixels (tonemapped sRGB),
/// `tests/golden/<scene>_pathtrace_reference.png`. With `BLESS=1` it is rendered first, as
/// `game_demo render --scene <scene> --mode pathtrace --spp 4096 --width <size> --height <size>`
/// does (minutes on a software driver).
pub fn path_traced_reference(gpu: &GpuContext, scene: &str, size: u32) -> image::RgbaImage {
    let path = golden_dir().join(format!("{scene}_pathtrace_reference.png"));
    // Several tests share a reference: the first one of the process to get here renders it.
    static BLESSED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
    let mut blessed = BLESSED.lock().unwrap_or_else(|e| e.into_inner());
    if blessing() && !blessed.contains(&path) {
        let description = scenes::find(scene).map(|s| (s.build)()).unwrap_or_else(|| panic!("no built-in scene '{scene}'"));
        let frames = REFERENCE_SPP.div_ceil(REFERENCE_SPP_PER_FRAME);
        let settings = HeadlessSettings { width: size, height: size, frames, ..Default::default() };
        let tracer = pathtrace::PathTraceSettings { samples_per_frame: REFERENCE_SPP_PER_FRAME, ..Default::default() };
        let frame = render_scene_with(gpu, description, &settings, |app| pathtrace::use_path_tracer(app, tracer)).expect("path trace");
        image::save_buffer(&path, &frame.ldr, size, size, image::ExtendedColorType::Rgba8).expect("write the reference");
        eprintln!("blessed {}", path.display());
        blessed.push(path.clone());
    }
    drop(blessed);
    let reference = image::open(&path).unwrap_or_else(|e| panic!("{}: {e} (run `make bless` to create it)", path.display())).to_rgba8();
    assert_eq!(reference.dimensions(), (size, size), "{}: size differs", path.display());
    reference
}

/// A closed room of solid slabs `thickness` thick around the interior `lo..hi`, all of one material,
/// with a camera at the centre looking at the `lo` corner.
pub fn closed_room(lo: Vec3, hi: Vec3, thickness: f32, material: Material) -> SceneDescription {
    let mut s = SceneDescription { name: "closed_room".into(), ..Default::default() };
    let m = s.add_material(material);
    s.add_mesh_node("room", Transform::IDENTITY, engine::shapes::closed_shell("room", lo, hi, thickness), m);
    let extent = (hi - lo).max_element();
    let camera = Transform::from_translation((lo + hi) * 0.5).looking_at(lo, Vec3::Y);
    let camera_node = Camera { yfov: 1.2, znear: extent * 1e-3, ..Default::default() };
    s.add_node("camera", camera, None, vec![NodeContent::Camera(camera_node)]);
    s
}

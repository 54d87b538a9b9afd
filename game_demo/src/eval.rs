//! `game_demo eval`: error against a path-traced reference and GPU time, for every configuration of
//! a list. Writes `report.md`, `results.json` and, per configuration, a strip of four panels:
//! direct only | the method | the reference | the FLIP error map (magma).

use std::path::{Path, PathBuf};

use engine::gpu::GpuContext;
use engine::headless::{HeadlessSettings, RenderedFrame, render_scene, render_scene_with};
use engine::metrics::{ErrorMetrics, compare, flip_rgb8, magma, tonemap_to_srgb8};
use engine::scene::SceneDescription;
use serde::Serialize;

/// Paths per pixel of the path tracer configurations compared with the reference.
pub const PATH_TRACE_LADDER: [u32; 4] = [1, 4, 16, 64];

/// One thing to evaluate.
#[derive(Clone, Debug, PartialEq)]
pub enum Config {
    Direct,
    PathTrace { spp: u32 },
}

impl Config {
    pub fn name(&self) -> String {
        match self {
            Config::Direct => "direct".into(),
            Config::PathTrace { spp } => format!("pathtrace_{spp}spp"),
        }
    }
}

/// A configuration's result.
#[derive(Serialize)]
pub struct EvalRow {
    pub config: String,
    pub frames: u32,
    /// Mean GPU milliseconds per frame (all passes that ran), or absent without timestamps.
    pub gpu_ms_per_frame: Option<f64>,
    /// GPU milliseconds for the whole image (all frames).
    pub gpu_ms_total: Option<f64>,
    pub error: ErrorMetrics,
}

const SAMPLES_PER_FRAME: u32 = 16;

fn render(
    gpu: &GpuContext,
    scene: &SceneDescription,
    config: &Config,
    width: u32,
    height: u32,
    seed: u32,
) -> Result<RenderedFrame, String> {
    match config {
        Config::Direct => render_scene(gpu, scene.clone(), &HeadlessSettings { width, height, ..Default::default() }),
        Config::PathTrace { spp } => {
            let per_frame = (*spp).clamp(1, SAMPLES_PER_FRAME);
            let settings = HeadlessSettings { width, height, frames: spp.div_ceil(per_frame), ..Default::default() };
            let path = pathtrace::PathTraceSettings { samples_per_frame: per_frame, seed, ..Default::default() };
            render_scene_with(gpu, scene.clone(), &settings, |app| pathtrace::use_path_tracer(app, path))
        }
    }
    .map_err(|e| e.to_string())
}

fn gpu_ms(frame: &RenderedFrame) -> (Option<f64>, Option<f64>) {
    let per_frame: Vec<f64> =
        frame.timings.iter().filter_map(|f| f.passes.iter().filter(|p| p.ran).map(|p| p.gpu_ms).sum::<Option<f64>>()).collect();
    if per_frame.is_empty() {
        return (None, None);
    }
    let total: f64 = per_frame.iter().sum();
    (Some(total / per_frame.len() as f64), Some(total))
}

/// The reference image (linear RGBA), rendered once and cached as EXR by scene, size and paths per pixel.
fn reference(
    gpu: &GpuContext,
    name: &str,
    scene: &SceneDescription,
    width: u32,
    height: u32,
    spp: u32,
    cache: &Path,
) -> Result<Vec<f32>, String> {
    let key = cache.join(format!("{}-{width}x{height}-{spp}spp.exr", name.replace(['/', '\\', '.'], "_")));
    if let Ok(img) = image::open(&key) {
        let rgb = img.to_rgb32f();
        if (rgb.width(), rgb.height()) == (width, height) {
            println!("reference: cached {}", key.display());
            return Ok(rgb.pixels().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect());
        }
    }
    println!("reference: path tracing {spp} paths per pixel…");
    // A different seed from the ladder's, so that the ladder's noise is not the reference's.
    let frame = render(gpu, scene, &Config::PathTrace { spp }, width, height, 0xC0DE)?;
    std::fs::create_dir_all(cache).map_err(|e| format!("{}: {e}", cache.display()))?;
    let rgb: Vec<f32> = frame.hdr.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]).collect();
    image::Rgb32FImage::from_raw(width, height, rgb)
        .ok_or("reference size mismatch")?
        .save(&key)
        .map_err(|e| format!("{}: {e}", key.display()))?;
    Ok(frame.hdr)
}

fn save_strip(path: &Path, panels: &[Vec<u8>], width: u32, height: u32) -> Result<(), String> {
    let mut strip = image::RgbImage::new(width * panels.len() as u32, height);
    for (k, panel) in panels.iter().enumerate() {
        for y in 0..height {
            for x in 0..width {
                let i = ((y * width + x) * 3) as usize;
                strip.put_pixel(k as u32 * width + x, y, image::Rgb([panel[i], panel[i + 1], panel[i + 2]]));
            }
        }
    }
    strip.save(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// What to evaluate and where to write it.
pub struct EvalOptions {
    pub width: u32,
    pub height: u32,
    /// Paths per pixel of the reference.
    pub reference_spp: u32,
    /// Folder of the report.
    pub out: PathBuf,
    /// Folder of cached references.
    pub cache: PathBuf,
}

/// Runs the evaluation of `scene` (named `name`) and writes the report.
pub fn run(gpu: &GpuContext, name: &str, scene: SceneDescription, options: &EvalOptions) -> Result<Vec<EvalRow>, String> {
    let EvalOptions { width, height, reference_spp, ref out, ref cache } = *options;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let exposure = 1.0;
    let reference = reference(gpu, name, &scene, width, height, reference_spp, cache)?;
    let reference_ldr = tonemap_to_srgb8(&reference, exposure);
    let mut configs = vec![Config::Direct];
    configs.extend(PATH_TRACE_LADDER.iter().map(|&spp| Config::PathTrace { spp }));
    let mut rows = Vec::new();
    let mut direct_ldr: Option<Vec<u8>> = None;
    for config in configs {
        let frame = render(gpu, &scene, &config, width, height, pathtrace::PathTraceSettings::default().seed)?;
        let error = compare(&reference, &frame.hdr, width, height, exposure);
        let (per_frame, total) = gpu_ms(&frame);
        let ldr = tonemap_to_srgb8(&frame.hdr, exposure);
        let direct = direct_ldr.get_or_insert_with(|| ldr.clone()).clone();
        let (_, map) = flip_rgb8(&reference_ldr, &ldr, width, height);
        save_strip(&out.join(format!("{}.png", config.name())), &[direct, ldr, reference_ldr.clone(), magma(&map)], width, height)?;
        println!("{:>18}: FLIP {:.4}, RMSE {:.4}, relative MSE {:.4}", config.name(), error.mean_flip, error.rmse, error.relative_mse);
        rows.push(EvalRow {
            config: config.name(),
            frames: frame.timings.len() as u32,
            gpu_ms_per_frame: per_frame,
            gpu_ms_total: total,
            error,
        });
    }
    write_report(out, name, &gpu.adapter_name(), width, height, reference_spp, &rows)?;
    Ok(rows)
}

fn write_report(
    out: &Path,
    name: &str,
    adapter: &str,
    width: u32,
    height: u32,
    reference_spp: u32,
    rows: &[EvalRow],
) -> Result<(), String> {
    let ms = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.3}"));
    let mut md = format!(
        "# Evaluation: {name}\n\n{width}×{height} on {adapter}; reference: the path tracer at {reference_spp} paths per pixel (another seed).\n\
         FLIP on sRGB tonemapped at exposure 1; RMSE and relative MSE on linear radiance.\n\
         Each strip `<configuration>.png`: direct only | the configuration | the reference | FLIP map (magma).\n\n\
         | configuration | frames | GPU ms per frame | GPU ms total | mean FLIP | RMSE | relative MSE |\n|---|---:|---:|---:|---:|---:|---:|\n"
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {} | {} | {:.4} | {:.4} | {:.5} |\n",
            r.config,
            r.frames,
            ms(r.gpu_ms_per_frame),
            ms(r.gpu_ms_total),
            r.error.mean_flip,
            r.error.rmse,
            r.error.relative_mse
        );
    }
    let path: PathBuf = out.join("report.md");
    std::fs::write(&path, md).map_err(|e| format!("{}: {e}", path.display()))?;
    let json = out.join("results.json");
    let text = serde_json::to_string_pretty(rows).map_err(|e| e.to_string())?;
    std::fs::write(&json, text).map_err(|e| format!("{}: {e}", json.display()))
}

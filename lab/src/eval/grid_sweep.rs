//! `game_demo eval --grid-sweep`: DDGI at its defaults over a ladder of probe grids, each against
//! the one path-traced reference — mean FLIP and the *dark-region ratio* (how bright the image's
//! dark part is against the reference's: a leak through a wall raises it, visibility that rejects
//! every probe lowers it) — so that a grid that leaks stands out. Writes `grid_sweep.md`,
//! `grid_sweep.json`, `grid_sweep.png` (both numbers per grid) and a strip per grid.

use std::path::Path;

use engine::gpu::GpuContext;
use engine::scene::SceneDescription;
use serde::Serialize;

use super::{Config, EXPOSURE, EvalOptions, SceneFacts, gpu_ms, reference, render, save_strip, still, write};
use crate::metrics::{flip_rgb8, magma, tonemap_to_srgb8};
use crate::plot;

/// The grids of the sweep, coarse to fine: a volume's defaults with only the grid changed (and
/// first the grid the volume fits itself, `None`).
pub const SWEEP_GRIDS: [Option<[u32; 3]>; 10] = [
    None,
    Some([4, 2, 4]),
    Some([8, 4, 8]),
    Some([8, 8, 8]),
    Some([12, 6, 12]),
    Some([16, 8, 16]),
    Some([16, 16, 16]),
    Some([24, 8, 24]),
    Some([32, 8, 32]),
    Some([32, 16, 32]),
];

/// Frames each grid runs before its image is taken: light in a closed room builds up over many
/// bounces, one a frame, smoothed by the hysteresis (0.97^240 ≈ 0.07% of the start left).
pub const SWEEP_FRAMES: u32 = 240;

/// A pixel is in the image's dark region when the reference's luminance there is under this share
/// of the reference's mean over the pixels that see anything.
pub const DARK_SHARE: f64 = 0.1;

/// One grid's result.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRow {
    /// `fitted` or `X×Y×Z`.
    pub grid: String,
    /// The probe counts the volume used.
    pub probes: [u32; 3],
    pub mean_flip: f32,
    /// Mean luminance of the dark region over the reference's there ([`dark_region_ratio`]).
    pub dark_ratio: Option<f64>,
    pub gpu_ms_per_frame: Option<f64>,
}

/// The image's dark region (see [`DARK_SHARE`]): mean luminance of `test` there over the
/// reference's. `None` when the reference has no such pixel. Both images linear RGBA.
pub fn dark_region_ratio(reference: &[f32], test: &[f32]) -> Option<f64> {
    let luminance = |p: &[f32]| 0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2]);
    let lit: Vec<f64> = reference.chunks_exact(4).map(luminance).collect();
    let seen: Vec<f64> = lit.iter().copied().filter(|&l| l > 0.0).collect();
    if seen.is_empty() {
        return None;
    }
    let threshold = DARK_SHARE * seen.iter().sum::<f64>() / seen.len() as f64;
    let (mut sum_ref, mut sum_test) = (0.0, 0.0);
    for (l, t) in lit.iter().zip(test.chunks_exact(4)) {
        if *l > 0.0 && *l < threshold {
            sum_ref += l;
            sum_test += luminance(t);
        }
    }
    (sum_ref > 0.0).then(|| sum_test / sum_ref)
}

/// The grid a volume of the defaults fits to `scene`'s GI box ([`ddgi::auto_probe_counts`]).
fn fitted_grid(facts: &SceneFacts, scene: &SceneDescription) -> [u32; 3] {
    let bounds = facts.gi_bounds.or_else(|| scene.bounds());
    bounds.map_or([2; 3], |(lo, hi)| ddgi::auto_probe_counts(hi - lo).to_array())
}

fn grid_name(grid: Option<[u32; 3]>) -> String {
    grid.map_or("fitted".into(), |[x, y, z]| format!("{x}×{y}×{z}"))
}

/// Runs the sweep on `scene` with `base`'s settings (the defaults unless an experiment says
/// otherwise; its grid and bounds are the sweep's) and writes its report into `options.out`.
pub fn run(
    gpu: &GpuContext,
    facts: &SceneFacts,
    scene: SceneDescription,
    options: &EvalOptions,
    base: &ddgi::DdgiVolume,
) -> Result<Vec<SweepRow>, String> {
    let EvalOptions { width, height, reference_spp, ref out, ref cache, .. } = *options;
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let scene = still(scene);
    let reference = reference(gpu, &facts.name, &scene, width, height, reference_spp, cache)?;
    let reference_ldr = tonemap_to_srgb8(&reference, EXPOSURE);
    let seed = pathtrace::PathTraceSettings::default().seed;
    let direct = tonemap_to_srgb8(&render(gpu, &scene, &Config::Direct, width, height, seed, Config::Direct.frames())?.hdr, EXPOSURE);
    let mut rows = Vec::new();
    for grid in SWEEP_GRIDS {
        let volume = ddgi::DdgiVolume { probe_counts: grid.map(Into::into), bounds: None, ..base.clone() };
        let name = format!("grid_{}", grid_name(grid).replace('×', "x"));
        let config = Config::ddgi(name.clone(), facts, volume).placed_at(scene.origin);
        let frame = render(gpu, &scene, &config, width, height, seed, SWEEP_FRAMES)?;
        let ldr = tonemap_to_srgb8(&frame.hdr, EXPOSURE);
        let (mean_flip, map) = flip_rgb8(&reference_ldr, &ldr, width, height);
        save_strip(&out.join(format!("{name}.png")), &[direct.clone(), ldr, reference_ldr.clone(), magma(&map)], width, height)?;
        let probes = grid.unwrap_or_else(|| fitted_grid(facts, &scene));
        let row = SweepRow {
            grid: grid_name(grid),
            probes,
            mean_flip,
            dark_ratio: dark_region_ratio(&reference, &frame.hdr),
            gpu_ms_per_frame: gpu_ms(&frame).0,
        };
        println!(
            "{:>10} ({}×{}×{}): FLIP {:.4}, dark-region ratio {}",
            row.grid,
            probes[0],
            probes[1],
            probes[2],
            row.mean_flip,
            row.dark_ratio.map_or("n/a".into(), |r| format!("{r:.3}"))
        );
        rows.push(row);
    }
    write_report(out, &facts.name, &gpu.adapter_name(), options, &rows)?;
    Ok(rows)
}

fn write_report(out: &Path, name: &str, adapter: &str, options: &EvalOptions, rows: &[SweepRow]) -> Result<(), String> {
    let EvalOptions { width, height, reference_spp, .. } = *options;
    let categories: Vec<String> = rows.iter().map(|r| r.grid.clone()).collect();
    let groups = vec![
        ("mean FLIP × 10".to_string(), rows.iter().map(|r| Some(10.0 * f64::from(r.mean_flip))).collect()),
        ("dark-region ratio (1: as the reference)".to_string(), rows.iter().map(|r| r.dark_ratio).collect()),
    ];
    plot::bars(&out.join("grid_sweep.png"), &format!("{name}: DDGI by probe grid"), &categories, &groups, "value")?;
    let best = rows.iter().map(|r| r.mean_flip).fold(f32::INFINITY, f32::min);
    let mut md = format!(
        "# Grid sweep: {name}\n\n{width}×{height} on {adapter}; DDGI at its defaults, or the settings of `--volume-settings` (one \
         volume over the scene's GI box, adaptive budgets, TAA), with only the probe grid changed, {SWEEP_FRAMES} frames each; reference: the path tracer at \
         {reference_spp} paths per pixel. Mean FLIP on sRGB tonemapped at exposure 1. Dark-region ratio: mean luminance over \
         the pixels where the reference's is under {DARK_SHARE} of its mean (over the pixels that see anything), DDGI's over \
         the reference's: above 1, light leaks in; below 1, the dark region lost its indirect light. Each strip \
         `grid_<grid>.png`: direct only | DDGI | the reference | FLIP map (magma).\n\n\
         | grid | probes | mean FLIP | over the best grid's | dark-region ratio | GPU ms per frame |\n|---|---|---:|---:|---:|---:|\n"
    );
    for r in rows {
        let [x, y, z] = r.probes;
        md += &format!(
            "| {} | {x}×{y}×{z} | {:.4} | {:.2} | {} | {} |\n",
            r.grid,
            r.mean_flip,
            r.mean_flip / best.max(f32::MIN_POSITIVE),
            r.dark_ratio.map_or("n/a".into(), |v| format!("{v:.3}")),
            r.gpu_ms_per_frame.map_or("n/a".into(), |v| format!("{v:.3}")),
        );
    }
    md += "\n![FLIP and dark-region ratio by grid](grid_sweep.png)\n";
    write(&out.join("grid_sweep.md"), &md)?;
    let text = serde_json::to_string_pretty(rows).map_err(|e| e.to_string())?;
    write(&out.join("grid_sweep.json"), &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dark_region_ratio_sees_a_leak_and_a_loss_and_ignores_the_bright_part() {
        // Four pixels: bright, bright, dark, black background.
        let reference = [[1.0, 1.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0], [0.01, 0.01, 0.01, 1.0], [0.0, 0.0, 0.0, 1.0]].concat();
        let same = reference.clone();
        assert!((dark_region_ratio(&reference, &same).expect("dark pixels") - 1.0).abs() < 1e-9);
        let mut leak = reference.clone();
        leak[8..11].copy_from_slice(&[0.04, 0.04, 0.04]);
        // Brighter elsewhere changes nothing.
        leak[0..3].copy_from_slice(&[3.0, 3.0, 3.0]);
        assert!((dark_region_ratio(&reference, &leak).expect("dark pixels") - 4.0).abs() < 1e-6);
        let mut lost = reference.clone();
        lost[8..11].copy_from_slice(&[0.0, 0.0, 0.0]);
        assert_eq!(dark_region_ratio(&reference, &lost), Some(0.0));
        assert_eq!(dark_region_ratio(&[0.5, 0.5, 0.5, 1.0], &[0.5, 0.5, 0.5, 1.0]), None, "no dark pixel");
        assert_eq!(dark_region_ratio(&[0.0; 4], &[1.0; 4]), None, "nothing seen");
    }
}

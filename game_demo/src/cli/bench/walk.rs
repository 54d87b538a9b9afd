//! `bench walk`: DDGI's GPU time per frame while the camera walks a scene's tour.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};

use super::write_json;
use crate::cli::{load, parse_dvec3};

#[derive(clap::Args)]
pub struct WalkArgs {
    /// A built-in scene with a tour (open_world) or any scene (its camera carried sideways).
    #[arg(long, default_value = "open_world")]
    scene: String,
    /// Camera-following cascades (0: one volume over the scene's GI bounds with --probes).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(0..=8))]
    cascades: u32,
    /// Probes of the one volume with --cascades 0, `X,Y,Z`.
    #[arg(long, value_parser = lab::parse_uvec3, default_value = "32,8,32")]
    probes: glam::UVec3,
    /// Probes of each cascade, `X,Y,Z`.
    #[arg(long, value_parser = lab::parse_uvec3, default_value = "16,8,16")]
    cascade_probes: glam::UVec3,
    /// Probe spacing of the finest cascade (metres).
    #[arg(long, default_value_t = 1.5)]
    cascade_spacing: f32,
    /// Width of the cascades' blend bands, in cells (DdgiCascades::blend_cells).
    #[arg(long, default_value_t = ddgi::DdgiCascades::default().blend_cells)]
    cascade_blend: f32,
    /// Longest update period of a cascade in frames (DdgiCascades::max_update_period).
    #[arg(long, default_value_t = ddgi::DdgiCascades::default().max_update_period, value_parser = clap::value_parser!(u32).range(1..))]
    cascade_period: u32,
    /// Rays per frame shared by the cascades that update in a frame, in proportion to what their
    /// probes ask for (DdgiCascades::frame_budget), or, with --cascades 0, the one volume's
    /// (DdgiAdaptive::frame_budget): the same budget compares both at one ray count. Default:
    /// no budget.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    frame_budget: Option<u32>,
    /// Rays per probe per frame.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().rays_per_probe)]
    rays: u32,
    /// Fixed ray budgets instead of adaptive ones.
    #[arg(long)]
    no_adaptive: bool,
    /// Frames of the walk (60 per second).
    #[arg(long, default_value_t = 600)]
    frames: u32,
    /// Frames the camera stands at the door first.
    #[arg(long, default_value_t = 60)]
    warmup: u32,
    /// Walking speed, metres per second.
    #[arg(long, default_value_t = 1.5)]
    speed: f32,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1920)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 1080)]
    height: u32,
    /// Place the scene this far from the world's origin, `x,y,z`.
    #[arg(long, value_parser = parse_dvec3)]
    offset: Option<glam::DVec3>,
    /// Output folder of walk.csv.
    #[arg(long, default_value = "out/walk")]
    out: PathBuf,
    /// Visibility rays of the sky light per pixel no volume covers (DdgiSkyLight::rays; 0: off).
    #[arg(long, default_value_t = ddgi::DdgiSkyLight::default().rays)]
    sky_rays: u32,
    /// Reach of those rays in metres (default: a tenth of the scene's extent).
    #[arg(long)]
    sky_reach: Option<f32>,
    /// Every N frames, the frame's mean FLIP against a path-traced reference of its view
    /// (walk.csv's `flip`), and the mean change of that error from one measured frame to the next.
    #[arg(long)]
    error_every: Option<u32>,
    /// Paths per pixel of those references.
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// Also write the results as JSON to this file (the same figures as the Markdown).
    #[arg(long)]
    json: Option<PathBuf>,
}

pub fn run(args: WalkArgs) -> Result<(), String> {
    let report = walk(&args)?;
    write_json(args.json.as_deref(), report)
}

/// Walks the tour and prints what it measured; gives the same figures as JSON.
fn walk(args: &WalkArgs) -> Result<serde_json::Value, String> {
    let WalkArgs {
        ref scene,
        cascades,
        cascade_spacing: spacing,
        cascade_blend: blend,
        cascade_period,
        frame_budget,
        rays,
        frames,
        warmup,
        speed,
        width,
        height,
        offset,
        ref out,
        error_every,
        reference_spp,
        ..
    } = *args;
    let name = scene.as_str();
    let adaptive = !args.no_adaptive;
    let probes = if cascades > 0 { args.cascade_probes } else { args.probes };
    let sky_light = ddgi::DdgiSkyLight { rays: args.sky_rays, max_distance: args.sky_reach };
    let out = out.as_path();
    let scene = load(name)?;
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    let volume = ddgi::DdgiVolume {
        bounds: scenes::find(name).and_then(|e| (e.gi_bounds)()).map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3())),
        probe_counts: Some(probes),
        rays_per_probe: rays,
        adaptive: ddgi::DdgiAdaptive {
            enabled: adaptive,
            min_rays: ddgi::DdgiAdaptive::default().min_rays.min(rays),
            // One volume takes the budget itself; cascades share theirs (below).
            frame_budget: if cascades == 0 { frame_budget } else { None },
            ..Default::default()
        },
        ..Default::default()
    };
    volume.validate().map_err(|e| e.to_string())?;
    let cascades = (cascades > 0).then(|| ddgi::DdgiCascades {
        count: Some(cascades),
        probe_counts: probes,
        spacing,
        blend_cells: blend,
        max_update_period: cascade_period,
        frame_budget,
        volume: ddgi::DdgiVolume { bounds: None, warm_up: true, ..volume.clone() },
    });
    if let Some(c) = &cascades {
        c.validate().map_err(|e| e.to_string())?;
    }
    let what = cascades
        .as_ref()
        .map_or(format!("one volume of {probes}"), |c| format!("{} cascades of {probes}, finest {spacing} m", c.count.unwrap_or(0)));
    let config = match &cascades {
        Some(c) => lab::eval::Config::ddgi_cascades(c),
        None => lab::eval::Config::Ddgi { name: "ddgi".into(), volume: Box::new(volume), occlusion: Default::default(), taa: true },
    };
    let path = lab::walk::WalkPath::for_scene(name, &scene);
    let options = lab::walk::WalkOptions {
        speed,
        warmup,
        offset: offset.unwrap_or_default(),
        sky: scenes::find(name).and_then(|e| e.walk_sky).unwrap_or(glam::Vec3::ZERO),
        sky_light,
        error_every,
        reference_spp,
        ..lab::walk::WalkOptions::new(config, path, engine::render::RenderSize { width, height }, frames)
    };
    let report = lab::walk::walk(&gpu, scene, &options, Some(out))?;
    println!(
        "# bench walk: {name}, {what}, {rays} rays (adaptive: {adaptive}), {width}×{height}, {frames} frames at {speed} m/s, on {}",
        gpu.adapter_name()
    );
    println!(
        "DDGI GPU ms per frame: median {:.3}, slowest {:.3}; frames over 2× the median: {}",
        report.median_ddgi_ms(),
        report.max_ddgi_ms(),
        report.frames_over(2.0)
    );
    for k in 0..report.volumes {
        let rays = report.mean_volume_rays(k).map_or("n/a".to_string(), |r| format!("{r:.0}"));
        println!("  volume {k}: gather median {:.3} ms, rays per frame mean {rays}", report.median_volume_ms(k));
    }
    println!(
        "  all gathers: median {:.3} ms; composite (with the sky light): median {:.3} ms",
        report.median_of(|f| f.gather_ms),
        report.median_of(|f| f.composite_ms)
    );
    let scrolls = report.frames.iter().filter(|f| f.scrolled > 0).count();
    let over: Vec<u32> = report.frames.iter().filter(|f| f.ddgi_ms > 2.0 * report.median_ddgi_ms()).map(|f| f.frame).collect();
    println!("frames with a scroll: {scrolls}; frames over 2× the median: {over:?}");
    if let Some((mean, change)) = report.flip_summary() {
        println!(
            "FLIP against path-traced references ({reference_spp} spp) of every {}th frame: mean {mean:.4}, mean change between them {change:.4}",
            error_every.unwrap_or(0)
        );
    }
    println!("median GPU ms of each pass (over the frames it ran in):");
    for (label, ms, frames) in report.pass_medians() {
        println!("  {label}: {ms:.4} ({frames} frames)");
    }
    if let Some(rays) = report.mean_rays() {
        println!("rays traced per frame (every volume): mean {rays:.0}");
    }
    let rebases = report.frames.iter().filter(|f| f.rebased).count();
    println!("rebases: {rebases}; every frame in {}", out.join("walk.csv").display());
    let passes: serde_json::Map<String, serde_json::Value> = report
        .pass_medians()
        .into_iter()
        .map(|(label, ms, frames)| (label, serde_json::json!({"median_ms": ms, "frames": frames})))
        .collect();
    let volumes: Vec<serde_json::Value> = (0..report.volumes)
        .map(|k| serde_json::json!({"gather_median_ms": report.median_volume_ms(k), "mean_rays": report.mean_volume_rays(k)}))
        .collect();
    Ok(serde_json::json!({
        "bench": "walk", "scene": name, "configuration": what, "adapter": gpu.adapter_name(), "rays_per_probe": rays,
        "adaptive": adaptive, "size": [width, height], "frames": frames, "speed": speed,
        "ddgi_median_ms": report.median_ddgi_ms(), "ddgi_max_ms": report.max_ddgi_ms(), "frames_over_2x_median": report.frames_over(2.0),
        "frames_with_a_scroll": scrolls, "rebases": rebases, "mean_rays": report.mean_rays(),
        "flip": report.flip_summary().map(|(mean, change)| serde_json::json!({"mean": mean, "mean_change": change})),
        "volumes": volumes, "pass_median_ms": passes, "csv": out.join("walk.csv"),
    }))
}

//! `render`: a scene rendered without a window, to files.

use std::path::PathBuf;

use engine::gpu::{GpuContext, GpuOptions};
use engine::headless::HeadlessSettings;
use engine::scene::SceneDescription;

use super::{CameraArgs, load, parse_dvec3};

/// `render`'s examples (its long help).
pub const EXAMPLES: &str = "Examples:
  game_demo render --scene cornell --mode ddgi                       # direct light + DDGI
  game_demo render --scene cornell --mode pathtrace --spp 1024       # the reference
  game_demo render --scene level --mode ddgi --display-transform agx --auto-exposure --width 1920 --height 1080
  game_demo render --scene scene.glb --mode ddgi --probes 16,8,16 --no-adaptive --dump-atlases
  game_demo render --scene open_world --mode ddgi --cascades 8       # camera-following cascades
  game_demo render --scene cornell --offset 1e5,0,0                  # far from the origin
  game_demo render --scene cornell --mode ddgi --frames 10 --trace out/trace.json   # CPU and GPU on one timeline
  game_demo render --list-scenes";

#[derive(clap::Args)]
pub struct RenderArgs {
    /// A built-in scene name (see --list-scenes; `level` is the demo level) or a .gltf, .glb or .obj file.
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 480)]
    height: u32,
    /// Frames to run with a fixed 1/60 s step; the image is the last frame (default: 120 with
    /// `--mode ddgi` and `indirect`, for the probes to converge; 32 for `direct`, for the temporal
    /// anti-aliasing to converge, 1 with --no-taa). With `--mode pathtrace` the frames needed for
    /// `--spp` are added.
    #[arg(long)]
    frames: Option<u32>,
    /// What renders the image.
    #[arg(long, value_enum, default_value = "direct")]
    mode: ModeArg,
    #[command(flatten)]
    ddgi: DdgiArgs,
    /// Paths per pixel for `--mode pathtrace`.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Bounce cap for `--mode pathtrace` (0: unbounded, ended by Russian roulette).
    #[arg(long, default_value_t = 0)]
    max_bounces: u32,
    /// Output folder.
    #[arg(long, default_value = "out/render")]
    out: PathBuf,
    #[command(flatten)]
    camera: CameraArgs,
    /// How image.png shows the radiance: `clamp` (the radiometric values, clipped at 1: what the
    /// golden images and eval use) or `agx` (a filmic roll-off of highlights). image.exr is the
    /// linear radiance either way.
    #[arg(long, value_enum, default_value = "clamp")]
    display_transform: DisplayArg,
    /// The camera's exposure as a photographic exposure value at ISO 100 (one more EV: half the
    /// exposure); default: the scene camera's own exposure.
    #[arg(long, conflicts_with = "auto_exposure")]
    ev100: Option<f32>,
    /// image.png's exposure from the image's own luminance histogram (engine::render::AutoExposure);
    /// image.exr stays linear radiance.
    #[arg(long)]
    auto_exposure: bool,
    /// Without temporal anti-aliasing (every frame as rasterized: aliased edges).
    #[arg(long)]
    no_taa: bool,
    /// Print the built-in scene names and exit.
    #[arg(long)]
    list_scenes: bool,
    /// Place the scene (and its camera) this far from the world's origin, `x,y,z` (double
    /// precision; e.g. 1e5,0,0): large-world coordinates render it as at the origin.
    #[arg(long, value_parser = parse_dvec3)]
    offset: Option<glam::DVec3>,
}

/// `render --mode`.
#[derive(Clone, Copy, PartialEq, Eq, Debug, clap::ValueEnum)]
enum ModeArg {
    /// Direct light with hard shadows.
    Direct,
    /// Direct light and DDGI's indirect light.
    Ddgi,
    /// DDGI's indirect light alone.
    Indirect,
    /// The reference path tracer (--spp paths per pixel).
    Pathtrace,
}

/// `render --display-transform`.
#[derive(Clone, Copy, clap::ValueEnum)]
enum DisplayArg {
    /// The radiometric values clipped at 1 (what the golden images and eval use).
    Clamp,
    /// AgX: a filmic roll-off of highlights into white.
    Agx,
}

impl From<DisplayArg> for engine::render::DisplayTransform {
    fn from(d: DisplayArg) -> Self {
        match d {
            DisplayArg::Clamp => Self::Clamp,
            DisplayArg::Agx => Self::AgX,
        }
    }
}

/// DDGI volume settings from the command line (the volume fills the scene's bounds).
#[derive(clap::Args, Clone, Debug)]
struct DdgiArgs {
    /// Probes along x, y and z of the volume, `X,Y,Z` (default: fitted to the volume's box,
    /// ddgi::auto_probe_counts: 16 along its longest side, at least 8 along any side an eighth as
    /// long).
    #[arg(long, value_parser = lab::parse_uvec3)]
    probes: Option<glam::UVec3>,
    /// With --cascades: probes of each cascade, `X,Y,Z`.
    #[arg(long, value_parser = lab::parse_uvec3, default_value = "16,8,16")]
    cascade_probes: glam::UVec3,
    /// Rays per probe per frame.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().rays_per_probe)]
    rays: u32,
    /// Side of each probe's irradiance map, in texels.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().irradiance_texels)]
    irradiance_texels: u32,
    /// Side of each probe's distance map, in texels.
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().distance_texels)]
    distance_texels: u32,
    /// Weight of the old probe value per frame, in [0, 1].
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hysteresis)]
    hysteresis: f32,
    /// Write the irradiance and distance atlases and the ray directions as images beside the output.
    #[arg(long)]
    dump_atlases: bool,
    /// Contact occlusion of the indirect light: rays per pixel (DdgiContactOcclusion::rays; 0: off),
    /// their reach the finest probe spacing.
    #[arg(long, default_value_t = ddgi::DdgiContactOcclusion::default().rays, value_parser = clap::value_parser!(u32).range(0..=64))]
    contact_occlusion: u32,
    /// Trace the contact occlusion at every pixel instead of at one pixel of each 2×2 block a frame
    /// (DdgiContactOcclusion::half_resolution; four times the rays).
    #[arg(long)]
    contact_occlusion_full_resolution: bool,
    /// The fixed ray budget (every probe --rays rays a frame) instead of the default adaptive one,
    /// where each probe's rays follow its temporal error (between DdgiAdaptive's min_rays and
    /// --rays) and dark probes are switched off. `timings.json` records the rays traced per frame.
    #[arg(long)]
    no_adaptive: bool,
    /// Adaptive budgets: the longest volume update period of calm phases, in frames
    /// (DdgiAdaptive::max_update_period; 1: the volume updates every frame).
    #[arg(long, default_value_t = ddgi::DdgiAdaptive::default().max_update_period, value_parser = clap::value_parser!(u32).range(1..=64))]
    max_update_period: u32,
    /// Near-field occlusion rays at each probe ray's hit (DdgiVolume::hit_occlusion_rays; 0: off).
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hit_occlusion_rays, value_parser = clap::value_parser!(u32).range(0..=64))]
    hit_occlusion: u32,
    /// Reach of those rays, a share of the smallest probe spacing (DdgiVolume::hit_occlusion_reach).
    #[arg(long, default_value_t = ddgi::DdgiVolume::default().hit_occlusion_reach)]
    hit_occlusion_reach: f32,
    /// Camera-following cascades instead of one volume over the scene: N nested volumes of
    /// --cascade-probes probes each, centred on the camera, each with twice the spacing of the one
    /// inside it, the coarsest as wide as the scene; 0: one volume. Default (and without
    /// --probes): fitted to the scene (ddgi::DdgiLighting::fitted): one volume, unless its probes
    /// would be more than ddgi::MAX_FITTED_SPACING (4 m) apart, then cascades whose finest
    /// spacing is at most 1 m. --probes X,Y,Z alone means one volume of that grid.
    #[arg(long, value_parser = clap::value_parser!(u32).range(0..=8))]
    cascades: Option<u32>,
}

impl DdgiArgs {
    /// How to light `scene`: `--cascades N` ([`ddgi::DdgiCascades::fitted`] to its largest
    /// horizontal extent), one volume (`--cascades 0` or `--probes`), else the scene-fitted rule.
    fn lighting(&self, scene: &SceneDescription) -> ddgi::DdgiLighting {
        let bounds = scene.bounds().map(|(lo, hi)| (scene.origin + lo.as_dvec3(), scene.origin + hi.as_dvec3()));
        match self.cascades {
            Some(n) if n > 0 => {
                let extent = bounds.map_or(1.0, |(lo, hi)| (hi - lo).x.max((hi - lo).z) as f32);
                ddgi::DdgiLighting::Cascades(ddgi::DdgiCascades::fitted(n, self.cascade_probes, extent, self.volume()))
            }
            Some(_) => ddgi::DdgiLighting::Volume(self.volume()),
            None => match bounds {
                Some(b) => {
                    let lighting = ddgi::DdgiLighting::Fitted(self.volume()).resolve(b);
                    if matches!(lighting, ddgi::DdgiLighting::Cascades(_)) {
                        eprintln!(
                            "DDGI fitted to the scene: one volume's probes would be {:.1} apart (over {} m), so {} (--cascades 0 for one volume)",
                            ddgi::fit::fitted_spacing(b),
                            ddgi::MAX_FITTED_SPACING,
                            lighting.describe()
                        );
                    }
                    lighting
                }
                None => ddgi::DdgiLighting::Volume(self.volume()),
            },
        }
    }

    fn volume(&self) -> ddgi::DdgiVolume {
        ddgi::DdgiVolume {
            probe_counts: self.probes,
            rays_per_probe: self.rays,
            irradiance_texels: self.irradiance_texels,
            distance_texels: self.distance_texels,
            hysteresis: self.hysteresis,
            hit_occlusion_rays: self.hit_occlusion,
            hit_occlusion_reach: self.hit_occlusion_reach,
            adaptive: ddgi::DdgiAdaptive {
                enabled: !self.no_adaptive,
                min_rays: ddgi::DdgiAdaptive::default().min_rays.min(self.rays.max(1)),
                max_update_period: self.max_update_period,
                ..Default::default()
            },
            ..Default::default()
        }
    }
}

pub fn run(args: RenderArgs) -> Result<(), String> {
    if args.list_scenes {
        for name in lab::eval::built_in_scene_names() {
            println!("{name}");
        }
        return Ok(());
    }
    let mut scene = load(&args.scene)?;
    scene.origin = args.offset.unwrap_or_default();
    args.camera.apply(&mut scene)?;
    if let Some(ev) = args.ev100 {
        if !ev.is_finite() {
            return Err(format!("--ev100: {ev} is not a finite exposure value"));
        }
        for node in &mut scene.nodes {
            for content in &mut node.content {
                if let engine::scene::NodeContent::Camera(camera) = content {
                    camera.exposure = engine::color::exposure_from_ev100(ev);
                }
            }
        }
    }
    let display = engine::render::DisplayTransform::from(args.display_transform);
    let gpu = GpuContext::new(GpuOptions::default()).map_err(|e| e.to_string())?;
    let ddgi_mode = matches!(args.mode, ModeArg::Ddgi | ModeArg::Indirect);
    let default_frames = match (ddgi_mode, args.mode, args.no_taa) {
        (true, _, _) => 120,
        (false, ModeArg::Direct, false) => 32,
        _ => 1,
    };
    let frames = args.frames.unwrap_or(default_frames);
    let camera_settings = move |app: &mut engine::bevy_app::App| {
        lab::progress::show_blas_builds(app);
        if args.no_taa {
            app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
        }
        if args.auto_exposure {
            app.insert_resource(engine::render::DefaultAutoExposure::default());
        }
    };
    let mut settings = HeadlessSettings { width: args.width, height: args.height, frames, ..Default::default() };
    let frame = if ddgi_mode {
        let volume = args.ddgi.volume();
        volume.validate().map_err(|e| e.to_string())?;
        let lighting = args.ddgi.lighting(&scene);
        if let ddgi::DdgiLighting::Cascades(c) = &lighting {
            c.validate().map_err(|e| e.to_string())?;
        }
        let output = if args.mode == ModeArg::Indirect { ddgi::DdgiOutput::Indirect } else { ddgi::DdgiOutput::Full };
        let mut dumped: Result<Vec<PathBuf>, String> = Ok(Vec::new());
        let dump = args.ddgi.dump_atlases;
        let occlusion = ddgi::DdgiContactOcclusion {
            rays: args.ddgi.contact_occlusion,
            half_resolution: !args.ddgi.contact_occlusion_full_resolution,
            ..Default::default()
        };
        let out = args.out.clone();
        let frame = engine::headless::render_scene_and_inspect(
            &gpu,
            scene,
            &settings,
            |app| {
                app.insert_resource(display).insert_resource(occlusion);
                camera_settings(app);
                ddgi::use_ddgi_lighting(app, lighting, output);
            },
            |world| {
                let volumes = world.resource::<ddgi::DdgiGpuVolumes>();
                if let Some(error) = volumes.volumes.is_empty().then(|| volumes.first_error()).flatten() {
                    dumped = Err(format!("the DDGI volume is off: {error}"));
                } else if dump && let Some((_, v)) = volumes.volumes.first() {
                    dumped = ddgi::atlas::write_atlas_images(&gpu, v, &out);
                }
            },
        )
        .map_err(|e| e.to_string())?;
        for path in dumped? {
            println!("  {}", path.display());
        }
        Ok(frame)
    } else if args.mode == ModeArg::Pathtrace {
        let per_frame = args.spp.clamp(1, 16);
        // The last frame of the run holds all the samples: earlier frames are only for animation.
        settings.frames = frames.max(1) + args.spp.max(1).div_ceil(per_frame) - 1;
        let path = pathtrace::PathTraceSettings { samples_per_frame: per_frame, max_bounces: args.max_bounces, ..Default::default() };
        // A progress bar on standard error for long renders (hidden when it is not a terminal).
        let bar = indicatif::ProgressBar::new(u64::from(settings.frames));
        bar.set_style(
            indicatif::ProgressStyle::with_template("path tracing {bar:40} {pos}/{len} frames, {elapsed} elapsed, {eta} left")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        let tick = bar.clone();
        let frame = engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
            app.insert_resource(display);
            camera_settings(app);
            pathtrace::use_path_tracer(app, path);
            app.add_systems(engine::bevy_app::Last, move || tick.inc(1));
        });
        bar.finish_and_clear();
        frame
    } else {
        engine::headless::render_scene_with(&gpu, scene, &settings, |app| {
            app.insert_resource(display);
            camera_settings(app);
        })
    }
    .map_err(|e| e.to_string())?;
    frame.write(&args.out).map_err(|e| e.to_string())?;
    let spp = if args.mode == ModeArg::Pathtrace { format!(", {} paths per pixel", args.spp) } else { String::new() };
    println!(
        "rendered '{}' ({:?}) on {} ({}×{}, {} frames{spp})",
        args.scene, args.mode, frame.adapter, args.width, args.height, settings.frames
    );
    if let Some(file) = scenes::files::find(&args.scene) {
        println!("  the scene: {} (credit them wherever the image is shown)", file.credit);
    }
    println!("  {}", args.out.join("image.png").display());
    println!("  {}", args.out.join("image.exr").display());
    println!("  {}", args.out.join("timings.json").display());
    Ok(())
}

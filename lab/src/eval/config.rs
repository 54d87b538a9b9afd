//! The configurations of the evaluation ([`Config`]): the methods and their settings, the lists
//! the still image and the time series evaluate, and how each one sets an app up to render.

use engine::bevy_app::App;
use engine::scene::SceneDescription;

use super::{PATH_TRACE_LADDER, SAMPLES_PER_FRAME, SceneFacts, TIME_SERIES_SPP};

/// One thing to evaluate. A new method is a new variant with its arms in the `match`es of this
/// `impl` and an entry in [`Config::still_list`] and/or [`Config::time_series_list`]; nothing else
/// in the evaluation needs to know it.
#[derive(Clone, Debug, PartialEq)]
pub enum Config {
    /// Direct light with hard shadows: the engine's default frame script, one frame.
    Direct,
    /// The progressive path tracer with `spp` paths per pixel, at most [`SAMPLES_PER_FRAME`] per
    /// frame. In a time series it adds `spp` (at most [`SAMPLES_PER_FRAME`]) every frame and
    /// starts over when the scene changes.
    PathTrace { spp: u32 },
    /// Direct light + DDGI's indirect light from one probe volume, after [`DDGI_FRAMES`] frames (in
    /// a time series: frame after frame, the probes following the change at their hysteresis).
    /// `occlusion`: the contact occlusion of its indirect light (off unless the configuration is
    /// about it); `taa`: the camera's temporal anti-aliasing (on, as by default, unless the
    /// configuration is about it).
    Ddgi { name: String, volume: Box<ddgi::DdgiVolume>, occlusion: ddgi::DdgiContactOcclusion, taa: bool },
    /// DDGI's camera-following cascades instead of one volume.
    DdgiCascades { name: String, cascades: Box<ddgi::DdgiCascades> },
}

/// Frames DDGI runs before a still image is taken (the probes converge over many frames: each
/// adds a bounce, and the hysteresis smooths them).
pub const DDGI_FRAMES: u32 = 120;

/// The probe grids of the quality experiment (densities) and the irradiance map sides
/// (resolutions; the distance maps are twice as fine, as in the literature).
pub const DDGI_DENSITIES: [[u32; 3]; 3] = [[8, 4, 8], [16, 8, 16], [32, 16, 32]];

pub const DDGI_RESOLUTIONS: [u32; 3] = [4, 8, 16];

impl Config {
    /// A DDGI configuration on `scene` (its volume bounds from [`SceneFacts::gi_bounds`] unless
    /// `volume` has its own).
    pub fn ddgi(name: String, scene: &SceneFacts, volume: ddgi::DdgiVolume) -> Config {
        let bounds = volume.bounds.or(scene.gi_bounds.map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3())));
        Config::Ddgi { name, volume: Box::new(ddgi::DdgiVolume { bounds, ..volume }), occlusion: Default::default(), taa: true }
    }

    /// DDGI with `grid` (default: the published grid for `scene`), the fixed ray budget and the
    /// default settings otherwise.
    pub fn ddgi_default(scene: &SceneFacts, grid: Option<[u32; 3]>) -> Config {
        let probes = grid.unwrap_or(scene.paper_grid);
        let volume = ddgi::DdgiVolume { probe_counts: Some(probes.into()), adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() };
        Config::ddgi(format!("ddgi_{}x{}x{}", probes[0], probes[1], probes[2]), scene, volume)
    }

    /// [`Config::ddgi_default`] with adaptive ray budgets.
    pub fn ddgi_adaptive(scene: &SceneFacts, grid: Option<[u32; 3]>, adaptive: &ddgi::DdgiAdaptive) -> Config {
        let probes = grid.unwrap_or(scene.paper_grid);
        let adaptive = ddgi::DdgiAdaptive { enabled: true, ..adaptive.clone() };
        let volume = ddgi::DdgiVolume { probe_counts: Some(probes.into()), adaptive, ..Default::default() };
        Config::ddgi(format!("ddgi_{}x{}x{}_adaptive", probes[0], probes[1], probes[2]), scene, volume)
    }

    /// The quality table (every density × resolution) and the ablation of the visibility weights
    /// (none → back-face → Chebyshev → normal bias → contact occlusion), in report order.
    pub fn ddgi_experiments(scene: &SceneFacts) -> Vec<Config> {
        let mut list = Vec::new();
        for grid in DDGI_DENSITIES {
            for texels in DDGI_RESOLUTIONS {
                let volume = ddgi::DdgiVolume {
                    probe_counts: Some(grid.into()),
                    adaptive: ddgi::DdgiAdaptive::off(),
                    irradiance_texels: texels,
                    distance_texels: 2 * texels,
                    ..Default::default()
                };
                list.push(Config::ddgi(format!("ddgi_{}x{}x{}_{texels}px", grid[0], grid[1], grid[2]), scene, volume));
            }
        }
        let none = ddgi::DdgiWeights::NONE;
        let steps = [
            ("none", none),
            ("backface", ddgi::DdgiWeights { backface: true, ..none }),
            ("chebyshev", ddgi::DdgiWeights { backface: true, chebyshev: true, ..none }),
            ("normal_bias", ddgi::DdgiWeights::ALL),
        ];
        for (step, weights) in steps {
            let grid = scene.paper_grid;
            let volume =
                ddgi::DdgiVolume { probe_counts: Some(grid.into()), weights, adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() };
            list.push(Config::ddgi(format!("ddgi_weights_{step}"), scene, volume));
        }
        // The last step of the ablation: every weight, and contact occlusion of the indirect light
        // (8 rays a pixel reaching the probe spacing).
        let volume =
            ddgi::DdgiVolume { probe_counts: Some(scene.paper_grid.into()), adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() };
        if let Config::Ddgi { name, volume, .. } = Config::ddgi("ddgi_weights_contact_occlusion".into(), scene, volume) {
            list.push(Config::Ddgi { name, volume, occlusion: ddgi::DdgiContactOcclusion { rays: 8, ..Default::default() }, taa: true });
        }
        list.extend(Config::ddgi_contributions(scene));
        list
    }

    /// DDGI at the plugin's defaults ([`ddgi::DdgiVolume::default`]: the grid fitted to the box,
    /// temporal anti-aliasing on): what a new user's first render gets.
    pub fn ddgi_defaults(scene: &SceneFacts) -> Config {
        Config::ddgi("ddgi_defaults".into(), scene, ddgi::DdgiVolume::default())
    }

    /// What each default contributes, one step at a time from the published grid with the fixed
    /// budget and without temporal anti-aliasing (the defaults before them): + temporal
    /// anti-aliasing (the published grid's own row), + the grid fitted to the box (the fixed
    /// budget still), + adaptive budgets ([`Config::ddgi_defaults`], in the main list), + contact
    /// occlusion.
    pub fn ddgi_contributions(scene: &SceneFacts) -> Vec<Config> {
        let published = |name: &str, taa| match Config::ddgi_default(scene, None) {
            Config::Ddgi { volume, occlusion, .. } => Config::Ddgi { name: name.into(), volume, occlusion, taa },
            other => other,
        };
        let occluded = match Config::ddgi_defaults(scene) {
            Config::Ddgi { volume, .. } => Config::Ddgi {
                name: "ddgi_defaults_contact_occlusion".into(),
                volume,
                occlusion: ddgi::DdgiContactOcclusion { rays: 4, ..Default::default() },
                taa: true,
            },
            other => other,
        };
        let fitted = Config::ddgi(
            "ddgi_defaults_fixed_budget".into(),
            scene,
            ddgi::DdgiVolume { adaptive: ddgi::DdgiAdaptive::off(), ..Default::default() },
        );
        vec![published("ddgi_published_grid_no_taa", false), fitted, occluded]
    }
}

impl Config {
    /// The configurations of the still-image evaluation of `scene`, in report order; with
    /// `experiments`, DDGI's quality table and weight ablation too.
    pub fn still_list(scene: &SceneFacts, experiments: bool, grid: Option<[u32; 3]>, adaptive: &ddgi::DdgiAdaptive) -> Vec<Config> {
        let mut list = vec![Config::Direct];
        list.extend(PATH_TRACE_LADDER.iter().map(|&spp| Config::PathTrace { spp }));
        list.push(Config::ddgi_defaults(scene));
        list.push(Config::ddgi_default(scene, grid));
        list.push(Config::ddgi_adaptive(scene, grid, adaptive));
        if experiments {
            list.extend(Config::ddgi_experiments(scene));
        }
        list
    }

    /// The methods of the time series: each renders frame after frame and every frame is measured.
    pub fn time_series_list(scene: &SceneFacts, grid: Option<[u32; 3]>, adaptive: &ddgi::DdgiAdaptive) -> Vec<Config> {
        vec![
            Config::Direct,
            Config::PathTrace { spp: TIME_SERIES_SPP },
            Config::ddgi_default(scene, grid),
            Config::ddgi_adaptive(scene, grid, adaptive),
        ]
    }

    pub fn name(&self) -> String {
        match self {
            Config::Direct => "direct".into(),
            Config::PathTrace { spp } => format!("pathtrace_{spp}spp"),
            Config::Ddgi { name, .. } | Config::DdgiCascades { name, .. } => name.clone(),
        }
    }

    /// The method: configurations of one method form one series in the plots.
    pub fn method(&self) -> &'static str {
        match self {
            Config::Direct => "direct light",
            Config::PathTrace { .. } => "path tracer",
            Config::Ddgi { .. } | Config::DdgiCascades { .. } => "DDGI",
        }
    }

    /// Frames to render: a still image is the last of them; a time series runs them before the
    /// change, so that the method has settled.
    pub fn frames(&self) -> u32 {
        match self {
            Config::Direct => 1,
            Config::PathTrace { spp } => spp.div_ceil(self.samples_per_frame()),
            Config::Ddgi { .. } | Config::DdgiCascades { .. } => DDGI_FRAMES,
        }
    }

    fn samples_per_frame(&self) -> u32 {
        match self {
            Config::PathTrace { spp } => (*spp).clamp(1, SAMPLES_PER_FRAME),
            _ => 1,
        }
    }

    /// Sets `app` up to render this configuration (its frame script and settings); `seed` seeds
    /// the random sequences of the methods that have any. Large scenes' BLAS builds show a bar on
    /// a terminal ([`crate::progress::show_blas_builds`]).
    pub fn configure(&self, app: &mut App, seed: u32) {
        crate::progress::show_blas_builds(app);
        match self {
            Config::Direct => {}
            Config::PathTrace { .. } => {
                let settings = pathtrace::PathTraceSettings { samples_per_frame: self.samples_per_frame(), seed, ..Default::default() };
                pathtrace::use_path_tracer(app, settings);
            }
            Config::Ddgi { volume, occlusion, taa, .. } => {
                app.insert_resource(*occlusion);
                if !taa {
                    app.insert_resource(engine::render::DefaultTemporalAntiAliasing(engine::render::TemporalAntiAliasing::off()));
                }
                ddgi::use_ddgi(app, (**volume).clone(), ddgi::DdgiOutput::Full)
            }
            Config::DdgiCascades { cascades, .. } => ddgi::use_ddgi_cascades(app, (**cascades).clone(), ddgi::DdgiOutput::Full),
        }
    }
}

impl Config {
    /// This configuration for the scene placed at `origin` ([`SceneDescription::origin`]): a DDGI
    /// volume's bounds (world coordinates, from [`SceneFacts::gi_bounds`] at the origin) move with
    /// the scene.
    pub fn placed_at(self, origin: glam::DVec3) -> Config {
        match self {
            Config::Ddgi { name, volume, occlusion, taa } if origin != glam::DVec3::ZERO => {
                let shift = |p: glam::DVec3| p + origin;
                let bounds = volume.bounds.map(|(lo, hi)| (shift(lo), shift(hi)));
                Config::Ddgi { name, volume: Box::new(ddgi::DdgiVolume { bounds, ..*volume }), occlusion, taa }
            }
            other => other,
        }
    }

    /// This configuration with `rays` hit occlusion rays of `reach`
    /// ([`ddgi::DdgiVolume::hit_occlusion_rays`], [`ddgi::DdgiVolume::hit_occlusion_reach`]) if it
    /// is a DDGI volume.
    pub fn with_hit_occlusion(self, rays: u32, reach: f32) -> Config {
        match self {
            Config::Ddgi { name, volume, occlusion, taa } => Config::Ddgi {
                name,
                volume: Box::new(ddgi::DdgiVolume { hit_occlusion_rays: rays, hit_occlusion_reach: reach, ..*volume }),
                occlusion,
                taa,
            },
            other => other,
        }
    }

    /// The configurations of `list` for `scene` (placed where it is), with `cascades` added. A DDGI
    /// volume without a grid of its own is the scene-fitted default, and follows its rule
    /// ([`ddgi::DdgiLighting::fitted`], over the volume's bounds or the scene's): over a large
    /// scene it becomes cascades, under the same name.
    pub fn for_scene(list: Vec<Config>, scene: &SceneDescription, cascades: Option<&ddgi::DdgiCascades>) -> Vec<Config> {
        let scene_box = scene.bounds().map(|(lo, hi)| (lo.as_dvec3(), hi.as_dvec3()));
        list.into_iter()
            .map(|c| match (c, scene_box) {
                (Config::Ddgi { name, volume, occlusion, taa }, Some(b)) if volume.probe_counts.is_none() => {
                    match ddgi::DdgiLighting::Fitted((*volume).clone()).resolve(b) {
                        ddgi::DdgiLighting::Cascades(c) => Config::DdgiCascades { name, cascades: Box::new(c) },
                        _ => Config::Ddgi { name, volume, occlusion, taa },
                    }
                }
                (c, _) => c,
            })
            .chain(cascades.map(Config::ddgi_cascades))
            .map(|c| c.placed_at(scene.origin))
            .collect()
    }

    /// The cascaded configuration of `cascades`, named by its count and grid.
    pub fn ddgi_cascades(cascades: &ddgi::DdgiCascades) -> Config {
        let (n, c) = (cascades.count.unwrap_or(0), cascades.probe_counts);
        let name = format!("ddgi_cascades_{n}x{}x{}x{}", c.x, c.y, c.z);
        Config::DdgiCascades { name, cascades: Box::new(cascades.clone()) }
    }
}

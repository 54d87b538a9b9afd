//! What the evaluation knows of a scene beyond its description ([`SceneFacts`]), and the
//! built-in scenes by name ([`built_in_scene`]).

use engine::glam::Vec3;
use engine::scene::SceneDescription;

use super::time_series::SceneChange;

/// The probe grid of the published experiment on each built-in scene (Hvezda and Bittner), as its
/// entry gives it ([`scenes::SceneEntry::paper_grid`], [`scenes::files::SceneFile::paper_grid`]):
/// 16×8×16 for the door room, 16×16×15 for the room under a skylight, 2×2×2 for the colour
/// bleeding box, 16×8×12 for Šibenik (`sibenik`, and its stand-in `cathedral`); 8×8×8 elsewhere.
pub fn ddgi_paper_grid(scene: &str) -> [u32; 3] {
    let entry = scenes::find(scene).and_then(|entry| entry.paper_grid);
    entry.or_else(|| scenes::files::find(scene).and_then(|file| file.paper_grid)).unwrap_or([8, 8, 8])
}

/// What the evaluation knows of a scene beyond its description: its name, the probe grid and the
/// box of its DDGI configurations, and the change of its time series. [`SceneFacts::named`] gives
/// a built-in scene's (or a scene file's); an application describes its own scenes (the demo its
/// level) with their own values.
#[derive(Clone, Debug)]
pub struct SceneFacts {
    /// The scene's name: in reports, reference cache keys and output names.
    pub name: String,
    /// The probe grid of the DDGI configurations ([`ddgi_paper_grid`] for the built-in scenes).
    pub paper_grid: [u32; 3],
    /// The box DDGI's probes fill; `None`: the bounds of the scene's instances.
    pub gi_bounds: Option<(Vec3, Vec3)>,
    /// The time series' change, prepared in the scene; `None`: the built-in change for the scene's
    /// name ([`super::time_series::scene_change`]).
    pub change: Option<PrepareChange>,
}

/// Prepares a time series' change in a scene (it may add the node that changes, or move the
/// camera to where the change shows).
pub type PrepareChange = fn(&mut SceneDescription) -> Result<SceneChange, String>;

/// A built-in scene by name: one of [`scenes::ALL`], a scene file of the shared folder
/// ([`scenes::files::FILES`]: an error when it is absent) or the demo level
/// ([`scenes::level::NAME`]); `None` for any other name.
pub fn built_in_scene(name: &str) -> Option<Result<SceneDescription, String>> {
    if let Some(entry) = scenes::find(name) {
        return Some(Ok((entry.build)()));
    }
    if let Some(loaded) = scenes::files::load(name) {
        return Some(loaded);
    }
    (name == scenes::level::NAME).then(|| Ok(scenes::level::scene()))
}

/// The names [`built_in_scene`] knows: [`scenes::names`], the shared scene files, then the demo
/// level's.
pub fn built_in_scene_names() -> impl Iterator<Item = &'static str> {
    scenes::names().chain(scenes::files::FILES.iter().map(|f| f.name)).chain([scenes::level::NAME])
}

impl SceneFacts {
    /// The facts of the built-in scene `name` (its published grid and its own GI box), of the demo
    /// level ([`scenes::level::NAME`]: `play`'s grid and box, its change left to the demo), or of a
    /// scene file (8×8×8 probes over its instances' bounds, the first light moves).
    pub fn named(name: &str) -> SceneFacts {
        if name == scenes::level::NAME {
            let (paper_grid, gi_bounds) = (scenes::level::probe_counts().to_array(), Some(scenes::level::level_gi_bounds()));
            return SceneFacts { name: name.into(), paper_grid, gi_bounds, change: None };
        }
        SceneFacts {
            name: name.into(),
            paper_grid: ddgi_paper_grid(name),
            gi_bounds: scenes::find(name).and_then(|entry| (entry.gi_bounds)()),
            change: None,
        }
    }
}

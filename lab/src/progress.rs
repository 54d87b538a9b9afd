//! Progress bars on standard error for every job that can take more than a few seconds: reference
//! renders, each evaluation configuration, time series, benchmark tables, soaks, long BLAS builds.
//! indicatif draws them only when standard error is a terminal, so logs and tests see nothing of
//! them.

use std::sync::Mutex;
use std::time::{Duration, Instant};

use engine::rt::BlasBuildHook;
use indicatif::{ProgressBar, ProgressStyle};

/// A bar of `len` steps named `what` (e.g. `"cornell: reference 4096 spp"`), counting `unit`s
/// (`"frames"`, `"cells"`).
pub fn bar(len: u64, what: impl Into<String>, unit: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    let template = format!("{{prefix:>28}} {{bar:32}} {{pos}}/{{len}} {unit}, {{elapsed}} elapsed, {{eta}} left");
    bar.set_style(ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()));
    bar.set_prefix(what.into());
    bar
}

/// Advances `bar` by one at the end of every frame of `app` (a system in `Last`).
pub fn tick_every_frame(app: &mut engine::bevy_app::App, bar: &ProgressBar) {
    let bar = bar.clone();
    app.add_systems(engine::bevy_app::Last, move || bar.inc(1));
}

/// Requested BLAS builds of at least this many triangles show their bar from the start; smaller
/// batches show it only once they have run for [`BLAS_BAR_AFTER`] (a few meshes build in a blink).
pub const BLAS_BAR_TRIANGLES: usize = 2_000_000;

/// How long a batch of BLAS builds runs before its bar appears, whatever its size.
pub const BLAS_BAR_AFTER: Duration = Duration::from_secs(1);

/// Shows the BLAS builds of `app`'s scene as a bar of triangles built (through the engine's
/// [`BlasBuildHook`]) when they take long: a batch of [`BLAS_BAR_TRIANGLES`] or more, or one still
/// running after [`BLAS_BAR_AFTER`]. The bar is cleared once the batch is built; a later batch (a
/// level streamed in) gets its own.
pub fn show_blas_builds(app: &mut engine::bevy_app::App) {
    let state: Mutex<Option<(Instant, Option<ProgressBar>)>> = Mutex::new(None);
    app.insert_resource(BlasBuildHook::new(move |counts| {
        let mut state = state.lock().unwrap_or_else(|e| e.into_inner());
        let (started, bar) = state.get_or_insert_with(|| (Instant::now(), None));
        if bar.is_none() && (counts.total_triangles - counts.built_triangles >= BLAS_BAR_TRIANGLES || started.elapsed() >= BLAS_BAR_AFTER) {
            let new = self::bar(counts.total_triangles as u64, "BLAS builds", "triangles");
            new.enable_steady_tick(Duration::from_millis(250));
            *bar = Some(new);
        }
        if let Some(bar) = bar {
            bar.set_length(counts.total_triangles as u64);
            bar.set_position(counts.built_triangles as u64);
        }
        if counts.is_done() {
            if let Some(bar) = bar {
                bar.finish_and_clear();
            }
            *state = None;
        }
    }));
}

#[cfg(test)]
mod tests {
    /// A bar counts what it is told, whatever it draws.
    #[test]
    fn a_bar_counts_its_steps() {
        let bar = super::bar(10, "test", "frames");
        bar.inc(3);
        bar.inc(4);
        assert_eq!((bar.position(), bar.length()), (7, Some(10)));
        bar.finish_and_clear();
    }
}

//! Progress bars on standard error for every job that can take more than a few seconds: reference
//! renders, each evaluation configuration, time series, benchmark tables, soaks. indicatif draws
//! them only when standard error is a terminal, so logs and tests see nothing of them.

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

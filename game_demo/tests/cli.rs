//! `game_demo`'s command line: bad options are rejected, naming the option.

use std::process::Command;

#[test]
fn eval_rejects_bad_time_series_options_by_name() {
    let dir = std::env::temp_dir();
    for (args, expected) in [
        (&["eval", "--time-series", "--frames", "0"][..], "--frames"),
        (&["eval", "--frames", "5"][..], "--time-series"),
        (&["eval", "--reference-spp", "0"][..], "--reference-spp"),
        (&["eval", "--rest-smoothing", "often"][..], "--rest-smoothing"),
        (&["eval", "--rest-smoothing", "1.5"][..], "adaptive.rest_smoothing"),
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_game_demo"))
            .args(args)
            .arg("--out")
            .arg(&dir)
            .arg("--cache")
            .arg(&dir)
            .output()
            .expect("run game_demo");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success() && stderr.contains(expected), "{args:?}: {stderr}");
    }
}

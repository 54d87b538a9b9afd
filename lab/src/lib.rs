//! Evaluation tooling, apart from the engine and its plugins (which build without it):
//!
//! - [`metrics`]: error of an image against a reference (FLIP with nv-flip, RMSE, relative MSE) and
//!   FLIP error maps;
//! - [`eval`]: error against a path-traced reference and GPU time for a list of configurations, and
//!   the time series after a change in the scene ([`eval::time_series`]);
//! - [`bench`]: ray-tracing and DDGI throughput, TLAS update costs, DDGI's classification check;
//! - [`plot`]: the evaluation's plots (plotters, with an embedded font);
//! - [`progress`]: progress bars of the long jobs;
//! - [`soak`]: judging a soak run (non-finite values, memory growth, frame-time drift) and its CSV;
//! - [`walk`]: DDGI's GPU time frame by frame while the camera walks the open world.

pub mod bench;
pub mod eval;
pub mod metrics;
pub mod plot;
pub mod progress;
pub mod soak;
pub mod walk;

/// The median of `values` (the upper one of an even count; sorts them), or `None` when empty.
pub fn median(values: &mut [f64]) -> Option<f64> {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied()
}

/// Three whole numbers `x,y,z` (a probe grid, a cell count), optionally in brackets: `[x,y,z]`.
pub fn parse_uvec3(text: &str) -> Result<engine::glam::UVec3, String> {
    let v: Vec<u32> = text
        .trim()
        .trim_start_matches('[')
        .trim_end_matches(']')
        .split(',')
        .map(|p| p.trim().parse::<u32>().map_err(|e| format!("'{p}': {e}")))
        .collect::<Result<_, _>>()?;
    match v[..] {
        [x, y, z] => Ok(engine::glam::UVec3::new(x, y, z)),
        _ => Err(format!("expected three whole numbers x,y,z, got '{text}'")),
    }
}

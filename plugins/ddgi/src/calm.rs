//! Volume-level update periods in calm phases ([`crate::DdgiAdaptive::max_update_period`]): the
//! CPU leaves a volume's whole probe update out of some frames while the probe data read back says
//! it is calm, and drops back to every frame at once when anything it can see changes.

use std::collections::VecDeque;

use crate::gpu::{DdgiProbeData, PROBE_FRESH, PROBE_INACTIVE};
use crate::volume::{CALM_UPDATES, DdgiAdaptive};

/// The largest share of a calm volume's active probes that may be fresh. A still scene's re-checks
/// (every `recheck_interval` frames) switch a few dark probes back on, fresh, and classification
/// switches them off again: that is the steady state, not a change. A volume that starts or whose
/// probes restart in numbers is not calm.
pub const CALM_FRESH: f64 = 0.125;

/// One volume's calm-phase update period and what decides it.
#[derive(Clone, Debug)]
pub struct DdgiCalm {
    /// The current period, in the volume's scheduled updates (frames for a volume whose
    /// [`crate::DdgiVolume::update_period`] is 1): 1 updates at each, 2 at every other, …
    pub period: u32,
    /// Scheduled updates left out since the last update.
    pub skipped: u32,
    /// Calm updates in a row at the current period.
    pub calm_updates: u32,
    /// The frame of the last drop to period 1 (a change): data read back from earlier frames is
    /// not judged.
    pub reset_frame: u64,
    /// The last update frame whose probe data was judged.
    judged: Option<u64>,
    /// Recent frames that updated, oldest first (to find the update a readback reflects).
    update_frames: VecDeque<u64>,
    /// Frames of this volume not yet reported to the frame timings: `(frame, updated, frames
    /// between updates at that frame)`.
    pub(crate) unreported: Vec<(u64, bool, u32)>,
    /// Whether this frame is one of the volume's scheduled updates (its `update_period` falls on it).
    pub(crate) scheduled: bool,
}

impl Default for DdgiCalm {
    fn default() -> Self {
        Self {
            period: 1,
            skipped: 0,
            calm_updates: 0,
            reset_frame: 0,
            judged: None,
            update_frames: VecDeque::new(),
            unreported: Vec::new(),
            scheduled: true,
        }
    }
}

/// What the probe data read back after an update says: whether it was calm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalmJudgement {
    /// Active probes that are not fresh.
    pub settled: u32,
    /// Active probes still fresh (their maps restart).
    pub fresh: u32,
    /// Mean temporal error of the settled active probes: the smaller of the means of their
    /// errors and, with `rest_smoothing`, of their settled errors.
    pub mean_error: f32,
    /// Mean of the settled active probes' errors ([`DdgiProbeData::error`]).
    pub mean_fast_error: f32,
    /// Mean of their settled errors ([`DdgiProbeData::settled_error`]).
    pub mean_settled_error: f32,
    /// Whether the update was calm: at most [`CALM_FRESH`] of the active probes fresh, and the
    /// mean error of the others under `calm_error` × `error_target` ([`DdgiAdaptive::calm_error`]).
    pub calm: bool,
}

/// Judges probe data read back after an update ([`DdgiCalm`]).
pub fn judge(probes: &[DdgiProbeData], adaptive: &DdgiAdaptive) -> CalmJudgement {
    let finite = |e: f32| if e.is_finite() { f64::from(e.max(0.0)) } else { f64::INFINITY };
    let (mut settled, mut fresh, mut sum, mut sum_settled) = (0u32, 0u32, 0.0f64, 0.0f64);
    for p in probes.iter().filter(|p| p.state & PROBE_INACTIVE == 0) {
        if p.state & PROBE_FRESH != 0 {
            fresh += 1;
        } else {
            settled += 1;
            sum += finite(p.error);
            sum_settled += finite(p.settled_error);
        }
    }
    let mean = |sum: f64| if settled > 0 { (sum / f64::from(settled)) as f32 } else { 0.0 };
    let (mean_fast_error, mean_settled_error) = (mean(sum), mean(sum_settled));
    // With `rest_smoothing`, the slower settled error is a second, less noisy reading of the same
    // change: the volume is as calm as the lower of the two means says.
    let mean_error = if adaptive.rest_smoothing.is_some() { mean_fast_error.min(mean_settled_error) } else { mean_fast_error };
    let calm = f64::from(fresh) <= CALM_FRESH * f64::from(settled + fresh) && mean_error <= adaptive.calm_error * adaptive.error_target;
    CalmJudgement { settled, fresh, mean_error, mean_fast_error, mean_settled_error, calm }
}

impl DdgiCalm {
    /// Whether calm periods apply to a volume with these settings.
    pub fn applies(adaptive: &DdgiAdaptive) -> bool {
        adaptive.enabled && adaptive.max_update_period > 1
    }

    /// Something the CPU saw change at `frame`: back to updating at every scheduled update.
    pub fn reset(&mut self, frame: u64) {
        self.period = 1;
        self.skipped = 0;
        self.calm_updates = 0;
        self.reset_frame = frame;
    }

    /// Something changed between frames (a pin, a pause): back to period 1 from the next frame.
    pub fn reset_next(&mut self) {
        let next = self.update_frames.back().map_or(self.reset_frame, |f| f + 1).max(self.reset_frame);
        self.reset(next);
    }

    /// Whether the calm period lets the next scheduled update run.
    pub fn due(&self) -> bool {
        self.skipped + 1 >= self.period
    }

    /// After the frame's graph: records whether `frame` updated (`frames_between` is the volume's
    /// current number of frames between updates, reported with it).
    pub(crate) fn finish_frame(&mut self, frame: u64, updated: bool, frames_between: u32) {
        if updated {
            self.skipped = 0;
            self.update_frames.push_back(frame);
            while self.update_frames.len() > 64 {
                self.update_frames.pop_front();
            }
        } else if self.scheduled {
            self.skipped += 1;
        }
        self.unreported.push((frame, updated, frames_between));
        if self.unreported.len() > 256 {
            self.unreported.remove(0);
        }
    }

    /// Probe data of `frame` has come back: judges the last update it reflects, once (unless it
    /// is older than the last change), and moves the period: doubled (up to `max_update_period`)
    /// after [`CALM_UPDATES`] calm updates in a row, back to 1 at one that is not calm. Returns the
    /// judgement, when one was made.
    pub fn observe(&mut self, frame: u64, probes: &[DdgiProbeData], adaptive: &DdgiAdaptive) -> Option<CalmJudgement> {
        let update = self.update_frames.iter().rev().find(|&&f| f <= frame).copied()?;
        while self.update_frames.front().is_some_and(|&f| f < update) {
            self.update_frames.pop_front();
        }
        if update < self.reset_frame || self.judged.is_some_and(|j| j >= update) {
            return None;
        }
        self.judged = Some(update);
        let judgement = judge(probes, adaptive);
        log::debug!("DDGI calm judgement of the update of frame {update}: {judgement:?}, period {}", self.period);
        if !Self::applies(adaptive) {
            self.period = 1;
            return Some(judgement);
        }
        if judgement.calm {
            self.calm_updates += 1;
            if self.calm_updates >= CALM_UPDATES && self.period < adaptive.max_update_period {
                self.period = (self.period * 2).min(adaptive.max_update_period);
                self.calm_updates = 0;
            }
        } else {
            self.period = 1;
            self.calm_updates = 0;
        }
        self.period = self.period.min(adaptive.max_update_period.max(1));
        Some(judgement)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn probe(state: u32, error: f32) -> DdgiProbeData {
        DdgiProbeData { state, error, settled_error: error, ..DdgiProbeData::NEW }
    }

    #[test]
    fn calm_updates_double_the_period_and_a_busy_one_drops_it() {
        let adaptive = DdgiAdaptive { max_update_period: 4, ..Default::default() };
        let quiet = vec![probe(0, 0.01), probe(0, 0.02), probe(PROBE_INACTIVE, 9.0)];
        let busy = vec![probe(0, 0.2), probe(0, 0.02)];
        let mut calm = DdgiCalm::default();
        let mut frame = 0;
        let mut update = |calm: &mut DdgiCalm, probes: &[DdgiProbeData]| {
            calm.finish_frame(frame, true, 1);
            let j = calm.observe(frame, probes, &adaptive).expect("an update is judged");
            frame += 1;
            j
        };
        for _ in 0..CALM_UPDATES - 1 {
            assert!(update(&mut calm, &quiet).calm);
            assert_eq!(calm.period, 1);
        }
        update(&mut calm, &quiet);
        assert_eq!(calm.period, 2);
        for _ in 0..3 * CALM_UPDATES {
            update(&mut calm, &quiet);
        }
        assert_eq!(calm.period, 4, "held to max_update_period");
        let j = update(&mut calm, &busy);
        assert!(!j.calm && (j.mean_error - 0.11).abs() < 1e-6, "{j:?}");
        assert_eq!(calm.period, 1);
        // Fresh active probes beyond an eighth are not calm; inactive ones do not count.
        assert!(!judge(&[probe(PROBE_FRESH, 0.0)], &adaptive).calm);
        let mut few = vec![probe(0, 0.0); 8];
        few.push(probe(PROBE_FRESH, 0.0));
        assert!(judge(&few, &adaptive).calm);
        few.push(probe(PROBE_FRESH, 0.0));
        assert!(!judge(&few, &adaptive).calm);
        assert!(judge(&[probe(PROBE_INACTIVE | PROBE_FRESH, 0.0)], &adaptive).calm);
        assert!(!judge(&[probe(0, f32::NAN)], &adaptive).calm);
    }

    #[test]
    fn the_settled_error_can_make_a_noisy_volume_calm() {
        // Noise keeps every probe's error over the calm level (0.5 × 0.1); the slower settled
        // error of most of them is under it.
        let noisy = |error: f32, settled_error: f32| DdgiProbeData { state: 0, error, settled_error, ..DdgiProbeData::NEW };
        let probes = vec![noisy(0.07, 0.03), noisy(0.06, 0.04), noisy(0.08, 0.06)];
        let with_settled = DdgiAdaptive::default();
        let j = judge(&probes, &with_settled);
        assert!(j.calm, "{j:?}");
        assert!((j.mean_fast_error - 0.07).abs() < 1e-6 && (j.mean_settled_error - 0.043_333).abs() < 1e-5, "{j:?}");
        assert_eq!(j.mean_error, j.mean_settled_error);
        // Without rest_smoothing the settled error is not kept: the error alone decides.
        let without = DdgiAdaptive { rest_smoothing: None, ..Default::default() };
        let j = judge(&probes, &without);
        assert!(!j.calm && j.mean_error == j.mean_fast_error, "{j:?}");
        // The smaller mean decides either way: an error under the level is calm whatever the
        // settled error, and a settled error that is not finite does not make a volume busy.
        let quick = vec![noisy(0.02, 0.2), noisy(0.03, f32::INFINITY)];
        assert!(judge(&quick, &with_settled).calm);
        // A change the settled error has not caught up with yet: both means over the level.
        let changed = vec![noisy(0.3, 0.06), noisy(0.2, 0.07)];
        assert!(!judge(&changed, &with_settled).calm);
    }

    #[test]
    fn a_readback_is_judged_once_and_not_from_before_a_change() {
        let adaptive = DdgiAdaptive::default();
        let quiet = vec![probe(0, 0.0)];
        let mut calm = DdgiCalm { period: 2, ..Default::default() };
        calm.finish_frame(10, true, 2);
        calm.scheduled = true;
        calm.finish_frame(11, false, 2);
        assert_eq!(calm.skipped, 1);
        assert!(calm.due());
        // Frame 11 skipped: its data reflects the update of frame 10, judged once.
        assert!(calm.observe(11, &quiet, &adaptive).is_some());
        assert!(calm.observe(11, &quiet, &adaptive).is_none());
        calm.reset(12);
        assert_eq!((calm.period, calm.skipped), (1, 0));
        calm.finish_frame(12, true, 1);
        // Data of frame 10 arriving late (before the change) is not judged; frame 12's is.
        assert!(calm.observe(10, &quiet, &adaptive).is_none());
        assert!(calm.observe(12, &quiet, &adaptive).is_some());
    }
}

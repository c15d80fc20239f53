//! Stage 1 of the reductions: the running accumulators an engine keeps over the steps after
//! the transient (α range, hops, impacts, power), turned into results by [`Tally::result`].

use super::InstanceResult;
use crate::config::Metric;
use crate::model::Status;

/// The running accumulators of one instance after the transient, as either engine keeps them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tally {
    /// How the integration ended.
    pub status: Status,
    /// Steps taken.
    pub steps: u64,
    /// Smallest and largest α (rad).
    pub alpha_range_rad: (f64, f64),
    /// Hops between the wells.
    pub hops: u32,
    /// Bumper contact onsets.
    pub impacts: u32,
    /// Σ v²/R_L over the steps (W).
    pub power_sum_w: f64,
}

/// What a tally was accumulated over: the time and steps after the transient.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// Simulated time after the transient (s).
    pub seconds: f64,
    /// Steps after the transient.
    pub steps: u64,
}

impl Tally {
    /// The accumulator-based metrics (everything but K, R and period), NaN when not requested
    /// or when the instance failed; K, R and period NaN until `reduce_series` fills them.
    pub fn result(&self, span: Span, metrics: &[Metric]) -> InstanceResult {
        let mut out = InstanceResult::unset(self.status, self.steps);
        if self.status != Status::Ok {
            return out;
        }
        let wants = |m: Metric| metrics.contains(&m);
        if wants(Metric::Hops) {
            out.hops = f64::from(self.hops);
        }
        if wants(Metric::ImpactsPerS) {
            out.impacts_per_s = f64::from(self.impacts) / span.seconds;
        }
        if wants(Metric::AlphaRange) {
            (out.alpha_min_rad, out.alpha_max_rad) = self.alpha_range_rad;
        }
        if wants(Metric::Power) {
            out.power_w = self.power_sum_w / span.steps as f64;
        }
        out
    }
}

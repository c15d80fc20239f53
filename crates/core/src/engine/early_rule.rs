//! The early stop's rule (`docs/analysis.md`, "Early stop"): which orbits count as confirmed
//! (longest period, window, tolerance by float type) and when λ1 lets a confirmed orbit stop.
//! What a plan carries; [`super::early`] tracks it through a run.

use crate::model::Real;
use crate::reduce::Lyapunov;
use crate::reduce::lyapunov::LYAPUNOV_BLOCK_COUNT;
use crate::reduce::regime::{CLASS_SHRINKING, lambda_class};
use crate::rules::{Float, abs, max, min, shared_rules};
use serde::Serialize;

/// Early termination of instances whose periodic orbit is confirmed (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EarlyStop {
    /// Longest orbit period tried (forcing periods).
    pub p_max: u32,
    /// Trailing stroboscopic instants that must repeat.
    pub window: u32,
    /// Relative tolerance of the repetition (`None`: [`EARLY_TOL_F64`] or [`EARLY_TOL_F32`] by
    /// the float type integrating).
    pub tol: Option<f64>,
}

/// The default tolerance of the confirmation in f64.
pub const EARLY_TOL_F64: f64 = 1e-5;

/// The default tolerance in f32: a settled impacting orbit on the GPU engine repeats only to a
/// few 1e-5 (at 4 Hz, 4 mm it confirmed period 4 at 3e-5 and none at 1e-5, period 2 at 1e-4).
pub const EARLY_TOL_F32: f64 = 1e-4;

impl EarlyStop {
    /// The map's default rule (`map.period_max`, `map.period_window`, tolerance by float type):
    /// what `search` and `calibrate` use.
    pub const DEFAULT: EarlyStop = EarlyStop {
        p_max: 8,
        window: 16,
        tol: None,
    };

    /// The tolerance in the float type `T` (f32 or f64).
    pub(crate) fn tol_in<T: Real>(&self) -> f64 {
        self.tol.unwrap_or(if T::NAME == "f32" {
            EARLY_TOL_F32
        } else {
            EARLY_TOL_F64
        })
    }
}

/// The largest standard error of λ1, relative to |λ1|, with which a confirmed orbit stops.
/// A settled orbit's growths repeat every cycle only where its contacts fall on the same steps
/// (the period-2 orbit at 4 Hz, 4 mm, N = 3, over its first 16 periods after confirmation:
/// σ/|λ1| 12 % on the CPU in f64, 42 % on the GPU in f32, where a full 30-s window gives 4 %);
/// a stopped cell's λ1 is then known about as well as the full run's.
pub const EARLY_LYAPUNOV_REL_SE: f64 = 0.1;

shared_rules! {
    /// Renormalisations λ1 first measures on a confirmed orbit of period p: a block
    /// (LYAPUNOV_BLOCK_COUNT of them) of at least one cycle and two periods each.
    pub fn early_twin_window(p: u32) -> u32 {
        return LYAPUNOV_BLOCK_COUNT * max(p, 2);
    }

    /// The latest instant at or before `last` a whole number of cycles `cycle` before s (s
    /// itself where s <= last): where a stopped orbit's run finds instant s once it repeats
    /// the cycle that ended at `last` (EarlyTracker::continue_orbit, for its periods, its
    /// stroboscopic samples and its R series).
    pub(crate) fn cycle_copy(s: u32, last: u32, cycle: u32) -> u32 {
        if s <= last {
            return s;
        }
        let gap = s - last;
        let back = gap / cycle + min(gap % cycle, 1);
        return s - back * cycle;
    }

    /// Whether two values of a stroboscopic instant and of the one `p` periods before count as
    /// the same: |a − b| ≤ tol · max(|a|, 1).
    pub(crate) fn early_close(a: Float, b: Float, tol: Float) -> bool {
        return abs(a - b) <= tol * max(abs(a), 1.0);
    }

    /// Whether λ1 (`per_s`, 1/s, standard error `se_per_s`) measured on a confirmed orbit of
    /// forcing period `period_s` lets it stop: shrinking per period and within
    /// EARLY_LYAPUNOV_REL_SE of itself.
    pub(crate) fn early_lyapunov_stops_at(per_s: Float, se_per_s: Float, period_s: Float) -> bool {
        let growth = lambda_class(per_s * period_s, se_per_s * period_s);
        return growth == CLASS_SHRINKING && se_per_s <= EARLY_LYAPUNOV_REL_SE * abs(per_s);
    }
}

/// Whether λ1 measured on a confirmed orbit (forcing period `period_s`) lets it stop: shrinking
/// and within [`EARLY_LYAPUNOV_REL_SE`] of itself (the shared rule `early_lyapunov_stops_at`).
pub fn early_lyapunov_stops(l: &Lyapunov, period_s: f64) -> bool {
    early_lyapunov_stops_at(l.per_s, l.se_per_s, period_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `cycle_copy` is each of the three forms the continuation wrote before it: the periods'
    /// `P − p + (q − P) mod p`, and the strobe's and the R series' `s − ⌈(s − last)/c⌉ c`.
    #[test]
    fn cycle_copy_is_the_continuations_three_former_forms() {
        for p in 1..=9u32 {
            for big_p in p..40 {
                for q in big_p..big_p + 30 {
                    assert_eq!(cycle_copy(q, big_p - 1, p), big_p - p + (q - big_p) % p);
                }
            }
            for last in [0u32, 5, 64, 1000] {
                for s in last + 1..last + 50 {
                    let c = 7 * p;
                    assert_eq!(cycle_copy(s, last, p), s - (s - last).div_ceil(p) * p);
                    assert_eq!(cycle_copy(s, last, c), s - (s - last).div_ceil(c) * c);
                }
            }
        }
        // No overflow where the former forms' s − last + c − 1 passed u32::MAX.
        assert_eq!(cycle_copy(u32::MAX, u32::MAX - 10, 100), u32::MAX - 100);
        assert_eq!(cycle_copy(3, 7, 2), 3);
    }

    #[test]
    fn the_twin_window_on_an_orbit_is_a_block_of_at_least_two_periods() {
        assert_eq!(early_twin_window(1), 16);
        assert_eq!(early_twin_window(2), 16);
        assert_eq!(early_twin_window(5), 40);
    }
}

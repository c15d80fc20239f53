//! The early stop's rule (`docs/analysis.md`, "Early stop"): which orbits count as confirmed
//! (longest period, window, tolerance by float type) and when λ1 lets a confirmed orbit stop.
//! What a plan carries; [`super::early`] tracks it through a run.

use crate::model::Real;
use crate::reduce::LYAPUNOV_BLOCKS;
use crate::reduce::Lyapunov;
use crate::reduce::regime::{CLASS_SHRINKING, lambda_class};
use crate::rules::{Float, abs, max, shared_rules};
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

/// Renormalisations λ1 first measures on a confirmed orbit of period `p`: 8 blocks of at least
/// one cycle (and two periods) each.
pub fn early_twin_window(p: u32) -> u32 {
    LYAPUNOV_BLOCKS as u32 * p.max(2)
}

/// The largest standard error of λ1, relative to |λ1|, with which a confirmed orbit stops.
/// A settled orbit's growths repeat every cycle only where its contacts fall on the same steps
/// (the period-2 orbit at 4 Hz, 4 mm, N = 3, over its first 16 periods after confirmation:
/// σ/|λ1| 12 % on the CPU in f64, 42 % on the GPU in f32, where a full 30-s window gives 4 %);
/// a stopped cell's λ1 is then known about as well as the full run's.
pub const EARLY_LYAPUNOV_REL_SE: f64 = 0.1;

shared_rules! {
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

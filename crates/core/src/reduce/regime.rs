//! Stage 4 of the reductions: one verdict per cell from λ1, the period detector and K
//! (`docs/analysis.md`, "Regime").
//!
//! λ1 is read per forcing period, `Λ = λ1 T` with its standard error `σ = SE(λ1) T`, and
//! placed in one of three classes, each only when its whole interval `Λ ± zσ` lies inside:
//!
//! ```text
//! growing     Λ − zσ >  ε            (separations grow: chaos)
//! flat        |Λ| + zσ ≤ ε           (neither: a torus, or a bifurcation point)
//! shrinking   Λ + zσ < −ε            (every separation dies: a stable orbit)
//! ```
//!
//! K is firm when it comes from at least [`ZERO_ONE_COMFORTABLE_SAMPLES`] stroboscopic samples;
//! on fewer, a periodic orbit can read K ≥ 0.5 and a chaotic one K ≈ 0 (`docs/analysis.md`, §2),
//! so a K that is not firm cannot contradict λ1. The verdict (first rule that applies):
//!
//! | status | period p | λ1 class | K | verdict |
//! |---|---|---|---|---|
//! | not ok | | | | failed |
//! | ok | p > 0 | shrinking | any | periodic |
//! | ok | p = 0 | growing | ≥ K_chaos, or not firm | chaotic |
//! | ok | p = 0 | shrinking | any | regular (an orbit longer than `period_max`, or still settling) |
//! | ok | p = 0 | flat | < K_chaos, or not firm | regular (quasi-periodic) |
//! | ok | anything else | | | undecided |
//!
//! "Anything else" is where the indicators disagree beyond their uncertainty (a period with a
//! growing or flat λ1; growth with a firm low K; a flat λ1 with a firm high K) or λ1 itself is
//! not resolved (its interval straddles ±ε). A cell is never periodic and chaotic at once: the
//! period and λ1's class decide both.
//!
//! **Confidence** of a decided cell: `Φ(m/σ)`, the probability under a normal error of λ1 that
//! Λ lies on the verdict's side of its class boundary, `m` the distance of Λ from that boundary
//! (`Λ − ε` growing, `−ε − Λ` shrinking, `ε − |Λ|` flat); 1 when σ is 0 (a settled orbit
//! repeats its growth exactly). Undecided and failed cells have none (NaN).

use crate::analysis::ZERO_ONE_COMFORTABLE_SAMPLES;
use crate::rules::{Float, abs, is_finite, shared_rules};
use serde::Serialize;

/// z of the class intervals `Λ ± zσ`.
pub const REGIME_Z: f64 = 2.0;

/// ε: the largest |λ1 T| (per forcing period) read as zero.
pub const REGIME_FLAT_PER_PERIOD: f64 = 0.01;

/// The K from which a growing λ1 is confirmed as chaos (and a flat one is not a torus).
pub const REGIME_K_CHAOS: f64 = 0.5;

pub use crate::schema::Regime;

/// The fewest stroboscopic samples a firm K comes from ([`ZERO_ONE_COMFORTABLE_SAMPLES`]), as
/// the rules count.
pub(crate) const K_FIRM_SAMPLES: u32 = ZERO_ONE_COMFORTABLE_SAMPLES as u32;

/// The codes of the classes of λ1 ([`lambda_class`]).
pub(crate) const CLASS_UNRESOLVED: u32 = 0;
/// Growing: `Λ − zσ > ε`.
pub(crate) const CLASS_GROWING: u32 = 1;
/// Flat: `|Λ| + zσ ≤ ε`.
pub(crate) const CLASS_FLAT: u32 = 2;
/// Shrinking: `Λ + zσ < −ε`.
pub(crate) const CLASS_SHRINKING: u32 = 3;

/// The regimes' codes, as the rules return them ([`Regime::code`]).
const REGIME_UNDECIDED: i32 = Regime::Undecided.code() as i32;
const REGIME_PERIODIC: i32 = Regime::Periodic.code() as i32;
const REGIME_REGULAR: i32 = Regime::Regular.code() as i32;
const REGIME_CHAOTIC: i32 = Regime::Chaotic.code() as i32;

shared_rules! {
    /// The class of λ1 per period, Λ with standard error σ: growing, flat or shrinking where
    /// the whole interval Λ ± zσ lies inside the class, else unresolved (so too for a Λ or σ
    /// that is not finite).
    pub(crate) fn lambda_class(lambda: Float, sigma: Float) -> u32 {
        if !(is_finite(lambda) && is_finite(sigma)) {
            return CLASS_UNRESOLVED;
        } else if lambda - REGIME_Z * sigma > REGIME_FLAT_PER_PERIOD {
            return CLASS_GROWING;
        } else if lambda + REGIME_Z * sigma < -REGIME_FLAT_PER_PERIOD {
            return CLASS_SHRINKING;
        } else if abs(lambda) + REGIME_Z * sigma <= REGIME_FLAT_PER_PERIOD {
            return CLASS_FLAT;
        }
        return CLASS_UNRESOLVED;
    }

    /// The regime's code of a cell whose run ended ok, from λ1 per period (Λ, σ), whether a
    /// period was found, and K from `k_samples` samples: the table of the module doc.
    pub(crate) fn regime_code(lambda: Float, sigma: Float, periodic: bool, k: Float, k_samples: u32) -> i32 {
        let growth = lambda_class(lambda, sigma);
        let firm = k_samples >= K_FIRM_SAMPLES && is_finite(k);
        if growth == CLASS_SHRINKING && periodic {
            return REGIME_PERIODIC;
        } else if growth == CLASS_SHRINKING {
            return REGIME_REGULAR;
        } else if growth == CLASS_GROWING && !periodic && (k >= REGIME_K_CHAOS || !firm) {
            return REGIME_CHAOTIC;
        } else if growth == CLASS_FLAT && !periodic && (k < REGIME_K_CHAOS || !firm) {
            return REGIME_REGULAR;
        }
        return REGIME_UNDECIDED;
    }
}

/// What the verdict is formed from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evidence {
    /// The run ended `ok`.
    pub ok: bool,
    /// λ1 (1/s; NaN when not formed).
    pub lyapunov_per_s: f64,
    /// Its standard error (1/s).
    pub lyapunov_se_per_s: f64,
    /// The forcing period T (s).
    pub period_s: f64,
    /// Period of the stroboscopic section (0: none up to the detector's limit).
    pub period: f64,
    /// 0–1 test K.
    pub k: f64,
    /// Stroboscopic samples K comes from.
    pub k_samples: u32,
}

/// A cell's verdict and its confidence (NaN when failed or undecided).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Verdict {
    /// The regime.
    pub regime: Regime,
    /// Φ(m/σ), see the module doc.
    pub confidence: f64,
}

/// The class of λ1 per period, Λ with standard error σ (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Class {
    Growing,
    Flat,
    Shrinking,
    Unresolved,
}

fn class(lambda: f64, sigma: f64) -> Class {
    match lambda_class(lambda, sigma) {
        CLASS_GROWING => Class::Growing,
        CLASS_FLAT => Class::Flat,
        CLASS_SHRINKING => Class::Shrinking,
        _ => Class::Unresolved,
    }
}

/// Whether λ1 (1/s, standard error `se`, forcing period `period_s`) is in the class of a
/// stable orbit, *shrinking*: `λ1 T + zσ < −ε` (the early stop's test of a confirmed orbit).
pub fn shrinking(lyapunov_per_s: f64, se_per_s: f64, period_s: f64) -> bool {
    class(lyapunov_per_s * period_s, se_per_s * period_s) == Class::Shrinking
}

/// The verdict of one cell (see the module doc).
pub fn verdict(e: &Evidence) -> Verdict {
    let regime = regime_of(e);
    Verdict {
        regime,
        confidence: confidence(regime, e),
    }
}

/// The regime of one cell (see the module doc).
pub fn regime_of(e: &Evidence) -> Regime {
    if !e.ok {
        return Regime::Failed;
    }
    let code = regime_code(
        e.lyapunov_per_s * e.period_s,
        e.lyapunov_se_per_s * e.period_s,
        e.period > 0.0,
        e.k,
        e.k_samples,
    );
    Regime::from_code(i64::from(code)).expect("regime_code returns a regime's code")
}

/// The confidence of `regime` for a cell with evidence `e`: Φ(m/σ), `m` the margin of Λ inside
/// the λ1 class the regime rests on (1 when σ = 0); NaN for failed and undecided cells.
pub fn confidence(regime: Regime, e: &Evidence) -> f64 {
    let (lambda, sigma) = (
        e.lyapunov_per_s * e.period_s,
        e.lyapunov_se_per_s * e.period_s,
    );
    let eps = REGIME_FLAT_PER_PERIOD;
    let margin = match (regime, class(lambda, sigma)) {
        (Regime::Chaotic, _) => lambda - eps,
        (Regime::Periodic, _) | (Regime::Regular, Class::Shrinking) => -eps - lambda,
        (Regime::Regular, _) => eps - lambda.abs(),
        (Regime::Failed | Regime::Undecided, _) => return f64::NAN,
    };
    if sigma > 0.0 {
        normal_cdf(margin / sigma)
    } else {
        1.0
    }
}

/// Φ(x), the standard normal distribution function, from the complementary error function
/// of `libm` (the Rust port of musl's): Φ(x) = erfc(−x/√2)/2; Φ(+∞) = 1.
pub(crate) fn normal_cdf(x: f64) -> f64 {
    0.5 * libm::erfc(-x / std::f64::consts::SQRT_2)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cell(lambda: f64, se: f64, period: f64, k: f64, k_samples: u32) -> Regime {
        verdict(&Evidence {
            ok: true,
            lyapunov_per_s: lambda,
            lyapunov_se_per_s: se,
            period_s: 0.125,
            period,
            k,
            k_samples,
        })
        .regime
    }

    #[test]
    fn the_table_of_the_rule() {
        let firm = ZERO_ONE_COMFORTABLE_SAMPLES as u32;
        let short = firm - 1;
        assert_eq!(cell(-8.0, 0.0, 3.0, 0.9, firm), Regime::Periodic);
        assert_eq!(cell(-8.0, 0.0, 0.0, 0.9, firm), Regime::Regular);
        assert_eq!(cell(4.0, 0.3, 0.0, 0.95, firm), Regime::Chaotic);
        assert_eq!(cell(4.0, 0.3, 0.0, 0.2, firm), Regime::Undecided);
        assert_eq!(cell(4.0, 0.3, 0.0, 0.2, short), Regime::Chaotic);
        assert_eq!(cell(4.0, 0.3, 2.0, 0.95, firm), Regime::Undecided);
        assert_eq!(cell(0.0, 0.01, 0.0, 0.1, firm), Regime::Regular);
        assert_eq!(cell(0.0, 0.01, 0.0, 0.9, firm), Regime::Undecided);
        assert_eq!(cell(0.0, 0.01, 0.0, 0.9, short), Regime::Regular);
        assert_eq!(cell(0.0, 0.01, 2.0, 0.1, firm), Regime::Undecided);
        assert_eq!(cell(0.1, 1.0, 0.0, 0.9, firm), Regime::Undecided);
        assert_eq!(cell(f64::NAN, 0.0, 1.0, 0.0, firm), Regime::Undecided);
        let failed = verdict(&Evidence {
            ok: false,
            lyapunov_per_s: f64::NAN,
            lyapunov_se_per_s: f64::NAN,
            period_s: 0.125,
            period: f64::NAN,
            k: f64::NAN,
            k_samples: firm,
        });
        assert_eq!(failed.regime, Regime::Failed);
        assert!(failed.confidence.is_nan());
    }

    #[test]
    fn codes_round_trip_and_phi_matches_known_values() {
        for r in Regime::ALL {
            assert_eq!(Regime::from_code(i64::from(r.code())), Some(r));
        }
        assert_eq!(normal_cdf(0.0), 0.5);
        assert!((normal_cdf(1.959963985) - 0.975).abs() < 1e-9);
        assert!((normal_cdf(-1.0) - 0.158655253931457).abs() < 1e-12);
        assert_eq!(normal_cdf(f64::INFINITY), 1.0);
    }
}

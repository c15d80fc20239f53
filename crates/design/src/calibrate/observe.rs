//! Observations and how a case's runs are judged against them.
//!
//! One run (one initial state) is judged per observation with a **distance** `d` in units of the
//! observation's tolerance, `d ≤ 1` being a match:
//!
//! - K class: `d = 0` on the observed side of `K = 0.5`, else `|K − 0.5| / 0.5 + 1`;
//! - K or R value `v ± tol`: `d = |x − v| / tol`;
//! - period `p`: `d = 0` when the stroboscopic period is `p` (0: none up to the longest
//!   searched, "not periodic"), else 2;
//! - dominant line `p/q` of α's spectrum (a multiple of the forcing frequency, e.g. 1/3) with
//!   relative tolerance `t`: `d = |line − p/q| / (t·p/q)`;
//! - hops or no hops: `d = 0` when the run hops between the wells as observed, else 2;
//! - α range `[lo, hi]` (rad): `d = 0` inside, else `1 + gap / (hi − lo)`.
//!
//! A case runs from several initial states, since one chaotic trajectory's K near 0.5 is not
//! an observation. The observation is **matched** when at least `agreement` of the runs that
//! ended ok match it; its distance is the median of theirs.

use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::reduce::InstanceResult;
use serde::Serialize;

/// What was observed in one case.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Observation {
    /// Chaotic (K > 0.5) or regular.
    KClass {
        /// Chaotic when true.
        chaotic: bool,
    },
    /// K within a tolerance.
    K {
        /// Observed value.
        value: f64,
        /// Tolerance.
        tol: f64,
    },
    /// R (in the calibration's convention) within a tolerance.
    R {
        /// Observed value.
        value: f64,
        /// Tolerance.
        tol: f64,
    },
    /// Stroboscopic period in forcing periods (0: not periodic).
    Period {
        /// The period.
        period: u32,
    },
    /// The dominant line of α's spectrum at `p/q` of the forcing frequency.
    Line {
        /// Numerator.
        p: u32,
        /// Denominator.
        q: u32,
        /// Relative tolerance on `p/q`.
        rel_tol: f64,
    },
    /// The beam hops between the wells, or stays in one.
    Hops {
        /// Hops when true.
        hops: bool,
    },
    /// Range of the holder angle, max − min after the transient (rad).
    AlphaRange {
        /// Smallest accepted range (rad).
        lo_rad: f64,
        /// Largest accepted range (rad).
        hi_rad: f64,
    },
}

/// Distance of a mismatch that has no magnitude (a period, hops).
const MISS: f64 = 2.0;

impl Observation {
    /// A short name for tables: `K class`, `K`, `R`, `period`, `hops`, `alpha range`.
    pub fn label(&self) -> String {
        match self {
            Observation::KClass { chaotic } => {
                format!("K class {}", if *chaotic { "chaotic" } else { "regular" })
            }
            Observation::K { value, tol } => format!("K = {value} ± {tol}"),
            Observation::R { value, tol } => format!("R = {value} ± {tol}"),
            Observation::Period { period: 0 } => "not periodic".into(),
            Observation::Period { period } => format!("period {period}"),
            Observation::Line { p, q, rel_tol } => {
                format!("line at {p}/{q} f ± {}%", 100.0 * rel_tol)
            }
            Observation::Hops { hops } => (if *hops { "hops" } else { "no hops" }).into(),
            Observation::AlphaRange { lo_rad, hi_rad } => {
                format!("alpha range in [{lo_rad}, {hi_rad}] rad")
            }
        }
    }

    /// The distance of one run from the observation (1 = at the tolerance).
    pub fn distance(&self, r: &InstanceResult) -> f64 {
        match *self {
            Observation::KClass { chaotic } => {
                if (r.k > 0.5) == chaotic {
                    0.0
                } else {
                    1.0 + (r.k - 0.5).abs() / 0.5
                }
            }
            Observation::K { value, tol } => (r.k - value).abs() / tol,
            Observation::R { value, tol } => (r.r - value).abs() / tol,
            Observation::Period { period } => {
                if r.period == f64::from(period) {
                    0.0
                } else {
                    MISS
                }
            }
            Observation::Line { p, q, rel_tol } => {
                let at = f64::from(p) / f64::from(q);
                (r.line - at).abs() / (rel_tol * at)
            }
            Observation::Hops { hops } => {
                if (r.hops > 0.0) == hops {
                    0.0
                } else {
                    MISS
                }
            }
            Observation::AlphaRange { lo_rad, hi_rad } => {
                let x = r.alpha_max_rad - r.alpha_min_rad;
                let gap = (lo_rad - x).max(x - hi_rad).max(0.0);
                if gap == 0.0 {
                    0.0
                } else {
                    1.0 + gap / (hi_rad - lo_rad)
                }
            }
        }
    }
}

/// An observation judged over a case's runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Judgement {
    /// At least the agreement share of the ok runs match.
    pub matched: bool,
    /// Share of the ok runs that match.
    pub share: f64,
    /// Median distance over the ok runs (infinite when none ended ok).
    pub distance: f64,
}

/// Judge `obs` over the runs of one case (one per initial state).
pub fn judge(obs: &Observation, runs: &[InstanceResult], agreement: f64) -> Judgement {
    let mut d: Vec<f64> = runs
        .iter()
        .filter(|r| r.status == Status::Ok)
        .map(|r| obs.distance(r))
        .filter(|x| !x.is_nan())
        .collect();
    if d.is_empty() {
        return Judgement {
            matched: false,
            share: 0.0,
            distance: f64::INFINITY,
        };
    }
    let share = d.iter().filter(|&&x| x <= 1.0).count() as f64 / d.len() as f64;
    d.sort_by(f64::total_cmp);
    let n = d.len();
    let median = if n % 2 == 1 {
        d[n / 2]
    } else {
        0.5 * (d[n / 2 - 1] + d[n / 2])
    };
    Judgement {
        matched: share >= agreement - 1e-12,
        share,
        distance: median,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(k: f64, period: f64, status: Status) -> InstanceResult {
        InstanceResult {
            k,
            r: 0.5,
            period,
            hops: 0.0,
            impacts_per_s: 0.0,
            alpha_min_rad: -0.1,
            alpha_max_rad: 0.2,
            power_w: 0.0,
            line: 0.34,
            ..InstanceResult::unset(status, 1)
        }
    }

    #[test]
    fn a_class_is_matched_by_the_agreement_share_of_the_ok_runs() {
        let chaotic = Observation::KClass { chaotic: true };
        let runs = [
            run(0.9, 0.0, Status::Ok),
            run(0.95, 0.0, Status::Ok),
            run(0.3, 0.0, Status::Ok),
            run(0.0, 0.0, Status::Diverged),
        ];
        let j = judge(&chaotic, &runs, 2.0 / 3.0);
        assert!(j.matched);
        assert!((j.share - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(j.distance, 0.0);
        assert!(!judge(&chaotic, &runs, 0.9).matched);
        let failed = judge(&chaotic, &runs[3..], 0.5);
        assert!(!failed.matched && failed.distance.is_infinite());
    }

    #[test]
    fn distances_are_in_units_of_the_tolerance() {
        let r = run(0.2, 3.0, Status::Ok);
        assert!(
            (Observation::K {
                value: 0.0,
                tol: 0.1
            }
            .distance(&r)
                - 2.0)
                .abs()
                < 1e-12
        );
        assert_eq!(
            Observation::R {
                value: 0.5,
                tol: 0.1
            }
            .distance(&r),
            0.0
        );
        assert_eq!(Observation::Period { period: 3 }.distance(&r), 0.0);
        assert_eq!(Observation::Period { period: 1 }.distance(&r), MISS);
        assert_eq!(Observation::Period { period: 0 }.distance(&r), MISS);
        // Line 0.34 against 1/3 ± 5 %: 0.00667 off over 0.01667.
        let third = Observation::Line {
            p: 1,
            q: 3,
            rel_tol: 0.05,
        };
        assert!((third.distance(&r) - 0.4).abs() < 1e-9);
        assert_eq!(Observation::Hops { hops: false }.distance(&r), 0.0);
        // Range 0.3 rad against [0.1, 0.2]: 0.1 beyond, over a width of 0.1.
        let a = Observation::AlphaRange {
            lo_rad: 0.1,
            hi_rad: 0.2,
        };
        assert!((a.distance(&r) - 2.0).abs() < 1e-12);
        assert!((Observation::KClass { chaotic: true }.distance(&r) - 1.6).abs() < 1e-12);
    }
}

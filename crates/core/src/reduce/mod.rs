//! Per-instance results of an ensemble (`docs/analysis.md`, §6 and §9): what either engine's
//! integration leaves of an instance, reduced to the numbers a map shows.
//!
//! Stages, in the order an instance goes through them:
//! 1. [`Tally`] (`tally`): the running accumulators after the transient (α range, hops, impacts,
//!    power), turned into results by [`Tally::result`];
//! 2. the recorded series (`series`): K ([`k_of`]), R ([`r_of`]), the period ([`period_of`])
//!    and the dominant line ([`line_of`]) with the analysis library, by [`reduce_series`];
//! 3. λ1 ([`lyapunov`]): the twin trajectory's log-growths ([`LyapunovSums`]) into the
//!    largest Lyapunov exponent and its standard error;
//! 4. the verdict ([`regime`]): one [`Regime`] per cell from λ1, the period and K, with its
//!    confidence ([`verdict`]);
//! 5. attractors ([`attractors`]), for maps run from several starts per cell: each run's
//!    fingerprint, the runs of a cell grouped into attractors, families labelled across
//!    neighbouring cells, basin fractions ([`attractor_map`]);
//! 6. escapes ([`escape`]), for the cells of a map settling leaves not firm: the nudged copies'
//!    eventual verdicts, the cell's verdict after them, the share of copies that disagree (its
//!    start sensitivity) and the chaotic transient's lifetime;
//! 7. periodic orbits ([`orbits`]), for the cells whose verdict is periodic: shooting from
//!    the cell's end state, Floquet multipliers, continuation into the neighbouring cells,
//!    bifurcation curves.
//!
//! The CPU engine runs every stage here; the GPU engine reduces on the device with the same
//! definitions (`shaders/reduce_*.wgsl`, the twin in `shaders/integrate.wgsl`) and converts
//! its accumulators with [`Tally::result`] like the CPU engine does.

pub mod attractors;
pub mod escape;
pub mod lyapunov;
pub mod orbits;
pub mod regime;
mod series;
mod tally;

pub use attractors::{AttractorMap, AttractorRule, Fingerprint, attractor_map, basin_map};
pub use lyapunov::{LYAPUNOV_BLOCKS, Lyapunov, LyapunovSums, TwinPlan};
pub use regime::{Evidence, Regime, Verdict, verdict};
pub use series::{Series, k_of, line_of, period_of, r_of, reduce_series};
pub use tally::{Span, Tally};

/// The natural log of the span of positive f64 values (`ln(f64::MAX / f64::MIN_POSITIVE)`): no
/// twin measures a growth per renormalisation beyond it.
pub(crate) const LN_F64_RANGE: f64 = 1418.2;

/// What a result read back is held to besides its own ranges ([`InstanceResult::check_rule`]).
#[derive(Debug, Clone, Copy)]
pub struct RowRule {
    /// `map.period_max`.
    pub period_max: u32,
    /// The instance's forcing period (s).
    pub period_s: f64,
    /// The stroboscopic samples its K comes from.
    pub k_samples: u32,
    /// The verdict was formed in f64 from the stored numbers (the CPU engine; the GPU forms
    /// it in f32 in the shader).
    pub exact_verdict: bool,
}

use crate::analysis::{K01Method, PhaseConvention, ZeroOneOptions};
use crate::config::{MapSpec, Metric};
use crate::schema::{Dtype, FIELDS};
use crate::text::num;
use serde::Serialize;

pub use crate::schema::InstanceResult;

/// The rules of [`crate::schema::FIELDS`], and the verdict's, applied to a result.
impl InstanceResult {
    /// The rules every result of the engines obeys (a shard row read back is held to them):
    /// a failed instance carries no number and the verdict `failed`; an `ok` one carries a
    /// finite value of every metric in `metrics`, and every value it carries lies in its
    /// range (K in [−1, 1], R and the confidence in [0, 1], whole periods; hops, rates,
    /// power, line and λ1's error non-negative, α's minimum at most its maximum).
    pub fn check(&self, metrics: &[Metric]) -> Result<(), String> {
        let values = || FIELDS.iter().filter(|f| f.dtype == Dtype::F64);
        if !self.status.is_ok() {
            if let Some(f) = values().find(|f| !(f.get)(self).is_nan()) {
                let v = num((f.get)(self));
                return Err(format!("status `{}` but {} = {v}", self.status, f.name));
            }
            if self.regime != Regime::Failed {
                return Err(format!(
                    "status `{}` but regime `{}`",
                    self.status,
                    self.regime.name()
                ));
            }
            return Ok(());
        }
        if self.regime == Regime::Failed {
            return Err("status `ok` but regime `failed`".into());
        }
        for m in metrics {
            let v = self.metric(*m);
            if !v.is_finite() {
                return Err(format!("status `ok` but {} = {}", m.name(), num(v)));
            }
        }
        for f in values() {
            let v = (f.get)(self);
            if !v.is_nan() && !f.range.admits(v) {
                return Err(format!("{} = {} is outside its range", f.name, num(v)));
            }
        }
        if self.alpha_min_rad > self.alpha_max_rad {
            return Err(format!(
                "alpha_min_rad = {} above alpha_max_rad = {}",
                num(self.alpha_min_rad),
                num(self.alpha_max_rad)
            ));
        }
        Ok(())
    }

    /// [`InstanceResult::check`], and the rules that tie a result to its map and its own
    /// numbers (what a shard row read back must obey): a period at most `period_max`; λ1
    /// within what a twin in f64 can measure (|λ1|·T at most `LN_F64_RANGE` per forcing
    /// period); a verdict whose shape fits the period (periodic cells have one, regular and
    /// chaotic cells none); a confidence that is the one its regime and λ1 give; and, where
    /// the verdict was formed in f64 from these very numbers (`rule.exact_verdict`: the CPU
    /// engine), the regime they give.
    pub fn check_rule(&self, metrics: &[Metric], rule: &RowRule) -> Result<(), String> {
        self.check(metrics)?;
        if !self.status.is_ok() {
            return Ok(());
        }
        if self.period > f64::from(rule.period_max) {
            return Err(format!(
                "period = {} is above map.period_max = {}",
                num(self.period),
                rule.period_max
            ));
        }
        if (self.lyapunov_per_s * rule.period_s).abs() > LN_F64_RANGE {
            return Err(format!(
                "lambda1 = {} 1/s is beyond what a twin in f64 can measure ({} per forcing period at most)",
                num(self.lyapunov_per_s),
                num(LN_F64_RANGE)
            ));
        }
        if metrics.contains(&Metric::Regime) {
            self.check_verdict(rule)?;
        }
        Ok(())
    }

    /// The verdict's part of [`InstanceResult::check_rule`].
    fn check_verdict(&self, rule: &RowRule) -> Result<(), String> {
        let name = self.regime.name();
        let fits = match self.regime {
            Regime::Periodic => self.period > 0.0,
            Regime::Chaotic | Regime::Regular => self.period == 0.0,
            Regime::Undecided | Regime::Failed => true,
        };
        if !fits {
            return Err(format!("regime `{name}` with period {}", num(self.period)));
        }
        let e = self.evidence(rule.period_s, rule.k_samples);
        if rule.exact_verdict {
            // Whether K's samples count as firm only moves a cell between a class and
            // `undecided`: a regime both readings agree on is the verdict.
            let (firm, loose) = (
                regime::regime_of(&Evidence {
                    k_samples: u32::MAX,
                    ..e
                }),
                regime::regime_of(&Evidence { k_samples: 0, ..e }),
            );
            if firm == loose && firm != self.regime {
                return Err(format!(
                    "regime `{name}`, but its own lambda1, period and K give `{}`",
                    firm.name()
                ));
            }
        }
        let c = regime::confidence(self.regime, &e);
        let same = c == self.regime_confidence || (c.is_nan() && self.regime_confidence.is_nan());
        if !same {
            return Err(format!(
                "regime confidence {} for `{name}`, but its own lambda1 gives {}",
                num(self.regime_confidence),
                num(c)
            ));
        }
        Ok(())
    }

    /// Set the verdict and its confidence from this result's λ1, period and K
    /// ([`verdict`]); `period_s` is the forcing period, `k_samples` the stroboscopic samples
    /// K comes from.
    pub fn decide(&mut self, period_s: f64, k_samples: u32) {
        let v = verdict(&self.evidence(period_s, k_samples));
        self.regime = v.regime;
        self.regime_confidence = v.confidence;
    }

    /// What the verdict of this result is formed from.
    pub fn evidence(&self, period_s: f64, k_samples: u32) -> Evidence {
        Evidence {
            ok: self.status.is_ok(),
            lyapunov_per_s: self.lyapunov_per_s,
            lyapunov_se_per_s: self.lyapunov_se_per_s,
            period_s,
            period: self.period,
            k: self.k,
            k_samples,
        }
    }
}

/// The reduction settings of a map.
#[derive(Debug, Clone, Serialize)]
pub struct ReduceOptions {
    /// 0–1 test settings (correlation method, seeded c values).
    pub zero_one: ZeroOneOptions,
    /// Convention of R.
    pub convention: PhaseConvention,
    /// Longest period searched.
    pub period_max: u32,
    /// Trailing samples that must repeat.
    pub period_window: u32,
    /// Tolerance of the period test (rad).
    pub period_tol_rad: f64,
}

impl Default for ReduceOptions {
    /// A map's defaults: K by correlation with 100 seeded c values, R in the standard
    /// convention, periods up to 8 over 16 samples within 1e-3 rad.
    fn default() -> Self {
        ReduceOptions {
            zero_one: ZeroOneOptions::default(),
            convention: PhaseConvention::Standard,
            period_max: 8,
            period_window: 16,
            period_tol_rad: 1e-3,
        }
    }
}

impl ReduceOptions {
    /// From a map scene.
    pub fn from_spec(spec: &MapSpec) -> ReduceOptions {
        ReduceOptions {
            zero_one: ZeroOneOptions {
                method: K01Method::Correlation,
                n_c: spec.k_n_c,
                seed: spec.k_seed,
                normalize: false,
            },
            convention: spec.phase_convention,
            period_max: spec.period_max,
            period_window: spec.period_window,
            period_tol_rad: spec.period_tol_rad,
        }
    }
}

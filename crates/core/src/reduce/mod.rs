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
//!    neighbouring cells, basin fractions ([`attractor_map`]).
//!
//! The CPU engine runs every stage here; the GPU engine reduces on the device with the same
//! definitions (`shaders/reduce_*.wgsl`, the twin in `shaders/integrate.wgsl`) and converts
//! its accumulators with [`Tally::result`] like the CPU engine does.

pub mod attractors;
pub mod lyapunov;
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
pub const LN_F64_RANGE: f64 = 1418.2;

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
use crate::model::Status;
use crate::text::num;
use serde::Serialize;

/// The numbers a map shows for one grid point. Metrics not requested, and every metric of an
/// instance whose status is not `ok`, are NaN.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InstanceResult {
    /// 0–1 test K.
    #[serde(rename = "K")]
    pub k: f64,
    /// Phase-synchronisation index R.
    #[serde(rename = "R")]
    pub r: f64,
    /// Period of the stroboscopic section in forcing periods (0 = none ≤ period_max).
    pub period: f64,
    /// Hops between the wells after the transient.
    pub hops: f64,
    /// Bumper contact onsets per second after the transient.
    pub impacts_per_s: f64,
    /// Smallest holder angle after the transient (rad).
    pub alpha_min_rad: f64,
    /// Largest holder angle after the transient (rad).
    pub alpha_max_rad: f64,
    /// Mean harvested power v²/R_L after the transient (W).
    pub power_w: f64,
    /// Dominant line of α (the R series) over the forcing frequency: 1/3 for a third.
    #[serde(rename = "line_ratio")]
    pub line: f64,
    /// Largest Lyapunov exponent λ1 (1/s).
    pub lyapunov_per_s: f64,
    /// Standard error of λ1 (1/s).
    pub lyapunov_se_per_s: f64,
    /// The cell's verdict ([`Regime::Undecided`] when not asked for).
    pub regime: Regime,
    /// Confidence of the verdict (NaN when undecided, failed or not asked for): the
    /// probability that λ1 lies on the verdict's side of its class boundary.
    pub regime_confidence: f64,
    /// The chance that the verdict is the one a converged run gives, from the verdict and its
    /// grid neighbours' (the map's confidence stage, `pendulum_atlas_map::map::confidence`,
    /// calibrated in `docs/bench/VERDICT.md`); NaN outside a map, in a shard before its merge,
    /// and where the verdict is undecided, failed or not asked for.
    pub verdict_confidence: f64,
    /// How the integration ended.
    pub status: Status,
    /// Steps actually integrated (fewer than planned when the instance failed or stopped
    /// early on a confirmed periodic orbit).
    pub steps: u64,
}

impl InstanceResult {
    /// A result with every metric NaN (not yet reduced), of `status` after `steps` steps.
    pub fn unset(status: Status, steps: u64) -> InstanceResult {
        let nan = f64::NAN;
        InstanceResult {
            k: nan,
            r: nan,
            period: nan,
            hops: nan,
            impacts_per_s: nan,
            alpha_min_rad: nan,
            alpha_max_rad: nan,
            power_w: nan,
            line: nan,
            lyapunov_per_s: nan,
            lyapunov_se_per_s: nan,
            regime: if status.is_ok() {
                Regime::Undecided
            } else {
                Regime::Failed
            },
            regime_confidence: nan,
            verdict_confidence: nan,
            status,
            steps,
        }
    }

    /// The rules every result of the engines obeys (a shard row read back is held to them):
    /// a failed instance carries no number and the verdict `failed`; an `ok` one carries a
    /// finite value of every metric in `metrics`, and every value it carries lies in its
    /// range (K in [−1, 1], R and the confidence in [0, 1], whole periods; hops, rates,
    /// power, line and λ1's error non-negative, α's minimum at most its maximum).
    pub fn check(&self, metrics: &[crate::config::Metric]) -> Result<(), String> {
        let fields = [
            ("K", self.k),
            ("R", self.r),
            ("period", self.period),
            ("hops", self.hops),
            ("impacts_per_s", self.impacts_per_s),
            ("alpha_min_rad", self.alpha_min_rad),
            ("alpha_max_rad", self.alpha_max_rad),
            ("power_w", self.power_w),
            ("line_ratio", self.line),
            ("lyapunov", self.lyapunov_per_s),
            ("lyapunov_se", self.lyapunov_se_per_s),
            ("regime_confidence", self.regime_confidence),
            ("verdict_confidence", self.verdict_confidence),
        ];
        if !self.status.is_ok() {
            if let Some((name, v)) = fields.iter().find(|(_, v)| !v.is_nan()) {
                return Err(format!("status `{}` but {name} = {}", self.status, num(*v)));
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
        for (name, v) in fields.iter().filter(|(_, v)| !v.is_nan()) {
            if !value_in_range(name, *v) {
                return Err(format!("{name} = {} is outside its range", num(*v)));
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
    /// within what a twin in f64 can measure (|λ1|·T at most [`LN_F64_RANGE`] per forcing
    /// period); a verdict whose shape fits the period (periodic cells have one, regular and
    /// chaotic cells none); a confidence that is the one its regime and λ1 give; and, where
    /// the verdict was formed in f64 from these very numbers (`rule.exact_verdict`: the CPU
    /// engine), the regime they give.
    pub fn check_rule(
        &self,
        metrics: &[crate::config::Metric],
        rule: &RowRule,
    ) -> Result<(), String> {
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
        if metrics.contains(&crate::config::Metric::Regime) {
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

    /// The value shown on the map of `m` (α range: max − min).
    pub fn metric(&self, m: Metric) -> f64 {
        match m {
            Metric::K => self.k,
            Metric::R => self.r,
            Metric::Period => self.period,
            Metric::Hops => self.hops,
            Metric::ImpactsPerS => self.impacts_per_s,
            Metric::AlphaRange => self.alpha_max_rad - self.alpha_min_rad,
            Metric::Power => self.power_w,
            Metric::Line => self.line,
            Metric::Lyapunov => self.lyapunov_per_s,
            Metric::Regime => f64::from(self.regime.code()),
        }
    }
}

/// Whether `v` can be the value of result field `name` ([`InstanceResult::check`]).
fn value_in_range(name: &str, v: f64) -> bool {
    let whole = v.fract() == 0.0;
    match name {
        "K" => (-1.0..=1.0).contains(&v),
        "R" | "regime_confidence" | "verdict_confidence" => (0.0..=1.0).contains(&v),
        "period" => v >= 0.0 && whole && v.is_finite(),
        "hops" => v >= 0.0 && whole && v.is_finite(),
        "impacts_per_s" | "power_w" | "line_ratio" | "lyapunov_se" => v >= 0.0 && v.is_finite(),
        "alpha_min_rad" | "alpha_max_rad" => v.abs() <= std::f64::consts::PI,
        _ => v.is_finite(),
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

//! Per-instance results of an ensemble: the running accumulators of either engine and the
//! reductions of the recorded series (`docs/analysis.md`).
//!
//! The CPU engine records raw series and reduces them here with the analysis library: the 0–1
//! test on the stroboscopic samples ([`k_of`]), R from the uniform series against the cart
//! ([`r_of`]), the period of the stroboscopic section ([`period_of`]). The GPU engine reduces
//! on the device with the same definitions (`shaders/reduce_*.wgsl`) and converts its
//! accumulators with [`Tally::result`] like the CPU engine does.

use crate::analysis::{
    K01Method, PhaseConvention, ZeroOneOptions, amplitude_spectrum, detect_period, dominant_peak,
    phase_sync, zero_one_test,
};
use crate::config::{MapSpec, Metric};
use crate::model::Status;
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
    /// How the integration ended.
    pub status: Status,
    /// Steps actually integrated (fewer than planned when the instance failed or stopped
    /// early on a confirmed periodic orbit).
    pub steps: u64,
}

impl InstanceResult {
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
    /// or when the instance failed; K, R and period NaN until [`reduce_series`] fills them.
    pub fn result(&self, span: Span, metrics: &[Metric]) -> InstanceResult {
        let nan = f64::NAN;
        let mut out = InstanceResult {
            k: nan,
            r: nan,
            period: nan,
            hops: nan,
            impacts_per_s: nan,
            alpha_min_rad: nan,
            alpha_max_rad: nan,
            power_w: nan,
            line: nan,
            status: self.status,
            steps: self.steps,
        };
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

/// K of a stroboscopic series as the map computes it (NaN if the test refuses the series).
pub fn k_of(strobe: &[f64], opts: &ReduceOptions) -> f64 {
    zero_one_test(strobe, &opts.zero_one).map_or(f64::NAN, |r| r.k)
}

/// R of an α series against the cart positions at the same instants.
pub fn r_of(cart: &[f64], alpha: &[f64], opts: &ReduceOptions) -> f64 {
    phase_sync(cart, alpha, opts.convention).map_or(f64::NAN, |r| r.r)
}

/// The period of a stroboscopic series in forcing periods (0: none up to `period_max`).
pub fn period_of(strobe: &[f64], opts: &ReduceOptions) -> f64 {
    detect_period(
        strobe,
        opts.period_max as usize,
        opts.period_window as usize,
        opts.period_tol_rad,
    ) as f64
}

/// The dominant line of a uniform α series sampled `samples_per_period` times per forcing
/// period, as a multiple of the forcing frequency: the largest non-DC peak of the Hann-windowed
/// amplitude spectrum, located between bins by a parabola through the log amplitudes
/// ([`dominant_peak`]); with the sample rate in samples per period the peak's frequency is
/// already `f_line / f`. NaN for a constant series.
pub fn line_of(alpha: &[f64], samples_per_period: f64) -> f64 {
    amplitude_spectrum(alpha, samples_per_period)
        .ok()
        .and_then(|s| dominant_peak(&s))
        .map_or(f64::NAN, |p| p.frequency_hz)
}

/// The series an instance recorded: stroboscopic α, and the R series with its cart reference.
#[derive(Debug, Clone, Copy, Default)]
pub struct Series<'a> {
    /// Stroboscopic α after the transient (rad).
    pub strobe: &'a [f64],
    /// Uniform α for R (rad).
    pub r_alpha: &'a [f64],
    /// Cart positions at the R samples (m).
    pub r_cart: &'a [f64],
    /// Samples of the R series per forcing period.
    pub r_samples_per_period: f64,
}

/// Fill K, period and R of an `ok` result from its recorded series, as far as requested.
pub fn reduce_series(
    out: &mut InstanceResult,
    series: Series,
    metrics: &[Metric],
    opts: &ReduceOptions,
) {
    if out.status != Status::Ok {
        return;
    }
    let wants = |m: Metric| metrics.contains(&m);
    if wants(Metric::K) {
        out.k = k_of(series.strobe, opts);
    }
    if wants(Metric::Period) {
        out.period = period_of(series.strobe, opts);
    }
    if wants(Metric::R) {
        out.r = r_of(series.r_cart, series.r_alpha, opts);
    }
    if wants(Metric::Line) {
        out.line = line_of(series.r_alpha, series.r_samples_per_period);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_line_of_a_third_subharmonic_is_one_third_of_the_forcing() {
        // 64 forcing periods at 16 samples each: a strong f/3 under a weaker 1·f, plus a mean.
        let per_period = 16.0;
        let x: Vec<f64> = (0..1024)
            .map(|j| {
                let t = j as f64 / per_period; // in forcing periods
                0.2 + 0.3 * (std::f64::consts::TAU * t / 3.0).sin()
                    + 0.1 * (std::f64::consts::TAU * t).cos()
            })
            .collect();
        let line = line_of(&x, per_period);
        assert!((line - 1.0 / 3.0).abs() < 2e-3, "line {line}");
        assert!(line_of(&[0.5; 64], per_period).is_nan());
    }
}

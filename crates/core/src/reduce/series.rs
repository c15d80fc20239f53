//! Stage 2 of the reductions: the recorded series of an instance reduced with the analysis
//! library (`docs/analysis.md`): the 0–1 test on the stroboscopic samples ([`k_of`]), R from the
//! uniform series against the cart ([`r_of`]), the period of the stroboscopic section
//! ([`period_of`]) and the dominant line ([`line_of`]).

use super::{InstanceResult, LyapunovSums, ReduceOptions, TwinPlan};
use crate::analysis::{
    amplitude_spectrum, detect_period, dominant_peak, phase_sync, zero_one_test,
};
use crate::config::Metric;
use crate::model::Status;

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
    /// The twin's log-growths and its plan (λ1), when it ran.
    pub twin: Option<(&'a LyapunovSums, &'a TwinPlan)>,
}

/// Fill K, period, R, the line and λ1 of an `ok` result from its recorded series, and then
/// its verdict, as far as requested.
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
    if let (true, Some((sums, plan))) = (wants(Metric::Lyapunov), series.twin)
        && let Some(l) = sums.estimate(plan.window, plan.period_s)
    {
        out.lyapunov_per_s = l.per_s;
        out.lyapunov_se_per_s = l.se_per_s;
    }
    if wants(Metric::Regime)
        && let Some((_, plan)) = series.twin
    {
        out.decide(plan.period_s, series.strobe.len() as u32);
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

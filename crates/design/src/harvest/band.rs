//! The band metric: what a sampled power curve P(f) is worth to a harvester.
//!
//! P(f) is known at a few frequencies; between them it is taken as piecewise linear, so the
//! **bandwidth** (the total frequency span where P ≥ threshold) counts a partial interval up
//! to the interpolated crossing, and the **band-averaged power** is the trapezoidal mean
//! `∫P df / (f_end − f_start)`. Both work on non-uniform grids (the baseline's zoomed grid).
//!
//! A frequency whose power is not finite (an instance that failed) counts as zero power:
//! it never reaches the threshold and adds nothing to the average.

use serde::Serialize;

/// The numbers that summarise one P(f) curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BandMetrics {
    /// Total span of frequencies where P ≥ threshold (Hz).
    pub bandwidth_hz: f64,
    /// Trapezoidal mean of P over the band (W).
    pub band_average_w: f64,
    /// Largest sampled P (W).
    pub peak_w: f64,
    /// Frequency of the largest sampled P (Hz).
    pub peak_frequency_hz: f64,
}

/// Power with failed (non-finite) samples counted as zero.
fn finite_or_zero(p: f64) -> f64 {
    if p.is_finite() { p } else { 0.0 }
}

/// Total span of `f` where the piecewise-linear `p` is at least `threshold_w` (Hz).
/// `f` must be strictly increasing and as long as `p`.
pub fn bandwidth_hz(f: &[f64], p: &[f64], threshold_w: f64) -> f64 {
    assert_eq!(f.len(), p.len(), "bandwidth_hz: f and P differ in length");
    f.windows(2)
        .zip(p.windows(2))
        .map(|(fw, pw)| {
            let (a, b) = (finite_or_zero(pw[0]), finite_or_zero(pw[1]));
            let df = fw[1] - fw[0];
            match (a >= threshold_w, b >= threshold_w) {
                (true, true) => df,
                (false, false) => 0.0,
                // One end above: the span up to the linear crossing.
                (true, false) => df * (a - threshold_w) / (a - b),
                (false, true) => df * (b - threshold_w) / (b - a),
            }
        })
        .sum()
}

/// Trapezoidal mean of `p` over `f` (W); the single value if there is only one.
pub fn band_average_w(f: &[f64], p: &[f64]) -> f64 {
    assert_eq!(f.len(), p.len(), "band_average_w: f and P differ in length");
    match f.len() {
        0 => f64::NAN,
        1 => finite_or_zero(p[0]),
        n => {
            let integral: f64 = f
                .windows(2)
                .zip(p.windows(2))
                .map(|(fw, pw)| {
                    0.5 * (fw[1] - fw[0]) * (finite_or_zero(pw[0]) + finite_or_zero(pw[1]))
                })
                .sum();
            integral / (f[n - 1] - f[0])
        }
    }
}

/// Bandwidth, band average and peak of one curve.
pub fn band_metrics(f: &[f64], p: &[f64], threshold_w: f64) -> BandMetrics {
    let (peak_frequency_hz, peak_w) = f.iter().zip(p).filter(|(_, p)| p.is_finite()).fold(
        (f64::NAN, f64::NEG_INFINITY),
        |best, (&f, &p)| {
            if p > best.1 { (f, p) } else { best }
        },
    );
    BandMetrics {
        bandwidth_hz: bandwidth_hz(f, p, threshold_w),
        band_average_w: band_average_w(f, p),
        peak_w: if peak_w.is_finite() { peak_w } else { f64::NAN },
        peak_frequency_hz,
    }
}

/// The robust curve: at each frequency the smallest power over the initial states (what a
/// harvester delivers whichever attractor it lands on). NaN where any state failed.
pub fn robust_curve(per_state: &[Vec<f64>]) -> Vec<f64> {
    combine(per_state, |vals| {
        vals.iter().copied().fold(f64::INFINITY, f64::min)
    })
}

/// The mean curve over the initial states (NaN where any state failed).
pub fn mean_curve(per_state: &[Vec<f64>]) -> Vec<f64> {
    combine(per_state, |vals| {
        vals.iter().sum::<f64>() / vals.len() as f64
    })
}

/// Apply `op` across the initial states at each frequency; NaN where any state failed.
fn combine(per_state: &[Vec<f64>], op: impl Fn(&[f64]) -> f64) -> Vec<f64> {
    let n = per_state.first().map_or(0, Vec::len);
    (0..n)
        .map(|j| {
            let vals: Vec<f64> = per_state.iter().map(|s| s[j]).collect();
            if vals.iter().all(|v| v.is_finite()) {
                op(&vals)
            } else {
                f64::NAN
            }
        })
        .collect()
}

//! The Gottwald–Melbourne 0–1 test for chaos, as Matthews' `z1test.m` computes it: a single
//! number `K` near 0 for regular and near 1 for chaotic dynamics, from one observable.
//!
//! For `φ(j)`, `j = 1…N`, and random `c ∈ (π/5, 4π/5)`:
//! `p_c(n) = Σ_{j≤n} φ(j) cos jc`, `q_c(n) = Σ_{j≤n} φ(j) sin jc`,
//! `M_c(n) = mean_{j=1}^{N−n} [(p_c(j+n) − p_c(j))² + (q_c(j+n) − q_c(j))²]`,
//! `D_c(n) = M_c(n) − (Eφ)² (1 − cos nc)/(1 − cos c)` for `n = 1…n_cut`, `n_cut = round(N/10)`,
//! `K_c = corr(n, D_c(n))`, and `K` is the median of `K_c` over `n_c` values of `c`.

use std::f64::consts::PI;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::checks::{ensure_finite, ensure_min_len, mean, median, min_max, population_variance};
use super::error::AnalysisError;

/// Shortest series the test accepts: `N = 95`, the smallest length whose lag window
/// `n_cut = round(N/10)` holds 10 lags.
///
/// Ten lags is what each part of the test needs before its number means anything:
/// - `K_c` is a correlation over `n_cut` points; over fewer than ten, a bounded `D_c(n)`
///   correlates with `n` by chance (two or three lags give ±1 whatever the dynamics: a
///   period-2 series of 25 samples, `n_cut = 3`, came out as `K = 0.80`);
/// - the regression method fits `ln M_c(n)` against `ln n`, and a growth exponent needs the
///   lags to span a decade, `n = 1…10`;
/// - the bounded part of `D_c(n)` oscillates in `n` with period `2π/c` up to 10 lags (at
///   `c = π/5`); a window shorter than one such period cannot tell it from growth.
///
/// Below [`ZERO_ONE_COMFORTABLE_SAMPLES`] the test still runs but warns.
pub const ZERO_ONE_MIN_SAMPLES: usize = 95;

/// Length from which `K` is trustworthy for every periodic series up to period 12 (the
/// periodicity detector's default limit): `N = 1000`, `n_cut = 100`, as Matthews recommends
/// for `z1test.m`.
///
/// A period-`p` series resonates with the `c` values near multiples of `2π/p`; the `K_c` of
/// those `c` look chaotic until `n_cut` spans several periods of the slow beat, and the median
/// absorbs them only when they are a minority. Measured with random period-`p` values and seeds
/// (correlation method, 100 values of `c`): the worst `|K|` for `p = 2…12` is 0.98 at `N = 100`,
/// 0.9 at `N = 300`, 0.23 at `N = 500` and 0.09 at `N = 1000`; for `p ≤ 4` it drops below 0.1
/// from `N = 200`. Between [`ZERO_ONE_MIN_SAMPLES`] and this length the result carries a
/// warning.
pub const ZERO_ONE_COMFORTABLE_SAMPLES: usize = 1000;

/// Threshold of Matthews' first oversampling check, `(max φ − min φ)/mean|Δφ|`.
const OVERSAMPLING_RANGE_RATIO: f64 = 10.0;
/// Threshold of the second check: median `K_c` of low `c` minus that of high `c`.
const OVERSAMPLING_KC_GAP: f64 = 0.5;
/// A series whose range is below this fraction of its magnitude is treated as constant.
const CONSTANT_REL_RANGE: f64 = 1e-12;

/// How each `K_c` is estimated from the mean-square displacement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum K01Method {
    /// Pearson correlation of `D_c(n)` with `n` (Gottwald & Melbourne 2009; robust, default).
    Correlation,
    /// Least-squares slope of `ln M_c(n)` against `ln n` (the paper's eq. 10, for reproducing it).
    Regression,
}

/// Settings of the 0–1 test; the defaults are Matthews' choices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ZeroOneOptions {
    /// Estimator of the growth rate of `M_c`.
    pub method: K01Method,
    /// Number of random `c` values whose `K_c` are medianed.
    pub n_c: usize,
    /// Seed of the `c` generator (ChaCha8), so the same input always gives the same `K`.
    pub seed: u64,
    /// Use `(φ − mean)/σ` (population σ) instead of `φ`, as the paper's eq. 8 does.
    pub normalize: bool,
}

impl Default for ZeroOneOptions {
    fn default() -> Self {
        Self {
            method: K01Method::Correlation,
            n_c: 100,
            seed: 0,
            normalize: false,
        }
    }
}

/// Outcome of the 0–1 test, with what is needed to draw the paper's Fig. 6 (`K_c` against `c`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ZeroOneResult {
    /// Median of `K_c`: near 0 for regular, near 1 for chaotic dynamics.
    pub k: f64,
    /// Estimator used for each `K_c`.
    pub method: K01Method,
    /// Length `N` of the series tested.
    pub n_samples: usize,
    /// Largest lag `n_cut = round(N/10)`.
    pub n_cut: usize,
    /// The `c` values drawn, in draw order.
    pub c_values: Vec<f64>,
    /// `K_c` for each entry of `c_values`.
    pub k_c: Vec<f64>,
    /// Whether either oversampling check fired (then `K` is unreliable).
    pub oversampled: bool,
    /// Human-readable diagnostics (oversampling, constant series, skipped lags).
    pub warnings: Vec<String>,
}

/// Runs the 0–1 test on `series` (ideally stroboscopic or extrema samples, not a smooth
/// oversampled record).
///
/// A constant series gives `K = 0` with a warning rather than NaN, since it is the most
/// regular motion there is.
pub fn zero_one_test(
    series: &[f64],
    options: &ZeroOneOptions,
) -> Result<ZeroOneResult, AnalysisError> {
    ensure_min_len("0-1 test", ZERO_ONE_MIN_SAMPLES, series.len())?;
    ensure_finite("0-1 test series", series)?;
    if options.n_c == 0 {
        return Err(AnalysisError::InvalidArgument(
            "the 0-1 test needs at least one value of c".into(),
        ));
    }
    let n_cut = (series.len() as f64 / 10.0).round() as usize;
    let c_values = draw_c_values(options.n_c, options.seed);
    let mut warnings = Vec::new();
    if is_constant(series) {
        warnings.push("series is constant: K set to 0 (no dynamics to test)".to_string());
        return Ok(ZeroOneResult {
            k: 0.0,
            method: options.method,
            n_samples: series.len(),
            n_cut,
            k_c: vec![0.0; c_values.len()],
            c_values,
            oversampled: false,
            warnings,
        });
    }
    if series.len() < ZERO_ONE_COMFORTABLE_SAMPLES {
        warnings.push(short_series_warning(series.len(), n_cut));
    }
    let phi = prepared_series(series, options.normalize);
    let k_c = k_c_values(&phi, &c_values, n_cut, options.method, &mut warnings);
    let oversampled = oversampling_warnings(&phi, &c_values, &k_c, &mut warnings);
    Ok(ZeroOneResult {
        k: median(&k_c),
        method: options.method,
        n_samples: series.len(),
        n_cut,
        c_values,
        k_c,
        oversampled,
        warnings,
    })
}

/// The translation variables `(p_c(n), q_c(n))`, `n = 1…N`, whose bounded or diffusive path
/// the 0–1 test measures; drawn as the paper's `(p, q)` plot. The series is used as given
/// (normalise it first if wanted).
pub fn pq_path(series: &[f64], c: f64) -> (Vec<f64>, Vec<f64>) {
    let mut p = vec![0.0; series.len()];
    let mut q = vec![0.0; series.len()];
    fill_pq(series, c, &mut p, &mut q);
    (p, q)
}

/// Draws `c = π/5 + U·3π/5`, `U ~ U[0, 1)`, from a ChaCha8 stream seeded by `seed`: the
/// `c` values [`zero_one_test`] uses (the GPU reduction is handed the same ones).
pub fn draw_c_values(n_c: usize, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n_c)
        .map(|_| PI / 5.0 + rng.random::<f64>() * 3.0 * PI / 5.0)
        .collect()
}

/// What a series shorter than [`ZERO_ONE_COMFORTABLE_SAMPLES`] risks.
fn short_series_warning(n: usize, n_cut: usize) -> String {
    format!(
        "only {n} samples ({n_cut} lags): K is reliable from {ZERO_ONE_COMFORTABLE_SAMPLES} \
         samples on; with fewer, a periodic series of long period can give K near 1 \
         (check the period, or use a longer record)"
    )
}

/// True when the range is negligible against the magnitude (or exactly zero).
fn is_constant(series: &[f64]) -> bool {
    let (lo, hi) = min_max(series);
    let magnitude = lo.abs().max(hi.abs());
    hi - lo <= CONSTANT_REL_RANGE * magnitude
}

/// The series, or its standardised copy `(φ − mean)/σ` when the paper's eq. 8 is asked for.
fn prepared_series(series: &[f64], normalize: bool) -> Vec<f64> {
    if !normalize {
        return series.to_vec();
    }
    let m = mean(series);
    let sd = population_variance(series).sqrt();
    series.iter().map(|v| (v - m) / sd).collect()
}

/// `K_c` for every `c`, reusing the same buffers for all of them.
fn k_c_values(
    phi: &[f64],
    c_values: &[f64],
    n_cut: usize,
    method: K01Method,
    warnings: &mut Vec<String>,
) -> Vec<f64> {
    let n = phi.len();
    let (mut p, mut q) = (vec![0.0; n], vec![0.0; n]);
    let mut msd = vec![0.0; n_cut];
    let mean_sq = mean(phi).powi(2);
    let mut skipped_lags = false;
    let k_c = c_values
        .iter()
        .map(|&c| {
            fill_pq(phi, c, &mut p, &mut q);
            fill_mean_square_displacement(&p, &q, &mut msd);
            match method {
                K01Method::Correlation => {
                    subtract_oscillatory_term(&mut msd, mean_sq, c);
                    correlation_with_lag(&msd)
                }
                K01Method::Regression => {
                    let (slope, skipped) = log_log_slope(&msd);
                    skipped_lags |= skipped;
                    slope
                }
            }
        })
        .collect();
    if skipped_lags {
        warnings.push("regression: lags with M_c(n) <= 0 were skipped (log undefined)".into());
    }
    k_c
}

/// Cumulative sums `p(n) = Σ_{j≤n} φ(j) cos jc`, `q(n) = Σ_{j≤n} φ(j) sin jc` with 1-based `j`.
fn fill_pq(phi: &[f64], c: f64, p: &mut [f64], q: &mut [f64]) {
    let (mut sp, mut sq) = (0.0, 0.0);
    for (j, &v) in phi.iter().enumerate() {
        let (s, co) = ((j + 1) as f64 * c).sin_cos();
        sp += v * co;
        sq += v * s;
        p[j] = sp;
        q[j] = sq;
    }
}

/// `M_c(n)` for `n = 1…msd.len()`: mean over `j = 1…N−n` of the squared displacement.
fn fill_mean_square_displacement(p: &[f64], q: &[f64], msd: &mut [f64]) {
    let n = p.len();
    for (lag_index, m) in msd.iter_mut().enumerate() {
        let lag = lag_index + 1;
        let sum: f64 = p[lag..]
            .iter()
            .zip(&p[..n - lag])
            .zip(q[lag..].iter().zip(&q[..n - lag]))
            .map(|((pa, pb), (qa, qb))| (pa - pb).powi(2) + (qa - qb).powi(2))
            .sum();
        *m = sum / (n - lag) as f64;
    }
}

/// Turns `M_c` into `D_c` by removing the bounded oscillatory term `(Eφ)²(1 − cos nc)/(1 − cos c)`.
fn subtract_oscillatory_term(msd: &mut [f64], mean_sq: f64, c: f64) {
    let denom = 1.0 - c.cos();
    for (lag_index, m) in msd.iter_mut().enumerate() {
        let lag = (lag_index + 1) as f64;
        *m -= mean_sq * (1.0 - (lag * c).cos()) / denom;
    }
}

/// Pearson correlation of `d(n)` with `n = 1…len`; 0 when `d` has no spread.
fn correlation_with_lag(d: &[f64]) -> f64 {
    let len = d.len() as f64;
    let xi_mean = (len + 1.0) / 2.0;
    let d_mean = d.iter().sum::<f64>() / len;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (i, &v) in d.iter().enumerate() {
        let dx = (i + 1) as f64 - xi_mean;
        let dy = v - d_mean;
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    if syy <= 0.0 || sxx <= 0.0 {
        return 0.0;
    }
    sxy / (sxx * syy).sqrt()
}

/// Least-squares slope of `ln M(n)` against `ln n`, skipping lags with `M ≤ 0`; 0 when fewer
/// than two lags remain. Also says whether any lag was skipped.
fn log_log_slope(msd: &[f64]) -> (f64, bool) {
    let points: Vec<(f64, f64)> = msd
        .iter()
        .enumerate()
        .filter(|(_, m)| **m > 0.0)
        .map(|(i, m)| (((i + 1) as f64).ln(), m.ln()))
        .collect();
    let skipped = points.len() < msd.len();
    if points.len() < 2 {
        return (0.0, skipped);
    }
    let count = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / count;
    let my = points.iter().map(|p| p.1).sum::<f64>() / count;
    let sxy: f64 = points.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = points.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    (sxy / sxx, skipped)
}

/// Matthews' two oversampling checks; pushes a warning for each that fires.
fn oversampling_warnings(
    phi: &[f64],
    c_values: &[f64],
    k_c: &[f64],
    warnings: &mut Vec<String>,
) -> bool {
    let mut fired = false;
    let ratio = range_to_mean_step(phi);
    if ratio > OVERSAMPLING_RANGE_RATIO {
        warnings.push(format!(
            "series is probably oversampled: (max - min)/mean|dphi| = {ratio:.1} > 10; \
             sample more coarsely (stroboscopic or extrema)"
        ));
        fired = true;
    }
    let gap = low_minus_high_c_median(c_values, k_c);
    if gap > OVERSAMPLING_KC_GAP {
        warnings.push(format!(
            "series is probably oversampled: median K_c for low c exceeds that for high c by \
             {gap:.2} > 0.5; sample more coarsely or reduce the largest c"
        ));
        fired = true;
    }
    fired
}

/// `(max φ − min φ) / mean|φ(j+1) − φ(j)|`: large when consecutive samples barely move.
fn range_to_mean_step(phi: &[f64]) -> f64 {
    let (lo, hi) = min_max(phi);
    let steps = phi.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>();
    let mean_step = steps / (phi.len() - 1) as f64;
    if mean_step == 0.0 {
        return f64::INFINITY;
    }
    (hi - lo) / mean_step
}

/// Median `K_c` over `c < mean(c)` minus that over `c > mean(c)`, as `z1test.m` splits them.
fn low_minus_high_c_median(c_values: &[f64], k_c: &[f64]) -> f64 {
    let c_mean = mean(c_values);
    let pick = |low: bool| -> Vec<f64> {
        c_values
            .iter()
            .zip(k_c)
            .filter(|(c, _)| if low { **c < c_mean } else { **c > c_mean })
            .map(|(_, k)| *k)
            .collect()
    };
    let (low, high) = (pick(true), pick(false));
    if low.is_empty() || high.is_empty() {
        return 0.0;
    }
    median(&low) - median(&high)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn correlation_of_a_line_is_one() {
        let d: Vec<f64> = (1..=10).map(|n| 3.0 * n as f64 - 2.0).collect();
        assert!((correlation_with_lag(&d) - 1.0).abs() < 1e-12);
        assert_eq!(correlation_with_lag(&[2.0; 5]), 0.0);
    }

    #[test]
    fn log_log_slope_of_a_power_law() {
        let m: Vec<f64> = (1..=20).map(|n| 5.0 * (n as f64).powf(0.7)).collect();
        let (slope, skipped) = log_log_slope(&m);
        assert!((slope - 0.7).abs() < 1e-12 && !skipped);
    }

    #[test]
    fn c_values_lie_in_the_matthews_interval() {
        let c = draw_c_values(1000, 7);
        assert!(c.iter().all(|v| (PI / 5.0..4.0 * PI / 5.0).contains(v)));
    }
}

//! Continuous wavelet transform with the Morlet wavelet (`ω0 = 6`) after Torrence & Compo
//! (1998, "TC98"), computed in Fourier space with exactly the conventions of pycwt's `cwt`, so
//! scalograms (the paper's Fig. 9b) can be checked against an independent implementation.
//!
//! Conventions (all as pycwt 0.5): scales `s_j = s0·2^{j·δj}`, `j = 0…J`, with
//! `s0 = 2δt/λ` and `J = round(log2(N·δt/s0)/δj)`; Fourier period `λ·s`,
//! `λ = 4π/(ω0 + √(2 + ω0²))`; the signal zero-padded to the next power of two; the wavelet
//! `ψ̂(sω) = π^{−1/4} e^{−(sω − ω0)²/2}` normalised by `(s·ω_1·N)^{1/2} = (2πs/δt)^{1/2}`;
//! cone of influence `λ/√2 · δt · (N/2 − |k − (N−1)/2|)`.

use std::f64::consts::{PI, TAU};

use num_complex::Complex64;
use rustfft::FftPlanner;
use serde::Serialize;

use super::checks::{
    ensure_finite, ensure_finite_arg, ensure_min_len, ensure_positive, mean, population_variance,
};
use super::error::AnalysisError;

/// Morlet wave number `ω0`, the TC98 (and paper) choice.
pub const MORLET_OMEGA0: f64 = 6.0;
/// Reconstruction factor `Cδ` of the Morlet wavelet with `ω0 = 6` (TC98 Table 2).
pub const MORLET_C_DELTA: f64 = 0.776;
/// Default confidence level of significance contours.
pub const DEFAULT_CONFIDENCE: f64 = 0.95;
/// Shortest series the transform accepts.
pub const WAVELET_MIN_SAMPLES: usize = 8;

/// Choices of the transform; defaults follow TC98 and pycwt.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WaveletOptions {
    /// Scale spacing in octaves (`1/12`: twelve scales per doubling of period).
    pub dj: f64,
    /// Smallest scale in seconds; `None` gives `2δt/λ`, a Fourier period of `2δt`.
    pub s0: Option<f64>,
    /// Number of scales less one; `None` gives `round(log2(N·δt/s0)/δj)`.
    pub j: Option<usize>,
    /// Zero-pad to the next power of two (as pycwt with its scipy FFT back end) to limit
    /// wrap-around at the ends.
    pub pad: bool,
    /// Transform `(x − mean)/σ` (population σ) so power is in units of the variance; otherwise
    /// `x` is transformed as given (pycwt's `cwt` itself removes nothing).
    pub normalize: bool,
}

impl Default for WaveletOptions {
    fn default() -> Self {
        Self {
            dj: 1.0 / 12.0,
            s0: None,
            j: None,
            pad: true,
            normalize: true,
        }
    }
}

/// Wavelet transform of a series: coefficients, power and the cone of influence.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WaveletResult {
    /// Scales `s_j`, in seconds.
    pub scales: Vec<f64>,
    /// Equivalent Fourier periods `λ·s_j`, in seconds.
    pub period_s: Vec<f64>,
    /// Cone of influence per time sample, as the largest trustworthy period, in seconds.
    pub coi_s: Vec<f64>,
    /// Wavelet power `|W|²`, indexed `[scale][time]`.
    pub power: Vec<Vec<f64>>,
    /// Complex coefficients `W`, indexed `[scale][time]` (for reconstruction; not serialised).
    #[serde(skip)]
    pub coefficients: Vec<Vec<Complex64>>,
    /// Sampling step `δt`, in seconds.
    pub dt_s: f64,
    /// Scale spacing `δj` used.
    pub dj: f64,
    /// Population variance of the input before any normalisation, in signal units squared.
    pub input_variance: f64,
    /// Whether the transformed series was `(x − mean)/σ`.
    pub normalized: bool,
}

/// Fourier factor `λ = 4π/(ω0 + √(2 + ω0²))`: Fourier period of the Morlet wavelet per unit scale.
pub fn morlet_fourier_factor() -> f64 {
    4.0 * PI / (MORLET_OMEGA0 + (2.0 + MORLET_OMEGA0 * MORLET_OMEGA0).sqrt())
}

/// Cone of influence for `n` samples: `λ/√2 · δt · (n/2 − |k − (n−1)/2|)` (pycwt's
/// formula: the e-folding time `√2·s` of the wavelet equals the distance to the nearer end,
/// counted from half a sample beyond it), as a Fourier period in seconds.
pub fn cone_of_influence(n: usize, dt_s: f64) -> Vec<f64> {
    let factor = morlet_fourier_factor() / 2f64.sqrt() * dt_s;
    let centre = (n as f64 - 1.0) / 2.0;
    (0..n)
        .map(|k| factor * (n as f64 / 2.0 - (k as f64 - centre).abs()))
        .collect()
}

/// Morlet CWT of the uniformly sampled `x` (step `dt_s`), in Fourier space (TC98 eq. 4).
pub fn morlet_cwt(
    x: &[f64],
    dt_s: f64,
    options: &WaveletOptions,
) -> Result<WaveletResult, AnalysisError> {
    ensure_min_len("wavelet transform", WAVELET_MIN_SAMPLES, x.len())?;
    ensure_finite("wavelet input", x)?;
    ensure_positive("dt_s", dt_s)?;
    ensure_positive("dj", options.dj)?;
    let input_variance = population_variance(x);
    let signal = transformed_signal(x, input_variance, options.normalize)?;
    let scales = scale_ladder(x.len(), dt_s, options)?;
    let coefficients = transform_in_fourier_space(&signal, dt_s, &scales, options.pad);
    let power = coefficients
        .iter()
        .map(|row| row.iter().map(|w| w.norm_sqr()).collect())
        .collect();
    let lambda = morlet_fourier_factor();
    Ok(WaveletResult {
        period_s: scales.iter().map(|s| lambda * s).collect(),
        coi_s: cone_of_influence(x.len(), dt_s),
        scales,
        power,
        coefficients,
        dt_s,
        dj: options.dj,
        input_variance,
        normalized: options.normalize,
    })
}

/// Lag-1 autocorrelation `Σ(x_k − x̄)(x_{k+1} − x̄) / Σ(x_k − x̄)²`, the `a` of the AR(1)
/// red-noise background.
pub fn lag1_autocorrelation(x: &[f64]) -> Result<f64, AnalysisError> {
    ensure_min_len("lag-1 autocorrelation", 3, x.len())?;
    ensure_finite("autocorrelation input", x)?;
    let m = mean(x);
    let denom: f64 = x.iter().map(|v| (v - m).powi(2)).sum();
    if denom == 0.0 {
        return Err(AnalysisError::InvalidArgument(
            "lag-1 autocorrelation of a constant series is undefined".into(),
        ));
    }
    let num: f64 = x.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum();
    Ok(num / denom)
}

/// Two-sided `χ²` quantile with 2 degrees of freedom, `−2 ln(1 − p)` (5.991… at 95 %).
pub fn chi2_2dof_quantile(confidence: f64) -> Result<f64, AnalysisError> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "confidence must lie in (0, 1), got {confidence}"
        )));
    }
    Ok(-2.0 * (1.0 - confidence).ln())
}

/// Power level per period above which wavelet power is significant against AR(1) red noise
/// (TC98 eqs. 16–18): `variance · (1 − a²)/(1 + a² − 2a cos(2π δt/period)) · χ²_2(p)/2`.
///
/// Evaluated element by element for every period (pycwt's `significance` gets this wrong
/// for arrays, its issue #26). Pass `variance = 1` for normalised transforms.
pub fn significance_ar1(
    variance: f64,
    dt_s: f64,
    period_s: &[f64],
    alpha_lag1: f64,
    confidence: f64,
) -> Result<Vec<f64>, AnalysisError> {
    if !(variance.is_finite() && variance >= 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "variance must be finite and >= 0, got {variance}"
        )));
    }
    ensure_positive("dt_s", dt_s)?;
    ensure_finite_arg("alpha_lag1", alpha_lag1)?;
    if alpha_lag1.abs() >= 1.0 {
        return Err(AnalysisError::InvalidArgument(format!(
            "alpha_lag1 must lie in (-1, 1) for a stationary AR(1), got {alpha_lag1}"
        )));
    }
    ensure_finite("periods", period_s)?;
    let chi2_half = chi2_2dof_quantile(confidence)? / 2.0;
    let a = alpha_lag1;
    period_s
        .iter()
        .map(|&period| {
            ensure_positive("period", period)?;
            let red = (1.0 - a * a) / (1.0 + a * a - 2.0 * a * (TAU * dt_s / period).cos());
            Ok(variance * red * chi2_half)
        })
        .collect()
}

/// Variance of the transformed series recovered from its power (TC98 eq. 14):
/// `σ² = δj·δt/(Cδ·N) Σ_n Σ_j |W_n(s_j)|²/s_j`. Equals 1 for a normalised transform up to the
/// discretisation error (a few percent); a check that the scale range covers the signal.
pub fn reconstruct_variance(result: &WaveletResult) -> f64 {
    let n = result.power.first().map_or(0, Vec::len);
    if n == 0 {
        return 0.0;
    }
    let sum: f64 = result
        .power
        .iter()
        .zip(&result.scales)
        .map(|(row, s)| row.iter().sum::<f64>() / s)
        .sum();
    result.dj * result.dt_s / (MORLET_C_DELTA * n as f64) * sum
}

/// The transformed series rebuilt from the real part of its coefficients (TC98 eq. 11):
/// `x_n = δj·δt^{1/2}/(Cδ·ψ0(0)) Σ_j Re W_n(s_j)/s_j^{1/2}`, `ψ0(0) = π^{−1/4}`.
pub fn reconstruct_signal(result: &WaveletResult) -> Vec<f64> {
    let n = result.coefficients.first().map_or(0, Vec::len);
    let psi0_at_zero = PI.powf(-0.25);
    let factor = result.dj * result.dt_s.sqrt() / (MORLET_C_DELTA * psi0_at_zero);
    let mut out = vec![0.0; n];
    for (row, s) in result.coefficients.iter().zip(&result.scales) {
        let weight = factor / s.sqrt();
        for (o, w) in out.iter_mut().zip(row) {
            *o += weight * w.re;
        }
    }
    out
}

/// Time average of the power over the samples inside the cone of influence, per scale
/// (a global spectrum free of edge effects); `None` for scales with no such sample.
pub fn power_averaged_inside_coi(result: &WaveletResult) -> Vec<Option<f64>> {
    result
        .power
        .iter()
        .zip(&result.period_s)
        .map(|(row, &period)| {
            let inside: Vec<f64> = row
                .iter()
                .zip(&result.coi_s)
                .filter(|(_, coi)| period <= **coi)
                .map(|(p, _)| *p)
                .collect();
            (!inside.is_empty()).then(|| inside.iter().sum::<f64>() / inside.len() as f64)
        })
        .collect()
}

/// The series actually transformed: standardised, or as given.
fn transformed_signal(
    x: &[f64],
    variance: f64,
    normalize: bool,
) -> Result<Vec<f64>, AnalysisError> {
    if !normalize {
        return Ok(x.to_vec());
    }
    if variance == 0.0 {
        return Err(AnalysisError::InvalidArgument(
            "wavelet input is constant (sigma = 0), so it cannot be normalised".into(),
        ));
    }
    let (m, sd) = (mean(x), variance.sqrt());
    Ok(x.iter().map(|v| (v - m) / sd).collect())
}

/// Scales `s0·2^{j·δj}`, `j = 0…J`, with pycwt's defaults for `s0` and `J`.
fn scale_ladder(n: usize, dt_s: f64, options: &WaveletOptions) -> Result<Vec<f64>, AnalysisError> {
    let s0 = options.s0.unwrap_or(2.0 * dt_s / morlet_fourier_factor());
    ensure_positive("s0", s0)?;
    let j_max = options.j.unwrap_or_else(|| {
        ((n as f64 * dt_s / s0).log2() / options.dj)
            .round()
            .max(0.0) as usize
    });
    Ok((0..=j_max)
        .map(|j| s0 * 2f64.powf(j as f64 * options.dj))
        .collect())
}

/// `W(s) = IFFT[X̂(ω)·(2πs/δt)^{1/2}·ψ̂(sω)]` per scale, trimmed to the input length.
fn transform_in_fourier_space(
    signal: &[f64],
    dt_s: f64,
    scales: &[f64],
    pad: bool,
) -> Vec<Vec<Complex64>> {
    let n0 = signal.len();
    let n = if pad { n0.next_power_of_two() } else { n0 };
    let mut planner = FftPlanner::<f64>::new();
    let inverse = planner.plan_fft_inverse(n);
    let mut spectrum: Vec<Complex64> = signal.iter().map(|&v| Complex64::new(v, 0.0)).collect();
    spectrum.resize(n, Complex64::new(0.0, 0.0));
    planner.plan_fft_forward(n).process(&mut spectrum);
    let omega = angular_frequencies(n, dt_s);
    let mut buf = vec![Complex64::new(0.0, 0.0); n];
    scales
        .iter()
        .map(|&s| {
            let norm = (TAU * s / dt_s).sqrt();
            for ((b, x), w) in buf.iter_mut().zip(&spectrum).zip(&omega) {
                *b = x * (norm * morlet_fourier(s * w));
            }
            inverse.process(&mut buf);
            buf[..n0].iter().map(|z| z / n as f64).collect()
        })
        .collect()
}

/// `2π·fftfreq(n, dt)`: angular frequencies in numpy's FFT order (negative half last).
fn angular_frequencies(n: usize, dt_s: f64) -> Vec<f64> {
    let step = TAU / (n as f64 * dt_s);
    (0..n)
        .map(|k| {
            let signed = if k <= (n - 1) / 2 {
                k as f64
            } else {
                k as f64 - n as f64
            };
            signed * step
        })
        .collect()
}

/// Fourier transform of the Morlet wavelet at `sω`, without the Heaviside factor (as pycwt;
/// the negative-frequency part is below `e^{−18}` of the peak).
fn morlet_fourier(s_omega: f64) -> f64 {
    PI.powf(-0.25) * (-0.5 * (s_omega - MORLET_OMEGA0).powi(2)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fftfreq_order_matches_numpy() {
        let w: Vec<f64> = angular_frequencies(4, 1.0)
            .iter()
            .map(|v| v / TAU)
            .collect();
        assert_eq!(w, vec![0.0, 0.25, -0.5, -0.25]);
        let w: Vec<f64> = angular_frequencies(5, 1.0)
            .iter()
            .map(|v| v / TAU)
            .collect();
        assert_eq!(w, vec![0.0, 0.2, 0.4, -0.4, -0.2]);
    }

    #[test]
    fn fourier_factor_matches_pycwt_and_gives_period_two_dt_at_s0() {
        let s0 = 2.0 * 0.25 / morlet_fourier_factor();
        assert!((morlet_fourier_factor() * s0 - 0.5).abs() < 1e-15);
        // pycwt.Morlet(6).flambda()
        assert!((morlet_fourier_factor() - 1.033_043_647_749_253_7).abs() < 1e-15);
    }
}

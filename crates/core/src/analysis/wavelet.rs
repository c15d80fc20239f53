//! Continuous wavelet transform with the Morlet wavelet (`ω0 = 6` unless chosen otherwise)
//! after Torrence & Compo (1998, "TC98"), computed in Fourier space with exactly the
//! conventions of pycwt's `cwt`, so scalograms (the paper's Fig. 9b) can be checked against an
//! independent implementation; and its significance against AR(1) red noise.
//!
//! Conventions (all as pycwt 0.5): scales `s_j = s0·2^{j·δj}`, `j = 0…J`, with
//! `s0 = 2δt/λ` and `J = round(log2(N·δt/s0)/δj)`; Fourier period `λ·s`,
//! `λ = 4π/(ω0 + √(2 + ω0²))`; the signal zero-padded to the next power of two; the wavelet
//! `ψ̂(sω) = π^{−1/4} e^{−(sω − ω0)²/2}` normalised by `(s·ω_1·N)^{1/2} = (2πs/δt)^{1/2}`;
//! cone of influence `λ/√2 · δt · (N/2 − |k − (N−1)/2|)`.
//!
//! Significance (TC98 section 4): the AR(1) background `P_k = (1 − a²)/(1 + a² − 2a cos(2πδt/T))`
//! at period `T`, times `χ²_ν(p)/ν` with `ν = 2` for one power value and, for the time-averaged
//! (global) spectrum over `n_a` times, `ν = 2·√(1 + (n_a·δt/(γ·s))²)` with `γ = 2.32` (TC98
//! eq. 23). The lag-1 coefficient `a` is estimated as pycwt's `ar1` does by default
//! ([`lag1_allen_smith`]), or by the plain sample autocorrelation ([`lag1_autocorrelation`]).

use std::f64::consts::{PI, TAU};

use num_complex::Complex64;
use rustfft::FftPlanner;
use serde::Serialize;

use super::checks::{ensure_finite, ensure_min_len, ensure_positive, mean, population_variance};
use super::error::AnalysisError;

/// Morlet wave number `ω0`, the TC98 (and paper) choice.
pub const MORLET_OMEGA0: f64 = 6.0;
/// Reconstruction factor `Cδ` of the Morlet wavelet with `ω0 = 6` (TC98 Table 2).
pub const MORLET_C_DELTA: f64 = 0.776;
/// Default confidence level of significance contours.
pub const DEFAULT_CONFIDENCE: f64 = 0.95;
/// Shortest series the transform accepts.
pub const WAVELET_MIN_SAMPLES: usize = 8;
/// Smallest Morlet wave number accepted: the Morlet wavelet's mean, `π^{−1/4} e^{−ω0²/2}`
/// relative to its peak, must vanish for it to be a wavelet at all; at `ω0 = 5` it is 4e-6,
/// at `ω0 = 3` already 1e-2.
pub const MORLET_OMEGA0_MIN: f64 = 5.0;
/// Decorrelation factor `γ` of the Morlet wavelet in time, for the degrees of freedom of a
/// time-averaged spectrum (TC98 Table 2, `ω0 = 6`). It depends on the envelope `e^{−η²/2}` only,
/// which does not change with `ω0`, so it serves every Morlet wavelet.
pub const MORLET_GAMMA: f64 = 2.32;
/// Degrees of freedom of one power value `|W|²` of a complex wavelet (TC98 eq. 18).
pub const MORLET_DOF_MIN: f64 = 2.0;

/// The mother wavelet. Only the Morlet wavelet exists; the enum names it so that options and
/// output files say which one was used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "name", rename_all = "lowercase")]
pub enum MotherWavelet {
    /// `ψ(η) = π^{−1/4} e^{iω0η} e^{−η²/2}`.
    Morlet {
        /// Wave number `ω0` (6 in TC98 and the paper), at least [`MORLET_OMEGA0_MIN`].
        omega0: f64,
    },
}

impl MotherWavelet {
    /// The mother wavelet in words: `the Morlet wavelet with omega0 = 6`.
    pub fn name(&self) -> String {
        match self {
            MotherWavelet::Morlet { omega0 } => {
                format!("the Morlet wavelet with omega0 = {omega0}")
            }
        }
    }
}

impl Default for MotherWavelet {
    fn default() -> Self {
        MotherWavelet::Morlet {
            omega0: MORLET_OMEGA0,
        }
    }
}

impl MotherWavelet {
    /// Refuses a wave number that is not finite or below [`MORLET_OMEGA0_MIN`].
    pub fn validate(&self) -> Result<(), AnalysisError> {
        let MotherWavelet::Morlet { omega0 } = *self;
        if !(omega0.is_finite() && omega0 >= MORLET_OMEGA0_MIN) {
            return Err(AnalysisError::InvalidArgument(format!(
                "the Morlet wave number omega0 must be finite and >= {MORLET_OMEGA0_MIN} \
                 (below, the wavelet's mean does not vanish), got {omega0}"
            )));
        }
        Ok(())
    }

    /// Fourier factor `λ = 4π/(ω0 + √(2 + ω0²))`: the Fourier period per unit scale.
    pub(crate) fn fourier_factor(&self) -> f64 {
        let MotherWavelet::Morlet { omega0 } = *self;
        4.0 * PI / (omega0 + (2.0 + omega0 * omega0).sqrt())
    }

    /// Cone of influence for `n` samples, as the largest trustworthy Fourier period in seconds:
    /// `λ/√2 · δt · (n/2 − |k − (n−1)/2|)` (the e-folding time `√2·s` of the Morlet wavelet
    /// equals the distance to the nearer end, counted from half a sample beyond it; pycwt).
    pub fn cone_of_influence(&self, n: usize, dt_s: f64) -> Vec<f64> {
        let factor = self.fourier_factor() / 2f64.sqrt() * dt_s;
        let centre = (n as f64 - 1.0) / 2.0;
        (0..n)
            .map(|k| factor * (n as f64 / 2.0 - (k as f64 - centre).abs()))
            .collect()
    }

    /// Reconstruction factor `Cδ` (TC98 Table 2): tabulated for `ω0 = 6` only.
    pub(crate) fn c_delta(&self) -> Option<f64> {
        let MotherWavelet::Morlet { omega0 } = *self;
        (omega0 == MORLET_OMEGA0).then_some(MORLET_C_DELTA)
    }

    /// Fourier transform at `sω`, without the Heaviside factor (as pycwt; the negative-frequency
    /// part is below `e^{−ω0²/2}` of the peak).
    fn fourier_transform(&self, s_omega: f64) -> f64 {
        let MotherWavelet::Morlet { omega0 } = *self;
        PI.powf(-0.25) * (-0.5 * (s_omega - omega0).powi(2)).exp()
    }
}

/// How the lag-1 autocorrelation `a` of the AR(1) background is estimated from the series.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Lag1Estimator {
    /// Allen & Smith's estimate, corrected for the bias that removing the sample mean puts on
    /// short series: exactly pycwt's `ar1` ([`lag1_allen_smith`]).
    AllenSmith,
    /// The sample autocorrelation ([`lag1_autocorrelation`]), biased low for short series.
    Sample,
}

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
    /// The mother wavelet (Morlet, `ω0 = 6`).
    pub mother: MotherWavelet,
}

impl Default for WaveletOptions {
    fn default() -> Self {
        Self {
            dj: 1.0 / 12.0,
            s0: None,
            j: None,
            pad: true,
            normalize: true,
            mother: MotherWavelet::default(),
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
    /// The mother wavelet used.
    pub mother: MotherWavelet,
}

/// Fourier factor `λ` of the default Morlet wavelet (`ω0 = 6`); see
/// `MotherWavelet::fourier_factor` for another `ω0`.
pub fn morlet_fourier_factor() -> f64 {
    MotherWavelet::default().fourier_factor()
}

/// Cone of influence of the default Morlet wavelet (`ω0 = 6`); see
/// [`MotherWavelet::cone_of_influence`].
pub fn cone_of_influence(n: usize, dt_s: f64) -> Vec<f64> {
    MotherWavelet::default().cone_of_influence(n, dt_s)
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
    ensure_positive("the scale spacing dj", options.dj)?;
    options.mother.validate()?;
    let input_variance = population_variance(x);
    if !input_variance.is_finite() {
        return Err(AnalysisError::Overflow {
            what: "wavelet input".into(),
            max_abs: x.iter().fold(0.0f64, |m, v| m.max(v.abs())),
        });
    }
    let signal = transformed_signal(x, input_variance, options.normalize)?;
    let scales = scale_ladder(x.len(), dt_s, options)?;
    let mother = options.mother;
    let coefficients = transform_in_fourier_space(&signal, dt_s, &scales, options.pad, &mother);
    let power = coefficients
        .iter()
        .map(|row| row.iter().map(|w| w.norm_sqr()).collect())
        .collect();
    let lambda = mother.fourier_factor();
    Ok(WaveletResult {
        period_s: scales.iter().map(|s| lambda * s).collect(),
        coi_s: mother.cone_of_influence(x.len(), dt_s),
        scales,
        power,
        coefficients,
        dt_s,
        dj: options.dj,
        input_variance,
        normalized: options.normalize,
        mother,
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

/// Lag-1 coefficient `g` of an AR(1) model, estimated as pycwt's `ar1` does (Allen & Smith
/// 1996, in A. Grinsted's algebra): removing the sample mean makes the raw ratio of the lag-1
/// and lag-0 covariances too small for short series, and the correction solves for the `g`
/// whose expected ratio matches the measured one.
///
/// With `x'` the series less its mean, `c0 = Σ x'²/N` and `c1 = Σ x'_k x'_{k+1}/(N − 1)`, `g`
/// is the smaller root of `A g² + B g + C = 0`, `A = c0 N²`,
/// `B = −c1 N − c0 N² − 2 c0 + 2 c1 − c1 N² + c0 N`, `C = N (c0 + c1 N − c1)`. A series for
/// which that root is not real or not inside (−1, 1) (too short, or dominated by a trend) has
/// no stationary AR(1) model and is refused.
pub fn lag1_allen_smith(x: &[f64]) -> Result<f64, AnalysisError> {
    ensure_min_len("lag-1 autocorrelation", 3, x.len())?;
    ensure_finite("autocorrelation input", x)?;
    let m = mean(x);
    let n = x.len() as f64;
    let c0 = x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n;
    if c0 == 0.0 {
        return Err(AnalysisError::InvalidArgument(
            "lag-1 autocorrelation of a constant series is undefined".into(),
        ));
    }
    let c1 = x.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / (n - 1.0);
    let a = c0 * n * n;
    let b = -c1 * n - c0 * n * n - 2.0 * c0 + 2.0 * c1 - c1 * n * n + c0 * n;
    let c = n * (c0 + c1 * n - c1);
    let discriminant = b * b - 4.0 * a * c;
    let g = (-b - discriminant.sqrt()) / (2.0 * a);
    if !(discriminant > 0.0 && g.abs() < 1.0) {
        return Err(AnalysisError::InvalidArgument(
            "the series has no stationary AR(1) model (too short, or dominated by a trend), \
             so its lag-1 autocorrelation cannot be estimated; give the lag-1 coefficient \
             explicitly"
                .into(),
        ));
    }
    Ok(g)
}

/// The lag-1 coefficient by the chosen estimator.
pub fn estimate_lag1(x: &[f64], estimator: Lag1Estimator) -> Result<f64, AnalysisError> {
    match estimator {
        Lag1Estimator::AllenSmith => lag1_allen_smith(x),
        Lag1Estimator::Sample => lag1_autocorrelation(x),
    }
}

/// Two-sided `χ²` quantile with 2 degrees of freedom, `−2 ln(1 − p)` (5.991… at 95 %).
pub fn chi2_2dof_quantile(confidence: f64) -> Result<f64, AnalysisError> {
    ensure_confidence(confidence)?;
    Ok(-2.0 * (1.0 - confidence).ln())
}

/// Quantile of the `χ²` distribution with `dof > 0` degrees of freedom (not necessarily an
/// integer) at probability `p ∈ (0, 1)`: the `x` with `P(dof/2, x/2) = p`, where `P` is the
/// regularised lower incomplete gamma function; found by bisection to a relative 1e-14.
pub fn chi2_quantile(dof: f64, p: f64) -> Result<f64, AnalysisError> {
    ensure_positive("degrees of freedom", dof)?;
    ensure_confidence(p)?;
    let a = dof / 2.0;
    let cdf = |x: f64| regularized_lower_gamma(a, x / 2.0);
    let (mut lo, mut hi) = (0.0, dof.max(1.0));
    while cdf(hi) < p {
        lo = hi;
        hi *= 2.0;
    }
    while hi - lo > 1e-14 * hi {
        let mid = 0.5 * (lo + hi);
        if cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(0.5 * (lo + hi))
}

/// Refuses a confidence level outside the open interval (0, 1).
fn ensure_confidence(confidence: f64) -> Result<(), AnalysisError> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the confidence level must lie in (0, 1), got {confidence}"
        )));
    }
    Ok(())
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
    ensure_lag1(alpha_lag1)?;
    ensure_finite("periods", period_s)?;
    let chi2_half = chi2_2dof_quantile(confidence)? / 2.0;
    period_s
        .iter()
        .map(|&period| {
            ensure_positive("period", period)?;
            Ok(variance * red_noise_spectrum(alpha_lag1, dt_s, period) * chi2_half)
        })
        .collect()
}

/// Global wavelet spectrum: the power of each scale averaged over all times (TC98 eq. 22).
pub fn global_wavelet_spectrum(result: &WaveletResult) -> Vec<f64> {
    result
        .power
        .iter()
        .map(|row| {
            if row.is_empty() {
                f64::NAN
            } else {
                row.iter().sum::<f64>() / row.len() as f64
            }
        })
        .collect()
}

/// Level per scale above which the global spectrum ([`global_wavelet_spectrum`]) is
/// significant against AR(1) red noise (TC98 eqs. 17 and 23): averaging `n_a = N` times gives
/// `ν_j = ν_min·√(1 + (n_a·δt/(γ·s_j))²)` degrees of freedom (`ν_min` = [`MORLET_DOF_MIN`],
/// `γ` = [`MORLET_GAMMA`]), and the level is `variance · P_k(T_j) · χ²_ν(p)/ν`. Pass
/// `variance = 1` for normalised transforms.
pub fn global_significance_ar1(
    result: &WaveletResult,
    variance: f64,
    alpha_lag1: f64,
    confidence: f64,
) -> Result<Vec<f64>, AnalysisError> {
    if !(variance.is_finite() && variance >= 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "variance must be finite and >= 0, got {variance}"
        )));
    }
    ensure_lag1(alpha_lag1)?;
    ensure_confidence(confidence)?;
    let n_avg = result.power.first().map_or(0, Vec::len) as f64;
    let dt = result.dt_s;
    result
        .scales
        .iter()
        .zip(&result.period_s)
        .map(|(&s, &period)| {
            let dof = MORLET_DOF_MIN * (1.0 + (n_avg * dt / (MORLET_GAMMA * s)).powi(2)).sqrt();
            let chi2 = chi2_quantile(dof, confidence)? / dof;
            Ok(variance * red_noise_spectrum(alpha_lag1, dt, period) * chi2)
        })
        .collect()
}

/// Normalised AR(1) spectrum `(1 − a²)/(1 + a² − 2a cos(2π δt/T))` at period `T` (TC98 eq. 16).
fn red_noise_spectrum(a: f64, dt_s: f64, period_s: f64) -> f64 {
    (1.0 - a * a) / (1.0 + a * a - 2.0 * a * (TAU * dt_s / period_s).cos())
}

/// Refuses a lag-1 coefficient that is not finite or outside (−1, 1).
fn ensure_lag1(alpha_lag1: f64) -> Result<(), AnalysisError> {
    if !(alpha_lag1.is_finite() && alpha_lag1.abs() < 1.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the lag-1 autocorrelation must lie in (-1, 1) for a stationary AR(1) background, \
             got {alpha_lag1}"
        )));
    }
    Ok(())
}

/// Regularised lower incomplete gamma function `P(a, x)`, `a > 0`, `x ≥ 0`: its power series
/// below `x = a + 1`, one minus the continued fraction of `Q(a, x)` above (Numerical Recipes'
/// split, each converging fast on its side).
fn regularized_lower_gamma(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let log_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (sum * log_prefactor.exp()).min(1.0)
    } else {
        1.0 - upper_gamma_fraction(a, x) * log_prefactor.exp()
    }
}

/// Continued fraction of `Q(a, x)·Γ(a)·e^x·x^{−a}` by the modified Lentz method.
fn upper_gamma_fraction(a: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..10_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < TINY {
            d = TINY;
        }
        c = b + an / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h
}

/// `ln Γ(x)` for `x > 0`: Lanczos' approximation (`g = 7`, nine terms, ~1e-15 relative),
/// with the reflection formula below one half.
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let z = x - 1.0;
    let series = C[1..]
        .iter()
        .enumerate()
        .fold(C[0], |acc, (i, c)| acc + c / (z + i as f64 + 1.0));
    let t = z + G + 0.5;
    0.5 * (2.0 * PI).ln() + (z + 0.5) * t.ln() - t + series.ln()
}

/// Variance of the transformed series recovered from its power (TC98 eq. 14):
/// `σ² = δj·δt/(Cδ·N) Σ_n Σ_j |W_n(s_j)|²/s_j`. Equals 1 for a normalised transform up to the
/// discretisation error (a few percent); a check that the scale range covers the signal.
/// Needs the tabulated `Cδ`, so `ω0 = 6`.
pub fn reconstruct_variance(result: &WaveletResult) -> Result<f64, AnalysisError> {
    let c_delta = tabulated_c_delta(&result.mother)?;
    let n = result.power.first().map_or(0, Vec::len);
    if n == 0 {
        return Ok(0.0);
    }
    let sum: f64 = result
        .power
        .iter()
        .zip(&result.scales)
        .map(|(row, s)| row.iter().sum::<f64>() / s)
        .sum();
    Ok(result.dj * result.dt_s / (c_delta * n as f64) * sum)
}

/// The transformed series rebuilt from the real part of its coefficients (TC98 eq. 11):
/// `x_n = δj·δt^{1/2}/(Cδ·ψ0(0)) Σ_j Re W_n(s_j)/s_j^{1/2}`, `ψ0(0) = π^{−1/4}`.
/// Needs the tabulated `Cδ`, so `ω0 = 6`.
pub fn reconstruct_signal(result: &WaveletResult) -> Result<Vec<f64>, AnalysisError> {
    let c_delta = tabulated_c_delta(&result.mother)?;
    let n = result.coefficients.first().map_or(0, Vec::len);
    let psi0_at_zero = PI.powf(-0.25);
    let factor = result.dj * result.dt_s.sqrt() / (c_delta * psi0_at_zero);
    let mut out = vec![0.0; n];
    for (row, s) in result.coefficients.iter().zip(&result.scales) {
        let weight = factor / s.sqrt();
        for (o, w) in out.iter_mut().zip(row) {
            *o += weight * w.re;
        }
    }
    Ok(out)
}

/// `Cδ` of the mother wavelet, or an error naming the one case TC98 tabulates.
fn tabulated_c_delta(mother: &MotherWavelet) -> Result<f64, AnalysisError> {
    mother.c_delta().ok_or_else(|| {
        AnalysisError::InvalidArgument(format!(
            "reconstruction needs the factor C_delta, tabulated only for the Morlet wavelet \
             with omega0 = {MORLET_OMEGA0}; this transform used {}",
            mother.name()
        ))
    })
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

/// Most wavelet coefficients (scales × samples) one transform computes: 2 GiB of complex
/// values.
pub(crate) const MAX_WAVELET_CELLS: usize = 1 << 27;

/// Scales `s0·2^{j·δj}`, `j = 0…J`, with pycwt's defaults for `s0` and `J`.
///
/// Refused: an `s0` whose Fourier period is below `2δt` (shorter than the Nyquist period, so
/// aliased) or whose scale exceeds the record `N·δt`, and a `J` that carries the largest
/// scale beyond the record (the default `J` ends there), and more than
/// [`MAX_WAVELET_CELLS`] coefficients.
fn scale_ladder(n: usize, dt_s: f64, options: &WaveletOptions) -> Result<Vec<f64>, AnalysisError> {
    let lambda = options.mother.fourier_factor();
    let s0_min = 2.0 * dt_s / lambda;
    let s0 = options.s0.unwrap_or(s0_min);
    let span = n as f64 * dt_s;
    if s0_min > span {
        let MotherWavelet::Morlet { omega0 } = options.mother;
        return Err(AnalysisError::InvalidArgument(format!(
            "the Morlet wavelet with omega0 = {omega0} resolves two steps of {dt_s} s only at              scales of {s0_min} s and longer, beyond the {span} s record: lower omega0 (its              default is 6) or analyse a longer record"
        )));
    }
    if !(s0.is_finite() && s0 >= s0_min * (1.0 - 1e-12) && s0 <= span) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the smallest wavelet scale s0 must lie in [{s0_min}, {span}] s (a Fourier period \
             of at least two steps of {dt_s} s, a scale no longer than the record), got {s0}"
        )));
    }
    let j_default = ((span / s0).log2() / options.dj).round().max(0.0) as usize;
    let j_max = options.j.unwrap_or(j_default);
    let cells = (j_max as f64 + 1.0) * n as f64;
    if cells > MAX_WAVELET_CELLS as f64 {
        return Err(AnalysisError::InvalidArgument(format!(
            "{} scales of {n} samples would hold {cells:.3e} wavelet coefficients, more than the \
             {MAX_WAVELET_CELLS} the transform takes (16 bytes each): raise dj (now {}), lower J, \
             or analyse a shorter or coarser record",
            j_max as f64 + 1.0,
            options.dj
        )));
    }
    if j_max > j_default {
        return Err(AnalysisError::InvalidArgument(format!(
            "the number of wavelet scales J must lie in [0, {j_default}] for s0 = {s0} s and \
             dj = {}: a larger J reaches scales longer than the {span} s record, got {j_max}",
            options.dj
        )));
    }
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
    mother: &MotherWavelet,
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
                *b = x * (norm * mother.fourier_transform(s * w));
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

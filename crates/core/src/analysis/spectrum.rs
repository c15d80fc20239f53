//! One-sided amplitude spectra (paper Figs. 3–5) and naming the dominant response frequency as
//! a simple fraction of the forcing (the paper's 8 Hz → 2.7 Hz is a 1/3 subharmonic).

use std::f64::consts::TAU;

use num_complex::Complex64;
use rustfft::FftPlanner;
use serde::Serialize;

use super::checks::{ensure_finite, ensure_min_len, ensure_positive, mean};
use super::error::AnalysisError;

/// Shortest record for which a spectrum has more than a DC bin and one neighbour.
pub const SPECTRUM_MIN_SAMPLES: usize = 4;
/// Largest denominator tried when naming a frequency ratio.
pub const RATIO_MAX_DENOMINATOR: u32 = 8;
/// Default relative tolerance between a measured ratio and the fraction that names it.
pub const RATIO_REL_TOL: f64 = 0.02;

/// One-sided amplitude spectrum: a sine of amplitude `a` on a bin shows a peak of height `a`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Spectrum {
    /// Bin frequencies `k·fs/N`, `k = 0…⌊N/2⌋`, in Hz.
    pub frequency_hz: Vec<f64>,
    /// Amplitude per bin, in the units of the signal.
    pub amplitude: Vec<f64>,
}

/// The strongest non-DC component, located between bins.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SpectralPeak {
    /// Interpolated peak frequency, in Hz.
    pub frequency_hz: f64,
    /// Interpolated peak amplitude, in the units of the signal.
    pub amplitude: f64,
}

/// A frequency ratio and the simple fraction that names it, if any.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RatioReport {
    /// `f_dominant / f_forcing`.
    pub ratio: f64,
    /// The nearest `p/q` (reduced, `q ≤ 8`) within tolerance.
    pub fraction: Option<(u32, u32)>,
    /// `"p/q"`, or `"incommensurate"` when no simple fraction is close enough.
    pub label: String,
}

/// Amplitude spectrum of the uniformly sampled `x` after removing its mean, with a periodic
/// Hann window `w_n = ½(1 − cos 2πn/N)` against leakage, scaled by the coherent gain `2/Σw`
/// (`1/Σw` at DC and at an even length's Nyquist bin), so a sine's peak has its amplitude.
pub fn amplitude_spectrum(x: &[f64], sample_rate_hz: f64) -> Result<Spectrum, AnalysisError> {
    ensure_min_len("amplitude spectrum", SPECTRUM_MIN_SAMPLES, x.len())?;
    ensure_finite("spectrum input", x)?;
    ensure_positive("sample_rate_hz", sample_rate_hz)?;
    let n = x.len();
    let m = mean(x);
    let window: Vec<f64> = (0..n).map(|i| hann(i, n)).collect();
    let window_sum: f64 = window.iter().sum();
    let mut buf: Vec<Complex64> = x
        .iter()
        .zip(&window)
        .map(|(&v, &w)| Complex64::new((v - m) * w, 0.0))
        .collect();
    FftPlanner::<f64>::new()
        .plan_fft_forward(n)
        .process(&mut buf);
    let bins = n / 2 + 1;
    let amplitude = (0..bins)
        .map(|k| one_sided_factor(k, n) * buf[k].norm() / window_sum)
        .collect();
    let frequency_hz = (0..bins)
        .map(|k| k as f64 * sample_rate_hz / n as f64)
        .collect();
    Ok(Spectrum {
        frequency_hz,
        amplitude,
    })
}

/// The largest non-DC peak, refined by a parabola through the log amplitudes of the peak bin
/// and its neighbours (exact for a Gaussian peak, within a few hundredths of a bin for Hann).
/// `None` when the spectrum has no non-DC bin or is zero everywhere.
pub fn dominant_peak(spectrum: &Spectrum) -> Option<SpectralPeak> {
    let a = &spectrum.amplitude;
    let f = &spectrum.frequency_hz;
    if a.len() < 2 || f.len() != a.len() {
        return None;
    }
    let k = (1..a.len()).max_by(|&i, &j| a[i].total_cmp(&a[j]))?;
    if a[k].is_nan() || a[k] <= 0.0 {
        return None;
    }
    let bin_hz = f[1] - f[0];
    let (shift, amplitude) = match (a.get(k - 1), a.get(k + 1)) {
        (Some(&l), Some(&r)) if l > 0.0 && r > 0.0 => log_parabola_vertex(l, a[k], r),
        _ => (0.0, a[k]),
    };
    Some(SpectralPeak {
        frequency_hz: f[k] + shift * bin_hz,
        amplitude,
    })
}

/// Names `f_dominant_hz / f_forcing_hz` as the nearest reduced fraction `p/q`, `q ≤ 8`, within
/// the relative tolerance [`RATIO_REL_TOL`]; "incommensurate" otherwise.
pub fn ratio_to_forcing(
    f_dominant_hz: f64,
    f_forcing_hz: f64,
) -> Result<RatioReport, AnalysisError> {
    ratio_to_forcing_within(f_dominant_hz, f_forcing_hz, RATIO_REL_TOL)
}

/// [`ratio_to_forcing`] with an explicit relative tolerance `|r − p/q| ≤ rel_tol·p/q`; among
/// fractions within tolerance the closest wins, the smaller denominator on a tie.
pub fn ratio_to_forcing_within(
    f_dominant_hz: f64,
    f_forcing_hz: f64,
    rel_tol: f64,
) -> Result<RatioReport, AnalysisError> {
    ensure_positive("f_forcing_hz", f_forcing_hz)?;
    if !(f_dominant_hz.is_finite() && f_dominant_hz >= 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the dominant frequency must be finite and >= 0 Hz, got {f_dominant_hz}"
        )));
    }
    if !(rel_tol.is_finite() && rel_tol >= 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the relative tolerance of a line match must be finite and >= 0, got {rel_tol}"
        )));
    }
    let ratio = f_dominant_hz / f_forcing_hz;
    let fraction = nearest_simple_fraction(ratio, rel_tol);
    let label = match fraction {
        Some((p, q)) => format!("{p}/{q}"),
        None => "incommensurate".to_string(),
    };
    Ok(RatioReport {
        ratio,
        fraction,
        label,
    })
}

/// The reduced `p/q` (`p ≥ 1`, `q ≤ 8`) closest to `ratio` in relative terms, if within `rel_tol`.
fn nearest_simple_fraction(ratio: f64, rel_tol: f64) -> Option<(u32, u32)> {
    let mut best: Option<((u32, u32), f64)> = None;
    for q in 1..=RATIO_MAX_DENOMINATOR {
        let p = (ratio * q as f64).round();
        if p < 1.0 || p > u32::MAX as f64 || gcd(p as u32, q) != 1 {
            continue;
        }
        let value = p / q as f64;
        let err = (ratio - value).abs() / value;
        if err <= rel_tol && best.is_none_or(|(_, e)| err < e) {
            best = Some(((p as u32, q), err));
        }
    }
    best.map(|(f, _)| f)
}

/// Greatest common divisor, to keep only reduced fractions.
fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// Periodic (DFT-even) Hann window value at sample `i` of `n`.
fn hann(i: usize, n: usize) -> f64 {
    0.5 * (1.0 - (TAU * i as f64 / n as f64).cos())
}

/// 2 for bins that stand for a positive and a negative frequency, 1 for DC and Nyquist.
fn one_sided_factor(k: usize, n: usize) -> f64 {
    if k == 0 || (n.is_multiple_of(2) && k == n / 2) {
        1.0
    } else {
        2.0
    }
}

/// Vertex `(offset in bins, value)` of the parabola through `ln l, ln c, ln r` at −1, 0, 1.
fn log_parabola_vertex(l: f64, c: f64, r: f64) -> (f64, f64) {
    let (ll, lc, lr) = (l.ln(), c.ln(), r.ln());
    let curvature = ll - 2.0 * lc + lr;
    if curvature >= 0.0 {
        return (0.0, c);
    }
    let shift = 0.5 * (ll - lr) / curvature;
    let log_peak = lc - 0.25 * (ll - lr) * shift;
    (shift, log_peak.exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_parabola_finds_a_gaussian_vertex() {
        let g = |x: f64| 3.0 * (-(x - 0.3f64).powi(2) / 2.0).exp();
        let (shift, peak) = log_parabola_vertex(g(-1.0), g(0.0), g(1.0));
        assert!((shift - 0.3).abs() < 1e-12 && (peak - 3.0).abs() < 1e-12);
    }

    #[test]
    fn fractions_are_reduced_and_nearest() {
        assert_eq!(nearest_simple_fraction(0.5, 0.02), Some((1, 2)));
        assert_eq!(nearest_simple_fraction(2.5, 0.02), Some((5, 2)));
        assert_eq!(nearest_simple_fraction(0.155, 0.02), None);
    }
}

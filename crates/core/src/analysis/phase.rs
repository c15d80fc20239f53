//! Phase synchronisation between two signals (paper eqs. 11–12): instantaneous phases from the
//! analytic signal, their difference, the index `R = |mean exp(iΔφ)|` and the histogram of
//! `Δφ` (the paper's Fig. 7).
//!
//! Two conventions exist for `Δφ` and they give different "random" values of `R`, so every
//! result says which one produced it.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use num_complex::Complex64;
use rustfft::FftPlanner;
use serde::Serialize;

use super::checks::{ensure_finite, ensure_min_len, ensure_same_len, mean};
use super::error::AnalysisError;

/// Shortest signal for which a Hilbert phase is worth computing.
pub const PHASE_MIN_SAMPLES: usize = 8;

/// How the phase difference is reduced before averaging.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PhaseConvention {
    /// `Δφ` wrapped to `(−π, π]` (Mormann et al. 2000): independent phases give `R → 0`.
    Standard,
    /// `Δφ` reduced modulo π into `[−π/2, π/2)` as the paper does: independent phases give
    /// `R → 2/π ≈ 0.64`, the paper's "random" value.
    Paper,
}

impl PhaseConvention {
    /// The interval `Δφ` lives in under this convention, in radians.
    pub fn range_rad(self) -> (f64, f64) {
        match self {
            PhaseConvention::Standard => (-PI, PI),
            PhaseConvention::Paper => (-FRAC_PI_2, FRAC_PI_2),
        }
    }

    /// Reduces a raw phase difference into this convention's interval.
    pub fn wrap(self, delta_rad: f64) -> f64 {
        match self {
            PhaseConvention::Standard => {
                let w = delta_rad.rem_euclid(TAU);
                if w > PI { w - TAU } else { w }
            }
            PhaseConvention::Paper => {
                let w = (delta_rad + FRAC_PI_2).rem_euclid(PI) - FRAC_PI_2;
                if w >= FRAC_PI_2 { w - PI } else { w }
            }
        }
    }
}

/// Synchronisation index and the phase differences it was computed from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhaseSyncResult {
    /// `R = |mean_k exp(iΔφ_k)|`, 1 for locked phases.
    pub r: f64,
    /// Convention used to reduce `Δφ` (it changes the value of `R` for unrelated signals).
    pub convention: PhaseConvention,
    /// `Δφ_k = φ2_k − φ1_k`, reduced per `convention`, in radians.
    pub delta_phi_rad: Vec<f64>,
}

/// Probability density of `Δφ` over the convention's interval (the paper's Fig. 7).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhaseHistogram {
    /// Bin edges, `bins + 1` values spanning the convention's interval, in radians.
    pub edges_rad: Vec<f64>,
    /// Density per bin, in 1/rad; `Σ density·width = 1`.
    pub density_per_rad: Vec<f64>,
}

/// The analytic signal of `x − mean(x)`: FFT, keep DC, double positive frequencies, keep the
/// Nyquist bin of an even length once, zero the negative frequencies, inverse FFT, divide by N.
///
/// Identical to `scipy.signal.hilbert(x − mean(x))`. Its argument is the instantaneous phase.
/// Non-finite input propagates into the output; validated callers use [`phase_sync`].
pub fn analytic_signal(x: &[f64]) -> Vec<Complex64> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let m = mean(x);
    let mut buf: Vec<Complex64> = x.iter().map(|&v| Complex64::new(v - m, 0.0)).collect();
    let mut planner = FftPlanner::<f64>::new();
    planner.plan_fft_forward(n).process(&mut buf);
    for (k, z) in buf.iter_mut().enumerate() {
        *z *= hilbert_weight(k, n);
    }
    planner.plan_fft_inverse(n).process(&mut buf);
    let scale = 1.0 / n as f64;
    buf.iter_mut().for_each(|z| *z *= scale);
    buf
}

/// Instantaneous phase `arg(analytic_signal(x))`, in radians on `(−π, π]`.
pub fn instantaneous_phase(x: &[f64]) -> Vec<f64> {
    analytic_signal(x).iter().map(|z| z.arg()).collect()
}

/// Phase-synchronisation index of `x2` relative to `x1` (for simulations: cart position and
/// holder angle), with `Δφ = φ2 − φ1` reduced per `convention`.
pub fn phase_sync(
    x1: &[f64],
    x2: &[f64],
    convention: PhaseConvention,
) -> Result<PhaseSyncResult, AnalysisError> {
    ensure_same_len("phase_sync signals", x1.len(), x2.len())?;
    ensure_min_len("phase synchronisation", PHASE_MIN_SAMPLES, x1.len())?;
    ensure_finite("phase_sync x1", x1)?;
    ensure_finite("phase_sync x2", x2)?;
    let delta_phi_rad: Vec<f64> = instantaneous_phase(x1)
        .iter()
        .zip(instantaneous_phase(x2))
        .map(|(p1, p2)| convention.wrap(p2 - p1))
        .collect();
    Ok(PhaseSyncResult {
        r: mean_resultant_length(&delta_phi_rad),
        convention,
        delta_phi_rad,
    })
}

/// `|mean_k exp(iθ_k)|` for non-empty `θ`.
fn mean_resultant_length(theta: &[f64]) -> f64 {
    let (s, c) = theta
        .iter()
        .fold((0.0, 0.0), |(s, c), t| (s + t.sin(), c + t.cos()));
    (s * s + c * c).sqrt() / theta.len() as f64
}

/// Density histogram of phase differences over the convention's interval with `bins` equal
/// bins. Values are first reduced per `convention`, so raw differences are accepted too.
pub fn phase_histogram(
    delta_phi_rad: &[f64],
    bins: usize,
    convention: PhaseConvention,
) -> Result<PhaseHistogram, AnalysisError> {
    if bins == 0 {
        return Err(AnalysisError::InvalidArgument(
            "the phase histogram needs at least 1 bin".into(),
        ));
    }
    ensure_min_len("phase histogram", 1, delta_phi_rad.len())?;
    ensure_finite("phase differences", delta_phi_rad)?;
    let (lo, hi) = convention.range_rad();
    let width = (hi - lo) / bins as f64;
    let mut counts = vec![0usize; bins];
    for &d in delta_phi_rad {
        let bin = ((convention.wrap(d) - lo) / width).floor() as usize;
        counts[bin.min(bins - 1)] += 1;
    }
    let norm = 1.0 / (delta_phi_rad.len() as f64 * width);
    Ok(PhaseHistogram {
        edges_rad: (0..=bins).map(|i| lo + i as f64 * width).collect(),
        density_per_rad: counts.iter().map(|&c| c as f64 * norm).collect(),
    })
}

/// scipy's `h`: 1 at DC (and at Nyquist for even N), 2 on positive frequencies, 0 elsewhere.
fn hilbert_weight(k: usize, n: usize) -> f64 {
    if k == 0 || (n.is_multiple_of(2) && k == n / 2) {
        1.0
    } else if k < n.div_ceil(2) {
        2.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hilbert_weights_match_scipy() {
        let even: Vec<f64> = (0..6).map(|k| hilbert_weight(k, 6)).collect();
        assert_eq!(even, vec![1.0, 2.0, 2.0, 1.0, 0.0, 0.0]);
        let odd: Vec<f64> = (0..5).map(|k| hilbert_weight(k, 5)).collect();
        assert_eq!(odd, vec![1.0, 2.0, 2.0, 0.0, 0.0]);
    }

    #[test]
    fn wrapping_stays_in_range() {
        for i in -100..=100 {
            let d = i as f64 * 0.173;
            let s = PhaseConvention::Standard.wrap(d);
            let p = PhaseConvention::Paper.wrap(d);
            assert!(s > -PI && s <= PI, "{d} -> {s}");
            assert!((-FRAC_PI_2..FRAC_PI_2).contains(&p), "{d} -> {p}");
        }
        assert_eq!(PhaseConvention::Standard.wrap(PI), PI);
        assert_eq!(PhaseConvention::Paper.wrap(FRAC_PI_2), -FRAC_PI_2);
    }
}

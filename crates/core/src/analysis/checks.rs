//! Input validation and small statistics shared by every analysis module, so each public
//! function refuses bad input the same way and with the same messages.

use super::error::AnalysisError;

/// Refuses a series shorter than `needed`.
pub(crate) fn ensure_min_len(
    method: &'static str,
    needed: usize,
    got: usize,
) -> Result<(), AnalysisError> {
    if got < needed {
        return Err(AnalysisError::TooFewSamples {
            method,
            needed,
            got,
        });
    }
    Ok(())
}

/// Refuses a series holding NaN or infinity, naming the first bad index.
pub(crate) fn ensure_finite(what: &str, x: &[f64]) -> Result<(), AnalysisError> {
    match x.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(AnalysisError::NonFinite {
            what: what.to_string(),
            index,
        }),
        None => Ok(()),
    }
}

/// Refuses two series that must pair sample by sample but differ in length.
pub(crate) fn ensure_same_len(
    what: &'static str,
    left: usize,
    right: usize,
) -> Result<(), AnalysisError> {
    if left != right {
        return Err(AnalysisError::LengthMismatch { what, left, right });
    }
    Ok(())
}

/// Refuses a scalar argument that is not finite and strictly positive.
pub(crate) fn ensure_positive(name: &str, value: f64) -> Result<(), AnalysisError> {
    if !(value.is_finite() && value > 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "{name} must be finite and > 0, got {value}"
        )));
    }
    Ok(())
}

/// Refuses a scalar argument that is NaN or infinite.
pub(crate) fn ensure_finite_arg(name: &str, value: f64) -> Result<(), AnalysisError> {
    if !value.is_finite() {
        return Err(AnalysisError::InvalidArgument(format!(
            "{name} must be finite, got {value}"
        )));
    }
    Ok(())
}

/// Arithmetic mean; callers guarantee a non-empty slice.
pub(crate) fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len() as f64
}

/// Population variance (divides by N, as numpy's default `std`), about the mean.
pub(crate) fn population_variance(x: &[f64]) -> f64 {
    let m = mean(x);
    x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64
}

/// Median by sorting a copy; the mean of the two middle values for an even count (as Matlab).
pub(crate) fn median(x: &[f64]) -> f64 {
    let mut sorted = x.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        sorted[n / 2]
    } else {
        0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
    }
}

/// Relative range `(max − min)/max|x|` at or below which a record counts as constant.
///
/// `1e-9` lies far above the rounding noise of a computed signal at rest (an integrator holding
/// an equilibrium jitters by ~1e-15 relative) and far below any measured motion (a 24-bit
/// converter resolves 6e-8 of its full scale), so a record under it is flat in every practical
/// sense: its standard deviation is rounding noise, and normalising by it would blow that noise
/// up into spectra, wavelet power and phases of pure artefacts.
pub const FLAT_SIGNAL_REL_RANGE: f64 = 1e-9;

/// Smallest and largest value of a non-empty slice.
pub(crate) fn min_max(x: &[f64]) -> (f64, f64) {
    x.iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        })
}

/// True when the range of `x` is at most `rel_range` times its largest magnitude (an
/// all-zero series included).
pub(crate) fn is_flat(x: &[f64], rel_range: f64) -> bool {
    let (lo, hi) = min_max(x);
    hi - lo <= rel_range * lo.abs().max(hi.abs())
}

/// Refuses a non-empty, finite series whose variance overflows or which is constant to within
/// [`FLAT_SIGNAL_REL_RANGE`]: every indicator of a record measures its variation.
pub(crate) fn ensure_varying(what: &str, x: &[f64]) -> Result<(), AnalysisError> {
    if !population_variance(x).is_finite() {
        let max_abs = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        return Err(AnalysisError::Overflow {
            what: what.to_string(),
            max_abs,
        });
    }
    if is_flat(x, FLAT_SIGNAL_REL_RANGE) {
        return Err(AnalysisError::ConstantSignal {
            what: what.to_string(),
            value: x[0],
            rel_range: FLAT_SIGNAL_REL_RANGE,
        });
    }
    Ok(())
}

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

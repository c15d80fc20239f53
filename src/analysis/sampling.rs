//! Turning a response into the series each indicator expects: stroboscopic sections (one
//! sample per forcing period, the natural section of a forced system), local extrema (the
//! paper's choice for Fig. 6) and uniform resampling (for spectra, wavelets and phases).
//!
//! Every resampling here uses **linear interpolation between the two bracketing samples**:
//! it is exact for the piecewise-linear reading of the data, needs no extra assumption on
//! smoothness (impacts make the response non-smooth), and its error is O(dt²·|ẍ|).

use std::f64::consts::TAU;

use super::checks::{
    ensure_finite, ensure_finite_arg, ensure_min_len, ensure_positive, ensure_same_len,
};
use super::error::AnalysisError;

/// Samples `x(t)` once per forcing period, at the fixed forcing phase `phase_rad`, after the
/// transient.
///
/// Sample times are `t_k = (k + phase_rad/2π) / forcing_hz` for every integer `k` with
/// `t[0] + transient_s ≤ t_k ≤ t[last]`; the transient is counted from the first time stamp.
/// Values come from linear interpolation between the bracketing samples, so `t` need not be
/// uniform, only strictly increasing.
pub fn stroboscopic(
    t: &[f64],
    x: &[f64],
    forcing_hz: f64,
    phase_rad: f64,
    transient_s: f64,
) -> Result<Vec<f64>, AnalysisError> {
    validate_record(t, x)?;
    ensure_positive("forcing_hz", forcing_hz)?;
    ensure_finite_arg("phase_rad", phase_rad)?;
    ensure_finite_arg("transient_s", transient_s)?;
    let times = strobe_times(t[0] + transient_s, t[t.len() - 1], forcing_hz, phase_rad);
    Ok(interpolate_at(t, x, &times))
}

/// [`stroboscopic`] for a uniformly sampled record starting at `start_time_s`, so callers
/// holding only samples and a rate need not build the time axis.
pub fn stroboscopic_uniform(
    x: &[f64],
    sample_rate_hz: f64,
    start_time_s: f64,
    forcing_hz: f64,
    phase_rad: f64,
    transient_s: f64,
) -> Result<Vec<f64>, AnalysisError> {
    ensure_positive("sample_rate_hz", sample_rate_hz)?;
    ensure_finite_arg("start_time_s", start_time_s)?;
    let t = uniform_axis(start_time_s, sample_rate_hz, x.len());
    stroboscopic(&t, x, forcing_hz, phase_rad, transient_s)
}

/// Values of the strict local maxima and minima of `x`, in time order.
///
/// A plateau (a run of equal samples) counts once, with its value, when it is higher (or
/// lower) than the samples on both sides; a plateau that is a step (higher on one side,
/// lower on the other) is no extremum. The end points are never extrema, since one
/// neighbour is unknown.
pub fn local_extrema(x: &[f64]) -> Result<Vec<f64>, AnalysisError> {
    ensure_finite("local_extrema input", x)?;
    let mut out = Vec::new();
    let Some((&first, rest)) = x.split_first() else {
        return Ok(out);
    };
    let mut before: Option<f64> = None;
    let mut run = first;
    for &v in rest {
        if v == run {
            continue;
        }
        if before.is_some_and(|b| (run - b) * (run - v) > 0.0) {
            out.push(run);
        }
        before = Some(run);
        run = v;
    }
    Ok(out)
}

/// Checks that `t` is strictly increasing with a constant step, and returns that step.
///
/// The step is the mean step `(t[last] − t[0])/(N − 1)`; every individual step must lie within
/// `rel_tol` of it (relative). Spectra and wavelets assume a uniform step, so measured data
/// with jitter or gaps must be refused (or resampled with [`resample_uniform`]).
pub fn check_uniform_time(t: &[f64], rel_tol: f64) -> Result<f64, AnalysisError> {
    ensure_min_len("check_uniform_time", 2, t.len())?;
    ensure_finite("time stamps", t)?;
    if !(rel_tol.is_finite() && rel_tol >= 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "rel_tol must be finite and >= 0, got {rel_tol}"
        )));
    }
    ensure_increasing(t)?;
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    for (i, w) in t.windows(2).enumerate() {
        let step_s = w[1] - w[0];
        if (step_s - dt).abs() > rel_tol * dt {
            return Err(AnalysisError::NonUniformTime {
                index: i + 1,
                step_s,
                expected_s: dt,
                rel_tol,
            });
        }
    }
    Ok(dt)
}

/// Resamples `x(t)` on the uniform grid `t[0] + i/rate_hz` up to `t[last]`, by linear
/// interpolation between bracketing samples. Returns `(times, values)`.
pub fn resample_uniform(
    t: &[f64],
    x: &[f64],
    rate_hz: f64,
) -> Result<(Vec<f64>, Vec<f64>), AnalysisError> {
    validate_record(t, x)?;
    ensure_positive("rate_hz", rate_hz)?;
    let span_s = t[t.len() - 1] - t[0];
    let count = (span_s * rate_hz * (1.0 + 1e-12)).floor() as usize + 1;
    let times = uniform_axis(t[0], rate_hz, count);
    let values = interpolate_at(t, x, &times);
    Ok((times, values))
}

/// Shared checks for a `(t, x)` record: equal lengths, at least two samples, finite values and
/// strictly increasing time.
fn validate_record(t: &[f64], x: &[f64]) -> Result<(), AnalysisError> {
    ensure_same_len("time stamps and samples", t.len(), x.len())?;
    ensure_min_len("interpolation", 2, t.len())?;
    ensure_finite("time stamps", t)?;
    ensure_finite("samples", x)?;
    ensure_increasing(t)
}

/// Refuses time stamps that repeat or go backwards, naming the first offender.
fn ensure_increasing(t: &[f64]) -> Result<(), AnalysisError> {
    match t.windows(2).position(|w| w[1] <= w[0]) {
        Some(i) => Err(AnalysisError::NonIncreasingTime {
            index: i + 1,
            previous_s: t[i],
            current_s: t[i + 1],
        }),
        None => Ok(()),
    }
}

/// `start + i/rate` for `i = 0..count`, computed by multiplication to avoid drift.
fn uniform_axis(start_s: f64, rate_hz: f64, count: usize) -> Vec<f64> {
    (0..count).map(|i| start_s + i as f64 / rate_hz).collect()
}

/// The stroboscopic instants `(k + phase/2π)/f` inside `[from_s, to_s]`.
///
/// A tiny relative slack at the end keeps an instant that lands on the last stamp up to
/// rounding; it is clamped to `to_s` by the interpolation.
fn strobe_times(from_s: f64, to_s: f64, forcing_hz: f64, phase_rad: f64) -> Vec<f64> {
    let offset = phase_rad / TAU;
    let slack = 1e-9 / forcing_hz;
    let first_k = (from_s * forcing_hz - offset).ceil();
    let mut times = Vec::new();
    let mut k = first_k;
    loop {
        let tk = (k + offset) / forcing_hz;
        if tk > to_s + slack {
            break;
        }
        if tk >= from_s {
            times.push(tk.min(to_s));
        }
        k += 1.0;
    }
    times
}

/// Linear interpolation of `x(t)` at increasing query times inside `[t[0], t[last]]`, walking
/// one cursor forward so the cost is O(N + queries).
fn interpolate_at(t: &[f64], x: &[f64], queries: &[f64]) -> Vec<f64> {
    let mut i = 0;
    let last = t.len() - 1;
    queries
        .iter()
        .map(|&tq| {
            while i + 1 < last && t[i + 1] <= tq {
                i += 1;
            }
            let w = ((tq - t[i]) / (t[i + 1] - t[i])).clamp(0.0, 1.0);
            x[i] + w * (x[i + 1] - x[i])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_is_exact_on_a_line() {
        let t = [0.0, 0.5, 2.0, 3.0];
        let x: Vec<f64> = t.iter().map(|v| 2.0 * v + 1.0).collect();
        let y = interpolate_at(&t, &x, &[0.0, 0.25, 1.0, 2.5, 3.0]);
        assert_eq!(y, vec![1.0, 1.5, 3.0, 6.0, 7.0]);
    }

    #[test]
    fn strobe_times_respect_phase_and_bounds() {
        let times = strobe_times(1.0, 3.0, 1.0, std::f64::consts::PI);
        assert_eq!(times, vec![1.5, 2.5]);
    }
}

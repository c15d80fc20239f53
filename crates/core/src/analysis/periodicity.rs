//! Per-instance statistics of a response that the parameter-grid maps show: the period of the
//! stroboscopic section, hops between the two potential wells, RMS and range.

use serde::Serialize;

use super::checks::{ensure_finite, ensure_min_len};
use super::error::AnalysisError;
use crate::rules::{Float, shared_rules};

/// Which side of the upright position the holder leans to, for hop counting.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Well {
    /// α above `+θc/2`.
    Positive,
    /// α below `−θc/2`.
    Negative,
}

impl Well {
    /// The well of a side code of [`well_side`] (`None` for 0).
    fn of_side(side: i32) -> Option<Well> {
        match side {
            1 => Some(Well::Positive),
            -1 => Some(Well::Negative),
            _ => None,
        }
    }

    /// The side code of a well (0 for none yet).
    fn side(well: Option<Well>) -> i32 {
        match well {
            Some(Well::Positive) => 1,
            Some(Well::Negative) => -1,
            None => 0,
        }
    }
}

shared_rules! {
    /// The side of the hysteresis band ±`half` (θc/2) a sample `alpha` is on: 1 above it, −1
    /// below it, 0 inside it (and for a NaN).
    pub(crate) fn well_side(alpha: Float, half: Float) -> i32 {
        if alpha > half {
            return 1;
        } else if alpha < -half {
            return -1;
        }
        return 0;
    }

    /// Whether a sample on side `side` hopped: it entered the well other than `last`, the
    /// well last visited (0: none yet, so the first well entered is not a hop).
    pub(crate) fn is_hop(last: i32, side: i32) -> bool {
        return side != 0 && last != 0 && last != side;
    }

    /// The well last visited after a sample on side `side`: that side, or `last` from inside
    /// the band.
    pub(crate) fn next_well(last: i32, side: i32) -> i32 {
        if side != 0 {
            return side;
        }
        return last;
    }
}

/// The well a sample `alpha` (rad) is in, with the hysteresis band `±half` (θc/2): `None`
/// inside the band (and for a NaN), where the current well is kept.
pub fn well_of(alpha: f64, half: f64) -> Option<Well> {
    Well::of_side(well_side(alpha, half))
}

/// One sample of the hop count: the well after `alpha` from `current`, and whether the sample
/// hopped (entered the other well; the first well entered is not a hop). The one rule of
/// [`hops`] and of the engines' running count.
pub fn hop_step(current: Option<Well>, alpha: f64, half: f64) -> (Option<Well>, bool) {
    let (last, side) = (Well::side(current), well_side(alpha, half));
    (Well::of_side(next_well(last, side)), is_hop(last, side))
}

/// Smallest period `p ∈ 1…p_max` of the stroboscopic samples, or 0 when none fits (aperiodic,
/// quasi-periodic, or too short a record).
///
/// Tolerance rule: over the last `m` samples every `|x[k] − x[k−p]| ≤ tol · max(1, scale)`,
/// `scale = max |x|` over those `m` samples. The tolerance is thus absolute for signals of
/// order one (angles in radians) and relative for large ones. A period `p` is checked only if
/// the record holds `m + p` samples. Non-finite samples never match (giving 0), and `m = 0`
/// or `p_max = 0` gives 0.
pub fn detect_period(strobe: &[f64], p_max: usize, m: usize, tol: f64) -> usize {
    let n = strobe.len();
    if m == 0 || m > n || tol.is_nan() || tol < 0.0 {
        return 0;
    }
    let window = &strobe[n - m..];
    let scale = window.iter().fold(0.0f64, |acc, v| acc.max(v.abs()));
    let bound = tol * scale.max(1.0);
    (1..=p_max)
        .take_while(|p| m + p <= n)
        .find(|&p| repeats_with_period(strobe, p, m, bound))
        .unwrap_or(0)
}

/// Whether the last `m` samples each lie within `bound` of the sample `p` earlier.
fn repeats_with_period(x: &[f64], p: usize, m: usize, bound: f64) -> bool {
    let n = x.len();
    (n - m..n).all(|k| (x[k] - x[k - p]).abs() <= bound)
}

/// Number of hops between the wells: passages of `α` from above `+θc/2` to below `−θc/2` or
/// back. Hysteresis: a sample inside `[−θc/2, θc/2]` keeps the current well, so wobbles around
/// upright are not counted; the first well entered is not a hop. Non-finite samples are
/// ignored; `theta_c ≤ 0` or non-finite gives 0.
pub fn hops(alpha: &[f64], theta_c: f64) -> usize {
    if !(theta_c.is_finite() && theta_c > 0.0) {
        return 0;
    }
    let half = theta_c / 2.0;
    let mut current: Option<Well> = None;
    let mut count = 0;
    for &a in alpha {
        let hopped;
        (current, hopped) = hop_step(current, a, half);
        count += usize::from(hopped);
    }
    count
}

/// Root mean square `sqrt(mean x²)` about zero (upright), not about the mean, so a response
/// resting in one well still shows its offset.
pub fn rms(x: &[f64]) -> Result<f64, AnalysisError> {
    ensure_min_len("rms", 1, x.len())?;
    ensure_finite("rms input", x)?;
    Ok((x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt())
}

/// Peak-to-peak range `max x − min x`.
pub fn range(x: &[f64]) -> Result<f64, AnalysisError> {
    ensure_min_len("range", 1, x.len())?;
    ensure_finite("range input", x)?;
    let (lo, hi) = x
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    Ok(hi - lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn period_three_is_found_not_six() {
        let x: Vec<f64> = (0..30).map(|k| [0.1, -0.4, 0.7][k % 3]).collect();
        assert_eq!(detect_period(&x, 8, 12, 1e-9), 3);
    }
}

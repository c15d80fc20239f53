//! Newton shooting on the stroboscopic map: `x*` with `P^p(x*) = x*`, and its monodromy.
//!
//! ```text
//! scaled state:  z = x / s,  s = (1 rad for θ, Ω for θ̇, 1 V for v),  Ω = 2π f; v only
//!                with a coupled piezo patch (otherwise it stays 0 and is no coordinate)
//! residual:      r(x) = ‖(P^p(x) − x) / s‖∞               (rad, and volts for v)
//! Newton:        (DP^p − I) Δ = −(P^p(x) − x),  DP^p by forward differences of step
//!                FD_STEP · s_j, kept (chord steps) while each step divides r by 20; a step
//!                longer than MAX_STEP (scaled) is shortened to it, and a fresh one halved (up
//!                to 4 times) while it does not lower r
//! converged:     r ≤ TOL
//! monodromy:     M = DP^p(x*) by forward differences of step FD_STEP · s_j
//! least period:  the least divisor d of p with ‖(P^d(x*) − x*)/s‖∞ ≤ SAME_POINT, shot again
//! ```

use super::strobe::Strobe;
use crate::model::{Real, Status};
use nalgebra::DMatrix;
use rayon::prelude::*;

/// Converged when the scaled residual is at most this.
pub const TOL: f64 = 1e-9;
/// Newton iterations at most.
pub const MAX_ITERATIONS: u32 = 16;
/// Forward-difference step of Newton's Jacobian and of the monodromy matrix (scaled).
const FD_STEP: f64 = 1e-7;
/// The longest Newton step (scaled).
const MAX_STEP: f64 = 0.3;
/// Two states closer than this (scaled) are one point of an orbit.
pub const SAME_POINT: f64 = 1e-6;

/// Why shooting found no orbit.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ShootError {
    /// A run of the map failed its health check.
    #[error("a run of the stroboscopic map ended `{0}`")]
    Failed(Status),
    /// Newton did not reach [`TOL`] within [`MAX_ITERATIONS`].
    #[error("Newton stopped at residual {residual:e} after {iterations} iterations")]
    NoConvergence {
        /// The last scaled residual.
        residual: f64,
        /// Iterations taken.
        iterations: u32,
    },
    /// `DP^p − I` is singular at an iterate (a multiplier at +1).
    #[error("DP^p − I is singular (a multiplier at +1)")]
    Singular,
    /// The monodromy matrix's eigenvalues did not converge or are not finite.
    #[error("the monodromy matrix has no finite eigenvalues")]
    NoMultipliers,
}

/// A fixed point of `P^p`.
#[derive(Debug, Clone, PartialEq)]
pub struct Fixed {
    /// `x*`.
    pub x: Vec<f64>,
    /// Its least period `p` (forcing periods).
    pub period: u32,
    /// The scaled residual at `x*`.
    pub residual: f64,
    /// Newton iterations.
    pub iterations: u32,
}

/// The scales `s` of the state's active components: the angles and rates, and the piezo
/// voltage where a patch is coupled (without one, `v` stays 0 and is no coordinate of the
/// orbit: its multiplier would be exactly 1).
pub fn scales<T: Real>(strobe: &Strobe<T>) -> Vec<f64> {
    let p = &strobe.plan().params;
    let n = p.segments;
    let omega = std::f64::consts::TAU * strobe.plan().frequency_hz;
    let dim = 2 * n + usize::from(p.piezo.is_some());
    (0..dim)
        .map(|i| {
            if i < n {
                1.0
            } else if i < 2 * n {
                omega
            } else {
                1.0
            }
        })
        .collect()
}

/// The scaled max-norm of `a − b` over the active components (those `s` scales).
pub fn distance(a: &[f64], b: &[f64], s: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(s)
        .fold(0.0f64, |m, ((x, y), w)| m.max(((x - y) / w).abs()))
}

/// Shoot from `x0` for a fixed point of `P^p`, then reduce `p` to the least period.
pub fn shoot<T: Real>(strobe: &Strobe<T>, x0: &[f64], p: u32) -> Result<Fixed, ShootError> {
    let fixed = newton(strobe, x0, p)?;
    for d in (1..p).filter(|d| p.is_multiple_of(*d)) {
        let s = scales(strobe);
        let back = strobe.advance(&fixed.x, d).map_err(ShootError::Failed)?;
        if distance(&back, &fixed.x, &s) <= SAME_POINT {
            return newton(strobe, &fixed.x, d);
        }
    }
    Ok(fixed)
}

/// Newton's iteration on `P^p(x) − x` from `x0`, its Jacobian kept while each step at
/// least divides the residual by [`KEEP_RATE`] (a chord step costs one run of `P^p`, a
/// Jacobian `d + 1`); given up after [`MAX_STALLS`] fresh steps that do not halve it.
fn newton<T: Real>(strobe: &Strobe<T>, x0: &[f64], p: u32) -> Result<Fixed, ShootError> {
    let s = scales(strobe);
    let mut x = x0.to_vec();
    let mut fx = strobe.advance(&x, p).map_err(ShootError::Failed)?;
    let mut r = distance(&fx, &x, &s);
    let mut lu = None;
    let mut stalls = 0;
    for it in 0..MAX_ITERATIONS {
        if r <= TOL {
            return Ok(Fixed {
                x,
                period: p,
                residual: r,
                iterations: it,
            });
        }
        let fresh = lu.is_none();
        let j = match lu.take() {
            Some(j) => j,
            None => jacobian(strobe, &x, &fx, p)?.lu(),
        };
        let Some(step) = solve(&j, &x, &fx) else {
            if fresh {
                return Err(ShootError::Singular);
            }
            continue;
        };
        let (xn, fxn, rn) = if fresh {
            line_search(strobe, (&x, r), &step, p, &s)?
        } else {
            let xn = shifted(&x, &step, clip(&step, &s));
            match strobe.advance(&xn, p) {
                Ok(f) => {
                    let rn = distance(&f, &xn, &s);
                    (xn, f, rn)
                }
                Err(_) => continue,
            }
        };
        if rn <= 0.5 * r {
            if rn <= KEEP_RATE * r {
                lu = Some(j);
            }
            (x, fx, r) = (xn, fxn, rn);
        } else if fresh {
            stalls += 1;
            if stalls >= MAX_STALLS {
                break;
            }
            if rn < r {
                (x, fx, r) = (xn, fxn, rn);
            }
        }
    }
    if r <= TOL {
        return Ok(Fixed {
            x,
            period: p,
            residual: r,
            iterations: MAX_ITERATIONS,
        });
    }
    Err(ShootError::NoConvergence {
        residual: r,
        iterations: MAX_ITERATIONS,
    })
}

/// A step that divides the residual by at least this keeps its Jacobian for the next.
const KEEP_RATE: f64 = 0.05;
/// Fresh Newton steps that fail to halve the residual before shooting gives up.
const MAX_STALLS: u32 = 3;

/// `x + t · step`.
fn shifted(x: &[f64], step: &[f64], t: f64) -> Vec<f64> {
    let mut xn = x.to_vec();
    for (a, d) in xn.iter_mut().zip(step) {
        *a += t * d;
    }
    xn
}

/// The share of `step` no longer than [`MAX_STEP`] (scaled).
fn clip(step: &[f64], s: &[f64]) -> f64 {
    let len = distance(step, &vec![0.0; step.len()], s);
    if len > MAX_STEP { MAX_STEP / len } else { 1.0 }
}

/// `DP^p(x) − I` by forward differences from `fx = P^p(x)`.
fn jacobian<T: Real>(
    strobe: &Strobe<T>,
    x: &[f64],
    fx: &[f64],
    p: u32,
) -> Result<DMatrix<f64>, ShootError> {
    let mut j = monodromy(strobe, x, fx, p).map_err(ShootError::Failed)?;
    for i in 0..j.nrows() {
        j[(i, i)] -= 1.0;
    }
    Ok(j)
}

/// The Newton step Δ of `(DP^p − I) Δ = −(P^p(x) − x)`, `j` the factorised `DP^p − I`.
fn solve(
    j: &nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    x: &[f64],
    fx: &[f64],
) -> Option<Vec<f64>> {
    let d = j.l().nrows();
    let rhs = nalgebra::DVector::from_iterator(d, fx.iter().zip(x).take(d).map(|(f, x)| x - f));
    let step = j.solve(&rhs)?;
    step.iter()
        .all(|v| v.is_finite())
        .then(|| step.iter().copied().collect())
}

/// The iterate after `step` from `x` (residual `r`): the step shortened to [`MAX_STEP`], then
/// halved while the residual does not fall (the last try is taken regardless).
fn line_search<T: Real>(
    strobe: &Strobe<T>,
    (x, r): (&[f64], f64),
    step: &[f64],
    p: u32,
    s: &[f64],
) -> Result<(Vec<f64>, Vec<f64>, f64), ShootError> {
    let mut t = clip(step, s);
    let mut tries = 0;
    loop {
        let xn = shifted(x, step, t);
        match strobe.advance(&xn, p) {
            Ok(f) => {
                let rn = distance(&f, &xn, s);
                if rn < r || tries == 4 {
                    return Ok((xn, f, rn));
                }
            }
            Err(status) if tries == 4 => return Err(ShootError::Failed(status)),
            Err(_) => {}
        }
        t *= 0.5;
        tries += 1;
    }
}

/// The monodromy matrix `DP^p(x)` by forward differences of step `FD_STEP` = 1e-7 (scaled) from
/// `fx = P^p(x)`: Newton's Jacobian plus I, and at `x*` the orbit's monodromy.
pub fn monodromy<T: Real>(
    strobe: &Strobe<T>,
    x: &[f64],
    fx: &[f64],
    p: u32,
) -> Result<DMatrix<f64>, Status> {
    let s = scales(strobe);
    let d = s.len();
    let cols: Vec<Vec<f64>> = (0..d)
        .into_par_iter()
        .map(|j| {
            let h = FD_STEP * s[j];
            let mut xp = x.to_vec();
            xp[j] += h;
            let f = strobe.advance(&xp, p)?;
            Ok(f.iter().zip(fx).map(|(a, b)| (a - b) / h).collect())
        })
        .collect::<Result<_, Status>>()?;
    Ok(DMatrix::from_fn(d, d, |r, c| cols[c][r]))
}

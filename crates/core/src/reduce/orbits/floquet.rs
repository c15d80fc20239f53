//! Floquet multipliers: the eigenvalues μ of an orbit's monodromy matrix `DP^p(x*)`.
//!
//! ```text
//! stable:        max |μ| < 1
//! period doubling: a real μ crosses −1;  fold (or a symmetry-breaking branch): a real μ
//!                crosses +1;  the summary keeps, of the real multipliers, the one nearest −1
//!                and the one nearest +1 (NaN where none is real)
//! ```
//!
//! The eigenvalues come from nalgebra's real Schur form, as the linearisation's do
//! (`crate::model::linear`).

use crate::model::linear::EIGEN_MAX_ITERATIONS;
use nalgebra::{Complex, DMatrix, Schur};
use serde::Serialize;

/// A multiplier is real when its imaginary part is at most this share of its modulus.
const REAL_SHARE: f64 = 1e-9;

/// An orbit's multipliers and what a map shows of them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Multipliers {
    /// Every multiplier, `[re, im]`, by descending modulus.
    pub values: Vec<[f64; 2]>,
    /// max |μ|.
    pub max_abs: f64,
    /// The real multiplier nearest −1 (NaN where none is real).
    pub near_minus_one: f64,
    /// The real multiplier nearest +1 (NaN where none is real).
    pub near_plus_one: f64,
}

impl Multipliers {
    /// The multipliers of monodromy matrix `m`; `None` when its Schur form does not converge
    /// or is not finite.
    pub fn of(m: DMatrix<f64>) -> Option<Multipliers> {
        let schur = Schur::try_new(m, f64::EPSILON, EIGEN_MAX_ITERATIONS)?;
        let mut ev: Vec<Complex<f64>> = schur.complex_eigenvalues().iter().copied().collect();
        if !ev.iter().all(|z| z.re.is_finite() && z.im.is_finite()) {
            return None;
        }
        ev.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
        let real: Vec<f64> = ev
            .iter()
            .filter(|z| z.im.abs() <= REAL_SHARE * z.norm().max(f64::MIN_POSITIVE))
            .map(|z| z.re)
            .collect();
        let nearest = |target: f64| {
            real.iter()
                .copied()
                .min_by(|a, b| (a - target).abs().total_cmp(&(b - target).abs()))
                .unwrap_or(f64::NAN)
        };
        Some(Multipliers {
            max_abs: ev.first().map_or(f64::NAN, |z| z.norm()),
            near_minus_one: nearest(-1.0),
            near_plus_one: nearest(1.0),
            values: ev.iter().map(|z| [z.re, z.im]).collect(),
        })
    }

    /// Whether every multiplier lies inside the unit circle.
    pub fn stable(&self) -> bool {
        self.max_abs < 1.0
    }
}

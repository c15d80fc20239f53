//! The step controller of adaptive steps, written once (`docs/model.md`, "Adaptive steps"):
//! the ladder of steps aligned to the base step `H`, its error norm, and its accept, reject
//! and grow rules. Every engine takes its sub-steps by these: the scalar loop
//! ([`crate::engine::adaptive::Adaptive`]), each SIMD lane (`engine/cpu/lane_ladder.rs`), and
//! the GPU kernel. The rules are written once ([`crate::rules`]): `ladder_ratio`,
//! `scaled_max`, `ladder_rejects` and `ladder_next_level` are Rust functions here and the same
//! text in the kernels' header, and a table-driven test runs both on the same cases.
//!
//! ```text
//! levels:   h_k = H / 2^k,  k = 0 … MAX_LEVEL
//! error:    e = max_s |x_s| / (atol + rtol·|y_s|),  x the pair's error estimate, y the state
//!           before the step (a NaN ratio is passed over, as f64::max does)
//! accept:   e ≤ 1 (or k = MAX_LEVEL, counted as forced); then, where the position within H
//!           is a multiple of h_{k−1} and e ≤ LADDER_GROW, k ← k − 1 for the next step
//! reject:   k ← k + 1, the same step again from the same state
//! ```
//!
//! [`Rungs`] is what a pair gives the ladder: its stages, its estimate, its finish.

use crate::model::{Branches, Chain, Lane, Real, Workspace};
use crate::rules::{Float, abs, is_nan, max, shared_rules};

/// The finest level: `H / 2^20`, a microsecond of a one-second base step.
pub(crate) const MAX_LEVEL: u32 = 20;

/// The error below which the next step may double (its error then about 8× as large).
pub(crate) const LADDER_GROW: f64 = 0.1;

/// A base step in units of the finest step: positions within it are counted in these.
pub(crate) const UNIT: u64 = 1 << MAX_LEVEL;

/// [`UNIT`] as the rules (and the kernels) count it.
pub(crate) const LADDER_UNIT: u32 = 1 << MAX_LEVEL;

/// The tolerances of the error norm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerance {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
}

impl Tolerance {
    /// The scaled error `e = max_s |x_s| / (atol + rtol·|y_s|)` of lane `lane` of the estimate
    /// `err` for a step from `y`, in f64 from the lane's values (lane 0 of a scalar).
    pub(crate) fn scaled_error<V: Lane>(&self, err: &[V], y: &[V], lane: usize) -> f64 {
        err.iter().zip(y).fold(0.0, |e, (x, y)| {
            let (x, y) = (x.lane(lane).wide(), y.lane(lane).wide());
            scaled_max(e, x, y, self.rtol, self.atol)
        })
    }

    /// One component's ratio `|x| / (atol + rtol·|y|)`.
    pub fn ratio(&self, x: f64, y: f64) -> f64 {
        ladder_ratio(x, y, self.rtol, self.atol)
    }
}

/// Where one instance stands on the ladder: the level of its next sub-step and its position
/// within the base step (in units of the finest step).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Rung {
    /// The level k of the next sub-step (`h = H / 2^k`).
    pub level: u32,
    /// The position within the base step, in [`UNIT`]s of the finest step.
    pub pos: u64,
}

impl Rung {
    /// The next sub-step's length in units of the finest step.
    pub fn span(&self) -> u64 {
        UNIT >> self.level
    }

    /// The next sub-step's length for a base step of `base_s` seconds.
    pub fn step_s(&self, base_s: f64) -> f64 {
        base_s / f64::from(1u32 << self.level)
    }

    /// The next sub-step's start and width as fractions of the base step.
    pub fn fractions(&self) -> (f64, f64) {
        let unit = UNIT as f64;
        (self.pos as f64 / unit, self.span() as f64 / unit)
    }

    /// Judge a try of scaled error `e`: accepted (true), or rejected and the level refined
    /// for the same step again. At the finest level every try is accepted (forced if e > 1).
    pub fn judge(&mut self, e: f64) -> bool {
        if ladder_rejects(e, self.level) {
            self.level += 1;
            return false;
        }
        true
    }

    /// Move past an accepted sub-step of scaled error `e`: the position advances, and the
    /// level coarsens by one where the new position is aligned to the coarser step and
    /// `e ≤ LADDER_GROW`. True when the base step is complete (the position back at 0).
    pub(crate) fn advance(&mut self, e: f64) -> bool {
        self.pos += self.span();
        // The sub-steps of a base step add up to UNIT = 2^20, so the cast is exact.
        debug_assert!(self.pos <= UNIT, "position {} past the base step", self.pos);
        self.level = ladder_next_level(self.level, self.pos as u32, e);
        if self.pos < UNIT {
            return false;
        }
        self.pos = 0;
        true
    }
}

shared_rules! {
    /// |x| / (atol + rtol |y|): one component's ratio in the error norm.
    pub(crate) fn ladder_ratio(x: Float, y: Float, rtol: Float, atol: Float) -> Float {
        return abs(x) / (atol + rtol * abs(y));
    }

    /// max(e, |x| / (atol + rtol |y|)): the error norm folded over one more component, a NaN
    /// ratio passed over.
    pub(crate) fn scaled_max(e: Float, x: Float, y: Float, rtol: Float, atol: Float) -> Float {
        let r = ladder_ratio(x, y, rtol, atol);
        if is_nan(r) {
            return e;
        }
        return max(e, r);
    }

    /// A try of scaled error e at level k is taken again one level finer (at the finest level
    /// every try is accepted).
    pub(crate) fn ladder_rejects(e: Float, k: u32) -> bool {
        return e > 1.0 && k < MAX_LEVEL;
    }

    /// The level after an accepted sub-step of level k and error e that ends at position
    /// `pos` (in units of the finest step): one coarser where `pos` is aligned to the coarser
    /// step and e <= LADDER_GROW.
    pub(crate) fn ladder_next_level(k: u32, pos: u32, e: Float) -> u32 {
        let span = LADDER_UNIT >> k;
        if k > 0 && pos % (span << 1) == 0 && e <= LADDER_GROW {
            return k - 1;
        }
        return k;
    }
}

/// A pair the ladder steps with: a sub-step of level `k` (`h = H / 2^k`) tried from `y`, its
/// error estimate, and the sub-step taken.
pub trait Rungs<T: Real>: Sized {
    /// Evaluations of the chain's right-hand side per tried sub-step.
    const EVALUATIONS: u64;

    /// Evaluations beside [`Rungs::EVALUATIONS`] per try so far (none unless the pair says).
    fn extra_evaluations(&self) -> u64 {
        0
    }

    /// The same pair with nothing carried over (a twin's).
    fn fresh(&self) -> Self;

    /// Every stage of a sub-step of level `k` from `y` by the exact law, `y` left as it is;
    /// `acc(c)` is the cart's acceleration at fraction `c` of the sub-step. The bumpers'
    /// branches at each stage (what a twin follows).
    fn stages(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        acc: &impl Fn(f64) -> T,
    ) -> [Branches<T>; 4];

    /// The error estimate of the stages just computed, component by component, into `out`
    /// (the state's length).
    fn error(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        at: (&[T], &impl Fn(f64) -> T),
        out: &mut [T],
    );

    /// Take the sub-step whose stages were just computed: `y` advanced (compensated).
    fn finish(&mut self, k: usize, y: &mut [T]);

    /// A twin's sub-step of level `k`, every stage on the main stages' `branches`.
    fn follow(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        at: (&mut [T], &impl Fn(f64) -> T),
        branches: &[Branches<T>; 4],
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rejected_try_refines_and_an_aligned_small_error_coarsens() {
        let mut r = Rung::default();
        assert!(!r.judge(2.0));
        assert_eq!(r.level, 1);
        assert!(r.judge(0.05));
        assert!(!r.advance(0.05), "half of the base step");
        assert_eq!((r.level, r.pos), (1, UNIT / 2), "not aligned to h_0 yet");
        assert!(r.advance(0.05));
        assert_eq!((r.level, r.pos), (0, 0), "aligned at the end: coarser");
        let mut fine = Rung {
            level: MAX_LEVEL,
            pos: 0,
        };
        assert!(fine.judge(1e9), "forced at the finest level");
    }

    #[test]
    fn the_norm_takes_the_worst_component_and_passes_over_nan() {
        let tol = Tolerance {
            rtol: 1e-3,
            atol: 1e-6,
        };
        let e = tol.scaled_error(&[1e-6f64, f64::NAN, 2e-6], &[0.0, 1.0, 0.0], 0);
        assert_eq!(e, 2.0);
    }
}

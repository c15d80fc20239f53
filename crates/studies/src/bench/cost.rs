//! The flop count of one integration step, as a table: for each method, the operations of one
//! step of one instance as polynomials in the segment count N. The throughput studies read it
//! to turn instance-steps per second into flop per second and a share of the peak.
//!
//! The coefficients were counted, not estimated by hand: the lab runs the engine's own step
//! (`rk4_step`, `Imex::step_with`) on a number type that counts its operations, with a
//! bumper pressed (`benches/src/flops.rs`, `pendulum-atlas-lab flops`), and its test holds
//! this table against a fresh count at every N from 1 to 64, on the scenes of both studies.
//! A change to the step that changes its count fails that test until the table is counted
//! again.
//!
//! `sin`/`cos` pairs are counted apart: the SIMD loop computes each with `wide`'s polynomial,
//! whose floating-point operations [`SIN_COS_FLOP`] counts (its integer and blend operations
//! are not flops and not counted).

use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_core::model::ModelParams;
use serde::Serialize;

/// Floating-point operations of one lane of `wide::f32x8::sin_cos` (abs, the quadrant's
/// multiply and round, three fused reductions (2 each), x², two degree-2 polynomials with
/// their scaling, and the final sums: 26).
pub const SIN_COS_FLOP: u64 = 26;

/// A count `c0 + c1·N + c2·N² + c3·L` over the segments N and the contact's levers L (the
/// segments at and below the bumpers' contact point, whose sines sum to its position).
pub type Poly = [u64; 4];

/// The operations of one step of one instance, each kind a [`Poly`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepOps {
    /// Additions, subtractions, multiplications, negations, max and selects.
    pub arithmetic: Poly,
    /// Divisions.
    pub divisions: Poly,
    /// sin/cos pairs.
    pub sin_cos: Poly,
}

/// One RK4 step: four stages, each one sin/cos per segment and two divisions per segment
/// (the backward sweep's 1/d and the forward sweep's division by d).
pub const RK4_OPS: StepOps = StepOps {
    arithmetic: [119, 456, 0, 32],
    divisions: [0, 8, 0, 0],
    sin_cos: [0, 4, 0, 0],
};

/// One IMEX step (ARK3(2)4L\[2\]SA with the joints implicit): the dense products with the
/// implicit part's matrices give the N² term, the explicit stages the same sin/cos and
/// divisions as RK4's.
pub const IMEX_OPS: StepOps = StepOps {
    arithmetic: [107, 564, 18, 32],
    divisions: [0, 8, 0, 0],
    sin_cos: [0, 4, 0, 0],
};

/// The table's row for `method`.
pub fn step_ops(method: Method) -> StepOps {
    match method {
        Method::Rk4 => RK4_OPS,
        Method::Imex => IMEX_OPS,
    }
}

/// The operations of one step by `method` of one instance of `p`: a scene of the throughput
/// studies (no piezo patch), with a bumper pressed.
pub fn step_flops(method: Method, p: &ModelParams) -> FlopCount {
    let levers = p.contact.as_ref().map_or(0, |c| c.levers_m.len());
    step_ops(method).at(p.segments, levers)
}

impl StepOps {
    /// The count at N segments and L levers.
    pub fn at(&self, segments: usize, levers: usize) -> FlopCount {
        let (n, l) = (segments as u64, levers as u64);
        let at = |p: Poly| p[0] + p[1] * n + p[2] * n * n + p[3] * l;
        FlopCount::new(
            segments,
            at(self.arithmetic),
            at(self.divisions),
            at(self.sin_cos),
        )
    }
}

/// Operations of one step of one instance, and per segment-step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlopCount {
    /// Segments N.
    pub segments: usize,
    /// Additions, subtractions, multiplications, negations, max and selects.
    pub arithmetic: u64,
    /// Divisions.
    pub divisions: u64,
    /// sin/cos pairs.
    pub sin_cos: u64,
    /// All of it in flop (a division 1, a sin/cos pair [`SIN_COS_FLOP`]).
    pub flop_per_step: u64,
    /// `flop_per_step / N`.
    pub flop_per_segment_step: f64,
}

impl FlopCount {
    /// The count of a step of `segments` segments with these operations.
    pub fn new(segments: usize, arithmetic: u64, divisions: u64, sin_cos: u64) -> FlopCount {
        let flop_per_step = arithmetic + divisions + sin_cos * SIN_COS_FLOP;
        FlopCount {
            segments,
            arithmetic,
            divisions,
            sin_cos,
            flop_per_step,
            flop_per_segment_step: flop_per_step as f64 / segments as f64,
        }
    }
}

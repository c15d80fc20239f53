//! The flop count of one integration step, counted by running the engine's own step on a
//! number type that counts its operations ([`Counted`]), not estimated by hand.
//!
//! `sin`/`cos` pairs are counted apart: the SIMD loop computes each with `wide`'s polynomial,
//! whose floating-point operations `SIN_COS_FLOP` counts (its integer and blend operations are
//! not flops and not counted).

use pendulum_atlas_core::engine::imex::{Imex, ImexMatrices};
use pendulum_atlas_core::engine::rk4::{Rk4Scratch, rk4_step};
use pendulum_atlas_core::model::{Chain, Lane, ModelParams};
use serde::Serialize;
use std::cell::Cell;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};
use std::sync::Arc;

/// Floating-point operations of one lane of `wide::f32x8::sin_cos` (abs, the quadrant's
/// multiply and round, three fused reductions (2 each), x², two degree-2 polynomials with
/// their scaling, and the final sums: 26).
pub(crate) const SIN_COS_FLOP: u64 = 26;

thread_local! {
    static OPS: Cell<[u64; 3]> = const { Cell::new([0; 3]) };
}

fn count(kind: usize) {
    OPS.with(|c| {
        let mut v = c.get();
        v[kind] += 1;
        c.set(v);
    });
}

const ARITH: usize = 0;
const DIV: usize = 1;
const SIN_COS: usize = 2;

/// An `f64` that counts the operations done on it (per thread).
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd)]
pub struct Counted(pub f64);

macro_rules! counted_op {
    ($tr:ident, $f:ident, $op:tt, $kind:expr, $tra:ident, $fa:ident) => {
        impl $tr for Counted {
            type Output = Counted;
            #[inline]
            fn $f(self, o: Counted) -> Counted {
                count($kind);
                Counted(self.0 $op o.0)
            }
        }
        impl $tra for Counted {
            #[inline]
            fn $fa(&mut self, o: Counted) {
                *self = *self $op o;
            }
        }
    };
}

counted_op!(Add, add, +, ARITH, AddAssign, add_assign);
counted_op!(Sub, sub, -, ARITH, SubAssign, sub_assign);
counted_op!(Mul, mul, *, ARITH, MulAssign, mul_assign);

impl Div for Counted {
    type Output = Counted;
    fn div(self, o: Counted) -> Counted {
        count(DIV);
        Counted(self.0 / o.0)
    }
}

impl Neg for Counted {
    type Output = Counted;
    fn neg(self) -> Counted {
        count(ARITH);
        Counted(-self.0)
    }
}

impl Lane for Counted {
    type Scalar = f64;
    const LANES: usize = 1;
    fn splat(x: f64) -> Self {
        Counted(x)
    }
    fn gather(mut f: impl FnMut(usize) -> f64) -> Self {
        Counted(f(0))
    }
    fn lane(self, _: usize) -> f64 {
        self.0
    }
    fn with_lane(self, _: usize, v: f64) -> Self {
        Counted(v)
    }
    fn v_sin_cos(self) -> (Self, Self) {
        count(SIN_COS);
        let (s, c) = self.0.sin_cos();
        (Counted(s), Counted(c))
    }
    fn v_max(self, y: Self) -> Self {
        count(ARITH);
        Counted(self.0.max(y.0))
    }
    fn if_positive(cond: Self, a: Self, b: Self) -> Self {
        count(ARITH);
        if cond.0 > 0.0 { a } else { b }
    }
}

/// Operations of one step of one instance, and per segment-step.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FlopCount {
    /// Segments N.
    pub segments: usize,
    /// Additions, subtractions, multiplications, negations, max and selects.
    pub arithmetic: u64,
    /// Divisions.
    pub divisions: u64,
    /// sin/cos pairs.
    pub sin_cos: u64,
    /// All of it in flop (a division 1, a sin/cos pair `SIN_COS_FLOP`).
    pub flop_per_step: u64,
    /// `flop_per_step / N`.
    pub flop_per_segment_step: f64,
}

fn counted(segments: usize, step: impl FnOnce()) -> FlopCount {
    OPS.with(|c| c.set([0; 3]));
    step();
    let [arithmetic, divisions, sin_cos] = OPS.with(Cell::get);
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

/// The operations of one RK4 step of the engine on the instance `p` (bumper pressed).
pub fn rk4_flops(p: &ModelParams, dt_s: f64) -> FlopCount {
    let chain: Chain<Counted> = Chain::new(p);
    let (mut ws, mut y) = (chain.workspace(), start_state(p));
    let mut scratch = Rk4Scratch::new(y.len());
    let acc = [Counted(1.0); 3];
    counted(p.segments, || {
        rk4_step(&chain, &mut ws, &mut y, &mut scratch, Counted(dt_s), acc);
    })
}

/// The operations of one IMEX step of the engine on the instance `p` (bumper pressed).
pub fn imex_flops(p: &ModelParams, dt_s: f64) -> FlopCount {
    let chain: Chain<Counted> = Chain::new(p);
    let (mut ws, mut y) = (chain.workspace(), start_state(p));
    let mut imex: Imex<Counted> = Imex::new(&Arc::new(ImexMatrices::new(p, dt_s)), y.len());
    counted(p.segments, || {
        imex.step_with(&chain, &mut ws, &mut y, |_| Counted(1.0));
    })
}

/// A state leaning 0.4 rad into the +x bumper and moving into it.
fn start_state(p: &ModelParams) -> Vec<Counted> {
    let n = p.segments;
    (0..2 * n + 1)
        .map(|k| {
            Counted(if k < n {
                0.4
            } else if k < 2 * n {
                1.0
            } else {
                0.0
            })
        })
        .collect()
}

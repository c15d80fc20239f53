//! The flop count of one integration step, counted by running the engine's own step on a
//! number type that counts its operations ([`Counted`]), not estimated by hand.
//!
//! `sin`/`cos` pairs are counted apart: the SIMD loop computes each with `wide`'s polynomial,
//! whose floating-point operations `SIN_COS_FLOP` counts (its integer and blend operations are
//! not flops and not counted).

use nalgebra::{DMatrix, DVector};
use pendulum_atlas_core::engine::imex::{Imex, ImexMatrices};
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_core::engine::rk4::{Rk4Scratch, rk4_step};
use pendulum_atlas_core::model::{Chain, Lane, ModelParams};
use pendulum_atlas_studies::bench::cost::{FlopCount, Poly, StepOps, step_ops};
use pendulum_atlas_studies::bench::gpu_throughput::{ThroughputScene, workload};
use pendulum_atlas_studies::bench::workload::WorkloadError;
use std::cell::Cell;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};
use std::sync::Arc;

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

fn counted(segments: usize, step: impl FnOnce()) -> FlopCount {
    OPS.with(|c| c.set([0; 3]));
    step();
    let [arithmetic, divisions, sin_cos] = OPS.with(Cell::get);
    FlopCount::new(segments, arithmetic, divisions, sin_cos)
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

/// The count of one step of `method` on the instance `p`.
pub fn step_count(method: Method, p: &ModelParams, dt_s: f64) -> FlopCount {
    match method {
        Method::Rk4 => rk4_flops(p, dt_s),
        Method::Imex => imex_flops(p, dt_s),
    }
}

/// The largest N the table is checked at.
pub const CHECK_MAX_N: usize = 64;

/// The contact's levers of `p` (0 without bumpers).
fn levers(p: &ModelParams) -> usize {
    p.contact.as_ref().map_or(0, |c| c.levers_m.len())
}

/// The table's row through `counts` (N, L, count): least squares over every point, rounded to
/// integers, and `None` unless it gives every count exactly.
pub fn fit(counts: &[(usize, usize, FlopCount)]) -> Option<StepOps> {
    let poly = |f: fn(&FlopCount) -> u64| -> Option<Poly> {
        let rows = counts.len();
        let a = DMatrix::from_fn(rows, 4, |r, c| {
            let (n, l, _) = counts[r];
            [1.0, n as f64, (n * n) as f64, l as f64][c]
        });
        let b = DVector::from_fn(rows, |r, _| f(&counts[r].2) as f64);
        let x = a.svd(true, true).solve(&b, 1e-9).ok()?;
        let mut p = [0u64; 4];
        for (k, v) in x.iter().enumerate() {
            let r = v.round();
            ((r - v).abs() < 1e-6 && r >= 0.0).then_some(())?;
            p[k] = r as u64;
        }
        Some(p)
    };
    let ops = StepOps {
        arithmetic: poly(|c| c.arithmetic)?,
        divisions: poly(|c| c.divisions)?,
        sin_cos: poly(|c| c.sin_cos)?,
    };
    let exact = counts.iter().all(|(n, l, c)| ops.at(*n, *l) == *c);
    exact.then_some(ops)
}

/// The table counted afresh on `params_at(method, n)`, the instance a study times at N, for
/// every N from 1 to [`CHECK_MAX_N`]; `None` where no table gives every count.
pub fn count_table<E>(
    method: Method,
    params_at: impl Fn(Method, usize) -> Result<(ModelParams, f64), E>,
) -> Result<Option<StepOps>, E> {
    let mut counts = Vec::with_capacity(CHECK_MAX_N);
    for n in 1..=CHECK_MAX_N {
        let (p, dt) = params_at(method, n)?;
        counts.push((n, levers(&p), step_count(method, &p, dt)));
    }
    Ok(fit(&counts))
}
/// The instance the GPU throughput study times at N for `method` on `scene` (its first).
pub fn throughput_params(
    scene: ThroughputScene,
    method: Method,
    n: usize,
) -> Result<(ModelParams, f64), WorkloadError> {
    let plan = workload(scene, n, method, 1)?;
    let first = &plan.instances[0];
    Ok((first.params.clone(), first.dt_s))
}

/// The table counted afresh on both studies' scenes, as Rust to paste into `cost.rs`, and
/// whether it is the table the product ships.
pub fn table_report() -> Result<(String, bool), WorkloadError> {
    let mut text = String::new();
    let mut same = true;
    for method in [Method::Rk4, Method::Imex] {
        for scene in ThroughputScene::ALL {
            let counted = count_table(method, |m, n| throughput_params(scene, m, n))?;
            let line = match counted {
                Some(ops) => {
                    same &= ops == step_ops(method);
                    format!("{} on the {scene:?} scene: {ops:?}", method.name())
                }
                None => {
                    same = false;
                    format!(
                        "{} on the {scene:?} scene: no table c0 + c1 N + c2 N² + c3 L gives every count",
                        method.name()
                    )
                }
            };
            text.push_str(&line);
            text.push('\n');
        }
    }
    Ok((text, same))
}

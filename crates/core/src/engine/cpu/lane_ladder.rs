//! Adaptive steps of the explicit pair in the SIMD lanes: the ladder of
//! [`crate::engine::adaptive`], lane by lane. Each lane keeps its own level and position within
//! the base step; a pass tries one sub-step in every lane that has not finished its base step
//! (a lane that has gets a zero step and is masked), so the lanes part only within a base step
//! and meet again at its end, where the loop's bookkeeping runs for all of them.
//!
//! Per lane this is [`crate::engine::adaptive::Adaptive`] with [`crate::engine::rk4::Rk4Rungs`]
//! operation for operation: the same stages and estimate on the lane's own step, the scaled
//! error in f64 from the lane's values, the cart at the same fractions of the base step, the
//! accept, reject and growth rules, onsets counted and the twin's saltation at the sub-step
//! where a contact begins. So a lane gives what the scalar loop gives for its instance.

use crate::engine::adaptive::{GROW, MAX_LEVEL};
use crate::engine::plan::InstancePlan;
use crate::engine::rk4::{Rk4Scratch, rk4_error_at, rk4_finish_masked, rk4_stages_at};
use crate::engine::twin::onsets_of;
use crate::model::{Chain, Lane, Real, Workspace};

/// The sub-step positions of a base step, in units of the finest step.
const UNIT: u64 = 1 << MAX_LEVEL;

/// The most lanes of a vector (`F32x8`): per-lane bookkeeping lives in arrays of this length,
/// not in vectors allocated at every step.
pub(super) const MAX_LANES: usize = 8;

/// One value per lane (the first `V::LANES` used).
pub(super) type PerLane<T> = [T; MAX_LANES];

/// The ladder of every lane of a group, with the pair's scratch.
#[derive(Clone)]
pub(super) struct LaneLadder<V: Lane> {
    /// Each lane's base step (s); the padding lanes of a short group have none.
    base_s: Vec<f64>,
    /// Each lane's tolerances (rtol, atol).
    tol: Vec<(f64, f64)>,
    /// Each lane's level k of its next sub-step (h = base / 2^k).
    level: Vec<u32>,
    scratch: Rk4Scratch<V>,
    end: Vec<V>,
    k5: Vec<V>,
    err: Vec<V>,
}

/// A twin's onset saltation: `(lane, main state, twins' state, onsets)`.
pub(super) type Saltation<'a, V> = dyn FnMut(usize, &[V], &mut [V], (bool, bool)) + 'a;

/// The twins beside the main lanes during a base step: their state, their stepper's scratch,
/// which lanes' twin runs, and the saltation at a lane's contact onset.
pub(super) struct Twins<'a, V: Lane> {
    pub y: &'a mut [V],
    pub scratch: &'a mut Rk4Scratch<V>,
    pub running: PerLane<bool>,
    pub salt: &'a mut Saltation<'a, V>,
}

/// Where each lane is within the base step being taken.
struct Pass {
    pos: PerLane<u64>,
    accepted: PerLane<bool>,
    errors: PerLane<f64>,
}

impl<V: Lane> LaneLadder<V>
where
    V::Scalar: Real,
{
    /// The ladders of the instances `plans` (at most `V::LANES`), for a state of length `dim`.
    pub(super) fn new(plans: &[&InstancePlan], dim: usize) -> Self {
        let tol = |p: &InstancePlan| match p.control {
            crate::config::StepControl::Adaptive { rtol, atol } => (rtol, atol),
            crate::config::StepControl::Fixed => unreachable!("a ladder of fixed steps"),
        };
        assert!(V::LANES <= MAX_LANES, "{} lanes", V::LANES);
        let z = vec![V::splat(0.0); dim];
        LaneLadder {
            base_s: plans.iter().map(|p| p.dt_s).collect(),
            tol: plans.iter().map(|p| tol(p)).collect(),
            level: vec![0; V::LANES],
            scratch: Rk4Scratch::new(dim),
            end: z.clone(),
            k5: z.clone(),
            err: z,
        }
    }

    /// Base step `n` of every lane in `live` (and of its twin where it runs); per lane, the
    /// bumper contact onsets within it. `touching` follows each lane's bumpers sub-step by
    /// sub-step.
    pub(super) fn base_step(
        &mut self,
        (chain, ws): (&Chain<V>, &mut Workspace<V>),
        y: &mut [V],
        (n, plans): (u64, &[&InstancePlan]),
        live: &PerLane<bool>,
        mut twins: Option<Twins<'_, V>>,
        touching: &mut [(bool, bool)],
    ) -> PerLane<u32> {
        let lanes = plans.len();
        let mut pass = Pass {
            pos: std::array::from_fn(|l| if l < lanes && live[l] { 0 } else { UNIT }),
            accepted: [false; MAX_LANES],
            errors: [0.0; MAX_LANES],
        };
        let mut onsets = [0u32; MAX_LANES];
        while pass.pos.iter().any(|&p| p < UNIT) {
            let (h, acc) = self.sub_step(plans, n, &pass.pos);
            let branches = rk4_stages_at(chain, ws, (y, &mut self.scratch), h, acc, None);
            let scratch = (&mut self.end[..], &mut self.k5[..]);
            rk4_error_at(
                chain,
                ws,
                (y, &self.scratch),
                (h, acc[2]),
                scratch,
                &mut self.err,
            );
            self.judge(y, &mut pass);
            let mask = V::gather(|l| f64::from(u8::from(pass.accepted[l])));
            rk4_finish_masked(y, &mut self.scratch, h, mask);
            let pen = chain.penetrations(y);
            let zero = <V::Scalar as num_traits::Zero>::zero();
            let now = |l: usize| {
                pen.map_or((false, false), |(r, q)| {
                    (r.lane(l) > zero, q.lane(l) > zero)
                })
            };
            let mut new = [(false, false); MAX_LANES];
            for l in (0..lanes).filter(|&l| pass.accepted[l]) {
                new[l] = onsets_of(touching[l], now(l));
                onsets[l] += u32::from(new[l].0) + u32::from(new[l].1);
                touching[l] = now(l);
            }
            if let Some(t) = &mut twins {
                let follows = |l: usize| l < lanes && pass.accepted[l] && t.running[l];
                if (0..V::LANES).any(follows) {
                    let tmask = V::gather(|l| f64::from(u8::from(follows(l))));
                    let on = Some(&branches);
                    rk4_stages_at(chain, ws, (&*t.y, &mut *t.scratch), h, acc, on);
                    rk4_finish_masked(t.y, t.scratch, h, tmask);
                    for l in (0..lanes).filter(|&l| follows(l) && (new[l].0 || new[l].1)) {
                        (t.salt)(l, y, t.y, new[l]);
                    }
                }
            }
            self.advance(&mut pass);
        }
        onsets
    }

    /// Each lane's step and the cart at the fractions 0, ½, 1 of its sub-step, from its
    /// position within base step `n` (a zero step where the lane has finished it).
    fn sub_step(&self, plans: &[&InstancePlan], n: u64, pos: &[u64]) -> (V, [V; 3]) {
        let active = |l: usize| pos[l] < UNIT;
        let h = V::gather(|l| {
            if active(l) {
                self.base_s[l] / f64::from(1u32 << self.level[l])
            } else {
                0.0
            }
        });
        let acc = [0.0, 0.5, 1.0].map(|c| {
            V::gather(|l| {
                if !active(l) {
                    return 0.0;
                }
                let span = UNIT >> self.level[l];
                let (start, width) = (pos[l] as f64 / UNIT as f64, span as f64 / UNIT as f64);
                plans[l].cart_at(n, start + c * width).a_m_s2
            })
        });
        (h, acc)
    }

    /// Each active lane's scaled error (in f64, from its values, as the scalar loop computes
    /// it), accepted or taken again one level finer.
    fn judge(&mut self, y: &[V], pass: &mut Pass) {
        for l in 0..V::LANES {
            pass.accepted[l] = false;
            if pass.pos[l] >= UNIT {
                continue;
            }
            let (rtol, atol) = self.tol[l];
            let e = self
                .err
                .iter()
                .zip(y)
                .map(|(es, ys)| es.lane(l).wide().abs() / (atol + rtol * ys.lane(l).wide().abs()))
                .fold(0.0, f64::max);
            pass.errors[l] = e;
            if e > 1.0 && self.level[l] < MAX_LEVEL {
                self.level[l] += 1;
            } else {
                pass.accepted[l] = true;
            }
        }
    }

    /// The accepted lanes on by their sub-step, each one level coarser where the position is
    /// aligned to it and the error small.
    fn advance(&mut self, pass: &mut Pass) {
        for l in (0..V::LANES).filter(|&l| pass.accepted[l]) {
            let k = self.level[l];
            let span = UNIT >> k;
            pass.pos[l] += span;
            if k > 0 && pass.pos[l].is_multiple_of(span << 1) && pass.errors[l] <= GROW {
                self.level[l] = k - 1;
            }
        }
    }

    /// The scratch of the twins' stepper (a fresh one: no compensation carried).
    pub(super) fn twin_scratch(&self) -> Rk4Scratch<V> {
        Rk4Scratch::new(self.end.len())
    }
}

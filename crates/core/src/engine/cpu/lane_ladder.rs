//! Adaptive steps in the SIMD lanes: the ladder of [`crate::engine::adaptive`], lane by lane,
//! for both pairs ([`LanePair`]). Each lane keeps its own base step, level and position
//! within the base step; a pass tries one sub-step in every live lane, and a lane whose base
//! step ends with it has the loop's bookkeeping at once and goes on into its next base step:
//! the lanes do not wait for one another (waiting at every base step left half the lanes idle
//! at N = 17, where one lane's impact takes many sub-steps while the others fly freely).
//!
//! Per lane this is [`crate::engine::adaptive::Adaptive`] operation for operation: the same
//! stages and estimate on the lane's own step (IMEX: with the lane's own `S⁻¹`, set when its
//! level changes), the scaled error in f64 from the lane's values, the cart at the same
//! fractions of the base step, the accept, reject and growth rules, onsets counted and the
//! twin's saltation at the sub-step where a contact begins. So a lane gives what the scalar
//! loop gives for its instance.

use super::cart_table::CartTable;
use crate::engine::imex::{C as IMEX_C, Imex, ImexMatrices};
use crate::engine::ladder::{MAX_LEVEL, Rung, Tolerance};
use crate::engine::method::Method;
use crate::engine::plan::InstancePlan;
use crate::engine::rk4::Rk4Pair;
use crate::engine::twin::onsets_of;
use crate::model::{Branches, Chain, Lane, ModelParams, Real, Workspace};
use std::sync::Arc;

/// The most lanes of a vector (`F32x16`): per-lane bookkeeping lives in arrays of this
/// length, not in vectors allocated at every step.
pub(super) const MAX_LANES: usize = 16;

/// One value per lane (the first `V::LANES` used).
pub(super) type PerLane<T> = [T; MAX_LANES];

/// The embedded pair of a group's lanes, with its scratch.
#[derive(Clone)]
pub(super) enum LanePair<V: Lane> {
    /// RK4 with its third-order solution, first same as last ([`crate::engine::rk4::Rk4Rungs`]).
    Rk4(Rk4Pair<V>),
    /// ARK3(2)4L\[2\]SA with its filtered estimate ([`crate::engine::adaptive::ImexRungs`]).
    Imex(Box<ImexLanes<V>>),
}

/// The IMEX pair in lanes: one stepper whose lanes each hold the step and `S⁻¹` of their own
/// level. The group's lanes share the chain's linear part and base step
/// ([`InstancePlan::imex_key`]), so the matrices of a level are built once per group, when
/// a lane first needs them. One summation compensation follows the state (the scalar loop
/// hands it from level to level).
#[derive(Clone)]
pub(super) struct ImexLanes<V: Lane> {
    params: Arc<ModelParams>,
    base_s: f64,
    /// The matrices of each level built so far.
    levels: Vec<Option<Arc<ImexMatrices>>>,
    imex: Imex<V>,
    /// The level whose step and `S⁻¹` each lane holds.
    holds: PerLane<u32>,
}

impl<V: Lane> ImexLanes<V>
where
    V::Scalar: Real,
{
    fn new(plan: &InstancePlan, dim: usize) -> Self {
        let base = Arc::new(ImexMatrices::new(&plan.params, plan.dt_s));
        let mut levels = vec![None; MAX_LEVEL as usize + 1];
        levels[0] = Some(base.clone());
        ImexLanes {
            params: Arc::new(plan.params.clone()),
            base_s: plan.dt_s,
            imex: Imex::new(&base, dim),
            levels,
            holds: [0; MAX_LANES],
        }
    }

    /// Every lane's step and `S⁻¹` at its level in `level`.
    fn hold(&mut self, level: &[u32]) {
        for (l, &k) in level.iter().enumerate().take(V::LANES) {
            if self.holds[l] == k {
                continue;
            }
            let h = self.base_s / f64::from(1u32 << k);
            let params = &self.params;
            let m = self.levels[k as usize]
                .get_or_insert_with(|| Arc::new(ImexMatrices::new(params, h)));
            self.imex.set_lane_step(l, m);
            self.holds[l] = k;
        }
    }
}

impl<V: Lane> LanePair<V>
where
    V::Scalar: Real,
{
    /// The pair of the instances' method, for a state of length `dim`.
    fn new(plan: &InstancePlan, dim: usize) -> Self {
        match plan.method {
            Method::Rk4 => LanePair::Rk4(Rk4Pair::new(dim)),
            Method::Imex => LanePair::Imex(Box::new(ImexLanes::new(plan, dim))),
        }
    }

    /// The same pair with nothing carried over (the twins').
    pub(super) fn fresh(&self) -> Self {
        match self {
            LanePair::Rk4(p) => LanePair::Rk4(p.fresh()),
            LanePair::Imex(p) => {
                let mut p = p.clone();
                p.imex = p.imex.fresh_lanes();
                LanePair::Imex(p)
            }
        }
    }

    /// Forget the summation compensation of lane `i` (a twin starting there).
    pub(super) fn zero_compensation_lane(&mut self, i: usize) {
        match self {
            LanePair::Rk4(p) => p.zero_compensation_lane(i),
            LanePair::Imex(p) => p.imex.zero_compensation_lane(i),
        }
    }

    /// The fractions of a sub-step at which the stages take the cart.
    fn fractions(&self) -> &'static [f64] {
        match self {
            LanePair::Rk4(_) => &[0.0, 0.5, 1.0],
            LanePair::Imex(_) => &IMEX_C,
        }
    }

    /// Every stage of a sub-step from `y` (each lane's step `h`, at its `level`; the cart at
    /// [`LanePair::fractions`] in `acc`), by the exact law or on the branches `on`.
    fn stages(
        &mut self,
        (chain, ws): (&Chain<V>, &mut Workspace<V>),
        y: &[V],
        (h, level, acc): (V, &[u32], &[V; 4]),
        on: Option<&[Branches<V>; 4]>,
    ) -> [Branches<V>; 4] {
        match self {
            LanePair::Rk4(p) => p.stages((chain, ws), y, (h, [acc[0], acc[1], acc[2]]), on),
            LanePair::Imex(p) => {
                p.hold(level);
                match on {
                    None => p.imex.stages(chain, ws, y, &|i| acc[i]),
                    Some(b) => {
                        p.imex.stages_on(chain, ws, y, &|i| acc[i], b);
                        *b
                    }
                }
            }
        }
    }

    /// The estimate of the stages just computed into `out`.
    fn error(
        &mut self,
        (chain, ws): (&Chain<V>, &mut Workspace<V>),
        y: &[V],
        (h, acc): (V, &[V; 4]),
        out: &mut [V],
    ) {
        match self {
            LanePair::Rk4(p) => p.error((chain, ws), y, (h, acc[2]), out),
            LanePair::Imex(p) => p.imex.filtered_error(out),
        }
    }

    /// Take the sub-step just computed in the lanes where `mask` is positive.
    fn finish_masked(&mut self, y: &mut [V], h: V, mask: V) {
        match self {
            LanePair::Rk4(p) => p.finish_masked(y, h, mask),
            LanePair::Imex(p) => p.imex.finish_masked(y, mask),
        }
    }
}

/// The ladder of every lane of a group, with its pair.
#[derive(Clone)]
pub(super) struct LaneLadder<V: Lane> {
    /// Each lane's base step (s); the padding lanes of a short group have none.
    base_s: Vec<f64>,
    /// Each lane's tolerances.
    tol: Vec<Tolerance>,
    /// Each lane's place on the ladder: the level of its next sub-step and its position
    /// within its base step.
    rung: PerLane<Rung>,
    /// Each lane's base step under way (0-based).
    step: PerLane<u64>,
    /// Each lane's bumper contact onsets so far within its base step.
    onsets: PerLane<u32>,
    pair: LanePair<V>,
    err: Vec<V>,
    /// The cart at the pair's fractions of every base step of a period (base-level sub-steps
    /// read it; finer ones call `cart_at`, which gives the same values).
    cart: CartTable,
}

/// A lane's base step just ended: its number (1-based) and the contact onsets within it.
pub(super) type Ended = Option<(u64, u32)>;

/// A twin's onset saltation: `(lane, main state, twins' state, onsets)`.
pub(super) type Saltation<'a, V> = dyn FnMut(usize, &[V], &mut [V], (bool, bool)) + 'a;

/// The twins beside the main lanes during a base step: their state, their pair (a fresh one
/// of the main lanes'), which lanes' twin runs, and the saltation at a lane's contact onset.
pub(super) struct Twins<'a, V: Lane> {
    pub y: &'a mut [V],
    pub pair: &'a mut LanePair<V>,
    pub running: PerLane<bool>,
    pub salt: &'a mut Saltation<'a, V>,
}

/// What a pass judged of each lane: accepted, and its scaled error.
struct Judged {
    accepted: PerLane<bool>,
    errors: PerLane<f64>,
}

impl<V: Lane> LaneLadder<V>
where
    V::Scalar: Real,
{
    /// The ladders of the instances `plans` (at most `V::LANES`, of one method and, for IMEX,
    /// one linear part and base step), for a state of length `dim`.
    pub(super) fn new(plans: &[&InstancePlan], dim: usize) -> Self {
        let tol = |p: &InstancePlan| match p.control {
            crate::config::StepControl::Adaptive { rtol, atol } => Tolerance { rtol, atol },
            crate::config::StepControl::Fixed => unreachable!("a ladder of fixed steps"),
        };
        assert!(V::LANES <= MAX_LANES, "{} lanes", V::LANES);
        let pair = LanePair::new(plans[0], dim);
        LaneLadder {
            cart: CartTable::new(plans, pair.fractions()),
            pair,
            base_s: plans.iter().map(|p| p.dt_s).collect(),
            tol: plans.iter().map(|p| tol(p)).collect(),
            rung: [Rung::default(); MAX_LANES],
            step: [0; MAX_LANES],
            onsets: [0; MAX_LANES],
            err: vec![V::splat(0.0); dim],
        }
    }

    /// One pass: a sub-step tried in every lane in `live` (and taken by its twin where it
    /// runs and the lane's is accepted); the lanes whose base step ends with it
    /// ([`Ended`]). `touching` follows each lane's bumpers sub-step by sub-step. A lane goes
    /// on into its next base step at the next pass, whatever the others do.
    pub(super) fn pass(
        &mut self,
        (chain, ws): (&Chain<V>, &mut Workspace<V>),
        y: &mut [V],
        plans: &[&InstancePlan],
        live: &PerLane<bool>,
        mut twins: Option<Twins<'_, V>>,
        touching: &mut [(bool, bool)],
    ) -> PerLane<Ended> {
        let lanes = plans.len();
        let active: PerLane<bool> = std::array::from_fn(|l| l < lanes && live[l]);
        let (h, acc) = self.sub_step(plans, &active);
        // Each lane's level of this try (the judgement moves a rejected lane's on).
        let tried: PerLane<u32> = std::array::from_fn(|l| self.rung[l].level);
        let branches = self.pair.stages((chain, ws), y, (h, &tried, &acc), None);
        self.pair.error((chain, ws), y, (h, &acc), &mut self.err);
        let judged = self.judge(y, &active);
        let mask = V::gather(|l| f64::from(u8::from(judged.accepted[l])));
        self.pair.finish_masked(y, h, mask);
        let new = self.onsets_in(chain, y, &judged.accepted, touching);
        if let Some(t) = &mut twins {
            let follows = |l: usize| judged.accepted[l] && t.running[l];
            if (0..V::LANES).any(follows) {
                let tmask = V::gather(|l| f64::from(u8::from(follows(l))));
                let on = Some(&branches);
                t.pair.stages((chain, ws), t.y, (h, &tried, &acc), on);
                t.pair.finish_masked(t.y, h, tmask);
                for l in (0..lanes).filter(|&l| follows(l) && (new[l].0 || new[l].1)) {
                    (t.salt)(l, y, t.y, new[l]);
                }
            }
        }
        self.advance(&judged)
    }

    /// The bumper contacts that began in each accepted lane with its sub-step (counted into
    /// the lane's onsets), `touching` moved on.
    fn onsets_in(
        &mut self,
        chain: &Chain<V>,
        y: &[V],
        accepted: &PerLane<bool>,
        touching: &mut [(bool, bool)],
    ) -> PerLane<(bool, bool)> {
        let pen = chain.penetrations(y);
        let zero = <V::Scalar as num_traits::Zero>::zero();
        let now = |l: usize| {
            pen.map_or((false, false), |(r, q)| {
                (r.lane(l) > zero, q.lane(l) > zero)
            })
        };
        let mut new = [(false, false); MAX_LANES];
        for l in (0..touching.len()).filter(|&l| accepted[l]) {
            new[l] = onsets_of(touching[l], now(l));
            self.onsets[l] += u32::from(new[l].0) + u32::from(new[l].1);
            touching[l] = now(l);
        }
        new
    }

    /// Each lane's step and the cart at the pair's fractions of its sub-step, from its
    /// position within its base step (a zero step where the lane is not `active`).
    fn sub_step(&self, plans: &[&InstancePlan], active: &PerLane<bool>) -> (V, [V; 4]) {
        let h = V::gather(|l| {
            if active[l] {
                self.rung[l].step_s(self.base_s[l])
            } else {
                0.0
            }
        });
        let fracs = self.pair.fractions();
        let acc = std::array::from_fn(|j| {
            let Some(&c) = fracs.get(j) else {
                return V::splat(0.0);
            };
            V::gather(|l| {
                if !active[l] {
                    return 0.0;
                }
                if self.rung[l] == Rung::default() {
                    return self.cart.at_lane(l, self.step[l], j);
                }
                let (start, width) = self.rung[l].fractions();
                plans[l].cart_at(self.step[l], start + c * width).a_m_s2
            })
        });
        (h, acc)
    }

    /// Each active lane's scaled error (in f64, from its values, as the scalar loop computes
    /// it), accepted or taken again one level finer.
    fn judge(&mut self, y: &[V], active: &PerLane<bool>) -> Judged {
        let mut judged = Judged {
            accepted: [false; MAX_LANES],
            errors: [0.0; MAX_LANES],
        };
        for l in (0..V::LANES).filter(|&l| active[l]) {
            let e = self.tol[l].scaled_error(&self.err, y, l);
            judged.errors[l] = e;
            judged.accepted[l] = self.rung[l].judge(e);
        }
        judged
    }

    /// The accepted lanes on by their sub-step, each one level coarser where the position is
    /// aligned to it and the error small; those at the end of their base step on to the next.
    fn advance(&mut self, judged: &Judged) -> PerLane<Ended> {
        let mut ended = [None; MAX_LANES];
        for l in (0..V::LANES).filter(|&l| judged.accepted[l]) {
            if self.rung[l].advance(judged.errors[l]) {
                self.step[l] += 1;
                ended[l] = Some((self.step[l], self.onsets[l]));
                self.onsets[l] = 0;
            }
        }
        ended
    }

    /// The twins' pair (a fresh one: no compensation carried).
    pub(super) fn twin_pair(&self) -> LanePair<V> {
        self.pair.fresh()
    }
}

//! The SIMD loop of the CPU engine: instances integrated side by side in the lanes of a vector
//! ([`Lane`]: 4 in `f64`, 8 in `f32`), structure of arrays, rayon over lane groups.
//!
//! Stages of [`integrate_lanes`]:
//! 1. [`lane_groups`]: instances of the same structure (and IMEX matrices) are sorted by their
//!    step count and cut into groups of `LANES`, the last one padded by repeating its last
//!    instance; the grouping depends on the plan alone, so results do not depend on the
//!    thread count;
//! 2. [`run_group`]: one step of the whole vector ([`rk4_step`] or [`Imex::step_with`], the
//!    very functions the scalar loop runs), and of the vector of λ1's twins while any lane's
//!    twin runs, then per lane, in the scalar loop's order: bumper onsets, the health check
//!    when due ([`health_due`], [`crate::model::Guard::check`] on that lane), the bookkeeping
//!    of [`EnsembleHook::record`] (which starts and renormalises that lane's twin). A lane that
//!    has failed, stopped early or run all its steps is masked: its arithmetic goes on, its
//!    results are frozen; the group ends when every lane has;
//! 3. the cart's acceleration at each stage comes from a per-lane table of one forcing period
//!    ([`CartTable`]), filled by the same `cart_at` the scalar loop calls.
//!
//! Steps 2 and 3 are those of fixed steps ([`fixed_steps`]). Adaptive steps
//! ([`ladder_steps`]) go pass by pass instead, each lane on its own ladder (`lane_ladder.rs`),
//! its bookkeeping as soon as its base step ends.

use super::cart_table::CartTable;
use super::hook::{EnsembleHook, LaneView, LaneViewMut, RawInstance};
use super::lane_ladder::{Ended, LaneLadder, MAX_LANES, PerLane, Twins};
use crate::config::StepControl;
use crate::engine::imex::{C as IMEX_C, Imex};
use crate::engine::method::Method;
use crate::engine::plan::{EnsemblePlan, InstancePlan};
use crate::engine::rk4::{Rk4Scratch, rk4_step, rk4_step_twin};
use crate::engine::state_view::StateView;
use crate::engine::twin::{onset_saltation, onsets_of};
use crate::engine::{EngineError, Progress};
use crate::model::{Chain, Lane, ModelParams, Real, Status, Workspace, health_due};
use rayon::prelude::*;

/// Stage fractions of a step at which RK4 takes the cart (start, middle, end).
const RK4_STAGES: [f64; 3] = [0.0, 0.5, 1.0];

/// Integrate every instance of `plan` in lanes of `V` (λ1's twins at separation `d0`); results
/// in plan order.
pub(super) fn integrate_lanes<V: Lane>(
    plan: &EnsemblePlan,
    d0: Option<f64>,
    progress: Progress,
) -> Result<Vec<RawInstance>, EngineError>
where
    V::Scalar: Real,
{
    let groups = lane_groups(plan, V::LANES);
    // Asked at every lane's period ends too, so that a cancel stops running groups.
    let asked = super::Asker::new(progress, plan.instances.len() as u64);
    let stop = || !asked.go_on();
    let runs: Vec<Vec<RawInstance>> = groups
        .par_iter()
        .map(|g| {
            let raw = run_group::<V>(plan, g, d0, &stop);
            asked.finished(g.len() as u64)?;
            Ok(raw)
        })
        .collect::<Result<_, EngineError>>()?;
    let mut out: Vec<Option<RawInstance>> = vec![None; plan.instances.len()];
    for (g, raws) in groups.iter().zip(runs) {
        for (&i, r) in g.iter().zip(raws) {
            out[i] = Some(r);
        }
    }
    Ok(out
        .into_iter()
        .map(|r| r.expect("every instance is in one group"))
        .collect())
}

/// Instance indices in groups of at most `lanes` that can share a vector: the same structure
/// ([`Chain::same_structure`]) and, for IMEX, the same linear part and step
/// ([`InstancePlan::imex_key`]: one set of matrices, or of ladder levels), sorted by step count
/// within a class.
fn lane_groups(plan: &EnsemblePlan, lanes: usize) -> Vec<Vec<usize>> {
    let key = |p: &InstancePlan| (p.method == Method::Imex).then(|| p.imex_key());
    let mut classes: Vec<Vec<usize>> = Vec::new();
    for (i, p) in plan.instances.iter().enumerate() {
        let same = |c: &Vec<usize>| {
            let q = &plan.instances[c[0]];
            key(q) == key(p) && Chain::<f64>::same_structure(&q.params, &p.params)
        };
        match classes.iter_mut().find(|c| same(c)) {
            Some(c) => c.push(i),
            None => classes.push(vec![i]),
        }
    }
    let mut groups = Vec::new();
    for mut c in classes {
        c.sort_by_key(|&i| plan.instances[i].total_steps());
        groups.extend(c.chunks(lanes).map(<[usize]>::to_vec));
    }
    groups
}

/// The integrator of a lane group.
#[derive(Clone)]
enum LaneStepper<V: Lane> {
    Rk4 { dt: V, scratch: Rk4Scratch<V> },
    Imex(Box<Imex<V>>),
}

impl<V: Lane> LaneStepper<V>
where
    V::Scalar: Real,
{
    fn new(plans: &[&InstancePlan], dim: usize) -> (LaneStepper<V>, Vec<f64>) {
        match &plans[0].imex {
            None => {
                let dt = V::gather(|i| plans[i % plans.len()].dt_s);
                let scratch = Rk4Scratch::new(dim);
                (LaneStepper::Rk4 { dt, scratch }, RK4_STAGES.to_vec())
            }
            Some(m) => (
                LaneStepper::Imex(Box::new(Imex::new(m, dim))),
                IMEX_C.to_vec(),
            ),
        }
    }

    /// The same integrator with nothing carried over (the stepper of the twins).
    fn fresh(&self, dim: usize) -> LaneStepper<V> {
        match self {
            LaneStepper::Rk4 { dt, .. } => LaneStepper::Rk4 {
                dt: *dt,
                scratch: Rk4Scratch::new(dim),
            },
            LaneStepper::Imex(imex) => LaneStepper::Imex(Box::new(imex.fresh_lanes())),
        }
    }

    /// Forget the summation compensation of lane `i`: a twin starts there, and what the lane
    /// carried from its placeholder state must not leak into it.
    fn zero_compensation_lane(&mut self, i: usize) {
        match self {
            LaneStepper::Rk4 { scratch, .. } => scratch.zero_compensation_lane(i),
            LaneStepper::Imex(imex) => imex.zero_compensation_lane(i),
        }
    }

    /// One step of `y` and of the twins' state `ty` beside it (their stepper `twin`), the
    /// twins on the branches of the main stages.
    #[inline]
    fn step_twin(
        &mut self,
        twin: &mut LaneStepper<V>,
        chain: &Chain<V>,
        ws: &mut Workspace<V>,
        (y, ty): (&mut [V], &mut [V]),
        cart: &CartTable,
    ) {
        match (self, twin) {
            (LaneStepper::Rk4 { dt, scratch }, LaneStepper::Rk4 { scratch: ts, .. }) => {
                let acc = [0, 1, 2].map(|j| cart.at::<V>(j));
                rk4_step_twin(chain, ws, y, scratch, *dt, acc, (ty, ts));
            }
            (LaneStepper::Imex(main), LaneStepper::Imex(tw)) => {
                main.step_pair(chain, ws, y, &|j| cart.at::<V>(j), Some((tw.as_mut(), ty)));
            }
            _ => unreachable!("a twin's stepper is its main stepper, fresh"),
        }
    }

    #[inline]
    fn step(&mut self, chain: &Chain<V>, ws: &mut Workspace<V>, y: &mut [V], cart: &CartTable) {
        match self {
            LaneStepper::Rk4 { dt, scratch } => {
                let acc = [0, 1, 2].map(|j| cart.at::<V>(j));
                rk4_step(chain, ws, y, scratch, *dt, acc);
            }
            LaneStepper::Imex(imex) => imex.step_with(chain, ws, y, |j| cart.at::<V>(j)),
        }
    }
}

/// One lane of a group: its instance, a scalar chain for the health check, the bookkeeping.
struct LaneState<'a, T: Real> {
    plan: &'a InstancePlan,
    chain: Chain<T>,
    hook: EnsembleHook<'a, T>,
    /// `Some` once the lane has ended: its status and steps.
    end: Option<(Status, u64)>,
    /// The lane's state where it ended (the group steps on after it).
    y_end: Vec<f64>,
    /// Adaptive steps: the sub-steps the lane tried (one a pass while it is live).
    sub_steps: u64,
}

impl<T: Real> LaneState<'_, T> {
    /// The scalar loop's work after step `step` for this lane, `onsets` bumper contacts
    /// having begun within it (`twin`: its lane of the twins).
    fn after_step<V: Lane<Scalar = T>>(
        &mut self,
        step: u64,
        y: &LaneView<'_, V>,
        onsets: u32,
        twin: &mut LaneViewMut<'_, V>,
    ) {
        let total = self.plan.total_steps();
        if health_due(step, total, false) {
            let state: Vec<T> = (0..y.len()).map(|k| y.at(k)).collect();
            let v = self.plan.cart_at(step, 0.0).v_m_s;
            let status = self.plan.guard.check(&self.chain, &state, v);
            if status != Status::Ok {
                self.end = Some((status, step));
                return;
            }
        }
        if self.hook.record(step, y, onsets, twin).is_break() || step == total {
            self.end = Some((Status::Ok, step));
            self.y_end = (0..y.len()).map(|k| y.at(k).wide()).collect();
        }
    }
}

/// A group's vectors: its lanes' chain and workspace, their state and λ1's twins beside it,
/// and which bumpers each lane touches.
struct Vectors<V: Lane> {
    chain: Chain<V>,
    ws: Workspace<V>,
    y: Vec<V>,
    twin_y: Vec<V>,
    touching: Vec<(bool, bool)>,
}

/// Integrate the instances `members` of `plan` side by side in the lanes of `V`, with λ1's
/// twins at separation `d0` in a second vector: fixed steps all together ([`fixed_steps`]),
/// adaptive ones each lane its own ([`ladder_steps`]).
fn run_group<V: Lane>(
    plan: &EnsemblePlan,
    members: &[usize],
    d0: Option<f64>,
    stop: &(dyn Fn() -> bool + Sync),
) -> Vec<RawInstance>
where
    V::Scalar: Real,
{
    let plans: Vec<&InstancePlan> = members.iter().map(|&i| &plan.instances[i]).collect();
    let params: Vec<ModelParams> = plans.iter().map(|p| p.params.clone()).collect();
    let chain: Chain<V> = Chain::from_lanes(&params);
    let dim = plans[0].y0.len();
    let y: Vec<V> = (0..dim)
        .map(|k| V::gather(|i| plans[i % plans.len()].y0[k]))
        .collect();
    let now = touching_lanes(&chain, &y);
    let mut v = Vectors {
        ws: chain.workspace(),
        touching: (0..plans.len()).map(now).collect(),
        twin_y: y.clone(),
        y,
        chain,
    };
    let mut lanes: Vec<LaneState<V::Scalar>> = plans
        .iter()
        .map(|&p| LaneState {
            plan: p,
            chain: Chain::new(&p.params),
            hook: EnsembleHook::new(p, plan.want_strobe, plan.want_rseries, plan.early_stop, d0)
                .with_stop(Some(stop)),
            end: None,
            y_end: Vec::new(),
            sub_steps: 0,
        })
        .collect();
    if plans[0].control == StepControl::Fixed {
        fixed_steps(&plans, &mut v, &mut lanes);
    } else {
        ladder_steps(&plans, &mut v, &mut lanes);
    }
    lanes
        .into_iter()
        .map(|l| {
            let (status, steps) = l.end.unwrap_or((Status::Ok, l.plan.total_steps()));
            let mut raw = l.hook.finish();
            raw.tally.status = status;
            raw.tally.steps = steps;
            raw.y_end = l.y_end;
            raw.sub_steps = l.sub_steps;
            raw
        })
        .collect()
}

/// Fixed steps: every lane's step `n` at once, until every lane has ended.
fn fixed_steps<V: Lane>(
    plans: &[&InstancePlan],
    v: &mut Vectors<V>,
    lanes: &mut [LaneState<V::Scalar>],
) where
    V::Scalar: Real,
{
    let dim = v.y.len();
    let (mut stepper, fracs) = LaneStepper::<V>::new(plans, dim);
    let mut cart = CartTable::new(plans, &fracs);
    let mut twin_stepper = stepper.fresh(dim);
    let mut twins_running = false;
    let longest = plans.iter().map(|p| p.total_steps()).max().unwrap_or(0);
    for n in 0..longest {
        let group = Group {
            chain: &v.chain,
            lanes,
            twins_running,
        };
        let onsets = group.step(
            (&mut stepper, &mut twin_stepper),
            &mut v.ws,
            (&mut v.y, &mut v.twin_y),
            &cart,
            &mut v.touching,
        );
        cart.advance();
        let ended = std::array::from_fn(|i| Some((n + 1, onsets[i])));
        let started = after_steps(lanes, &v.y, &mut v.twin_y, &ended);
        for i in (0..MAX_LANES).filter(|&i| started[i]) {
            twin_stepper.zero_compensation_lane(i);
        }
        if lanes.iter().all(|l| l.end.is_some()) {
            break;
        }
        twins_running = lanes
            .iter()
            .any(|l| l.end.is_none() && l.hook.twin_running());
    }
}

/// Adaptive steps: a pass of the lanes' ladders at a time ([`LaneLadder::pass`]), each lane's
/// bookkeeping as soon as its base step ends, until every lane has ended.
fn ladder_steps<V: Lane>(
    plans: &[&InstancePlan],
    v: &mut Vectors<V>,
    lanes: &mut [LaneState<V::Scalar>],
) where
    V::Scalar: Real,
{
    let mut ladder = LaneLadder::<V>::new(plans, v.y.len());
    let mut twin_pair = ladder.twin_pair();
    loop {
        let lane_is = |f: &dyn Fn(&LaneState<V::Scalar>) -> bool| -> PerLane<bool> {
            std::array::from_fn(|i| lanes.get(i).is_some_and(f))
        };
        let live = lane_is(&|l| l.end.is_none());
        if !live.iter().any(|&l| l) {
            break;
        }
        let running = lane_is(&|l| l.end.is_none() && l.hook.twin_running());
        for (lane, _) in lanes.iter_mut().zip(live).filter(|(_, on)| *on) {
            lane.sub_steps += 1;
        }
        let ended = {
            let lanes = &*lanes;
            let mut salt = |l: usize, y: &[V], ty: &mut [V], on: (bool, bool)| {
                lane_saltation(&lanes[l], y, ty, l, on);
            };
            let twins = running.iter().any(|&r| r).then(|| Twins {
                y: &mut v.twin_y,
                pair: &mut twin_pair,
                running,
                salt: &mut salt,
            });
            let at = (&v.chain, &mut v.ws);
            ladder.pass(at, &mut v.y, plans, &live, twins, &mut v.touching)
        };
        let started = after_steps(lanes, &v.y, &mut v.twin_y, &ended);
        for i in (0..MAX_LANES).filter(|&i| started[i]) {
            twin_pair.zero_compensation_lane(i);
        }
    }
}

/// The scalar loop's work for every live lane whose step has ended (`ended[i]`: the step's
/// number and the bumper contact onsets within it); the lanes whose twin started with it
/// (their twin's stepper must forget its compensation there).
fn after_steps<V: Lane>(
    lanes: &mut [LaneState<'_, V::Scalar>],
    y: &[V],
    twin_y: &mut [V],
    ended: &PerLane<Ended>,
) -> PerLane<bool>
where
    V::Scalar: Real,
{
    let mut started = [false; MAX_LANES];
    for (i, lane) in lanes.iter_mut().enumerate() {
        let (None, Some((step, onsets))) = (lane.end, ended[i]) else {
            continue;
        };
        let mut twin = LaneViewMut { y: twin_y, lane: i };
        let was = lane.hook.twin_running();
        lane.after_step(step, &LaneView { y, lane: i }, onsets, &mut twin);
        started[i] = !was && lane.hook.twin_running();
    }
    started
}

/// What one fixed step of a group reads: the vector chain and the lanes' states.
struct Group<'g, 'a, V: Lane>
where
    V::Scalar: Real,
{
    chain: &'g Chain<V>,
    lanes: &'g [LaneState<'a, V::Scalar>],
    twins_running: bool,
}

impl<V: Lane> Group<'_, '_, V>
where
    V::Scalar: Real,
{
    /// The next step of every lane (and of the twins while any runs, with their onset
    /// saltations; `cart` at its step); per lane, the bumper contact onsets within
    /// it, `touching` following the bumpers.
    fn step(
        &self,
        (stepper, twin_stepper): (&mut LaneStepper<V>, &mut LaneStepper<V>),
        ws: &mut Workspace<V>,
        (y, twin_y): (&mut [V], &mut [V]),
        cart: &CartTable,
        touching: &mut [(bool, bool)],
    ) -> PerLane<u32> {
        let twin_runs = |l: &LaneState<V::Scalar>| l.end.is_none() && l.hook.twin_running();
        if self.twins_running {
            stepper.step_twin(twin_stepper, self.chain, ws, (y, twin_y), cart);
        } else {
            stepper.step(self.chain, ws, y, cart);
        }
        let now = touching_lanes(self.chain, y);
        let mut onsets = [0; MAX_LANES];
        for (i, lane) in self.lanes.iter().enumerate() {
            let new = onsets_of(touching[i], now(i));
            touching[i] = now(i);
            onsets[i] = u32::from(new.0) + u32::from(new.1);
            if self.twins_running && twin_runs(lane) && (new.0 || new.1) {
                lane_saltation(lane, y, twin_y, i, new);
            }
        }
        onsets
    }
}

/// [`onset_saltation`] of lane `i` (its scalar chain, its lanes of the main and twin states).
fn lane_saltation<V: Lane>(
    lane: &LaneState<'_, V::Scalar>,
    y: &[V],
    twin: &mut [V],
    i: usize,
    onsets: (bool, bool),
) where
    V::Scalar: Real,
{
    let main: Vec<V::Scalar> = y.iter().map(|v| v.lane(i)).collect();
    let mut tw: Vec<V::Scalar> = twin.iter().map(|v| v.lane(i)).collect();
    let mut ws = lane.chain.workspace();
    onset_saltation(&lane.chain, &mut ws, &main, &mut tw, onsets);
    for (t, &v) in twin.iter_mut().zip(&tw) {
        *t = t.with_lane(i, v);
    }
}

/// Which bumpers each lane touches (δ > 0), as a function of the lane.
fn touching_lanes<V: Lane>(chain: &Chain<V>, y: &[V]) -> impl Fn(usize) -> (bool, bool) + use<V> {
    let pen = chain.penetrations(y);
    let zero = <V::Scalar as num_traits::Zero>::zero();
    move |i| {
        pen.map_or((false, false), |(r, l)| {
            (r.lane(i) > zero, l.lane(i) > zero)
        })
    }
}

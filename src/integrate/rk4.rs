//! Classical fixed-step RK4, generic over `f32`/`f64`, for one instance or a rayon batch.
//!
//! Time never accumulates: every stage takes its cart acceleration from
//! [`CartMotion::at_step`] with the integer step count. The state is checked for non-finite
//! values and for divergence ([`Guard`]) every few steps; a failed instance stops early and is
//! reported by its [`Status`], never as numbers.

use crate::integrate::plan::StepPlan;
use crate::integrate::status::{Guard, Status};
use crate::model::{CartMotion, CartState, Chain, ContactLaw, Real, Workspace};
use rayon::prelude::*;
use serde::Serialize;

/// Receives the state at every output row (step 0 and every `sample_every` steps).
pub trait Observer<T: Real> {
    /// One output row. `ws` is scratch the observer may use with `chain`.
    fn sample(
        &mut self,
        step: u64,
        t_s: f64,
        cart: &CartState,
        y: &[T],
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
    );
}

/// An observer that records nothing.
pub struct NoObserver;

impl<T: Real> Observer<T> for NoObserver {
    fn sample(
        &mut self,
        _: u64,
        _: f64,
        _: &CartState,
        _: &[T],
        _: &Chain<T>,
        _: &mut Workspace<T>,
    ) {
    }
}

/// How one instance's integration ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Outcome {
    /// Final status.
    pub status: Status,
    /// Steps actually taken (fewer than planned when the instance failed).
    pub steps_done: u64,
    /// Bumper contact onsets counted at every step.
    pub impacts: u64,
    /// Time at which the failure was detected (s), if any.
    pub failed_at_s: Option<f64>,
}

/// One independent instance of a batch: its chain, cart motion and initial state.
pub struct Instance<T: Real> {
    /// The chain's coefficients.
    pub chain: Chain<T>,
    /// The cart motion.
    pub cart: CartMotion,
    /// Initial state `[θ; θ̇; v]`.
    pub y0: Vec<f64>,
    /// Divergence bounds.
    pub guard: Guard,
}

/// Steps between health checks when the output interval is long.
const CHECK_EVERY: u64 = 64;

/// Integrate one instance with RK4 over the plan, calling the observer at every output row.
pub fn integrate<T: Real, O: Observer<T>>(
    inst: &Instance<T>,
    plan: &StepPlan,
    obs: &mut O,
) -> Outcome {
    let chain = &inst.chain;
    let dim = inst.y0.len();
    let mut ws = chain.workspace();
    let mut y: Vec<T> = inst.y0.iter().map(|&v| T::of(v)).collect();
    let mut k = [
        vec![T::zero(); dim],
        vec![T::zero(); dim],
        vec![T::zero(); dim],
        vec![T::zero(); dim],
    ];
    let mut tmp = vec![T::zero(); dim];
    let dt = T::of(plan.dt_s);
    let mut impacts = 0u64;
    let mut touching = touch_flags(chain, &mut ws, &y);
    let cart0 = inst.cart.at_step(0, 0.0, plan.dt_s);
    obs.sample(0, 0.0, &cart0, &y, chain, &mut ws);
    let check = plan.sample_every.clamp(1, CHECK_EVERY);
    let mut cart_end = inst.cart.at_step(0, 0.0, plan.dt_s);
    for n in 0..plan.steps {
        let a0 = cart_end.a_m_s2;
        let a_mid = inst.cart.at_step(n, 0.5, plan.dt_s).a_m_s2;
        cart_end = inst.cart.at_step(n + 1, 0.0, plan.dt_s);
        let a1 = cart_end.a_m_s2;
        rk4_step(
            chain,
            &mut ws,
            &mut y,
            &mut k,
            &mut tmp,
            dt,
            [T::of(a0), T::of(a_mid), T::of(a1)],
        );
        let now = touch_flags(chain, &mut ws, &y);
        impacts += u64::from(now.0 && !touching.0) + u64::from(now.1 && !touching.1);
        touching = now;
        let step = n + 1;
        let row = step % plan.sample_every == 0;
        if row || step % check == 0 || step == plan.steps {
            let t = step as f64 * plan.dt_s;
            if let Some(status) = health(inst, &y, &cart_end) {
                return Outcome {
                    status,
                    steps_done: step,
                    impacts,
                    failed_at_s: Some(t),
                };
            }
            if row {
                obs.sample(step, t, &cart_end, &y, chain, &mut ws);
            }
        }
    }
    Outcome {
        status: Status::Ok,
        steps_done: plan.steps,
        impacts,
        failed_at_s: None,
    }
}

/// Integrate a batch of independent instances in parallel (rayon), one observer each.
pub fn integrate_batch<T: Real, O: Observer<T> + Send>(
    instances: &[Instance<T>],
    plan: &StepPlan,
    observers: &mut [O],
) -> Vec<Outcome> {
    assert_eq!(
        instances.len(),
        observers.len(),
        "one observer per instance"
    );
    instances
        .par_iter()
        .zip(observers.par_iter_mut())
        .map(|(inst, obs)| integrate(inst, plan, obs))
        .collect()
}

/// One classical RK4 step of `y` by `dt`, with the cart acceleration at the start, middle
/// and end of the step. `k` and `tmp` are scratch of the state's length.
#[inline]
pub fn rk4_step<T: Real>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    k: &mut [Vec<T>; 4],
    tmp: &mut [T],
    dt: T,
    cart_acc: [T; 3],
) {
    let half = T::of(0.5);
    let sixth = T::of(1.0 / 6.0);
    let [a0, a_mid, a1] = cart_acc;
    chain.derivative(ws, a0, y, &mut k[0], ContactLaw::Exact);
    stage(tmp, y, &k[0], dt * half);
    chain.derivative(ws, a_mid, tmp, &mut k[1], ContactLaw::Exact);
    stage(tmp, y, &k[1], dt * half);
    chain.derivative(ws, a_mid, tmp, &mut k[2], ContactLaw::Exact);
    stage(tmp, y, &k[2], dt);
    chain.derivative(ws, a1, tmp, &mut k[3], ContactLaw::Exact);
    for i in 0..y.len() {
        y[i] += dt * sixth * (k[0][i] + T::of(2.0) * (k[1][i] + k[2][i]) + k[3][i]);
    }
}

#[inline]
fn stage<T: Real>(out: &mut [T], y: &[T], k: &[T], h: T) {
    for ((o, &yi), &ki) in out.iter_mut().zip(y).zip(k) {
        *o = yi + h * ki;
    }
}

#[inline]
fn touch_flags<T: Real>(chain: &Chain<T>, ws: &mut Workspace<T>, y: &[T]) -> (bool, bool) {
    chain.touching(ws, y)
}

/// `None` when healthy, otherwise the failure status.
pub fn health<T: Real>(inst: &Instance<T>, y: &[T], cart: &CartState) -> Option<Status> {
    if y.iter().any(|v| !v.is_finite()) {
        return Some(Status::NonFinite);
    }
    let n = inst.chain.segments();
    if y[0].abs().wide() > inst.guard.max_holder_angle_rad {
        return Some(Status::Escaped);
    }
    let bent = (1..n).any(|i| (y[i] - y[i - 1]).abs().wide() > inst.guard.max_joint_bend_rad);
    let e = inst.chain.energy(y, cart.x_m, cart.v_m_s).total_j();
    if bent || !e.is_finite() || e.abs() > inst.guard.max_energy_j {
        return Some(Status::Diverged);
    }
    None
}

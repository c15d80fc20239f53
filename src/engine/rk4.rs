//! Classical fixed-step RK4 and the one step loop that every CPU path runs (single runs and the
//! CPU ensemble engine alike; the WGSL kernel mirrors it, see `shaders/integrate.wgsl`).
//!
//! The loop takes the cart from a [`CartClock`] (time-based for single runs, exact-phase for
//! ensembles), counts bumper contact onsets, checks the state's health by the model's rules
//! ([`health_due`], [`Guard::check`]) and hands every step to a [`StepHook`], which records what
//! its caller needs and may end the run early.

use crate::model::{Chain, ContactLaw, Guard, Real, Status, Workspace, health_due};
use std::ops::ControlFlow;

/// Where the cart is at each step of a run.
pub trait CartClock {
    /// Cart acceleration (m/s²) at the start, the middle and the end of step `step` (0-based).
    fn stage_accelerations(&self, step: u64) -> [f64; 3];
    /// Cart velocity (m/s) after `step` steps.
    fn velocity(&self, step: u64) -> f64;
}

/// What a run does with each step.
pub trait StepHook<T: Real> {
    /// Whether the state after `step` steps is recorded (its health is then checked first, so
    /// a failed state is never recorded).
    fn records(&self, step: u64) -> bool;
    /// After `step` steps (1-based) with state `y`; `onsets` bumper contacts began at this step.
    /// `Break` ends the run early (a confirmed periodic orbit, say) with status `ok`.
    fn after_step(
        &mut self,
        step: u64,
        y: &[T],
        onsets: u32,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
    ) -> ControlFlow<()>;
}

/// How a step loop ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopEnd {
    /// `Ok` unless a health check failed.
    pub status: Status,
    /// Steps taken.
    pub steps_done: u64,
}

/// Scratch of one RK4 step: the four stage derivatives and a stage state.
#[derive(Debug, Clone)]
pub struct Rk4Scratch<T> {
    k: [Vec<T>; 4],
    tmp: Vec<T>,
}

impl<T: Real> Rk4Scratch<T> {
    /// Scratch for a state of length `dim`.
    pub fn new(dim: usize) -> Self {
        let z = vec![T::zero(); dim];
        Rk4Scratch {
            k: [z.clone(), z.clone(), z.clone(), z.clone()],
            tmp: z,
        }
    }
}

/// One classical RK4 step of `y` by `dt`, with the cart acceleration at the start, middle
/// and end of the step.
#[inline]
pub fn rk4_step<T: Real>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
) {
    let half = T::of(0.5);
    let sixth = T::of(1.0 / 6.0);
    let [a0, a_mid, a1] = cart_acc;
    let (k, tmp) = (&mut s.k, &mut s.tmp);
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

/// Integrate `y` over `steps` RK4 steps of `dt_s` (s), the cart given by `clock`.
#[allow(clippy::too_many_arguments)]
pub fn run_steps<T: Real, C: CartClock, H: StepHook<T>>(
    chain: &Chain<T>,
    guard: &Guard,
    y: &mut [T],
    dt_s: f64,
    steps: u64,
    clock: &C,
    hook: &mut H,
) -> LoopEnd {
    let mut ws = chain.workspace();
    let mut scratch = Rk4Scratch::new(y.len());
    let dt = T::of(dt_s);
    let mut touching = chain.touching(y);
    for n in 0..steps {
        let acc = clock.stage_accelerations(n);
        rk4_step(chain, &mut ws, y, &mut scratch, dt, acc.map(T::of));
        let now = chain.touching(y);
        let onsets = u32::from(now.0 && !touching.0) + u32::from(now.1 && !touching.1);
        touching = now;
        let step = n + 1;
        if health_due(step, steps, hook.records(step)) {
            let status = guard.check(chain, y, clock.velocity(step));
            if status != Status::Ok {
                return LoopEnd {
                    status,
                    steps_done: step,
                };
            }
        }
        if hook.after_step(step, y, onsets, chain, &mut ws).is_break() {
            return LoopEnd {
                status: Status::Ok,
                steps_done: step,
            };
        }
    }
    LoopEnd {
        status: Status::Ok,
        steps_done: steps,
    }
}

//! The one step loop that every CPU path runs (single runs and the CPU ensemble engine alike;
//! the WGSL kernel mirrors it, see `shaders/integrate.wgsl`), over any `Stepper`.
//!
//! The loop takes the cart from a `CartClock` (time-based for single runs, exact-phase for
//! ensembles), counts bumper contact onsets, checks the state's health by the model's rules
//! ([`health_due`], [`Guard::check`]) and hands every step to a `StepHook`, which records what
//! its caller needs and may end the run early.

use crate::engine::twin::{onset_saltation, onsets_of};
use crate::model::{Chain, Guard, Lane, Real, Status, Workspace, health_due};
use std::ops::ControlFlow;

/// Where the cart is at each step of a run.
pub(crate) trait CartClock {
    /// Cart acceleration (m/s²) at `frac` of step `step` (0-based): t = (step + frac)·dt.
    fn acceleration(&self, step: u64, frac: f64) -> f64;
    /// Cart velocity (m/s) after `step` steps.
    fn velocity(&self, step: u64) -> f64;
}

/// A fixed-step integration method: advances the state by one step.
pub(crate) trait Stepper<T: Real> {
    /// The same method at the same step with nothing carried over (no summation
    /// compensation): the stepper of a twin trajectory.
    fn fresh(&self) -> Self
    where
        Self: Sized;

    /// Advance `y = [θ; θ̇; v]` by one step from step index `step`.
    fn step<C: CartClock>(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        step: u64,
        clock: &C,
    );

    /// Advance `y` and λ1's twin beside it (with its own stepper) by one step, the twin's
    /// bumpers on the branches of the main stages (`crate::engine::twin`).
    fn step_twin<C: CartClock>(
        &mut self,
        twin_stepper: &mut Self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y_and_twin: (&mut [T], &mut [T]),
        step: u64,
        clock: &C,
    ) where
        Self: Sized;

    /// Bumper contact onsets inside the last step when the stepper counts them itself (an
    /// adaptive step made of sub-steps, which also applies the twin's onset saltation at the
    /// sub-step where a contact begins); `None`: the loop counts them at the step's end.
    fn onsets_within(&mut self) -> Option<u32> {
        None
    }
}

/// `y += inc` with Kahan's compensation `comp` (one per state component, zero at the start).
///
/// A step adds an increment much smaller than the state (`h θ̇ ≈ 1e-5 θ` at the IMEX step,
/// `1e-7 θ` at RK4's with stiff dampers); in f32 each addition rounds away up to 6e-8 of θ,
/// and over 1e5–1e6 steps the rounding adds up to a drift that changes the dynamics
/// (a chaotic cell computed as regular). The compensation carries the rounded-away part into
/// the next step, so the sum is accurate to a few roundings whatever the step count.
#[inline]
pub(crate) fn compensated_add<T: Lane>(y: &mut T, comp: &mut T, inc: T) {
    let corrected = inc - *comp;
    let sum = *y + corrected;
    *comp = (sum.opaque() - *y) - corrected;
    *y = sum;
}

/// What a run does with each step.
pub(crate) trait StepHook<T: Real> {
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

    /// The state of the twin trajectory the loop advances beside the main one with the same
    /// step (λ1), while the hook runs one.
    fn twin(&mut self) -> Option<&mut [T]> {
        None
    }
}

/// How a step loop ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LoopEnd {
    /// `Ok` unless a health check failed.
    pub status: Status,
    /// Steps taken.
    pub steps_done: u64,
}

/// Integrate `y` over `steps` steps of `stepper`, the cart given by `clock`.
pub(crate) fn run_steps<T: Real, S: Stepper<T>, C: CartClock, H: StepHook<T>>(
    chain: &Chain<T>,
    guard: &Guard,
    y: &mut [T],
    stepper: &mut S,
    steps: u64,
    clock: &C,
    hook: &mut H,
) -> LoopEnd {
    let mut ws = chain.workspace();
    let mut touching = chain.touching(y);
    let mut twin_stepper: Option<S> = None;
    for n in 0..steps {
        let before = touching;
        match hook.twin() {
            None => {
                // A twin that starts again (the early stop's restart, then its reset) starts
                // with a fresh stepper, as it does in a run without the early stop.
                twin_stepper = None;
                stepper.step(chain, &mut ws, y, n, clock)
            }
            Some(twin) => {
                let ts = twin_stepper.get_or_insert_with(|| stepper.fresh());
                stepper.step_twin(ts, chain, &mut ws, (&mut *y, &mut *twin), n, clock);
            }
        }
        touching = chain.touching(y);
        let onsets = match stepper.onsets_within() {
            Some(inside) => inside,
            None => {
                if let Some(twin) = hook.twin() {
                    onset_saltation(chain, &mut ws, y, twin, onsets_of(before, touching));
                }
                u32::from(touching.0 && !before.0) + u32::from(touching.1 && !before.1)
            }
        };
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

//! A single run: one instance integrated by RK4 over a [`StepPlan`], its state handed to an
//! [`Observer`] at every output row (`simulate`, `reproduce`, the harvest check, the bench's
//! trajectories). Time is formed from the integer step count ([`CartMotion::at_step`]); a
//! failed instance stops at the first health check that fails and is reported by its status.

use crate::config::{Scene, StepControl};
use crate::engine::adaptive::{AdaptiveImex, AdaptiveRk4, SubstepStats};
use crate::engine::imex::{Imex, ImexMatrices};
use crate::engine::method::Method;
use crate::engine::rk4::Rk4;
use crate::engine::step_plan::StepPlan;
use crate::engine::stepper::{CartClock, StepHook, Stepper, run_steps};
use crate::engine::twin::TwinTracker;
use crate::model::linear::LinearError;
use crate::model::{CartMotion, CartState, Chain, Guard, ModelParams, Real, Status, Workspace};
use crate::reduce::lyapunov::{LYAPUNOV_MAX_WINDOW, LYAPUNOV_MIN_WINDOW, TwinNorm};
use crate::reduce::{Lyapunov, TwinPlan};
use rayon::prelude::*;
use serde::Serialize;
use std::ops::ControlFlow;
use std::sync::Arc;

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

    /// Whether the run should stop at the row just sampled (a cancel or a time limit); the
    /// outcome then counts fewer steps than planned. Never, unless the observer says so.
    fn stopped(&self) -> bool {
        false
    }

    /// Called every [`POLL_STEPS`] steps between rows, so that a cancel or a time limit is
    /// seen within a bounded number of steps however sparse the rows are; `true` stops the
    /// run there. Never, unless the observer says so.
    fn poll(&mut self, _step: u64) -> bool {
        false
    }
}

/// Steps between two [`Observer::poll`] calls of a single run (about 1 to 60 ms of one core
/// from N = 3 RK4 to N = 17 IMEX in f64): a cancel or a time limit is seen within this many
/// steps even when output rows are hours of integration apart.
pub const POLL_STEPS: u64 = 1024;

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
    /// What the step controller did (adaptive steps only).
    pub substeps: Option<SubstepStats>,
}

impl Outcome {
    /// The outcome with what the step controller did.
    fn with_substeps(mut self, stats: SubstepStats) -> Self {
        self.substeps = Some(stats);
        self
    }
}

/// One independent instance: its chain, cart motion, initial state and health bounds.
pub struct Instance<T: Real> {
    /// Every coefficient, in f64 (the IMEX method's matrices are built from it).
    pub params: ModelParams,
    /// The chain's coefficients.
    pub chain: Chain<T>,
    /// The cart motion.
    pub cart: CartMotion,
    /// Initial state `[θ; θ̇; v]`.
    pub y0: Vec<f64>,
    /// Divergence bounds.
    pub guard: Guard,
}

impl<T: Real> Instance<T> {
    /// The instance a scene describes, with its initial state; `Err` when its damping ratio's
    /// eigenproblem cannot be solved.
    pub fn from_scene(scene: &Scene) -> Result<Instance<T>, LinearError> {
        let params = scene.model_params()?;
        Ok(Instance::new(&params, scene.initial_state(&params)))
    }

    /// The instance of a chain started from `y0`.
    pub fn new(params: &ModelParams, y0: Vec<f64>) -> Instance<T> {
        Instance {
            params: params.clone(),
            chain: Chain::new(params),
            cart: params.cart,
            y0,
            guard: Guard::for_params(params),
        }
    }
}

/// The cart of a single run: `t = (step + stage)·dt` in `f64`.
struct TimeClock<'a> {
    cart: &'a CartMotion,
    dt_s: f64,
}

impl CartClock for TimeClock<'_> {
    fn acceleration(&self, step: u64, frac: f64) -> f64 {
        self.cart.at_step(step, frac, self.dt_s).a_m_s2
    }

    fn velocity(&self, step: u64) -> f64 {
        self.cart.at_step(step, 0.0, self.dt_s).v_m_s
    }
}

/// Samples the rows of a single run, counts every contact onset, and keeps λ1's twin.
struct Rows<'a, T, O> {
    obs: &'a mut O,
    cart: &'a CartMotion,
    plan: &'a StepPlan,
    impacts: u64,
    twin: Option<RunTwin<T>>,
}

/// λ1's twin of a single run: its schedule, bookkeeping and state.
struct RunTwin<T> {
    schedule: SingleTwin,
    tracker: TwinTracker,
    state: Vec<T>,
}

/// λ1's twin of a single run. A single run's step need not divide the forcing period, so the
/// twin is renormalised every `every` steps, the whole number of steps nearest to one period
/// of the (reference) forcing frequency, from the first step after the transient; its plan's
/// `period_s` is that interval (`every · dt`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SingleTwin {
    /// When the twin starts, aligns and measures, and its norm.
    pub plan: TwinPlan,
    /// Steps between renormalisations.
    pub every: u64,
    /// The step of renormalisation instant 0 (the first after the transient).
    pub first_step: u64,
    /// The separation d0.
    pub d0: f64,
}

impl SingleTwin {
    /// The twin of a run of `scene` over `plan` at separation `d0`, aligned over `align`
    /// renormalisations; `Err` says why the run is too short for one.
    pub(crate) fn for_run(
        scene: &Scene,
        plan: &StepPlan,
        d0: f64,
        align: u32,
    ) -> Result<SingleTwin, String> {
        let f = scene.excitation.reference_frequency_hz();
        let every = ((1.0 / (f * plan.dt_s)).round() as u64).max(1);
        let first_step = (scene.integration.transient_s / plan.dt_s).ceil().max(1.0) as u64;
        let instants = plan.steps.saturating_sub(first_step) / every + 1;
        let window = instants.saturating_sub(1 + u64::from(align));
        if plan.steps < first_step || window < u64::from(LYAPUNOV_MIN_WINDOW) {
            return Err(format!(
                "lambda1 needs {} renormalisations (forcing periods) after the transient and {align} to align; this run has {instants}: lengthen integration.duration_s",
                LYAPUNOV_MIN_WINDOW + align + 1
            ));
        }
        if window > u64::from(LYAPUNOV_MAX_WINDOW) {
            return Err(format!(
                "lambda1 averages at most {LYAPUNOV_MAX_WINDOW} renormalisations (forcing periods); this run has {instants}: shorten integration.duration_s"
            ));
        }
        let params = scene.model_params().map_err(|e| e.to_string())?;
        Ok(SingleTwin {
            plan: TwinPlan {
                start_sample: 0,
                align,
                window: window as u32,
                norm: TwinNorm::of(&params, std::f64::consts::TAU * f),
                period_s: every as f64 * plan.dt_s,
            },
            every,
            first_step,
            d0,
        })
    }
}

impl<T: Real, O: Observer<T>> StepHook<T> for Rows<'_, T, O> {
    fn records(&self, step: u64) -> bool {
        step.is_multiple_of(self.plan.sample_every)
    }

    fn after_step(
        &mut self,
        step: u64,
        y: &[T],
        onsets: u32,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
    ) -> ControlFlow<()> {
        self.impacts += u64::from(onsets);
        if StepHook::<T>::records(self, step) {
            let t = step as f64 * self.plan.dt_s;
            let cart = self.cart.at_step(step, 0.0, self.plan.dt_s);
            self.obs.sample(step, t, &cart, y, chain, ws);
            if self.obs.stopped() {
                return ControlFlow::Break(());
            }
        } else if step.is_multiple_of(POLL_STEPS) && self.obs.poll(step) {
            return ControlFlow::Break(());
        }
        if let Some(tw) = &mut self.twin {
            let sch = tw.schedule;
            if step >= sch.first_step && (step - sch.first_step).is_multiple_of(sch.every) {
                if tw.state.is_empty() {
                    tw.state = y.to_vec();
                }
                let j = ((step - sch.first_step) / sch.every) as u32;
                tw.tracker.at_sample(j, y, &mut tw.state[..]);
            }
        }
        ControlFlow::Continue(())
    }

    fn twin(&mut self) -> Option<&mut [T]> {
        self.twin
            .as_mut()
            .filter(|t| t.tracker.running())
            .map(|t| &mut t.state[..])
    }
}

/// Integrate one instance over the plan with the plan's method, calling the observer at every
/// output row.
pub fn integrate<T: Real, O: Observer<T>>(
    inst: &Instance<T>,
    plan: &StepPlan,
    obs: &mut O,
) -> Outcome {
    integrate_with_twin(inst, plan, None, obs).0
}

/// [`integrate`] with λ1's twin when `twin` is given: the outcome, and λ1 once the run
/// ended `ok` with every renormalisation of the window done.
pub(crate) fn integrate_with_twin<T: Real, O: Observer<T>>(
    inst: &Instance<T>,
    plan: &StepPlan,
    twin: Option<SingleTwin>,
    obs: &mut O,
) -> (Outcome, Option<Lyapunov>) {
    let dim = inst.y0.len();
    if let StepControl::Adaptive { rtol, atol } = plan.control {
        let tol = (rtol, atol);
        return match plan.method {
            Method::Rk4 => {
                let mut a = AdaptiveRk4::explicit(plan.dt_s, tol, dim);
                let (outcome, l) = run_single(inst, plan, &mut a, twin, obs);
                (outcome.with_substeps(a.stats()), l)
            }
            Method::Imex => {
                let mut a = AdaptiveImex::imex(&inst.params, plan.dt_s, tol, dim);
                let (outcome, l) = run_single(inst, plan, &mut a, twin, obs);
                (outcome.with_substeps(a.stats()), l)
            }
        };
    }
    match plan.method {
        Method::Rk4 => run_single(inst, plan, &mut Rk4::new(plan.dt_s, dim), twin, obs),
        Method::Imex => {
            let m = Arc::new(ImexMatrices::new(&inst.params, plan.dt_s));
            run_single(inst, plan, &mut Imex::new(&m, dim), twin, obs)
        }
    }
}

/// One run with `stepper` over the plan, the observer at every row, λ1's twin when given.
fn run_single<T: Real, S: Stepper<T>, O: Observer<T>>(
    inst: &Instance<T>,
    plan: &StepPlan,
    stepper: &mut S,
    twin: Option<SingleTwin>,
    obs: &mut O,
) -> (Outcome, Option<Lyapunov>) {
    let chain = &inst.chain;
    let mut y: Vec<T> = inst.y0.iter().map(|&v| T::of(v)).collect();
    let mut ws = chain.workspace();
    let cart0 = inst.cart.at_step(0, 0.0, plan.dt_s);
    obs.sample(0, 0.0, &cart0, &y, chain, &mut ws);
    let clock = TimeClock {
        cart: &inst.cart,
        dt_s: plan.dt_s,
    };
    let mut rows = Rows {
        obs,
        cart: &inst.cart,
        plan,
        impacts: 0,
        twin: twin.map(|schedule| RunTwin {
            tracker: TwinTracker::new(
                schedule.plan,
                schedule.d0,
                inst.params.segments,
                inst.y0.len(),
                0,
            ),
            schedule,
            state: Vec::new(),
        }),
    };
    let end = run_steps(
        chain,
        &inst.guard,
        &mut y,
        stepper,
        plan.steps,
        &clock,
        &mut rows,
    );
    let lyapunov = rows.twin.filter(|_| end.status.is_ok()).and_then(|t| {
        t.tracker
            .sums
            .estimate(t.schedule.plan.window, t.schedule.plan.period_s)
    });
    let outcome = Outcome {
        status: end.status,
        steps_done: end.steps_done,
        impacts: rows.impacts,
        failed_at_s: (!end.status.is_ok()).then_some(end.steps_done as f64 * plan.dt_s),
        substeps: None,
    };
    (outcome, lyapunov)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// λ1's window is refused past the longest a block index counts in u32, with the reason;
    /// a window at it is accepted.
    #[test]
    fn a_single_runs_twin_is_refused_past_the_longest_window() {
        let scene = crate::config::load_scene(None, &[]).expect("the default scene");
        let mut plan = StepPlan::for_scene(&scene).expect("a plan");
        let f = scene.excitation.reference_frequency_hz();
        let every = ((1.0 / (f * plan.dt_s)).round() as u64).max(1);
        let first = (scene.integration.transient_s / plan.dt_s).ceil().max(1.0) as u64;
        let align = 4;
        let with_window = |plan: &mut StepPlan, window: u64| {
            plan.steps = first + every * (window + u64::from(align));
            SingleTwin::for_run(&scene, plan, 1e-8, align)
        };
        let max = u64::from(LYAPUNOV_MAX_WINDOW);
        let ok = with_window(&mut plan, max).expect("the longest window");
        assert_eq!(ok.plan.window, LYAPUNOV_MAX_WINDOW);
        let err = with_window(&mut plan, max + 1).expect_err("refused");
        assert!(err.contains("at most 536870911"), "{err}");
    }
}

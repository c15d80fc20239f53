//! The CPU ensemble engine: every instance integrated by the shared RK4 loop in `f32` or `f64`,
//! spread over rayon's threads, its recorded series reduced with the analysis library.
//!
//! Each instance runs the step loop of [`crate::engine::rk4`] with an `EnsembleHook` that
//! keeps the accumulators after the transient, records the stroboscopic and R samples, and
//! (with [`EarlyStop`]) ends a confirmed periodic orbit early.

mod cart_table;
mod hook;
mod lane_ladder;
mod lanes;

pub use hook::RawInstance;

use crate::config::StepControl;
use crate::engine::adaptive::{AdaptiveImex, AdaptiveRk4};
use crate::engine::early::EarlyStop;
use crate::engine::imex::Imex;
use crate::engine::method::Method;
use crate::engine::plan::{EnsemblePlan, InstancePlan};
use crate::engine::rk4::Rk4;
use crate::engine::stepper::{StepHook, run_steps};
use crate::engine::{
    EngineError, EngineRun, EngineTimings, Precision, Progress, ProgressUnit, Readback,
};
use crate::model::{Chain, F32Lanes, F64Lanes, Lane, Real, Workspace};
use crate::reduce::{ReduceOptions, Series, Span, reduce_series};
use hook::{EnsembleHook, PhaseClock};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

/// Integrate one instance with the plan's method in the float type `T`, as the GPU kernel
/// does, over the whole run.
pub fn run_instance<T: Real>(
    plan: &InstancePlan,
    want_strobe: bool,
    want_rseries: bool,
) -> RawInstance {
    run_instance_with::<T>(plan, want_strobe, want_rseries, None, None, None)
}

/// [`run_instance`], stopping early once a periodic orbit is confirmed when `early` is given,
/// with λ1's twin at separation `separation` when the plan has one, ending at the first
/// forcing period's end at which `stop` says so (a cancel; asked every few periods).
pub(crate) fn run_instance_with<T: Real>(
    plan: &InstancePlan,
    want_strobe: bool,
    want_rseries: bool,
    early: Option<EarlyStop>,
    separation: Option<f64>,
    stop: Option<&(dyn Fn() -> bool + Sync)>,
) -> RawInstance {
    let chain: Chain<T> = Chain::new(&plan.params);
    let mut y: Vec<T> = plan.y0.iter().map(|&v| T::of(v)).collect();
    let mut hook =
        EnsembleHook::<T>::new(plan, want_strobe, want_rseries, early, separation).with_stop(stop);
    let (steps, dim) = (plan.total_steps(), y.len());
    // The loop over one stepper type; each arm below builds its own.
    macro_rules! run_with {
        ($stepper:expr) => {
            run_steps(
                &chain,
                &plan.guard,
                &mut y,
                &mut $stepper,
                steps,
                &PhaseClock(plan),
                &mut hook,
            )
        };
    }
    let (end, sub_steps) = match (&plan.imex, plan.control) {
        (_, StepControl::Adaptive { rtol, atol }) if plan.method == Method::Rk4 => {
            let mut a = AdaptiveRk4::explicit(plan.dt_s, (rtol, atol), dim);
            (run_with!(a), a.stats().tries())
        }
        (_, StepControl::Adaptive { rtol, atol }) => {
            let mut a = AdaptiveImex::imex(&plan.params, plan.dt_s, (rtol, atol), dim);
            (run_with!(a), a.stats().tries())
        }
        (None, StepControl::Fixed) => (run_with!(Rk4::new(plan.dt_s, dim)), 0),
        (Some(m), StepControl::Fixed) => (run_with!(Imex::new(m, dim)), 0),
    };
    let mut raw = hook.finish();
    raw.sub_steps = sub_steps;
    raw.tally.status = end.status;
    raw.tally.steps = end.steps_done;
    raw.y_end = y.iter().map(|v| v.wide()).collect();
    raw
}

/// A hook that records nothing.
struct Silent;

impl<T: Real> StepHook<T> for Silent {
    fn records(&self, _step: u64) -> bool {
        false
    }

    fn after_step(
        &mut self,
        _: u64,
        _: &[T],
        _: u32,
        _: &Chain<T>,
        _: &mut Workspace<T>,
    ) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// The state of `plan`'s instance after `steps` RK4 steps in f64, as the ensemble engine
/// integrates it (the check that a peer implementation integrates the same model).
pub fn run_steps_f64(plan: &InstancePlan, steps: u64) -> Vec<f64> {
    let chain: Chain<f64> = Chain::new(&plan.params);
    let mut y = plan.y0.clone();
    let mut rk4 = Rk4::new(plan.dt_s, y.len());
    let clock = PhaseClock(plan);
    run_steps(
        &chain,
        &plan.guard,
        &mut y,
        &mut rk4,
        steps,
        &clock,
        &mut Silent,
    );
    y
}

/// How the CPU engine walks its instances.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum CpuLoop {
    /// One instance per rayon task, scalar arithmetic (the reference of the SIMD loop).
    Scalar,
    /// Instances side by side in vector lanes (4 in `f64`, 8 in `f32`), rayon over lane groups.
    #[default]
    Simd,
}

impl CpuLoop {
    /// "scalar" or "simd".
    pub fn name(self) -> &'static str {
        match self {
            CpuLoop::Scalar => "scalar",
            CpuLoop::Simd => "simd",
        }
    }

    /// Instances integrated side by side in `precision`.
    pub fn lanes(self, precision: Precision) -> usize {
        match (self, precision) {
            (CpuLoop::Scalar, _) => 1,
            (CpuLoop::Simd, Precision::F64) => F64Lanes::LANES,
            (CpuLoop::Simd, Precision::F32) => F32Lanes::LANES,
        }
    }
}

/// The CPU engine in one float type.
#[derive(Debug, Clone, Copy)]
pub struct CpuEngine {
    /// `f32` or `f64`.
    pub precision: Precision,
    /// Scalar or SIMD.
    pub simd: CpuLoop,
}

impl CpuEngine {
    /// Integrate and reduce every instance of `plan` (rayon); refused before any work when
    /// λ1's twin separation is below what the float type resolves.
    pub fn run(
        &self,
        plan: &EnsemblePlan,
        opts: &ReduceOptions,
        readback: Readback,
        progress: Progress,
    ) -> Result<EngineRun, EngineError> {
        let d0 = plan.twin_separation(self.precision)?;
        let t0 = Instant::now();
        let raw = match (self.simd, self.precision) {
            (CpuLoop::Scalar, Precision::F64) => integrate_all::<f64>(plan, d0, progress),
            (CpuLoop::Scalar, Precision::F32) => integrate_all::<f32>(plan, d0, progress),
            (CpuLoop::Simd, Precision::F64) => {
                lanes::integrate_lanes::<F64Lanes>(plan, d0, progress)
            }
            (CpuLoop::Simd, Precision::F32) => {
                lanes::integrate_lanes::<F32Lanes>(plan, d0, progress)
            }
        }?;
        let integrate_s = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let results = plan
            .instances
            .par_iter()
            .zip(&raw)
            .map(|(p, r)| {
                let span = Span {
                    seconds: p.post_transient_s(),
                    steps: p.total_steps() - p.transient_steps(),
                };
                let mut out = r.tally.result(span, &plan.metrics);
                let cart = if plan.want_rseries {
                    p.cart_series()
                } else {
                    Vec::new()
                };
                let series = Series {
                    strobe: &r.strobe,
                    r_alpha: &r.r_alpha,
                    r_cart: &cart,
                    r_samples_per_period: f64::from(p.spp / p.r_every),
                    twin: r.twin.as_ref().zip(r.twin_plan.as_ref()),
                };
                reduce_series(&mut out, series, &plan.metrics, opts);
                out
            })
            .collect();
        let reduce_s = t0.elapsed().as_secs_f64();
        let stopped_early = raw.iter().filter(|r| r.stopped_early.is_some()).count();
        let keep = |on: bool, f: fn(&RawInstance) -> &Vec<f64>| {
            if on {
                raw.iter().map(|r| f(r).clone()).collect()
            } else {
                Vec::new()
            }
        };
        Ok(EngineRun {
            results,
            strobe: keep(readback.strobe && plan.want_strobe, |r| &r.strobe),
            r_series: keep(readback.r_series && plan.want_rseries, |r| &r.r_alpha),
            final_state: keep(readback.final_state, |r| &r.y_end),
            timings: EngineTimings {
                integrate_s,
                reduce_s,
                gpu: None,
            },
            dispatches: 0,
            stopped_early,
            sub_steps: plan
                .is_adaptive()
                .then(|| raw.iter().map(|r| r.sub_steps).sum()),
        })
    }
}

/// Integrate every instance on the CPU (λ1's twins at separation `d0`); progress counts
/// finished instances, and is asked every few forcing periods whether to go on, so that a
/// cancel stops the running instances within milliseconds and the others before they start.
fn integrate_all<T: Real>(
    plan: &EnsemblePlan,
    d0: Option<f64>,
    progress: Progress,
) -> Result<Vec<RawInstance>, EngineError> {
    let asked = Asker::new(progress, plan.instances.len() as u64);
    let stop = || !asked.go_on();
    plan.instances
        .par_iter()
        .map(|p| {
            let (strobe, rseries) = (plan.want_strobe, plan.want_rseries);
            let r = run_instance_with::<T>(p, strobe, rseries, plan.early_stop, d0, Some(&stop));
            asked.finished(1)?;
            Ok(r)
        })
        .collect()
}

/// The progress of a CPU run, counted in finished instances: told as instances finish and
/// asked from within running ones whether to go on ([`hook::Stop`]). Once it says stop it is
/// not asked again, so that a cancel costs the callback no more calls than those in flight.
pub(super) struct Asker<'a> {
    progress: Progress<'a>,
    total: u64,
    done: AtomicU64,
    cancelled: AtomicBool,
}

impl<'a> Asker<'a> {
    pub(super) fn new(progress: Progress<'a>, total: u64) -> Self {
        Asker {
            progress,
            total,
            done: AtomicU64::new(0),
            cancelled: AtomicBool::new(false),
        }
    }

    /// Whether to go on, with the instances finished so far.
    pub(super) fn go_on(&self) -> bool {
        self.ask(self.done.load(Ordering::Relaxed))
    }

    /// Count `k` more finished instances; [`EngineError::Cancelled`] where the run stops.
    pub(super) fn finished(&self, k: u64) -> Result<(), EngineError> {
        let n = self.done.fetch_add(k, Ordering::Relaxed) + k;
        match self.ask(n) {
            true => Ok(()),
            false => Err(EngineError::Cancelled),
        }
    }

    fn ask(&self, done: u64) -> bool {
        if self.cancelled.load(Ordering::Relaxed) {
            return false;
        }
        let go = (self.progress)(done, self.total, ProgressUnit::Instances).is_continue();
        if !go {
            self.cancelled.store(true, Ordering::Relaxed);
        }
        go
    }
}

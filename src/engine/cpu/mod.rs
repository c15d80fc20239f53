//! The CPU ensemble engine: every instance integrated by the shared RK4 loop in `f32` or `f64`,
//! spread over rayon's threads, its recorded series reduced with the analysis library.
//!
//! Each instance runs the step loop of [`crate::engine::rk4`] with an [`EnsembleHook`] that
//! keeps the accumulators after the transient, records the stroboscopic and R samples, and
//! (with [`EarlyStop`]) ends a confirmed periodic orbit early.

use crate::engine::imex::Imex;
use crate::engine::plan::{EarlyStop, EnsemblePlan, InstancePlan};
use crate::engine::rk4::Rk4;
use crate::engine::stepper::{CartClock, StepHook, run_steps};
use crate::engine::{EngineRun, EngineTimings, Precision, Progress, ProgressUnit, Readback};
use crate::model::{Chain, Real, Status, Workspace};
use crate::reduce::{ReduceOptions, Series, Span, Tally, reduce_series};
use rayon::prelude::*;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// What one instance's integration leaves behind: accumulators and the recorded series.
#[derive(Debug, Clone, PartialEq)]
pub struct RawInstance {
    /// The accumulators after the transient.
    pub tally: Tally,
    /// Stroboscopic α after the transient (empty unless recorded).
    pub strobe: Vec<f64>,
    /// Uniform α series for R (empty unless recorded).
    pub r_alpha: Vec<f64>,
    /// Orbit period (forcing periods) at which the instance stopped early, if it did.
    pub stopped_early: Option<u32>,
}

/// The cart of an ensemble instance: exact phase `(step mod spp + c)/spp`.
struct PhaseClock<'a>(&'a InstancePlan);

impl CartClock for PhaseClock<'_> {
    fn acceleration(&self, step: u64, frac: f64) -> f64 {
        self.0.cart_at(step, frac).a_m_s2
    }

    fn velocity(&self, step: u64) -> f64 {
        self.0.cart_at(step, 0.0).v_m_s
    }
}

/// The per-step bookkeeping of an ensemble instance.
struct EnsembleHook<'a, T> {
    plan: &'a InstancePlan,
    raw: RawInstance,
    well: i32,
    early: Option<EarlyStop>,
    /// States at the last p_max + 1 stroboscopic samples (ring), for early termination.
    ring: Vec<Vec<T>>,
}

impl<'a, T: Real> EnsembleHook<'a, T> {
    fn new(
        plan: &'a InstancePlan,
        want_strobe: bool,
        want_r: bool,
        early: Option<EarlyStop>,
    ) -> Self {
        let nan_series = |want: bool, n: u32| {
            if want {
                vec![f64::NAN; n as usize]
            } else {
                Vec::new()
            }
        };
        EnsembleHook {
            plan,
            raw: RawInstance {
                tally: Tally {
                    status: Status::Ok,
                    steps: 0,
                    alpha_range_rad: (f64::INFINITY, f64::NEG_INFINITY),
                    hops: 0,
                    impacts: 0,
                    power_sum_w: 0.0,
                },
                strobe: nan_series(want_strobe, plan.strobe_count),
                r_alpha: nan_series(want_r, plan.r_count),
                stopped_early: None,
            },
            well: 0,
            early,
            ring: vec![Vec::new(); early.map_or(0, |e| e.p_max as usize + 1)],
        }
    }

    /// Accumulators over the steps after the transient: α range, hops, impacts, power.
    fn accumulate(&mut self, alpha: f64, onsets: u32, y: &[T]) {
        let t = &mut self.raw.tally;
        t.impacts += onsets;
        t.alpha_range_rad.0 = t.alpha_range_rad.0.min(alpha);
        t.alpha_range_rad.1 = t.alpha_range_rad.1.max(alpha);
        let h = self.plan.half_clearance_rad;
        let w = if alpha > h {
            1
        } else if alpha < -h {
            -1
        } else {
            0
        };
        if w != 0 {
            if self.well != 0 && self.well != w {
                t.hops += 1;
            }
            self.well = w;
        }
        if let Some(z) = &self.plan.params.piezo {
            let v = y[2 * self.plan.params.segments].wide();
            t.power_sum_w += v * v * (1.0 / z.load_ohm);
        }
    }

    /// Record a stroboscopic sample; `Break` when the early stop confirms a periodic orbit.
    fn strobe_sample(&mut self, step: u64, alpha: f64, y: &[T]) -> ControlFlow<()> {
        let p = self.plan;
        let idx =
            (step - u64::from(p.strobe_offset)) / u64::from(p.spp) - u64::from(p.transient_periods);
        if let Some(slot) = self.raw.strobe.get_mut(idx as usize) {
            *slot = alpha;
        }
        let Some(e) = self.early else {
            return ControlFlow::Continue(());
        };
        let k = idx as usize;
        let ring_len = self.ring.len();
        let slot = &mut self.ring[k % ring_len];
        slot.clear();
        slot.extend_from_slice(y);
        match confirmed_period(&self.raw.strobe, &self.ring, k, &e) {
            Some(period) => {
                for j in k + 1..self.raw.strobe.len() {
                    self.raw.strobe[j] = self.raw.strobe[j - period];
                }
                self.raw.stopped_early = Some(period as u32);
                ControlFlow::Break(())
            }
            None => ControlFlow::Continue(()),
        }
    }

    /// Record a sample of the R series when `step` is one of its instants.
    fn r_sample(&mut self, step: u64, alpha: f64) {
        let (start, every) = (u64::from(self.plan.r_start), u64::from(self.plan.r_every));
        if step >= start
            && (step - start).is_multiple_of(every)
            && let Some(slot) = self.raw.r_alpha.get_mut(((step - start) / every) as usize)
        {
            *slot = alpha;
        }
    }
}

impl<T: Real> StepHook<T> for EnsembleHook<'_, T> {
    fn records(&self, _step: u64) -> bool {
        false
    }

    fn after_step(
        &mut self,
        step: u64,
        y: &[T],
        onsets: u32,
        _chain: &Chain<T>,
        _ws: &mut Workspace<T>,
    ) -> ControlFlow<()> {
        let p = self.plan;
        let alpha = y[0].wide();
        let transient = p.transient_steps();
        if step > transient {
            self.accumulate(alpha, onsets, y);
        }
        let want_strobe = !self.raw.strobe.is_empty() || self.early.is_some();
        if want_strobe
            && step >= transient
            && step % u64::from(p.spp) == u64::from(p.strobe_offset)
            && self.strobe_sample(step, alpha, y).is_break()
        {
            return ControlFlow::Break(());
        }
        if !self.raw.r_alpha.is_empty() {
            self.r_sample(step, alpha);
        }
        ControlFlow::Continue(())
    }
}

/// Integrate one instance with the plan's method in the float type `T`, as the GPU kernel
/// does, over the whole run.
pub fn run_instance<T: Real>(
    plan: &InstancePlan,
    want_strobe: bool,
    want_rseries: bool,
) -> RawInstance {
    run_instance_with::<T>(plan, want_strobe, want_rseries, None)
}

/// [`run_instance`], stopping early once a periodic orbit is confirmed when `early` is given.
pub fn run_instance_with<T: Real>(
    plan: &InstancePlan,
    want_strobe: bool,
    want_rseries: bool,
    early: Option<EarlyStop>,
) -> RawInstance {
    let chain: Chain<T> = Chain::new(&plan.params);
    let mut y: Vec<T> = plan.y0.iter().map(|&v| T::of(v)).collect();
    let mut hook = EnsembleHook::<T>::new(plan, want_strobe, want_rseries, early);
    let (steps, clock) = (plan.total_steps(), PhaseClock(plan));
    let end = match &plan.imex {
        None => {
            let mut rk4 = Rk4::new(plan.dt_s, y.len());
            run_steps(
                &chain,
                &plan.guard,
                &mut y,
                &mut rk4,
                steps,
                &clock,
                &mut hook,
            )
        }
        Some(m) => {
            let mut imex = Imex::new(m, y.len());
            run_steps(
                &chain,
                &plan.guard,
                &mut y,
                &mut imex,
                steps,
                &clock,
                &mut hook,
            )
        }
    };
    let mut raw = hook.raw;
    raw.tally.status = end.status;
    raw.tally.steps = end.steps_done;
    raw
}

/// The smallest p ≤ p_max for which the stroboscopic samples up to `k` and the full state at
/// sample `k` repeat with period p (see [`EarlyStop`]).
fn confirmed_period<T: Real>(
    strobe: &[f64],
    ring: &[Vec<T>],
    k: usize,
    e: &EarlyStop,
) -> Option<usize> {
    let w = e.window as usize;
    let close = |a: f64, b: f64| (a - b).abs() <= e.tol * a.abs().max(1.0);
    (1..=e.p_max as usize).find(|&p| {
        k + 1 >= w + p && (k + 1 - w..=k).all(|j| close(strobe[j], strobe[j - p])) && {
            let (now, then) = (&ring[k % ring.len()], &ring[(k - p) % ring.len()]);
            then.len() == now.len() && now.iter().zip(then).all(|(a, b)| close(a.wide(), b.wide()))
        }
    })
}

/// The CPU engine in one float type.
#[derive(Debug, Clone, Copy)]
pub struct CpuEngine {
    /// `f32` or `f64`.
    pub precision: Precision,
}

impl CpuEngine {
    /// Integrate and reduce every instance of `plan` (rayon).
    pub fn run(
        &self,
        plan: &EnsemblePlan,
        opts: &ReduceOptions,
        readback: Readback,
        progress: Progress,
    ) -> EngineRun {
        let t0 = Instant::now();
        let raw = match self.precision {
            Precision::F64 => integrate_all::<f64>(plan, progress),
            Precision::F32 => integrate_all::<f32>(plan, progress),
        };
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
        EngineRun {
            results,
            strobe: keep(readback.strobe && plan.want_strobe, |r| &r.strobe),
            r_series: keep(readback.r_series && plan.want_rseries, |r| &r.r_alpha),
            timings: EngineTimings {
                integrate_s,
                reduce_s,
                gpu: None,
            },
            dispatches: 0,
            stopped_early,
        }
    }
}

/// Integrate every instance on the CPU; progress counts finished instances.
fn integrate_all<T: Real>(plan: &EnsemblePlan, progress: Progress) -> Vec<RawInstance> {
    let done = AtomicU64::new(0);
    let total = plan.instances.len() as u64;
    plan.instances
        .par_iter()
        .map(|p| {
            let r = run_instance_with::<T>(p, plan.want_strobe, plan.want_rseries, plan.early_stop);
            progress(
                done.fetch_add(1, Ordering::Relaxed) + 1,
                total,
                ProgressUnit::Instances,
            );
            r
        })
        .collect()
}

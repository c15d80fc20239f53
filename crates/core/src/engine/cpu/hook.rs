//! The per-step bookkeeping of an ensemble instance, shared by the scalar and the lane loops:
//! accumulators per forcing period, added up after the transient (α range, hops, impacts,
//! power), the stroboscopic and R samples, λ1's twin, and the early stop on a confirmed
//! periodic orbit ([`crate::engine::early`]).

use crate::analysis::{Well, hop_step};
use crate::engine::early::{
    EarlyStop, EarlyTracker, PeriodTally, early_lyapunov_stops, early_twin_window,
};
use crate::engine::plan::InstancePlan;
use crate::engine::state_view::{StateView, StateViewMut};
use crate::engine::stepper::{CartClock, StepHook};
use crate::engine::twin::TwinTracker;
use crate::model::{Chain, Lane, Real, Status, Workspace};
use crate::reduce::{LyapunovSums, Tally, TwinPlan};
use std::ops::ControlFlow;

/// Whether a run should end now: asked by a hook every few forcing periods, so that
/// a cancel reaches an instance that runs for minutes (a settled cell, a long single run).
pub(super) type Stop<'a> = &'a (dyn Fn() -> bool + Sync);

/// Forcing periods between two questions to [`Stop`] (a few milliseconds of work at N = 3).
const STOP_EVERY: u64 = 16;

/// Lane `lane` of a state of vectors.
pub(super) struct LaneView<'a, V> {
    pub(super) y: &'a [V],
    pub(super) lane: usize,
}

impl<V: Lane> StateView<V::Scalar> for LaneView<'_, V> {
    #[inline]
    fn at(&self, k: usize) -> V::Scalar {
        self.y[k].lane(self.lane)
    }
    fn len(&self) -> usize {
        self.y.len()
    }
}

/// Lane `lane` of a state of vectors, written (the twin of λ1).
pub(super) struct LaneViewMut<'a, V> {
    pub(super) y: &'a mut [V],
    pub(super) lane: usize,
}

impl<V: Lane> StateView<V::Scalar> for LaneViewMut<'_, V> {
    #[inline]
    fn at(&self, k: usize) -> V::Scalar {
        self.y[k].lane(self.lane)
    }
    fn len(&self) -> usize {
        self.y.len()
    }
}

impl<V: Lane> StateViewMut<V::Scalar> for LaneViewMut<'_, V> {
    #[inline]
    fn set(&mut self, k: usize, v: V::Scalar) {
        self.y[k] = self.y[k].with_lane(self.lane, v);
    }
}

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
    /// The log-growths of λ1's twin, when it ran.
    pub twin: Option<LyapunovSums>,
    /// The plan the twin ran (a confirmed orbit measures a shorter window).
    pub twin_plan: Option<TwinPlan>,
    /// The main state `[θ; θ̇; v]` where the instance ended.
    pub y_end: Vec<f64>,
    /// Adaptive steps: the sub-steps tried, accepted and rejected (0 at fixed steps).
    pub sub_steps: u64,
}

/// The cart of an ensemble instance: exact phase `(step mod spp + c)/spp`.
pub(super) struct PhaseClock<'a>(pub(super) &'a InstancePlan);

impl CartClock for PhaseClock<'_> {
    fn acceleration(&self, step: u64, frac: f64) -> f64 {
        self.0.cart_at(step, frac).a_m_s2
    }

    fn velocity(&self, step: u64) -> f64 {
        self.0.cart_at(step, 0.0).v_m_s
    }
}

/// Where an instance's early stop stands ([`crate::engine::early`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum EarlyPhase {
    /// Looking for a confirmed orbit at every stroboscopic instant.
    Watching,
    /// Orbit of period `p` confirmed; λ1's twin measures it until instant `until` (before
    /// the map's own λ1 window begins).
    Measuring { p: u32, until: u64 },
    /// Orbit of period `p` confirmed (and stable): stop at the next period boundary.
    Closing { p: u32 },
    /// No early stop (none asked for, λ1 not shrinking, or the map's λ1 window too near).
    Off,
}

/// The per-step bookkeeping of an ensemble instance.
pub(super) struct EnsembleHook<'a, T> {
    plan: &'a InstancePlan,
    /// Asked at the end of every [`STOP_EVERY`]-th forcing period: `true` ends the run there
    /// (the run was cancelled; its results are not used).
    stop: Option<Stop<'a>>,
    pub(super) raw: RawInstance,
    /// The accumulators of the current forcing period, and the well last visited (kept
    /// through the transient).
    period: PeriodTally,
    well: Option<Well>,
    early: Option<EarlyTracker<T>>,
    phase: EarlyPhase,
    /// The next stroboscopic instant (from the first step when the early stop watches, else
    /// from the transient), and the next instant of the R series: counters instead of a
    /// division per step.
    next_strobe: u64,
    next_r: u64,
    /// λ1's twin, when asked for.
    twin: Option<TwinTracker>,
    /// The twin's state on the scalar loop (the lane loop keeps its twins in a vector).
    twin_state: Vec<T>,
}

impl<'a, T: Real> EnsembleHook<'a, T> {
    pub(super) fn new(
        plan: &'a InstancePlan,
        want_strobe: bool,
        want_r: bool,
        early: Option<EarlyStop>,
        separation: Option<f64>,
    ) -> Self {
        let nan_series = |want: bool, n: u32| {
            if want {
                vec![f64::NAN; n as usize]
            } else {
                Vec::new()
            }
        };
        let dim = plan.y0.len();
        let segments = plan.params.segments;
        let tp = plan.transient_periods;
        EnsembleHook {
            plan,
            stop: None,
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
                twin: None,
                twin_plan: None,
                y_end: Vec::new(),
                sub_steps: 0,
            },
            period: PeriodTally::default(),
            well: None,
            phase: if early.is_some() {
                EarlyPhase::Watching
            } else {
                EarlyPhase::Off
            },
            next_strobe: first_strobe_step(plan, early.is_some()),
            early: early.map(|e| EarlyTracker::new(e, plan, want_r)),
            next_r: u64::from(plan.r_start),
            twin: plan
                .twin
                .zip(separation)
                .map(|(t, d0)| TwinTracker::new(t, d0, segments, dim, tp)),
            twin_state: Vec::new(),
        }
    }

    /// The hook, ending its run at the first period's end at which `stop` says so.
    pub(super) fn with_stop(self, stop: Option<Stop<'a>>) -> Self {
        EnsembleHook { stop, ..self }
    }

    /// Whether λ1's twin is running (the loop must advance it).
    pub(super) fn twin_running(&self) -> bool {
        self.twin.as_ref().is_some_and(TwinTracker::running)
    }

    /// The bookkeeping is over: the raw results, with the twin's log-growths and plan.
    pub(super) fn finish(mut self) -> RawInstance {
        if let Some(t) = self.twin {
            self.raw.twin_plan = Some(*t.plan());
            self.raw.twin = Some(t.sums);
        }
        self.raw
    }

    /// The current period's accumulators: α range, hops, impacts, power.
    fn accumulate(&mut self, alpha: f64, onsets: u32, y: &(impl StateView<T> + ?Sized)) {
        let t = &mut self.period;
        t.impacts += onsets;
        t.alpha_min = t.alpha_min.min(alpha);
        t.alpha_max = t.alpha_max.max(alpha);
        let hopped;
        (self.well, hopped) = hop_step(self.well, alpha, self.plan.half_clearance_rad);
        t.hops += u32::from(hopped);
        if let Some(z) = &self.plan.params.piezo {
            let v = y.at(2 * self.plan.params.segments).wide();
            t.power_sum_w += v * v * (1.0 / z.load_ohm);
        }
    }

    /// The stroboscopic instant `step`: λ1's twin, the recorded α after the transient, the
    /// early stop's watch.
    fn strobe_instant(
        &mut self,
        step: u64,
        alpha: f64,
        y: &(impl StateView<T> + ?Sized),
        twin: &mut (impl StateViewMut<T> + ?Sized),
    ) {
        let p = self.plan;
        let abs = (step - u64::from(p.strobe_offset)) / u64::from(p.spp);
        if let Some(j) = abs.checked_sub(u64::from(p.transient_periods))
            && let Some(slot) = self.raw.strobe.get_mut(j as usize)
        {
            *slot = alpha;
        }
        self.watch(abs, y);
        if let Some(t) = &mut self.twin {
            t.at_sample(abs as u32, y, twin);
        }
        self.measured(abs);
    }

    /// The early stop's detection at instant `abs` (before the twin's sample, which a
    /// confirmed orbit may restart).
    fn watch(&mut self, abs: u64, y: &(impl StateView<T> + ?Sized)) {
        let Some(e) = &mut self.early else {
            return;
        };
        let confirmed = e.at_strobe(abs, y);
        let (EarlyPhase::Watching, Some(p)) = (self.phase, confirmed) else {
            return;
        };
        self.phase = match &mut self.twin {
            None => EarlyPhase::Closing { p },
            Some(t) => {
                let window = early_twin_window(p);
                let until = abs + u64::from(t.plan().align + window);
                if t.started_by(until as u32) {
                    EarlyPhase::Off
                } else {
                    t.restart(abs as u32, window);
                    EarlyPhase::Measuring { p, until }
                }
            }
        };
    }

    /// After the twin's sample at `abs`: a measuring orbit whose λ1 is complete closes when
    /// λ1 shrinks, precisely enough ([`early_lyapunov_stops`]); short of the precision its
    /// window doubles while that still ends before the map's own; else the twin goes back to
    /// the map's window (still ahead) and the run goes on.
    fn measured(&mut self, abs: u64) {
        let (EarlyPhase::Measuring { p, until }, Some(t)) = (self.phase, &mut self.twin) else {
            return;
        };
        if abs < until {
            return;
        }
        let plan = *t.plan();
        let estimate = t.sums.estimate(plan.window, plan.period_s);
        self.phase = if estimate.is_some_and(|l| early_lyapunov_stops(&l, plan.period_s)) {
            EarlyPhase::Closing { p }
        } else if estimate.is_some() && t.extend() {
            EarlyPhase::Measuring {
                p,
                until: until + u64::from(plan.window),
            }
        } else {
            t.reset();
            EarlyPhase::Off
        };
    }

    /// The end of forcing period `q` (0-based): its tally into the run's after the transient,
    /// into the early stop's ring; `Break` when a closing orbit stops here.
    fn period_end(&mut self, q: u64) -> ControlFlow<()> {
        if q % STOP_EVERY == STOP_EVERY - 1 && self.stop.is_some_and(|stop| stop()) {
            return ControlFlow::Break(());
        }
        let done = std::mem::take(&mut self.period);
        if q >= u64::from(self.plan.transient_periods) {
            done.add_to(&mut self.raw.tally);
        }
        let Some(e) = &mut self.early else {
            return ControlFlow::Continue(());
        };
        e.end_period(q, done);
        let EarlyPhase::Closing { p } = self.phase else {
            return ControlFlow::Continue(());
        };
        let raw = &mut self.raw;
        e.continue_orbit(
            p,
            q + 1,
            self.plan,
            &mut raw.tally,
            &mut raw.strobe,
            &mut raw.r_alpha,
        );
        raw.stopped_early = Some(p);
        ControlFlow::Break(())
    }

    /// Record a sample of the R series when `step` is one of its instants (`r_start` +
    /// a multiple of `r_every`; steps come one by one), and keep α for the early stop.
    fn r_sample(&mut self, step: u64, alpha: f64) {
        let every = u64::from(self.plan.r_every);
        if let Some(e) = &mut self.early
            && e.wants_r()
            && step.is_multiple_of(every)
        {
            e.r_sample(step, every, alpha);
        }
        if step != self.next_r {
            return;
        }
        let start = u64::from(self.plan.r_start);
        self.next_r += every;
        if let Some(slot) = self.raw.r_alpha.get_mut(((step - start) / every) as usize) {
            *slot = alpha;
        }
    }
}

impl<T: Real> EnsembleHook<'_, T> {
    /// The bookkeeping after `step` steps (1-based) with state `y`, `onsets` bumper contacts
    /// begun at this step; `Break` when the early stop ends the run here.
    pub(super) fn record(
        &mut self,
        step: u64,
        y: &(impl StateView<T> + ?Sized),
        onsets: u32,
        twin: &mut (impl StateViewMut<T> + ?Sized),
    ) -> ControlFlow<()> {
        let alpha = y.at(0).wide();
        self.accumulate(alpha, onsets, y);
        let spp = u64::from(self.plan.spp);
        if step == self.next_strobe {
            self.next_strobe += spp;
            self.strobe_instant(step, alpha, y, twin);
        }
        if !self.raw.r_alpha.is_empty() {
            self.r_sample(step, alpha);
        }
        if step.is_multiple_of(spp) {
            return self.period_end(step / spp - 1);
        }
        ControlFlow::Continue(())
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
        if self.twin.is_some() && self.twin_state.is_empty() {
            self.twin_state = y.to_vec();
        }
        let mut twin = std::mem::take(&mut self.twin_state);
        let flow = self.record(step, y, onsets, &mut twin[..]);
        self.twin_state = twin;
        flow
    }

    fn twin(&mut self) -> Option<&mut [T]> {
        if self.twin_running() {
            Some(&mut self.twin_state)
        } else {
            None
        }
    }
}

/// The first stroboscopic instant (1-based step, `step mod spp` = the strobe offset): from
/// the first step when the early stop watches the whole run, else from the transient's end.
fn first_strobe_step(p: &InstancePlan, from_start: bool) -> u64 {
    let (spp, offset) = (u64::from(p.spp), u64::from(p.strobe_offset));
    let from = if from_start {
        1
    } else {
        p.transient_steps().max(1)
    };
    from + (offset + spp - from % spp) % spp
}

//! The per-step bookkeeping of an ensemble instance, shared by the scalar and the lane loops:
//! accumulators after the transient (α range, hops, impacts, power), the stroboscopic and R
//! samples, and the early stop on a confirmed periodic orbit ([`EarlyStop`]).

use crate::engine::plan::{EarlyStop, InstancePlan};
use crate::engine::stepper::{CartClock, StateView, StateViewMut, StepHook};
use crate::engine::twin::TwinTracker;
use crate::model::{Chain, Lane, Real, Status, Workspace};
use crate::reduce::LyapunovSums;
use crate::reduce::Tally;
use std::ops::ControlFlow;

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

/// The per-step bookkeeping of an ensemble instance.
pub(super) struct EnsembleHook<'a, T> {
    plan: &'a InstancePlan,
    pub(super) raw: RawInstance,
    well: i32,
    early: Option<EarlyStop>,
    /// States at the last p_max + 1 stroboscopic samples (ring), for early termination.
    ring: Vec<Vec<T>>,
    /// The next step that is a stroboscopic instant after the transient (`step mod spp` =
    /// the strobe offset), and the next instant of the R series: counters instead of a
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
                twin: None,
            },
            well: 0,
            early,
            ring: vec![Vec::new(); early.map_or(0, |e| e.p_max as usize + 1)],
            next_strobe: first_strobe_step(plan),
            next_r: u64::from(plan.r_start),
            twin: plan
                .twin
                .zip(separation)
                .map(|(t, d0)| TwinTracker::new(t, d0, plan.params.segments, plan.y0.len())),
            twin_state: Vec::new(),
        }
    }

    /// Whether λ1's twin is running (the loop must advance it).
    pub(super) fn twin_running(&self) -> bool {
        self.twin.as_ref().is_some_and(TwinTracker::running)
    }

    /// The bookkeeping is over: the raw results, with the twin's log-growths.
    pub(super) fn finish(mut self) -> RawInstance {
        self.raw.twin = self.twin.map(|t| t.sums);
        self.raw
    }

    /// Accumulators over the steps after the transient: α range, hops, impacts, power.
    fn accumulate(&mut self, alpha: f64, onsets: u32, y: &(impl StateView<T> + ?Sized)) {
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
            let v = y.at(2 * self.plan.params.segments).wide();
            t.power_sum_w += v * v * (1.0 / z.load_ohm);
        }
    }

    /// Record a stroboscopic sample; `Break` when the early stop confirms a periodic orbit.
    fn strobe_sample(
        &mut self,
        step: u64,
        alpha: f64,
        y: &(impl StateView<T> + ?Sized),
    ) -> ControlFlow<()> {
        let idx = u64::from(strobe_index(self.plan, step));
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
        slot.extend((0..y.len()).map(|k| y.at(k)));
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

    /// Record a sample of the R series when `step` is one of its instants (`r_start` +
    /// a multiple of `r_every`; steps come one by one).
    fn r_sample(&mut self, step: u64, alpha: f64) {
        if step != self.next_r {
            return;
        }
        let (start, every) = (u64::from(self.plan.r_start), u64::from(self.plan.r_every));
        self.next_r += every;
        if let Some(slot) = self.raw.r_alpha.get_mut(((step - start) / every) as usize) {
            *slot = alpha;
        }
    }
}

impl<T: Real> EnsembleHook<'_, T> {
    /// The bookkeeping after `step` steps (1-based) with state `y`, `onsets` bumper contacts
    /// begun at this step; `Break` when the early stop confirms a periodic orbit.
    pub(super) fn record(
        &mut self,
        step: u64,
        y: &(impl StateView<T> + ?Sized),
        onsets: u32,
        twin: &mut (impl StateViewMut<T> + ?Sized),
    ) -> ControlFlow<()> {
        let p = self.plan;
        let alpha = y.at(0).wide();
        let transient = p.transient_steps();
        if step > transient {
            self.accumulate(alpha, onsets, y);
        }
        let want_strobe = !self.raw.strobe.is_empty() || self.early.is_some();
        if step == self.next_strobe {
            self.next_strobe += u64::from(p.spp);
            if let Some(t) = &mut self.twin {
                t.at_sample(strobe_index(p, step), y, twin);
            }
            if want_strobe && self.strobe_sample(step, alpha, y).is_break() {
                return ControlFlow::Break(());
            }
        }
        if !self.raw.r_alpha.is_empty() {
            self.r_sample(step, alpha);
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

/// The index after the transient of the stroboscopic sample taken at `step`.
fn strobe_index(p: &InstancePlan, step: u64) -> u32 {
    ((step - u64::from(p.strobe_offset)) / u64::from(p.spp) - u64::from(p.transient_periods)) as u32
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

/// The first step (1-based) at or after the transient whose `step mod spp` is the strobe
/// offset: the first stroboscopic sample.
fn first_strobe_step(p: &InstancePlan) -> u64 {
    let (spp, offset) = (u64::from(p.spp), u64::from(p.strobe_offset));
    let from = p.transient_steps().max(1);
    from + (offset + spp - from % spp) % spp
}

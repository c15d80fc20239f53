//! The early stop of an ensemble instance whose periodic orbit is confirmed
//! (`docs/analysis.md`, "Early stop"): the rule, the rings it needs, and the continuation that
//! gives the stopped instance the indicators its full run would give. The CPU hook
//! ([`crate::engine::cpu`]) and the WGSL kernel (`shaders/early.wgsl`) follow these steps.
//!
//! **Detection.** At every stroboscopic instant of the run, transient included (absolute index
//! `a`, step `a·spp + offset`), the instance keeps its whole state (angles, rates, voltage) and
//! α. The orbit is *confirmed* with period `p ≤ p_max` forcing periods when
//!
//! ```text
//! |α_j − α_{j−p}| ≤ tol·max(1, |α_j|)      for the last `window` instants j ≤ a, and
//! |y_a − y_{a−p}|_k ≤ tol·max(1, |y_a,k|)  for every component k of the state,
//! ```
//!
//! the smallest such `p` taken.
//!
//! **λ1.** When λ1 is asked for, a confirmed orbit is stopped only once λ1 says it is stable:
//! the twin starts at the confirming instant, aligns over `align` periods and measures
//! `W_e = 8·max(p, 2)` renormalisations (8 blocks of at least one cycle each), all before the
//! map's own λ1 window begins (else no early stop). Only a *shrinking* λ1 (`λ1 T + 2σ < −ε`,
//! the regime's class of a stable orbit) measured to a relative standard error
//! `σ ≤ `[`EARLY_LYAPUNOV_REL_SE`]`·|λ1|` lets the instance stop. Short of that precision the
//! window doubles in place (the block sums merged in pairs) as long as it still ends before
//! the map's window; otherwise the twin goes back to the map's window and the run to its end,
//! as without the early stop. The stopped instance's λ1 is this Floquet exponent of the
//! confirmed cycle, with its standard error.
//!
//! **Stop and continuation.** The instance stops at the next period boundary `P·spp` (every
//! accumulator is kept per forcing period). The rest of the run would repeat the last cycle of
//! `p` periods, so:
//!
//! ```text
//! period q ≥ P:        its tally (hops, impacts, Σv²/R, α range) = that of period P − p + (q − P) mod p
//! instant a after P:   α_a = α_{a − p·⌈(a − a_last)/p⌉}
//! R sample at step s:  α(s) = α(s − p·spp·⌈(s − P·spp)/(p·spp)⌉)
//! ```
//!
//! and the tally adds the periods after the transient. K, the period, R, the line, hops,
//! impacts, power and the α range are then those of the full run up to the tolerance `tol` of
//! the confirmation; `steps` counts the steps integrated.

pub use crate::engine::early_rule::{
    EARLY_LYAPUNOV_REL_SE, EARLY_TOL_F32, EARLY_TOL_F64, EarlyStop, early_lyapunov_stops,
    early_twin_window,
};
use crate::engine::early_rule::{cycle_copy, early_close};
use crate::engine::plan::InstancePlan;
use crate::engine::state_view::StateView;
use crate::model::Real;
use crate::reduce::Tally;

/// The shared rule [`cycle_copy`] on a run's step and period counts, which a plan keeps within
/// `u32` (`EngineError::TooManySteps`).
fn copy_of(s: u64, last: u64, cycle: u64) -> u64 {
    let narrow = |x: u64| {
        debug_assert!(x <= u64::from(u32::MAX), "{x} past a plan's step count");
        x as u32
    };
    u64::from(cycle_copy(narrow(s), narrow(last), narrow(cycle)))
}

/// The accumulators of one forcing period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PeriodTally {
    /// Hops between the wells.
    pub hops: u32,
    /// Bumper contact onsets.
    pub impacts: u32,
    /// Σ v²/R_L over the period's steps (W).
    pub power_sum_w: f64,
    /// Smallest α (rad).
    pub alpha_min: f64,
    /// Largest α (rad).
    pub alpha_max: f64,
}

impl Default for PeriodTally {
    fn default() -> Self {
        PeriodTally {
            hops: 0,
            impacts: 0,
            power_sum_w: 0.0,
            alpha_min: f64::INFINITY,
            alpha_max: f64::NEG_INFINITY,
        }
    }
}

impl PeriodTally {
    /// Add this period to the run's tally.
    pub(crate) fn add_to(&self, t: &mut Tally) {
        t.hops += self.hops;
        t.impacts += self.impacts;
        t.power_sum_w += self.power_sum_w;
        t.alpha_range_rad.0 = t.alpha_range_rad.0.min(self.alpha_min);
        t.alpha_range_rad.1 = t.alpha_range_rad.1.max(self.alpha_max);
    }
}

/// The rings of one instance's early stop.
#[derive(Debug, Clone)]
pub(crate) struct EarlyTracker<T> {
    rule: EarlyStop,
    /// Whole states at the last `p_max + 1` stroboscopic instants.
    states: Vec<Vec<T>>,
    /// α at the last `window + p_max` instants.
    alphas: Vec<f64>,
    /// Instants seen, and the last one.
    seen: u64,
    last_abs: u64,
    /// Tallies of the last `p_max` periods.
    periods: Vec<PeriodTally>,
    /// α at every R instant of the last `p_max` periods (empty without an R series).
    r_ring: Vec<f64>,
}

impl<T: Real> EarlyTracker<T> {
    /// The tracker of `rule` for `plan`, keeping R's instants when `want_r`.
    pub fn new(rule: EarlyStop, plan: &InstancePlan, want_r: bool) -> Self {
        let r_len = if want_r {
            (rule.p_max * (plan.spp / plan.r_every)) as usize
        } else {
            0
        };
        EarlyTracker {
            rule,
            states: vec![Vec::new(); rule.p_max as usize + 1],
            alphas: vec![f64::NAN; (rule.window + rule.p_max) as usize],
            seen: 0,
            last_abs: 0,
            periods: vec![PeriodTally::default(); rule.p_max as usize],
            r_ring: vec![f64::NAN; r_len],
        }
    }

    /// Keep the state at stroboscopic instant `abs`; the period of the orbit when it is
    /// confirmed there.
    pub(crate) fn at_strobe(&mut self, abs: u64, y: &(impl StateView<T> + ?Sized)) -> Option<u32> {
        let (ns, na) = (self.states.len() as u64, self.alphas.len() as u64);
        let slot = &mut self.states[(abs % ns) as usize];
        slot.clear();
        slot.extend((0..y.len()).map(|k| y.at(k)));
        self.alphas[(abs % na) as usize] = y.at(0).wide();
        self.seen += 1;
        self.last_abs = abs;
        let e = self.rule;
        let tol = e.tol_in::<T>();
        let close = |a: f64, b: f64| early_close(a, b, tol);
        let w = u64::from(e.window);
        (1..=u64::from(e.p_max))
            .find(|&p| {
                self.seen >= w + p
                    && (abs + 1 - w..=abs).all(|j| {
                        close(
                            self.alphas[(j % na) as usize],
                            self.alphas[((j - p) % na) as usize],
                        )
                    })
                    && {
                        let now = &self.states[(abs % ns) as usize];
                        let then = &self.states[((abs - p) % ns) as usize];
                        now.iter().zip(then).all(|(a, b)| close(a.wide(), b.wide()))
                    }
            })
            .map(|p| p as u32)
    }

    /// Keep the tally of period `q` (0-based).
    pub(crate) fn end_period(&mut self, q: u64, t: PeriodTally) {
        let n = self.periods.len() as u64;
        self.periods[(q % n) as usize] = t;
    }

    /// Whether α at R instants is kept.
    pub(crate) fn wants_r(&self) -> bool {
        !self.r_ring.is_empty()
    }

    /// Keep α at the R instant `step` (a multiple of `r_every`).
    pub(crate) fn r_sample(&mut self, step: u64, r_every: u64, alpha: f64) {
        let n = self.r_ring.len() as u64;
        self.r_ring[((step / r_every) % n) as usize] = alpha;
    }

    /// Fill what the run after period boundary `stop_period` would have added (see the
    /// module doc): the tally of the periods after the transient, the stroboscopic α after
    /// the transient (`strobe`, empty when not recorded) and the R series (`r_alpha`).
    pub(crate) fn continue_orbit(
        &self,
        p: u32,
        stop_period: u64,
        plan: &InstancePlan,
        tally: &mut Tally,
        strobe: &mut [f64],
        r_alpha: &mut [f64],
    ) {
        let (p, big_p) = (u64::from(p), stop_period);
        let (tp, total) = (
            u64::from(plan.transient_periods),
            u64::from(plan.total_periods),
        );
        let np = self.periods.len() as u64;
        for q in big_p.max(tp)..total {
            let src = copy_of(q, big_p - 1, p);
            self.periods[(src % np) as usize].add_to(tally);
        }
        let (spp, offset) = (u64::from(plan.spp), u64::from(plan.strobe_offset));
        let stop_step = big_p * spp;
        let na = self.alphas.len() as u64;
        for (j, slot) in strobe.iter_mut().enumerate() {
            let a = tp + j as u64;
            if a * spp + offset > stop_step {
                let src = copy_of(a, self.last_abs, p);
                *slot = self.alphas[(src % na) as usize];
            }
        }
        if self.r_ring.is_empty() {
            return;
        }
        let (r_start, r_every) = (u64::from(plan.r_start), u64::from(plan.r_every));
        let (cycle, nr) = (p * spp, self.r_ring.len() as u64);
        for (j, slot) in r_alpha.iter_mut().enumerate() {
            let s = r_start + j as u64 * r_every;
            if s > stop_step {
                let src = copy_of(s, stop_step, cycle);
                *slot = self.r_ring[((src / r_every) % nr) as usize];
            }
        }
    }
}

//! The stroboscopic map `P` of a map's instance: its state at the start of a forcing period
//! carried over whole periods, by RK4 with the bumpers' contact events located.
//!
//! ```text
//! P^k(x):   k · spp · m steps of h = dt / m from x at forcing phase 0 (dt: the instance's
//!           (base) step, spp steps per period; m = SUBSTEPS = 1 for an RK4 instance, more
//!           where RK4 needs a shorter step than an IMEX instance's)
//! cart:     exact phase, (step mod spp + frac)/spp of a period, as the ensemble engines
//! bumpers:  each on a branch of its law, frozen over a step (ContactLaw::Frozen); where a
//!           branch changes inside a step, the instant is found on the step's RK4 solution
//!           (Illinois' false position on δ, δ̇ or k_c δ + c_c δ̇) and the step split there
//! ```
//!
//! Loading-only damping makes the force jump at a contact's onset (by c_c δ̇). A fixed step
//! through that jump makes `P` jump wherever a stage crosses the bumper, and Newton's
//! differences would see those jumps. Split at the events, `P` is as smooth as the flow
//! (its derivative carries the onsets' saltation), and the orbit and its multipliers are the
//! flow's to RK4's order. The map's error-controlled ladder is not used: a level chosen from
//! the state would make `P` jump too.

use crate::engine::method::Method;
use crate::engine::plan::InstancePlan;
use crate::engine::rk4::{Rk4Scratch, rk4_step_on};
use crate::model::{
    BumperMode, Chain, ContactDamping, ContactLaw, Real, Status, Workspace, health_due,
};

/// Steps of the stroboscopic map per step of an RK4 instance's plan. One: with the events
/// located, the multipliers of two default-map orbits agree with the reference integrator's
/// to 1e-5 at it (2e-6 at two; `tests/suite/orbits.rs`).
pub const SUBSTEPS: u32 = 1;
/// Contact events located within one step at most (the rest of a step after them is taken on
/// the branches reached).
const EVENTS_PER_STEP: usize = 8;
/// Illinois iterations per event at most.
const EVENT_ITERATIONS: usize = 60;
/// An event's instant is located to this share of a step.
const EVENT_TOL: f64 = 1e-13;

/// The stroboscopic map of one instance, in `T`.
pub struct Strobe<'a, T: Real> {
    plan: &'a InstancePlan,
    chain: Chain<T>,
    /// Steps per step of the plan.
    sub: u64,
    law: Option<ContactDamping>,
}

/// What a run of the map saw on the way, besides its end.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    /// The state at the start of each forcing period run (the orbit's stroboscopic points).
    pub points: Vec<Vec<f64>>,
    /// Least and greatest holder angle θ₁ at the steps (rad).
    pub theta_range: (f64, f64),
    /// Least distance to the nearer bumper at the steps (m; negative in contact), NaN without
    /// bumpers.
    pub margin_m: f64,
}

/// The bumpers' branches, +x then −x.
type Modes = (BumperMode, BumperMode);

impl<'a, T: Real> Strobe<'a, T> {
    /// The map of instance `plan`.
    pub fn new(plan: &'a InstancePlan) -> Self {
        let chain = Chain::new(&plan.params);
        Strobe {
            plan,
            sub: substeps(plan),
            law: chain.damping_law(),
            chain,
        }
    }

    /// The instance.
    pub fn plan(&self) -> &InstancePlan {
        self.plan
    }

    /// `P^periods(x)`; `Err` with the status of a run that failed its health check.
    pub fn advance(&self, x: &[f64], periods: u32) -> Result<Vec<f64>, Status> {
        self.run(x, periods, None)
    }

    /// `P^periods(x)` and what the run saw ([`Track`]).
    pub fn track(&self, x: &[f64], periods: u32) -> Result<(Vec<f64>, Track), Status> {
        let mut track = Track {
            points: vec![x.to_vec()],
            theta_range: (f64::INFINITY, f64::NEG_INFINITY),
            margin_m: f64::NAN,
        };
        let end = self.run(x, periods, Some(&mut track))?;
        track.points.pop();
        Ok((end, track))
    }

    fn run(
        &self,
        x: &[f64],
        periods: u32,
        mut track: Option<&mut Track>,
    ) -> Result<Vec<f64>, Status> {
        let mut y: Vec<T> = x.iter().map(|&v| T::of(v)).collect();
        let mut ws = self.chain.workspace();
        let mut scratch = Rk4Scratch::new(y.len());
        let mut modes = self.modes(&mut ws, &y);
        let mut trial = y.clone();
        let per_period = u64::from(self.plan.spp) * self.sub;
        let steps = u64::from(periods) * per_period;
        for n in 0..steps {
            self.step(n, (&mut y, &mut trial), &mut modes, (&mut ws, &mut scratch));
            let done = n + 1;
            if health_due(done, steps, false) {
                let status = self
                    .plan
                    .guard
                    .check(&self.chain, &y, self.cart(n, 1.0).v_m_s);
                if status != Status::Ok {
                    return Err(status);
                }
            }
            if let Some(t) = track.as_deref_mut() {
                let theta = y[0].wide();
                t.theta_range = (t.theta_range.0.min(theta), t.theta_range.1.max(theta));
                if let Some(m) = self.chain.bumper_margin(&y) {
                    t.margin_m = t.margin_m.min(m.wide());
                }
                if done.is_multiple_of(per_period) {
                    t.points.push(y.iter().map(|v| v.wide()).collect());
                }
            }
        }
        Ok(y.iter().map(|v| v.wide()).collect())
    }

    /// The cart at `frac` of step `n`.
    fn cart(&self, n: u64, frac: f64) -> crate::model::CartState {
        let within = (n % self.sub) as f64 + frac;
        self.plan.cart_at(n / self.sub, within / self.sub as f64)
    }

    /// The branches the exact law puts the bumpers on at `y`.
    fn modes(&self, ws: &mut Workspace<T>, y: &[T]) -> Modes {
        self.chain.bumper_modes(ws, y)
    }

    /// Step `n`, split at the bumpers' events.
    fn step(
        &self,
        n: u64,
        (y, trial): (&mut [T], &mut [T]),
        modes: &mut Modes,
        (ws, s): (&mut Workspace<T>, &mut Rk4Scratch<T>),
    ) {
        let mut at = 0.0;
        for _ in 0..EVENTS_PER_STEP {
            trial.copy_from_slice(y);
            self.partial(n, (at, 1.0), trial, *modes, (ws, s));
            let end = self.modes(ws, trial);
            if end == *modes || self.law.is_none() {
                y.copy_from_slice(trial);
                return;
            }
            let (theta, next) = self.locate(n, at, y, (*modes, end), (ws, s));
            self.partial(n, (at, theta), y, *modes, (ws, s));
            *modes = next;
            at = theta;
        }
        self.partial(n, (at, 1.0), y, *modes, (ws, s));
    }

    /// `y` carried from `a` to `b` (shares of step `n`) with the bumpers on `modes`.
    fn partial(
        &self,
        n: u64,
        (a, b): (f64, f64),
        y: &mut [T],
        modes: Modes,
        (ws, s): (&mut Workspace<T>, &mut Rk4Scratch<T>),
    ) {
        if b <= a {
            return;
        }
        let h = self.plan.dt_s / self.sub as f64 * (b - a);
        let acc = |f: f64| T::of(self.cart(n, f).a_m_s2);
        let law = ContactLaw::Frozen {
            right: modes.0,
            left: modes.1,
        };
        rk4_step_on(
            &self.chain,
            ws,
            y,
            s,
            T::of(h),
            [acc(a), acc(0.5 * (a + b)), acc(b)],
            law,
        );
    }

    /// The earliest branch change after `at` in step `n` from `y`: its instant (share of the
    /// step) and the branches after it.
    fn locate(
        &self,
        n: u64,
        at: f64,
        y: &[T],
        (from, to): (Modes, Modes),
        (ws, s): (&mut Workspace<T>, &mut Rk4Scratch<T>),
    ) -> (f64, Modes) {
        let law = self.law.unwrap_or(ContactDamping::Loading);
        let mut best = (1.0, to);
        for side in 0..2 {
            let (f, t) = if side == 0 {
                (from.0, to.0)
            } else {
                (from.1, to.1)
            };
            if f == t {
                continue;
            }
            let (which, after) = switch(law, f, t);
            let mut g = |theta: f64, ws: &mut Workspace<T>, s: &mut Rk4Scratch<T>| {
                let mut z = y.to_vec();
                self.partial(n, (at, theta), &mut z, from, (ws, s));
                self.chain
                    .bumper_switches(ws, &z)
                    .map_or(0.0, |v| v[side][which].wide())
            };
            let theta = illinois(&mut g, at, 1.0, (ws, s));
            if theta < best.0 {
                let mut next = from;
                if side == 0 {
                    next.0 = after;
                } else {
                    next.1 = after;
                }
                best = (theta, next);
            }
        }
        best
    }
}

/// Which switching value (index into [`Chain::bumper_switches`]) a bumper leaving branch
/// `from` for `to` crosses, and the branch it is on just after.
fn switch(law: ContactDamping, from: BumperMode, to: BumperMode) -> (usize, BumperMode) {
    use BumperMode::{Free, Spring, SpringDamper};
    match (law, from, to) {
        // Onset: δ rises through 0 (δ̇ > 0, so the damper engages with it under either law).
        (_, Free, _) => (0, SpringDamper),
        // Kelvin–Voigt release: the force k_c δ + c_c δ̇ falls through 0.
        (ContactDamping::KelvinVoigt, _, _) => (2, Free),
        // Loading-only release: δ falls through 0.
        (ContactDamping::Loading, _, Free) => (0, Free),
        // Loading-only: δ̇ changes sign inside the contact.
        (ContactDamping::Loading, Spring, _) => (1, SpringDamper),
        (ContactDamping::Loading, SpringDamper, _) => (1, Spring),
    }
}

/// The root of `g` in `[a, b]` by Illinois' false position, to [`EVENT_TOL`] (the bracket's
/// far end); `b` where `g` does not change sign there.
fn illinois<T: Real>(
    g: &mut impl FnMut(f64, &mut Workspace<T>, &mut Rk4Scratch<T>) -> f64,
    a: f64,
    b: f64,
    (ws, s): (&mut Workspace<T>, &mut Rk4Scratch<T>),
) -> f64 {
    let (mut lo, mut hi) = (a, b);
    let (mut g_lo, mut g_hi) = (g(lo, ws, s), g(hi, ws, s));
    if g_lo == 0.0 {
        return lo;
    }
    if g_lo * g_hi > 0.0 {
        // No sign change seen over the step: split at its end.
        return hi;
    }
    let mut last = 0i8;
    for _ in 0..EVENT_ITERATIONS {
        if hi - lo <= EVENT_TOL {
            break;
        }
        let c = (lo * g_hi - hi * g_lo) / (g_hi - g_lo);
        let c = if c > lo && c < hi { c } else { 0.5 * (lo + hi) };
        let gc = g(c, ws, s);
        if gc == 0.0 {
            return c;
        }
        if (gc < 0.0) == (g_lo < 0.0) {
            (lo, g_lo) = (c, gc);
            if last == -1 {
                g_hi *= 0.5;
            }
            last = -1;
        } else {
            (hi, g_hi) = (c, gc);
            if last == 1 {
                g_lo *= 0.5;
            }
            last = 1;
        }
    }
    // Just past the switch, so that the branch after it holds.
    hi
}

/// Steps of the map per step of `plan`: [`SUBSTEPS`] for RK4; for IMEX, enough that RK4 at
/// its automatic step is stable.
fn substeps(plan: &InstancePlan) -> u64 {
    let m = u64::from(SUBSTEPS);
    if plan.method == Method::Rk4 {
        return m;
    }
    let rk4 = crate::model::linear::modes(&plan.params, 0.8).map_or(f64::NAN, |x| x.dt_auto_s);
    match (plan.dt_s / rk4).ceil() {
        k if k.is_finite() && k >= 1.0 => m.max(k as u64),
        _ => m,
    }
}

//! The twin trajectory of λ1 ([`crate::reduce::lyapunov`]) as the step loops run it: the loop
//! advances the twin's state with the main state's step (same method, step, cart and float
//! type); a `TwinTracker` starts it, measures its separation and renormalises it at the
//! stroboscopic instants, and sums the log-growths. The scalar loop, the SIMD lanes and the
//! WGSL kernel (`shaders/integrate.wgsl`, `twin_sample`, `twin_saltation`) follow the same
//! steps.
//!
//! **Contacts.** The bumper force is piecewise smooth: each bumper is free, pushing, or pushing
//! with its damper ([`crate::model::Branches`]). The twin takes every stage on the branches of
//! the main trajectory's stage (`crate::model::Chain::rates_on`): its separation is then the
//! derivative of the fixed-step map along the main orbit (the variational equations solved by
//! a finite difference), with no spurious jump where the twin and the main trajectory would
//! sit on two sides of a switch inside one step. (Without this, a fixed-step periodic orbit
//! that had settled within 1e-13 of such a switch, which a discrete map can do, gave λ1 > 0
//! for a stable orbit: 7.56 Hz, 16.5 mm, N = 3, RK4 at 2400 steps per period.)
//!
//! The force is continuous where a contact ends and where the damper switches off or on inside
//! a contact (the variational equations need nothing there), but it jumps when a contact
//! begins: by `c_c δ̇` with either law. The trajectory `Δδ` deeper in the bumper met the jump
//! `τ = Δδ/δ̇` earlier and took the extra impulse `c_c δ̇ τ = c_c Δδ`: the saltation of the
//! flow, `S = I + (f⁺ − f⁻)∇hᵀ/(∇hᵀ f⁻)` with `h = δ`, which no fixed step sees (the onset falls
//! on one stage for both). `onset_saltation` adds it after every step in which the main
//! trajectory begins a contact:
//!
//! ```text
//! Δθ̇ += ∓ c_c (δ_twin − δ_main) M(θ)⁻¹ (λ_i cos θ_i)      (− at the +x bumper, + at the −x one)
//! ```
//!
//! (`δ̇` cancels, so the correction stays bounded at grazing.) Without it, λ1 of the impacting
//! period-2 orbit at 4 Hz, 4 mm (N = 3) read −0.42 1/s on every fixed-step engine, against
//! its Floquet exponent −3.30 1/s from the event-locating DOP853 integrator.

use crate::engine::state_view::{StateView, StateViewMut};
use crate::model::{Chain, Lane, Real, Workspace};
use crate::reduce::{LyapunovSums, TwinPlan};

/// Add the saltation of a contact onset to the twin's separation (see the module doc):
/// `onsets` says, per bumper (+x, −x), whether the main trajectory `y` began touching it in
/// the step just taken.
pub(crate) fn onset_saltation<T: Real>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &[T],
    twin: &mut [T],
    onsets: (bool, bool),
) {
    if !(onsets.0 || onsets.1) {
        return;
    }
    let flag = |on: bool| T::splat(if on { 1.0 } else { 0.0 });
    saltation_lanes(chain, ws, y, twin, (flag(onsets.0), flag(onsets.1)));
}

/// [`onset_saltation`] in every lane, the onsets as lane flags (1 where the contact began, 0
/// elsewhere): the twin's rates take ∓c_c (δ_twin − δ_main) M(θ)⁻¹(λ_i cos θ_i) at the main
/// state's angles. Written once for the CPU and the GPU, whose `twin_saltation` is generated
/// from it (`crate::engine::gpu::codegen`).
pub(crate) fn saltation_lanes<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &[T],
    twin: &mut [T],
    (right, left): (T, T),
) {
    let (Some(c), Some((rm, lm)), Some((rt, lt))) = (
        chain.contact_damping(),
        chain.penetrations(y),
        chain.penetrations(twin),
    ) else {
        return;
    };
    let n = chain.segments();
    let mut response = vec![T::splat(0.0); n];
    chain.lever_response(ws, y, &mut response);
    let mut k = T::splat(0.0);
    k = T::if_positive(right, k - c * (rt - rm), k);
    k = T::if_positive(left, k + c * (lt - lm), k);
    for (w, r) in twin[n..2 * n].iter_mut().zip(&response) {
        *w += k * *r;
    }
}

/// Per bumper (+x, −x), whether a contact began: touching `now`, not `before`.
pub(crate) fn onsets_of(before: (bool, bool), now: (bool, bool)) -> (bool, bool) {
    (now.0 && !before.0, now.1 && !before.1)
}

/// The bookkeeping of one instance's twin.
#[derive(Debug, Clone)]
pub(crate) struct TwinTracker {
    plan: TwinPlan,
    d0: f64,
    /// The twin's start offset `d0·u` ([`crate::reduce::lyapunov::TwinNorm::start_offset`]).
    offset: Vec<f64>,
    segments: usize,
    running: bool,
    /// The stroboscopic instant (absolute index, transient included) at which it starts.
    start_abs: u32,
    /// The start and window it was made with.
    original: (u32, u32),
    /// The log-growths of the window.
    pub sums: LyapunovSums,
}

impl TwinTracker {
    /// The tracker of `plan` with separation `d0` for a chain of `segments` and a state of
    /// `dim` components, in a run whose transient lasts `transient_periods`.
    pub fn new(
        plan: TwinPlan,
        d0: f64,
        segments: usize,
        dim: usize,
        transient_periods: u32,
    ) -> TwinTracker {
        TwinTracker {
            offset: plan.norm.start_offset(segments, dim, d0),
            start_abs: plan.start_sample + transient_periods,
            original: (plan.start_sample + transient_periods, plan.window),
            plan,
            d0,
            segments,
            running: false,
            sums: LyapunovSums::default(),
        }
    }

    /// The plan it runs (its window changed by [`TwinTracker::restart`]).
    pub fn plan(&self) -> &TwinPlan {
        &self.plan
    }

    /// Whether the twin has started by instant `abs` (it starts at its first instant).
    pub(crate) fn started_by(&self, abs: u32) -> bool {
        abs >= self.start_abs
    }

    /// The last instant it renormalises at (absolute index).
    pub(crate) fn last_abs(&self) -> u32 {
        self.start_abs + self.plan.align + self.plan.window
    }

    /// Back to the plan it was made with (after a [`TwinTracker::restart`]).
    pub fn reset(&mut self) {
        self.start_abs = self.original.0;
        self.plan.window = self.original.1;
        self.running = false;
        self.sums = LyapunovSums::default();
    }

    /// Start over at instant `abs` with a window of `window` renormalisations (λ1 of a
    /// confirmed orbit: [`crate::engine::early`]).
    pub(crate) fn restart(&mut self, abs: u32, window: u32) {
        self.start_abs = abs;
        self.plan.window = window;
        self.running = false;
        self.sums = LyapunovSums::default();
    }

    /// Double the window of a restarted twin in place, its block sums merged in pairs
    /// ([`LyapunovSums::merge_pairs`]), when the longer window still ends before the window
    /// it was made with begins; whether it did. The twin goes on from its last renormalisation.
    pub fn extend(&mut self) -> bool {
        let end = self.start_abs + self.plan.align + 2 * self.plan.window;
        if end >= self.original.0 {
            return false;
        }
        self.sums.merge_pairs();
        self.plan.window *= 2;
        self.running = true;
        true
    }

    /// Whether the loop must advance the twin with the next step.
    pub fn running(&self) -> bool {
        self.running
    }

    /// At stroboscopic instant `j` (absolute index, transient included), with the main state
    /// `y` and the twin's state `twin`: start the twin at `y + d0·u`, or measure `g = ln(d/d0)`
    /// and pull the twin back to distance `d0` along its separation.
    pub(crate) fn at_sample<T: Real>(
        &mut self,
        j: u32,
        y: &(impl StateView<T> + ?Sized),
        twin: &mut (impl StateViewMut<T> + ?Sized),
    ) {
        let (p, start) = (self.plan, self.start_abs);
        if j == start {
            for (k, &du) in self.offset.iter().enumerate() {
                twin.set(k, y.at(k) + T::of(du));
            }
            self.running = true;
            return;
        }
        if !self.running || j <= start {
            return;
        }
        let dim = self.offset.len();
        let d = p
            .norm
            .distance(self.segments, dim, |k| (twin.at(k) - y.at(k)).wide());
        let r = j - start;
        let g = (d / self.d0).ln();
        if r > p.align {
            self.sums.add(r - p.align - 1, p.window, g);
        }
        if !g.is_finite() {
            self.sums.broken = true;
            self.running = false;
            return;
        }
        let scale = T::of(self.d0 / d);
        for k in 0..dim {
            let (yk, tk) = (y.at(k), twin.at(k));
            twin.set(k, yk + scale * (tk - yk));
        }
        if j >= self.last_abs() {
            self.running = false;
        }
    }
}

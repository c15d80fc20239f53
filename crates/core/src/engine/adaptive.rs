//! Error-controlled steps (`integration.step = "adaptive"`; `docs/model.md`, "Adaptive
//! steps"): an embedded pair on a ladder of steps aligned to the plan's base step `H` (the
//! sample grid). Two pairs climb it ([`Rungs`]):
//! - IMEX (`ImexRungs`): ARK3(2)4L\[2\]SA with its embedded second-order solution, the error
//!   filtered through the implicit solve; its base step is the output interval's fraction
//!   (`crate::engine::plan::ADAPTIVE_BASE_MAX_S` at most);
//! - explicit ([`crate::engine::rk4::Rk4Rungs`]): classical RK4 with an embedded third-order
//!   solution from one more evaluation at the step's end, which is the next step's first
//!   (first same as last: four evaluations per try); its base step is RK4's automatic
//!   (stable) step, so the ladder only ever refines it.
//!
//! The ladder's levels, error norm and rules are [`crate::engine::ladder`]'s.
//!
//! So every base step ends exactly on the sample grid (stroboscopic and output instants, and
//! the forcing's phase, hit exactly), and IMEX refactors no matrix per step (S⁻¹ is built once
//! per level). A bumper's kink inside a step shows in `e` and halves the step there. Contact
//! onsets are counted at every sub-step, and λ1's twin takes the main trajectory's sub-steps,
//! on its stages' branches, with its onset saltation at the sub-step where a contact begins
//! (`crate::engine::twin`).
//!
//! Single runs and the CPU engine's scalar loop take their steps here, one instance at a
//! time; the SIMD loop takes the same steps each lane its own (`engine/cpu/lane_ladder.rs`),
//! and the GPU kernel per invocation, one sub-step per pass of its loop
//! (`shaders/integrate.wgsl`, `adaptive_substep`; its explicit pair hands k₅ on as the CPU's
//! does, from a k₁ taken at each dispatch's start).

use crate::config::StepControl;
use crate::engine::error::EngineError;
use crate::engine::imex::{C, Imex, ImexMatrices};
use crate::engine::ladder::{Rung, Rungs, Tolerance};
use crate::engine::rk4::Rk4Rungs;
use crate::engine::stepper::{CartClock, Stepper};
use crate::engine::twin::{onset_saltation, onsets_of};
use crate::model::{Branches, Chain, ModelParams, Real, Workspace};
use serde::Serialize;
use std::sync::Arc;

/// The finest relative tolerance an f32 engine meets. Below it the tolerance is under f32's
/// resolution of the state, the estimate cannot meet it, and every sub-step is forced at the
/// finest level: at rtol 1e-5 one N = 17 instance took 21 s in f32 against 0.06 s in f64
/// (`docs/bench/STIFF.md`'s study, whose f32 runs stop at this tolerance), and at 1e-10 a
/// 2-s run took 75.8 s against 0.05 s.
pub const F32_FINEST_RTOL: f64 = 1e-4;

/// Refuse steps controlled to a tolerance finer than an engine in f32 (`f32`) resolves:
/// every command that runs an ensemble or a single run in f32 checks this before any step.
pub fn check_f32_tolerance(control: StepControl, f32: bool) -> Result<(), EngineError> {
    match control {
        StepControl::Adaptive { rtol, .. } if f32 && rtol < F32_FINEST_RTOL => {
            Err(EngineError::ToleranceBelowF32 {
                rtol,
                floor: F32_FINEST_RTOL,
            })
        }
        _ => Ok(()),
    }
}

/// What the controller did over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct SubstepStats {
    /// Sub-steps accepted.
    pub accepted: u64,
    /// Sub-steps rejected (tried again at half the step).
    pub rejected: u64,
    /// Sub-steps accepted at the finest level with an error above the tolerance.
    pub forced: u64,
    /// The smallest step taken (s).
    pub smallest_s: f64,
    /// The largest step taken (s).
    pub largest_s: f64,
    /// Evaluations of the chain's right-hand side per tried sub-step (the pair's).
    pub evaluations_per_try: u64,
    /// Evaluations beside those (the explicit pair's first k₁, which later tries are handed).
    pub extra_evaluations: u64,
}

impl SubstepStats {
    /// Sub-steps tried: accepted and rejected.
    pub(crate) fn tries(&self) -> u64 {
        self.accepted + self.rejected
    }

    /// Evaluations of the chain's right-hand side (four per tried sub-step of either pair,
    /// and the explicit pair's first k₁).
    pub fn evaluations(&self) -> u64 {
        self.evaluations_per_try * self.tries() + self.extra_evaluations
    }

    fn took(&mut self, h: f64) {
        self.accepted += 1;
        if self.accepted == 1 || h < self.smallest_s {
            self.smallest_s = h;
        }
        self.largest_s = self.largest_s.max(h);
    }
}

/// The IMEX pair on the ladder: one [`Imex`] stepper per level, each with its S⁻¹(h_k),
/// built when first used; the state's summation compensation passes to the level that takes
/// the next sub-step.
#[derive(Debug, Clone)]
pub(crate) struct ImexRungs<T> {
    params: Arc<ModelParams>,
    base_s: f64,
    dim: usize,
    levels: Vec<Option<Imex<T>>>,
    /// The level holding the compensation.
    level: usize,
}

impl<T: Real> ImexRungs<T> {
    /// The pair for chain `params` over base steps of `base_s` seconds, state length `dim`.
    pub fn new(params: &ModelParams, base_s: f64, dim: usize) -> Self {
        ImexRungs {
            params: Arc::new(params.clone()),
            base_s,
            dim,
            levels: vec![None; crate::engine::ladder::MAX_LEVEL as usize + 1],
            level: 0,
        }
    }

    /// The stepper of level `k`.
    fn at(&mut self, k: usize) -> &mut Imex<T> {
        let h = self.base_s / f64::from(1u32 << k);
        let (params, dim) = (&self.params, self.dim);
        self.levels[k]
            .get_or_insert_with(|| Imex::new(&Arc::new(ImexMatrices::new(params, h)), dim))
    }

    /// Move the state's summation compensation to level `k`.
    fn go_to(&mut self, k: usize) {
        if k == self.level {
            return;
        }
        self.at(k);
        let (a, b) = (self.level.min(k), self.level.max(k));
        let (lo, hi) = self.levels.split_at_mut(b);
        if let (Some(x), Some(y)) = (lo[a].as_mut(), hi[0].as_mut()) {
            x.pass_compensation(y);
        }
        self.level = k;
    }
}

impl<T: Real> Rungs<T> for ImexRungs<T> {
    const EVALUATIONS: u64 = 4;

    fn fresh(&self) -> Self {
        ImexRungs::new(&self.params, self.base_s, self.dim)
    }

    fn stages(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        acc: &impl Fn(f64) -> T,
    ) -> [Branches<T>; 4] {
        self.at(k).stages(chain, ws, y, &|i| acc(C[i]))
    }

    /// The embedded error filtered through the implicit solve (`Imex::filtered_error`).
    fn error(
        &mut self,
        k: usize,
        _: &Chain<T>,
        _: &mut Workspace<T>,
        _: (&[T], &impl Fn(f64) -> T),
        out: &mut [T],
    ) {
        self.at(k).filtered_error(out);
    }

    fn finish(&mut self, k: usize, y: &mut [T]) {
        self.go_to(k);
        self.at(k).finish(y);
    }

    fn follow(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        (y, acc): (&mut [T], &impl Fn(f64) -> T),
        branches: &[Branches<T>; 4],
    ) {
        self.go_to(k);
        let at = self.at(k);
        at.stages_on(chain, ws, y, &|i| acc(C[i]), branches);
        at.finish(y);
    }
}

/// The adaptive stepper of one chain with the pair `R` (see the module's documentation).
#[derive(Debug, Clone)]
pub struct Adaptive<T, R> {
    rungs: R,
    base_s: f64,
    tol: Tolerance,
    rung: Rung,
    onsets: u32,
    stats: SubstepStats,
    /// The error vector of the step being tried.
    scratch: Vec<T>,
}

/// Adaptive steps of the IMEX pair.
pub(crate) type AdaptiveImex<T> = Adaptive<T, ImexRungs<T>>;

/// Adaptive steps of the explicit pair (RK4 with its embedded third-order solution).
pub(crate) type AdaptiveRk4<T> = Adaptive<T, Rk4Rungs<T>>;

impl<T: Real> AdaptiveRk4<T> {
    /// The explicit stepper over base steps of `base_s` seconds (RK4's stable step),
    /// tolerances `(rtol, atol)`, for a state of length `dim`.
    pub fn explicit(base_s: f64, tol: (f64, f64), dim: usize) -> Self {
        Adaptive::new(Rk4Rungs::new(base_s, dim), base_s, tol)
    }
}

impl<T: Real> AdaptiveImex<T> {
    /// The IMEX stepper of chain `params` over base steps of `base_s` seconds, tolerances
    /// `(rtol, atol)`, for a state of length `dim`.
    pub fn imex(params: &ModelParams, base_s: f64, tol: (f64, f64), dim: usize) -> Self {
        Adaptive::new(ImexRungs::new(params, base_s, dim), base_s, tol)
    }
}

impl<T: Real, R: Rungs<T>> Adaptive<T, R> {
    /// The stepper of pair `rungs` over base steps of `base_s` seconds, tolerances
    /// `(rtol, atol)`.
    pub fn new(rungs: R, base_s: f64, (rtol, atol): (f64, f64)) -> Self {
        Adaptive {
            rungs,
            base_s,
            tol: Tolerance { rtol, atol },
            rung: Rung::default(),
            onsets: 0,
            stats: SubstepStats {
                evaluations_per_try: R::EVALUATIONS,
                ..SubstepStats::default()
            },
            scratch: Vec::new(),
        }
    }

    /// What the controller did so far.
    pub fn stats(&self) -> SubstepStats {
        SubstepStats {
            extra_evaluations: self.rungs.extra_evaluations(),
            ..self.stats
        }
    }

    /// The scaled error of the stages just computed at level `k` for a step from `y`.
    fn error(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        at: (&[T], &impl Fn(f64) -> T),
    ) -> f64 {
        let mut e = std::mem::take(&mut self.scratch);
        e.resize(at.0.len(), T::of(0.0));
        self.rungs.error(k, chain, ws, at, &mut e);
        let worst = self.tol.scaled_error(&e, at.0, 0);
        self.scratch = e;
        worst
    }

    /// One base step `step` of `y` (and of the twin's state beside it, with its stepper).
    fn base_step<CL: CartClock>(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        (step, clock): (u64, &CL),
        mut twin: Option<(&mut Adaptive<T, R>, &mut [T])>,
    ) {
        let mut touching = chain.touching(y);
        self.onsets = 0;
        loop {
            let k = self.rung.level as usize;
            let (start, width) = self.rung.fractions();
            let acc = |c: f64| T::of(clock.acceleration(step, start + c * width));
            let branches = self.rungs.stages(k, chain, ws, y, &acc);
            let e = self.error(k, chain, ws, (y, &acc));
            if !self.rung.judge(e) {
                self.stats.rejected += 1;
                continue;
            }
            self.stats.forced += u64::from(e > 1.0);
            self.stats.took(self.rung.step_s(self.base_s));
            self.rungs.finish(k, y);
            let now = chain.touching(y);
            let new = onsets_of(touching, now);
            self.onsets += u32::from(new.0) + u32::from(new.1);
            touching = now;
            if let Some((ts, ty)) = &mut twin {
                ts.rungs.follow(k, chain, ws, (ty, &acc), &branches);
                onset_saltation(chain, ws, y, ty, new);
            }
            if self.rung.advance(e) {
                return;
            }
        }
    }
}

impl<T: Real, R: Rungs<T>> Stepper<T> for Adaptive<T, R> {
    fn fresh(&self) -> Self {
        Adaptive::new(
            self.rungs.fresh(),
            self.base_s,
            (self.tol.rtol, self.tol.atol),
        )
    }

    fn step<CL: CartClock>(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        step: u64,
        clock: &CL,
    ) {
        self.base_step(chain, ws, y, (step, clock), None);
    }

    fn step_twin<CL: CartClock>(
        &mut self,
        twin_stepper: &mut Self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        (y, twin): (&mut [T], &mut [T]),
        step: u64,
        clock: &CL,
    ) {
        self.base_step(chain, ws, y, (step, clock), Some((twin_stepper, twin)));
    }

    fn onsets_within(&mut self) -> Option<u32> {
        Some(self.onsets)
    }
}

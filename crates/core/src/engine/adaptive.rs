//! Error-controlled steps (`integration.step = "adaptive"`; `docs/model.md`, "Adaptive
//! steps"): the IMEX pair ARK3(2)4L[2]SA with its embedded second-order solution, on a ladder
//! of steps aligned to the plan's base step `H` (the sample grid):
//!
//! ```text
//! levels:   h_k = H / 2^k,  k = 0 … MAX_LEVEL;  S⁻¹ built once per level and reused
//! error:    e = max_s |x_s| / (atol + rtol·|y_s|),  x = (I − hγL)⁻¹ h Σ (b_i − b̂_i) f_i
//!           (the embedded estimate filtered through the implicit solve: stiff joint modes that
//!           the implicit part damps do not inflate it)
//! accept:   e ≤ 1 (or k = MAX_LEVEL, counted as forced); then, where the position within H
//!           is a multiple of h_{k−1} and e ≤ GROW, k ← k − 1 for the next step
//! reject:   k ← k + 1, the same step again from the same state
//! ```
//!
//! So every base step ends exactly on the sample grid (stroboscopic and output instants, and
//! the forcing's phase, hit exactly), and no matrix is refactored per step. A bumper's kink
//! inside a step shows in `e` and halves the step there. Contact onsets are counted at every
//! sub-step, and λ1's twin takes the main trajectory's sub-steps, on its stages' branches, with
//! its onset saltation at the sub-step where a contact begins (`crate::engine::twin`).
//!
//! Single runs and the CPU engine take their steps here, one instance at a time (the SIMD
//! lanes step together, so an adaptive plan runs on the scalar loop); the GPU kernel takes the
//! same steps per invocation, one sub-step per pass of its loop (`shaders/integrate.wgsl`,
//! `adaptive_substep`).

use crate::engine::imex::{C, Imex, ImexMatrices};
use crate::engine::stepper::{CartClock, Stepper};
use crate::engine::twin::{onset_saltation, onsets_of};
use crate::model::{Chain, ModelParams, Real, Workspace};
use serde::Serialize;
use std::sync::Arc;

/// The finest level: `H / 2^20`, a microsecond of a one-second base step.
pub const MAX_LEVEL: u32 = 20;

/// The error below which the next step may double (its error then about 8× as large).
pub const GROW: f64 = 0.1;

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
}

impl SubstepStats {
    /// Evaluations of the chain's right-hand side (four per tried sub-step).
    pub fn evaluations(&self) -> u64 {
        4 * (self.accepted + self.rejected)
    }

    fn took(&mut self, h: f64) {
        self.accepted += 1;
        if self.accepted == 1 || h < self.smallest_s {
            self.smallest_s = h;
        }
        self.largest_s = self.largest_s.max(h);
    }
}

/// The adaptive IMEX stepper of one chain (see the module's documentation).
#[derive(Debug, Clone)]
pub struct AdaptiveImex<T> {
    params: Arc<ModelParams>,
    base_s: f64,
    rtol: f64,
    atol: f64,
    dim: usize,
    /// The stepper of each level, built when first used.
    levels: Vec<Option<Imex<T>>>,
    level: usize,
    onsets: u32,
    stats: SubstepStats,
    /// The error vector of the step being tried.
    scratch: Vec<T>,
}

impl<T: Real> AdaptiveImex<T> {
    /// The stepper of chain `params` over base steps of `base_s` seconds, tolerances
    /// `(rtol, atol)`, for a state of length `dim`.
    pub fn new(params: &ModelParams, base_s: f64, (rtol, atol): (f64, f64), dim: usize) -> Self {
        AdaptiveImex {
            params: Arc::new(params.clone()),
            base_s,
            rtol,
            atol,
            dim,
            levels: vec![None; MAX_LEVEL as usize + 1],
            level: 0,
            onsets: 0,
            stats: SubstepStats::default(),
            scratch: Vec::new(),
        }
    }

    /// What the controller did so far.
    pub fn stats(&self) -> SubstepStats {
        self.stats
    }

    fn h(&self, k: usize) -> f64 {
        self.base_s / f64::from(1u32 << k)
    }

    /// The stepper of level `k`.
    fn at(&mut self, k: usize) -> &mut Imex<T> {
        let h = self.h(k);
        let (params, dim) = (&self.params, self.dim);
        self.levels[k]
            .get_or_insert_with(|| Imex::new(&Arc::new(ImexMatrices::new(params, h)), dim))
    }

    /// Move to level `k`, the state's summation compensation with it.
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

    /// The scaled error of the stages just computed at level `k` for a step from `y`.
    fn error(&mut self, k: usize, y: &[T]) -> f64 {
        let (rtol, atol) = (self.rtol, self.atol);
        let mut e = std::mem::take(&mut self.scratch);
        e.resize(y.len(), T::of(0.0));
        self.at(k).filtered_error(&mut e);
        let worst = e
            .iter()
            .zip(y)
            .map(|(es, ys)| es.wide().abs() / (atol + rtol * ys.wide().abs()))
            .fold(0.0, f64::max);
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
        mut twin: Option<(&mut AdaptiveImex<T>, &mut [T])>,
    ) {
        let unit = 1u64 << MAX_LEVEL;
        let mut pos = 0u64;
        let mut touching = chain.touching(y);
        self.onsets = 0;
        while pos < unit {
            let k = self.level;
            let span = unit >> k;
            let (start, width) = (pos as f64 / unit as f64, span as f64 / unit as f64);
            let acc = |i: usize| T::of(clock.acceleration(step, start + C[i] * width));
            let branches = self.at(k).stages(chain, ws, y, &acc);
            let e = self.error(k, y);
            if e > 1.0 && k < MAX_LEVEL as usize {
                self.stats.rejected += 1;
                self.go_to(k + 1);
                continue;
            }
            self.stats.forced += u64::from(e > 1.0);
            self.stats.took(self.h(k));
            self.at(k).finish(y);
            let now = chain.touching(y);
            let new = onsets_of(touching, now);
            self.onsets += u32::from(new.0) + u32::from(new.1);
            touching = now;
            if let Some((ts, ty)) = &mut twin {
                ts.go_to(k);
                let tk = ts.at(k);
                tk.stages_on(chain, ws, ty, &acc, &branches);
                tk.finish(ty);
                onset_saltation(chain, ws, y, ty, new);
            }
            pos += span;
            let aligned = k > 0 && pos.is_multiple_of(span << 1);
            if aligned && e <= GROW {
                self.go_to(k - 1);
            }
        }
    }
}

impl<T: Real> Stepper<T> for AdaptiveImex<T> {
    fn fresh(&self) -> Self {
        AdaptiveImex::new(&self.params, self.base_s, (self.rtol, self.atol), self.dim)
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

//! Classical fixed-step RK4: four evaluations of the O(N) chain solve per step, stable up to
//! |λ dt| ≈ 2.78 on the negative real axis, so its step is bound by the largest eigenvalue of
//! the linearised chain (`docs/model.md`, "Time step").

use crate::engine::ladder::Rungs;
use crate::engine::stepper::{CartClock, Stepper, compensated_add};
use crate::model::{Branches, BumperLoad, Chain, ContactLaw, Lane, Real, Workspace};

/// Scratch of one RK4 step: the four stage derivatives and a stage state; and the state's
/// summation compensation, carried from step to step (`compensated_add`).
#[derive(Debug, Clone)]
pub struct Rk4Scratch<T> {
    k: [Vec<T>; 4],
    tmp: Vec<T>,
    comp: Vec<T>,
}

impl<T: Lane> Rk4Scratch<T> {
    /// Forget the summation compensation of lane `i` (a twin starting there).
    pub(crate) fn zero_compensation_lane(&mut self, i: usize) {
        for c in &mut self.comp {
            *c = c.with_lane(i, <T::Scalar as num_traits::Zero>::zero());
        }
    }

    /// Scratch for a state of length `dim`.
    pub fn new(dim: usize) -> Self {
        let z = vec![T::splat(0.0); dim];
        Rk4Scratch {
            k: [z.clone(), z.clone(), z.clone(), z.clone()],
            tmp: z.clone(),
            comp: z,
        }
    }
}

/// One classical RK4 step of `y` by `dt`, with the cart acceleration at the start, middle
/// and end of the step.
#[inline]
pub fn rk4_step<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
) {
    rk4_step_on(chain, ws, y, s, dt, cart_acc, ContactLaw::Exact);
}

/// [`rk4_step`] with the bumpers on the force law `law` (frozen branches between located
/// contact events: the stroboscopic map of `crate::reduce::orbits`).
#[inline]
pub(crate) fn rk4_step_on<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
    law: ContactLaw,
) {
    rk4_stages(chain, ws, y, s, dt, cart_acc, law, None);
}

/// One RK4 step of `y` and of λ1's twin beside it: every stage of the twin evaluated with the
/// bumpers on the branches of the main stage ([`Chain::rates_on`], `crate::engine::twin`).
#[inline]
pub(crate) fn rk4_step_twin<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
    twin: (&mut [T], &mut Rk4Scratch<T>),
) {
    rk4_stages(chain, ws, y, s, dt, cart_acc, ContactLaw::Exact, Some(twin));
}

/// The stage times of RK4 as fractions of the step, and the stage each state is formed from.
const STAGES: [(usize, f64); 4] = [(0, 0.0), (1, 0.5), (1, 0.5), (2, 1.0)];

/// Stage `j`'s offset `h c_j` for a step of `h` (`c = 0, ½, ½, 1`), which stage `j`'s state
/// `y + h c_j k_{j−1}` is formed with.
#[inline]
pub(crate) fn stage_step<T: Lane>(h: T, j: usize) -> T {
    h * T::splat(STAGES[j].1)
}

#[allow(clippy::too_many_arguments)]
fn rk4_stages<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
    law: ContactLaw,
    mut twin: Option<(&mut [T], &mut Rk4Scratch<T>)>,
) {
    for (j, &(a, _)) in STAGES.iter().enumerate() {
        let load = stage_rates(chain, ws, y, s, j, cart_acc[a], dt, Stage::Law(law));
        if let Some((ty, ts)) = &mut twin {
            let branches = load.map_or_else(Branches::free, |l| l.branches);
            stage_rates(chain, ws, ty, ts, j, cart_acc[a], dt, Stage::On(branches));
        }
    }
    rk4_finish(y, s, dt);
    if let Some((ty, ts)) = twin {
        rk4_finish(ty, ts, dt);
    }
}

/// `y += dt (k₁ + 2k₂ + 2k₃ + k₄)/6` with the state's compensation, after the stages.
#[inline]
fn rk4_finish<T: Lane>(y: &mut [T], s: &mut Rk4Scratch<T>, dt: T) {
    finish_in(y, &s.k, &mut s.comp, dt);
}

/// `y += dt (k₁ + 2k₂ + 2k₃ + k₄)/6` with compensation `comp` ([`compensated_add`]), from the
/// stage derivatives `k`.
#[inline]
pub(crate) fn finish_in<T: Lane>(y: &mut [T], k: &[Vec<T>; 4], comp: &mut [T], dt: T) {
    for i in 0..y.len() {
        compensated_add(&mut y[i], &mut comp[i], rk4_increment(k, i, dt));
    }
}

/// Component `i` of the RK4 increment `dt (k₁ + 2k₂ + 2k₃ + k₄)/6`.
#[inline]
fn rk4_increment<T: Lane>(k: &[Vec<T>; 4], i: usize, dt: T) -> T {
    dt * T::splat(1.0 / 6.0) * (k[0][i] + T::splat(2.0) * (k[1][i] + k[2][i]) + k[3][i])
}

/// The candidate `y₄ = y + (Δ − c)` of the stages `k` (`Δ` the RK4 increment for a step of
/// `h`, `c` the compensation), bit for bit the state [`finish_in`] leaves, into `end`.
#[inline]
pub(crate) fn candidate_in<T: Lane>(y: &[T], k: &[Vec<T>; 4], comp: &[T], h: T, end: &mut [T]) {
    for (i, e) in end.iter_mut().enumerate() {
        *e = y[i] + (rk4_increment(k, i, h) - comp[i]);
    }
}

/// The embedded estimate `h (k₄ − k₅)/6` into `out`.
#[inline]
pub(crate) fn estimate_in<T: Lane>(k4: &[T], k5: &[T], h: T, out: &mut [T]) {
    let sixth = h * T::splat(1.0 / 6.0);
    for (i, o) in out.iter_mut().enumerate() {
        *o = sixth * (k4[i] - k5[i]);
    }
}

/// How a stage evaluates the bumpers: by a law (the exact one, or frozen branches), or on the
/// branches of the main trajectory's stage (λ1's twin).
#[derive(Clone, Copy)]
enum Stage<T> {
    Law(ContactLaw),
    On(Branches<T>),
}

/// Stage `j` of a step of `h`: `k_j` at `y + h c_j k_{j−1}` (at `y` for the first), by the
/// stage's law or on the given branches; the bumpers' load there.
#[allow(clippy::too_many_arguments)]
#[inline]
fn stage_rates<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &[T],
    s: &mut Rk4Scratch<T>,
    j: usize,
    acc: T,
    h: T,
    how: Stage<T>,
) -> Option<BumperLoad<T>> {
    let (k, tmp) = (&mut s.k, &mut s.tmp);
    let (before, after) = k.split_at_mut(j);
    let at: &[T] = if j == 0 {
        y
    } else {
        stage(tmp, y, &before[j - 1], stage_step(h, j));
        tmp
    };
    match how {
        Stage::Law(law) => chain.rates(ws, acc, at, &mut after[0], law),
        Stage::On(b) => chain.rates_on(ws, acc, at, &mut after[0], b),
    }
}

/// A stage's state `y + h k` (`h` the stage's offset, [`stage_step`]) into `out`.
#[inline]
pub(crate) fn stage<T: Lane>(out: &mut [T], y: &[T], k: &[T], h: T) {
    for ((o, &yi), &ki) in out.iter_mut().zip(y).zip(k) {
        *o = yi + h * ki;
    }
}

/// Classical RK4 at a fixed step, as a `Stepper`.
#[derive(Debug, Clone)]
pub struct Rk4<T> {
    dt: T,
    scratch: Rk4Scratch<T>,
}

impl<T: Real> Rk4<T> {
    /// RK4 with step `dt_s` (s) for a state of length `dim`.
    pub fn new(dt_s: f64, dim: usize) -> Self {
        Rk4 {
            dt: T::of(dt_s),
            scratch: Rk4Scratch::new(dim),
        }
    }
}

impl<T: Real> Stepper<T> for Rk4<T> {
    fn fresh(&self) -> Self {
        Rk4 {
            dt: self.dt,
            scratch: Rk4Scratch::new(self.scratch.tmp.len()),
        }
    }

    fn step_twin<C: CartClock>(
        &mut self,
        twin_stepper: &mut Self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        (y, twin): (&mut [T], &mut [T]),
        step: u64,
        clock: &C,
    ) {
        let acc = [0.0, 0.5, 1.0].map(|c| T::of(clock.acceleration(step, c)));
        let ts = (twin, &mut twin_stepper.scratch);
        rk4_step_twin(chain, ws, y, &mut self.scratch, self.dt, acc, ts);
    }

    #[inline]
    fn step<C: CartClock>(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        step: u64,
        clock: &C,
    ) {
        let acc = [0.0, 0.5, 1.0].map(|c| T::of(clock.acceleration(step, c)));
        rk4_step(chain, ws, y, &mut self.scratch, self.dt, acc);
    }
}

/// Classical RK4 on the adaptive ladder (`crate::engine::adaptive`), with an embedded
/// third-order solution from one more evaluation at the step's end:
///
/// ```text
/// y₄ = y + h (k₁ + 2k₂ + 2k₃ + k₄) / 6     RK4, the solution taken
/// k₅ = f(t + h, y₄)
/// ŷ₃ = y + h (k₁ + 2k₂ + 2k₃ + k₅) / 6     third order: b̂ = (1/6, 1/3, 1/3, 0, 1/6) meets
///                                          Σb̂ = 1, Σb̂c = 1/2, Σb̂c² = 1/3, Σb̂Ac = 1/6
/// e  = y₄ − ŷ₃ = h (k₄ − k₅) / 6
/// ```
///
/// Its base step is RK4's automatic one (within the stable limit), so the ladder refines it
/// where the error asks (a bumper's kink) and never coarsens it past stability.
#[derive(Debug, Clone)]
pub struct Rk4Rungs<T> {
    base_s: f64,
    pair: Rk4Pair<T>,
    /// The state the pair's k₁ belongs to: a state changed between sub-steps from outside
    /// has its k₁ taken afresh.
    k1_at: Vec<T>,
}

impl<T: Real> Rk4Rungs<T> {
    /// The pair over base steps of `base_s` seconds for a state of length `dim`.
    pub fn new(base_s: f64, dim: usize) -> Self {
        Rk4Rungs {
            base_s,
            pair: Rk4Pair::new(dim),
            k1_at: vec![T::of(0.0); dim],
        }
    }

    fn h(&self, k: usize) -> T {
        T::of(self.base_s / f64::from(1u32 << k))
    }

    /// The cart's acceleration at the stages' fractions 0, ½ and 1 of a sub-step.
    fn cart(acc: &impl Fn(f64) -> T) -> [T; 3] {
        [0.0, 0.5, 1.0].map(acc)
    }
}

/// The explicit pair's working state, lane by lane: RK4's scratch, k₅ and where it was taken,
/// first same as last. k₅ is taken at the compensated candidate `y + (Δ − c)`, which is bit
/// for bit the state an accepted sub-step leaves ([`compensated_add`]), so it is the next
/// sub-step's k₁; a rejected sub-step keeps its k₁ (the same state at the same instant). So a
/// try costs four evaluations, k₂ … k₅, once the first k₁ is taken.
#[derive(Debug, Clone)]
pub(crate) struct Rk4Pair<T> {
    scratch: Rk4Scratch<T>,
    /// The candidate y₄ of the sub-step being tried, and k₅ there with its branches.
    end: Vec<T>,
    k5: Vec<T>,
    k5_branches: Branches<T>,
    /// Whether `k5` belongs to the stages just computed (the next finish hands it on).
    k5_fresh: bool,
    /// Whether the scratch's k₁ is that of the state the next try starts from, its branches.
    k1_ready: bool,
    k1_branches: Branches<T>,
    /// Evaluations of k₁ that no earlier try handed on.
    k1_evaluations: u64,
}

impl<T: Lane> Rk4Pair<T> {
    /// The pair for a state of length `dim`.
    pub(crate) fn new(dim: usize) -> Self {
        Rk4Pair {
            scratch: Rk4Scratch::new(dim),
            end: vec![T::splat(0.0); dim],
            k5: vec![T::splat(0.0); dim],
            k5_branches: Branches::free(),
            k5_fresh: false,
            k1_ready: false,
            k1_branches: Branches::free(),
            k1_evaluations: 0,
        }
    }

    /// The same pair with nothing carried over (a twin's).
    pub(crate) fn fresh(&self) -> Self {
        Rk4Pair::new(self.end.len())
    }

    /// Forget the summation compensation of lane `i` (a twin starting there).
    pub(crate) fn zero_compensation_lane(&mut self, i: usize) {
        self.scratch.zero_compensation_lane(i);
    }

    /// Take k₁ afresh at the next try (the state was changed from outside).
    pub(crate) fn forget_k1(&mut self) {
        self.k1_ready = false;
    }

    /// Evaluations of k₁ that no earlier try handed on (the first sub-step's, and after
    /// [`Rk4Pair::forget_k1`]).
    pub(crate) fn k1_evaluations(&self) -> u64 {
        self.k1_evaluations
    }

    /// The four RK4 stages of a sub-step of `h` from `y`, the cart at its start, middle and
    /// end; `y` left as it is. By the exact law (k₁ handed on where the pair has it), or on
    /// the given branches (a twin: every stage). The bumpers' branches at each stage.
    pub(crate) fn stages(
        &mut self,
        (chain, ws): (&Chain<T>, &mut Workspace<T>),
        y: &[T],
        (h, cart_acc): (T, [T; 3]),
        on: Option<&[Branches<T>; 4]>,
    ) -> [Branches<T>; 4] {
        let handed = on.is_none() && self.k1_ready;
        let mut branches = [self.k1_branches; 4];
        for (j, &(a, _)) in STAGES.iter().enumerate().skip(usize::from(handed)) {
            let how = on.map_or(Stage::Law(ContactLaw::Exact), |b| Stage::On(b[j]));
            let s = &mut self.scratch;
            let load = stage_rates(chain, ws, y, s, j, cart_acc[a], h, how);
            branches[j] = load.map_or_else(Branches::free, |l| l.branches);
        }
        if on.is_none() && !handed {
            (self.k1_ready, self.k1_branches) = (true, branches[0]);
            self.k1_evaluations += 1;
        }
        self.k5_fresh = false;
        branches
    }

    /// The estimate `h (k₄ − k₅)/6` of the stages just computed into `out`: k₅ at the
    /// compensated candidate by the exact law, the cart at the sub-step's end.
    pub(crate) fn error(
        &mut self,
        (chain, ws): (&Chain<T>, &mut Workspace<T>),
        y: &[T],
        (h, acc_end): (T, T),
        out: &mut [T],
    ) {
        let s = &self.scratch;
        candidate_in(y, &s.k, &s.comp, h, &mut self.end);
        let load = chain.rates(ws, acc_end, &self.end, &mut self.k5, ContactLaw::Exact);
        self.k5_branches = load.map_or_else(Branches::free, |l| l.branches);
        self.k5_fresh = true;
        estimate_in(&s.k[3], &self.k5, h, out);
    }

    /// Take the sub-step just computed in the lanes where `mask` is positive (the others,
    /// state and compensation, left exactly as they are); there k₅ becomes the next k₁.
    pub(crate) fn finish_masked(&mut self, y: &mut [T], h: T, mask: T) {
        let (k, comp) = (&self.scratch.k, &mut self.scratch.comp);
        for i in 0..y.len() {
            let (mut ny, mut nc) = (y[i], comp[i]);
            compensated_add(&mut ny, &mut nc, rk4_increment(k, i, h));
            y[i] = T::if_positive(mask, ny, y[i]);
            comp[i] = T::if_positive(mask, nc, comp[i]);
        }
        if self.k5_fresh {
            for (k1, &k5) in self.scratch.k[0].iter_mut().zip(&self.k5) {
                *k1 = T::if_positive(mask, k5, *k1);
            }
            let pick = |a: (T, T), b: (T, T)| {
                (
                    T::if_positive(mask, a.0, b.0),
                    T::if_positive(mask, a.1, b.1),
                )
            };
            let (new, old) = (self.k5_branches, self.k1_branches);
            self.k1_branches = Branches {
                right: pick(new.right, old.right),
                left: pick(new.left, old.left),
            };
            self.k5_fresh = false;
        }
    }
}

impl<T: Real> Rungs<T> for Rk4Rungs<T> {
    const EVALUATIONS: u64 = 4;

    fn fresh(&self) -> Self {
        Rk4Rungs::new(self.base_s, self.k1_at.len())
    }

    fn extra_evaluations(&self) -> u64 {
        self.pair.k1_evaluations()
    }

    fn stages(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        acc: &impl Fn(f64) -> T,
    ) -> [Branches<T>; 4] {
        if self
            .k1_at
            .iter()
            .zip(y)
            .any(|(a, b)| a.wide().to_bits() != b.wide().to_bits())
        {
            self.pair.forget_k1();
            self.k1_at.copy_from_slice(y);
        }
        let h = self.h(k);
        self.pair.stages((chain, ws), y, (h, Self::cart(acc)), None)
    }

    /// `h (k₄ − k₅) / 6`, k₅ at the sub-step's end by the exact law.
    fn error(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        (y, acc): (&[T], &impl Fn(f64) -> T),
        out: &mut [T],
    ) {
        let h = self.h(k);
        self.pair.error((chain, ws), y, (h, acc(1.0)), out);
    }

    fn finish(&mut self, k: usize, y: &mut [T]) {
        let h = self.h(k);
        self.pair.finish_masked(y, h, T::of(1.0));
        self.k1_at.copy_from_slice(y);
    }

    fn follow(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        (y, acc): (&mut [T], &impl Fn(f64) -> T),
        branches: &[Branches<T>; 4],
    ) {
        let h = self.h(k);
        let on = Some(branches);
        self.pair.stages((chain, ws), y, (h, Self::cart(acc)), on);
        self.pair.finish_masked(y, h, T::of(1.0));
    }
}

//! Classical fixed-step RK4: four evaluations of the O(N) chain solve per step, stable up to
//! |λ dt| ≈ 2.78 on the negative real axis, so its step is bound by the largest eigenvalue of
//! the linearised chain (`docs/model.md`, "Time step").

use crate::engine::adaptive::Rungs;
use crate::engine::stepper::{CartClock, Stepper, compensated_add};
use crate::model::{Branches, BumperLoad, Chain, ContactLaw, Lane, Real, Workspace};

/// Scratch of one RK4 step: the four stage derivatives and a stage state; and the state's
/// summation compensation, carried from step to step ([`compensated_add`]).
#[derive(Debug, Clone)]
pub struct Rk4Scratch<T> {
    k: [Vec<T>; 4],
    tmp: Vec<T>,
    comp: Vec<T>,
}

impl<T: Lane> Rk4Scratch<T> {
    /// Forget the summation compensation of lane `i` (a twin starting there).
    pub fn zero_compensation_lane(&mut self, i: usize) {
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
    rk4_stages(chain, ws, y, s, dt, cart_acc, None);
}

/// One RK4 step of `y` and of λ1's twin beside it: every stage of the twin evaluated with the
/// bumpers on the branches of the main stage ([`Chain::rates_on`], `crate::engine::twin`).
#[inline]
pub fn rk4_step_twin<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
    twin: (&mut [T], &mut Rk4Scratch<T>),
) {
    rk4_stages(chain, ws, y, s, dt, cart_acc, Some(twin));
}

/// The stage times of RK4 as fractions of the step, and the stage each state is formed from.
const STAGES: [(usize, f64); 4] = [(0, 0.0), (1, 0.5), (1, 0.5), (2, 1.0)];

fn rk4_stages<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    y: &mut [T],
    s: &mut Rk4Scratch<T>,
    dt: T,
    cart_acc: [T; 3],
    mut twin: Option<(&mut [T], &mut Rk4Scratch<T>)>,
) {
    for (j, &(a, frac)) in STAGES.iter().enumerate() {
        let load = stage_rates(chain, ws, y, s, j, cart_acc[a], dt * T::splat(frac), None);
        if let Some((ty, ts)) = &mut twin {
            let branches = load.map_or_else(Branches::free, |l| l.branches);
            stage_rates(
                chain,
                ws,
                ty,
                ts,
                j,
                cart_acc[a],
                dt * T::splat(frac),
                Some(branches),
            );
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
    let (k, comp) = (&s.k, &mut s.comp);
    for i in 0..y.len() {
        compensated_add(&mut y[i], &mut comp[i], rk4_increment(k, i, dt));
    }
}

/// Component `i` of the RK4 increment `dt (k₁ + 2k₂ + 2k₃ + k₄)/6`.
#[inline]
fn rk4_increment<T: Lane>(k: &[Vec<T>; 4], i: usize, dt: T) -> T {
    dt * T::splat(1.0 / 6.0) * (k[0][i] + T::splat(2.0) * (k[1][i] + k[2][i]) + k[3][i])
}

/// Stage `j` of RK4: `k_j` at `y + h k_{j−1}` (at `y` for the first), by the exact law or on
/// the given branches; the bumpers' load there.
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
    branches: Option<Branches<T>>,
) -> Option<BumperLoad<T>> {
    let (k, tmp) = (&mut s.k, &mut s.tmp);
    let (before, after) = k.split_at_mut(j);
    let at: &[T] = if j == 0 {
        y
    } else {
        stage(tmp, y, &before[j - 1], h);
        tmp
    };
    match branches {
        None => chain.rates(ws, acc, at, &mut after[0], ContactLaw::Exact),
        Some(b) => chain.rates_on(ws, acc, at, &mut after[0], b),
    }
}

#[inline]
fn stage<T: Lane>(out: &mut [T], y: &[T], k: &[T], h: T) {
    for ((o, &yi), &ki) in out.iter_mut().zip(y).zip(k) {
        *o = yi + h * ki;
    }
}

/// Classical RK4 at a fixed step, as a [`Stepper`].
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
    scratch: Rk4Scratch<T>,
    /// y₄ of the sub-step being tried, and k₅ there.
    end: Vec<T>,
    k5: Vec<T>,
}

impl<T: Real> Rk4Rungs<T> {
    /// The pair over base steps of `base_s` seconds for a state of length `dim`.
    pub fn new(base_s: f64, dim: usize) -> Self {
        Rk4Rungs {
            base_s,
            scratch: Rk4Scratch::new(dim),
            end: vec![T::of(0.0); dim],
            k5: vec![T::of(0.0); dim],
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

/// The four RK4 stages of a step of `h` (lane by lane) from `y`, by the exact law or on the
/// given branches, the cart at the step's start, middle and end; `y` left as it is. The
/// bumpers' branches at each stage.
pub(crate) fn rk4_stages_at<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    (y, s): (&[T], &mut Rk4Scratch<T>),
    h: T,
    cart_acc: [T; 3],
    on: Option<&[Branches<T>; 4]>,
) -> [Branches<T>; 4] {
    let mut branches = [Branches::free(); 4];
    for (j, &(a, frac)) in STAGES.iter().enumerate() {
        let b = on.map(|b| b[j]);
        let load = stage_rates(chain, ws, y, s, j, cart_acc[a], h * T::splat(frac), b);
        branches[j] = load.map_or_else(Branches::free, |l| l.branches);
    }
    branches
}

/// The explicit pair's error estimate `h (k₄ − k₅)/6` into `out` after [`rk4_stages_at`]:
/// k₅ at y₄ (into `end`, the rates into `k5`) by the exact law, the cart at the step's end.
pub(crate) fn rk4_error_at<T: Lane>(
    chain: &Chain<T>,
    ws: &mut Workspace<T>,
    (y, s): (&[T], &Rk4Scratch<T>),
    (h, acc_end): (T, T),
    (end, k5): (&mut [T], &mut [T]),
    out: &mut [T],
) {
    for (i, e) in end.iter_mut().enumerate() {
        *e = y[i] + rk4_increment(&s.k, i, h);
    }
    chain.rates(ws, acc_end, end, k5, ContactLaw::Exact);
    let sixth = h * T::splat(1.0 / 6.0);
    for (i, o) in out.iter_mut().enumerate() {
        *o = sixth * (s.k[3][i] - k5[i]);
    }
}

/// [`rk4_finish`] in the lanes where `mask` is positive; the others, state and compensation,
/// left exactly as they are.
pub(crate) fn rk4_finish_masked<T: Lane>(y: &mut [T], s: &mut Rk4Scratch<T>, h: T, mask: T) {
    let (k, comp) = (&s.k, &mut s.comp);
    for i in 0..y.len() {
        let (mut ny, mut nc) = (y[i], comp[i]);
        compensated_add(&mut ny, &mut nc, rk4_increment(k, i, h));
        y[i] = T::if_positive(mask, ny, y[i]);
        comp[i] = T::if_positive(mask, nc, comp[i]);
    }
}

impl<T: Real> Rungs<T> for Rk4Rungs<T> {
    const EVALUATIONS: u64 = 5;

    fn fresh(&self) -> Self {
        Rk4Rungs::new(self.base_s, self.end.len())
    }

    fn stages(
        &mut self,
        k: usize,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        acc: &impl Fn(f64) -> T,
    ) -> [Branches<T>; 4] {
        let h = self.h(k);
        rk4_stages_at(chain, ws, (y, &mut self.scratch), h, Self::cart(acc), None)
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
        let scratch = (&mut self.end[..], &mut self.k5[..]);
        rk4_error_at(chain, ws, (y, &self.scratch), (h, acc(1.0)), scratch, out);
    }

    fn finish(&mut self, k: usize, y: &mut [T]) {
        let h = self.h(k);
        rk4_finish(y, &mut self.scratch, h);
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
        rk4_stages_at(chain, ws, (y, &mut self.scratch), h, Self::cart(acc), on);
        self.finish(k, y);
    }
}

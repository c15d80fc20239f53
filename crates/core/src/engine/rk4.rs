//! Classical fixed-step RK4: four evaluations of the O(N) chain solve per step, stable up to
//! |λ dt| ≈ 2.78 on the negative real axis, so its step is bound by the largest eigenvalue of
//! the linearised chain (`docs/model.md`, "Time step").

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
    let sixth = T::splat(1.0 / 6.0);
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
    let finish = |y: &mut [T], s: &mut Rk4Scratch<T>| {
        let (k, comp) = (&s.k, &mut s.comp);
        for i in 0..y.len() {
            let inc = dt * sixth * (k[0][i] + T::splat(2.0) * (k[1][i] + k[2][i]) + k[3][i]);
            compensated_add(&mut y[i], &mut comp[i], inc);
        }
    };
    finish(y, s);
    if let Some((ty, ts)) = twin {
        finish(ty, ts);
    }
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

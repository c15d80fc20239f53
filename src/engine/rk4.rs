//! Classical fixed-step RK4: four evaluations of the O(N) chain solve per step, stable up to
//! |λ dt| ≈ 2.78 on the negative real axis, so its step is bound by the largest eigenvalue of
//! the linearised chain (`docs/model.md`, "Time step").

use crate::engine::stepper::{CartClock, Stepper, compensated_add};
use crate::model::{Chain, ContactLaw, Lane, Real, Workspace};

/// Scratch of one RK4 step: the four stage derivatives and a stage state; and the state's
/// summation compensation, carried from step to step ([`compensated_add`]).
#[derive(Debug, Clone)]
pub struct Rk4Scratch<T> {
    k: [Vec<T>; 4],
    tmp: Vec<T>,
    comp: Vec<T>,
}

impl<T: Lane> Rk4Scratch<T> {
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
    let half = T::splat(0.5);
    let sixth = T::splat(1.0 / 6.0);
    let [a0, a_mid, a1] = cart_acc;
    let (k, tmp, comp) = (&mut s.k, &mut s.tmp, &mut s.comp);
    chain.rates(ws, a0, y, &mut k[0], ContactLaw::Exact);
    stage(tmp, y, &k[0], dt * half);
    chain.rates(ws, a_mid, tmp, &mut k[1], ContactLaw::Exact);
    stage(tmp, y, &k[1], dt * half);
    chain.rates(ws, a_mid, tmp, &mut k[2], ContactLaw::Exact);
    stage(tmp, y, &k[2], dt);
    chain.rates(ws, a1, tmp, &mut k[3], ContactLaw::Exact);
    for i in 0..y.len() {
        let inc = dt * sixth * (k[0][i] + T::splat(2.0) * (k[1][i] + k[2][i]) + k[3][i]);
        compensated_add(&mut y[i], &mut comp[i], inc);
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

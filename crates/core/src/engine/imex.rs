//! A stiff-aware integrator: the additive Runge–Kutta pair ARK3(2)4L\[2\]SA of Kennedy &
//! Carpenter (2003), with the linear joint springs and dampers implicit and everything else
//! explicit (`docs/model.md`, "Time step").
//!
//! The chain's equations `θ̇ = ω, ω̇ = M(θ)⁻¹Q` are split as `ẏ = L y + N(y)` with
//!
//! ```text
//! L [θ; ω] = [ω; M0⁻¹ q(θ, ω)],   q = −(K θ + C ω)   (joint and root springs and dampers)
//! N(y)     = f(y) − L y                               (gravity, cart, velocity terms, bumpers,
//!                                                     piezo, and the M(θ) − M0 correction)
//! ```
//!
//! where `M0` is the mass matrix of a straight beam (at any holder angle). The stiff part of
//! the spectrum (eigenvalues down to −1e7 s⁻¹ at N = 17 with the library damping) belongs to
//! `L`; the implicit half of the pair is L-stable, so the step is set by accuracy. Each
//! implicit stage solves `(I − hγL) U = R`, which reduces to one symmetric N × N system
//!
//! ```text
//! S U_ω = M0 R_ω − hγ K R_θ,   S = M0 + hγ C + (hγ)² K,   U_θ = R_θ + hγ U_ω
//! ```
//!
//! with the same `S` for every stage (the implicit tableau has one diagonal value γ): its
//! inverse, and `M0⁻¹`, are computed once per structure and step ([`ImexMatrices`]) and shared
//! by every instance that has them. Per step: four evaluations of the O(N) chain solve, three
//! applications of `S⁻¹` and four of `M0⁻¹` (N² each), all in the engine's float type.

use crate::engine::stepper::{CartClock, Stepper, compensated_add};
use crate::model::linear::spring_pattern;
use crate::model::{
    Branches, BumperLoad, Chain, ContactLaw, Lane, ModelParams, Real, Workspace, dense,
};
use nalgebra::DMatrix;
use std::sync::Arc;

/// γ, the diagonal of the implicit tableau.
pub const GAMMA: f64 = 1767732205903.0 / 4055673282236.0;

/// Stage times c_i (shared by both tableaux).
pub const C: [f64; 4] = [0.0, 2.0 * GAMMA, 3.0 / 5.0, 1.0];

/// Explicit tableau a^E_ij (strictly lower triangular).
pub const AE: [[f64; 4]; 4] = [
    [0.0, 0.0, 0.0, 0.0],
    [2.0 * GAMMA, 0.0, 0.0, 0.0],
    [
        5535828885825.0 / 10492691773637.0,
        788022342437.0 / 10882634858940.0,
        0.0,
        0.0,
    ],
    [
        6485989280629.0 / 16251701735622.0,
        -4246266847089.0 / 9704473918619.0,
        10755448449292.0 / 10357097424841.0,
        0.0,
    ],
];

/// Implicit tableau a^I_ij (lower triangular, γ on the diagonal but the first stage).
pub const AI: [[f64; 4]; 4] = [
    [0.0, 0.0, 0.0, 0.0],
    [GAMMA, GAMMA, 0.0, 0.0],
    [
        2746238789719.0 / 10658868560708.0,
        -640167445237.0 / 6845629431997.0,
        GAMMA,
        0.0,
    ],
    [B[0], B[1], B[2], GAMMA],
];

/// Weights b_i of both tableaux (the implicit one is stiffly accurate: b = its last row).
pub const B: [f64; 4] = [
    1471266399579.0 / 7840856788654.0,
    -4482444167858.0 / 7529755066697.0,
    11266239266428.0 / 11593286722821.0,
    GAMMA,
];

/// Weights of the embedded second-order solution (error estimate of the step probe).
pub const B_HAT: [f64; 4] = [
    2756255671327.0 / 12835298489170.0,
    -10771552573575.0 / 22201958757719.0,
    9247589265047.0 / 10645013368117.0,
    2193209047091.0 / 5459859503100.0,
];

/// The constant matrices of one structure and step: `M0⁻¹` and `S⁻¹` (row-major, N × N),
/// and the joint coefficients that form `q = −(K θ + C ω)` in O(N).
#[derive(Debug, Clone, PartialEq)]
pub struct ImexMatrices {
    /// Segments N.
    pub segments: usize,
    /// The step h (s) the matrices belong to.
    pub dt_s: f64,
    /// Joint spring k and damper b, root spring k0 and damper b0.
    pub joints: JointCoefficients,
    /// M0⁻¹ (1/(kg m²)), row-major.
    pub m0_inv: Vec<f64>,
    /// S⁻¹ (1/(kg m²)), row-major.
    pub s_inv: Vec<f64>,
    /// M0 (kg m²), row-major: the right-hand side of the implicit solve.
    pub m0: Vec<f64>,
}

/// The linear joint forces' coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointCoefficients {
    /// Joint spring k (N m/rad).
    pub k: f64,
    /// Joint damper b (N m s/rad).
    pub b: f64,
    /// Root spring k0 (N m/rad).
    pub k0: f64,
    /// Root damper (N m s/rad).
    pub b0: f64,
}

impl ImexMatrices {
    /// The matrices of chain `p` at step `dt_s`.
    pub fn new(p: &ModelParams, dt_s: f64) -> ImexMatrices {
        let n = p.segments;
        let m0 = dense::mass_matrix(p, &vec![0.0; n]);
        let k = spring_pattern(n, p.joint_stiffness_nm, p.root_stiffness_nm);
        let c = spring_pattern(n, p.joint_damping_nms, p.root_damping_nms);
        let hg = dt_s * GAMMA;
        let s = &m0 + &c * hg + &k * (hg * hg);
        ImexMatrices {
            segments: n,
            dt_s,
            joints: JointCoefficients {
                k: p.joint_stiffness_nm,
                b: p.joint_damping_nms,
                k0: p.root_stiffness_nm,
                b0: p.root_damping_nms,
            },
            m0_inv: row_major(&spd_inverse(m0.clone())),
            s_inv: row_major(&spd_inverse(s)),
            m0: row_major(&m0),
        }
    }
}

/// The inverse of a symmetric positive definite matrix (Cholesky).
fn spd_inverse(m: DMatrix<f64>) -> DMatrix<f64> {
    m.cholesky()
        .expect("mass and iteration matrices are positive definite")
        .inverse()
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    let n = m.nrows();
    (0..n * n).map(|k| m[(k / n, k % n)]).collect()
}

/// `out = A x` for a row-major N × N matrix.
#[inline]
fn mat_vec<T: Lane>(a: &[T], x: &[T], out: &mut [T]) {
    let n = x.len();
    for (i, o) in out.iter_mut().enumerate() {
        let row = &a[i * n..(i + 1) * n];
        let mut s = T::splat(0.0);
        for (&aij, &xj) in row.iter().zip(x) {
            s += aij * xj;
        }
        *o = s;
    }
}

/// The joint coefficients in the engine's float type.
#[derive(Debug, Clone, Copy)]
struct Joints<T> {
    k: T,
    b: T,
    k0: T,
    b0: T,
}

impl<T: Lane> Joints<T> {
    /// `q = −(K θ + C ω)`: the joint and root couples (the dampers only when `omega` is given).
    #[inline]
    fn couples(&self, theta: &[T], omega: Option<&[T]>, q: &mut [T]) {
        let n = theta.len();
        let rate = |i: usize| omega.map_or(T::splat(0.0), |w| w[i]);
        q[0] = -self.k0 * theta[0] - self.b0 * rate(0);
        for qi in q.iter_mut().skip(1) {
            *qi = T::splat(0.0);
        }
        for i in 1..n {
            let tau = -self.k * (theta[i] - theta[i - 1]) - self.b * (rate(i) - rate(i - 1));
            q[i] += tau;
            q[i - 1] -= tau;
        }
    }
}

/// The matrices in the engine's float type, with the step's scratch.
#[derive(Debug, Clone)]
pub struct Imex<T> {
    n: usize,
    h: T,
    hg: T,
    k: T,
    b: T,
    k0: T,
    b0: T,
    m0_inv: Vec<T>,
    s_inv: Vec<T>,
    m0: Vec<T>,
    /// Full derivatives f(U_j) of the stages.
    f: [Vec<T>; 4],
    /// ω-part of L U_j.
    l: [Vec<T>; 4],
    /// Stage state.
    u: Vec<T>,
    /// Scratch of length N: couples and the implicit right-hand side.
    q: Vec<T>,
    r: Vec<T>,
    /// The state's summation compensation, carried from step to step ([`compensated_add`]).
    comp: Vec<T>,
}

impl<T: Lane> Imex<T> {
    /// The stepper of matrices `m` for a state of length `dim`.
    pub fn new(m: &Arc<ImexMatrices>, dim: usize) -> Self {
        let n = m.segments;
        let t = |v: &[f64]| v.iter().map(|&x| T::splat(x)).collect::<Vec<T>>();
        let zd = vec![T::splat(0.0); dim];
        let zn = vec![T::splat(0.0); n];
        Imex {
            n,
            h: T::splat(m.dt_s),
            hg: T::splat(m.dt_s * GAMMA),
            k: T::splat(m.joints.k),
            b: T::splat(m.joints.b),
            k0: T::splat(m.joints.k0),
            b0: T::splat(m.joints.b0),
            m0_inv: t(&m.m0_inv),
            s_inv: t(&m.s_inv),
            m0: t(&m.m0),
            f: [zd.clone(), zd.clone(), zd.clone(), zd.clone()],
            l: [zn.clone(), zn.clone(), zn.clone(), zn.clone()],
            u: zd.clone(),
            comp: zd,
            q: zn.clone(),
            r: zn,
        }
    }

    /// `l[stage] = M0⁻¹ q(θ, ω)`: the ω-part of L at the stage state in `self.u`.
    fn linear_part(&mut self, stage: usize) {
        let n = self.n;
        let j = self.joints();
        j.couples(&self.u[..n], Some(&self.u[n..2 * n]), &mut self.q);
        mat_vec(&self.m0_inv, &self.q, &mut self.l[stage]);
    }

    fn joints(&self) -> Joints<T> {
        Joints {
            k: self.k,
            b: self.b,
            k0: self.k0,
            b0: self.b0,
        }
    }

    /// Form the right-hand side R of stage `i` from `y` and the earlier stages, then solve
    /// `(I − hγL) U = R` into `self.u`.
    fn implicit_stage(&mut self, y: &[T], i: usize) {
        let n = self.n;
        let dim = y.len();
        let h = self.h;
        self.u.copy_from_slice(y);
        for j in 0..i {
            let (ae, ai) = (T::splat(AE[i][j]), T::splat(AI[i][j]));
            for s in 0..n {
                // θ-part: N has none, L's is U_ω = f's θ-part.
                self.u[s] += h * ai * self.f[j][s];
                self.u[n + s] += h * (ae * self.f[j][n + s] + (ai - ae) * self.l[j][s]);
            }
            for s in 2 * n..dim {
                self.u[s] += h * ae * self.f[j][s];
            }
        }
        let mut u = std::mem::take(&mut self.u);
        self.solve(&mut u);
        self.u = u;
    }

    /// The implicit solve `(I − hγL) x ← x` on the chain's part of `x` (its voltage, if any,
    /// left as it is): `S x_ω = M0 x_ω − hγ K x_θ`, then `x_θ += hγ x_ω`. A stage solves for
    /// its state U from its right-hand side R; the error filter solves the same system for the
    /// embedded error.
    fn solve(&mut self, x: &mut [T]) {
        let n = self.n;
        let j = self.joints();
        j.couples(&x[..n], None, &mut self.q);
        mat_vec(&self.m0, &x[n..2 * n], &mut self.r);
        for s in 0..n {
            self.r[s] += self.hg * self.q[s];
        }
        mat_vec(&self.s_inv, &self.r, &mut x[n..2 * n]);
        for s in 0..n {
            x[s] += self.hg * x[n + s];
        }
    }
}

impl<T: Lane> Imex<T> {
    /// Forget the summation compensation of lane `i` (a twin starting there).
    pub(crate) fn zero_compensation_lane(&mut self, i: usize) {
        for c in &mut self.comp {
            *c = c.with_lane(i, <T::Scalar as num_traits::Zero>::zero());
        }
    }

    /// The same matrices and step with nothing carried over (a twin trajectory's stepper).
    pub(crate) fn fresh_lanes(&self) -> Self {
        let mut s = self.clone();
        s.comp.fill(T::splat(0.0));
        s
    }

    /// One step of `y`, the cart acceleration at stage `i` (time `C[i]`·h) given by `acc(i)`.
    #[inline]
    pub fn step_with(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        acc: impl Fn(usize) -> T,
    ) {
        self.step_pair(chain, ws, y, &acc, None);
    }

    /// One step of `y` and of λ1's twin beside it (with its own stepper `twin.0`): every stage
    /// of the twin evaluated with the bumpers on the branches of the main stage
    /// ([`Chain::rates_on`], `crate::engine::twin`).
    #[inline]
    pub(crate) fn step_pair(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        acc: &impl Fn(usize) -> T,
        mut twin: Option<(&mut Imex<T>, &mut [T])>,
    ) {
        for i in 0..C.len() {
            let load = self.stage(chain, ws, y, i, acc(i), None);
            if let Some((ts, ty)) = &mut twin {
                let b = load.map_or_else(Branches::free, |l| l.branches);
                ts.stage(chain, ws, ty, i, acc(i), Some(b));
            }
        }
        self.finish(y);
        if let Some((ts, ty)) = twin {
            ts.finish(ty);
        }
    }

    /// Every stage of a step of `y` by the exact law, `y` left as it is: the bumpers' branches
    /// at each stage (what a twin follows). [`Imex::finish`] then takes the step.
    pub(crate) fn stages(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        acc: &impl Fn(usize) -> T,
    ) -> [Branches<T>; 4] {
        std::array::from_fn(|i| {
            let load = self.stage(chain, ws, y, i, acc(i), None);
            load.map_or_else(Branches::free, |l| l.branches)
        })
    }

    /// Every stage of a twin's step of `y` on the main stages' `branches`.
    pub(crate) fn stages_on(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        acc: &impl Fn(usize) -> T,
        branches: &[Branches<T>; 4],
    ) {
        for (i, b) in branches.iter().enumerate() {
            self.stage(chain, ws, y, i, acc(i), Some(*b));
        }
    }

    /// The embedded error filtered through the implicit solve, `(I − hγL)⁻¹ e` with
    /// `e = h Σ (b_i − b̂_i) f_i` (Shampine's filter; Hairer & Wanner, *Solving ODEs II*, IV.8),
    /// into `out` (the state's length), after [`Imex::stages`]: a stiff joint mode that the
    /// implicit part damps no longer inflates the estimate, and the smooth components keep
    /// theirs. The same solve as a stage's: `S x_ω = M0 e_ω − hγ K e_θ`, `x_θ = e_θ + hγ x_ω`;
    /// the voltage is left as it is.
    pub(crate) fn filtered_error(&mut self, out: &mut [T]) {
        embedded_error_in(&self.f, self.h, out);
        self.solve(out);
    }

    /// `y += h Σ b_i f_i` with the state's compensation in the lanes where `mask` is positive;
    /// the others, state and compensation, left exactly as they are.
    pub(crate) fn finish_masked(&mut self, y: &mut [T], mask: T) {
        for (s, (ys, cs)) in y.iter_mut().zip(&mut self.comp).enumerate() {
            let inc = increment(&self.f, self.h, s);
            let (mut ny, mut nc) = (*ys, *cs);
            compensated_add(&mut ny, &mut nc, inc);
            *ys = T::if_positive(mask, ny, *ys);
            *cs = T::if_positive(mask, nc, *cs);
        }
    }

    /// Lane `lane` steps by `m`'s step with its `S⁻¹` (a lane's own level of the ladder);
    /// `m` is of the same chain as the other lanes (`M0`, `M0⁻¹` and the joints are shared).
    pub(crate) fn set_lane_step(&mut self, lane: usize, m: &ImexMatrices)
    where
        T::Scalar: Real,
    {
        let of = <T::Scalar as Real>::of;
        self.h = self.h.with_lane(lane, of(m.dt_s));
        self.hg = self.hg.with_lane(lane, of(m.dt_s * GAMMA));
        for (s, &x) in self.s_inv.iter_mut().zip(&m.s_inv) {
            *s = s.with_lane(lane, of(x));
        }
    }

    /// Hand the state's summation compensation to `other` (a change of step level).
    pub(crate) fn pass_compensation(&mut self, other: &mut Imex<T>) {
        std::mem::swap(&mut self.comp, &mut other.comp);
    }

    /// Stage `i`: its state (the implicit solve for `i > 0`), the derivative there by the exact
    /// law or on the given branches, and L's part when later stages need it; the bumpers' load.
    #[inline]
    fn stage(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &[T],
        i: usize,
        acc: T,
        branches: Option<Branches<T>>,
    ) -> Option<BumperLoad<T>> {
        if i == 0 {
            self.u.copy_from_slice(y);
        } else {
            self.implicit_stage(y, i);
        }
        let u = std::mem::take(&mut self.u);
        let load = match branches {
            None => chain.rates(ws, acc, &u, &mut self.f[i], ContactLaw::Exact),
            Some(b) => chain.rates_on(ws, acc, &u, &mut self.f[i], b),
        };
        self.u = u;
        if i < 3 {
            self.linear_part(i);
        }
        load
    }

    /// `y += h Σ b_i f_i` with the state's compensation.
    #[inline]
    pub(crate) fn finish(&mut self, y: &mut [T]) {
        finish_in(y, &self.f, &mut self.comp, self.h);
    }
}

/// `y += h Σ b_i f_i` from the stage derivatives `f`, with the summation compensation `comp`
/// (what [`Imex::finish`] does; the GPU kernel's `imex_finish` is generated from it).
#[inline]
pub(crate) fn finish_in<T: Lane>(y: &mut [T], f: &[Vec<T>; 4], comp: &mut [T], h: T) {
    for (s, (ys, cs)) in y.iter_mut().zip(comp.iter_mut()).enumerate() {
        compensated_add(ys, cs, increment(f, h, s));
    }
}

/// The difference between the step's solution and the embedded second-order one,
/// `h Σ (b_i − b̂_i) f_i`, into `out` (the kernel's `imex_embedded_error` is generated from it).
#[inline]
pub(crate) fn embedded_error_in<T: Lane>(f: &[Vec<T>; 4], h: T, out: &mut [T]) {
    for (s, o) in out.iter_mut().enumerate() {
        let mut e = T::splat(0.0);
        for (fi, (&b, &bh)) in f.iter().zip(B.iter().zip(&B_HAT)) {
            e += T::splat(b - bh) * fi[s];
        }
        *o = h * e;
    }
}

/// Component `s` of a step's increment `h Σ b_i f_i` from its stage derivatives `f`.
#[inline]
fn increment<T: Lane>(f: &[Vec<T>; 4], h: T, s: usize) -> T {
    let mut inc = T::splat(0.0);
    for (fi, &b) in f.iter().zip(&B) {
        inc += T::splat(b) * fi[s];
    }
    h * inc
}

impl<T: Real> Stepper<T> for Imex<T> {
    fn fresh(&self) -> Self {
        self.fresh_lanes()
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
        let acc = |i: usize| T::of(clock.acceleration(step, C[i]));
        self.step_pair(chain, ws, y, &acc, Some((twin_stepper, twin)));
    }

    fn step<CL: CartClock>(
        &mut self,
        chain: &Chain<T>,
        ws: &mut Workspace<T>,
        y: &mut [T],
        step: u64,
        clock: &CL,
    ) {
        self.step_with(chain, ws, y, |i| T::of(clock.acceleration(step, C[i])));
    }
}

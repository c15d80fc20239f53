//! Stage 3 of the reductions: the largest Lyapunov exponent λ1 of an instance, by the
//! two-trajectory method of Benettin, Galgani, Giorgilli & Strelcyn (Meccanica 1980).
//!
//! A twin of the instance starts at a distance `d0` from the main trajectory in the weighted
//! state norm below, is integrated beside it with the very same steps (same method, step, cart
//! and float type), and is pulled back to distance `d0` along the current separation at every
//! renormalisation instant: once per forcing period, at the stroboscopic phase.
//!
//! ```text
//! d_k = ‖y_twin − y‖_w                 just before renormalisation k
//! g_k = ln(d_k / d0)                   the log-growth over period k
//! y_twin ← y + (d0 / d_k)(y_twin − y)
//! λ1 = Σ_{k in window} g_k / (W T)     T = 1/f, W renormalisations averaged (1/s)
//! ```
//!
//! The twin starts `align + window + 1` stroboscopic samples before the last one; the first
//! `align` growths are not averaged: they turn the separation into the most unstable direction
//! (its component along any faster-contracting direction shrinks by their ratio every period).
//!
//! **Norm.** The energy of the separation in the chain linearised about the straight beam,
//! so that a linear free motion keeps its size through every oscillation and only its damping
//! shows in the growths ([`TwinNorm`]):
//!
//! ```text
//! ‖Δy‖² = s · ( Δθ̇ᵀ M₀ Δθ̇  +  Δθᵀ K_s Δθ  +  w_r (uᵀ M₀ Δθ)²  +  C_p Δv² )
//! M₀   mass matrix at θ = 0 (segments, tip, holder)      K_s   joint and root springs
//! u    the rigid rotation (1, …, 1)                       Q = uᵀ M₀ u, its inertia about the pivot
//! w_r  Ω²/Q with a hinged root (no root spring), else 0   s = 1/(Ω² Q)
//! ```
//!
//! With a clamped root `K_s` is positive definite and the norm is twice the linear chain's
//! energy without gravity. A hinged root leaves the rigid rotation without a spring, so `w_r`
//! gives it the stiffness `Ω² Q` of an oscillation at the forcing frequency; the flexible modes
//! are M₀-orthogonal to u and keep their energy exactly. The scale `s` makes a rigid rotation
//! of δ rad at Ω measure δ, as the rates over one forcing radian of the earlier diagonal norm
//! did. Gravity and the bumpers are left out: gravity makes `K` indefinite on a hinged chain,
//! and the bumpers act only in contact. On the linear clamped cantilever the growth of a mode
//! is then `−ζω T` per period up to an O(ζ) ripple that does not add up over the window (the
//! growths telescope), where the earlier norm `Σ Δθ² + Σ (Δθ̇/Ω)²` swung by a factor (ω₁/Ω)²
//! within every period. The voltage enters as the capacitor's energy, and only when the patch
//! is coupled (an uncoupled circuit decays on its own and is not the chain's motion).
//! λ1 itself does not depend on the norm; the finite-time growths and their SE do.
//! The initial separation is `(1, …, 1; Ω, …, Ω; Θ/C_p)` scaled to unit norm
//! ([`TwinNorm::direction`]).
//!
//! **Standard error.** The W growths are cut into [`LYAPUNOV_BLOCKS`] consecutive blocks
//! (block of growth `k` = ⌊k·B/W⌋, sizes differing by at most one); with the block rates
//! `m_b = Σ_{k∈b} g_k / (n_b T)`, `SE = sd(m_b)/√B` (sample standard deviation). Block means
//! absorb the correlation of neighbouring growths (a chaotic orbit stretches in bursts a few
//! periods long); with B = 8 the SE is itself uncertain by about `1/√(2(B − 1))` ≈ 27 %. On a
//! settled periodic orbit every period repeats the same growth and the SE is rounding.
//!
//! **Contacts.** The bumper force jumps when a contact begins (by `c_c δ̇` with the loading law)
//! and has a kink where its damping switches on or off. The twin crosses each switching surface
//! a time O(d0) away from the main orbit, so the finite difference carries the jump's saltation
//! (which the variational equations miss unless saltation matrices are added), and stays O(d0)
//! as long as both trajectories cross (transversal crossings). Where an orbit grazes a bumper
//! (touches it with δ̇ ≈ 0), one of the two may touch while the other does not: the separation
//! then jumps by O(√d0) and the growth of that period is overstated. Such grazing happens at
//! isolated instants of chaotic orbits and on the borders of periodic windows; the engine suite
//! holds λ1 of an impacting periodic orbit against its Floquet multiplier computed without a
//! twin, and λ1 against changes of `d0` over decades.

use crate::model::{Lane, ModelParams};
use crate::rules::{max, min, shared_rules};
use serde::Serialize;

/// Blocks of consecutive growths over which the standard error of λ1 is formed.
pub const LYAPUNOV_BLOCKS: usize = 8;

/// [`LYAPUNOV_BLOCKS`] as the rules (and the kernels) count it.
pub(crate) const LYAPUNOV_BLOCK_COUNT: u32 = LYAPUNOV_BLOCKS as u32;

/// The most renormalisations λ1 is averaged over: [`lyapunov_block`] forms `k · B` in `u32`.
pub(crate) const LYAPUNOV_MAX_WINDOW: u32 = u32::MAX / LYAPUNOV_BLOCK_COUNT;

/// The fewest renormalisations λ1 is averaged over: two per block.
pub(crate) const LYAPUNOV_MIN_WINDOW: u32 = 2 * LYAPUNOV_BLOCKS as u32;

/// The twin's separation d0 in f64 when none is given: inside the range where λ1 does not
/// depend on it. Measured on the default map's 192-cell subgrid (34 s, N = 3): over d0 = 1e-10
/// to 1e-5, λ1 of the periodic cells moves by at most 3.5e-6 of itself, at 1e-4 by 3.5e-4, at
/// 1e-3 by 3.4e-3 (the nonlinearity of the smooth forces); chaotic cells move far less than
/// their standard errors (`docs/bench/LYAPUNOV.md`).
pub(crate) const SEPARATION_F64: f64 = 1e-8;

/// The twin's separation d0 in f32 (the CPU engine's and the GPU's) when none is given: small
/// separations drown in the rounding of the state (λ1 of the same periodic orbits, median
/// error against f64: CPU 3.4e-3 at 1e-5 and 2.4e-4 at 1e-4; GPU 7.4e-3 at 1e-5, 8.8e-4 at
/// 1e-4 and 17 % at 1e-6, its twin and main state rounding apart more than the CPU's).
pub(crate) const SEPARATION_F32: f64 = 1e-4;

/// The smallest d0 accepted in f32: below it the GPU's IMEX twin drowns in rounding on some
/// orbits (λ1 of the period-2 orbit at 4 Hz, 4 mm, N = 3: −1.63 1/s at 1e-5 against −3.27 at
/// 1e-4 and 1e-3, and −3.29 from the DOP853 monodromy).
pub(crate) const SEPARATION_F32_MIN: f64 = 1e-4;

/// The smallest d0 accepted in f64 (measured down to it).
pub(crate) const SEPARATION_F64_MIN: f64 = 1e-10;

/// The largest d0 accepted: a bound of the settings ([`crate::config::SEPARATION_MAX`]).
pub use crate::config::SEPARATION_MAX;

/// How an instance's twin runs: when it starts, how long it aligns and measures, and the
/// norm it measures its separation in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TwinPlan {
    /// Stroboscopic sample (index after the transient) at which the twin starts.
    pub start_sample: u32,
    /// Renormalisations that align the separation, not averaged.
    pub align: u32,
    /// Renormalisations averaged into λ1 (one per forcing period).
    pub window: u32,
    /// The norm of the separation.
    pub norm: TwinNorm,
    /// Time between renormalisations: the forcing period (s).
    pub period_s: f64,
}

/// The energy norm of the twin's separation (see the module's documentation): the chain's
/// inertias and springs, the rigid rotation's weight, the capacitance and the scale.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TwinNorm {
    /// Segment length ℓ (m).
    pub seg_len_m: f64,
    /// Segment mass (kg).
    pub seg_mass_kg: f64,
    /// Segment moment of inertia about its centre (kg m²).
    pub seg_inertia_kgm2: f64,
    /// Tip mass (kg).
    pub tip_mass_kg: f64,
    /// Holder inertia on the first segment (kg m²).
    pub holder_inertia_kgm2: f64,
    /// Joint stiffness (N m/rad).
    pub joint_stiffness_nm: f64,
    /// Root stiffness (N m/rad; 0 with a hinged root).
    pub root_stiffness_nm: f64,
    /// `w_r = Ω²/Q` (1/s² per kg m²) with a hinged root, else 0.
    pub rigid_weight: f64,
    /// The capacitance `C_p` (F) of a coupled piezo patch, else 0.
    pub volt_weight: f64,
    /// `s = 1/(Ω² Q)` (1/J).
    pub scale: f64,
    /// Ω = 2πf (rad/s), the rates' share of the initial separation.
    pub omega: f64,
}

impl TwinNorm {
    /// The norm of a chain `p` forced at `omega` (rad/s).
    pub fn of(p: &ModelParams, omega: f64) -> TwinNorm {
        let mut norm = TwinNorm {
            seg_len_m: p.seg_length_m,
            seg_mass_kg: p.seg_mass_kg,
            seg_inertia_kgm2: p.seg_inertia_kgm2,
            tip_mass_kg: p.tip_mass_kg,
            holder_inertia_kgm2: p.holder_inertia_kgm2,
            joint_stiffness_nm: p.joint_stiffness_nm,
            root_stiffness_nm: p.root_stiffness_nm,
            rigid_weight: 0.0,
            volt_weight: p
                .piezo
                .as_ref()
                .filter(|z| z.coupling_nm_per_v != 0.0)
                .map_or(0.0, |z| z.capacitance_f),
            scale: 1.0,
            omega,
        };
        let q = norm.rigid_inertia(p.segments);
        if p.root_stiffness_nm == 0.0 {
            norm.rigid_weight = omega * omega / q;
        }
        norm.scale = 1.0 / (omega * omega * q);
        norm
    }

    /// `Q = uᵀ M₀ u` (kg m²): the straight chain's inertia about its pivot.
    pub(crate) fn rigid_inertia(&self, n: usize) -> f64 {
        self.inertia_form(n, |_| 1.0, |_| 1.0)
    }

    /// `aᵀ M₀ b` in O(N) ([`inertia_form_in`] in f64).
    fn inertia_form(&self, n: usize, a: impl Fn(usize) -> f64, b: impl Fn(usize) -> f64) -> f64 {
        inertia_form_in(n, |c| self.coefficient(c), a, b)
    }

    /// The norm's coefficient `c`.
    pub fn coefficient(&self, c: NormCoefficient) -> f64 {
        match c {
            NormCoefficient::SegLength => self.seg_len_m,
            NormCoefficient::SegMass => self.seg_mass_kg,
            NormCoefficient::SegInertia => self.seg_inertia_kgm2,
            NormCoefficient::TipMass => self.tip_mass_kg,
            NormCoefficient::HolderInertia => self.holder_inertia_kgm2,
            NormCoefficient::JointStiffness => self.joint_stiffness_nm,
            NormCoefficient::RootStiffness => self.root_stiffness_nm,
            NormCoefficient::RigidWeight => self.rigid_weight,
            NormCoefficient::VoltWeight => self.volt_weight,
            NormCoefficient::Scale => self.scale,
        }
    }

    /// `‖Δy‖` of a chain of `n` segments from the component differences `diff(k)`, `k < dim`
    /// (state `[θ; θ̇; v]`): the root of [`distance2_in`] in f64.
    pub fn distance(&self, n: usize, dim: usize, diff: impl Fn(usize) -> f64) -> f64 {
        distance2_in(n, dim > 2 * n, |c| self.coefficient(c), diff).sqrt()
    }

    /// The initial separation of unit norm: every angle 1, every rate Ω, the voltage (of a
    /// coupled patch) 1/√(C_p s), scaled together.
    pub fn direction(&self, n: usize, dim: usize) -> Vec<f64> {
        let e: Vec<f64> = (0..dim)
            .map(|k| match k {
                k if k < n => 1.0,
                k if k < 2 * n => self.omega,
                _ if self.volt_weight > 0.0 => 1.0 / (self.volt_weight * self.scale).sqrt(),
                _ => 0.0,
            })
            .collect();
        let d = self.distance(n, dim, |k| e[k]);
        e.into_iter().map(|x| x / d).collect()
    }

    /// The twin's start offset `d0·u` from the main state, `u` the [`TwinNorm::direction`]:
    /// formed here in f64 for every engine (the CPU's tracker adds it in its number type, the
    /// GPU's kernel takes it in `InstanceParams`).
    pub fn start_offset(&self, n: usize, dim: usize, d0: f64) -> Vec<f64> {
        self.direction(n, dim).into_iter().map(|u| d0 * u).collect()
    }
}

/// One coefficient of the twin's norm, by name ([`TwinNorm::coefficient`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NormCoefficient {
    /// Segment length ℓ (m).
    SegLength,
    /// Segment mass (kg).
    SegMass,
    /// Segment moment of inertia about its centre (kg m²).
    SegInertia,
    /// Tip mass (kg).
    TipMass,
    /// Holder inertia (kg m²).
    HolderInertia,
    /// Joint stiffness (N m/rad).
    JointStiffness,
    /// Root stiffness (N m/rad).
    RootStiffness,
    /// The rigid rotation's weight `w_r`.
    RigidWeight,
    /// The capacitance of a coupled patch (F), else 0.
    VoltWeight,
    /// The scale `s` (1/J).
    Scale,
}

/// `aᵀ M₀ b` in O(N) in the number type `U`, the kinetic energy's form at θ = 0 (as
/// `Chain::energy_in` sums it): horizontal velocities of the segment centres and the tip, plus
/// the rotations.
pub fn inertia_form_in<U: Lane>(
    n: usize,
    c: impl Fn(NormCoefficient) -> U,
    a: impl Fn(usize) -> U,
    b: impl Fn(usize) -> U,
) -> U {
    let (l, half) = (c(NormCoefficient::SegLength), U::splat(0.5));
    let (m, j) = (c(NormCoefficient::SegMass), c(NormCoefficient::SegInertia));
    let zero = U::splat(0.0);
    let (mut va, mut vb, mut sum) = (zero, zero, zero);
    for i in 0..n {
        let (ai, bi) = (a(i), b(i));
        let (ca, cb) = (va + half * l * ai, vb + half * l * bi);
        sum += m * ca * cb + j * ai * bi;
        va += l * ai;
        vb += l * bi;
    }
    let (tip, holder) = (
        c(NormCoefficient::TipMass),
        c(NormCoefficient::HolderInertia),
    );
    sum + tip * va * vb + holder * a(0) * b(0)
}

/// `‖Δy‖²` of a chain of `n` segments from the component differences `diff(k)` in the number
/// type `U`, the voltage's term where `volt` (a state of `2n + 1` components): the scale times
/// the kinetic form of the rates, the springs' form of the angles, the rigid rotation's
/// weighted square and the patch's `C_p Δv²`. Written once for the CPU ([`TwinNorm::distance`])
/// and the GPU (its `twin_norm2`, generated from this function).
pub fn distance2_in<U: Lane>(
    n: usize,
    volt: bool,
    c: impl Fn(NormCoefficient) -> U,
    diff: impl Fn(usize) -> U,
) -> U {
    let zero = U::splat(0.0);
    let kinetic = inertia_form_in(n, &c, |i| diff(n + i), |i| diff(n + i));
    let mut springs = c(NormCoefficient::RootStiffness) * diff(0) * diff(0);
    for i in 1..n {
        let bend = diff(i) - diff(i - 1);
        springs += c(NormCoefficient::JointStiffness) * bend * bend;
    }
    let weight = c(NormCoefficient::RigidWeight);
    let p = inertia_form_in(n, &c, |_| U::splat(1.0), &diff);
    let rigid = U::if_positive(weight, weight * p * p, zero);
    let volt = if volt {
        c(NormCoefficient::VoltWeight) * diff(2 * n) * diff(2 * n)
    } else {
        zero
    };
    c(NormCoefficient::Scale) * (kinetic + springs + rigid + volt)
}

/// The log-growths of one twin, summed per block.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LyapunovSums {
    /// Σ g_k per block.
    pub sums: [f64; LYAPUNOV_BLOCKS],
    /// Growths per block.
    pub counts: [u32; LYAPUNOV_BLOCKS],
    /// A separation was zero or not finite: λ1 cannot be formed.
    pub broken: bool,
}

shared_rules! {
    /// The block of growth k of a window of `window` growths: floor(k B / window), B =
    /// LYAPUNOV_BLOCK_COUNT, the last block for k past the window. Exact while window <=
    /// LYAPUNOV_MAX_WINDOW (k B is formed for k <= window, so it fits a u32), which the plans
    /// hold.
    pub(crate) fn lyapunov_block(k: u32, window: u32) -> u32 {
        let w = max(window, 1);
        return min(min(k, w) * LYAPUNOV_BLOCK_COUNT / w, LYAPUNOV_BLOCK_COUNT - 1);
    }
}

impl LyapunovSums {
    /// Add growth `g` (the `k`-th of the window).
    pub fn add(&mut self, k: u32, window: u32, g: f64) {
        if !g.is_finite() {
            self.broken = true;
            return;
        }
        let b = lyapunov_block(k, window) as usize;
        self.sums[b] += g;
        self.counts[b] += 1;
    }

    /// The sums of a window twice as long whose first half is this one: blocks merged in pairs
    /// (`⌊k·B/2W⌋ = ⌊⌊k·B/W⌋/2⌋`, so growth `k` stays where it belongs), the second half empty.
    pub(crate) fn merge_pairs(&mut self) {
        let half = LYAPUNOV_BLOCKS / 2;
        for b in 0..half {
            self.sums[b] = self.sums[2 * b] + self.sums[2 * b + 1];
            self.counts[b] = self.counts[2 * b] + self.counts[2 * b + 1];
        }
        for b in half..LYAPUNOV_BLOCKS {
            self.sums[b] = 0.0;
            self.counts[b] = 0;
        }
    }

    /// λ1 and its standard error (1/s) once all `window` growths are in; `None` when the twin
    /// broke or the window is incomplete.
    pub fn estimate(&self, window: u32, period_s: f64) -> Option<Lyapunov> {
        let n: u32 = self.counts.iter().sum();
        if self.broken || n != window || self.counts.contains(&0) {
            return None;
        }
        let total: f64 = self.sums.iter().sum();
        let rates: Vec<f64> = self
            .sums
            .iter()
            .zip(&self.counts)
            .map(|(s, &c)| s / (f64::from(c) * period_s))
            .collect();
        let b = rates.len() as f64;
        let mean = rates.iter().sum::<f64>() / b;
        let var = rates.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (b - 1.0);
        Some(Lyapunov {
            per_s: total / (f64::from(n) * period_s),
            se_per_s: (var / b).sqrt(),
        })
    }
}

/// λ1 of an instance with its standard error.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Lyapunov {
    /// λ1 (1/s).
    pub per_s: f64,
    /// Standard error of λ1 from the block means (1/s).
    pub se_per_s: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_split_a_window_evenly_and_the_estimate_is_the_mean_growth_rate() {
        let window = 20;
        let sizes = (0..window).fold([0u32; LYAPUNOV_BLOCKS], |mut c, k| {
            c[lyapunov_block(k, window) as usize] += 1;
            c
        });
        assert!(sizes.iter().all(|&s| s == 2 || s == 3), "{sizes:?}");
        let mut sums = LyapunovSums::default();
        for k in 0..window {
            sums.add(k, window, -0.5 + 0.01 * f64::from(k % 2));
        }
        let l = sums.estimate(window, 0.25).expect("complete");
        assert!((l.per_s - (-0.495 / 0.25)).abs() < 1e-12, "{l:?}");
        assert!(l.se_per_s > 0.0 && l.se_per_s < 0.05, "{l:?}");
        let mut short = LyapunovSums::default();
        short.add(0, window, -0.5);
        assert!(short.estimate(window, 0.25).is_none());
        sums.add(0, window, f64::NEG_INFINITY);
        assert!(sums.estimate(window, 0.25).is_none());
    }

    /// The shared rule is the block the CPU engine formed in u64 before it (floor(k B / W),
    /// the last block past the window), up to the longest window a plan allows.
    #[test]
    fn the_block_rule_is_the_u64_floor_up_to_the_longest_window() {
        let wide = |k: u32, w: u32| {
            (u64::from(k) * LYAPUNOV_BLOCKS as u64 / u64::from(w.max(1))).min(7) as u32
        };
        let big = LYAPUNOV_MAX_WINDOW;
        for w in [0, 1, 2, 16, 17, 33, 1000, big - 1, big] {
            for k in [0, 1, 2, 15, 16, 999, 1000, big / 2, big - 1, big, u32::MAX] {
                assert_eq!(lyapunov_block(k, w), wide(k, w), "k {k}, window {w}");
            }
        }
    }

    #[test]
    fn merged_pairs_are_the_sums_of_a_window_twice_as_long() {
        let (w, g) = (24u32, |k: u32| (f64::from(k) * 0.37).sin());
        let mut long = LyapunovSums::default();
        let mut merged = LyapunovSums::default();
        for k in 0..2 * w {
            long.add(k, 2 * w, g(k));
        }
        for k in 0..w {
            merged.add(k, w, g(k));
        }
        merged.merge_pairs();
        for k in w..2 * w {
            merged.add(k, 2 * w, g(k));
        }
        assert_eq!(merged.counts, long.counts);
        for (a, b) in merged.sums.iter().zip(&long.sums) {
            assert!((a - b).abs() < 1e-12, "{merged:?} vs {long:?}");
        }
    }

    #[test]
    fn the_initial_separation_has_unit_norm() {
        let mut p = crate::config::Scene::paper().model_params().unwrap();
        for root in [0.0, 50.0] {
            p.root_stiffness_nm = root;
            let norm = TwinNorm::of(&p, std::f64::consts::TAU * 8.0);
            let (n, dim) = (p.segments, 2 * p.segments + 1);
            let u = norm.direction(n, dim);
            assert_eq!(
                u[2 * n],
                0.0,
                "no coupled piezo: the voltage is not perturbed"
            );
            assert!((norm.distance(n, dim, |k| u[k]) - 1.0).abs() < 1e-12);
        }
    }

    /// The O(N) forms of the norm against the dense matrices of the linearisation: the mass
    /// matrix at θ = 0 (`model::dense`) and the spring pattern (`model::linear`).
    #[test]
    fn the_norm_is_the_energy_of_the_dense_linearisation() {
        use crate::model::{dense, linear};
        use nalgebra::DVector;
        let scene = crate::config::Scene::paper();
        let mut p = scene.model_params().unwrap();
        for root in [0.0, 37.0] {
            p.root_stiffness_nm = root;
            let n = p.segments;
            let omega = 50.0;
            let norm = TwinNorm::of(&p, omega);
            let m0 = dense::mass_matrix(&p, &vec![0.0; n]);
            let ks = linear::spring_pattern(n, p.joint_stiffness_nm, root);
            let u = DVector::from_element(n, 1.0);
            let q = (u.transpose() * &m0 * &u)[(0, 0)];
            assert!((norm.rigid_inertia(n) - q).abs() < 1e-12 * q);
            let dy: Vec<f64> = (0..2 * n).map(|k| (0.37 * k as f64 + 0.1).sin()).collect();
            let th = DVector::from_column_slice(&dy[..n]);
            let om = DVector::from_column_slice(&dy[n..]);
            let rigid = if root == 0.0 {
                omega * omega / q * (u.transpose() * &m0 * &th)[(0, 0)].powi(2)
            } else {
                0.0
            };
            let dense = ((om.transpose() * &m0 * &om)[(0, 0)]
                + (th.transpose() * &ks * &th)[(0, 0)]
                + rigid)
                / (omega * omega * q);
            let fast = norm.distance(n, 2 * n, |k| dy[k]).powi(2);
            assert!((fast - dense).abs() < 1e-12 * dense, "{fast} vs {dense}");
        }
    }
}

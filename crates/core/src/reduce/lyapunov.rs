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
//! **Norm.** `‖Δy‖_w² = Σ Δθ_i² + Σ (Δθ̇_i / Ω)² + (C_p Δv / Θ)²` with `Ω = 2πf`: angles in
//! rad, rates over one forcing radian, the voltage as the rotation ψ that would charge it
//! (left out without a piezo or without coupling). λ1 itself does not depend on the norm;
//! the finite-time growths do, and this one weighs a period's worth of rate like an angle.
//! The initial separation has the same share in every weighted component ([`TwinPlan::direction`]).
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

use serde::Serialize;

/// Blocks of consecutive growths over which the standard error of λ1 is formed.
pub const LYAPUNOV_BLOCKS: usize = 8;

/// The fewest renormalisations λ1 is averaged over: two per block.
pub const LYAPUNOV_MIN_WINDOW: u32 = 2 * LYAPUNOV_BLOCKS as u32;

/// The twin's separation d0 in f64 when none is given: inside the range where λ1 does not
/// depend on it. Measured on the default map's 192-cell subgrid (34 s, N = 3): over d0 = 1e-10
/// to 1e-5, λ1 of the periodic cells moves by at most 3.5e-6 of itself, at 1e-4 by 3.5e-4, at
/// 1e-3 by 3.4e-3 (the nonlinearity of the smooth forces); chaotic cells move far less than
/// their standard errors (`docs/bench/LYAPUNOV.md`).
pub const SEPARATION_F64: f64 = 1e-8;

/// The twin's separation d0 in f32 (the CPU engine's and the GPU's) when none is given: small
/// separations drown in the rounding of the state (λ1 of the same periodic orbits, median
/// error against f64: CPU 3.4e-3 at 1e-5 and 2.4e-4 at 1e-4; GPU 7.4e-3 at 1e-5, 8.8e-4 at
/// 1e-4 and 17 % at 1e-6, its twin and main state rounding apart more than the CPU's).
pub const SEPARATION_F32: f64 = 1e-4;

/// The smallest d0 accepted in f32: below it the GPU's IMEX twin drowns in rounding on some
/// orbits (λ1 of the period-2 orbit at 4 Hz, 4 mm, N = 3: −1.63 1/s at 1e-5 against −3.27 at
/// 1e-4 and 1e-3, and −3.29 from the DOP853 monodromy).
pub const SEPARATION_F32_MIN: f64 = 1e-4;

/// The smallest d0 accepted in f64 (measured down to it).
pub const SEPARATION_F64_MIN: f64 = 1e-10;

/// The largest d0 accepted: a bound of the settings ([`crate::config::SEPARATION_MAX`]).
pub use crate::config::SEPARATION_MAX;

/// How an instance's twin runs: when it starts, how long it aligns and measures, and the
/// weights of its state norm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TwinPlan {
    /// Stroboscopic sample (index after the transient) at which the twin starts.
    pub start_sample: u32,
    /// Renormalisations that align the separation, not averaged.
    pub align: u32,
    /// Renormalisations averaged into λ1 (one per forcing period).
    pub window: u32,
    /// Weight 1/Ω² of the rates in the norm (s²).
    pub rate_weight: f64,
    /// Weight (C_p/Θ)² of the voltage in the norm (rad²/V²; 0 without a piezo).
    pub volt_weight: f64,
    /// Time between renormalisations: the forcing period (s).
    pub period_s: f64,
}

impl TwinPlan {
    /// The last stroboscopic sample the twin renormalises at.
    pub fn last_sample(&self) -> u32 {
        self.start_sample + self.align + self.window
    }

    /// The weight of component `k` of the state `[θ; θ̇; v]` of a chain of `n` segments.
    #[inline]
    pub fn weight(&self, k: usize, n: usize) -> f64 {
        if k < n {
            1.0
        } else if k < 2 * n {
            self.rate_weight
        } else {
            self.volt_weight
        }
    }

    /// `‖Δy‖_w` from the component differences `diff(k)`, `k < dim`.
    pub fn distance(&self, n: usize, dim: usize, diff: impl Fn(usize) -> f64) -> f64 {
        (0..dim)
            .map(|k| {
                let d = diff(k);
                self.weight(k, n) * d * d
            })
            .sum::<f64>()
            .sqrt()
    }

    /// The initial separation of unit norm: the same share `1/√m` in each of the `m` weighted
    /// components (a component of weight 0 is not perturbed).
    pub fn direction(&self, n: usize, dim: usize) -> Vec<f64> {
        let m = (0..dim).filter(|&k| self.weight(k, n) > 0.0).count().max(1) as f64;
        (0..dim)
            .map(|k| {
                let w = self.weight(k, n);
                if w > 0.0 { 1.0 / (w * m).sqrt() } else { 0.0 }
            })
            .collect()
    }
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

/// The block of growth `k` of a window of `window` growths.
#[inline]
pub fn block_of(k: u32, window: u32) -> usize {
    (u64::from(k) * LYAPUNOV_BLOCKS as u64 / u64::from(window.max(1))) as usize
}

impl LyapunovSums {
    /// Add growth `g` (the `k`-th of the window).
    pub fn add(&mut self, k: u32, window: u32, g: f64) {
        if !g.is_finite() {
            self.broken = true;
            return;
        }
        let b = block_of(k, window).min(LYAPUNOV_BLOCKS - 1);
        self.sums[b] += g;
        self.counts[b] += 1;
    }

    /// The sums of a window twice as long whose first half is this one: blocks merged in pairs
    /// (`⌊k·B/2W⌋ = ⌊⌊k·B/W⌋/2⌋`, so growth `k` stays where it belongs), the second half empty.
    pub fn merge_pairs(&mut self) {
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
            c[block_of(k, window)] += 1;
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
        let plan = TwinPlan {
            start_sample: 0,
            align: 1,
            window: 16,
            rate_weight: 1.0 / 2500.0,
            volt_weight: 0.0,
            period_s: 0.125,
        };
        let (n, dim) = (3, 7);
        let u = plan.direction(n, dim);
        assert_eq!(u[6], 0.0);
        assert!((plan.distance(n, dim, |k| u[k]) - 1.0).abs() < 1e-12);
    }
}

//! Per-instance results of a map, from either engine.
//!
//! The CPU engine leaves raw series ([`RawInstance`]); they are reduced here with the analysis
//! library ([`crate::analysis`]): the 0–1 test on the stroboscopic samples, R from the uniform
//! series, the period of the stroboscopic section. The GPU engine reduces on the device with
//! the same definitions (`shaders/ensemble.wgsl`); [`from_gpu`] only converts units.

use crate::analysis::{
    K01Method, PhaseConvention, ZeroOneOptions, detect_period, phase_sync, zero_one_test,
};
use crate::config::{MapSpec, Metric};
use crate::integrate::Status;
use crate::integrate::ensemble::{EnsemblePlan, InstancePlan, RawInstance};
use crate::integrate::gpu::GpuRun;
use rayon::prelude::*;
use serde::Serialize;

/// The numbers a map shows for one grid point. Metrics not requested, and every metric of an
/// instance whose status is not `ok`, are NaN.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InstanceResult {
    /// 0–1 test K.
    #[serde(rename = "K")]
    pub k: f64,
    /// Phase-synchronisation index R.
    #[serde(rename = "R")]
    pub r: f64,
    /// Period of the stroboscopic section in forcing periods (0 = none ≤ period_max).
    pub period: f64,
    /// Hops between the wells after the transient.
    pub hops: f64,
    /// Bumper contact onsets per second after the transient.
    pub impacts_per_s: f64,
    /// Smallest holder angle after the transient (rad).
    pub alpha_min_rad: f64,
    /// Largest holder angle after the transient (rad).
    pub alpha_max_rad: f64,
    /// Mean harvested power v²/R_L after the transient (W).
    pub power_w: f64,
    /// How the integration ended.
    pub status: Status,
    /// Steps actually integrated (fewer than planned when the instance failed or stopped
    /// early on a confirmed periodic orbit).
    pub steps: u64,
}

impl InstanceResult {
    /// The value shown on the map of `m` (α range: max − min).
    pub fn metric(&self, m: Metric) -> f64 {
        match m {
            Metric::K => self.k,
            Metric::R => self.r,
            Metric::Period => self.period,
            Metric::Hops => self.hops,
            Metric::ImpactsPerS => self.impacts_per_s,
            Metric::AlphaRange => self.alpha_max_rad - self.alpha_min_rad,
            Metric::Power => self.power_w,
        }
    }
}

/// The reduction settings of a map.
#[derive(Debug, Clone, Serialize)]
pub struct ReduceOptions {
    /// 0–1 test settings (correlation method, seeded c values).
    pub zero_one: ZeroOneOptions,
    /// Convention of R.
    pub convention: PhaseConvention,
    /// Longest period searched.
    pub period_max: u32,
    /// Trailing samples that must repeat.
    pub period_window: u32,
    /// Tolerance of the period test (rad).
    pub period_tol_rad: f64,
}

impl ReduceOptions {
    /// From a map scene.
    pub fn from_spec(spec: &MapSpec) -> ReduceOptions {
        ReduceOptions {
            zero_one: ZeroOneOptions {
                method: K01Method::Correlation,
                n_c: spec.k_n_c,
                seed: spec.k_seed,
                normalize: false,
            },
            convention: spec.phase_convention,
            period_max: spec.period_max,
            period_window: spec.period_window,
            period_tol_rad: spec.period_tol_rad,
        }
    }

    /// The same settings in the form the GPU kernels take.
    pub fn for_gpu(&self) -> crate::integrate::gpu::ReduceSettings {
        crate::integrate::gpu::ReduceSettings {
            c_values: crate::analysis::draw_c_values(self.zero_one.n_c, self.zero_one.seed),
            paper_convention: self.convention == PhaseConvention::Paper,
            period_max: self.period_max,
            period_window: self.period_window,
            period_tol_rad: self.period_tol_rad,
        }
    }
}

/// The cart position at the R samples of an instance: the reference signal of R.
pub fn cart_series(p: &InstancePlan) -> Vec<f64> {
    (0..u64::from(p.r_count))
        .map(|j| p.cart_pos(u64::from(p.r_start) + j * u64::from(p.r_every)))
        .collect()
}

/// K of a stroboscopic series as the map computes it (NaN if the test refuses the series).
pub fn k_of(strobe: &[f64], opts: &ReduceOptions) -> f64 {
    zero_one_test(strobe, &opts.zero_one).map_or(f64::NAN, |r| r.k)
}

/// R of an instance's α series against its cart series.
pub fn r_of(p: &InstancePlan, alpha: &[f64], opts: &ReduceOptions) -> f64 {
    phase_sync(&cart_series(p), alpha, opts.convention).map_or(f64::NAN, |r| r.r)
}

/// Reduce the CPU engine's raw instances with the analysis library.
pub fn from_cpu(
    plan: &EnsemblePlan,
    raw: &[RawInstance],
    opts: &ReduceOptions,
) -> Vec<InstanceResult> {
    plan.instances
        .par_iter()
        .zip(raw)
        .map(|(p, r)| {
            let wants = |m: Metric| plan.metrics.contains(&m);
            let mut out = accumulators(
                p,
                plan,
                r.steps_done,
                r.status,
                (r.alpha_min, r.alpha_max),
                r.hops,
                r.impacts,
                r.power_sum,
            );
            if r.status == Status::Ok {
                if wants(Metric::K) {
                    out.k = k_of(&r.strobe, opts);
                }
                if wants(Metric::Period) {
                    out.period = detect_period(
                        &r.strobe,
                        opts.period_max as usize,
                        opts.period_window as usize,
                        opts.period_tol_rad,
                    ) as f64;
                }
                if wants(Metric::R) {
                    out.r = r_of(p, &r.r_alpha, opts);
                }
            }
            out
        })
        .collect()
}

/// Convert the GPU engine's per-instance results.
pub fn from_gpu(plan: &EnsemblePlan, run: &GpuRun) -> Vec<InstanceResult> {
    plan.instances
        .iter()
        .zip(&run.accum)
        .map(|(p, a)| {
            let status = match a.status {
                0 => Status::Ok,
                1 => Status::Diverged,
                3 => Status::Escaped,
                _ => Status::NonFinite,
            };
            let mut out = accumulators(
                p,
                plan,
                u64::from(a.step),
                status,
                (f64::from(a.alpha_min), f64::from(a.alpha_max)),
                a.hops,
                a.impacts,
                f64::from(a.power_sum),
            );
            if status == Status::Ok {
                let wants = |m: Metric| plan.metrics.contains(&m);
                if wants(Metric::K) {
                    out.k = f64::from(a.k);
                }
                if wants(Metric::R) {
                    out.r = f64::from(a.r);
                }
                if wants(Metric::Period) {
                    out.period = f64::from(a.period);
                }
            }
            out
        })
        .collect()
}

/// The accumulator-based metrics (everything but K, R and period), NaN when not requested
/// or when the instance failed.
#[allow(clippy::too_many_arguments)]
fn accumulators(
    p: &InstancePlan,
    plan: &EnsemblePlan,
    steps: u64,
    status: Status,
    alpha: (f64, f64),
    hops: u32,
    impacts: u32,
    power_sum: f64,
) -> InstanceResult {
    let nan = f64::NAN;
    let mut out = InstanceResult {
        k: nan,
        r: nan,
        period: nan,
        hops: nan,
        impacts_per_s: nan,
        alpha_min_rad: nan,
        alpha_max_rad: nan,
        power_w: nan,
        status,
        steps,
    };
    if status != Status::Ok {
        return out;
    }
    let wants = |m: Metric| plan.metrics.contains(&m);
    if wants(Metric::Hops) {
        out.hops = f64::from(hops);
    }
    if wants(Metric::ImpactsPerS) {
        out.impacts_per_s = f64::from(impacts) / p.post_transient_s();
    }
    if wants(Metric::AlphaRange) {
        out.alpha_min_rad = alpha.0;
        out.alpha_max_rad = alpha.1;
    }
    if wants(Metric::Power) {
        let steps = p.total_steps() - p.transient_steps();
        out.power_w = power_sum / steps as f64;
    }
    out
}

//! The ensemble of a map: one independent instance per grid point, each with its own step
//! plan, integrated by the CPU engine here (rayon, `f32` or `f64`) or by the GPU engine
//! ([`crate::integrate::gpu`]), which mirrors this file step for step.
//!
//! Every instance's step divides its forcing period exactly: `spp` steps per period, a
//! multiple of `samples_per_period`. The forcing phase is `(step mod spp)/spp`, exact in
//! integer arithmetic on both engines, and stroboscopic samples fall on steps.
//!
//! While integrating, each instance keeps running accumulators over the steps after the
//! transient (α range, hops, impacts, harvested power) and records only the series its
//! metrics need: the stroboscopic α (K, period, bifurcation) and a power-of-two uniform α
//! series at `samples_per_period` per period (R). Trajectories are never stored.

use crate::config::{MapSpec, Metric, Scene, TimeStep};
use crate::integrate::status::{Guard, Status};
use crate::model::{Chain, ModelParams, Real, modes};
use anyhow::{Result, bail};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::f64::consts::TAU;
use std::sync::atomic::{AtomicU64, Ordering};

/// Steps between health checks (energy bound, folded chain, non-finite state).
pub const CHECK_EVERY: u64 = 64;

/// The step plan and sampling of one instance.
#[derive(Debug, Clone, Serialize)]
pub struct InstancePlan {
    /// The instance's coefficients.
    #[serde(skip)]
    pub params: ModelParams,
    /// Initial state `[θ; θ̇; v]`.
    #[serde(skip)]
    pub y0: Vec<f64>,
    /// Divergence bounds.
    #[serde(skip)]
    pub guard: Guard,
    /// Forcing frequency (Hz).
    pub frequency_hz: f64,
    /// Cart amplitude A (m).
    pub amplitude_m: f64,
    /// Steps per forcing period.
    pub spp: u32,
    /// The step (s) = 1/(f · spp).
    pub dt_s: f64,
    /// Forcing periods discarded as transient.
    pub transient_periods: u32,
    /// Forcing periods integrated in all.
    pub total_periods: u32,
    /// Step within the period at which stroboscopic samples are taken.
    pub strobe_offset: u32,
    /// Number of stroboscopic samples after the transient.
    pub strobe_count: u32,
    /// Steps between samples of the R series.
    pub r_every: u32,
    /// Length of the R series (a power of two).
    pub r_count: u32,
    /// Step of the first R sample.
    pub r_start: u32,
    /// Half the clearance (rad): the well thresholds of hop counting.
    pub half_clearance_rad: f64,
}

impl InstancePlan {
    /// Total steps.
    pub fn total_steps(&self) -> u64 {
        u64::from(self.total_periods) * u64::from(self.spp)
    }

    /// Steps of the transient.
    pub fn transient_steps(&self) -> u64 {
        u64::from(self.transient_periods) * u64::from(self.spp)
    }

    /// Time after the transient (s).
    pub fn post_transient_s(&self) -> f64 {
        f64::from(self.total_periods - self.transient_periods) / self.frequency_hz
    }

    /// Cart acceleration at phase `(step mod spp + frac)/spp`.
    #[inline]
    pub fn cart_acc(&self, phase_steps: u64, frac: f64) -> f64 {
        let ph = (phase_steps as f64 + frac) / f64::from(self.spp);
        -self.acc_amp() * (TAU * ph).sin()
    }

    /// Cart position at `step`.
    pub fn cart_pos(&self, step: u64) -> f64 {
        let ph = (step % u64::from(self.spp)) as f64 / f64::from(self.spp);
        self.amplitude_m * (TAU * ph).sin()
    }

    /// Cart velocity at `step`.
    pub fn cart_vel(&self, step: u64) -> f64 {
        let ph = (step % u64::from(self.spp)) as f64 / f64::from(self.spp);
        self.amplitude_m * TAU * self.frequency_hz * (TAU * ph).cos()
    }

    /// A ω² (m/s²).
    pub fn acc_amp(&self) -> f64 {
        self.amplitude_m * (TAU * self.frequency_hz).powi(2)
    }
}

/// Every instance of a map with the settings shared by all.
#[derive(Debug, Clone, Serialize)]
pub struct EnsemblePlan {
    /// The instances, in grid order (last axis fastest).
    #[serde(skip)]
    pub instances: Vec<InstancePlan>,
    /// Segments N (shared).
    pub segments: usize,
    /// Bumpers present (shared).
    pub has_contact: bool,
    /// Piezo present (shared).
    pub has_piezo: bool,
    /// Metrics requested.
    pub metrics: Vec<Metric>,
    /// Stroboscopic samples are recorded (K, period or bifurcation).
    pub want_strobe: bool,
    /// The R series is recorded.
    pub want_rseries: bool,
    /// Largest stroboscopic count over the instances.
    pub strobe_stride: u32,
    /// Largest R series length over the instances.
    pub r_stride: u32,
    /// Smallest and largest step over the instances (s).
    pub dt_range_s: (f64, f64),
    /// Total instance-steps.
    pub total_steps: u64,
    /// Warnings from planning (explicit dt beyond the stability limit, ...).
    pub warnings: Vec<String>,
    /// Early termination, when asked for and allowed by the metrics.
    pub early_stop: Option<EarlyStop>,
}

/// How the instances of an ensemble are sampled, and what they record.
#[derive(Debug, Clone, Serialize)]
pub struct EnsembleOptions {
    /// Metrics to compute.
    pub metrics: Vec<Metric>,
    /// Record the stroboscopic samples even if no metric needs them (bifurcation diagrams).
    pub keep_strobe: bool,
    /// Steps per period are a multiple of this; R's samples per period.
    pub samples_per_period: u32,
    /// Phase of the stroboscopic samples, in [0, 1).
    pub strobe_phase: f64,
    /// Longest R series (a power of two).
    pub r_max_samples: u32,
    /// Stop an instance once its periodic orbit is confirmed (only honoured when every
    /// requested metric allows it: see [`EarlyStop`]).
    pub early_stop: Option<EarlyStop>,
}

/// Early termination of instances whose periodic orbit is confirmed.
///
/// At each stroboscopic sample, an instance stops when, for some p ≤ `p_max` forcing periods,
/// (a) its last `window` stroboscopic angles each equal the one p samples earlier and (b) its
/// whole state (every angle, rate and the voltage) equals the state p samples earlier, both
/// within `tol · max(1, |x|)`. The rest of the run would repeat that orbit, so the remaining
/// stroboscopic samples are filled by periodic continuation. Only K, the period and the α
/// range are exactly preserved by that; with any other metric the option is ignored.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EarlyStop {
    /// Longest orbit period tried (forcing periods).
    pub p_max: u32,
    /// Trailing stroboscopic samples that must repeat.
    pub window: u32,
    /// Relative tolerance of the repetition.
    pub tol: f64,
}

/// The metrics whose values a periodic continuation preserves exactly.
pub const EARLY_STOP_METRICS: [Metric; 3] = [Metric::K, Metric::Period, Metric::AlphaRange];

impl EnsembleOptions {
    /// The options of a map scene.
    pub fn from_spec(spec: &MapSpec) -> EnsembleOptions {
        EnsembleOptions {
            metrics: spec.metrics.clone(),
            keep_strobe: spec.bifurcation,
            samples_per_period: spec.samples_per_period,
            strobe_phase: spec.strobe_phase,
            r_max_samples: spec.r_max_samples,
            early_stop: spec.early_stop.then_some(EarlyStop {
                p_max: spec.period_max,
                window: spec.period_window,
                tol: spec.early_stop_tol,
            }),
        }
    }

    fn wants(&self, m: Metric) -> bool {
        self.metrics.contains(&m)
    }
}

/// Minimum stroboscopic samples the 0–1 test accepts.
const MIN_STROBE: u32 = crate::analysis::ZERO_ONE_MIN_SAMPLES as u32;

impl EnsemblePlan {
    /// Plan every instance of a map: validate its scene, choose its step and sampling.
    pub fn new(spec: &MapSpec) -> Result<EnsemblePlan> {
        let scenes: Vec<Scene> = (0..spec.instances())
            .into_par_iter()
            .map(|k| spec.instance_scene(k))
            .collect::<Result<_, _>>()?;
        EnsemblePlan::from_scenes(&scenes, &EnsembleOptions::from_spec(spec))
    }

    /// Plan an ensemble of arbitrary validated scenes (a grid, a list of designs × frequencies
    /// × initial states, ...). They must share the segment count, bumpers and piezo, and use
    /// harmonic excitation.
    pub fn from_scenes(scenes: &[Scene], opts: &EnsembleOptions) -> Result<EnsemblePlan> {
        let n_inst = scenes.len();
        if n_inst == 0 {
            bail!("an ensemble needs at least one instance");
        }
        if let Some(s) = scenes.iter().find(|s| {
            !matches!(
                s.excitation.kind,
                crate::config::ExcitationKind::Harmonic { .. }
            )
        }) {
            bail!(
                "ensembles need harmonic excitation, found {:?}",
                s.excitation.kind
            );
        }
        // The stability limit depends on the structure, not on the cart: solve it once per
        // distinct structure.
        let reference_excitation = scenes[0].excitation.clone();
        let key = |s: &Scene| {
            let mut s = s.clone();
            s.excitation = reference_excitation.clone();
            serde_json::to_string(&s).unwrap_or_default()
        };
        let mut unique: HashMap<String, usize> = HashMap::new();
        for (k, s) in scenes.iter().enumerate() {
            unique.entry(key(s)).or_insert(k);
        }
        let reps: Vec<(String, usize)> = unique.into_iter().collect();
        let limits: HashMap<String, (f64, f64)> = reps
            .par_iter()
            .map(|(kstr, k)| {
                let m = modes(&scenes[*k]);
                (kstr.clone(), (m.dt_auto_s, m.dt_stable_s))
            })
            .collect();
        let mut warnings = Vec::new();
        let first = &scenes[0];
        let instances: Vec<InstancePlan> = scenes
            .par_iter()
            .map(|s| plan_instance(opts, s, limits[&key(s)]))
            .collect::<Result<_>>()?;
        for s in scenes {
            if s.limiter.enabled != first.limiter.enabled
                || s.piezo.enabled != first.piezo.enabled
                || s.beam.segments != first.beam.segments
            {
                bail!(
                    "every instance of an ensemble must share beam.segments, limiter.enabled and piezo.enabled"
                );
            }
        }
        if let TimeStep::Seconds(dt) = first.integration.dt_s {
            let unstable = scenes.iter().filter(|s| dt > limits[&key(s)].1).count();
            if unstable > 0 {
                warnings.push(format!(
                    "integration.dt_s = {dt:e} s exceeds the RK4 stability limit of the linearised model for {unstable} of {n_inst} instances; those that blow up are flagged `diverged`"
                ));
            }
        }
        let early_stop = match opts.early_stop {
            Some(e) => {
                let blocking: Vec<&str> = opts
                    .metrics
                    .iter()
                    .filter(|m| !EARLY_STOP_METRICS.contains(m))
                    .map(|m| m.name())
                    .collect();
                if blocking.is_empty() {
                    Some(e)
                } else {
                    warnings.push(format!(
                        "map.early_stop ignored: metric(s) {} need the whole run (only K, period and alpha_range survive a periodic continuation)",
                        blocking.join(", ")
                    ));
                    None
                }
            }
            None => None,
        };
        let want_strobe = opts.wants(Metric::K)
            || opts.wants(Metric::Period)
            || opts.keep_strobe
            || early_stop.is_some();
        let want_rseries = opts.wants(Metric::R);
        let strobe_stride = instances.iter().map(|p| p.strobe_count).max().unwrap_or(0);
        let r_stride = instances.iter().map(|p| p.r_count).max().unwrap_or(0);
        let dts = instances.iter().map(|p| p.dt_s);
        let dt_range_s = (
            dts.clone().fold(f64::INFINITY, f64::min),
            dts.fold(0.0, f64::max),
        );
        let total_steps = instances.iter().map(InstancePlan::total_steps).sum();
        Ok(EnsemblePlan {
            segments: first.beam.segments,
            has_contact: first.limiter.enabled,
            has_piezo: first.piezo.enabled,
            metrics: opts.metrics.clone(),
            want_strobe,
            want_rseries,
            strobe_stride,
            r_stride,
            dt_range_s,
            total_steps,
            warnings,
            early_stop,
            instances,
        })
    }
}

fn plan_instance(
    spec: &EnsembleOptions,
    scene: &Scene,
    limits: (f64, f64),
) -> Result<InstancePlan> {
    let params = ModelParams::from_scene(scene);
    let f = scene.excitation.reference_frequency_hz();
    let period = 1.0 / f;
    let sp = u64::from(spec.samples_per_period);
    let blocks = match scene.integration.dt_s {
        TimeStep::Auto => (period / (sp as f64 * limits.0) - 1e-9).ceil().max(1.0),
        TimeStep::Seconds(dt) => (period / (sp as f64 * dt)).round().max(1.0),
    } as u64;
    let spp = sp * blocks;
    let total_periods = (scene.integration.duration_s * f).round().max(1.0) as u64;
    let transient_periods = ((scene.integration.transient_s * f).round() as u64).max(1);
    let at = format!(
        "f = {f} Hz, duration {} s, transient {} s",
        scene.integration.duration_s, scene.integration.transient_s
    );
    if transient_periods >= total_periods {
        bail!("{at}: the transient leaves no forcing period to analyse");
    }
    let total_steps = total_periods * spp;
    if total_steps > u64::from(u32::MAX) {
        bail!(
            "{at}: {total_steps} steps per instance exceed the engine's 32-bit step counter; shorten integration.duration_s or lengthen dt"
        );
    }
    let strobe_offset = ((spec.strobe_phase * spp as f64).round() as u64) % spp;
    let mut strobe_count = 0u64;
    while (transient_periods + strobe_count) * spp + strobe_offset <= total_steps {
        strobe_count += 1;
    }
    let needs_strobe = spec.wants(Metric::K) || spec.wants(Metric::Period);
    if needs_strobe && strobe_count < u64::from(MIN_STROBE) {
        bail!(
            "{at}: only {strobe_count} stroboscopic samples after the transient; K and period need at least {MIN_STROBE}: lengthen integration.duration_s"
        );
    }
    let r_every = blocks;
    let avail = (total_steps - transient_periods * spp) / r_every + 1;
    let mut r_count = 1u64 << (63 - avail.leading_zeros());
    r_count = r_count.min(u64::from(spec.r_max_samples));
    if spec.wants(Metric::R) && r_count < 32 {
        bail!("{at}: too short after the transient for R (needs 32 samples)");
    }
    let r_start = total_steps - (r_count - 1) * r_every;
    let y0 = params.initial_state(scene);
    let guard = Guard::for_params(&params);
    Ok(InstancePlan {
        frequency_hz: f,
        amplitude_m: scene.excitation.amplitude_m,
        spp: spp as u32,
        dt_s: period / spp as f64,
        transient_periods: transient_periods as u32,
        total_periods: total_periods as u32,
        strobe_offset: strobe_offset as u32,
        strobe_count: strobe_count as u32,
        r_every: r_every as u32,
        r_count: r_count as u32,
        r_start: r_start as u32,
        half_clearance_rad: 0.5 * scene.limiter.clearance_deg.to_radians(),
        params,
        y0,
        guard,
    })
}

/// What one instance's integration leaves behind: accumulators and the recorded series.
#[derive(Debug, Clone, PartialEq)]
pub struct RawInstance {
    /// Final status.
    pub status: Status,
    /// Steps taken.
    pub steps_done: u64,
    /// Smallest α after the transient (rad).
    pub alpha_min: f64,
    /// Largest α after the transient (rad).
    pub alpha_max: f64,
    /// Hops between wells after the transient.
    pub hops: u32,
    /// Bumper contact onsets after the transient.
    pub impacts: u32,
    /// Σ v²/R_L over the steps after the transient (W).
    pub power_sum: f64,
    /// Stroboscopic α after the transient (empty unless recorded).
    pub strobe: Vec<f64>,
    /// Uniform α series for R (empty unless recorded).
    pub r_alpha: Vec<f64>,
    /// Orbit period (forcing periods) at which the instance stopped early, if it did.
    pub stopped_early: Option<u32>,
}

/// Integrate one instance with RK4 in the float type `T`, as the GPU kernel does, over the
/// whole run.
pub fn run_instance<T: Real>(
    plan: &InstancePlan,
    want_strobe: bool,
    want_rseries: bool,
) -> RawInstance {
    run_instance_with::<T>(plan, want_strobe, want_rseries, None)
}

/// [`run_instance`], stopping early once a periodic orbit is confirmed when `early` is given.
pub fn run_instance_with<T: Real>(
    plan: &InstancePlan,
    want_strobe: bool,
    want_rseries: bool,
    early: Option<EarlyStop>,
) -> RawInstance {
    let chain: Chain<T> = Chain::new(&plan.params);
    let n = chain.segments();
    let dim = plan.y0.len();
    let mut ws = chain.workspace();
    let mut y: Vec<T> = plan.y0.iter().map(|&v| T::of(v)).collect();
    let mut k = [
        vec![T::zero(); dim],
        vec![T::zero(); dim],
        vec![T::zero(); dim],
        vec![T::zero(); dim],
    ];
    let mut tmp = vec![T::zero(); dim];
    let dt = T::of(plan.dt_s);
    let total = plan.total_steps();
    let transient = plan.transient_steps();
    let spp = u64::from(plan.spp);
    let inv_r = plan.params.piezo.as_ref().map_or(0.0, |z| 1.0 / z.load_ohm);
    let mut raw = RawInstance {
        status: Status::Ok,
        steps_done: 0,
        alpha_min: f64::INFINITY,
        alpha_max: f64::NEG_INFINITY,
        hops: 0,
        impacts: 0,
        power_sum: 0.0,
        strobe: if want_strobe {
            vec![f64::NAN; plan.strobe_count as usize]
        } else {
            Vec::new()
        },
        r_alpha: if want_rseries {
            vec![f64::NAN; plan.r_count as usize]
        } else {
            Vec::new()
        },
        stopped_early: None,
    };
    // States at the last p_max + 1 stroboscopic samples (ring), for early termination.
    let ring_len = early.map_or(0, |e| e.p_max as usize + 1);
    let mut ring: Vec<Vec<T>> = vec![Vec::new(); ring_len];
    let mut touch = chain.touching(&mut ws, &y);
    let mut well = 0i32;
    let mut s = 0u64;
    while s < total {
        let ph = s % spp;
        let a0 = T::of(plan.cart_acc(ph, 0.0));
        let am = T::of(plan.cart_acc(ph, 0.5));
        let a1 = T::of(plan.cart_acc(ph, 1.0));
        crate::integrate::rk4::rk4_step(
            &chain,
            &mut ws,
            &mut y,
            &mut k,
            &mut tmp,
            dt,
            [a0, am, a1],
        );
        s += 1;
        let alpha = y[0].wide();
        let now = chain.touching(&mut ws, &y);
        if s > transient {
            raw.impacts += u32::from(now.0 && !touch.0) + u32::from(now.1 && !touch.1);
            raw.alpha_min = raw.alpha_min.min(alpha);
            raw.alpha_max = raw.alpha_max.max(alpha);
            let w = if alpha > plan.half_clearance_rad {
                1
            } else if alpha < -plan.half_clearance_rad {
                -1
            } else {
                0
            };
            if w != 0 {
                if well != 0 && well != w {
                    raw.hops += 1;
                }
                well = w;
            }
            if plan.params.piezo.is_some() {
                let v = y[2 * n].wide();
                raw.power_sum += v * v * inv_r;
            }
        }
        touch = now;
        if want_strobe && s >= transient && s % spp == u64::from(plan.strobe_offset) {
            let idx = (s - u64::from(plan.strobe_offset)) / spp - u64::from(plan.transient_periods);
            if let Some(slot) = raw.strobe.get_mut(idx as usize) {
                *slot = alpha;
            }
            if let Some(e) = early {
                let k = idx as usize;
                ring[k % ring_len].clone_from(&y);
                if let Some(p) = confirmed_period(&raw.strobe, &ring, k, &e) {
                    for j in k + 1..raw.strobe.len() {
                        raw.strobe[j] = raw.strobe[j - p];
                    }
                    raw.stopped_early = Some(p as u32);
                    break;
                }
            }
        }
        let r_start = u64::from(plan.r_start);
        if want_rseries && s >= r_start && (s - r_start).is_multiple_of(u64::from(plan.r_every)) {
            let j = (s - r_start) / u64::from(plan.r_every);
            if let Some(slot) = raw.r_alpha.get_mut(j as usize) {
                *slot = alpha;
            }
        }
        if s.is_multiple_of(CHECK_EVERY) || s == total {
            let status = health(&chain, &plan.guard, &y, plan.cart_vel(s));
            if status != Status::Ok {
                raw.status = status;
                break;
            }
        }
    }
    raw.steps_done = s;
    raw
}

/// The smallest p ≤ p_max for which the stroboscopic samples up to `k` and the full state at
/// sample `k` repeat with period p (see [`EarlyStop`]).
fn confirmed_period<T: Real>(
    strobe: &[f64],
    ring: &[Vec<T>],
    k: usize,
    e: &EarlyStop,
) -> Option<usize> {
    let w = e.window as usize;
    let close = |a: f64, b: f64| (a - b).abs() <= e.tol * a.abs().max(1.0);
    (1..=e.p_max as usize).find(|&p| {
        k + 1 >= w + p && (k + 1 - w..=k).all(|j| close(strobe[j], strobe[j - p])) && {
            let (now, then) = (&ring[k % ring.len()], &ring[(k - p) % ring.len()]);
            then.len() == now.len() && now.iter().zip(then).all(|(a, b)| close(a.wide(), b.wide()))
        }
    })
}

/// The health check of [`crate::integrate::health`], with the cart velocity given.
fn health<T: Real>(chain: &Chain<T>, guard: &Guard, y: &[T], cart_v: f64) -> Status {
    if y.iter().any(|v| !v.is_finite()) {
        return Status::NonFinite;
    }
    let n = chain.segments();
    if y[0].abs().wide() > guard.max_holder_angle_rad {
        return Status::Escaped;
    }
    if (1..n).any(|i| (y[i] - y[i - 1]).abs().wide() > guard.max_joint_bend_rad) {
        return Status::Diverged;
    }
    let e = chain.energy(y, 0.0, cart_v).total_j();
    if !e.is_finite() || e.abs() > guard.max_energy_j {
        return Status::Diverged;
    }
    Status::Ok
}

/// Integrate every instance on the CPU (rayon); `progress` is called with the number of
/// instances finished so far.
pub fn run_cpu<T: Real>(plan: &EnsemblePlan, progress: &(dyn Fn(u64) + Sync)) -> Vec<RawInstance> {
    let done = AtomicU64::new(0);
    plan.instances
        .par_iter()
        .map(|p| {
            let r = run_instance_with::<T>(p, plan.want_strobe, plan.want_rseries, plan.early_stop);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            r
        })
        .collect()
}

//! The plan of an ensemble: one independent instance per grid point (or design, case, …), each
//! with its own step and sampling, integrated by either engine.
//!
//! Every instance's step divides its forcing period exactly: `spp` steps per period, a multiple
//! of `samples_per_period`. The forcing phase is `(step mod spp)/spp`, exact in integer
//! arithmetic on both engines, and stroboscopic samples fall on steps.
//!
//! While integrating, each instance keeps running accumulators over the steps after the
//! transient (α range, hops, impacts, harvested power) and records only the series its metrics
//! need: the stroboscopic α (K, period, bifurcation) and a power-of-two uniform α series at
//! `samples_per_period` per period (R). Trajectories are never stored.

use crate::config::{GpuKernelChoice, StepControl};
use crate::config::{
    LyapunovSettings, MapSpec, MethodChoice, Metric, Perturbation, Scene, TimeStep,
};
use crate::engine::early_rule::EarlyStop;
use crate::engine::error::EngineError;
use crate::engine::imex::ImexMatrices;
use crate::engine::method::{Method, MethodSteps};
use crate::engine::step_plan::given_step_warning;
use crate::engine::{Precision, Progress, ProgressUnit, no_progress};
use crate::model::linear::LinearError;
use crate::model::{CartState, ChainShape, ExcitationKind, Guard, ModelParams};
use crate::reduce::TwinPlan;
use crate::reduce::lyapunov::TwinNorm;
use crate::reduce::lyapunov::{LYAPUNOV_MAX_WINDOW, LYAPUNOV_MIN_WINDOW};
use crate::schema::Source;
use crate::text::num;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::sync::Arc;

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
    /// The ensemble's method.
    pub method: Method,
    /// The IMEX method's matrices for this structure and step (shared between instances;
    /// fixed steps only).
    #[serde(skip)]
    pub imex: Option<Arc<ImexMatrices>>,
    /// The twin of λ1, when λ1 is asked for.
    pub twin: Option<TwinPlan>,
    /// Fixed steps, or error-controlled ones within each step `dt_s` (the ladder's base step,
    /// [`crate::engine::adaptive`]; the CPU engine's scalar loop).
    pub control: StepControl,
}

impl InstancePlan {
    /// This run from the end of its period `periods` on, to be started from the state it
    /// had there (the map's settling stage continues a cell so): the same steps, strobe
    /// instants, R series, twin and early stop as the whole run, counted from that period.
    /// `None` where period `periods` lies after the transient (the window would be cut).
    pub fn continued_after(&self, periods: u32) -> Option<InstancePlan> {
        if periods > self.transient_periods {
            return None;
        }
        let shift = u64::from(periods) * u64::from(self.spp);
        let r_start = u32::try_from(u64::from(self.r_start).checked_sub(shift)?).ok()?;
        Some(InstancePlan {
            total_periods: self.total_periods - periods,
            transient_periods: self.transient_periods - periods,
            r_start,
            ..self.clone()
        })
    }

    /// Total steps.
    pub fn total_steps(&self) -> u64 {
        u64::from(self.total_periods) * u64::from(self.spp)
    }

    /// Steps of the transient.
    pub(crate) fn transient_steps(&self) -> u64 {
        u64::from(self.transient_periods) * u64::from(self.spp)
    }

    /// Time after the transient (s).
    pub(crate) fn post_transient_s(&self) -> f64 {
        f64::from(self.total_periods - self.transient_periods) / self.frequency_hz
    }

    /// The cart at `(step mod spp + frac)/spp` of a forcing period (exact phase).
    #[inline]
    pub(crate) fn cart_at(&self, step: u64, frac: f64) -> CartState {
        let phase_steps = step % u64::from(self.spp);
        let cycles = (phase_steps as f64 + frac) / f64::from(self.spp);
        self.params.cart.at_phase(cycles)
    }

    /// What the IMEX matrices of this instance depend on: its structure and its (base) step.
    /// Instances with equal keys share one set (and, with adaptive steps, one ladder).
    pub(crate) fn imex_key(&self) -> Vec<u64> {
        let mut bits = self.params.structure_bits();
        bits.push(self.dt_s.to_bits());
        bits
    }

    /// The cart positions at the R samples: the reference signal of R.
    pub fn cart_series(&self) -> Vec<f64> {
        (0..u64::from(self.r_count))
            .map(|j| {
                let step = u64::from(self.r_start) + j * u64::from(self.r_every);
                self.cart_at(step, 0.0).x_m
            })
            .collect()
    }
}

/// Every instance of an ensemble with the settings shared by all.
#[derive(Debug, Clone, Serialize)]
pub struct EnsemblePlan {
    /// The instances, in the caller's order (a map's grid order: last axis fastest).
    #[serde(skip)]
    pub instances: Vec<InstancePlan>,
    /// Integration method (shared).
    pub method: Method,
    /// Why that method.
    pub method_reason: String,
    /// Distinct IMEX matrix sets (structure × step) the instances share.
    pub imex_matrix_sets: usize,
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
    /// The twins' separation d0, when λ1 is asked for (resolved per float type by the engine:
    /// [`EnsemblePlan::twin_separation`]).
    pub perturbation: Option<Perturbation>,
    /// The GPU's integration kernel (`gpu.kernel`; the CPU engine has none).
    pub gpu_kernel: GpuKernelChoice,
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
    /// Stop an instance once its periodic orbit is confirmed, its indicators continued
    /// ([`EarlyStop`]).
    pub early_stop: Option<EarlyStop>,
    /// How λ1's twin runs (used when [`Metric::Lyapunov`] is asked for).
    pub lyapunov: LyapunovSettings,
    /// The GPU's integration kernel (`gpu.kernel`; the CPU engine has none).
    pub gpu_kernel: GpuKernelChoice,
}

impl EnsembleOptions {
    /// The options of a map scene.
    pub fn from_spec(spec: &MapSpec) -> EnsembleOptions {
        EnsembleOptions {
            metrics: spec.metrics.clone(),
            // A continuation compares the cells' attractors by their stroboscopic tails.
            keep_strobe: spec.bifurcation
                || matches!(spec.mode, crate::config::MapMode::Continuation(_)),
            samples_per_period: spec.samples_per_period,
            strobe_phase: spec.strobe_phase,
            r_max_samples: spec.r_max_samples,
            early_stop: spec.early_stop.then_some(EarlyStop {
                p_max: spec.period_max,
                window: spec.period_window,
                tol: spec.early_stop_tol,
            }),
            lyapunov: spec.lyapunov,
            gpu_kernel: spec.gpu_kernel,
        }
    }

    fn wants(&self, m: Metric) -> bool {
        self.metrics.contains(&m)
    }

    /// Whether a metric asked for is recorded from `source` (the result schema's
    /// [`Metric::source`]).
    fn records(&self, source: Source) -> bool {
        Metric::any_from(&self.metrics, source)
    }
}

/// Minimum stroboscopic samples the 0–1 test accepts.
const MIN_STROBE_K: u32 = crate::analysis::ZERO_ONE_MIN_SAMPLES as u32;

/// Minimum stroboscopic samples of the period test alone (its default window of 16 samples
/// and a few periods to compare with).
const MIN_STROBE_PERIOD: u32 = 20;

impl EnsemblePlan {
    /// Plan every instance of a map: validate its scene, choose its step and sampling.
    pub fn new(spec: &MapSpec) -> Result<EnsemblePlan, EngineError> {
        EnsemblePlan::new_with(spec, &no_progress)
    }

    /// [`EnsemblePlan::new`], reporting the runs planned to `progress` (unit
    /// [`ProgressUnit::Planned`]) every few thousand runs; a `Break` stops the planning with
    /// [`EngineError::Cancelled`] (Ctrl-C while a huge map is planned).
    pub fn new_with(spec: &MapSpec, progress: Progress) -> Result<EnsemblePlan, EngineError> {
        let total = (spec.instances() * spec.starts_per_cell()) as u64;
        let go_on = |run: u64| progress(run, total, ProgressUnit::Planned).is_continue();
        let scenes = spec
            .run_scenes_while(&go_on)?
            .ok_or(EngineError::Cancelled)?;
        if !go_on(total) {
            return Err(EngineError::Cancelled);
        }
        EnsemblePlan::from_scenes(&scenes, &EnsembleOptions::from_spec(spec))
    }

    /// Plan an ensemble of arbitrary validated scenes (a grid, a list of designs × frequencies
    /// × initial states, ...). They must share the segment count, bumpers and piezo, and use
    /// harmonic excitation.
    pub fn from_scenes(
        scenes: &[Scene],
        opts: &EnsembleOptions,
    ) -> Result<EnsemblePlan, EngineError> {
        let first = scenes.first().ok_or(EngineError::Empty)?;
        check_shared_structure(scenes)?;
        let seed = Solved::seeded(first)?;
        let limits: Vec<MethodSteps> = scenes
            .par_iter()
            .map_init(|| seed.clone(), |solved, s| solved.steps(s))
            .collect::<Result<_, LinearError>>()?;
        let (method, method_reason) = ensemble_method(scenes, &limits);
        let mut instances: Vec<InstancePlan> = scenes
            .par_iter()
            .zip(&limits)
            .map_init(
                || seed.clone(),
                |solved, (s, lim)| {
                    plan_instance(opts, s, solved.params(s)?, (method, lim.auto_s(method)))
                },
            )
            .collect::<Result<_, EngineError>>()?;
        let fixed = first.integration.step == StepControl::Fixed;
        let imex_matrix_sets = if method == Method::Imex && fixed {
            attach_imex_matrices(&mut instances)
        } else {
            0
        };
        let mut warnings = Vec::new();
        if let TimeStep::Seconds(dt) = first.integration.dt_s {
            let beyond = limits
                .iter()
                .filter(|l| given_step_warning(method, dt, l).is_some())
                .count();
            if beyond > 0 {
                warnings.push(format!(
                    "integration.dt_s = {dt:e} s exceeds the {} method's limit for {beyond} of {} instances; those that blow up are flagged `diverged`",
                    method.name(),
                    scenes.len()
                ));
            }
        }
        // The verdict reads a K from fewer samples as not firm and decides by λ1 and the
        // period (`reduce::regime`): a short K misleads only a map that shows K without it.
        if opts.wants(Metric::K) && !opts.wants(Metric::Regime) {
            warnings.extend(short_k_warning(&instances));
        }
        let early_stop = opts.early_stop;
        let mut plan = EnsemblePlan::assemble(first, opts, instances, warnings, early_stop);
        plan.method = method;
        plan.method_reason = method_reason;
        plan.imex_matrix_sets = imex_matrix_sets;
        Ok(plan)
    }

    /// Whether the instances take adaptive steps (a plan's instances share their step control).
    pub fn is_adaptive(&self) -> bool {
        self.instances
            .first()
            .is_some_and(|p| p.control != StepControl::Fixed)
    }

    /// The chain's shape the GPU kernels are generated for: every instance must share the
    /// bumpers' law and the piezo's span; contact heights may differ, and the kernel takes the
    /// most levers any instance has (the `levers` buffer holds zeros past each instance's
    /// contact segment, which add exact zeros).
    pub fn kernel_shape(&self) -> Result<ChainShape, EngineError> {
        let shapes: Vec<ChainShape> = self
            .instances
            .iter()
            .map(|p| ChainShape::of(&p.params))
            .collect();
        let first = *shapes.first().ok_or(EngineError::Empty)?;
        if let Some(index) = shapes
            .iter()
            .position(|s| s.every_lever() != first.every_lever())
        {
            return Err(EngineError::MixedKernelShape { index });
        }
        let levers = shapes.iter().filter_map(|s| s.contact).map(|c| c.0).max();
        Ok(ChainShape {
            contact: first.contact.zip(levers).map(|((_, law), n)| (n, law)),
            ..first
        })
    }

    /// The twins' separation d0 for an engine in `precision` (`None` without λ1): the given
    /// one, or the measured default of the float type ([`crate::reduce::lyapunov`]); refused
    /// when smaller than the float type resolves.
    pub fn twin_separation(&self, precision: Precision) -> Result<Option<f64>, EngineError> {
        use crate::reduce::lyapunov::{
            SEPARATION_F32, SEPARATION_F32_MIN, SEPARATION_F64, SEPARATION_F64_MIN,
        };
        let (auto, min) = match precision {
            Precision::F32 => (SEPARATION_F32, SEPARATION_F32_MIN),
            Precision::F64 => (SEPARATION_F64, SEPARATION_F64_MIN),
        };
        match self.perturbation {
            None => Ok(None),
            Some(Perturbation::Auto) => Ok(Some(auto)),
            Some(Perturbation::Given(d0)) if d0 >= min => Ok(Some(d0)),
            Some(Perturbation::Given(given)) => Err(EngineError::TwinSeparation {
                given,
                precision: precision.name(),
                min,
                auto,
            }),
        }
    }

    /// The sub-ensemble of the instances at `members` (indices into this plan, in order), with
    /// this plan's method, metrics and warnings: a shard integrates exactly what the whole
    /// ensemble would for those instances.
    pub fn select(&self, members: &[usize]) -> EnsemblePlan {
        let instances: Vec<InstancePlan> =
            members.iter().map(|&i| self.instances[i].clone()).collect();
        let dts = instances.iter().map(|p| p.dt_s);
        EnsemblePlan {
            strobe_stride: instances.iter().map(|p| p.strobe_count).max().unwrap_or(0),
            r_stride: instances.iter().map(|p| p.r_count).max().unwrap_or(0),
            dt_range_s: (
                dts.clone().fold(f64::INFINITY, f64::min),
                dts.fold(0.0, f64::max),
            ),
            total_steps: instances.iter().map(InstancePlan::total_steps).sum(),
            instances,
            method_reason: self.method_reason.clone(),
            metrics: self.metrics.clone(),
            warnings: self.warnings.clone(),
            ..*self
        }
    }

    fn assemble(
        first: &Scene,
        opts: &EnsembleOptions,
        instances: Vec<InstancePlan>,
        warnings: Vec<String>,
        early_stop: Option<EarlyStop>,
    ) -> EnsemblePlan {
        let want_strobe = opts.records(Source::Strobe) || opts.keep_strobe;
        let dts = instances.iter().map(|p| p.dt_s);
        let dt_range_s = (
            dts.clone().fold(f64::INFINITY, f64::min),
            dts.fold(0.0, f64::max),
        );
        EnsemblePlan {
            method: Method::Rk4,
            method_reason: String::new(),
            imex_matrix_sets: 0,
            segments: first.beam.segments,
            has_contact: first.limiter.enabled,
            has_piezo: first.piezo.enabled,
            metrics: opts.metrics.clone(),
            want_strobe,
            want_rseries: opts.records(Source::RSeries),
            strobe_stride: instances.iter().map(|p| p.strobe_count).max().unwrap_or(0),
            r_stride: instances.iter().map(|p| p.r_count).max().unwrap_or(0),
            dt_range_s,
            total_steps: instances.iter().map(InstancePlan::total_steps).sum(),
            warnings,
            early_stop,
            perturbation: opts
                .records(Source::Twin)
                .then_some(opts.lyapunov.perturbation),
            gpu_kernel: opts.gpu_kernel,
            instances,
        }
    }
}

/// Harmonic excitation, and one segment count, bumper and piezo setting for all.
fn check_shared_structure(scenes: &[Scene]) -> Result<(), EngineError> {
    let first = &scenes[0];
    for (index, s) in scenes.iter().enumerate() {
        if let ExcitationKind::Sweep { .. } = s.excitation.kind {
            return Err(EngineError::NotHarmonic("sweep"));
        }
        if s.limiter.enabled != first.limiter.enabled
            || s.piezo.enabled != first.piezo.enabled
            || s.beam.segments != first.beam.segments
            || std::mem::discriminant(&s.integration.step)
                != std::mem::discriminant(&first.integration.step)
        {
            return Err(EngineError::MixedStructure { index });
        }
    }
    Ok(())
}

/// The model coefficients and both methods' automatic steps of the last few distinct
/// structures solved. Neither depends on the cart ([`Scene::same_structure`]), so a scene
/// that shares its structure (and step safety factor) with one already solved takes that
/// one's coefficients with its own cart: a map over the forcing plane solves its eigenproblems
/// once, not once per cell.
#[derive(Clone)]
struct Solved<'a> {
    reps: Vec<(&'a Scene, ModelParams, MethodSteps)>,
}

impl<'a> Solved<'a> {
    /// Structures remembered (the oldest is forgotten first).
    const REMEMBERED: usize = 16;

    /// Remembering `first`'s structure.
    fn seeded(first: &'a Scene) -> Result<Solved<'a>, LinearError> {
        let mut solved = Solved { reps: Vec::new() };
        solved.solve(first)?;
        Ok(solved)
    }

    /// The coefficients of `s`.
    fn params(&mut self, s: &'a Scene) -> Result<ModelParams, LinearError> {
        let (p, _) = self.solve(s)?;
        Ok(p.with_cart(s.cart_motion()))
    }

    /// The automatic steps of `s`.
    fn steps(&mut self, s: &'a Scene) -> Result<MethodSteps, LinearError> {
        Ok(self.solve(s)?.1)
    }

    /// The coefficients (with the cart of the scene that was solved) and steps of `s`'s
    /// structure, solved now if it is not remembered.
    fn solve(&mut self, s: &'a Scene) -> Result<(&ModelParams, MethodSteps), LinearError> {
        let same = |(rep, _, _): &(&Scene, ModelParams, MethodSteps)| {
            rep.same_structure(s) && rep.integration.dt_safety == s.integration.dt_safety
        };
        let at = match self.reps.iter().position(same) {
            Some(at) => at,
            None => {
                let p = s.model_params()?;
                let steps = MethodSteps::of(&p, s.integration.dt_safety)?;
                if self.reps.len() == Self::REMEMBERED {
                    self.reps.remove(0);
                }
                self.reps.push((s, p, steps));
                self.reps.len() - 1
            }
        };
        let (_, p, steps) = &self.reps[at];
        Ok((p, *steps))
    }
}

/// The warning when some instances give the 0–1 test fewer samples than it needs to be reliable
/// (long-period orbits can then read as chaotic), for a map without the verdict.
fn short_k_warning(instances: &[InstancePlan]) -> Option<String> {
    let comfortable = crate::analysis::ZERO_ONE_COMFORTABLE_SAMPLES as u32;
    let short: Vec<u32> = instances
        .iter()
        .map(|p| p.strobe_count)
        .filter(|&n| n < comfortable)
        .collect();
    let fewest = short.iter().min()?;
    Some(format!(
        "K of {} of {} instances comes from fewer than {comfortable} stroboscopic samples (fewest {fewest}): orbits of long period may read as chaotic; lengthen integration.duration_s for a firmer K",
        short.len(),
        instances.len()
    ))
}

/// One method for the whole ensemble (the kernels are specialised on it): the one every scene
/// names, or, with `auto`, the one with the smaller total cost over the instances (or, with a
/// given step, IMEX as soon as it is beyond RK4's stable limit for some instance).
fn ensemble_method(scenes: &[Scene], limits: &[MethodSteps]) -> (Method, String) {
    let (method, reason) = fixed_step_method(scenes, limits);
    match scenes[0].integration.step {
        StepControl::Fixed => (method, reason),
        StepControl::Adaptive { .. } => (method, format!("{reason}; {}", method.adaptive_reason())),
    }
}

/// [`ensemble_method`] at fixed steps (adaptive steps choose the same way, a given step
/// aside: it is unused there).
fn fixed_step_method(scenes: &[Scene], limits: &[MethodSteps]) -> (Method, String) {
    // Every scene of an ensemble comes from one base scene: its choice applies.
    let choice = scenes[0].integration.method;
    let dt = match scenes[0].integration.step {
        StepControl::Fixed => scenes[0].integration.dt_s,
        StepControl::Adaptive { .. } => TimeStep::Auto,
    };
    match (choice, dt) {
        (MethodChoice::Rk4, _) => (Method::Rk4, "integration.method = \"rk4\"".into()),
        (MethodChoice::Imex, _) => (Method::Imex, "integration.method = \"imex\"".into()),
        (MethodChoice::Auto, TimeStep::Seconds(dt)) => {
            if limits.iter().any(|l| dt > l.rk4_stable_s) {
                (
                    Method::Imex,
                    format!("auto: the given step {dt:e} s is beyond RK4's stable limit"),
                )
            } else {
                (
                    Method::Rk4,
                    "auto: the given step is within RK4's stable limit".into(),
                )
            }
        }
        (MethodChoice::Auto, TimeStep::Auto) => {
            let cost = |m: Method| -> f64 {
                scenes
                    .iter()
                    .zip(limits)
                    .map(|(s, l)| l.cost_per_s(m) * s.integration.duration_s)
                    .sum()
            };
            let (rk4, imex) = (cost(Method::Rk4), cost(Method::Imex));
            let m = if imex < rk4 {
                Method::Imex
            } else {
                Method::Rk4
            };
            (
                m,
                format!(
                    "auto: {} is {:.1}x cheaper for these instances at the automatic steps",
                    m.name(),
                    rk4.max(imex) / rk4.min(imex)
                ),
            )
        }
    }
}

/// Build the IMEX matrices once per distinct structure and step and hand every instance its
/// set; returns the number of distinct sets.
fn attach_imex_matrices(instances: &mut [InstancePlan]) -> usize {
    let key = InstancePlan::imex_key;
    let mut first_of: HashMap<Vec<u64>, usize> = HashMap::new();
    for (k, p) in instances.iter().enumerate() {
        first_of.entry(key(p)).or_insert(k);
    }
    let built: HashMap<Vec<u64>, Arc<ImexMatrices>> = first_of
        .par_iter()
        .map(|(bits, &k)| {
            let p = &instances[k];
            (bits.clone(), Arc::new(ImexMatrices::new(&p.params, p.dt_s)))
        })
        .collect();
    for p in instances.iter_mut() {
        p.imex = Some(built[&key(p)].clone());
    }
    built.len()
}

/// Steps per forcing period: a multiple of `samples_per_period` whose step is at most the
/// method's automatic step `dt_auto_s` (or the given step): the step is only ever shortened.
/// With adaptive steps, the base step is at most the given `integration.base_step_s`, else
/// [`ADAPTIVE_BASE_MAX_S`] for IMEX and RK4's automatic step for the explicit pair.
fn steps_per_period(
    opts: &EnsembleOptions,
    scene: &Scene,
    period_s: f64,
    (method, dt_auto_s): (Method, f64),
) -> u64 {
    let sp = u64::from(opts.samples_per_period);
    let i = &scene.integration;
    let dt = match (i.step, i.dt_s, i.base_step_s) {
        (StepControl::Adaptive { .. }, _, TimeStep::Seconds(base)) => base,
        (StepControl::Adaptive { .. }, _, TimeStep::Auto) if method == Method::Rk4 => {
            dt_auto_s.min(ADAPTIVE_BASE_MAX_S)
        }
        (StepControl::Adaptive { .. }, _, TimeStep::Auto) => ADAPTIVE_BASE_MAX_S,
        (StepControl::Fixed, TimeStep::Auto, _) => dt_auto_s,
        (StepControl::Fixed, TimeStep::Seconds(dt), _) => dt,
    };
    let blocks = (period_s / (sp as f64 * dt) - 1e-9).ceil().max(1.0) as u64;
    sp * blocks
}

/// The longest base step of adaptive steps in an ensemble (s): the hook's per-step tallies
/// (hops, α range, power) and λ1's renormalisations see the state this often at least.
pub(crate) const ADAPTIVE_BASE_MAX_S: f64 = 1e-3;

fn plan_instance(
    opts: &EnsembleOptions,
    scene: &Scene,
    params: ModelParams,
    (method, dt_auto_s): (Method, f64),
) -> Result<InstancePlan, EngineError> {
    let f = scene.excitation.reference_frequency_hz();
    let period = 1.0 / f;
    let spp = steps_per_period(opts, scene, period, (method, dt_auto_s));
    let blocks = spp / u64::from(opts.samples_per_period);
    let total_periods = (scene.integration.duration_s * f).round().max(1.0) as u64;
    let transient_periods = ((scene.integration.transient_s * f).round() as u64).max(1);
    let at = || {
        format!(
            "f = {} Hz, duration {} s, transient {} s",
            num(f),
            num(scene.integration.duration_s),
            num(scene.integration.transient_s)
        )
    };
    let short = |reason: String| EngineError::TooShort { at: at(), reason };
    if transient_periods >= total_periods {
        return Err(short(
            "the transient leaves no forcing period to analyse".into(),
        ));
    }
    let total_steps = total_periods.saturating_mul(spp);
    if total_steps > u64::from(u32::MAX) {
        return Err(EngineError::TooManySteps {
            at: at(),
            steps: total_steps,
        });
    }
    let strobe_offset = ((opts.strobe_phase * spp as f64).round() as u64) % spp;
    // Samples at steps (transient_periods + c)·spp + strobe_offset ≤ total_steps, c = 0, 1, …
    let first_strobe = transient_periods * spp + strobe_offset;
    let strobe_count = match total_steps.checked_sub(first_strobe) {
        Some(room) => room / spp + 1,
        None => 0,
    };
    let (need, what) = if opts.wants(Metric::K) {
        (MIN_STROBE_K, "the 0-1 test (K) needs")
    } else if opts.wants(Metric::Period) {
        (MIN_STROBE_PERIOD, "the period test needs")
    } else {
        (0, "")
    };
    if strobe_count < u64::from(need) {
        let more_s = f64::from(need) / f - (total_periods - transient_periods) as f64 / f;
        return Err(short(format!(
            "only {strobe_count} stroboscopic samples after the transient; {what} at least {need}: lengthen integration.duration_s by {:.1} s (or shorten the transient)",
            more_s.max(0.0)
        )));
    }
    let r_every = blocks;
    let avail = (total_steps - transient_periods * spp) / r_every + 1;
    let r_count = (1u64 << (63 - avail.leading_zeros())).min(u64::from(opts.r_max_samples));
    if opts.records(Source::RSeries) && r_count < 32 {
        return Err(short(format!(
            "too short after the transient for R and the dominant line (they need 32 samples at {} per forcing period)",
            opts.samples_per_period
        )));
    }
    let r_start = total_steps - (r_count - 1) * r_every;
    let twin = if opts.records(Source::Twin) {
        Some(twin_plan(&opts.lyapunov, scene, &params, strobe_count as u32).map_err(short)?)
    } else {
        None
    };
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
        y0: scene.initial_state(&params),
        guard: Guard::for_params(&params),
        params,
        method,
        imex: None,
        twin,
        control: scene.integration.step,
    })
}

/// Why λ1's window of `window` forcing periods does not fit a run with `room` periods left
/// after the transient and the alignment, and the change that makes it fit: a longer run
/// when even the shortest window does not fit, a window within the room when the asked one
/// is too long, a longer window when it is below [`LYAPUNOV_MIN_WINDOW`].
fn window_refusal(
    s: &LyapunovSettings,
    window: u32,
    room: u32,
    strobe_count: u32,
    f: f64,
) -> String {
    let align = s.align_periods;
    let asked = match s.window_s {
        Some(w) => format!("map.lyapunov_window_s = {w} s gives {window} forcing periods"),
        None => format!("{room} forcing periods are left for its window"),
    };
    let lengthen = |periods: u32| {
        let need = periods + align + 1;
        format!(
            "lengthen integration.duration_s by {:.2} s (or shorten the transient)",
            f64::from(need.saturating_sub(strobe_count)) / f
        )
    };
    let fix = if room < LYAPUNOV_MIN_WINDOW {
        lengthen(window.max(LYAPUNOV_MIN_WINDOW))
    } else if window > room {
        format!(
            "ask for a window of at most {room} periods ({:.2} s), or {}",
            f64::from(room) / f,
            lengthen(window)
        )
    } else {
        format!(
            "ask for a window of at least {LYAPUNOV_MIN_WINDOW} periods ({:.2} s)",
            f64::from(LYAPUNOV_MIN_WINDOW) / f
        )
    };
    format!(
        "lambda1 needs at least {LYAPUNOV_MIN_WINDOW} renormalisations (forcing periods) in its window after {align} to align (map.lyapunov_align_periods): {asked}, and the run has {strobe_count} stroboscopic samples after the transient; {fix}"
    )
}

/// The twin of λ1 of an instance with `strobe_count` stroboscopic samples after the transient:
/// it ends at the last one, after `align` renormalisations and a window of `window_s` (or of
/// every remaining forcing period); refused, with the duration to add, when the run is too
/// short for [`LYAPUNOV_MIN_WINDOW`] renormalisations in the window.
fn twin_plan(
    s: &LyapunovSettings,
    scene: &Scene,
    params: &ModelParams,
    strobe_count: u32,
) -> Result<TwinPlan, String> {
    let f = scene.excitation.reference_frequency_hz();
    let align = s.align_periods;
    let room = strobe_count.saturating_sub(1 + align);
    let window = match s.window_s {
        Some(w) => (w * f).round().max(1.0) as u32,
        None => room,
    };
    if window < LYAPUNOV_MIN_WINDOW || window > room {
        return Err(window_refusal(s, window, room, strobe_count, f));
    }
    if window > LYAPUNOV_MAX_WINDOW {
        return Err(format!(
            "lambda1 averages at most {LYAPUNOV_MAX_WINDOW} renormalisations (forcing periods), and its window has {window}: set map.lyapunov_window_s to at most {:.0} s",
            f64::from(LYAPUNOV_MAX_WINDOW) / f
        ));
    }
    Ok(TwinPlan {
        start_sample: strobe_count - 1 - align - window,
        align,
        window,
        norm: TwinNorm::of(params, std::f64::consts::TAU * f),
        period_s: 1.0 / f,
    })
}

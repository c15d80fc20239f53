//! The search itself: the linear baseline, the grid of designs, the refinement around the
//! best, and the ranking, every stage one batch of instances on the ensemble engine.
//!
//! A batch holds every (design, initial state, frequency) of its stage as one instance of
//! one [`EnsemblePlan`] (designs × states × frequencies in that order), so the GPU engine sees
//! thousands of independent instances at once and the CPU engine spreads them over its
//! threads. The baseline runs as its own batch: it has no bumpers, and every instance of an
//! ensemble shares `limiter.enabled`.
//!
//! Refinement is a batched multi-start compass (pattern) search: each round takes the best
//! `refine.top` designs so far and evaluates their neighbours one step along each variable,
//! in both directions, the step shrinking each round. All candidates of a round go into one
//! batch, which a one-point-at-a-time optimiser (Nelder–Mead and the like) could not do.

use super::band::{BandMetrics, band_metrics, mean_curve, robust_curve};
use super::error::HarvestError;
use super::spec::{InitialState, Objective, SearchSpec, Weighting, describe_design};
use pendulum_atlas_core::config::{ConfigError, Metric, Scene, neighbours, point_key};
use pendulum_atlas_core::engine::{
    Engine, EngineInfo, EnsembleOptions, EnsemblePlan, ProgressUnit,
};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions};
use pendulum_atlas_map::map::run_plan;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashSet;
use std::time::Instant;

/// Progress callbacks: `(stage, done, total)`.
pub type SearchProgress<'a> = &'a (dyn Fn(&str, u64, u64) + Sync);

/// One evaluated design: its P(f) from every initial state and its band metrics.
#[derive(Debug, Clone, Serialize)]
pub struct DesignResult {
    /// Index in evaluation order (the row of designs.csv).
    pub id: usize,
    /// Where it came from: `grid` or `refine N`.
    pub stage: String,
    /// Values of the design variables, in the scene's order.
    pub values: Vec<f64>,
    /// Mean harvested power per initial state and band frequency (W), `[state][frequency]`.
    pub power_w: Vec<Vec<f64>>,
    /// Hops between the wells per initial state and frequency (after the transient).
    pub hops: Vec<Vec<f64>>,
    /// Bumper impacts per second per initial state and frequency.
    pub impacts_per_s: Vec<Vec<f64>>,
    /// Period of the stroboscopic section in forcing periods per initial state and frequency
    /// (0: none up to 8, i.e. quasi-periodic or chaotic; NaN: runs too short to tell).
    pub period: Vec<Vec<f64>>,
    /// The smallest power over the initial states, per frequency (W).
    pub robust_w: Vec<f64>,
    /// The mean power over the initial states, per frequency (W).
    pub mean_w: Vec<f64>,
    /// Band metrics of the robust curve.
    pub robust: BandMetrics,
    /// Band metrics of the mean curve.
    pub mean: BandMetrics,
    /// With the expected weighting, per frequency: the high-power attractor, the starts whose
    /// power is within [`TOP_POWER_SHARE`] of the most powerful start's and whose period is
    /// its period (empty with the robust weighting).
    pub top_attractor: Vec<TopAttractor>,
    /// Instances (state × frequency) that did not end `ok`.
    pub failed: usize,
    /// On the Pareto front of (robust bandwidth, robust band-averaged power).
    pub pareto: bool,
    /// Position in the ranking (1 = best).
    pub rank: usize,
}

/// Two starts of one (design, frequency) are on the high-power attractor when their powers
/// differ by at most this share of the highest power and their periods agree.
pub const TOP_POWER_SHARE: f64 = 0.1;

/// The high-power attractor of one (design, frequency) among its sampled starts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TopAttractor {
    /// Mean power of its starts (W).
    pub power_w: f64,
    /// Its basin fraction: the share of all starts (failed ones included) that reached it.
    pub basin_fraction: f64,
    /// Its period (forcing periods; 0: not periodic up to the period test's limit; NaN: not
    /// tested).
    pub period: f64,
}

impl TopAttractor {
    /// The high-power attractor of the starts' `power_w` and `period` at one frequency
    /// (`None` when no start ended ok).
    pub fn of(power_w: &[f64], period: &[f64]) -> Option<TopAttractor> {
        let top = (0..power_w.len())
            .filter(|&i| power_w[i].is_finite())
            .max_by(|&a, &b| power_w[a].total_cmp(&power_w[b]))?;
        let (p, per) = (power_w[top], period[top]);
        let same_period = |q: f64| q == per || (q.is_nan() && per.is_nan());
        let members: Vec<f64> = (0..power_w.len())
            .filter(|&i| {
                power_w[i].is_finite()
                    && p - power_w[i] <= TOP_POWER_SHARE * p.abs()
                    && same_period(period[i])
            })
            .map(|i| power_w[i])
            .collect();
        Some(TopAttractor {
            power_w: members.iter().sum::<f64>() / members.len() as f64,
            basin_fraction: members.len() as f64 / power_w.len() as f64,
            period: per,
        })
    }
}

impl DesignResult {
    /// The band metrics and the curve the ranking reads under `w`: the robust curve's, or
    /// the mean's (the expected power over sampled starts).
    pub fn ranked(&self, w: Weighting) -> (&BandMetrics, &[f64]) {
        match w {
            Weighting::Robust => (&self.robust, &self.robust_w),
            Weighting::Expected { .. } => (&self.mean, &self.mean_w),
        }
    }
}

/// The clamped linear cantilever with the same beam, patch and load.
#[derive(Debug, Clone, Serialize)]
pub struct Baseline {
    /// Its validated scene (at the band's first frequency).
    pub scene: Scene,
    /// First natural frequency of the clamped beam, from the linearisation (Hz).
    pub first_natural_hz: f64,
    /// The band frequencies and the zoom around the resonance, merged and sorted (Hz).
    pub frequencies_hz: Vec<f64>,
    /// Power at `frequencies_hz` (W).
    pub power_w: Vec<f64>,
    /// Power at the band frequencies only (W).
    pub band_power_w: Vec<f64>,
    /// Metrics on the merged grid (what designs are compared with).
    pub metrics: BandMetrics,
    /// Metrics on the band grid alone (as coarse as the designs').
    pub band_metrics: BandMetrics,
    /// Instances that did not end `ok`.
    pub failed: usize,
}

/// What one batch cost.
#[derive(Debug, Clone, Serialize)]
pub struct StageReport {
    /// `baseline`, `grid`, `refine 1`, ...
    pub stage: String,
    /// Designs in the batch.
    pub designs: usize,
    /// Instances (designs × states × frequencies).
    pub instances: usize,
    /// Total RK4 instance-steps.
    pub instance_steps: u64,
    /// Wall time of the stage, scenes and planning included (s).
    pub wall_s: f64,
    /// Integration and reduction on the engine (s).
    pub engine_s: f64,
    /// Instance-steps per second of the integration.
    pub instance_steps_per_s: f64,
    /// Smallest and largest step (s).
    pub dt_range_s: (f64, f64),
    /// Warnings of the plan.
    pub warnings: Vec<String>,
}

/// A finished search.
#[derive(Debug, Clone, Serialize)]
pub struct SearchRun {
    /// The linear baseline.
    pub baseline: Baseline,
    /// The bandwidth threshold in watts.
    pub threshold_w: f64,
    /// Every evaluated design, in evaluation order.
    pub designs: Vec<DesignResult>,
    /// Design ids, best first.
    pub ranking: Vec<usize>,
    /// One entry per batch.
    pub stages: Vec<StageReport>,
    /// The engine that ran every batch.
    pub engine: EngineInfo,
    /// Wall time of the whole search (s).
    pub total_s: f64,
}

impl SearchRun {
    /// Whether any instance of any design ended ok (every design failing leaves nothing to
    /// rank).
    pub fn usable(&self) -> bool {
        self.designs
            .iter()
            .any(|d| d.failed < d.power_w.iter().map(Vec::len).sum::<usize>())
    }

    /// The best design by the ranking.
    pub fn best(&self) -> &DesignResult {
        &self.designs[self.ranking[0]]
    }

    /// The top `n` designs, best first.
    pub fn top(&self, n: usize) -> Vec<&DesignResult> {
        self.ranking
            .iter()
            .take(n)
            .map(|&i| &self.designs[i])
            .collect()
    }
}

/// The opened engine every batch runs on, and the progress callback.
struct Batches<'a> {
    engine: &'a Engine,
    progress: SearchProgress<'a>,
}

/// Whether the runs are long enough for the period test (it needs 20 stroboscopic samples
/// after the transient at the lowest frequency).
pub(crate) fn period_test_possible(spec: &SearchSpec) -> bool {
    let i = &spec.scene.integration;
    (i.duration_s - i.transient_s) * spec.band.start_hz() >= 20.5
}

/// Power with the accumulators that tell the regime (hops, impacts) and, when the runs are
/// long enough, the period of the stroboscopic section (regular or not); neither K nor R is
/// computed.
pub fn ensemble_options(spec: &SearchSpec) -> EnsembleOptions {
    let mut metrics = vec![Metric::Hops, Metric::ImpactsPerS, Metric::Power];
    if period_test_possible(spec) {
        metrics.push(Metric::Period);
        metrics.sort();
    }
    EnsembleOptions {
        metrics,
        keep_strobe: false,
        samples_per_period: spec.samples_per_period,
        strobe_phase: 0.0,
        // R is not computed: the shortest series keeps the GPU's work buffer small.
        r_max_samples: 32,
        // A confirmed orbit's power is its cycle's (pendulum_atlas_core::engine::early).
        early_stop: Some(pendulum_atlas_core::engine::EarlyStop::DEFAULT),
        lyapunov: Default::default(),
        gpu_kernel: Default::default(),
    }
}

/// Reduction settings: the map's defaults (only the period test is used).
fn reduce_options() -> ReduceOptions {
    ReduceOptions::default()
}

impl Batches<'_> {
    /// Integrate a list of scenes: one ensemble, or chunks of `search.max_batch_instances`
    /// (the GPU engine itself splits whatever exceeds the adapter's buffers). Results keep the
    /// order of `scenes`.
    fn run(
        &mut self,
        spec: &SearchSpec,
        stage: &str,
        designs: usize,
        scenes: Vec<Scene>,
        started: Instant,
    ) -> Result<(Vec<InstanceResult>, StageReport), HarvestError> {
        let instances = scenes.len();
        let chunk = spec.max_batch_instances.max(1);
        let n_chunks = instances.div_ceil(chunk);
        let mut results = Vec::with_capacity(instances);
        let mut report = StageReport {
            stage: stage.to_string(),
            designs,
            instances,
            instance_steps: 0,
            wall_s: 0.0,
            engine_s: 0.0,
            instance_steps_per_s: 0.0,
            dt_range_s: (f64::INFINITY, 0.0),
            warnings: Vec::new(),
        };
        let mut integrate_s = 0.0;
        for (c, part) in scenes.chunks(chunk).enumerate() {
            let failed = |source| HarvestError::Engine {
                stage: stage.to_string(),
                source,
            };
            let plan = EnsemblePlan::from_scenes(part, &ensemble_options(spec)).map_err(failed)?;
            let label = if n_chunks > 1 {
                format!(
                    "{stage}: {designs} designs, {instances} instances (chunk {}/{n_chunks})",
                    c + 1
                )
            } else {
                format!("{stage}: {designs} designs, {instances} instances")
            };
            let progress = self.progress;
            let cb = |done: u64, total: u64, _unit: ProgressUnit| {
                progress(&label, done, total);
                std::ops::ControlFlow::Continue(())
            };
            let run = run_plan(plan, &reduce_options(), None, self.engine, &cb).map_err(failed)?;
            let steps = run.plan.total_steps;
            report.instance_steps += steps;
            report.engine_s += run.timings.total_s;
            integrate_s += steps as f64 / run.instance_steps_per_s();
            report.dt_range_s.0 = report.dt_range_s.0.min(run.plan.dt_range_s.0);
            report.dt_range_s.1 = report.dt_range_s.1.max(run.plan.dt_range_s.1);
            for w in &run.plan.warnings {
                if !report.warnings.contains(w) {
                    report.warnings.push(w.clone());
                }
            }
            results.extend(run.results);
        }
        report.instance_steps_per_s = report.instance_steps as f64 / integrate_s.max(1e-12);
        report.wall_s = started.elapsed().as_secs_f64();
        Ok((results, report))
    }
}

/// Build the scenes of a batch of designs: designs × initial states × band frequencies.
fn design_scenes(spec: &SearchSpec, designs: &[Vec<f64>]) -> Result<Vec<Scene>, HarvestError> {
    let per_design: Vec<Vec<Scene>> = designs
        .par_iter()
        .map(|d| -> Result<Vec<Scene>, HarvestError> {
            let (table, scene) = spec.design_table(d)?;
            let clearance = scene.limiter.clearance_deg;
            let mut out = Vec::new();
            for state in &spec.initial_states {
                for &f in &spec.band.frequencies_hz {
                    out.push(
                        spec.instance_scene(&table, clearance, state, f)
                            .map_err(|e| ConfigError::Inconsistent {
                                key: "search.variables".into(),
                                reason: format!(
                                    "design {} at {f} Hz from {}: {e}",
                                    describe_design(&spec.variables, d),
                                    state.name
                                ),
                            })?,
                    );
                }
            }
            Ok(out)
        })
        .collect::<Result<_, _>>()?;
    Ok(per_design.into_iter().flatten().collect())
}

/// Evaluate a batch of designs and turn the instances back into P(f) curves.
fn evaluate(
    spec: &SearchSpec,
    engine: &mut Batches,
    stage: &str,
    designs: Vec<Vec<f64>>,
    first_id: usize,
    threshold_w: f64,
) -> Result<(Vec<DesignResult>, StageReport), HarvestError> {
    let started = Instant::now();
    let scenes = design_scenes(spec, &designs)?;
    let (results, report) = engine.run(spec, stage, designs.len(), scenes, started)?;
    let n_f = spec.band.frequencies_hz.len();
    let n_s = spec.initial_states.len();
    let per_design = n_f * n_s;
    let out = designs
        .into_iter()
        .enumerate()
        .map(|(i, values)| {
            let chunk = &results[i * per_design..(i + 1) * per_design];
            let grid = |get: fn(&InstanceResult) -> f64| -> Vec<Vec<f64>> {
                chunk
                    .chunks(n_f)
                    .map(|c| c.iter().map(get).collect())
                    .collect()
            };
            let power_w = grid(|r| r.power_w);
            let period = grid(|r| r.period);
            let failed = chunk.iter().filter(|r| r.status != Status::Ok).count();
            let top_attractor = match spec.weighting {
                Weighting::Robust => Vec::new(),
                Weighting::Expected { .. } => (0..n_f)
                    .map(|j| {
                        let at = |g: &[Vec<f64>]| g.iter().map(|s| s[j]).collect::<Vec<f64>>();
                        TopAttractor::of(&at(&power_w), &at(&period)).unwrap_or(TopAttractor {
                            power_w: f64::NAN,
                            basin_fraction: 0.0,
                            period: f64::NAN,
                        })
                    })
                    .collect(),
            };
            let robust_w = robust_curve(&power_w);
            let mean_w = mean_curve(&power_w);
            let f = &spec.band.frequencies_hz;
            DesignResult {
                id: first_id + i,
                stage: stage.to_string(),
                values,
                hops: grid(|r| r.hops),
                impacts_per_s: grid(|r| r.impacts_per_s),
                period,
                top_attractor,
                robust: band_metrics(f, &robust_w, threshold_w),
                mean: band_metrics(f, &mean_w, threshold_w),
                robust_w,
                mean_w,
                power_w,
                failed,
                pareto: false,
                rank: 0,
            }
        })
        .collect();
    Ok((out, report))
}

/// The baseline's frequencies: the band plus `count` points within ± halfwidth of the
/// clamped resonance (inside the band), merged and sorted.
fn baseline_frequencies(spec: &SearchSpec, f1: f64) -> Vec<f64> {
    let mut f = spec.band.frequencies_hz.clone();
    let z = &spec.baseline_zoom;
    if z.count >= 2 {
        for j in 0..z.count {
            let x = f1 - z.halfwidth_hz + 2.0 * z.halfwidth_hz * j as f64 / (z.count - 1) as f64;
            if x > spec.band.start_hz() && x < spec.band.end_hz() {
                f.push(x);
            }
        }
    }
    f.sort_by(f64::total_cmp);
    f.dedup_by(|a, b| (*a - *b).abs() < 1e-9 * b.abs());
    f
}

/// Evaluate the clamped linear cantilever over the band (and the zoom around its resonance).
fn evaluate_baseline(
    spec: &SearchSpec,
    engine: &mut Batches,
) -> Result<(Baseline, StageReport), HarvestError> {
    let started = Instant::now();
    let table = spec.baseline_table()?;
    let scene0 = Scene::from_table(table.clone())?;
    let first_natural_hz = scene0
        .modes()
        .map_err(pendulum_atlas_core::config::ConfigError::from)?
        .frequencies_hz
        .first()
        .copied()
        .ok_or(HarvestError::NoBaselineMode)?;
    let freqs = baseline_frequencies(spec, first_natural_hz);
    let rest = InitialState {
        name: "rest".into(),
        well: None,
        angle_deg: Some(0.0),
        rate_deg_s: 0.0,
        voltage_v: 0.0,
    };
    let scenes: Vec<Scene> = freqs
        .iter()
        .map(|&f| spec.instance_scene(&table, 0.0, &rest, f))
        .collect::<Result<_, _>>()?;
    let (results, report) = engine.run(spec, "baseline", 1, scenes, started)?;
    let power_w: Vec<f64> = results.iter().map(|r| r.power_w).collect();
    let band_power_w: Vec<f64> = spec
        .band
        .frequencies_hz
        .iter()
        .map(|&fb| {
            let j = freqs
                .iter()
                .position(|&x| (x - fb).abs() < 1e-9 * fb)
                .expect("band frequency in the merged grid");
            power_w[j]
        })
        .collect();
    let failed = results.iter().filter(|r| r.status != Status::Ok).count();
    // The threshold may depend on the peak: metrics are filled in once it is known.
    let nan = BandMetrics {
        bandwidth_hz: f64::NAN,
        band_average_w: f64::NAN,
        peak_w: f64::NAN,
        peak_frequency_hz: f64::NAN,
    };
    Ok((
        Baseline {
            scene: scene0,
            first_natural_hz,
            frequencies_hz: freqs,
            power_w,
            band_power_w,
            metrics: nan,
            band_metrics: nan,
            failed,
        },
        report,
    ))
}

/// Ranking key: designs with failed instances last, then the objective.
fn better(spec: &SearchSpec, a: &DesignResult, b: &DesignResult) -> std::cmp::Ordering {
    let key = |d: &DesignResult| {
        let m = d.ranked(spec.weighting).0;
        let (p, s) = match spec.objective {
            Objective::Bandwidth => (m.bandwidth_hz, m.band_average_w),
            Objective::Power => (m.band_average_w, m.bandwidth_hz),
        };
        (d.failed == 0, p, s)
    };
    let (ka, kb) = (key(a), key(b));
    kb.0.cmp(&ka.0)
        .then(kb.1.total_cmp(&ka.1))
        .then(kb.2.total_cmp(&ka.2))
        .then(a.id.cmp(&b.id))
}

/// Design ids, best first.
fn rank(spec: &SearchSpec, designs: &[DesignResult]) -> Vec<usize> {
    let mut ids: Vec<usize> = (0..designs.len()).collect();
    ids.sort_by(|&i, &j| better(spec, &designs[i], &designs[j]));
    ids
}

/// Mark the designs no other design beats in both bandwidth and band-averaged power of the
/// ranked curve (`w`; designs with failed instances take no part). Sorted sweep: O(n log n).
fn mark_pareto(designs: &mut [DesignResult], w: Weighting) {
    let key = |d: &DesignResult| {
        let m = d.ranked(w).0;
        (m.bandwidth_hz, m.band_average_w)
    };
    let mut ok: Vec<usize> = (0..designs.len())
        .filter(|&i| designs[i].failed == 0)
        .collect();
    ok.sort_by(|&a, &b| {
        let (ka, kb) = (key(&designs[a]), key(&designs[b]));
        kb.0.total_cmp(&ka.0).then(kb.1.total_cmp(&ka.1))
    });
    for d in designs.iter_mut() {
        d.pareto = false;
    }
    // Best power among designs of strictly larger bandwidth.
    let mut best_wider = f64::NEG_INFINITY;
    let mut i = 0;
    while i < ok.len() {
        let bw = key(&designs[ok[i]]).0;
        let mut j = i;
        while j < ok.len() && key(&designs[ok[j]]).0 == bw {
            j += 1;
        }
        // Sorted by power within the group: its first has the group's best power.
        let top = key(&designs[ok[i]]).1;
        for &k in &ok[i..j] {
            designs[k].pareto = key(&designs[k]).1 == top && top > best_wider;
        }
        best_wider = best_wider.max(top);
        i = j;
    }
}

/// The candidates of refinement round `round`: one step along each variable, both ways,
/// around each of the best `refine.top` designs, within the grid's range, not yet seen.
fn refinement_candidates(
    spec: &SearchSpec,
    designs: &[DesignResult],
    ranking: &[usize],
    round: u32,
    seen: &mut HashSet<String>,
) -> Vec<Vec<f64>> {
    let shrink = spec.refine.shrink.powi(round as i32);
    ranking
        .iter()
        .take(spec.refine.top)
        .flat_map(|&id| neighbours(&spec.variables, &designs[id].values, shrink))
        .filter(|c| seen.insert(point_key(c)))
        .collect()
}

/// Run a whole search: baseline, grid, refinement, ranking.
pub fn run_search(
    spec: &SearchSpec,
    engine: &Engine,
    progress: SearchProgress,
) -> Result<SearchRun, HarvestError> {
    let t_all = Instant::now();
    let mut engine = Batches { engine, progress };
    let mut stages = Vec::new();

    let (mut baseline, mut report) = evaluate_baseline(spec, &mut engine)?;
    if baseline.failed > 0 {
        report.warnings.push(format!(
            "{} of {} baseline instances did not end `ok`: their power counts as zero",
            baseline.failed,
            baseline.frequencies_hz.len()
        ));
    }
    stages.push(report);
    let peak = band_metrics(&baseline.frequencies_hz, &baseline.power_w, 0.0).peak_w;
    let threshold_w = spec.threshold.power_w(peak);
    if !(threshold_w.is_finite() && threshold_w >= 0.0) {
        return Err(HarvestError::NoBaselinePower { peak_w: peak });
    }
    baseline.metrics = band_metrics(&baseline.frequencies_hz, &baseline.power_w, threshold_w);
    baseline.band_metrics = band_metrics(
        &spec.band.frequencies_hz,
        &baseline.band_power_w,
        threshold_w,
    );

    let grid: Vec<Vec<f64>> = (0..spec.grid_designs())
        .map(|k| spec.grid_design(k))
        .collect();
    let mut seen: HashSet<String> = grid.iter().map(|d| point_key(d)).collect();
    let (mut designs, report) = evaluate(spec, &mut engine, "grid", grid, 0, threshold_w)?;
    stages.push(report);

    for round in 1..=spec.refine.rounds {
        let ranking = rank(spec, &designs);
        let cands = refinement_candidates(spec, &designs, &ranking, round, &mut seen);
        if cands.is_empty() {
            continue;
        }
        let stage = format!("refine {round}");
        let (more, report) =
            evaluate(spec, &mut engine, &stage, cands, designs.len(), threshold_w)?;
        designs.extend(more);
        stages.push(report);
    }

    mark_pareto(&mut designs, spec.weighting);
    let ranking = rank(spec, &designs);
    for (pos, &id) in ranking.iter().enumerate() {
        designs[id].rank = pos + 1;
    }
    Ok(SearchRun {
        baseline,
        threshold_w,
        designs,
        ranking,
        stages,
        engine: engine.engine.info().clone(),
        total_s: t_all.elapsed().as_secs_f64(),
    })
}

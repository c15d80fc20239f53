//! A calibration from start to finish: the coarse grid of candidates, then refinement around
//! the best, each stage one ensemble of candidates × cases × initial states on the engine.
//!
//! A candidate's **score** is the number of observations it matches over all cases; ties are
//! broken by the sum of its distances, each capped at `DISTANCE_CAP` so that one failed run
//! does not outweigh the rest.

use super::observe::{Judgement, judge};
use super::spec::CalibrationSpec;
use pendulum_atlas_core::config::{ConfigError, Metric, neighbours, point_key as key};
use pendulum_atlas_core::engine::{Engine, EngineError, EnsembleOptions, EnsemblePlan, Progress};
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions};
use pendulum_atlas_map::map::run_plan;
use serde::Serialize;
use std::collections::HashSet;

/// Largest distance counted per observation in the tie-break.
pub(crate) const DISTANCE_CAP: f64 = 5.0;

/// One candidate: values of the unknowns and how it fares on every observation.
#[derive(Debug, Clone, Serialize)]
pub struct Candidate {
    /// Values of the unknowns, in the spec's order.
    pub values: Vec<f64>,
    /// `grid` or `refine N`.
    pub stage: String,
    /// Per case, per observation.
    pub judgements: Vec<Vec<Judgement>>,
    /// Observations matched.
    pub matched: usize,
    /// Sum of the capped distances.
    pub distance: f64,
}

impl Candidate {
    /// Observations judged: those with at least one run of this candidate that ended ok.
    pub fn judged(&self) -> usize {
        self.judgements
            .iter()
            .flatten()
            .filter(|j| j.distance.is_finite())
            .count()
    }
}

/// A finished calibration.
#[derive(Debug, Clone, Serialize)]
pub struct CalibrationRun {
    /// Every candidate evaluated, in evaluation order.
    pub candidates: Vec<Candidate>,
    /// Candidate indices, best first.
    pub ranking: Vec<usize>,
    /// Observations in all.
    pub observations: usize,
    /// Instances integrated.
    pub instances: usize,
}

impl CalibrationRun {
    /// The best candidate.
    pub fn best(&self) -> &Candidate {
        &self.candidates[self.ranking[0]]
    }

    /// Whether any run of any candidate ended ok, so that something could be judged.
    pub fn usable(&self) -> bool {
        self.candidates
            .iter()
            .flat_map(|c| c.judgements.iter().flatten())
            .any(|j| j.distance.is_finite())
    }
}

/// Errors of a calibration run.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// A candidate's scene is invalid.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// The engine failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

/// Run the grid and the refinement rounds on an opened engine.
pub fn run_calibration(
    spec: &CalibrationSpec,
    engine: &Engine,
    progress: Progress,
) -> Result<CalibrationRun, CalibrateError> {
    let mut seen = HashSet::new();
    let grid: Vec<Vec<f64>> = grid_points(spec)
        .into_iter()
        .filter(|c| seen.insert(key(c)))
        .collect();
    let mut candidates = evaluate(spec, engine, progress, grid, "grid")?;
    for round in 1..=spec.refine.rounds {
        let ranking = rank(&candidates);
        let around = refinement(spec, &candidates, &ranking, round, &mut seen);
        if around.is_empty() {
            break;
        }
        let stage = format!("refine {round}");
        candidates.extend(evaluate(spec, engine, progress, around, &stage)?);
    }
    let observations = spec.cases.iter().map(|c| c.observations.len()).sum();
    let instances = candidates.len() * spec.cases.len() * spec.initial_states as usize;
    Ok(CalibrationRun {
        ranking: rank(&candidates),
        candidates,
        observations,
        instances,
    })
}

/// Every combination of the unknowns' grid values (last unknown fastest).
pub fn grid_points(spec: &CalibrationSpec) -> Vec<Vec<f64>> {
    spec.unknowns.iter().fold(vec![Vec::new()], |acc, u| {
        acc.iter()
            .flat_map(|head| {
                u.values.iter().map(move |&v| {
                    let mut c = head.clone();
                    c.push(v);
                    c
                })
            })
            .collect()
    })
}

/// Candidates, best first: most observations matched, then smallest distance.
fn rank(candidates: &[Candidate]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| {
        let (x, y) = (&candidates[a], &candidates[b]);
        y.matched
            .cmp(&x.matched)
            .then(x.distance.total_cmp(&y.distance))
    });
    order
}

/// Round `round`'s candidates: the neighbours of each of the best `refine.top`, the step
/// shrunk by `refine.shrink` per round, not yet seen.
fn refinement(
    spec: &CalibrationSpec,
    candidates: &[Candidate],
    ranking: &[usize],
    round: u32,
    seen: &mut HashSet<String>,
) -> Vec<Vec<f64>> {
    let shrink = spec.refine.shrink.powi(round as i32);
    ranking
        .iter()
        .take(spec.refine.top)
        .flat_map(|&id| neighbours(&spec.unknowns, &candidates[id].values, shrink))
        .filter(|c| seen.insert(key(c)))
        .collect()
}

/// The ensemble's settings: what the observations need, on the whole run.
pub fn options(spec: &CalibrationSpec) -> (EnsembleOptions, ReduceOptions) {
    let ens = EnsembleOptions {
        metrics: vec![
            Metric::K,
            Metric::R,
            Metric::Period,
            Metric::Hops,
            Metric::AlphaRange,
            Metric::Line,
        ],
        keep_strobe: false,
        samples_per_period: spec.samples_per_period,
        strobe_phase: 0.0,
        r_max_samples: 1024,
        early_stop: Some(pendulum_atlas_core::engine::EarlyStop::DEFAULT),
        lyapunov: Default::default(),
        gpu_kernel: Default::default(),
    };
    let red = ReduceOptions {
        convention: spec.convention,
        ..ReduceOptions::default()
    };
    (ens, red)
}

/// Integrate candidates × cases × initial states and judge every observation.
fn evaluate(
    spec: &CalibrationSpec,
    engine: &Engine,
    progress: Progress,
    values: Vec<Vec<f64>>,
    stage: &str,
) -> Result<Vec<Candidate>, CalibrateError> {
    let offsets = spec.angle_offsets_deg();
    let mut scenes = Vec::new();
    for v in &values {
        for case in &spec.cases {
            for &o in &offsets {
                scenes.push(spec.scene(case, v, o)?);
            }
        }
    }
    let (ens, red) = options(spec);
    // One ensemble: the GPU engine splits it by the adapter's limits.
    let plan = EnsemblePlan::from_scenes(&scenes, &ens)?;
    let results: Vec<InstanceResult> = run_plan(plan, &red, None, engine, progress)?.results;
    let per_case = offsets.len();
    let per_candidate = per_case * spec.cases.len();
    Ok(values
        .into_iter()
        .zip(results.chunks(per_candidate))
        .map(|(v, runs)| candidate(spec, v, runs, per_case, stage))
        .collect())
}

fn candidate(
    spec: &CalibrationSpec,
    values: Vec<f64>,
    runs: &[InstanceResult],
    per_case: usize,
    stage: &str,
) -> Candidate {
    let judgements: Vec<Vec<Judgement>> = spec
        .cases
        .iter()
        .zip(runs.chunks(per_case))
        .map(|(case, r)| {
            case.observations
                .iter()
                .map(|o| judge(o, r, spec.agreement))
                .collect()
        })
        .collect();
    let all = judgements.iter().flatten();
    Candidate {
        values,
        stage: stage.into(),
        matched: all.clone().filter(|j| j.matched).count(),
        distance: all.map(|j| j.distance.min(DISTANCE_CAP)).sum(),
        judgements,
    }
}

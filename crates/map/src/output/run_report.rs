//! `run.json` of a single run: the scene, how it was integrated, how it ended, λ1 and the
//! paper's analysis. `simulate` writes it; the Python package's `simulate` carries it.

use crate::output::Row;
use pendulum_atlas_core::analysis::{AnalysisError, RecordAnalysis, analyze_record};
use pendulum_atlas_core::config::{DampingReport, Scene};
use pendulum_atlas_core::engine::Outcome;
use pendulum_atlas_core::engine::method::MethodSteps;
use pendulum_atlas_core::engine::{
    DtSource, Integrator, Precision, RunLyapunov, SceneRun, StepPlan,
};
use pendulum_atlas_core::model::{Modes, Status};
use serde::Serialize;

/// Everything `run.json` says about a single run.
#[derive(Debug, Clone, Serialize)]
pub struct RunReport<'a> {
    /// The scene after its overrides.
    pub scene: &'a Scene,
    /// The integrator.
    pub integrator: Integrator,
    /// The float type.
    pub precision: Precision,
    /// The method (`rk4`, `imex` or `dop853`).
    pub method: &'a str,
    /// Why this method ran: the fixed-step engine's choice, or the reference asked for.
    pub method_reason: String,
    /// Steps each method would take.
    pub method_steps: &'a MethodSteps,
    /// The damping the scene's keys give.
    pub damping: Option<DampingReport>,
    /// The step (s).
    pub dt_s: f64,
    /// Where the step came from.
    pub dt_source: DtSource,
    /// The explicit method's stable step (s).
    pub dt_stable_s: f64,
    /// Steps planned.
    pub steps: u64,
    /// Steps taken.
    pub steps_done: u64,
    /// Output rows recorded.
    pub rows: usize,
    /// Wall time of the integration (s).
    pub wall_time_s: f64,
    /// How the run ended.
    pub status: Status,
    /// When it failed (s), if it did.
    pub failed_at_s: Option<f64>,
    /// Bumper contact onsets.
    pub impacts: u64,
    /// Adaptive steps: the tolerances, and what the controller did (its sub-steps and the
    /// chain evaluations they took); null for fixed steps.
    pub adaptive: Option<serde_json::Value>,
    /// The linearised chain's frequencies and rates.
    pub modes: &'a Modes,
    /// The plan's warnings and the run's own.
    pub warnings: &'a [String],
    /// The paper's analysis of α against the cart (absent when the run failed or it could
    /// not be made).
    pub analysis: Option<&'a RecordAnalysis>,
    /// λ1, or why there is none.
    pub lyapunov: &'a RunLyapunov,
    /// For a map cell (a scene with `[cell]`): the cell's values as its map computes them
    /// (`map::cell::rerun_cell`), with the engine that computed them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub map_cell: Option<serde_json::Value>,
}

/// What a single run was and how it went, for [`RunReport::new`].
pub struct RunFacts<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its step plan.
    pub plan: &'a StepPlan,
    /// The integrator it ran with.
    pub integrator: Integrator,
    /// The run.
    pub run: &'a SceneRun,
    /// The scene's modes.
    pub modes: &'a Modes,
    /// Rows recorded.
    pub rows: usize,
    /// Wall time (s).
    pub wall_time_s: f64,
}

impl<'a> RunReport<'a> {
    /// The report of a run from its facts, warnings and analysis.
    pub fn new(
        f: RunFacts<'a>,
        warnings: &'a [String],
        analysis: Option<&'a RecordAnalysis>,
    ) -> Self {
        RunReport {
            scene: f.scene,
            integrator: f.integrator,
            precision: f.run.precision,
            method: match f.integrator {
                Integrator::Engine => f.plan.method.name(),
                Integrator::Reference => "dop853",
            },
            method_reason: match f.integrator {
                Integrator::Engine => f.plan.method_reason.clone(),
                Integrator::Reference => {
                    "the reference integrator was asked for: adaptive DOP853 with contact events in f64 (the fixed-step engine's choice of RK4 or IMEX does not apply)".into()
                }
            },
            method_steps: &f.plan.method_steps,
            damping: f.scene.damping_report().ok(),
            dt_s: f.plan.dt_s,
            dt_source: f.plan.dt_source,
            dt_stable_s: f.plan.dt_stable_s,
            steps: f.plan.steps,
            steps_done: f.run.outcome.steps_done,
            rows: f.rows,
            wall_time_s: f.wall_time_s,
            status: f.run.outcome.status,
            failed_at_s: f.run.outcome.failed_at_s,
            impacts: f.run.outcome.impacts,
            adaptive: f.run.outcome.substeps.map(|st| {
                serde_json::json!({
                    "control": f.plan.control,
                    "base_step_s": f.plan.dt_s,
                    "accepted": st.accepted,
                    "rejected": st.rejected,
                    "forced": st.forced,
                    "smallest_s": st.smallest_s,
                    "largest_s": st.largest_s,
                    "evaluations": st.evaluations(),
                })
            }),
            modes: f.modes,
            warnings,
            analysis,
            lyapunov: &f.run.lyapunov,
            map_cell: None,
        }
    }
}

/// The plan's warnings, and where the run stopped when it failed.
pub fn run_warnings(plan: &StepPlan, outcome: &Outcome) -> Vec<String> {
    let mut warnings = plan.warnings.clone();
    if let Some(t) = outcome.failed_at_s {
        warnings.push(format!(
            "run stopped at t = {t:.6} s with status `{}`: rows after that time are not written",
            outcome.status
        ));
    }
    warnings
}

/// The paper's analysis of a run: the holder angle α against the cart position x0, read at
/// the rate its rows were written ([`StepPlan::row_rate_hz`]), after its transient
/// (`docs/analysis.md`).
pub fn record_analysis(
    scene: &Scene,
    plan: &StepPlan,
    rows: &[Row],
) -> Result<RecordAnalysis, AnalysisError> {
    let alpha: Vec<f64> = rows.iter().map(|r| r.alpha_rad).collect();
    let cart: Vec<f64> = rows.iter().map(|r| r.x0_m).collect();
    analyze_record(
        &alpha,
        Some(&cart),
        plan.row_rate_hz,
        0.0,
        &scene.record_options(),
    )
}

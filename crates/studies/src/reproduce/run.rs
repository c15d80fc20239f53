//! Integrating one scene with the RK4 engine (f64, automatic step) and keeping its rows.

use super::error::ReproduceError;
use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::{Instance, StepPlan, integrate};
use pendulum_atlas_map::output::{Row, TrajectoryRecorder};
use serde::Serialize;
use std::time::Instant;

/// A finished simulation of one scene.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The scene that was integrated.
    pub scene: Scene,
    /// Output rows (every `1/output.sample_rate_hz`).
    pub rows: Vec<Row>,
    /// How the run went (step, steps, impacts, wall time).
    pub stats: RunStats,
}

/// Numbers about a run that the report quotes.
#[derive(Debug, Clone, Serialize)]
pub struct RunStats {
    /// RK4 step (s).
    pub dt_s: f64,
    /// Steps taken.
    pub steps: u64,
    /// Bumper contact onsets.
    pub impacts: u64,
    /// Wall time of the integration (s).
    pub wall_s: f64,
}

impl Simulation {
    /// A column of the rows.
    pub fn column(&self, f: impl Fn(&Row) -> f64) -> Vec<f64> {
        self.rows.iter().map(f).collect()
    }

    /// Output sample rate (Hz).
    pub fn rate_hz(&self) -> f64 {
        self.scene.output.sample_rate_hz
    }

    /// Index of the first row after the transient.
    pub(crate) fn transient_rows(&self) -> usize {
        ((self.scene.integration.transient_s * self.rate_hz()).ceil() as usize).min(self.rows.len())
    }
}

/// Integrate `scene` (case `case` in error messages) at its automatic step with f64 RK4.
/// A run that diverges or turns non-finite is an error: its numbers would mean nothing.
pub fn simulate(case: &str, scene: &Scene) -> Result<Simulation, ReproduceError> {
    let invalid = |e| ReproduceError::Scene {
        case: case.into(),
        source: pendulum_atlas_core::config::ConfigError::from(e),
    };
    let plan = StepPlan::for_scene(scene).map_err(invalid)?;
    let inst = Instance::<f64>::from_scene(scene).map_err(invalid)?;
    let mut rec = TrajectoryRecorder {
        rows: Vec::with_capacity(plan.rows()),
        load_ohm: scene.piezo_params().map(|z| z.load_ohm),
        ..Default::default()
    };
    let started = Instant::now();
    let outcome = integrate(&inst, &plan, &mut rec);
    let wall_s = started.elapsed().as_secs_f64();
    if let Some(at_s) = outcome.failed_at_s {
        return Err(ReproduceError::Failed {
            case: case.to_string(),
            status: outcome.status,
            at_s,
        });
    }
    Ok(Simulation {
        scene: scene.clone(),
        rows: rec.rows,
        stats: RunStats {
            dt_s: plan.dt_s,
            steps: outcome.steps_done,
            impacts: outcome.impacts,
            wall_s,
        },
    })
}

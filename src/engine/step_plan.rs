//! The step plan of a single run: the time step (automatic or given), step count, output
//! cadence.

use crate::config::{Scene, TimeStep};
use crate::model::Modes;
use serde::Serialize;

/// Where a run's step came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DtSource {
    /// `integration.dt_s = "auto"`: from the linearisation.
    Auto,
    /// `integration.dt_s` given in seconds.
    Given,
}

/// How a run is discretised in time.
#[derive(Debug, Clone, Serialize)]
pub struct StepPlan {
    /// The RK4 step (s).
    pub dt_s: f64,
    /// Total number of steps.
    pub steps: u64,
    /// Steps between output rows (the output interval is `sample_every · dt_s`).
    pub sample_every: u64,
    /// Where dt came from.
    pub dt_source: DtSource,
    /// Largest stable RK4 step of the linearised model (s).
    pub dt_stable_s: f64,
    /// Warnings about the step (an explicit dt beyond the stable limit, ...).
    pub warnings: Vec<String>,
}

impl StepPlan {
    /// Choose the step for a scene. The automatic step is `safety · 2.78 / max|λ|`, capped by the
    /// output interval and then shortened so that the output interval is a whole number of steps.
    pub fn for_scene(scene: &Scene, modes: &Modes) -> StepPlan {
        let out_dt = 1.0 / scene.output.sample_rate_hz;
        let duration = scene.integration.duration_s;
        let mut warnings = Vec::new();
        let (dt_s, sample_every, dt_source) = match scene.integration.dt_s {
            TimeStep::Auto => {
                let dt0 = modes.dt_auto_s.min(out_dt);
                let per_row = (out_dt / dt0 - 1e-9).ceil().max(1.0);
                (out_dt / per_row, per_row as u64, DtSource::Auto)
            }
            TimeStep::Seconds(dt) => {
                if dt > modes.dt_stable_s {
                    warnings.push(format!(
                        "integration.dt_s = {dt:e} s exceeds the RK4 stability limit {:e} s of the linearised model; instances that blow up are flagged `diverged`",
                        modes.dt_stable_s
                    ));
                }
                let every = (out_dt / dt).round().max(1.0) as u64;
                if ((every as f64) * dt - out_dt).abs() > 1e-9 * out_dt {
                    warnings.push(format!(
                        "output interval {out_dt:e} s is not a multiple of dt = {dt:e} s: rows are written every {every} steps ({:e} s)",
                        every as f64 * dt
                    ));
                }
                (dt, every, DtSource::Given)
            }
        };
        StepPlan {
            dt_s,
            steps: (duration / dt_s).round() as u64,
            sample_every,
            dt_source,
            dt_stable_s: modes.dt_stable_s,
            warnings,
        }
    }

    /// Number of output rows, including t = 0.
    pub fn rows(&self) -> usize {
        (self.steps / self.sample_every) as usize + 1
    }
}

//! The step plan of a single run: the method, its time step (automatic or given), the step
//! count and the output cadence.

use crate::config::{Scene, StepControl, TimeStep};
use crate::engine::method::{Method, MethodSteps, choose_method};
use crate::model::linear::LinearError;
use serde::Serialize;

/// Where a run's step came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum DtSource {
    /// `integration.dt_s = "auto"`: the method's automatic step.
    Auto,
    /// `integration.dt_s` given in seconds.
    Given,
}

/// How a run is discretised in time.
#[derive(Debug, Clone, Serialize)]
pub struct StepPlan {
    /// The integration method.
    pub method: Method,
    /// Why that method.
    pub method_reason: String,
    /// The step (s).
    pub dt_s: f64,
    /// Total number of steps.
    pub steps: u64,
    /// Steps between output rows (the output interval is `sample_every · dt_s`).
    pub sample_every: u64,
    /// The rate of the rows as written (Hz): `output.sample_rate_hz`, unless a given step
    /// does not divide the output interval, when it is `1/(sample_every · dt_s)`. The
    /// analysis of a run reads its rows at this rate.
    pub row_rate_hz: f64,
    /// Where dt came from.
    pub dt_source: DtSource,
    /// Largest stable RK4 step of the linearised model (s).
    pub dt_stable_s: f64,
    /// Both methods' automatic steps and what bounds them.
    pub method_steps: MethodSteps,
    /// Warnings about the step (an explicit dt beyond the stable limit, ...).
    pub warnings: Vec<String>,
    /// Fixed steps, or error-controlled ones within each step `dt_s` of the plan (which is
    /// then the ladder's base step, `crate::engine::adaptive`).
    pub control: StepControl,
}

impl StepPlan {
    /// Choose the method and step for a scene. The automatic step is the method's (see
    /// [`MethodSteps`]), capped by the output interval and then shortened so that the output
    /// interval is a whole number of steps. `Err` when the scene's linearisation, which sets
    /// the automatic steps, cannot be computed.
    pub fn for_scene(scene: &Scene) -> Result<StepPlan, LinearError> {
        let steps = MethodSteps::of_scene(scene)?;
        let control = scene.integration.step;
        let adaptive = matches!(control, StepControl::Adaptive { .. });
        // Adaptive steps leave a given step unused: the method is chosen as for automatic ones.
        let given = if adaptive {
            TimeStep::Auto
        } else {
            scene.integration.dt_s
        };
        let mut chosen = choose_method(scene.integration.method, given, &steps);
        // The step taken: a fixed step given, or the base step of adaptive steps given.
        let taken = if adaptive {
            scene.integration.base_step_s
        } else {
            given
        };
        if adaptive {
            chosen.reason = format!("{}; {}", chosen.reason, chosen.method.adaptive_reason());
            if chosen.method == Method::Imex && taken == TimeStep::Auto {
                return Ok(Self::adaptive(scene, steps, chosen.reason));
            }
        }
        let out_dt = 1.0 / scene.output.sample_rate_hz;
        let mut warnings = Vec::new();
        let (dt_s, sample_every, dt_source) = match taken {
            TimeStep::Auto => {
                let f_max = scene.excitation.kind.max_frequency_hz();
                let dt_forcing = 1.0 / (AUTO_STEPS_PER_FORCING_PERIOD * f_max);
                let dt_model = steps.auto_s(chosen.method);
                if dt_forcing < dt_model.min(out_dt) {
                    warnings.push(format!(
                        "the automatic step is shortened to {dt_forcing:e} s (from {:e} s) to take {AUTO_STEPS_PER_FORCING_PERIOD} steps per period of the {} Hz forcing",
                        dt_model.min(out_dt),
                        crate::text::num(f_max)
                    ));
                }
                let dt0 = dt_model.min(out_dt).min(dt_forcing);
                let per_row = (out_dt / dt0 - 1e-9).ceil().max(1.0);
                (out_dt / per_row, per_row as u64, DtSource::Auto)
            }
            TimeStep::Seconds(dt) => {
                // A base step is refined by the error control where the method needs it.
                if !adaptive {
                    warnings.extend(given_step_warning(chosen.method, dt, &steps));
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
        let interval = sample_every as f64 * dt_s;
        let row_rate_hz = if (interval - out_dt).abs() <= 1e-9 * out_dt {
            scene.output.sample_rate_hz
        } else {
            1.0 / interval
        };
        Ok(StepPlan {
            row_rate_hz,
            method: chosen.method,
            method_reason: chosen.reason,
            dt_s,
            steps: (scene.integration.duration_s / dt_s).round() as u64,
            sample_every,
            dt_source,
            dt_stable_s: steps.rk4_stable_s,
            method_steps: steps,
            warnings,
            control,
        })
    }

    /// The plan of adaptive steps: the IMEX pair (the one with an embedded solution), its
    /// base step the output interval, or a whole fraction of it short enough for
    /// [`AUTO_STEPS_PER_FORCING_PERIOD`] per period of the fastest forcing; every row on a
    /// base step, so every row's instant is hit exactly.
    fn adaptive(scene: &Scene, steps: MethodSteps, method_reason: String) -> StepPlan {
        let out_dt = 1.0 / scene.output.sample_rate_hz;
        let f_max = scene.excitation.kind.max_frequency_hz();
        let dt0 = out_dt.min(1.0 / (AUTO_STEPS_PER_FORCING_PERIOD * f_max));
        let per_row = (out_dt / dt0 - 1e-9).ceil().max(1.0);
        let dt_s = out_dt / per_row;
        StepPlan {
            method: Method::Imex,
            method_reason,
            dt_s,
            steps: (scene.integration.duration_s / dt_s).round() as u64,
            sample_every: per_row as u64,
            row_rate_hz: scene.output.sample_rate_hz,
            dt_source: DtSource::Auto,
            dt_stable_s: steps.rk4_stable_s,
            method_steps: steps,
            warnings: Vec::new(),
            control: scene.integration.step,
        }
    }

    /// Number of output rows, including t = 0.
    pub fn rows(&self) -> usize {
        (self.steps / self.sample_every) as usize + 1
    }
}

/// Fewest steps per period of the fastest forcing an automatic step takes: below two the
/// cart's motion aliases (a given step that coarse is refused, `integration.dt_s`), and 16 is
/// what a map takes at least (`map.samples_per_period`'s default).
pub(crate) const AUTO_STEPS_PER_FORCING_PERIOD: f64 = 16.0;

/// The warning for a given step beyond what `method` handles: RK4's stable limit, or the IMEX
/// method's automatic step at safety 1 (its explicit stability and accuracy bound).
pub(crate) fn given_step_warning(method: Method, dt: f64, steps: &MethodSteps) -> Option<String> {
    match method {
        Method::Rk4 if dt > steps.rk4_stable_s => Some(format!(
            "integration.dt_s = {dt:e} s exceeds the RK4 stability limit {:e} s of the linearised model; instances that blow up are flagged `diverged`",
            steps.rk4_stable_s
        )),
        Method::Imex if dt > steps.imex_limit_s() => Some(format!(
            "integration.dt_s = {dt:e} s exceeds the IMEX method's limit {:e} s (explicit stability and 1/500 of the first bending period): expect lost accuracy, and instances that blow up are flagged `diverged`",
            steps.imex_limit_s()
        )),
        _ => None,
    }
}

//! One run of a scene with the integrator its user chose: the fixed-step engine of the maps
//! (RK4 or IMEX, in `f64` or `f32`, with λ1 from a twin trajectory) or the DOP853 reference.
//! `simulate` on the command line and `pendulum_atlas.simulate` in Python both run this.

use super::{
    EngineError, Instance, Observer, Outcome, Precision, ReferenceOptions, SingleTwin, StepPlan,
    integrate_reference, integrate_with_twin,
};
use crate::config::{LyapunovSettings, Scene};
use crate::model::Real;
use crate::reduce::lyapunov::{SEPARATION_F32, SEPARATION_F64};
use serde::Serialize;

/// Which integrator a single run uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integrator {
    /// The engine's stepper, as the maps take it: adaptive steps within the plan's base step,
    /// or its fixed step.
    Engine,
    /// Adaptive DOP853 with contact events, `f64` only (for validation; slower).
    Reference,
}

/// λ1 of a single run from its twin, or why there is none.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum RunLyapunov {
    /// λ1 and how it was measured.
    Measured {
        /// λ1 (1/s).
        per_s: f64,
        /// Its standard error from the block means (1/s).
        se_per_s: f64,
        /// The twin's schedule and separation.
        twin: SingleTwin,
    },
    /// Why the run has no λ1.
    Skipped {
        /// The reason.
        skipped: String,
    },
}

/// What a single run ended with.
#[derive(Debug, Clone)]
pub struct SceneRun {
    /// Status, steps and impacts.
    pub outcome: Outcome,
    /// λ1, or why there is none.
    pub lyapunov: RunLyapunov,
    /// The float type it ran in.
    pub precision: Precision,
}

/// Integrate `scene` over `plan` with `integrator` in `precision`, handing every output row
/// to `obs`. The reference runs in `f64` only: asking it for `f32` is refused.
pub fn run_scene<O: Observer<f32> + Observer<f64>>(
    scene: &Scene,
    plan: &StepPlan,
    integrator: Integrator,
    precision: Precision,
    obs: &mut O,
) -> Result<SceneRun, EngineError> {
    let twin =
        |d0: f64| SingleTwin::for_run(scene, plan, d0, LyapunovSettings::default().align_periods);
    crate::engine::adaptive::check_f32_tolerance(plan.control, precision == Precision::F32)?;
    let (outcome, lyapunov) = match (integrator, precision) {
        (Integrator::Reference, Precision::F32) => return Err(EngineError::ReferenceNeedsF64),
        (Integrator::Reference, Precision::F64) => {
            let inst = Instance::<f64>::from_scene(scene)?;
            let opts = ReferenceOptions::for_stiffness(scene.modes()?.spectral_radius_per_s);
            let skipped = RunLyapunov::Skipped {
                skipped: "the DOP853 reference takes adaptive steps; lambda1 comes from the fixed-step engine's twin trajectory (--integrator engine; integrator=\"engine\" in Python)".into(),
            };
            (integrate_reference(&inst, plan, &opts, obs)?, skipped)
        }
        (Integrator::Engine, Precision::F64) => {
            engine_run::<f64, O>(scene, plan, twin(SEPARATION_F64), obs)?
        }
        (Integrator::Engine, Precision::F32) => {
            engine_run::<f32, O>(scene, plan, twin(SEPARATION_F32), obs)?
        }
    };
    Ok(SceneRun {
        outcome,
        lyapunov,
        precision,
    })
}

/// A run of the fixed-step engine in `T`, with λ1's twin when the run is long enough.
fn engine_run<T: Real, O: Observer<T>>(
    scene: &Scene,
    plan: &StepPlan,
    twin: Result<SingleTwin, String>,
    obs: &mut O,
) -> Result<(Outcome, RunLyapunov), EngineError> {
    let inst = Instance::<T>::from_scene(scene)?;
    let (outcome, lyapunov) = integrate_with_twin(&inst, plan, twin.clone().ok(), obs);
    let lyapunov = match (twin, lyapunov) {
        (Err(skipped), _) => RunLyapunov::Skipped { skipped },
        (Ok(twin), Some(l)) => RunLyapunov::Measured {
            per_s: l.per_s,
            se_per_s: l.se_per_s,
            twin,
        },
        (Ok(_), None) => RunLyapunov::Skipped {
            skipped: format!(
                "the twin trajectory broke off (status {}, or a separation that was zero or not finite)",
                outcome.status
            ),
        },
    };
    Ok((outcome, lyapunov))
}

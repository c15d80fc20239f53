//! Which integration method a run uses, and at which step: the automatic step of each method
//! and the choice between them (`integration.method`, `docs/model.md`, "Time step").
//!
//! - RK4's step is bound by stability: `safety · 2.78 / max|λ|` of the whole linearised chain,
//!   whose largest eigenvalues come from the stiffness-proportional joint dampers.
//! - The IMEX method ([`crate::engine::imex`]) treats those implicitly; its step is the smaller
//!   of (a) the explicit half's stability limit on what stays explicit (gravity, an engaged
//!   bumper, the piezo: `safety · 3.67 / ρ_E`, 3.67 being the explicit tableau's boundary on
//!   the negative real axis) and (b) an accuracy bound of 1/500 of the period of the first
//!   clamped bending mode (`safety / (500 f1)`, about 63 µs for Table 1's tube). The bound is
//!   empirical: fixed steps lose order at bumper impacts (the damper's force jumps at onset,
//!   and the loading-only law kinks at the turning point), so the error falls roughly with
//!   dt, not dt³. On the paper's scene (8 Hz / 9 mm, library damping) 1/80 gave 1.2e-4 to
//!   3.6e-4 rad over 0.5 s at N = 5, 9, 17; 1/500 keeps the holder angle within 1e-4 rad of
//!   the DOP853 reference (`bench --stiff`, `docs/bench/STIFF.md`).
//! - `auto` picks the method with the smaller cost per simulated second, steps times the cost
//!   of one step (`imex_step_cost` RK4 steps).

use crate::config::{MethodChoice, Scene, TimeStep};
use crate::model::linear::{LinearError, clamped_first_omega, explicit_part_radius};
use crate::model::{ModelParams, modes};
use serde::Serialize;

/// The explicit tableau's stability boundary on the negative real axis (|z| ≈ 3.665).
pub(crate) const IMEX_EXPLICIT_LIMIT: f64 = 3.665;

/// Steps per period of the first clamped bending mode that the IMEX step resolves.
pub(crate) const IMEX_STEPS_PER_FIRST_MODE: f64 = 500.0;

/// Cost of one IMEX step in RK4 steps at N segments: both take four derivatives (O(N) each);
/// the IMEX method adds its N × N products (about 9 N² multiply-adds against RK4's ~160 N per
/// step), so the ratio grows as `1 + N/16`. Measured on the CPU engine in f64
/// (`bench --stiff`): 1.4 at N = 9, 2.1 at N = 17.
pub(crate) fn imex_step_cost(segments: usize) -> f64 {
    1.0 + segments as f64 / 16.0
}

/// A resolved integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Classical RK4.
    Rk4,
    /// ARK3(2)4L\[2\]SA with the joint springs and dampers implicit.
    Imex,
}

impl Method {
    /// "rk4" or "imex".
    pub fn name(self) -> &'static str {
        match self {
            Method::Rk4 => "rk4",
            Method::Imex => "imex",
        }
    }

    /// What sets its steps under `integration.step = "adaptive"`.
    pub(crate) fn adaptive_reason(self) -> &'static str {
        match self {
            Method::Rk4 => {
                "integration.step = \"adaptive\": RK4's embedded third-order solution sets each step, within RK4's automatic step"
            }
            Method::Imex => {
                "integration.step = \"adaptive\": the embedded solution of ARK3(2)4L[2]SA sets each step"
            }
        }
    }
}

/// The automatic steps of both methods for one chain, and what bounds them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MethodSteps {
    /// RK4's automatic step: safety · 2.78/max|λ| (s).
    pub rk4_auto_s: f64,
    /// RK4's stable limit for the linearised chain (s).
    pub rk4_stable_s: f64,
    /// The IMEX method's automatic step (s).
    pub imex_auto_s: f64,
    /// Spectral radius of what the IMEX method keeps explicit (1/s).
    pub explicit_radius_per_s: f64,
    /// First clamped bending frequency, the IMEX method's accuracy scale (Hz).
    pub first_mode_hz: f64,
    /// Segments N (the IMEX step's cost in RK4 steps grows with it).
    pub segments: usize,
}

impl MethodSteps {
    /// The automatic steps of chain `p` with safety factor `safety`.
    pub fn of(p: &ModelParams, safety: f64) -> Result<MethodSteps, LinearError> {
        let m = modes(p, safety)?;
        let rho_e = explicit_part_radius(p)?;
        let f1 = clamped_first_omega(p)? / std::f64::consts::TAU;
        let mut steps = MethodSteps {
            rk4_auto_s: m.dt_auto_s,
            rk4_stable_s: m.dt_stable_s,
            imex_auto_s: 0.0,
            explicit_radius_per_s: rho_e,
            first_mode_hz: f1,
            segments: p.segments,
        };
        steps.imex_auto_s = safety * steps.imex_limit_s();
        Ok(steps)
    }

    /// The IMEX method's limit at safety 1 (s): the explicit half's stability limit or the
    /// accuracy bound, whichever is smaller.
    pub(crate) fn imex_limit_s(&self) -> f64 {
        let stability = IMEX_EXPLICIT_LIMIT / self.explicit_radius_per_s.max(1e-300);
        stability.min(1.0 / (IMEX_STEPS_PER_FIRST_MODE * self.first_mode_hz))
    }

    /// The automatic steps of a scene.
    pub fn of_scene(scene: &Scene) -> Result<MethodSteps, LinearError> {
        MethodSteps::of(&scene.model_params()?, scene.integration.dt_safety)
    }

    /// The automatic step of `method` (s).
    pub fn auto_s(&self, method: Method) -> f64 {
        match method {
            Method::Rk4 => self.rk4_auto_s,
            Method::Imex => self.imex_auto_s,
        }
    }

    /// Cost of one simulated second in RK4 steps, each method at its automatic step.
    pub(crate) fn cost_per_s(&self, method: Method) -> f64 {
        match method {
            Method::Rk4 => 1.0 / self.rk4_auto_s,
            Method::Imex => imex_step_cost(self.segments) / self.imex_auto_s,
        }
    }
}

/// The method a run uses, and why.
#[derive(Debug, Clone, Serialize)]
pub struct MethodChosen {
    /// The method.
    pub method: Method,
    /// Why (printed, and written to run.json / map.json).
    pub reason: String,
}

/// Resolve `integration.method` for a chain with automatic steps `steps` and the scene's step
/// setting: `auto` takes the cheaper method at the automatic steps, or, with a given step,
/// RK4 unless that step is beyond RK4's stable limit.
pub fn choose_method(choice: MethodChoice, dt: TimeStep, steps: &MethodSteps) -> MethodChosen {
    let (rk4, imex) = (
        steps.cost_per_s(Method::Rk4),
        steps.cost_per_s(Method::Imex),
    );
    match (choice, dt) {
        (MethodChoice::Rk4, _) => MethodChosen {
            method: Method::Rk4,
            reason: "integration.method = \"rk4\"".into(),
        },
        (MethodChoice::Imex, _) => MethodChosen {
            method: Method::Imex,
            reason: "integration.method = \"imex\"".into(),
        },
        (MethodChoice::Auto, TimeStep::Seconds(dt)) if dt > steps.rk4_stable_s => MethodChosen {
            method: Method::Imex,
            reason: format!(
                "auto: the given step {dt:e} s is beyond RK4's stable limit {:e} s",
                steps.rk4_stable_s
            ),
        },
        (MethodChoice::Auto, TimeStep::Seconds(_)) => MethodChosen {
            method: Method::Rk4,
            reason: "auto: the given step is within RK4's stable limit".into(),
        },
        (MethodChoice::Auto, TimeStep::Auto) => {
            let method = if imex < rk4 {
                Method::Imex
            } else {
                Method::Rk4
            };
            MethodChosen {
                method,
                reason: format!(
                    "auto: {} is {:.1}x cheaper here (RK4 step {:.2e} s, IMEX step {:.2e} s, one IMEX step costs {:.2} RK4 steps)",
                    method.name(),
                    rk4.max(imex) / rk4.min(imex),
                    steps.rk4_auto_s,
                    steps.imex_auto_s,
                    imex_step_cost(steps.segments)
                ),
            }
        }
    }
}

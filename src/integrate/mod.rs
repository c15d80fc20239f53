//! Time integration: the step plan, the fixed-step RK4 engine (CPU, generic, batched) and the
//! DOP853 reference integrator with contact events.

pub mod ensemble;
pub mod gpu;
mod plan;
mod reference;
mod rk4;
mod status;

pub use plan::StepPlan;
pub use reference::{ReferenceOptions, integrate_reference};
pub use rk4::{
    Instance, NoObserver, Observer, Outcome, health, integrate, integrate_batch, rk4_step,
};
pub use status::{Guard, Status};

use crate::config::Scene;
use crate::model::{Chain, ModelParams, Real};

impl<T: Real> Instance<T> {
    /// The instance a scene describes, with its initial state.
    pub fn from_scene(scene: &Scene, params: &ModelParams) -> Instance<T> {
        Instance {
            chain: Chain::new(params),
            cart: params.cart,
            y0: params.initial_state(scene),
            guard: Guard::for_params(params),
        }
    }
}

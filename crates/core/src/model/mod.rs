//! The physics of `docs/model.md`, free of any file format: the parameters of a built pendulum,
//! the cart motion, the chain's equations of motion, energies, the health rules of a run, and
//! the linearisation.
//!
//! Stages, in the order a model is built and used:
//! 1. [`ChainDesign`], [`BumperDesign`], [`PiezoParams`], [`CartMotion`] → [`ModelParams`]: every
//!    coefficient derived once (the scene is converted into these by `crate::config`);
//! 2. [`modes`], [`linear`]: natural frequencies, the damping for a first-mode ratio, the
//!    automatic RK4 step;
//! 3. [`Chain`]: the O(N) solve of M(θ)θ̈ = Q in the engine's float type ([`Real`]), energies;
//! 4. [`Guard`] and [`Status`]: what makes a state healthy, checked every [`CHECK_EVERY`] steps.

mod chain;
pub mod dense;
mod excitation;
mod health;
mod lane;
pub mod linear;
mod params;

pub use chain::{
    Branches, BumperLoad, BumperMode, Chain, ChainShape, Coefficient, ContactLaw, ContactReport,
    Energy, Workspace, bumper_force, bumper_mode, exact_bumper_force,
};
pub use excitation::{CartMotion, CartState, ExcitationKind, HarmonicAmplitudes};
pub(crate) use health::RULES as HEALTH_RULES;
#[cfg(test)]
pub(crate) use health::guard_status;
pub use health::{CHECK_EVERY, Guard, Status, health_due};
pub use lane::{F32Lanes, F32x8, F32x16, F64Lanes, F64x4, F64x8, Lane, Real};
pub use linear::{Modes, modes};
pub use params::{
    BumperDesign, ChainDesign, ContactDamping, ContactParams, ModelParams, PiezoParams, Tube,
};

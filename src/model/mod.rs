//! The physics of MODEL.md: parameters, cart motion, the chain's equations of motion,
//! energies, and the linearisation.

mod chain;
pub mod dense;
mod excitation;
pub mod linear;
mod params;
mod real;

pub use chain::{Chain, ContactLaw, ContactReport, Energy, Workspace};
pub use excitation::{CartMotion, CartState};
pub use linear::{Modes, modes};
pub use params::{ContactParams, ModelParams, PiezoParams};
pub use real::Real;

//! pendulum-atlas: chaos and bifurcation maps of an elastic inverted pendulum with clearance.
//!
//! The crate mirrors the pipeline a run goes through:
//!
//! 1. [`config`]: a TOML scene plus `--set key=value` overrides, validated into a typed
//!    [`config::Scene`] with units before any work starts.
//! 2. [`model`]: the physics of `shared/docs/MODEL.md` — one parameter struct
//!    ([`model::ModelParams`]), the O(N) chain solve, energies, and the linearisation
//!    (natural frequencies, unstable rates, the automatic time step).
//! 3. [`integrate`]: the fixed-step RK4 engine (generic over `f32`/`f64`, batched with rayon)
//!    and the adaptive DOP853 reference integrator with contact events.
//! 4. [`analysis`]: the indicators of the paper (0–1 test K, phase synchronisation R,
//!    spectra, wavelets, periodicity) for simulated and measured signals alike.
//! 5. [`output`] and [`render`]: CSV and `.npy` files, PNG pictures.
//!
//! The command-line interface (`src/main.rs`, `src/cli/`) is a thin layer on top.
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod config;
pub mod engine;
pub mod harvest;
pub mod map;
pub mod model;
pub mod output;
pub mod reduce;
pub mod render;
pub mod reproduce;

//! pendulum-atlas: chaos and bifurcation maps of an elastic inverted pendulum with clearance.
//!
//! The physics is written down in `docs/model.md` and the indicators in `docs/analysis.md`;
//! module docs name the sections they implement.
//!
//! The crate mirrors the pipeline a run goes through:
//!
//! 1. [`config`]: a TOML scene plus `--set key=value` overrides, validated into a typed
//!    [`config::Scene`] with units before any work starts (map scenes: [`config::MapSpec`]).
//! 2. [`model`]: the physics of `docs/model.md`: one parameter struct
//!    ([`model::ModelParams`]), the O(N) chain solve, the bumper laws, energies, the health
//!    rules and status codes, and the linearisation (natural frequencies, unstable rates,
//!    spectral radii).
//! 3. [`engine`]: fixed-step integration by RK4 or the IMEX method (joint springs and dampers
//!    implicit), with the choice between them; single runs, the DOP853 reference integrator
//!    with contact events, and the ensemble engines on the CPU (rayon, `f32`/`f64`) and the
//!    GPU (wgpu, the WGSL kernels of `shaders/`, `f32`).
//! 4. [`reduce`]: per-instance results of an ensemble: running accumulators and the K, R and
//!    period reductions of the recorded series (`docs/analysis.md`).
//! 5. [`analysis`]: the indicators of the paper (0–1 test K, phase synchronisation R,
//!    spectra, wavelets, periodicity) for simulated and measured signals alike
//!    (`docs/analysis.md`).
//! 6. [`output`] and [`render`]: CSV and `.npy` files, PNG pictures.
//!
//! Built on these: [`map`] (a parameter map from plan to results), [`harvest`] (the
//! broadband-harvesting design search), [`reproduce`] (the paper's cases and its report),
//! [`bench`] (work-precision and stiff-chain studies) and [`explore`] (a finished map in the
//! browser, a click re-running a cell). The command-line interface
//! (`src/main.rs`, `src/cli/`) is a thin layer on top.
#![warn(missing_docs)]

pub mod analysis;
pub mod bench;
pub mod calibrate;
pub mod config;
pub mod engine;
pub mod explore;
pub mod harvest;
pub mod map;
pub mod model;
pub mod output;
pub mod reduce;
pub mod render;
pub mod reproduce;
pub mod shard;
pub mod text;

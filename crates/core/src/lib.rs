//! pendulum-atlas-core: the numerical core of pendulum-atlas, from a scene to the numbers of
//! one instance. No files, pictures, servers or command lines: those live in the crates above
//! (`pendulum-atlas-map`, `-design`, `-studies`, `-explore` and the `pendulum-atlas` binary).
//!
//! The physics is written down in `docs/model.md` and the indicators in `docs/analysis.md`;
//! module docs name the sections they implement. The modules follow the pipeline a run goes
//! through:
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
//! 4. [`reduce`]: per-instance results of an ensemble: running accumulators, the K, R and
//!    period reductions of the recorded series, λ1, the regime and the attractors
//!    (`docs/analysis.md`).
//! 5. [`analysis`]: the indicators of the paper (0–1 test K, phase synchronisation R,
//!    spectra, wavelets, periodicity) for simulated and measured signals alike
//!    (`docs/analysis.md`).
//!
//! [`rules`] holds the scalar rules written once for Rust and the GPU kernels' WGSL (the
//! adaptive ladder's, the hop count's, the verdict's, the early stop's), and [`text`] the
//! number and shape formatting every message uses.
#![warn(missing_docs)]

pub mod analysis;
pub mod config;
pub mod engine;
pub mod model;
pub mod reduce;
pub mod rules;
pub mod schema;
pub mod text;

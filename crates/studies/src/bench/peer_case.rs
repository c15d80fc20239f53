//! The case a peer implementation (`benches/peers/`) integrates: the default map's instances at
//! N segments, their coefficients and steps, and the state our f64 engine reaches after a few
//! steps, so that a peer can show it integrates the same model before it is timed.
//!
//! Written as JSON (`peer_case_N{n}.json`) by `bench --cpu-throughput`; the peers tile its
//! instances to the instance count they are timed at.

use pendulum_atlas_core::config::{ConfigError, DEFAULT_MAP_TOML, map_from_toml};
use pendulum_atlas_core::engine::cpu::run_steps_f64;
use pendulum_atlas_core::engine::{EngineError, EnsemblePlan};
use pendulum_atlas_core::model::ModelParams;
use serde::Serialize;

/// Steps of the check trajectory (short enough that rounding has not yet separated peers).
pub(crate) const CHECK_STEPS: u64 = 256;

/// One instance of the case.
#[derive(Debug, Clone, Serialize)]
pub struct PeerInstance {
    /// Every coefficient of the equations of motion (SI units; `docs/model.md`).
    pub params: ModelParams,
    /// Initial state `[θ; θ̇; v]`.
    pub y0: Vec<f64>,
    /// The step (s) = 1/(f · spp).
    pub dt_s: f64,
    /// Steps per forcing period: the cart's phase at stage c of step n is
    /// `((n mod spp) + c)/spp` cycles, its acceleration −A(2πf)² sin(2π · phase).
    pub spp: u32,
    /// Forcing frequency f (Hz).
    pub frequency_hz: f64,
    /// Cart amplitude A (m).
    pub amplitude_m: f64,
    /// The state after [`CHECK_STEPS`] RK4 steps of our CPU engine in f64.
    pub y_check: Vec<f64>,
}

/// A peer case: a sample of the default map's instances at one N.
#[derive(Debug, Clone, Serialize)]
pub struct PeerCase {
    /// Segments N.
    pub segments: usize,
    /// The method every peer integrates: classical RK4.
    pub method: &'static str,
    /// Steps of the check trajectory.
    pub check_steps: u64,
    /// Instances (a spread over the default map's forcing plane).
    pub instances: Vec<PeerInstance>,
}

/// Why a peer case could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PeerCaseError {
    /// The default map with the overrides is not a valid scene.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Its plan could not be made.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

/// The default map at N segments with RK4 at fixed steps (and the overrides `extra`), the plan
/// of its `count` instances spread evenly over the grid.
pub(crate) fn default_map_plan(
    n: usize,
    count: usize,
    extra: &[&str],
) -> Result<EnsemblePlan, PeerCaseError> {
    let mut sets = vec![
        format!("beam.segments={n}"),
        "integration.method=\"rk4\"".to_string(),
        "integration.step=\"fixed\"".to_string(),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let spec = map_from_toml(DEFAULT_MAP_TOML, "configs/maps/default.toml", &sets)?;
    let plan = EnsemblePlan::new(&spec)?;
    let total = plan.instances.len();
    let members: Vec<usize> = (0..count.min(total)).map(|i| i * total / count).collect();
    Ok(plan.select(&members))
}

/// The peer case of the default map at N segments, `count` instances.
pub(crate) fn peer_case(n: usize, count: usize) -> Result<PeerCase, PeerCaseError> {
    let plan = default_map_plan(n, count, &[])?;
    let instances = plan
        .instances
        .iter()
        .map(|p| PeerInstance {
            params: p.params.clone(),
            y0: p.y0.clone(),
            dt_s: p.dt_s,
            spp: p.spp,
            frequency_hz: p.frequency_hz,
            amplitude_m: p.amplitude_m,
            y_check: run_steps_f64(p, CHECK_STEPS),
        })
        .collect();
    Ok(PeerCase {
        segments: n,
        method: "rk4",
        check_steps: CHECK_STEPS,
        instances,
    })
}

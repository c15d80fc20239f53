//! The case a peer implementation (`benches/peers/`) integrates: the default map's instances at
//! N segments, their coefficients and steps, and the state our f64 engine reaches after a few
//! steps, so that a peer can show it integrates the same model before it is timed.
//!
//! Written as JSON (`peer_case_N{n}.json`) by `pendulum-atlas-lab peer-cases`; the peers tile
//! its instances to the instance count they are timed at.

use pendulum_atlas_core::engine::cpu::run_steps_f64;
use pendulum_atlas_core::model::ModelParams;
use pendulum_atlas_studies::bench::workload::{WorkloadError, default_map_plan};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Steps of the check trajectory (short enough that rounding has not yet separated peers).
pub const CHECK_STEPS: u64 = 256;

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

/// The peer case of the default map at N segments, `count` instances.
pub fn peer_case(n: usize, count: usize) -> Result<PeerCase, WorkloadError> {
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

/// The segment counts of the peers' cases (those the CPU throughput study times).
pub const SEGMENTS: [usize; 3] = [3, 9, 17];

/// Instances of a peer case (the peers tile them).
pub const INSTANCES: usize = 16;

/// Why the peer cases could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PeerCaseError {
    /// A case could not be planned.
    #[error(transparent)]
    Workload(#[from] WorkloadError),
    /// A file could not be written.
    #[error(transparent)]
    Output(#[from] pendulum_atlas_map::output::OutputError),
}

/// Write `peer_case_N{n}.json` for every N of [`SEGMENTS`] into `dir`; the paths written.
pub fn write_peer_cases(dir: &Path) -> Result<Vec<PathBuf>, PeerCaseError> {
    pendulum_atlas_map::output::files::create_dir(dir)?;
    let mut written = Vec::new();
    for n in SEGMENTS {
        let path = dir.join(format!("peer_case_N{n}.json"));
        let case = peer_case(n, INSTANCES)?;
        written.push(pendulum_atlas_map::output::files::write_json(&path, &case)?);
    }
    Ok(written)
}

//! The nudged reference of a plane (`pendulum-atlas-lab nudged`): the verdict study's longer
//! reference run again, with every segment's initial rate raised by [`NUDGE_DEG_S`], on both
//! subgrids. Where it gives the reference's verdict (class, and period where periodic) a
//! settled cell is *predictable*; elsewhere a 1e-6 change of the start picks the end state (a
//! long chaotic transient, or a fractal basin boundary), and no single trajectory is the truth.
//! `benches/transients_study.py` scores a map on both kinds of cells.

use super::verdict::{Plane, REFERENCE_ATOL, REFERENCE_RTOL, reference_durations, thinning};
use pendulum_atlas_core::config::map_from_toml;
use pendulum_atlas_core::engine::{Engine, EngineError, Precision};
use serde::Serialize;

/// The nudge of the initial rate of every segment (deg/s).
pub const NUDGE_DEG_S: f64 = 1e-6;

/// One subgrid's nudged run.
#[derive(Debug, Clone, Serialize)]
pub struct NudgedRun {
    /// Its first index along each axis (subgrid A 0, B thin/2).
    pub offset: usize,
    /// Verdict per cell (code of `regime.npy`), in the subgrid's C order.
    pub regime: Vec<i8>,
    /// Period per cell (0: none).
    pub period: Vec<f64>,
    /// Wall time (s).
    pub wall_s: f64,
}

/// `nudged.json`.
#[derive(Debug, Clone, Serialize)]
pub struct NudgedReport {
    /// The plane.
    pub plane: Plane,
    /// Every this-many-th value of each axis.
    pub thin: usize,
    /// The nudge (deg/s).
    pub nudge_deg_s: f64,
    /// The initial rate nudged (deg/s).
    pub rate_deg_s: f64,
    /// The run's length (s): the reference's longer run.
    pub duration_s: f64,
    /// Subgrids A and B.
    pub runs: Vec<NudgedRun>,
}

/// Run the nudged reference of `plane` (a twentieth of it with `quick`), reporting each
/// subgrid through `progress`.
pub fn run_nudged(
    plane: Plane,
    quick: bool,
    progress: &dyn Fn(&str),
) -> Result<NudgedReport, EngineError> {
    let thin = thinning(quick);
    let [_, long] = reference_durations(quick);
    let base = map_from_toml(plane.scene(), plane.path(), &[])?;
    let rate = base.scene.initial.rate_deg_s + NUDGE_DEG_S;
    let engine = Engine::cpu(Precision::F64);
    let mut runs = Vec::new();
    for offset in [0, thin / 2] {
        let mut sets = super::verdict::reference_sets(long, REFERENCE_RTOL, REFERENCE_ATOL);
        // As the kept reference ran: before the orbit stage, whose periods it would correct.
        sets.push(format!("initial.rate_deg_s={rate:e}"));
        sets.push("map.orbits=false".into());
        let spec = super::verdict::subgrid_at(plane, &sets, thin, offset)?;
        let (run, wall_s) = super::verdict::timed(&spec, &engine)?;
        progress(&format!(
            "subgrid from {offset}: {} cells in {wall_s:.0} s",
            run.results.len()
        ));
        runs.push(NudgedRun {
            offset,
            regime: run.results.iter().map(|r| r.regime.code()).collect(),
            period: run.results.iter().map(|r| r.period).collect(),
            wall_s,
        });
    }
    Ok(NudgedReport {
        plane,
        thin,
        nudge_deg_s: NUDGE_DEG_S,
        rate_deg_s: rate,
        duration_s: long,
        runs,
    })
}

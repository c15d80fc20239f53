//! The converged reference of the verdict study (`bench --verdict`): each cell run twice,
//! long and twice as long, and the verdicts of the cells both runs decide alike. The
//! settling study scores against it too.

use serde::Serialize;

/// The converged reference.
#[derive(Debug, Clone, Serialize)]
pub struct Reference {
    /// The two run lengths (s).
    pub durations_s: [f64; 2],
    /// Wall time of both (s).
    pub wall_s: f64,
    /// Cells whose verdict changes when the run doubles.
    pub changed: usize,
    /// Cells whose verdict or period changes when the shorter run's tolerances are divided by
    /// ten (`None`: not checked on this subgrid).
    pub tightened: Option<usize>,
    /// The relative tolerance of the runs' adaptive steps.
    pub rtol: f64,
    /// Cells decided alike by both runs.
    pub settled: usize,
    /// Cells.
    pub cells: usize,
    /// The longer run's verdict per cell (code of `regime.npy`).
    pub regime: Vec<i8>,
    /// The longer run's period per cell.
    pub period: Vec<f64>,
    /// Whether a cell is settled (both runs reach the same decided verdict).
    pub is_settled: Vec<bool>,
    /// The time the longer run's early stop stopped each cell at (s; NaN: it ran to its end).
    pub stop_s: Vec<f64>,
    /// Verdict counts of the longer run, in code order (failed … chaotic).
    pub counts: [usize; 5],
}

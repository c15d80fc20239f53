//! The converged reference of the verdict study (`pendulum-atlas-lab verdict`): each cell run twice,
//! long and twice as long, and the verdicts of the cells both runs decide alike. The
//! settling study scores against it too. A study may keep the references of an earlier study
//! of the same plane (`super::kept`, `pendulum-atlas-lab verdict --reference-from DIR`): they
//! depend only on the plane and the reference's settings, not on the map's.

use serde::{Deserialize, Deserializer, Serialize};

/// The converged reference.
#[derive(Debug, Clone, Serialize, Deserialize)]
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
    #[serde(deserialize_with = "nan_for_null")]
    pub period: Vec<f64>,
    /// Whether a cell is settled (both runs reach the same decided verdict). Empty in a
    /// study that predates the flags (`super::kept::recover_settled` recovers them).
    #[serde(default)]
    pub is_settled: Vec<bool>,
    /// The time the longer run's early stop stopped each cell at (s; NaN: it ran to its end).
    #[serde(deserialize_with = "nan_for_null")]
    pub stop_s: Vec<f64>,
    /// Verdict counts of the longer run, in code order (failed … chaotic).
    pub counts: [usize; 5],
}

/// JSON writes NaN as `null`: read it back as NaN.
fn nan_for_null<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let v: Vec<Option<f64>> = Deserialize::deserialize(d)?;
    Ok(v.into_iter().map(|x| x.unwrap_or(f64::NAN)).collect())
}

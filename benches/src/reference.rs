//! The converged reference of the verdict study (`pendulum-atlas-lab verdict`): each cell run twice,
//! long and twice as long, and the verdicts of the cells both runs decide alike. The
//! settling study scores against it too. A study may keep the references of an earlier study
//! of the same plane ([`kept_references`], `pendulum-atlas-lab verdict --reference-from DIR`): they depend
//! only on the plane and the reference's settings, not on the map's.

use super::verdict::{Plane, REFERENCE_RTOL};
use serde::{Deserialize, Deserializer, Serialize};
use std::path::Path;
use thiserror::Error;

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
    /// study that predates the flags ([`super::verdict::recover_settled`] recovers them).
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

/// Why an earlier study's references cannot be kept.
#[derive(Debug, Error)]
pub enum KeptError {
    /// Its `verdict.json` could not be read.
    #[error("cannot read `{path}`: {source}")]
    Read {
        /// The file.
        path: String,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// It is not a verdict study of this version.
    #[error("`{path}` is not a verdict study of this version ({reason})")]
    Parse {
        /// The file.
        path: String,
        /// What is missing or wrong.
        reason: String,
    },
    /// Its shorter run, run again to recover the settled flags, did not reproduce its counts.
    #[error(
        "`{path}`'s shorter reference run does not reproduce: {changed} cells change on doubling and {settled} are settled, the study says {stored_changed} and {stored_settled}"
    )]
    NotReproduced {
        /// The file.
        path: String,
        /// Cells that change on doubling, now.
        changed: usize,
        /// Settled cells, now.
        settled: usize,
        /// Cells that changed, as stored.
        stored_changed: usize,
        /// Settled cells, as stored.
        stored_settled: usize,
    },
    /// The run that recovers the settled flags failed.
    #[error(transparent)]
    Engine(#[from] pendulum_atlas_core::engine::EngineError),
    /// It was made on another plane, subgrid or reference setting.
    #[error("`{path}` cannot serve this study: {reason}")]
    Mismatch {
        /// The file.
        path: String,
        /// What differs.
        reason: String,
    },
}

#[derive(Deserialize)]
struct StoredReferences {
    plane: Plane,
    thin: usize,
    reference: Reference,
    second: Reference,
}

/// The references (subgrids A and B) of the study in `dir` (its `verdict.json`), checked to be
/// of `plane`, thinned by `thin`, at today's [`REFERENCE_RTOL`], with `durations_s`.
pub fn kept_references(
    dir: &Path,
    plane: Plane,
    thin: usize,
    durations_s: [f64; 2],
) -> Result<(Reference, Reference), KeptError> {
    let path = dir.join("verdict.json");
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(&path).map_err(|source| KeptError::Read {
        path: shown.clone(),
        source,
    })?;
    let s: StoredReferences = serde_json::from_str(&text).map_err(|e| KeptError::Parse {
        path: shown.clone(),
        reason: e.to_string(),
    })?;
    let mismatch = |reason: String| KeptError::Mismatch {
        path: shown.clone(),
        reason,
    };
    if s.plane != plane {
        return Err(mismatch(format!(
            "its plane is `{}`, this study's `{}`",
            s.plane.name(),
            plane.name()
        )));
    }
    if s.thin != thin {
        return Err(mismatch(format!(
            "its subgrid takes every {}th value, this study's every {thin}th (--quick on one \
             and not the other)",
            s.thin
        )));
    }
    for r in [&s.reference, &s.second] {
        if r.rtol != REFERENCE_RTOL || r.durations_s != durations_s {
            return Err(mismatch(format!(
                "its reference ran {:?} s at rtol {:e}, this version's {durations_s:?} s at {REFERENCE_RTOL:e}",
                r.durations_s, r.rtol
            )));
        }
    }
    Ok((s.reference, s.second))
}

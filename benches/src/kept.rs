//! References kept from an earlier study of the same plane (`pendulum-atlas-lab verdict
//! --reference-from DIR`): read back and checked ([`kept_references`]), their settled flags
//! recovered where the study predates them ([`recover_settled`]).

use super::reference::Reference;
use super::study_file::{StudyFileError, read_study};
use super::verdict::{
    Plane, REFERENCE_ATOL, REFERENCE_RTOL, decided, reference_sets, subgrid_at, timed,
};
use pendulum_atlas_core::engine::{Engine, Precision};
use serde::Deserialize;
use std::path::Path;
use thiserror::Error;

/// Why an earlier study's references cannot be kept.
#[derive(Debug, Error)]
pub enum KeptError {
    /// Its `verdict.json` could not be read back.
    #[error(transparent)]
    Study(#[from] StudyFileError),
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
    let (s, shown): (StoredReferences, _) = read_study(dir)?;
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

/// The settled flags of a kept reference (of the subgrid from `offset`) from a study that
/// predates them: its shorter run again (CPU f64, deterministic), the flags from it and the
/// stored longer run's verdicts. It must reproduce the stored counts of cells that change on
/// doubling and of settled cells. Returns whether it ran.
pub fn recover_settled(
    (plane, thin, offset): (Plane, usize, usize),
    r: &mut Reference,
    from: &str,
) -> Result<bool, KeptError> {
    if r.is_settled.len() == r.cells {
        return Ok(false);
    }
    let sets = reference_sets(r.durations_s[0], r.rtol, REFERENCE_ATOL);
    let spec = subgrid_at(plane, &sets, thin, offset)?;
    let (short, _) = timed(&spec, &Engine::cpu(Precision::F64))?;
    let pairs = || short.results.iter().zip(&r.regime);
    let is_settled: Vec<bool> = pairs()
        .map(|(x, &y)| decided(y) && x.regime.code() == y)
        .collect();
    let changed = pairs().filter(|(x, y)| x.regime.code() != **y).count();
    let settled = is_settled.iter().filter(|s| **s).count();
    if (changed, settled) != (r.changed, r.settled) {
        return Err(KeptError::NotReproduced {
            path: from.to_string(),
            changed,
            settled,
            stored_changed: r.changed,
            stored_settled: r.settled,
        });
    }
    r.is_settled = is_settled;
    Ok(true)
}

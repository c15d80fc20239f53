//! What can stop `reproduce`, each variant naming the case or file involved.

use pendulum_atlas_core::analysis::AnalysisError;
use pendulum_atlas_core::config::ConfigError;
use thiserror::Error;

/// Everything that can go wrong while reproducing the paper.
#[derive(Debug, Error)]
pub enum ReproduceError {
    /// A case's scene (embedded from `configs/paper/`, plus the `--quick` overrides) is invalid.
    #[error("scene of case `{case}` is invalid: {source}")]
    Scene {
        /// Case identifier, e.g. `table2_A09_f08`.
        case: String,
        /// What the validator found.
        source: ConfigError,
    },
    /// A simulation did not reach its end with a finite, bounded state.
    #[error(
        "case `{case}` stopped with status `{status}` at t = {at_s:.4} s: its indicators would be meaningless (try a smaller integration.dt_safety in configs/paper/{case}.toml)"
    )]
    Failed {
        /// Case identifier.
        case: String,
        /// `diverged` or `non-finite`.
        status: pendulum_atlas_core::model::Status,
        /// Simulated time at which the failure was detected (s).
        at_s: f64,
    },
    /// An indicator could not be computed from a case's record (too short a run, ...).
    #[error("analysis of case `{case}` failed ({what}): {source}")]
    Analysis {
        /// Case identifier.
        case: String,
        /// Which indicator.
        what: &'static str,
        /// The analysis error.
        source: AnalysisError,
    },
    /// A case's map from several starts (the basins) could not run.
    #[error("the basins of case `{case}` could not be computed: {reason}")]
    Basins {
        /// Case identifier.
        case: String,
        /// What the map engine said.
        reason: String,
    },
    /// A file or folder could not be written.
    #[error("cannot write `{path}`: {source}")]
    Io {
        /// Path involved.
        path: String,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// A file or figure could not be written.
    #[error(transparent)]
    Output(#[from] pendulum_atlas_map::output::OutputError),
}

impl ReproduceError {
    /// An I/O error on `path`.
    pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        ReproduceError::Io {
            path: path.display().to_string(),
            source,
        }
    }

    /// An analysis error of `case` while computing `what`.
    pub(crate) fn analysis(case: &str, what: &'static str, source: AnalysisError) -> Self {
        ReproduceError::Analysis {
            case: case.to_string(),
            what,
            source,
        }
    }
}

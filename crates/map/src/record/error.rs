//! Why a record cannot be read.

use pendulum_atlas_core::analysis::AnalysisError;

/// Why a record file gives no uniformly sampled signal. Each names the file.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file itself: missing, not a regular file, too large, empty, no data rows.
    #[error("{path}: {reason}")]
    File {
        /// The file.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The header: a wanted column missing, a name given twice.
    #[error("{path}: {reason}")]
    Header {
        /// The file.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A cell of a wanted column: not a number, not finite, a malformed row.
    #[error("{path}: line {line}, column `{column}`: {reason}")]
    Cell {
        /// The file.
        path: String,
        /// The file's line.
        line: u64,
        /// The column.
        column: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The time axis: not increasing, not uniform, gaps.
    #[error("{at}: {reason}")]
    TimeAxis {
        /// The file and its time column.
        at: String,
        /// What is wrong with it.
        reason: String,
    },
    /// Neither a time column nor a sample rate was given.
    #[error("give the time column (--time COL) or the sample rate (--sample-rate-hz F)")]
    NoTimeAxis,
    /// The resampling failed.
    #[error(transparent)]
    Analysis(#[from] AnalysisError),
}

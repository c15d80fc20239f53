//! Measured records: a CSV file's columns made into a uniformly sampled signal (and reference)
//! that the analysis takes (`pendulum-atlas analyze`, `docs/analysis.md`, "Records").
//!
//! Stages, in order:
//! 1. [`Table::read`] (`table.rs`): the header and the wanted columns, every cell a finite
//!    number, every error naming the file, the line and the column.
//! 2. [`read_record`] (`uniform.rs`): the time axis, from a time column (uniform within
//!    [`UNIFORM_STEP_REL_TOL`] of its median step, or resampled linearly at the median rate,
//!    gaps longer than [`GAP_MEDIAN_STEPS`] median steps refused unless allowed) or from a
//!    sample rate.
//!
//! [`GAP_MEDIAN_STEPS`]: pendulum_atlas_core::analysis::GAP_MEDIAN_STEPS

mod error;
mod table;
mod uniform;

pub use error::RecordError;
pub use table::Table;
pub use uniform::{Record, RecordSource, TimeAxis, UNIFORM_STEP_REL_TOL, read_record};

//! What leaves the program: trajectories as CSV, arrays as `.npy`, maps and their pictures,
//! every file written whole or not at all ([`files`]).

#[cfg(feature = "pictures")]
pub mod analysis;
pub mod budget;
pub mod earlier;
mod error;
pub mod files;
pub mod folder;
mod held;
pub mod manifest;
pub mod map;
pub mod npy;
pub mod process;
#[cfg(feature = "pictures")]
pub mod run_analysis;
mod run_report;
mod trajectory;

pub use error::OutputError;
pub use run_report::{RunFacts, RunReport, record_analysis, run_warnings};
pub use trajectory::{
    BASE_COLUMNS, PIEZO_COLUMNS, ROW_COLUMNS, Row, RowColumn, TrajectoryRecorder, row_columns,
    write_trajectory_csv,
};

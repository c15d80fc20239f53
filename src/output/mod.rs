//! What leaves the program: trajectories as CSV, arrays as `.npy`, maps and their pictures,
//! every file written whole or not at all ([`files`]).

pub mod budget;
mod error;
pub mod files;
pub mod folder;
pub mod map;
pub mod npy;
mod trajectory;

pub use error::OutputError;
pub use trajectory::{BASE_COLUMNS, PIEZO_COLUMNS, Row, TrajectoryRecorder, write_trajectory_csv};

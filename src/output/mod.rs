//! What leaves the program: trajectories as CSV, arrays as `.npy`.

pub mod map;
pub mod npy;
mod trajectory;

pub use trajectory::{BASE_COLUMNS, PIEZO_COLUMNS, Row, TrajectoryRecorder, write_trajectory_csv};

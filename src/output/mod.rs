//! What leaves the program: trajectories as CSV, run metadata as JSON.

mod trajectory;

pub use trajectory::{
    BASE_COLUMNS, PIEZO_COLUMNS, Row, TrajectoryRecorder, write_trajectory_csv,
};

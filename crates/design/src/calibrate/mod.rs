//! `calibrate`: which values of the unknown parameters reproduce what was observed.
//!
//! The stages, in the order a calibration runs them:
//!
//! 1. [`spec`]: a scene plus a `[calibrate]` section, validated into a
//!    [`CalibrationSpec`]: the unknowns (scene keys with ranges, like map axes), the cases
//!    (scene overrides, each with its observations) and how many initial states judge a case.
//! 2. `observe`: the observations (K class or value, R, period, hops, α range) and how a
//!    case's runs are judged against each: a distance in units of its tolerance, matched when
//!    the agreement share of the runs match.
//! 3. [`run`]: the coarse grid of candidates, then refinement around the best, each stage one
//!    ensemble of candidates × cases × initial states on the engine, ranked by observations
//!    matched, then by distance.
//! 4. [`files`]: `candidates.csv`, `best_scene.toml`, `REPORT.md`, `calibrate.json`.

pub mod files;
pub(crate) mod observe;
pub mod run;
pub mod spec;

pub use files::{CalibrateManifest, write_calibration};
pub use observe::{Judgement, Observation, judge};
pub use run::{CalibrateError, CalibrationRun, Candidate, grid_points, run_calibration};
pub use spec::{CalibrationSpec, Case, Refine, Unknown, calibration_from_toml, load_calibration};

//! pendulum-atlas-design: what to build and what explains a measurement. Both are stages of
//! their own that read a scene, run ensembles of the core's engines through the map's planner
//! and write their files; the browser explorer reads what they wrote.
//!
//! - [`harvest`]: the broadband-harvesting design search (`pendulum-atlas search`).
//! - [`calibrate`]: which values of the unknown parameters reproduce what was observed
//!   (`pendulum-atlas calibrate`).
//! - [`about`]: what ran a search or a calibration, as its manifest states it.
#![warn(missing_docs)]

pub mod about;
pub mod calibrate;
pub mod harvest;

//! pendulum-atlas-studies: the studies built on maps and single runs. Each is a stage of its
//! own that reads a scene, runs the core's engines (often through a map) and writes its files.
//!
//! - `bench`: work-precision, throughput, stiff-chain, refinement and verdict studies
//!   (`pendulum-atlas bench`).
//! - [`reproduce`]: the paper's cases, figures and report in one call.
//! - [`harvest`]: the broadband-harvesting design search (`pendulum-atlas search`).
//! - [`calibrate`]: which values of the unknown parameters reproduce what was observed.
//! - [`about`]: what ran a study, as its manifest states it.
#![warn(missing_docs)]

pub mod about;
pub mod bench;
pub mod calibrate;
pub mod harvest;
pub mod reproduce;

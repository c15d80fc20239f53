//! pendulum-atlas-studies: the studies a user runs on their own machine, built on maps and
//! single runs. Each is a stage of its own that reads a scene, runs the core's engines (often
//! through a map) and writes its files.
//!
//! - `bench`: work-precision, throughput, stiff-chain and refinement studies
//!   (`pendulum-atlas bench`).
//! - [`reproduce`]: the paper's cases, figures and report in one call.
//!
//! The design search and calibration are in `pendulum-atlas-design`; the studies that fit or
//! check the product (the verdict's references and its fits) are the lab's, in `benches/`.
#![warn(missing_docs)]

pub mod bench;
pub mod reproduce;

//! pendulum-atlas-map: a parameter map from plan to files, on top of the numerical core
//! (`pendulum-atlas-core`).
//!
//! 0. [`machine`]: the memory and disk the machine has, for the size checks of every stage.
//! 1. [`map`]: a map from start to finish: the instances of a `MapSpec` planned and run on an
//!    opened engine (plain, several starts per cell, continuation, adaptive refinement), with
//!    what the pictures need kept.
//! 2. [`shard`]: one map split over several processes or machines, and the merge back into the
//!    files one run writes.
//! 3. [`output`]: what leaves the program: trajectories as CSV, arrays as `.npy`, the map's
//!    folder and manifest, every file written whole or not at all.
//! 4. [`record`]: measured records: a CSV file's columns as a uniformly sampled signal for
//!    the analysis.
//! 5. [`render`]: the PNG pictures (heat maps with axes and colour bars, line charts, panels,
//!    scalograms); behind the `pictures` feature (on by default), with the folder writers
//!    that draw.
#![warn(missing_docs)]

pub mod machine;
pub mod map;
pub mod output;
pub mod record;
#[cfg(feature = "pictures")]
pub mod render;
pub mod shard;

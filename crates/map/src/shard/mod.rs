//! Sharded maps: one map split over several processes or machines (Slurm array tasks), then
//! merged into the files one unsharded run writes.
//!
//! The stages, in the order a sharded map runs them:
//!
//! 1. [`Shard`] (the map planner's `map::shard`): `--shard I/N`: which instances of the grid it integrates. The
//!    partition interleaves (instance `k` belongs to shard `k mod N`), so that neighbouring
//!    cells, which cost alike, spread over all shards and every shard takes about as long.
//! 2. [`files`]: a shard's folder: its results (`shard_results.npy`, full f64, NaN kept), the
//!    stroboscopic tails of a bifurcation diagram, the scene as given (`scene.toml`) and the
//!    manifest `shard.json` (map hash, grid, shard index, engine, timings), written last.
//! 3. [`merge`]: shard folders checked to belong to one map (same hash and grid), every shard
//!    present exactly once, the results put back in grid order as one [`crate::map::MapRun`].
//! 4. [`slurm`]: the sbatch scripts that run the shards as a job array and the merge after it.
//!
//! The **map hash** is the SHA-256 of the resolved map (base scene after `--set`, axes, metrics
//! and sampling), not of the file's text: comments do not matter, any value does.

pub mod files;
pub mod merge;
pub mod slurm;

pub use crate::map::shard::{MAX_SHARDS, Shard, ShardSpecError, map_hash};
pub use files::{ShardData, ShardManifest, read_shard, write_shard};
pub use merge::{MergeError, merge_shards};
pub use slurm::{SlurmJob, SlurmSpecError, check_partition, check_time};

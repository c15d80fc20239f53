//! `--shard I/N`: which instances a shard integrates, and the hash that ties shards to a map.

use pendulum_atlas_core::config::MapSpec;
use serde::Serialize;
use sha2::{Digest, Sha256};
use std::str::FromStr;

/// Largest number of shards (a Slurm array is limited to a few thousand tasks anyway).
pub const MAX_SHARDS: u32 = 100_000;

/// Shard `index` of `count` (0-based, as `SLURM_ARRAY_TASK_ID` with `--array=0-(N-1)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Shard {
    /// Index, `0 ≤ index < count`.
    pub index: u32,
    /// Number of shards.
    pub count: u32,
}

/// A `--shard` value that is not `I/N` with `0 ≤ I < N ≤ 100000`.
#[derive(Debug, thiserror::Error)]
#[error(
    "--shard `{0}`: give I/N, the 0-based shard index I of N shards (0 <= I < N <= {MAX_SHARDS}), e.g. 0/4"
)]
pub struct ShardSpecError(pub String);

impl FromStr for Shard {
    type Err = ShardSpecError;

    fn from_str(s: &str) -> Result<Shard, ShardSpecError> {
        let bad = || ShardSpecError(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: u32 = i.trim().parse().map_err(|_| bad())?;
        let count: u32 = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || count > MAX_SHARDS || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl Shard {
    /// The instances of a grid of `instances` this shard integrates: `index, index + count, …`
    /// (interleaved, so that every shard gets cells from the whole grid).
    pub fn members(self, instances: usize) -> Vec<usize> {
        (self.index as usize..instances)
            .step_by(self.count as usize)
            .collect()
    }
}

/// SHA-256 (hex) of the resolved map: the base scene table after overrides and the validated
/// map settings, so that two shards of one map agree and a changed value does not.
pub fn map_hash(spec: &MapSpec) -> String {
    let mut h = Sha256::new();
    h.update(
        toml::to_string(&spec.base_table)
            .unwrap_or_default()
            .as_bytes(),
    );
    h.update(b"\0");
    h.update(serde_json::to_string(spec).unwrap_or_default().as_bytes());
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_parse_and_interleave_to_cover_the_grid_once() {
        let s: Shard = "1/3".parse().unwrap();
        assert_eq!(s, Shard { index: 1, count: 3 });
        assert_eq!(s.members(8), vec![1, 4, 7]);
        let mut all: Vec<usize> = (0..3)
            .flat_map(|i| Shard { index: i, count: 3 }.members(8))
            .collect();
        all.sort();
        assert_eq!(all, (0..8).collect::<Vec<_>>());
        for bad in ["3/3", "1", "-1/3", "1/0", "a/b", "0/100001"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}

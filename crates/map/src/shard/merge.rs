//! Shards back into one map: checked to be the parts of one map, each present exactly once,
//! their results put back in grid order.

use super::files::{ShardData, ShardReadError, read_shard};
use crate::map::shard::map_hash;
use crate::map::{MapPart, MapRun, assemble};
use pendulum_atlas_core::config::{ConfigError, MapSpec, map_from_toml};
use pendulum_atlas_core::engine::{EngineError, EngineKind, EnsemblePlan};
use pendulum_atlas_core::reduce::RowRule;
use std::path::PathBuf;

/// Why shards do not make one map.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// No folder given.
    #[error("no shard folder given")]
    Empty,
    /// A folder is not a readable shard.
    #[error(transparent)]
    Read(#[from] ShardReadError),
    /// Shards of different maps (or grids, or shard counts).
    #[error(
        "`{dir}` is not a shard of the same map as `{first}`: {what} differs ({theirs} against {ours})"
    )]
    Foreign {
        /// The odd shard.
        dir: String,
        /// The first shard.
        first: String,
        /// What differs.
        what: &'static str,
        /// Its value.
        theirs: String,
        /// The first shard's value.
        ours: String,
    },
    /// Shard indices given more than once.
    #[error("{} of {count} shards are given more than once: {}; merge one folder per shard", .duplicates.len(), .duplicates.iter().map(|(i, d)| format!("shard {i} in {d}")).collect::<Vec<_>>().join("; "))]
    Duplicate {
        /// Each duplicated index with the folders holding it.
        duplicates: Vec<(u32, String)>,
        /// Number of shards.
        count: u32,
    },
    /// Shards missing.
    #[error("{n} of {count} shards are missing: {list}; run each with `map ... --shard I/{count}` and merge again", n = missing.len(), list = index_list(missing))]
    Missing {
        /// Their indices.
        missing: Vec<u32>,
        /// Number of shards.
        count: u32,
    },
    /// A shard row that no engine could have written.
    #[error(
        "`{dir}`: the row of instance {instance} cannot be a result: {reason}; rerun that shard"
    )]
    BadRow {
        /// The shard folder.
        dir: String,
        /// The row's instance.
        instance: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// A manifest field no run could have written, or counts that do not add up.
    #[error("`{dir}`: shard.json's {field} {reason}; rerun that shard")]
    BadManifest {
        /// The shard folder.
        dir: String,
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The stored scene does not read back.
    #[error("the scene stored in `{dir}` no longer reads: {source}")]
    Scene {
        /// The shard folder.
        dir: String,
        /// Why.
        source: ConfigError,
    },
    /// The stored scene reads, but as another map than the one the shards ran.
    #[error(
        "the scene stored in `{0}` does not give the map its shards ran (another map hash); was it edited?"
    )]
    SceneChanged(String),
    /// A shard's rows are not the instances its index stands for.
    #[error(
        "`{0}`: its rows are not the instances of its shard index (the files were altered); rerun that shard"
    )]
    Corrupt(String),
    /// Re-planning the map failed.
    #[error(transparent)]
    Plan(#[from] EngineError),
}

fn index_list(v: &[u32]) -> String {
    let shown: Vec<String> = v.iter().take(20).map(u32::to_string).collect();
    let more = if v.len() > 20 {
        format!(" and {} more", v.len() - 20)
    } else {
        String::new()
    };
    format!("{}{more}", shown.join(", "))
}

/// A merged map: its spec and the run one unsharded run would have given.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The map.
    pub spec: MapSpec,
    /// Its results in grid order, with the list of shards.
    pub run: MapRun,
}

/// Read and merge the shard folders `dirs` (in any order).
pub fn merge_shards(dirs: &[PathBuf]) -> Result<Merged, MergeError> {
    let shards: Vec<ShardData> = dirs
        .iter()
        .map(|d| read_shard(d))
        .collect::<Result<_, _>>()?;
    let first = shards.first().ok_or(MergeError::Empty)?;
    for s in &shards[1..] {
        same_map(first, s)?;
    }
    check_coverage(&shards)?;
    let spec = map_from_toml(
        &first.scene_text,
        &first.dir.join("scene.toml").display().to_string(),
        &first.manifest.sets,
    )
    .map_err(|source| MergeError::Scene {
        dir: first.dir.display().to_string(),
        source,
    })?;
    if map_hash(&spec) != first.manifest.map_hash {
        return Err(MergeError::SceneChanged(first.dir.display().to_string()));
    }
    let plan = EnsemblePlan::new(&spec)?;
    for s in &shards {
        check_rows(s, &spec, &plan)?;
        check_manifest(s, &spec, &plan)?;
    }
    check_sums(&shards)?;
    let mut run = assemble(plan, shards.iter().map(part).collect());
    crate::map::confidence::fill_run(&spec.shape(), &mut run);
    Ok(Merged { spec, run })
}

/// Every row of shard `s` names an instance of the grid and obeys the rules of the engines'
/// own results, its verdict re-derived from its own numbers
/// ([`pendulum_atlas_core::reduce::InstanceResult::check_rule`]).
fn check_rows(s: &ShardData, spec: &MapSpec, plan: &EnsemblePlan) -> Result<(), MergeError> {
    let bad = |instance: usize, reason: String| MergeError::BadRow {
        dir: s.dir.display().to_string(),
        instance,
        reason,
    };
    for (&k, r) in s.members.iter().zip(&s.results) {
        if k >= spec.instances() {
            return Err(bad(
                k,
                format!("the grid has {} instances", spec.instances()),
            ));
        }
        let p = &plan.instances[k];
        let rule = RowRule {
            period_max: spec.period_max,
            period_s: 1.0 / p.frequency_hz,
            k_samples: p.strobe_count,
            exact_verdict: s.manifest.engine.kind == EngineKind::Cpu,
        };
        r.check_rule(&spec.metrics, &rule)
            .map_err(|reason| bad(k, reason))?;
    }
    let ok = s.results.iter().map(|r| r.status.is_ok());
    for ((&k, y), ok) in s.members.iter().zip(&s.final_state).zip(ok) {
        let want = plan.instances[k].y0.len();
        if ok && (y.len() != want || y.iter().any(|v| !v.is_finite())) {
            return Err(bad(
                k,
                format!(
                    "its final state has {} finite values of the {want} its state holds",
                    y.iter().filter(|v| v.is_finite()).count()
                ),
            ));
        }
    }
    Ok(())
}

/// The longest time a manifest may report for a stage (s): about 31 years.
const MAX_STAGE_S: f64 = 1e9;

/// Every numeric field of shard `s`'s manifest within what its run could have written: each
/// time finite, from 0 to [`MAX_STAGE_S`]; at most one early stop per member; sub-steps
/// (adaptive maps only) at least one per base step its rows integrated; a bifurcation tail
/// only where the map draws one, and no longer than it keeps.
fn check_manifest(s: &ShardData, spec: &MapSpec, plan: &EnsemblePlan) -> Result<(), MergeError> {
    let m = &s.manifest;
    let bad = |field: &'static str, reason: String| MergeError::BadManifest {
        dir: s.dir.display().to_string(),
        field,
        reason,
    };
    let mut times = Vec::new();
    numbers(
        &serde_json::to_value(&m.timings_s).unwrap_or_default(),
        &mut times,
    );
    if let Some(t) = times.iter().find(|t| !(0.0..=MAX_STAGE_S).contains(*t)) {
        let t = pendulum_atlas_core::text::num(*t);
        return Err(bad(
            "timings_s",
            format!("holds {t}, not a time from 0 to 1e9 s"),
        ));
    }
    if m.stopped_early > m.members {
        let n = m.stopped_early;
        return Err(bad(
            "stopped_early",
            format!("is {n}, more than its {} members", m.members),
        ));
    }
    let base_steps = s
        .results
        .iter()
        .try_fold(0u64, |a, r| a.checked_add(r.steps));
    match (plan.is_adaptive(), m.sub_steps, base_steps) {
        (true, Some(n), Some(b)) if n < b => Err(bad(
            "sub_steps",
            format!("is {n}, fewer than the {b} base steps its rows integrated"),
        )),
        (true, None, _) => Err(bad(
            "sub_steps",
            "is missing for a map of adaptive steps".into(),
        )),
        (false, Some(n), _) => Err(bad("sub_steps", format!("is {n} for a map of fixed steps"))),
        _ => Ok(()),
    }?;
    let keep = if spec.bifurcation {
        spec.bifurcation_samples as usize
    } else {
        0
    };
    if m.strobe_tail > keep {
        let n = m.strobe_tail;
        return Err(bad(
            "strobe_tail",
            format!("is {n}, more than the {keep} samples this map keeps"),
        ));
    }
    Ok(())
}

/// Every number in `v`, depth first.
fn numbers(v: &serde_json::Value, out: &mut Vec<f64>) {
    match v {
        serde_json::Value::Number(n) => out.extend(n.as_f64()),
        serde_json::Value::Array(a) => a.iter().for_each(|x| numbers(x, out)),
        serde_json::Value::Object(o) => o.values().for_each(|x| numbers(x, out)),
        _ => {}
    }
}

/// The shards' counts added without wrapping: dispatches within a `u32`, sub-steps within a
/// `u64` (the merged map's `map.json` reports both).
fn check_sums(shards: &[ShardData]) -> Result<(), MergeError> {
    let overflow = |field: &'static str| {
        MergeError::BadManifest {
        dir: shards.iter().map(|s| s.dir.display().to_string()).collect::<Vec<_>>().join(", "),
        field,
        reason: "values add up beyond what the count holds (2^32 dispatches, 2^64 sub-steps) across these shards".into(),
    }
    };
    shards
        .iter()
        .try_fold(0u32, |a, s| a.checked_add(s.manifest.dispatches))
        .ok_or_else(|| overflow("dispatches"))?;
    shards
        .iter()
        .try_fold(0u64, |a, s| {
            a.checked_add(s.manifest.sub_steps.unwrap_or(0))
        })
        .ok_or_else(|| overflow("sub_steps"))?;
    Ok(())
}

/// `b` is a shard of the same map as `a`, from the same engine and version.
fn same_map(a: &ShardData, b: &ShardData) -> Result<(), MergeError> {
    let (ma, mb) = (&a.manifest, &b.manifest);
    let checks: [(&'static str, String, String); 5] = [
        ("the map hash", mb.map_hash.clone(), ma.map_hash.clone()),
        (
            "the grid shape",
            pendulum_atlas_core::text::shape(&mb.shape),
            pendulum_atlas_core::text::shape(&ma.shape),
        ),
        (
            "the shard count",
            mb.shard.count.to_string(),
            ma.shard.count.to_string(),
        ),
        (
            "the engine",
            format!("{} {}", mb.engine.kind.name(), mb.engine.precision.name()),
            format!("{} {}", ma.engine.kind.name(), ma.engine.precision.name()),
        ),
        (
            "the pendulum-atlas version",
            mb.version.clone(),
            ma.version.clone(),
        ),
    ];
    for (what, theirs, ours) in checks {
        if theirs != ours {
            return Err(MergeError::Foreign {
                dir: b.dir.display().to_string(),
                first: a.dir.display().to_string(),
                what,
                theirs,
                ours,
            });
        }
    }
    Ok(())
}

/// Every shard index exactly once.
fn check_coverage(shards: &[ShardData]) -> Result<(), MergeError> {
    let count = shards[0].manifest.shard.count;
    let mut holders: Vec<Vec<String>> = vec![Vec::new(); count as usize];
    for s in shards {
        holders[s.manifest.shard.index as usize].push(s.dir.display().to_string());
    }
    let duplicates: Vec<(u32, String)> = holders
        .iter()
        .enumerate()
        .filter(|(_, d)| d.len() > 1)
        .map(|(i, d)| (i as u32, d.join(", ")))
        .collect();
    if !duplicates.is_empty() {
        return Err(MergeError::Duplicate { duplicates, count });
    }
    let missing: Vec<u32> = (0..count)
        .filter(|&i| holders[i as usize].is_empty())
        .collect();
    if let Some(s) = shards
        .iter()
        .find(|s| s.members != s.manifest.shard.members(s.manifest.instances))
    {
        return Err(MergeError::Corrupt(s.dir.display().to_string()));
    }
    if !missing.is_empty() {
        return Err(MergeError::Missing { missing, count });
    }
    Ok(())
}

/// A shard read back as a part of its map.
fn part(s: &ShardData) -> MapPart {
    MapPart {
        shard: s.manifest.shard,
        label: s.dir.display().to_string(),
        members: s.members.clone(),
        results: s.results.clone(),
        strobe_tail: s.strobe_tail.clone(),
        engine: s.manifest.engine.clone(),
        timings: s.manifest.timings_s.clone(),
        dispatches: s.manifest.dispatches,
        stopped_early: s.manifest.stopped_early,
        sub_steps: s.manifest.sub_steps,
        final_state: s.final_state.clone(),
    }
}

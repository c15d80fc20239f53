//! A shard's folder: what it integrated, bit for bit, and the manifest that says which map
//! and which part of it.
//!
//! - `shard_results.npy`: float64, one row per member instance; its columns are named in
//!   `shard.json` (`columns`): the grid index, then every row of the result schema
//!   ([`shard_columns`]; codes and counts as numbers, NaN kept as NaN), read back by name;
//! - `shard_strobe.npy`: float64, one row per member, the stroboscopic tail of a bifurcation
//!   diagram (only when the map draws one);
//! - `shard_state.npy`: float64, one row per member, its state at the end of its run (only
//!   when the map settles: `merge` continues the cells that are not firm from there; rows
//!   of a grid whose state lengths differ are padded with NaN);
//! - `scene.toml`: the map scene as given (the `--set` overrides are in the manifest);
//! - `shard.json`: the manifest, written last.

use crate::map::shard::{Shard, map_hash};
use crate::map::{MapRun, MapTimings};
use crate::output::OutputError;
use crate::output::files::{create_dir, write_bytes, write_json};
use crate::output::npy::{read_npy, write_npy_f64};
use pendulum_atlas_core::config::MapSpec;
use pendulum_atlas_core::engine::EngineInfo;
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::reduce::InstanceResult;
use pendulum_atlas_core::schema::FIELDS;
use pendulum_atlas_core::text::num;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The grid index's column of `shard_results.npy`.
const INDEX: &str = "index";

/// The columns of `shard_results.npy`, in the order written: the grid index, then every
/// result of the schema ([`FIELDS`]).
pub fn shard_columns() -> Vec<&'static str> {
    std::iter::once(INDEX)
        .chain(FIELDS.iter().map(|f| f.name))
        .collect()
}

/// `shard.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ShardManifest {
    /// The pendulum-atlas version that wrote it.
    pub version: String,
    /// SHA-256 of the resolved map ([`map_hash`]).
    pub map_hash: String,
    /// Which shard.
    pub shard: Shard,
    /// Grid shape.
    pub shape: Vec<usize>,
    /// Instances of the whole grid.
    pub instances: usize,
    /// Instances of this shard.
    pub members: usize,
    /// The `--set` overrides the map was read with.
    pub sets: Vec<String>,
    /// The engine that ran it.
    pub engine: EngineInfo,
    /// Wall time per stage (s).
    pub timings_s: MapTimings,
    /// Integration dispatches (GPU).
    pub dispatches: u32,
    /// Instances stopped early.
    pub stopped_early: usize,
    /// Sub-steps tried (adaptive steps; absent at fixed steps and from shards of earlier
    /// versions).
    #[serde(default)]
    pub sub_steps: Option<u64>,
    /// Stroboscopic samples kept per instance for the bifurcation diagram (0: none).
    pub strobe_tail: usize,
    /// Width of `shard_state.npy`'s rows (0: no final states, the map does not settle).
    #[serde(default)]
    pub final_state: usize,
    /// The columns of `shard_results.npy`, by name ([`shard_columns`]).
    pub columns: Vec<String>,
    /// SHA-256 of the shard's values (`shard_results.npy`, `shard_strobe.npy`, then
    /// `shard_state.npy`) as
    /// little-endian f64 ([`values_sha256`], hex in either case): `merge` refuses a shard
    /// whose files no longer hold what its run wrote. It detects damage, not tampering: who
    /// edits the values can write their hash too, so `merge` also holds every row and count
    /// to the rules of the engines' results.
    pub values_sha256: String,
}

/// SHA-256 (hex) of `parts`' values as little-endian f64, one after another.
pub fn values_sha256(parts: &[&[f64]]) -> String {
    use sha2::{Digest, Sha256};
    let mut h = Sha256::new();
    for part in parts {
        for v in *part {
            h.update(v.to_le_bytes());
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

impl crate::output::manifest::Manifest for ShardManifest {
    const NAME: &'static str = "shard.json";
}

impl<'de> Deserialize<'de> for Shard {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Shard, D::Error> {
        #[derive(Deserialize)]
        struct Raw {
            index: u32,
            count: u32,
        }
        let r = Raw::deserialize(d)?;
        format!("{}/{}", r.index, r.count).parse().map_err(|_| {
            serde::de::Error::custom(format!(
                "shard index {} of {} shards: the index must be below the count, and the count from 1 to {}",
                r.index,
                r.count,
                crate::map::shard::MAX_SHARDS
            ))
        })
    }
}

/// A shard read back.
#[derive(Debug, Clone)]
pub struct ShardData {
    /// Its folder.
    pub dir: PathBuf,
    /// Its manifest.
    pub manifest: ShardManifest,
    /// The scene text it was run from.
    pub scene_text: String,
    /// Grid index of each result.
    pub members: Vec<usize>,
    /// The results, in member order.
    pub results: Vec<InstanceResult>,
    /// Stroboscopic tails, in member order (empty without a bifurcation diagram).
    pub strobe_tail: Vec<Vec<f64>>,
    /// Final states, in member order (empty where the map does not settle).
    pub final_state: Vec<Vec<f64>>,
}

/// A result's row of `shard_results.npy`: its grid index, then every field of the schema.
fn row(index: usize, r: &InstanceResult) -> impl Iterator<Item = f64> + '_ {
    std::iter::once(index as f64).chain(FIELDS.iter().map(|f| (f.get)(r)))
}

/// Write shard `shard` of `spec` (its results `run`, for the instances `members`) into `dir`;
/// `shard.json` last. Returns the files written.
pub fn write_shard(
    dir: &Path,
    spec: &MapSpec,
    scene_text: &str,
    sets: &[String],
    shard: Shard,
    run: &MapRun,
) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    let members = shard.members(spec.instances());
    let data: Vec<f64> = members
        .iter()
        .zip(&run.results)
        .flat_map(|(&k, r)| row(k, r))
        .collect();
    let mut written = Vec::new();
    let p = dir.join("shard_results.npy");
    let columns = shard_columns();
    write_npy_f64(&p, &[members.len(), columns.len()], &data)?;
    written.push(p);
    let tail = run.strobe_tail.first().map_or(0, Vec::len);
    let flat: Vec<f64> = run.strobe_tail.iter().flatten().copied().collect();
    if tail > 0 {
        let p = dir.join("shard_strobe.npy");
        write_npy_f64(&p, &[members.len(), tail], &flat)?;
        written.push(p);
    }
    let (width, state) = padded(&run.final_state);
    if width > 0 {
        let p = dir.join("shard_state.npy");
        write_npy_f64(&p, &[members.len(), width], &state)?;
        written.push(p);
    }
    written.push(write_bytes(&dir.join("scene.toml"), scene_text.as_bytes())?);
    let manifest = ShardManifest {
        version: env!("CARGO_PKG_VERSION").into(),
        map_hash: map_hash(spec),
        shard,
        shape: spec.shape(),
        instances: spec.instances(),
        members: members.len(),
        sets: sets.to_vec(),
        engine: run.engine.clone(),
        timings_s: run.timings.clone(),
        dispatches: run.dispatches,
        stopped_early: run.stopped_early,
        sub_steps: run.sub_steps,
        strobe_tail: tail,
        final_state: width,
        columns: columns.iter().map(|c| c.to_string()).collect(),
        values_sha256: values_sha256(&[&data, &flat, &state]),
    };
    written.push(write_json(&dir.join(SHARD_JSON), &manifest)?);
    Ok(written)
}

/// `rows` as one flat block of rows of the longest one's width, the shorter padded with NaN:
/// `(width, values)`.
fn padded(rows: &[Vec<f64>]) -> (usize, Vec<f64>) {
    let width = rows.iter().map(Vec::len).max().unwrap_or(0);
    let mut flat = Vec::with_capacity(rows.len() * width);
    for r in rows {
        flat.extend_from_slice(r);
        flat.resize(flat.len() + width - r.len(), f64::NAN);
    }
    (width, flat)
}

/// The shard's manifest in its folder.
const SHARD_JSON: &str = <ShardManifest as crate::output::manifest::Manifest>::NAME;

/// Why a shard folder cannot be read.
#[derive(Debug, thiserror::Error)]
#[error("shard folder `{dir}`: {reason}")]
pub struct ShardReadError {
    /// The folder.
    pub dir: String,
    /// What is wrong.
    pub reason: String,
}

/// Read a shard folder written by [`write_shard`].
pub fn read_shard(dir: &Path) -> Result<ShardData, ShardReadError> {
    let fail = |reason: String| ShardReadError {
        dir: dir.display().to_string(),
        reason,
    };
    let text = |name: &str| {
        std::fs::read_to_string(dir.join(name)).map_err(|e| {
            fail(format!(
                "cannot read {name} ({e}); a shard that did not finish has no shard.json: rerun it"
            ))
        })
    };
    let manifest: ShardManifest = serde_json::from_str(&text(SHARD_JSON)?)
        .map_err(|e| fail(pendulum_atlas_core::text::json_damage(SHARD_JSON, &e)))?;
    let scene_text = text("scene.toml")?;
    let (shape, rows) = read_npy(&dir.join("shard_results.npy")).map_err(&fail)?;
    let width = manifest.columns.len();
    if shape != [manifest.members, width] {
        return Err(fail(format!(
            "shard_results.npy has shape {}, the manifest says {} rows of {width}",
            pendulum_atlas_core::text::shape(&shape),
            manifest.members,
        )));
    }
    let at = column_positions(&manifest.columns).map_err(&fail)?;
    let block = |name, width| read_block(dir, name, manifest.members, width).map_err(&fail);
    let strobe = block("shard_strobe.npy", manifest.strobe_tail)?;
    let state = block("shard_state.npy", manifest.final_state)?;
    if !values_sha256(&[&rows, &strobe, &state]).eq_ignore_ascii_case(&manifest.values_sha256) {
        return Err(fail(
            "its values are not those its run wrote (their SHA-256 differs from shard.json's values_sha256): a file was changed or damaged; rerun the shard".into(),
        ));
    }
    let mut members = Vec::with_capacity(manifest.members);
    let mut results = Vec::with_capacity(manifest.members);
    for r in rows.chunks_exact(width.max(1)) {
        let (index, result) = result_of(r, &at).map_err(&fail)?;
        members.push(index);
        results.push(result);
    }
    let strobe_tail = match manifest.strobe_tail {
        0 => Vec::new(),
        k => strobe.chunks_exact(k).map(<[f64]>::to_vec).collect(),
    };
    let final_state = match manifest.final_state {
        0 => Vec::new(),
        k => state.chunks_exact(k).map(unpadded).collect(),
    };
    Ok(ShardData {
        dir: dir.to_path_buf(),
        manifest,
        scene_text,
        members,
        results,
        strobe_tail,
        final_state,
    })
}

/// A row of `shard_state.npy` without its NaN padding.
fn unpadded(row: &[f64]) -> Vec<f64> {
    let end = row.iter().rposition(|v| !v.is_nan()).map_or(0, |i| i + 1);
    row[..end].to_vec()
}

/// The shard's `name` (`shard_strobe.npy`, `shard_state.npy`): `width` values per member,
/// flat (none when it kept none, `width` 0), checked against the manifest's shape.
fn read_block(dir: &Path, name: &str, members: usize, width: usize) -> Result<Vec<f64>, String> {
    if width == 0 {
        return Ok(Vec::new());
    }
    let (shape, flat) = read_npy(&dir.join(name))?;
    if shape != [members, width] {
        return Err(format!(
            "{name} has shape {}, the manifest says {members} × {width}",
            pendulum_atlas_core::text::shape(&shape),
        ));
    }
    Ok(flat)
}

/// Where each column of `shard_results.npy` is: the grid index's, then each schema row's;
/// a shard that lacks one (or names one twice) was written by another version.
fn column_positions(columns: &[String]) -> Result<Vec<usize>, String> {
    let position = |name: &str| {
        let mut at = columns.iter().enumerate().filter(|(_, c)| *c == name);
        match (at.next(), at.next()) {
            (Some((i, _)), None) => Ok(i),
            (None, _) => Err(format!(
                "shard.json names no column `{name}`: it was written by another version of pendulum-atlas; rerun the shard"
            )),
            (Some(_), Some(_)) => Err(format!("shard.json names the column `{name}` twice")),
        }
    };
    shard_columns().into_iter().map(position).collect()
}

/// A shard row as its grid index and result, read by name ([`column_positions`]): the
/// index whole, each code and count one of its type's (the schema's `set`).
fn result_of(r: &[f64], at: &[usize]) -> Result<(usize, InstanceResult), String> {
    let index = r[at[0]];
    if !(index.is_finite()
        && index.fract() == 0.0
        && (0.0..9.007_199_254_740_992e15).contains(&index))
    {
        return Err(format!(
            "a row's index is {}, not a whole number from 0 to 2^53",
            num(index)
        ));
    }
    let mut out = InstanceResult::unset(Status::Ok, 0);
    for (f, &i) in FIELDS.iter().zip(&at[1..]) {
        (f.set)(&mut out, r[i])
            .map_err(|e| format!("row of instance {}: its {} {e}", num(index), f.name))?;
    }
    // The merge's confidence stage fills it: a shard's cells lack some neighbours.
    out.verdict_confidence = f64::NAN;
    Ok((index as usize, out))
}

//! Manifests, typed: each command's manifest is one struct that its writer fills and every
//! reader parses through [`Manifest::read`] (the explorer, merge, the Python package), so that
//! a field is named once and a damaged or foreign file is refused in words. `map.json` is
//! [`MapManifest`] ([`super::map::map_manifest`] fills it); `shard.json`, `run.json`,
//! `analysis.json`, `search.json`, `calibrate.json` and `bench.json` have theirs beside their
//! writers.
//!
//! The fields a reader acts on are typed (axes, shape, engine, counts, files); the blocks that
//! describe the run for people (steps, timings, the verdict's tallies, sampling, refinement,
//! attractors, continuation, the scene) are kept as JSON values as the writer made them.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// The name of the manifest in a map's folder.
pub(crate) const MAP_JSON: &str = "map.json";

/// One axis of the map as `map.json` states it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestAxis {
    /// Dotted scene key.
    pub key: String,
    /// Values along the axis.
    pub values: Vec<f64>,
    /// `linear` or `log`.
    pub scale: String,
    /// Unit read off the key's name (`None` for ratios and counts).
    pub unit: Option<String>,
    /// Label with the unit, for pictures.
    pub label: String,
}

/// The time steps of the map's instances (s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StepRange {
    /// Smallest step.
    pub min: f64,
    /// Largest step.
    pub max: f64,
}

/// `map.json`: what the map is, how it ran, and which files belong to it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapManifest {
    /// The axes, in grid order.
    pub axes: Vec<ManifestAxis>,
    /// Unit of every stored value array, by file stem ("1": dimensionless).
    pub units: BTreeMap<String, String>,
    /// What each stored result is, by file stem (the result schema's descriptions; absent
    /// from maps of earlier versions).
    #[serde(default)]
    pub descriptions: BTreeMap<String, String>,
    /// Shape of the grid (and of every per-cell array).
    pub shape: Vec<usize>,
    /// Cells of the grid.
    pub instances: usize,
    /// How flat indices map onto the grid.
    pub order: String,
    /// How the cells ran: `plain`, `attractors`, `basin`, `continuation` or `refined`
    /// (`MapMode::name`).
    #[serde(default)]
    pub mode: String,
    /// Metrics asked for.
    pub metrics: Vec<String>,
    /// Engine kind (`cpu` or `gpu`).
    pub backend: String,
    /// Why this engine.
    pub backend_reason: String,
    /// The device (adapter name, or the CPU's threads and loop).
    pub adapter: String,
    /// Float type (`f32` or `f64`).
    pub precision: String,
    /// Rigid segments N.
    pub segments: usize,
    /// Integration method (`rk4` or `imex`).
    pub method: String,
    /// Why this method.
    pub method_reason: String,
    /// Distinct IMEX matrix sets the plan factored.
    pub imex_matrix_sets: usize,
    /// Automatic steps of the base scene.
    #[serde(default)]
    pub method_steps_of_base_scene: Value,
    /// Joint damping of the base scene.
    #[serde(default)]
    pub damping_of_base_scene: Value,
    /// Range of the instances' steps.
    pub dt_s: StepRange,
    /// Steps in full, integrated and saved.
    #[serde(default)]
    pub steps: Value,
    /// Wall time per stage (s): planning (`plan_s`), opening the engine, integration,
    /// reductions.
    pub timings_s: Value,
    /// Shares of the wall time per stage.
    #[serde(default)]
    pub wall_share: Value,
    /// Instance and segment steps per second.
    #[serde(default)]
    pub throughput: Value,
    /// Cells per status.
    pub status_counts: BTreeMap<String, usize>,
    /// Code of each status in `status.npy`.
    pub status_codes: BTreeMap<String, u8>,
    /// The verdict's counts and codes (null without the regime).
    #[serde(default)]
    pub regime: Value,
    /// λ1's settings and summary (null without it).
    #[serde(default)]
    pub lyapunov: Value,
    /// How each instance was sampled.
    #[serde(default)]
    pub sampling: Value,
    /// Adaptive refinement's rounds (null without it).
    #[serde(default)]
    pub refine: Value,
    /// The settling stage (`map.settle_max_s`; null without it).
    #[serde(default)]
    pub settle: Value,
    /// The attractor stage (null without several starts).
    #[serde(default)]
    pub attractors: Value,
    /// The continuation (null without it).
    #[serde(default)]
    pub continuation: Value,
    /// The transient stage: what the nudged copies found and how to read its arrays (null
    /// without it).
    #[serde(default)]
    pub transients: Value,
    /// The orbit stage: what it did and how to read its files (null without it).
    pub orbits: Value,
    /// Warnings of the plan.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The shards or devices the map was assembled from (null when run in one piece).
    #[serde(default)]
    pub shards: Value,
    /// The base scene, validated.
    #[serde(default)]
    pub scene: Value,
    /// Files of the map, by name in its folder (empty from the Python package).
    pub files: Vec<String>,
}

/// Why a `map.json` cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ManifestError {
    /// The file cannot be read.
    #[error("cannot read {path}: {reason}")]
    Unreadable {
        /// The manifest's path.
        path: String,
        /// What the system said.
        reason: String,
    },
    /// Not JSON, or not the fields this version writes.
    #[error("{0}")]
    Damaged(String),
    /// It lists a file outside its folder.
    #[error(
        "{path} lists `{name}`, which is not a file name of its folder (a map lists its own files by name, never a path): the manifest is damaged or not ours"
    )]
    ForeignFile {
        /// The manifest's path.
        path: String,
        /// The listed name.
        name: String,
    },
}

/// A manifest: the JSON file a command writes last into its folder (its presence means the
/// folder is complete), with the one type its writer fills and every reader parses.
pub trait Manifest: Serialize + DeserializeOwned {
    /// The file's name in its folder.
    const NAME: &'static str;

    /// The files of the folder it lists by name (none where it lists none).
    fn listed(&self) -> &[String] {
        &[]
    }

    /// Read and check the manifest in `dir`: the fields this version writes, and files
    /// listed by plain name (no folder, no `..`), so that nothing outside the folder is read
    /// through it.
    fn read_in(dir: &Path) -> Result<Self, ManifestError> {
        Self::read(&dir.join(Self::NAME))
    }

    /// [`Manifest::read_in`] of the manifest at `path`.
    fn read(path: &Path) -> Result<Self, ManifestError> {
        let shown = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ManifestError::Unreadable {
            path: shown.clone(),
            reason: e.to_string(),
        })?;
        let manifest: Self = serde_json::from_str(&text).map_err(|e| {
            ManifestError::Damaged(pendulum_atlas_core::text::json_damage(&shown, &e))
        })?;
        if let Some(name) = manifest.listed().iter().find(|n| !is_plain_name(n)) {
            return Err(ManifestError::ForeignFile {
                path: shown,
                name: name.clone(),
            });
        }
        Ok(manifest)
    }
}

impl Manifest for MapManifest {
    const NAME: &'static str = MAP_JSON;

    fn listed(&self) -> &[String] {
        &self.files
    }
}

/// The list of files any manifest keeps under `files` (and nothing else of it): what a
/// rerun with `--force` may delete ([`super::folder`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(crate) struct FileList {
    /// The files, by name in the folder.
    pub files: Vec<String>,
}

/// A file name with no folder in it: not empty, no separator, not `.` or `..`.
fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && !name.contains(['/', '\\'])
        && !Path::new(name).is_absolute()
}

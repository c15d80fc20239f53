//! A finished map folder, read and checked once when the server starts: `map.json` (the
//! manifest, written last), `map_scene.toml` (the map's scene, from which every cell's scene is
//! rebuilt), `status.npy` and one `.npy` per metric array, each shaped like the grid.

use super::error::ExploreError;
use crate::config::{MapSpec, Metric, map_from_toml};
use crate::output::folder::Product;
use crate::output::map::COLUMNS;
use crate::output::npy::read_npy;
use std::path::{Path, PathBuf};

/// One stored array of the map (`K.npy`, `alpha_min_rad.npy`, ...), in C order.
#[derive(Debug, Clone)]
pub struct Column {
    /// File stem and `grid.csv` column.
    pub stem: &'static str,
    /// The metric it belongs to.
    pub metric: Metric,
    /// One value per cell.
    pub values: Vec<f64>,
}

/// A complete map folder.
#[derive(Debug)]
pub struct RunFolder {
    /// The folder.
    pub dir: PathBuf,
    /// The map, rebuilt from `map_scene.toml`.
    pub spec: MapSpec,
    /// `map.json` as written.
    pub manifest: serde_json::Value,
    /// Every stored metric array.
    pub columns: Vec<Column>,
    /// Status code per cell (`model::Status::code`).
    pub status: Vec<u8>,
    /// The files `map.json` lists.
    pub files: Vec<String>,
}

impl RunFolder {
    /// Read `dir`, refusing a folder that is not a complete map with the reason.
    pub fn open(dir: &Path) -> Result<RunFolder, ExploreError> {
        if !dir.is_dir() {
            return Err(ExploreError::MissingFile {
                path: dir.display().to_string(),
                hint: "give the --out folder of a finished `pendulum-atlas map`".into(),
            });
        }
        let manifest = read_manifest(dir)?;
        let spec = read_scene(dir)?;
        check_shape(dir, &spec, &manifest)?;
        let columns = read_columns(dir, &spec)?;
        let status = read_array::<u8>(dir, "status.npy", &spec)?;
        let files = manifest["files"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|f| f.as_str().map(String::from))
                    .collect()
            })
            .unwrap_or_default();
        Ok(RunFolder {
            dir: dir.to_path_buf(),
            spec,
            manifest,
            columns,
            status,
            files,
        })
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.status.len()
    }

    /// The metrics the map holds, in output order.
    pub fn metrics(&self) -> &[Metric] {
        &self.spec.metrics
    }

    /// The metric called `name` (`K`, `alpha_range`, ...), or the error listing the others.
    pub fn metric(&self, name: &str) -> Result<Metric, ExploreError> {
        self.metrics()
            .iter()
            .copied()
            .find(|m| m.name() == name)
            .ok_or_else(|| ExploreError::UnknownMetric {
                name: name.into(),
                accepted: self
                    .metrics()
                    .iter()
                    .map(|m| m.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// The value of metric `m` in cell `k` as stored (the range for `alpha_range`).
    pub fn value(&self, m: Metric, k: usize) -> f64 {
        let of = |stem: &str| {
            self.columns
                .iter()
                .find(|c| c.stem == stem)
                .map_or(f64::NAN, |c| c.values[k])
        };
        match m {
            Metric::AlphaRange => of("alpha_max_rad") - of("alpha_min_rad"),
            _ => self
                .columns
                .iter()
                .find(|c| c.metric == m)
                .map_or(f64::NAN, |c| c.values[k]),
        }
    }

    /// Cell index `given` (text from a request), checked against the grid.
    pub fn cell(&self, given: &str) -> Result<usize, ExploreError> {
        given
            .parse::<usize>()
            .ok()
            .filter(|&k| k < self.cells())
            .ok_or_else(|| ExploreError::OutOfRange {
                what: "cell",
                given: given.into(),
                last: self.cells() - 1,
            })
    }
}

/// `map.json`, which `map` writes last: without it the map is missing or unfinished.
fn read_manifest(dir: &Path) -> Result<serde_json::Value, ExploreError> {
    let path = dir.join(Product::Map.manifest());
    if !path.is_file() {
        let hint = match other_manifest(dir) {
            Some(p) => format!(
                "this is the folder of `pendulum-atlas {}` ({} is there); explore reads the \
                 folder of a finished `pendulum-atlas map` (or `merge`)",
                p.command(),
                p.manifest()
            ),
            None => "not a finished map folder: `pendulum-atlas map --out DIR` writes map.json \
                     last, so a map that was stopped has none"
                .into(),
        };
        return Err(ExploreError::MissingFile {
            path: path.display().to_string(),
            hint,
        });
    }
    let text = std::fs::read_to_string(&path).map_err(|e| bad(&path, e.to_string()))?;
    serde_json::from_str(&text).map_err(|e| bad(&path, format!("not JSON: {e}")))
}

/// The product whose manifest the folder holds instead of a map's.
fn other_manifest(dir: &Path) -> Option<Product> {
    Product::ALL
        .into_iter()
        .find(|p| *p != Product::Map && dir.join(p.manifest()).is_file())
}

/// `map_scene.toml`: the map's scene after its overrides.
fn read_scene(dir: &Path) -> Result<MapSpec, ExploreError> {
    let path = dir.join("map_scene.toml");
    let text = std::fs::read_to_string(&path).map_err(|_| ExploreError::MissingFile {
        path: path.display().to_string(),
        hint: "the map's scene is needed to rerun a cell; maps written before map_scene.toml was \
               added have none: run the map again"
            .into(),
    })?;
    map_from_toml(&text, &path.display().to_string(), &[]).map_err(|e| bad(&path, e.to_string()))
}

/// The grid of `map_scene.toml` is the grid of `map.json`.
fn check_shape(
    dir: &Path,
    spec: &MapSpec,
    manifest: &serde_json::Value,
) -> Result<(), ExploreError> {
    let stated: Option<Vec<usize>> = manifest["shape"].as_array().map(|a| {
        a.iter()
            .filter_map(|v| v.as_u64().map(|n| n as usize))
            .collect()
    });
    if stated.as_deref() != Some(&spec.shape()[..]) {
        return Err(bad(
            &dir.join("map.json"),
            format!(
                "its shape {stated:?} is not the grid of map_scene.toml {:?}: the files are from different maps",
                spec.shape()
            ),
        ));
    }
    Ok(())
}

/// Every metric array the map's metrics call for.
fn read_columns(dir: &Path, spec: &MapSpec) -> Result<Vec<Column>, ExploreError> {
    COLUMNS
        .iter()
        .filter(|(_, m, _)| spec.wants(*m))
        .map(|&(stem, metric, _)| {
            Ok(Column {
                stem,
                metric,
                values: read_array::<f64>(dir, &format!("{stem}.npy"), spec)?,
            })
        })
        .collect()
}

/// An array shaped like the grid.
fn read_array<T: npyz::Deserialize>(
    dir: &Path,
    name: &str,
    spec: &MapSpec,
) -> Result<Vec<T>, ExploreError> {
    let path = dir.join(name);
    if !path.is_file() {
        return Err(ExploreError::MissingFile {
            path: path.display().to_string(),
            hint:
                "map.json lists it: the folder is incomplete (copied in part?); run the map again"
                    .into(),
        });
    }
    let (shape, data) = read_npy::<T>(&path).map_err(|e| bad(&path, e))?;
    if shape != spec.shape() {
        return Err(bad(
            &path,
            format!(
                "shape {shape:?}, the grid is {:?}: the files are from different maps",
                spec.shape()
            ),
        ));
    }
    Ok(data)
}

fn bad(path: &Path, reason: impl Into<String>) -> ExploreError {
    ExploreError::BadFile {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

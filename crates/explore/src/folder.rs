//! A finished run folder, read and checked once when the server starts, as one grid of cells:
//! its axes, the quantities stored per cell ([`Column`]s), a status per cell, and what a
//! cell's scene is made of ([`Source`]). Three kinds of folder are grids:
//!
//! - a `map` (or `merge`) folder: the map's axes and metrics (`map_folder`);
//! - a `calibrate` folder: the grid of the unknowns, how many observations each candidate
//!   matched, and the cases a candidate is run in (`calibrate_folder`);
//! - a `search` folder: the grid of the design variables, each design's bandwidth and power,
//!   and the band frequencies and initial states a design is run at (`search_folder`).
//!
//! Each kind keeps its scene after overrides (`map_scene.toml`, `calibrate_scene.toml`,
//! `search_scene.toml`), from which every cell's scene is rebuilt by the command's own code.

use super::error::ExploreError;
use super::sources::{Calibration, Search};
use pendulum_atlas_core::config::{AxisScale, MapSpec, c_order_index, grid_point};
use pendulum_atlas_design::calibrate::CalibrationSpec;
use pendulum_atlas_design::harvest::spec::SearchSpec;
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::output::manifest::{Manifest, ManifestError, MapManifest};
use pendulum_atlas_map::render::Palette;
use std::path::{Path, PathBuf};

/// One axis of the grid.
#[derive(Debug, Clone)]
pub struct Axis {
    /// The scene key it sets.
    pub key: String,
    /// Label with unit.
    pub label: String,
    /// Its values, in grid order.
    pub values: Vec<f64>,
    /// How the values are spaced: a log axis is drawn in log space.
    pub scale: AxisScale,
}

/// One quantity stored per cell, as the page shows it.
#[derive(Debug, Clone)]
pub struct Column {
    /// Name in the API (`K`, `matched`, `bandwidth_robust_hz`, ...).
    pub name: String,
    /// Colour-bar label, with units.
    pub label: String,
    /// How its values are coloured (the PNGs' rule).
    pub palette: Palette,
    /// The value per cell as shown (NaN: no data, drawn grey).
    pub values: Vec<f64>,
}

/// What a cell's scene is built from.
#[derive(Debug)]
pub enum Source {
    /// A map: the cell's axis values set in the map's scene.
    Map(Box<MapSpec>, Box<MapManifest>),
    /// A calibration: a candidate's unknowns in one of the cases.
    Calibrate(Box<Calibration>),
    /// A search: a design at one frequency of the band from one initial state.
    Search(Box<Search>),
}

/// A cell's mark: its nudged copies disagree with it (`start_sensitivity` > 0).
pub const MARK_START_DECIDES: u8 = 1;
/// A cell's mark: its verdict is a periodic orbit after a chaotic transient (`transient_s`
/// finite, verdict periodic).
pub const MARK_AFTER_TRANSIENT: u8 = 2;

/// A complete run folder as a grid.
#[derive(Debug)]
pub struct RunFolder {
    /// The folder.
    pub dir: PathBuf,
    /// Which command wrote it.
    pub product: Product,
    /// The grid's axes (C order: the last varies fastest).
    pub axes: Vec<Axis>,
    /// The quantities per cell, the first shown first.
    pub columns: Vec<Column>,
    /// Status code per cell (`model::Status::code`).
    pub status: Vec<u8>,
    /// Per cell, whether refinement filled it from its block (empty: none was).
    pub inferred: Vec<bool>,
    /// Per cell of a settling map, whether the settling stage ran it on (`ran_on.npy`;
    /// empty for other runs).
    pub ran_on: Vec<bool>,
    /// Per cell of a map whose cells ran nudged copies, its marks on the verdict's pictures
    /// (`MARK_START_DECIDES`, `MARK_AFTER_TRANSIENT`; empty for other runs).
    pub marks: Vec<u8>,
    /// Per cell of a map whose cells ran nudged copies, whether it ran them
    /// (`start_sensitivity.npy` finite; empty for other runs).
    pub copies: Vec<bool>,
    /// The files the manifest lists.
    pub files: Vec<String>,
    /// The ways a cell can be run (cases, or frequency and initial state); none for a map.
    pub variants: Vec<String>,
    /// How to build a cell's scene.
    pub source: Source,
    /// Segments N of the base scene.
    pub segments: usize,
    /// The start (of `map.initial_states`) whose run each cell's values are: a click reruns
    /// that start (empty for a map of one start per cell).
    pub starts: Vec<usize>,
    /// Per cell, the attractors its starts reached (a map of several starts per cell; empty
    /// otherwise).
    pub cell_attractors: Vec<Vec<CellAttractor>>,
}

/// One attractor of one cell of a map run from several starts per cell.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CellAttractor {
    /// Its family's label (`attractors.json`).
    pub label: usize,
    /// The family in words, as the legend names it (`P2 +`).
    pub name: String,
    /// Its basin fraction in the cell.
    pub fraction: f64,
    /// The first start of the cell that reached it: the variant `start + 1` runs it.
    pub start: usize,
}

/// The largest picture served (bytes): far above any map's PNG.
pub(crate) const PICTURE_MAX_BYTES: u64 = 256 << 20;

/// How many names the file of `meta` has.
fn links(meta: &std::fs::Metadata) -> u64 {
    #[cfg(unix)]
    {
        std::os::unix::fs::MetadataExt::nlink(meta)
    }
    #[cfg(not(unix))]
    {
        let _ = meta;
        1
    }
}

impl RunFolder {
    /// The bytes of picture `name` when it may be served: listed in the manifest (by plain
    /// name), a `.png`, and, as opened, a regular file with one link, at most
    /// `PICTURE_MAX_BYTES`. The file is opened without following a symlink and without
    /// blocking, and the checks are made on the opened handle, so a picture swapped for a
    /// symlink or a FIFO between a check and the read is never followed. A hard link (a
    /// second name of a file that may lie outside the folder) is refused: the pictures a
    /// command writes have one name.
    pub(crate) fn read_picture(&self, name: &str) -> Option<Vec<u8>> {
        if !name.ends_with(".png") || !self.files.iter().any(|f| f == name) {
            return None;
        }
        let mut options = std::fs::OpenOptions::new();
        options.read(true);
        #[cfg(unix)]
        {
            use std::os::unix::fs::OpenOptionsExt;
            options.custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK);
        }
        let mut file = options.open(self.dir.join(name)).ok()?;
        let meta = file.metadata().ok()?;
        if !meta.is_file() || meta.len() > PICTURE_MAX_BYTES || links(&meta) != 1 {
            return None;
        }
        let mut bytes = Vec::with_capacity(meta.len() as usize);
        std::io::Read::read_to_end(&mut file, &mut bytes).ok()?;
        Some(bytes)
    }

    /// Shape of the grid.
    pub fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(|a| a.values.len()).collect()
    }

    /// Number of cells.
    pub fn cells(&self) -> usize {
        self.status.len()
    }

    /// Axis indices of cell `k` (C order).
    pub fn index_of(&self, k: usize) -> Vec<usize> {
        c_order_index(&self.shape(), k)
    }

    /// Axis values of cell `k`.
    pub fn values_of(&self, k: usize) -> Vec<f64> {
        grid_point(self.axes.iter().map(|a| a.values.as_slice()), k)
    }

    /// The column called `name`, or the error listing the others.
    pub fn column(&self, name: &str) -> Result<&Column, ExploreError> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .ok_or_else(|| ExploreError::UnknownMetric {
                name: name.into(),
                accepted: self
                    .columns
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
    }

    /// Cell index `given` (text from a request), checked against the grid.
    pub fn cell(&self, given: &str) -> Result<usize, ExploreError> {
        parse_index(given, self.cells(), "cell")
    }

    /// Variant index `given` (text from a request; none: the first), checked. A map has
    /// one way to run a cell: variant 0.
    pub fn variant(&self, given: Option<&str>) -> Result<usize, ExploreError> {
        given.map_or(Ok(0), |g| {
            parse_index(g, self.variants.len().max(1), "variant")
        })
    }
}

/// A whole number below `count`, or the error naming the range.
pub(crate) fn parse_index(
    given: &str,
    count: usize,
    what: &'static str,
) -> Result<usize, ExploreError> {
    given
        .parse::<usize>()
        .ok()
        .filter(|&k| k < count)
        .ok_or_else(|| ExploreError::OutOfRange {
            what,
            given: given.into(),
            last: count.saturating_sub(1),
        })
}

/// The manifest `M` of `dir`, read by the type its writer fills ([`Manifest::read`]): a
/// missing one is a missing file, a damaged one a bad file.
pub(crate) fn read_manifest<M: Manifest>(dir: &Path) -> Result<M, ExploreError> {
    let path = dir.join(M::NAME);
    M::read(&path).map_err(|e| match e {
        ManifestError::Unreadable { .. } => ExploreError::MissingFile {
            path: path.display().to_string(),
            hint: e.to_string(),
        },
        other => bad(&path, other.to_string()),
    })
}

/// A JSON file of the folder that is not its manifest (`attractors.json`).
pub(crate) fn read_json(path: &Path) -> Result<serde_json::Value, ExploreError> {
    let text = std::fs::read_to_string(path).map_err(|e| bad(path, e.to_string()))?;
    serde_json::from_str(&text).map_err(|e| bad(path, format!("not JSON: {e}")))
}

/// The text of a file the folder must hold; `hint` says why it may be missing.
pub(crate) fn read_text(dir: &Path, name: &str, hint: &str) -> Result<String, ExploreError> {
    let path = dir.join(name);
    std::fs::read_to_string(&path).map_err(|_| ExploreError::MissingFile {
        path: path.display().to_string(),
        hint: hint.into(),
    })
}

/// A CSV file of the folder: its header and records.
pub struct Csv {
    /// The file.
    pub path: PathBuf,
    /// Column names.
    pub header: Vec<String>,
    /// Records, as text.
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    /// Read a CSV file the folder must hold.
    pub fn read(dir: &Path, name: &str) -> Result<Csv, ExploreError> {
        let path = dir.join(name);
        let mut r = csv::Reader::from_path(&path).map_err(|_| ExploreError::MissingFile {
            path: path.display().to_string(),
            hint: "the manifest lists it: the folder is incomplete (copied in part?)".into(),
        })?;
        let header: Vec<String> = r
            .headers()
            .map_err(|e| bad(&path, e.to_string()))?
            .iter()
            .map(String::from)
            .collect();
        let rows = r
            .records()
            .map(|rec| {
                rec.map(|r| r.iter().map(String::from).collect())
                    .map_err(|e| bad(&path, e.to_string()))
            })
            .collect::<Result<_, _>>()?;
        Ok(Csv { path, header, rows })
    }

    /// The index of column `name`, or the error naming the file.
    pub fn col(&self, name: &str) -> Result<usize, ExploreError> {
        self.header
            .iter()
            .position(|h| h == name)
            .ok_or_else(|| bad(&self.path, format!("no column `{name}`")))
    }
}

/// A number of a CSV cell (`nan` and anything unreadable: NaN).
pub fn num(s: &str) -> f64 {
    s.parse().unwrap_or(f64::NAN)
}

/// The grid cell whose axis values are `values` (equal within 1e-9 relative), if any.
pub(crate) fn grid_cell(axes: &[Axis], values: &[f64]) -> Option<usize> {
    let mut k = 0;
    for (a, &v) in axes.iter().zip(values) {
        let i = a
            .values
            .iter()
            .position(|&x| (x - v).abs() <= 1e-9 * x.abs().max(v.abs()).max(1e-300))?;
        k = k * a.values.len() + i;
    }
    Some(k)
}

/// A file that cannot be read as expected.
pub fn bad(path: &Path, reason: impl Into<String>) -> ExploreError {
    ExploreError::BadFile {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

/// The spec of a map source, for the map's own rules (colours, strobe phase).
impl Source {
    /// The map's spec, when the folder is a map.
    pub fn map(&self) -> Option<&MapSpec> {
        match self {
            Source::Map(m, _) => Some(m),
            _ => None,
        }
    }

    /// The calibration's spec, when the folder is one.
    pub fn calibration(&self) -> Option<&CalibrationSpec> {
        match self {
            Source::Calibrate(c) => Some(&c.spec),
            _ => None,
        }
    }

    /// The search's spec, when the folder is one.
    pub fn search(&self) -> Option<&SearchSpec> {
        match self {
            Source::Search(s) => Some(&s.spec),
            _ => None,
        }
    }
}

//! One metric over one 2-D slice of the grid, as the page paints it: the values, and each
//! cell's colour by the very rule of the PNG heat maps (`render::cell_colour` over
//! `render::colour_range`, with `output::map::metric_style`'s fixed ranges), so the page and
//! the pictures cannot disagree.
//!
//! The page's x axis is the map's first axis, y its second (a 1-D map is one row), and a
//! 3-D map is shown one slice of its third axis at a time. Cell `k` of slice `iz` at
//! `(ix, iy)` is `k = (ix·n_y + iy)·n_z + iz` (C order, last axis fastest).

use super::error::ExploreError;
use super::folder::RunFolder;
use crate::config::Metric;
use crate::model::Status;
use crate::output::map::{metric_style, shown_value};
use crate::render::{INVALID_COLOR, NODATA_COLOR, cell_colour, colour_range, viridis};
use plotters::style::RGBColor;
use serde::Serialize;

/// Colour-bar stops sent with a field (viridis from the low to the high end).
const BAR_STOPS: usize = 64;

/// A metric over one slice, ready to paint.
#[derive(Debug, Serialize)]
pub struct Field {
    /// Metric name.
    pub metric: &'static str,
    /// Colour-bar label, with units.
    pub label: String,
    /// Values at the low and high end of the colour bar.
    pub range: (f64, f64),
    /// Cells along x (first axis).
    pub nx: usize,
    /// Cells along y (second axis; 1 for a 1-D map).
    pub ny: usize,
    /// The slice of the third axis shown (0 for 1-D and 2-D maps).
    pub slice: usize,
    /// Cell index `k` of page cell `(ix, iy)`, at `iy·nx + ix`.
    pub cells: Vec<usize>,
    /// The value shown in each page cell (`null`: no data, e.g. no period found).
    pub values: Vec<Option<f64>>,
    /// Each page cell's colour, `#rrggbb`.
    pub colours: Vec<String>,
    /// Each page cell's status (`ok`, `diverged`, ...).
    pub status: Vec<&'static str>,
    /// The colour bar, low to high, `#rrggbb`.
    pub bar: Vec<String>,
    /// Colour of failed cells.
    pub invalid_colour: String,
    /// Colour of cells without a value.
    pub nodata_colour: String,
}

/// Cells along (x, y, z) of the page: `(n0, n1 or 1, n2 or 1)`.
pub fn page_shape(folder: &RunFolder) -> (usize, usize, usize) {
    let s = folder.spec.shape();
    (
        s[0],
        s.get(1).copied().unwrap_or(1),
        s.get(2).copied().unwrap_or(1),
    )
}

/// Slice index `given` (text from a request), checked against the third axis.
pub fn slice_index(folder: &RunFolder, given: Option<&str>) -> Result<usize, ExploreError> {
    let nz = page_shape(folder).2;
    let Some(given) = given else { return Ok(0) };
    given
        .parse::<usize>()
        .ok()
        .filter(|&iz| iz < nz)
        .ok_or_else(|| ExploreError::OutOfRange {
            what: "slice",
            given: given.into(),
            last: nz - 1,
        })
}

/// Metric `m` over slice `iz`.
pub fn field(folder: &RunFolder, m: Metric, iz: usize) -> Field {
    let (nx, ny, nz) = page_shape(folder);
    let cells: Vec<usize> = (0..ny)
        .flat_map(|iy| (0..nx).map(move |ix| (ix * ny + iy) * nz + iz))
        .collect();
    let shown: Vec<f64> = cells
        .iter()
        .map(|&k| shown_value(m, folder.value(m, k)))
        .collect();
    let invalid: Vec<bool> = cells
        .iter()
        .map(|&k| folder.status[k] != Status::Ok.code())
        .collect();
    let (label, fixed) = metric_style(m, &folder.spec);
    let range = colour_range(&shown, &invalid, fixed);
    Field {
        metric: m.name(),
        label,
        range,
        nx,
        ny,
        slice: iz,
        colours: shown
            .iter()
            .zip(&invalid)
            .map(|(&v, &bad)| hex(cell_colour(v, bad, range)))
            .collect(),
        values: shown.iter().map(|v| v.is_finite().then_some(*v)).collect(),
        status: cells
            .iter()
            .map(|&k| status_name(folder.status[k]))
            .collect(),
        cells,
        bar: (0..BAR_STOPS)
            .map(|i| hex(viridis(i as f64 / (BAR_STOPS - 1) as f64)))
            .collect(),
        invalid_colour: hex(INVALID_COLOR),
        nodata_colour: hex(NODATA_COLOR),
    }
}

/// The status name of a stored code (`unknown` for a code no status has).
pub fn status_name(code: u8) -> &'static str {
    Status::ALL
        .iter()
        .find(|s| s.code() == code)
        .map_or("unknown", |s| s.as_str())
}

/// `#rrggbb`.
pub fn hex(c: RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}

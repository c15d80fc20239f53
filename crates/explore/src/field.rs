//! One quantity over one 2-D slice of the grid, as the page paints it: the values, and each
//! cell's colour by the very rule of the PNG heat maps (the quantity's `render::Palette`:
//! its range, colours, colour bar or legend of categories), so the page and the pictures
//! cannot disagree.
//!
//! The page's x axis is the grid's first axis, y its second (a 1-D grid is one row); every
//! further axis is held at one index (the slice). Cell `k` is the C-order index of
//! `(ix, iy, i2, i3, ...)` (the last axis fastest).

use super::error::ExploreError;
use super::folder::{RunFolder, parse_index};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_map::render::{INVALID_COLOR, NODATA_COLOR};
use plotters::style::RGBColor;
use serde::Serialize;

/// Colour-bar stops sent with a field (from the low to the high end).
const BAR_STOPS: usize = 64;

/// A metric over one slice, ready to paint.
#[derive(Debug, Serialize)]
pub struct Field {
    /// Quantity name.
    pub metric: String,
    /// Colour-bar label, with units.
    pub label: String,
    /// Values at the low and high end of the colour bar.
    pub range: (f64, f64),
    /// Cells along x (first axis).
    pub nx: usize,
    /// Cells along y (second axis; 1 for a 1-D map).
    pub ny: usize,
    /// The index held on each axis beyond the second (empty for 1-D and 2-D grids).
    pub slice: Vec<usize>,
    /// Cell index `k` of page cell `(ix, iy)`, at `iy·nx + ix`.
    pub cells: Vec<usize>,
    /// The value shown in each page cell (`null`: no data, e.g. no period found).
    pub values: Vec<Option<f64>>,
    /// Each page cell's colour, `#rrggbb`.
    pub colours: Vec<String>,
    /// Each page cell's status (`ok`, `diverged`, ...).
    pub status: Vec<&'static str>,
    /// The colour bar, low to high, `#rrggbb` (empty for categories: see `categories`).
    pub bar: Vec<String>,
    /// The categories present in the slice, `(#rrggbb, name)`, for a categorical quantity
    /// (the regime).
    pub categories: Vec<(String, String)>,
    /// Colour of failed cells.
    pub invalid_colour: String,
    /// Colour of cells without a value.
    pub nodata_colour: String,
    /// Each page cell's marks on the verdict's pictures (`folder::MARK_*` bits; empty where
    /// the quantity is not the regime or the period, or the map ran no copies).
    pub marks: Vec<u8>,
}

/// Cells along x and y of the page: `(n0, n1 or 1)`.
pub(crate) fn page_shape(folder: &RunFolder) -> (usize, usize) {
    let s = folder.shape();
    (s[0], s.get(1).copied().unwrap_or(1))
}

/// The slice (text from a request: indices of the axes beyond the second, comma-separated;
/// none: all 0), each checked against its axis.
pub(crate) fn slice_index(
    folder: &RunFolder,
    given: Option<&str>,
) -> Result<Vec<usize>, ExploreError> {
    let extra = &folder.shape()[folder.shape().len().min(2)..];
    let Some(given) = given.filter(|g| !g.is_empty()) else {
        return Ok(vec![0; extra.len()]);
    };
    let parts: Vec<&str> = given.split(',').collect();
    if parts.len() != extra.len() {
        return Err(ExploreError::BadSlice {
            given: given.into(),
            axes: extra.len(),
        });
    }
    parts
        .iter()
        .zip(extra)
        .map(|(p, &n)| parse_index(p.trim(), n, "slice"))
        .collect()
}

/// Quantity `name` over `slice`.
pub fn field(folder: &RunFolder, name: &str, slice: &[usize]) -> Result<Field, ExploreError> {
    let col = folder.column(name)?;
    let shape = folder.shape();
    let (nx, ny) = page_shape(folder);
    let cell = |ix: usize, iy: usize| {
        let idx: Vec<usize> = [ix, iy]
            .into_iter()
            .take(shape.len())
            .chain(slice.iter().copied())
            .collect();
        idx.iter().zip(&shape).fold(0, |k, (&i, &n)| k * n + i)
    };
    let cells: Vec<usize> = (0..ny)
        .flat_map(|iy| (0..nx).map(move |ix| (ix, iy)))
        .map(|(ix, iy)| cell(ix, iy))
        .collect();
    let shown: Vec<f64> = cells.iter().map(|&k| col.values[k]).collect();
    let invalid: Vec<bool> = cells
        .iter()
        .map(|&k| folder.status[k] != Status::Ok.code())
        .collect();
    let palette = &col.palette;
    let range = palette.range(&shown, &invalid);
    let verdict = ["regime", "period"].contains(&col.name.as_str());
    let marks = match folder.marks.is_empty() || !verdict {
        true => Vec::new(),
        false => cells.iter().map(|&k| folder.marks[k]).collect(),
    };
    Ok(Field {
        metric: col.name.clone(),
        label: col.label.clone(),
        range,
        nx,
        ny,
        slice: slice.to_vec(),
        colours: shown
            .iter()
            .zip(&invalid)
            .map(|(&v, &bad)| hex(palette.colour(v, bad, range)))
            .collect(),
        values: shown.iter().map(|v| v.is_finite().then_some(*v)).collect(),
        status: cells
            .iter()
            .map(|&k| status_name(folder.status[k]))
            .collect(),
        cells,
        bar: palette.bar(BAR_STOPS).into_iter().map(hex).collect(),
        categories: palette
            .present(&shown, &invalid)
            .into_iter()
            .map(|c| (hex(c.colour), c.label))
            .collect(),
        invalid_colour: hex(INVALID_COLOR),
        nodata_colour: hex(NODATA_COLOR),
        marks,
    })
}

/// The status name of a stored code (`unknown` for a code no status has).
pub(crate) fn status_name(code: u8) -> &'static str {
    Status::ALL
        .iter()
        .find(|s| s.code() == code)
        .map_or("unknown", |s| s.as_str())
}

/// `#rrggbb`.
pub fn hex(c: RGBColor) -> String {
    format!("#{:02x}{:02x}{:02x}", c.0, c.1, c.2)
}

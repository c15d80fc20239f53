//! How a heat map turns values into colours: one rule shared by the PNG heat maps and the
//! browser page, so the two cannot disagree. Failed cells are magenta and cells without a
//! value grey under every palette; neither colour is used by any palette.

use super::colormap::{lerp_stops, viridis};
use super::finite_min_max;
use plotters::style::RGBColor;

/// Colour of invalid (diverged) heat-map cells; no palette reaches it.
pub const INVALID_COLOR: RGBColor = RGBColor(255, 0, 255);
/// Colour of non-finite but valid cells ("no data").
pub const NODATA_COLOR: RGBColor = RGBColor(190, 190, 190);

/// How a bifurcation curve of the orbit stage is drawn over a map (its PNGs and the page):
/// its colour and legend entry. Period doubling black, folds white, grazing grey.
pub fn curve_style(
    kind: pendulum_atlas_core::reduce::orbits::BifurcationKind,
) -> (RGBColor, &'static str) {
    use pendulum_atlas_core::reduce::orbits::BifurcationKind as K;
    match kind {
        K::PeriodDoubling => (RGBColor(0, 0, 0), "period doubling"),
        K::Fold => (RGBColor(255, 255, 255), "fold"),
        K::Grazing => (RGBColor(110, 110, 110), "grazing"),
    }
}

/// ColorBrewer's RdBu reversed (matplotlib `RdBu_r`), 11 stops: blue below the centre, white
/// at it, red above.
const RDBU_R: [(u8, u8, u8); 11] = [
    (0x05, 0x30, 0x61),
    (0x21, 0x66, 0xac),
    (0x43, 0x93, 0xc3),
    (0x92, 0xc5, 0xde),
    (0xd1, 0xe5, 0xf0),
    (0xf7, 0xf7, 0xf7),
    (0xfd, 0xdb, 0xc7),
    (0xf4, 0xa5, 0x82),
    (0xd6, 0x60, 0x4d),
    (0xb2, 0x18, 0x2b),
    (0x67, 0x00, 0x1f),
];

/// One value of a categorical palette.
#[derive(Debug, Clone, PartialEq)]
pub struct Category {
    /// The value that stands for it.
    pub value: f64,
    /// Its name in the legend.
    pub label: String,
    /// Its colour.
    pub colour: RGBColor,
}

/// How a heat map's values become colours.
#[derive(Debug, Clone, PartialEq)]
pub enum Palette {
    /// Viridis from the low to the high end: of the fixed range, or of the valid cells'
    /// finite values (values beyond are clamped).
    Sequential(Option<(f64, f64)>),
    /// Blue through white (at 0) to red, symmetric about 0: ± the fixed half-width, or ± the
    /// largest |value| of the valid cells (for signed quantities such as λ1).
    Diverging(Option<f64>),
    /// One colour per listed value, named in a legend instead of a colour bar; any other
    /// value is no data.
    Categorical(Vec<Category>),
}

impl Palette {
    /// The values at the low and high end of the colour bar for `values` (`invalid[k]`: cell
    /// `k` failed and does not count; `invalid` may be empty). A single value gets ±0.5
    /// around it; no value at all, 0 to 1.
    pub fn range(&self, values: &[f64], invalid: &[bool]) -> (f64, f64) {
        let bad = |k: usize| invalid.get(k).copied().unwrap_or(false);
        let valid = || {
            (0..values.len())
                .filter(move |&k| !bad(k))
                .map(|k| values[k])
        };
        let span = |r: Option<(f64, f64)>| match r {
            Some((a, b)) if b > a => (a, b),
            Some((a, _)) => (a - 0.5, a + 0.5),
            None => (0.0, 1.0),
        };
        match self {
            Palette::Sequential(Some((a, b))) if a.is_finite() && b.is_finite() && a < b => {
                (*a, *b)
            }
            Palette::Sequential(_) => span(finite_min_max(valid())),
            Palette::Diverging(Some(h)) if h.is_finite() && *h > 0.0 => (-h, *h),
            Palette::Diverging(_) => {
                let h = valid()
                    .filter(|v| v.is_finite())
                    .fold(0.0f64, |m, v| m.max(v.abs()));
                if h > 0.0 { (-h, h) } else { (-1.0, 1.0) }
            }
            Palette::Categorical(c) => span(finite_min_max(c.iter().map(|c| c.value))),
        }
    }

    /// The colour of one cell: [`INVALID_COLOR`] for a failed cell, [`NODATA_COLOR`] for no
    /// value (non-finite, or not one of the categories), else the palette's colour of the
    /// value's place in `(lo, hi)`.
    pub fn colour(&self, value: f64, invalid: bool, (lo, hi): (f64, f64)) -> RGBColor {
        if invalid {
            return INVALID_COLOR;
        }
        if !value.is_finite() {
            return NODATA_COLOR;
        }
        let t = (value - lo) / (hi - lo);
        match self {
            Palette::Sequential(_) => viridis(t),
            Palette::Diverging(_) => lerp_stops(&RDBU_R, t),
            Palette::Categorical(c) => c
                .iter()
                .find(|c| c.value == value)
                .map_or(NODATA_COLOR, |c| c.colour),
        }
    }

    /// `stops` colours of the colour bar from its low to its high end; none for a
    /// categorical palette (its legend names the categories).
    pub fn bar(&self, stops: usize) -> Vec<RGBColor> {
        let at = |i: usize| i as f64 / (stops.max(2) - 1) as f64;
        match self {
            Palette::Sequential(_) => (0..stops).map(|i| viridis(at(i))).collect(),
            Palette::Diverging(_) => (0..stops).map(|i| lerp_stops(&RDBU_R, at(i))).collect(),
            Palette::Categorical(_) => Vec::new(),
        }
    }

    /// The categories that occur among the valid cells' `values`, in the palette's order.
    pub fn present(&self, values: &[f64], invalid: &[bool]) -> Vec<Category> {
        let Palette::Categorical(c) = self else {
            return Vec::new();
        };
        let bad = |k: usize| invalid.get(k).copied().unwrap_or(false);
        c.iter()
            .filter(|c| (0..values.len()).any(|k| !bad(k) && values[k] == c.value))
            .cloned()
            .collect()
    }
}

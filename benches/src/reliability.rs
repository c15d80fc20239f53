//! Stage 5 of `pendulum-atlas-lab verdict`: does the map's `verdict_confidence` predict its error?
//!
//! The default map as shipped is run whole, so that every cell has its neighbours, and its
//! cells on two disjoint subgrids are scored against a converged reference of each (subgrid A:
//! every 4th frequency and amplitude from the first, the study's own; B: from the third). Then:
//! - **Reliability**: the settled cells binned by `verdict_confidence`, with the share right
//!   per bin; and the headline, the cells at 0.9 or above: how many, and how many right.
//! - **Cross-fit**: the table of the confidence stage (`map::confidence::Calibration`) fitted
//!   on one subgrid and scored on the other, an estimate free of the shipped table's fit on
//!   both; and the table fitted on both, which the map ships.

use pendulum_atlas_core::config::c_order_index;
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::MapRun;
use pendulum_atlas_map::map::confidence::{Bin, Calibration, agreement};
use serde::{Deserialize, Serialize};

/// The confidence at or above which a verdict is called firm: the settling stage's threshold.
pub use pendulum_atlas_core::config::FIRM;

/// Edges of the reliability bins (the last bin includes 1).
pub const EDGES: [f64; 6] = [0.0, 0.5, 0.7, 0.9, 0.95, 1.0];

/// One settled cell as the confidence stage sees it.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct ScoredCell {
    /// Its bin (`None`: undecided or failed).
    pub bin: Option<Bin>,
    /// Its `verdict_confidence` (`None`: NaN, undecided).
    pub confidence: Option<f64>,
    /// Its λ1 confidence (`regime_confidence`, which caps it; `None`: NaN).
    pub regime_confidence: Option<f64>,
    /// Whether its verdict is the reference's.
    pub right: bool,
}

impl ScoredCell {
    /// (confidence, right), NaN where there is none.
    fn shipped(&self) -> (f64, bool) {
        (self.confidence.unwrap_or(f64::NAN), self.right)
    }

    /// The confidence table `t` gives the cell, capped by its λ1 confidence as the map caps
    /// it (NaN where undecided).
    pub fn under(&self, t: &Calibration) -> (f64, bool) {
        let phi = self.regime_confidence.unwrap_or(f64::NAN);
        (self.bin.map_or(f64::NAN, |b| t.of(b).min(phi)), self.right)
    }
}

/// One subgrid's cells as the confidence stage sees them.
#[derive(Debug, Clone, Serialize)]
pub struct Scored {
    /// Which subgrid.
    pub name: &'static str,
    /// Its settled cells.
    pub cells: Vec<ScoredCell>,
    /// Settled cells.
    pub settled: usize,
}

/// One row of the reliability table.
#[derive(Debug, Clone, Serialize)]
pub struct BinRow {
    /// Lower edge (inclusive).
    pub from: f64,
    /// Upper edge (exclusive, but 1 included).
    pub to: f64,
    /// Settled cells in the bin.
    pub cells: usize,
    /// Of those, right.
    pub right: usize,
    /// Their mean confidence.
    pub mean_confidence: f64,
}

/// The firm verdicts of a table on a subgrid.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Firm {
    /// Settled cells at confidence ≥ [`FIRM`].
    pub cells: usize,
    /// Of those, right.
    pub right: usize,
    /// Settled cells in all.
    pub settled: usize,
}

impl Firm {
    /// Share of settled cells that are firm (%).
    pub fn coverage_pct(&self) -> f64 {
        100.0 * self.cells as f64 / self.settled.max(1) as f64
    }
    /// Share of firm cells that are right (%).
    pub fn right_pct(&self) -> f64 {
        100.0 * self.right as f64 / self.cells.max(1) as f64
    }
}

/// Everything stage 5 measured.
#[derive(Debug, Clone, Serialize)]
pub struct Reliability {
    /// Per subgrid (A, B, both): the reliability table of the shipped confidence.
    pub tables: Vec<(&'static str, Vec<BinRow>, Firm)>,
    /// Fitted on A, scored on B; fitted on B, scored on A.
    pub cross: Vec<(&'static str, Calibration, Firm)>,
    /// Fitted on both (what the map should ship).
    pub pooled: Calibration,
    /// The table the map applied.
    pub shipped: Calibration,
    /// Whether the shipped table equals the pooled fit.
    pub shipped_is_pooled: bool,
    /// The scored cells of both subgrids (what a fit across planes reads back).
    pub scored: Vec<Scored>,
}

/// The settled cells of the subgrid at `offset` (every `thin`th value of each axis) of the
/// whole map `run` of `shape`, against the reference verdicts `reference` (subgrid order) and
/// its settled flags.
pub fn score_subgrid(
    name: &'static str,
    run: &MapRun,
    shape: &[usize],
    (thin, offset): (usize, usize),
    reference: &[i8],
    settled: &[bool],
) -> Scored {
    let verdicts: Vec<Regime> = run.results.iter().map(|r| r.regime).collect();
    let mut cells = Vec::new();
    for (j, (&want, &ok)) in reference.iter().zip(settled).enumerate() {
        if !ok {
            continue;
        }
        let k = grid_index(shape, (thin, offset), j);
        let r = &run.results[k];
        let bin = Bin::of(r.regime, agreement(shape, k, |m| verdicts[m]));
        let finite = |x: f64| x.is_finite().then_some(x);
        cells.push(ScoredCell {
            bin,
            confidence: finite(r.verdict_confidence),
            regime_confidence: finite(r.regime_confidence),
            right: r.regime.code() == want,
        });
    }
    Scored {
        name,
        settled: cells.len(),
        cells,
    }
}

/// The grid index (C order, `shape`) of cell `j` of the subgrid that takes every `thin`th
/// value of each axis from the `offset`th.
pub fn grid_index(shape: &[usize], (thin, offset): (usize, usize), j: usize) -> usize {
    let sub: Vec<usize> = shape
        .iter()
        .map(|&n| (offset..n).step_by(thin).count())
        .collect();
    c_order_index(&sub, j)
        .iter()
        .zip(shape)
        .fold(0, |flat, (&i, &n)| flat * n + offset + i * thin)
}

/// The reliability table of confidences `conf` (NaN: undecided, in no bin).
pub fn table(cells: &[(f64, bool)]) -> Vec<BinRow> {
    EDGES
        .windows(2)
        .map(|w| {
            let last = w[1] >= 1.0;
            let inside: Vec<&(f64, bool)> = cells
                .iter()
                .filter(|(c, _)| *c >= w[0] && (*c < w[1] || (last && *c <= 1.0)))
                .collect();
            BinRow {
                from: w[0],
                to: w[1],
                cells: inside.len(),
                right: inside.iter().filter(|(_, ok)| *ok).count(),
                mean_confidence: inside.iter().map(|(c, _)| c).sum::<f64>()
                    / inside.len().max(1) as f64,
            }
        })
        .collect()
}

/// The firm verdicts among `cells` (confidence, right) of `settled` settled cells.
pub fn firm_of(cells: &[(f64, bool)], settled: usize) -> Firm {
    let f: Vec<&(f64, bool)> = cells.iter().filter(|(c, _)| *c >= FIRM).collect();
    Firm {
        cells: f.len(),
        right: f.iter().filter(|(_, ok)| *ok).count(),
        settled,
    }
}

/// The confidence `t` gives each cell of `s`.
fn under(t: &Calibration, s: &Scored) -> Vec<(f64, bool)> {
    s.cells.iter().map(|c| c.under(t)).collect()
}

fn fitted(s: &[&Scored]) -> Calibration {
    fit(s.iter().flat_map(|s| &s.cells))
}

/// The table fitted on `cells`.
pub fn fit<'a>(cells: impl IntoIterator<Item = &'a ScoredCell>) -> Calibration {
    let binned: Vec<(Bin, bool)> = cells
        .into_iter()
        .filter_map(|c| c.bin.map(|b| (b, c.right)))
        .collect();
    Calibration::fit(&binned)
}

/// Stage 5 on the two scored subgrids of a map whose confidence came from `shipped`.
pub fn reliability(a: &Scored, b: &Scored, applied: &Calibration) -> Reliability {
    let shipped =
        |s: &Scored| -> Vec<(f64, bool)> { s.cells.iter().map(ScoredCell::shipped).collect() };
    let both: Vec<(f64, bool)> = shipped(a).into_iter().chain(shipped(b)).collect();
    let tables = vec![
        ("A", table(&shipped(a)), firm_of(&shipped(a), a.settled)),
        ("B", table(&shipped(b)), firm_of(&shipped(b), b.settled)),
        (
            "A and B",
            table(&both),
            firm_of(&both, a.settled + b.settled),
        ),
    ];
    let (fa, fb) = (fitted(&[a]), fitted(&[b]));
    let cross = vec![
        (
            "fitted on A, scored on B",
            fa,
            firm_of(&under(&fa, b), b.settled),
        ),
        (
            "fitted on B, scored on A",
            fb,
            firm_of(&under(&fb, a), a.settled),
        ),
    ];
    let pooled = fitted(&[a, b]);
    Reliability {
        scored: vec![a.clone(), b.clone()],
        tables,
        cross,
        pooled,
        shipped: *applied,
        shipped_is_pooled: pooled == *applied,
    }
}

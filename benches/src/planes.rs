//! The confidence fitted beyond one plane (`pendulum-atlas-lab verdict-fit DIR…`).
//!
//! Each `DIR` holds one plane's verdict study (`pendulum-atlas-lab verdict --plane P --out DIR`): its
//! `verdict.json` keeps the scored cells of both subgrids, for the raw map and for the settled
//! map, against that plane's own converged reference. From them, for each table of the
//! confidence stage (`SHIPPED` for raw maps, `SETTLED` for settled ones):
//! - **Pooled**: the table fitted on every plane's cells, what the map ships.
//! - **Leave one plane out**: for each plane, the table fitted on the other planes and applied
//!   to it, as to a plane the fit never saw: its reliability bins, whether they rise with the
//!   confidence, and its firm cells (confidence ≥ 0.9) with how many are right.
//!
//! The target of a held-out plane: firm cells ≥ [`TARGET_RIGHT_PCT`] % right and
//! ≥ [`TARGET_FIRM_PCT`] % of the settled cells, with bins that rise.

use super::reliability::{BinRow, FIRM, Firm, ScoredCell, firm_of, fit, table};
use super::study_file::{StudyFileError, read_study};
use super::verdict::Plane;
use super::verdict_report::calibration_row;
use pendulum_atlas_map::map::confidence::Calibration;
use pendulum_atlas_map::output::OutputError;
use pendulum_atlas_map::output::files::{create_dir, write_bytes, write_json};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Share of a held-out plane's firm cells that must be right (%).
pub const TARGET_RIGHT_PCT: f64 = 98.0;

/// Share of a held-out plane's settled cells that must be firm (%).
pub const TARGET_FIRM_PCT: f64 = 80.0;

/// A bin counts towards "rising" when it holds at least this many cells.
pub const RISING_MIN_CELLS: usize = 5;

/// What can stop the fit.
#[derive(Debug, Error)]
pub enum PlanesError {
    /// A study's `verdict.json` could not be read back.
    #[error(transparent)]
    Study(#[from] StudyFileError),
    /// The planes given cannot be fitted across.
    #[error("{0}")]
    Planes(String),
    /// The report could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// Which map a table serves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Which {
    /// The raw map (`map.settle = false`): the table `SHIPPED`.
    Raw,
    /// The settled map (the default): the table `SETTLED`.
    Settled,
}

impl Which {
    /// Both, in the report's order.
    pub const ALL: [Which; 2] = [Which::Raw, Which::Settled];

    /// The table's name in `crates/map/src/map/confidence.rs`.
    pub fn table(self) -> &'static str {
        match self {
            Which::Raw => "SHIPPED",
            Which::Settled => "SETTLED",
        }
    }
}

/// One plane's scored cells (both subgrids).
#[derive(Debug, Clone)]
pub struct PlaneCells {
    /// The plane.
    pub plane: Plane,
    /// The raw map's settled cells.
    pub raw: Vec<ScoredCell>,
    /// The settled map's settled cells.
    pub settled: Vec<ScoredCell>,
}

impl PlaneCells {
    /// The cells of the map `which`.
    pub fn cells(&self, which: Which) -> &[ScoredCell] {
        match which {
            Which::Raw => &self.raw,
            Which::Settled => &self.settled,
        }
    }
}

#[derive(Deserialize)]
struct StoredScored {
    cells: Vec<ScoredCell>,
}

#[derive(Deserialize)]
struct StoredReliability {
    scored: Vec<StoredScored>,
}

#[derive(Deserialize)]
struct StoredSettling {
    reliability: StoredReliability,
}

#[derive(Deserialize)]
struct StoredStudy {
    plane: Plane,
    reliability: StoredReliability,
    settling: StoredSettling,
}

/// The scored cells of the study in `dir` (its `verdict.json`).
pub fn read_plane(dir: &Path) -> Result<PlaneCells, PlanesError> {
    let (study, _): (StoredStudy, _) = read_study(dir)?;
    let flat = |r: StoredReliability| -> Vec<ScoredCell> {
        r.scored.into_iter().flat_map(|s| s.cells).collect()
    };
    Ok(PlaneCells {
        plane: study.plane,
        raw: flat(study.reliability),
        settled: flat(study.settling.reliability),
    })
}

/// One plane scored by a table fitted without it.
#[derive(Debug, Clone, Serialize)]
pub struct HeldOut {
    /// The plane held out.
    pub plane: Plane,
    /// The table fitted on the other planes.
    pub table: Calibration,
    /// Its reliability bins on the held-out plane.
    pub bins: Vec<BinRow>,
    /// Whether the bins with at least [`RISING_MIN_CELLS`] cells are right more often as the
    /// confidence rises (never less).
    pub rising: bool,
    /// Its firm cells there.
    pub firm: Firm,
}

impl HeldOut {
    /// Whether the held-out plane meets the target.
    pub fn meets_target(&self) -> bool {
        self.rising
            && self.firm.right_pct() >= TARGET_RIGHT_PCT
            && self.firm.coverage_pct() >= TARGET_FIRM_PCT
    }
}

/// One table across the planes.
#[derive(Debug, Clone, Serialize)]
pub struct TableFit {
    /// The map it serves.
    pub which: Which,
    /// Fitted on every plane.
    pub pooled: Calibration,
    /// The pooled table's firm cells on each plane (a fit that saw them).
    pub pooled_firm: Vec<(Plane, Firm)>,
    /// Each plane held out.
    pub held_out: Vec<HeldOut>,
}

/// Everything the fit measured.
#[derive(Debug, Clone, Serialize)]
pub struct PlanesReport {
    /// The planes, in the order given.
    pub planes: Vec<Plane>,
    /// The folders they were read from.
    pub dirs: Vec<String>,
    /// The raw table, then the settled one.
    pub tables: Vec<TableFit>,
}

/// Whether the bins' shares right never fall as the confidence rises.
fn rising(bins: &[BinRow]) -> bool {
    let shares: Vec<f64> = bins
        .iter()
        .filter(|b| b.cells >= RISING_MIN_CELLS)
        .map(|b| b.right as f64 / b.cells as f64)
        .collect();
    shares.windows(2).all(|w| w[0] <= w[1])
}

/// `cells` under the table `t`: bins, rising, firm.
fn scored(plane: Plane, t: Calibration, cells: &[ScoredCell]) -> HeldOut {
    let under: Vec<(f64, bool)> = cells.iter().map(|c| c.under(&t)).collect();
    let bins = table(&under);
    HeldOut {
        plane,
        table: t,
        rising: rising(&bins),
        bins,
        firm: firm_of(&under, cells.len()),
    }
}

fn table_fit(planes: &[PlaneCells], which: Which) -> TableFit {
    let pooled = fit(planes.iter().flat_map(|p| p.cells(which)));
    let held_out = planes
        .iter()
        .map(|out| {
            let others = planes.iter().filter(|p| p.plane != out.plane);
            let t = fit(others.flat_map(|p| p.cells(which)));
            scored(out.plane, t, out.cells(which))
        })
        .collect();
    TableFit {
        which,
        pooled,
        pooled_firm: planes
            .iter()
            .map(|p| (p.plane, scored(p.plane, pooled, p.cells(which)).firm))
            .collect(),
        held_out,
    }
}

/// Fit across `planes` (read from `dirs`): at least two, each once.
pub fn fit_planes(planes: &[PlaneCells], dirs: &[PathBuf]) -> Result<PlanesReport, PlanesError> {
    if planes.len() < 2 {
        return Err(PlanesError::Planes(format!(
            "a fit across planes needs at least 2 studies of different planes (got {}); \
             run `pendulum-atlas-lab verdict --plane P` for each of {}",
            planes.len(),
            Plane::ALL.map(Plane::name).join(", ")
        )));
    }
    for (i, p) in planes.iter().enumerate() {
        if planes[..i].iter().any(|q| q.plane == p.plane) {
            return Err(PlanesError::Planes(format!(
                "the plane `{}` is given twice; give each plane's study once",
                p.plane.name()
            )));
        }
    }
    Ok(PlanesReport {
        planes: planes.iter().map(|p| p.plane).collect(),
        dirs: dirs.iter().map(|d| d.display().to_string()).collect(),
        tables: Which::ALL.iter().map(|&w| table_fit(planes, w)).collect(),
    })
}

/// Write `PLANES.md` and `planes.json` into `dir`.
pub fn write_planes(dir: &Path, r: &PlanesReport) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    Ok(vec![
        write_bytes(&dir.join("PLANES.md"), markdown(r).as_bytes())?,
        write_json(&dir.join("planes.json"), r)?,
    ])
}

fn markdown(r: &PlanesReport) -> String {
    let mut s = String::new();
    let names: Vec<&str> = r.planes.iter().map(|p| p.name()).collect();
    let _ = writeln!(
        s,
        "# The confidence fitted beyond one plane\n\n\
         Written by `pendulum-atlas-lab verdict-fit {}` (`benches/src/planes.rs`) \
         from the verdict studies of the planes {}, each scored against its own converged \
         reference. Target on a plane held out of the fit: firm cells (confidence ≥ {FIRM}) \
         ≥ {TARGET_RIGHT_PCT} % right and ≥ {TARGET_FIRM_PCT} % of the settled cells, with bins \
         (of at least {RISING_MIN_CELLS} cells) right more often as the confidence rises.\n",
        r.dirs.join(" "),
        names.join(", ")
    );
    for t in &r.tables {
        table_section(&mut s, t);
    }
    s
}

fn table_section(s: &mut String, t: &TableFit) {
    let _ = writeln!(
        s,
        "## `{}` ({} map)\n\n\
         | fitted on | chaotic, all agree | chaotic, some not | periodic a ≥ ½ | periodic a < ½ | regular | chaotic alone | periodic alone |\n\
         |---|---|---|---|---|---|---|---|\n| every plane | {} |",
        t.which.table(),
        match t.which {
            Which::Raw => "raw",
            Which::Settled => "settled",
        },
        calibration_row(&t.pooled)
    );
    for h in &t.held_out {
        let _ = writeln!(
            s,
            "| all but {} | {} |",
            h.plane.name(),
            calibration_row(&h.table)
        );
    }
    let _ = writeln!(
        s,
        "\n| plane | settled cells | pooled: firm, right | held out: firm | right of firm | bins rise | target |\n|---|---:|---|---:|---:|---|---|"
    );
    for (h, (_, pf)) in t.held_out.iter().zip(&t.pooled_firm) {
        let _ = writeln!(
            s,
            "| {} | {} | {} ({:.1} %), {:.1} % | {} ({:.1} %) | {} ({:.1} %) | {} | {} |",
            h.plane.name(),
            h.firm.settled,
            pf.cells,
            pf.coverage_pct(),
            pf.right_pct(),
            h.firm.cells,
            h.firm.coverage_pct(),
            h.firm.right,
            h.firm.right_pct(),
            if h.rising { "yes" } else { "no" },
            if h.meets_target() { "met" } else { "not met" }
        );
    }
    let _ = writeln!(
        s,
        "\nBins of the held-out planes (cells, right):\n\n| plane | {} |\n|---|{}",
        t.held_out
            .first()
            .map(|h| {
                h.bins
                    .iter()
                    .map(|b| match b.to >= 1.0 {
                        true => format!("[{}, {}]", b.from, b.to),
                        false => format!("[{}, {})", b.from, b.to),
                    })
                    .collect::<Vec<_>>()
                    .join(" | ")
            })
            .unwrap_or_default(),
        "---|".repeat(t.held_out.first().map_or(0, |h| h.bins.len()))
    );
    for h in &t.held_out {
        let cells: Vec<String> = h
            .bins
            .iter()
            .map(|b| format!("{}, {}", b.cells, b.right))
            .collect();
        let _ = writeln!(s, "| {} | {} |", h.plane.name(), cells.join(" | "));
    }
    let _ = writeln!(s);
}

#[cfg(test)]
mod tests {
    use super::*;
    use pendulum_atlas_map::map::confidence::Bin;

    fn cell(bin: Bin, right: bool) -> ScoredCell {
        ScoredCell {
            bin: Some(bin),
            confidence: None,
            regime_confidence: Some(1.0),
            right,
        }
    }

    /// `n` chaotic cells with agreeing neighbours, `right` of them right.
    fn plane(plane: Plane, n: usize, right: usize) -> PlaneCells {
        let cells: Vec<ScoredCell> = (0..n).map(|i| cell(Bin::ChaoticAll, i < right)).collect();
        PlaneCells {
            plane,
            raw: cells.clone(),
            settled: cells,
        }
    }

    #[test]
    fn a_held_out_plane_is_scored_by_the_table_of_the_other_planes_only() {
        // Forcing: every cell right; clearance: half. Held out, forcing meets clearance's
        // 0.5 and has no firm cell; clearance meets forcing's 1.0 and is firm, half right.
        let planes = [
            plane(Plane::Forcing, 10, 10),
            plane(Plane::Clearance, 10, 5),
        ];
        let r = fit_planes(&planes, &[]).unwrap();
        for t in &r.tables {
            assert_eq!(t.pooled.chaotic_all, 0.75);
            let (f, c) = (&t.held_out[0], &t.held_out[1]);
            assert_eq!((f.plane, f.table.chaotic_all), (Plane::Forcing, 0.5));
            assert_eq!((f.firm.cells, f.firm.settled), (0, 10));
            assert_eq!((c.plane, c.table.chaotic_all), (Plane::Clearance, 1.0));
            assert_eq!((c.firm.cells, c.firm.right), (10, 5));
            assert!(!c.meets_target() && !f.meets_target());
        }
    }

    #[test]
    fn bins_rise_only_when_no_bin_of_enough_cells_is_right_less_often_than_the_one_below() {
        let row = |from: f64, cells, right| BinRow {
            from,
            to: from + 0.1,
            cells,
            right,
            mean_confidence: from,
        };
        assert!(rising(&[row(0.0, 5, 2), row(0.5, 5, 4), row(0.9, 20, 20)]));
        assert!(!rising(&[row(0.0, 5, 5), row(0.5, 5, 4)]));
        // A bin of fewer cells does not count.
        assert!(rising(&[row(0.0, 4, 4), row(0.5, 5, 4)]));
    }

    #[test]
    fn one_plane_or_a_plane_twice_is_refused_by_name() {
        let one = fit_planes(&[plane(Plane::Forcing, 3, 3)], &[]).unwrap_err();
        assert!(one.to_string().contains("at least 2"), "{one}");
        let twice = [plane(Plane::Piezo, 3, 3), plane(Plane::Piezo, 3, 3)];
        let e = fit_planes(&twice, &[]).unwrap_err();
        assert!(e.to_string().contains("`piezo` is given twice"), "{e}");
    }
}

//! The map's confidence stage: how likely each cell's verdict is the one a converged run gives
//! (`verdict_confidence`), from the verdict and how many of its grid neighbours share it.
//!
//! The λ1 probability of the reductions (`regime_confidence`, `Φ(m/σ)`) answers "is λ1 on this
//! side of its class boundary over this window". It is 1.0 on cells whose verdict is wrong:
//! transient chaos near the periodic windows, orbits on a window's border. Those cells have
//! neighbours with another verdict. So the stage looks up the accuracy measured against the
//! converged reference of `pendulum-atlas-lab verdict` for the cell's class and its
//! neighbourhood:
//!
//! ```text
//! agreement a = (neighbours with the cell's verdict) / (neighbours)
//!               neighbours: the cells one step away along any set of axes (8 in a plane)
//!                      raw map (SHIPPED)   settled map (SETTLED, the default)
//! chaotic:  a = 1      0.989               0.994
//!           a < 1      0.473               0.618
//! periodic: a ≥ ½      1                   0.996
//!           a < ½      0.974               1
//! regular:  every a    0.4                 0.4
//! no neighbour (a one-cell map): the class's mean, chaotic 0.901 / 0.938, periodic 0.996 / 0.997
//! verdict_confidence = min(that, regime_confidence); NaN where undecided or failed
//! start decides (the cell's nudged copies disagree in a share s > 0, `map::transients`):
//!                     at most FIRM·(1 − s), never firm
//! own orbit unstable (a periodic cell whose orbit the orbit stage found unstable):
//!                     at most 0.5
//! ```
//!
//! Each table is fitted on three planes at N = 3 and 34 s, each scored against its own
//! converged reference (`pendulum-atlas-lab verdict --plane P`: two 192-cell subgrids per
//! plane, runs of 1000 s and 2000 s at rtol 1e-6) and pooled by `pendulum-atlas-lab verdict-fit`
//! (`docs/bench/PLANES.md`, 2026-11-27): the default forcing plane, frequency × clearance at
//! 9 mm, and the forcing plane with the piezo patch; 1134 settled cells. [`SHIPPED`] is fitted on
//! the raw maps, [`SETTLED`] on the maps settled to 68 s from their end (whose cells run on
//! were chosen by the tables before these). Each plane held out of the fit and scored by the
//! table of the other two: settled, 86.6–88.3 % of its settled cells at 0.9 or above, 99.4–99.7 %
//! of those right; raw, 83.6–86.3 %, 98.5–99.4 % right; on every plane the bins are right more
//! often as the confidence rises. Measured on those planes, N and run length: a map far from
//! them reads the table as a guide, not a measurement (`FITTED_ON`; `map.json`'s
//! `regime.confidence` says so). A regular verdict is the weak bin (0.4): against a reference
//! converged in its steps almost no cell is regular, and the map's regular cells are stable
//! orbits whose period it has not yet confirmed.

use pendulum_atlas_core::config::c_order_index;
use pendulum_atlas_core::reduce::{InstanceResult, Regime};

/// The accuracy of each class and neighbourhood, measured against a converged reference.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Calibration {
    /// A chaotic verdict whose neighbours all agree.
    pub chaotic_all: f64,
    /// A chaotic verdict with a neighbour of another verdict.
    pub chaotic_some: f64,
    /// A periodic verdict shared by at least half of its neighbours.
    pub periodic_half: f64,
    /// A periodic verdict shared by fewer than half.
    pub periodic_few: f64,
    /// A regular verdict.
    pub regular: f64,
    /// A chaotic verdict over all neighbourhoods (a cell without neighbours).
    pub chaotic_mean: f64,
    /// A periodic verdict over all neighbourhoods.
    pub periodic_mean: f64,
}

/// The table of a raw map (`map.settle = false`; see the module's documentation).
pub const SHIPPED: Calibration = Calibration {
    chaotic_all: 0.989,
    chaotic_some: 0.473,
    periodic_half: 1.0,
    periodic_few: 0.974,
    regular: 0.4,
    chaotic_mean: 0.901,
    periodic_mean: 0.996,
};

/// The table of a settled map (the default): the three planes' maps settled to 68 s from
/// their end, measured on the same subgrids (`docs/bench/PLANES.md`). Refitted on maps that
/// chose the cells to run on with these tables (rather than the earlier ones), every entry is
/// the same but `regular`, 0.5 from a handful of cells (below 0.9 either way): kept at 0.4.
pub const SETTLED: Calibration = Calibration {
    chaotic_all: 0.994,
    chaotic_some: 0.618,
    periodic_half: 0.996,
    periodic_few: 1.0,
    regular: 0.4,
    chaotic_mean: 0.938,
    periodic_mean: 0.997,
};

/// The bins of the table: (class, neighbourhood).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Bin {
    /// Chaotic, every neighbour agreeing.
    ChaoticAll,
    /// Chaotic, some neighbour not.
    ChaoticSome,
    /// Periodic, at least half agreeing.
    PeriodicHalf,
    /// Periodic, fewer.
    PeriodicFew,
    /// Regular.
    Regular,
    /// Chaotic without neighbours.
    ChaoticAlone,
    /// Periodic without neighbours.
    PeriodicAlone,
}

impl Bin {
    /// The bin of `verdict` with neighbour agreement `agreement` (`None`: no neighbour);
    /// `None` for undecided and failed cells.
    pub fn of(verdict: Regime, agreement: Option<f64>) -> Option<Bin> {
        Some(match (verdict, agreement) {
            (Regime::Chaotic, None) => Bin::ChaoticAlone,
            (Regime::Chaotic, Some(a)) if a >= 1.0 => Bin::ChaoticAll,
            (Regime::Chaotic, Some(_)) => Bin::ChaoticSome,
            (Regime::Periodic, None) => Bin::PeriodicAlone,
            (Regime::Periodic, Some(a)) if a >= 0.5 => Bin::PeriodicHalf,
            (Regime::Periodic, Some(_)) => Bin::PeriodicFew,
            (Regime::Regular, _) => Bin::Regular,
            _ => return None,
        })
    }
}

impl Calibration {
    /// The accuracy of `bin`.
    pub fn of(&self, bin: Bin) -> f64 {
        match bin {
            Bin::ChaoticAll => self.chaotic_all,
            Bin::ChaoticSome => self.chaotic_some,
            Bin::PeriodicHalf => self.periodic_half,
            Bin::PeriodicFew => self.periodic_few,
            Bin::Regular => self.regular,
            Bin::ChaoticAlone => self.chaotic_mean,
            Bin::PeriodicAlone => self.periodic_mean,
        }
    }

    /// The table measured on `cells`: (bin, whether the verdict was right) of settled cells
    /// with a neighbourhood; a bin without cells gets NaN.
    pub fn fit(cells: &[(Bin, bool)]) -> Calibration {
        let share = |keep: &dyn Fn(Bin) -> bool| {
            let (n, right) = cells
                .iter()
                .filter(|(b, _)| keep(*b))
                .fold((0usize, 0usize), |(n, r), (_, ok)| {
                    (n + 1, r + usize::from(*ok))
                });
            if n == 0 {
                f64::NAN
            } else {
                (1000.0 * right as f64 / n as f64).round() / 1000.0
            }
        };
        Calibration {
            chaotic_all: share(&|b| b == Bin::ChaoticAll),
            chaotic_some: share(&|b| b == Bin::ChaoticSome),
            periodic_half: share(&|b| b == Bin::PeriodicHalf),
            periodic_few: share(&|b| b == Bin::PeriodicFew),
            regular: share(&|b| b == Bin::Regular),
            chaotic_mean: share(&|b| matches!(b, Bin::ChaoticAll | Bin::ChaoticSome)),
            periodic_mean: share(&|b| matches!(b, Bin::PeriodicHalf | Bin::PeriodicFew)),
        }
    }
}

/// The calibrated accuracy of `verdict` with neighbour agreement `agreement` (`None`: no
/// neighbour) in the map's table; NaN for undecided and failed cells.
pub fn calibrated(verdict: Regime, agreement: Option<f64>) -> f64 {
    Bin::of(verdict, agreement).map_or(f64::NAN, |b| SHIPPED.of(b))
}

/// The share of cell `k`'s neighbours on a grid of `shape` (C order) whose verdict is `v(k)`;
/// `None` when it has none.
pub fn agreement(shape: &[usize], k: usize, v: impl Fn(usize) -> Regime) -> Option<f64> {
    let index = c_order_index(shape, k);
    let (mut same, mut all) = (0usize, 0usize);
    for offset in offsets(shape.len()) {
        let Some(n) = neighbour(shape, &index, offset) else {
            continue;
        };
        all += 1;
        same += usize::from(v(n) == v(k));
    }
    (all > 0).then(|| same as f64 / all as f64)
}

/// The moves to the neighbours of a cell of a `dims`-axis grid, as [`neighbour`] reads them:
/// every base-3 number of `dims` digits but the one whose digits are all 1 (no move).
fn offsets(dims: usize) -> impl Iterator<Item = usize> {
    let all = 3usize.pow(dims as u32);
    (0..all).filter(move |&o| o != (all - 1) / 2)
}

/// The cell at `index` moved by `offset` read in base 3 (digit 0: −1, 1: 0, 2: +1 per axis),
/// or `None` off the grid.
fn neighbour(shape: &[usize], index: &[usize], mut offset: usize) -> Option<usize> {
    let mut flat = 0usize;
    for (&n, &i) in shape.iter().zip(index) {
        let moved = (i + offset % 3).checked_sub(1).filter(|&j| j < n)?;
        flat = flat * n + moved;
        offset /= 3;
    }
    Some(flat)
}

/// Where both tables were fitted (`docs/bench/VERDICT.md`).
pub(crate) const FITTED_ON: &str = "three planes at N = 3 and 34 s (excitation.frequency_hz x excitation.amplitude_m; excitation.frequency_hz x limiter.clearance_deg at 9 mm; the forcing plane with the piezo patch): 1134 cells of six subgrids against converged references";

/// The table a whole map `run` reads, by name: [`SETTLED`] where it settled, else [`SHIPPED`].
fn table_of(run: &crate::map::MapRun) -> (&'static str, &'static Calibration) {
    match run.settle {
        Some(_) => ("settled", &SETTLED),
        None => ("shipped", &SHIPPED),
    }
}

/// What the confidence stage says of a map as a whole (`map.json`'s `regime.confidence`):
/// how many of its verdicts are firm, and how many the table expects right.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    /// The table the map read (`settled` or `shipped`).
    pub table: &'static str,
    /// Where that table was fitted (`FITTED_ON`).
    pub fitted_on: &'static str,
    /// Cells with a verdict (not undecided, not failed).
    pub decided: usize,
    /// Of those, cells at `verdict_confidence` ≥ [`FIRM`](pendulum_atlas_core::config::FIRM).
    pub firm: usize,
    /// `firm / decided`.
    pub firm_share: f64,
    /// The share of the decided cells the table expects right: their mean confidence.
    pub expected_right: f64,
    /// The same over the firm cells.
    pub expected_right_firm: f64,
    /// Decided cells whose nudged copies disagree with them: the start decides there
    /// (`start_sensitivity` > 0; `None` where the map ran no copies).
    pub start_decides: Option<usize>,
    /// `start_decides / decided`.
    pub start_decides_share: Option<f64>,
    /// The share of the other decided cells the table expects right: their mean confidence.
    pub expected_right_elsewhere: Option<f64>,
    /// What the figures hold for.
    pub note: &'static str,
}

/// The map's [`Summary`] (`None`: no cell has a verdict confidence).
pub fn summary(run: &crate::map::MapRun) -> Option<Summary> {
    let firm_at = pendulum_atlas_core::config::FIRM;
    let all: Vec<f64> = run
        .results
        .iter()
        .map(|r| r.verdict_confidence)
        .filter(|c| c.is_finite())
        .collect();
    let firm: Vec<f64> = all.iter().copied().filter(|&c| c >= firm_at).collect();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let table = table_of(run).0;
    let sensitive = run.transients.as_ref().map(|t| {
        let (mut decides, mut elsewhere) = (0usize, Vec::new());
        for (k, r) in run.results.iter().enumerate() {
            if !r.verdict_confidence.is_finite() {
                continue;
            }
            match t.start_decides_at(k) {
                true => decides += 1,
                false => elsewhere.push(r.verdict_confidence),
            }
        }
        (decides, mean(&elsewhere))
    });
    (!all.is_empty()).then(|| Summary {
        table,
        fitted_on: FITTED_ON,
        decided: all.len(),
        firm: firm.len(),
        firm_share: firm.len() as f64 / all.len() as f64,
        expected_right: mean(&all),
        expected_right_firm: mean(&firm),
        start_decides: sensitive.map(|s| s.0),
        start_decides_share: sensitive.map(|s| s.0 as f64 / all.len() as f64),
        expected_right_elsewhere: sensitive.map(|s| s.1),
        note: "expected from the table, measured on the planes it was fitted on and on each of them held out of the fit; on other keys, N or run lengths it is a guide, not a measurement (docs/bench/PLANES.md)",
    })
}

/// Fill `verdict_confidence` of a whole map `run` of `shape`: its cells, and each leg of a
/// continuation (the first leg's results are the cells). A settled run reads [`SETTLED`],
/// any other [`SHIPPED`].
pub(crate) fn fill_run(shape: &[usize], run: &mut crate::map::MapRun) {
    let table = table_of(run).1;
    fill(shape, &mut run.results, table);
    if let Some(t) = &run.transients {
        for (r, &s) in run.results.iter_mut().zip(&t.sensitivity) {
            r.verdict_confidence = held_by_sensitivity(r.verdict_confidence, s);
        }
    }
    if let Some(o) = &run.orbits {
        for (k, r) in run.results.iter_mut().enumerate() {
            if own_orbit_unstable(r, o, k) {
                r.verdict_confidence = r.verdict_confidence.min(UNSTABLE_OWN_ORBIT);
            }
        }
    }
    if let Some(c) = &mut run.continuation {
        for leg in &mut c.legs {
            fill(shape, &mut leg.results, table);
        }
    }
}

/// The most a periodic verdict whose own orbit converged unstable is trusted: the cell's
/// trajectory cannot stay on that orbit, so the detector's period names a passage near it
/// (on the default map the converged reference gave period 6 where such a cell said 3).
pub const UNSTABLE_OWN_ORBIT: f64 = 0.5;

/// Whether cell `k` with result `r` is periodic and its own orbit (the orbit stage's `o`)
/// converged unstable.
pub(crate) fn own_orbit_unstable(
    r: &InstanceResult,
    o: &pendulum_atlas_core::reduce::orbits::OrbitMap,
    k: usize,
) -> bool {
    r.regime == Regime::Periodic && o.own_orbit(k).is_some_and(|x| !x.orbit.stable())
}

/// A confidence `c` of a cell whose nudged copies disagree with it in a share `s` (NaN: it
/// ran none): at most `FIRM·(1 − s)` where `s > 0`, so that a cell where the start decides is
/// never firm; unchanged otherwise.
pub fn held_by_sensitivity(c: f64, s: f64) -> f64 {
    if s > 0.0 {
        c.min(pendulum_atlas_core::config::FIRM * (1.0 - s))
    } else {
        c
    }
}

/// Fill `verdict_confidence` of every cell of a map of `shape` whose results hold a verdict,
/// from `table`.
pub fn fill(shape: &[usize], results: &mut [InstanceResult], table: &Calibration) {
    let verdicts: Vec<Regime> = results.iter().map(|r| r.regime).collect();
    for (k, r) in results.iter_mut().enumerate() {
        let a = agreement(shape, k, |j| verdicts[j]);
        let c = Bin::of(r.regime, a).map_or(f64::NAN, |b| table.of(b));
        r.verdict_confidence = c.min(r.regime_confidence);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbours_are_the_cells_one_step_away_along_any_axes() {
        // 3 × 4 plane: the centre-ish cell (1, 1) has 8, a corner 3, an edge 5.
        let shape = [3, 4];
        let count = |k: usize| {
            let idx = c_order_index(&shape, k);
            offsets(2)
                .filter_map(|o| neighbour(&shape, &idx, o))
                .count()
        };
        assert_eq!(count(5), 8);
        let idx = c_order_index(&shape, 5);
        assert!(
            offsets(2)
                .filter_map(|o| neighbour(&shape, &idx, o))
                .all(|n| n != 5)
        );
        assert_eq!(count(0), 3);
        assert_eq!(count(1), 5);
        assert_eq!(count(11), 3);
        // A line: 2 inside, 1 at the ends; a cube's inner cell 26.
        let line = [5];
        assert_eq!(
            offsets(1).filter_map(|o| neighbour(&line, &[2], o)).count(),
            2
        );
        assert_eq!(
            offsets(1).filter_map(|o| neighbour(&line, &[0], o)).count(),
            1
        );
        let cube = [3, 3, 3];
        assert_eq!(
            (1..27)
                .filter_map(|o| neighbour(&cube, &[1, 1, 1], o))
                .count(),
            26
        );
    }

    #[test]
    fn agreement_counts_the_neighbours_with_the_same_verdict() {
        use Regime::{Chaotic as C, Periodic as P};
        // 3 × 3, periodic only in the middle row's left cell.
        let grid = [C, C, C, P, C, C, C, C, C];
        let a = |k| agreement(&[3, 3], k, |j| grid[j]);
        assert_eq!(a(4), Some(7.0 / 8.0));
        assert_eq!(a(3), Some(0.0));
        assert_eq!(a(2), Some(1.0));
        assert_eq!(agreement(&[1], 0, |_| C), None);
        assert_eq!(calibrated(C, a(2)), SHIPPED.chaotic_all);
        assert_eq!(calibrated(C, a(4)), SHIPPED.chaotic_some);
        assert_eq!(calibrated(P, a(3)), SHIPPED.periodic_few);
        assert!(calibrated(Regime::Undecided, a(4)).is_nan());
    }

    #[test]
    fn a_fitted_table_is_the_share_right_per_bin() {
        let cells = [
            (Bin::ChaoticAll, true),
            (Bin::ChaoticAll, true),
            (Bin::ChaoticAll, false),
            (Bin::ChaoticSome, false),
            (Bin::Regular, true),
        ];
        let t = Calibration::fit(&cells);
        assert_eq!(t.chaotic_all, 0.667);
        assert_eq!(t.chaotic_some, 0.0);
        assert_eq!(t.chaotic_mean, 0.5);
        assert_eq!(t.regular, 1.0);
        assert!(t.periodic_half.is_nan());
    }
}

//! Stage 6 of `pendulum-atlas-lab verdict`: transient chaos, and what settling (`map.settle_max_s`)
//! buys.
//!
//! - **Transient chaos named**: the cells of both subgrids that the default map (as shipped)
//!   calls chaotic and the converged reference settles as periodic or regular, with the time
//!   the reference's longer run stopped them at (its early stop: the orbit confirmed and λ1
//!   shrinking; a regular orbit without a period runs to the end and has no such time).
//! - **Accuracy against cost**: the whole default map with `map.settle_max_s` at each of
//!   [`SETTLE_CURVE_S`] against the map without it: wall time, cells run on, and on the
//!   settled cells of both subgrids the share right and the firm verdicts (confidence ≥ 0.9).
//! - **The settled map's table**: the reliability of `verdict_confidence` on the map settled
//!   for [`SETTLED_TABLE_S`], which `confidence::SETTLED` ships.

use super::reference::Reference;
use super::reliability::{
    Firm, Reliability, Scored, firm_of, grid_index, reliability, score_subgrid,
};
use pendulum_atlas_core::config::SettleFrom;
use pendulum_atlas_core::engine::{Engine, EngineError, no_progress};
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::confidence::SETTLED;
use pendulum_atlas_map::map::{MapRun, run_map};
use serde::Serialize;

/// The settling times of the study's curve (s).
pub const SETTLE_CURVE_S: [f64; 4] = [68.0, 136.0, 272.0, 544.0];

/// The settling time whose map the `SETTLED` table is fitted on (s).
pub const SETTLED_TABLE_S: f64 = 68.0;

/// One subgrid's reference with where its cells lie on the whole map.
pub struct Subgrid<'a> {
    /// "A" or "B".
    pub name: &'static str,
    /// Its first value on each axis (every `thin`th after it).
    pub offset: usize,
    /// Its converged reference.
    pub reference: &'a Reference,
}

/// Transient chaos on both subgrids.
#[derive(Debug, Clone, Serialize)]
pub struct Transient {
    /// Settled cells (both subgrids).
    pub settled: usize,
    /// Of those, cells the map calls chaotic.
    pub chaotic: usize,
    /// Of those, cells the reference settles as periodic or regular.
    pub settle_later: usize,
    /// Their reference stop times (s), sorted; a regular cell without one is not listed.
    pub stop_s: Vec<f64>,
    /// Transient-chaos cells the reference ran to its end (regular, no period confirmed).
    pub not_stopped: usize,
}

/// One point of the accuracy/cost curve.
#[derive(Debug, Clone, Serialize)]
pub struct CurvePoint {
    /// `map.settle_max_s` (`None`: not settled).
    pub settle_max_s: Option<f64>,
    /// `map.settle_from` (`None`: not settled).
    pub from: Option<SettleFrom>,
    /// Wall time of the whole map (s).
    pub wall_s: f64,
    /// Cells run on.
    pub rerun: usize,
    /// Cells whose verdict the settling changed.
    pub changed: usize,
    /// Settled cells of both subgrids.
    pub settled: usize,
    /// Of those, right.
    pub right: usize,
    /// Transient-chaos cells (of [`Transient::settle_later`]) now right.
    pub transient_right: usize,
    /// The firm verdicts with the table the map applied.
    pub firm: Firm,
}

/// Everything stage 6 measured.
#[derive(Debug, Clone, Serialize)]
pub struct Settling {
    /// Transient chaos.
    pub transient: Transient,
    /// The map without settling, then each settling time.
    pub curve: Vec<CurvePoint>,
    /// The reliability of the map settled for [`SETTLED_TABLE_S`] (its table: `SETTLED`).
    pub reliability: Reliability,
}

/// The grid index of each settled cell of `g`, with the reference's verdict and stop time.
fn settled_cells(g: &Subgrid, shape: &[usize], thin: usize) -> Vec<(usize, i8, f64)> {
    let r = g.reference;
    (0..r.regime.len())
        .filter(|&j| r.is_settled[j])
        .map(|j| {
            (
                grid_index(shape, (thin, g.offset), j),
                r.regime[j],
                r.stop_s[j],
            )
        })
        .collect()
}

fn is_transient(map: Regime, reference: i8) -> bool {
    map == Regime::Chaotic
        && (reference == Regime::Periodic.code() || reference == Regime::Regular.code())
}

/// Transient chaos of the unsettled map `whole` on `grids`.
fn transient(whole: &MapRun, cells: &[(usize, i8, f64)]) -> Transient {
    let chaotic: Vec<&(usize, i8, f64)> = cells
        .iter()
        .filter(|c| whole.results[c.0].regime == Regime::Chaotic)
        .collect();
    let later: Vec<&&(usize, i8, f64)> = chaotic
        .iter()
        .filter(|c| is_transient(Regime::Chaotic, c.1))
        .collect();
    let mut stop_s: Vec<f64> = later
        .iter()
        .map(|c| c.2)
        .filter(|t| t.is_finite())
        .collect();
    stop_s.sort_by(f64::total_cmp);
    Transient {
        settled: cells.len(),
        chaotic: chaotic.len(),
        settle_later: later.len(),
        not_stopped: later.len() - stop_s.len(),
        stop_s,
    }
}

/// One point of the curve: `run` scored on `cells`; `whole` is the unsettled map.
fn point(
    run: &MapRun,
    whole: &MapRun,
    cells: &[(usize, i8, f64)],
    settle_max_s: Option<f64>,
) -> CurvePoint {
    let from = run.settle.as_ref().map(|s| s.from);
    let right = |k: usize, want: i8| run.results[k].regime.code() == want;
    let scored: Vec<(f64, bool)> = cells
        .iter()
        .map(|&(k, want, _)| (run.results[k].verdict_confidence, right(k, want)))
        .collect();
    CurvePoint {
        settle_max_s,
        from,
        wall_s: run.timings.total_s,
        rerun: run.settle.as_ref().map_or(0, |s| s.cells),
        changed: run.settle.as_ref().map_or(0, |s| s.changed),
        settled: cells.len(),
        right: scored.iter().filter(|c| c.1).count(),
        transient_right: cells
            .iter()
            .filter(|&&(k, want, _)| is_transient(whole.results[k].regime, want) && right(k, want))
            .count(),
        firm: firm_of(&scored, cells.len()),
    }
}

/// Stage 6: `whole` is the default map as shipped, `spec_with` the default map with `--set`
/// overrides, `grids` the two subgrids (every `thin`th value).
pub fn settling(
    whole: &MapRun,
    spec_with: &dyn Fn(&[String]) -> Result<pendulum_atlas_core::config::MapSpec, EngineError>,
    (grids, thin): (&[Subgrid; 2], usize),
    quick: bool,
    progress: &dyn Fn(&str),
) -> Result<Settling, EngineError> {
    let shape = spec_with(&[])?.shape();
    let per: Vec<Vec<(usize, i8, f64)>> = grids
        .iter()
        .map(|g| settled_cells(g, &shape, thin))
        .collect();
    let cells: Vec<(usize, i8, f64)> = per.concat();
    let transient = transient(whole, &cells);
    let mut curve = vec![point(whole, whole, &cells, None)];
    let engine = Engine::cpu(whole.engine.precision);
    let times: &[f64] = if quick {
        &SETTLE_CURVE_S[..1]
    } else {
        &SETTLE_CURVE_S
    };
    let mut table_run = None;
    // Every time from the map's end (the default); the table's time from the start too,
    // which is one run of that length.
    let runs = times.iter().flat_map(|&t| {
        let starts = (t == SETTLED_TABLE_S).then_some((t, SettleFrom::Start));
        std::iter::once((t, SettleFrom::End)).chain(starts)
    });
    for (t, from) in runs {
        let spec = spec_with(&[
            format!("map.settle_max_s={t}"),
            format!("map.settle_from=\"{}\"", from.name()),
        ])?;
        let run = run_map(&spec, &engine, &no_progress)?;
        let p = point(&run, whole, &cells, Some(t));
        progress(&format!(
            "settle {t} s from the {}: {} cells run on, {}/{} right, {} firm ({:.1} s)",
            from.name(),
            p.rerun,
            p.right,
            p.settled,
            p.firm.cells,
            p.wall_s
        ));
        curve.push(p);
        if t == SETTLED_TABLE_S && from == SettleFrom::End {
            table_run = Some(run);
        }
    }
    let run = table_run.expect("the curve holds the table's settling time");
    let scored: Vec<Scored> = grids
        .iter()
        .map(|g| {
            let r = g.reference;
            score_subgrid(
                g.name,
                &run,
                &shape,
                (thin, g.offset),
                &r.regime,
                &r.is_settled,
            )
        })
        .collect();
    Ok(Settling {
        transient,
        curve,
        reliability: reliability(&scored[0], &scored[1], &SETTLED),
    })
}

//! Continuation, the map planner's stage for hysteresis (`docs/analysis.md`, "Continuation and
//! hysteresis"): the cells along one axis run one after another, each from the state its
//! neighbour ended in, as an experiment sweeps its frequency and the harvester stays on the
//! attractor it is on until that attractor ends.
//!
//! Stages of `continue_map`, per direction (up, down, or up then down):
//! 1. **Path**: the axis's indices in the order of the direction, by value
//!    ([`ContinuationSpec::order`]). Every grid line along the axis (every combination of the
//!    other axes) is one path, and all lines step together: step `j` runs, in one ensemble, the
//!    cells at the `j`-th value of every line.
//! 2. **Start**: a cell of step 0 starts from the scene's state; a later cell from the state
//!    `[θ; θ̇; v]` its predecessor on the line ended in, at a whole number of forcing periods,
//!    so the forcing phase carries on too (`excitation.phase_deg` is the same for both). A
//!    cell whose predecessor failed starts from the scene's state again and is counted as
//!    restarted; so does a cell whose bumpers the carried state lies beyond, deeper than it
//!    lay beyond its predecessor's (`carried_state_fits`: a step to a smaller clearance),
//!    counted as restarted and as `beyond_bumpers`.
//! 3. **Hysteresis** (both directions): a cell's two runs differ when their fingerprints
//!    ([`Fingerprint`], the rule of [`AttractorRule`]) are not one attractor, or one failed and
//!    the other did not. Consecutive differing cells of a line form a band, reported with its
//!    ends in the axis's unit.

use pendulum_atlas_core::config::{ContinuationSpec, Direction, MapSpec, c_order_index};
use pendulum_atlas_core::engine::EngineError;
use pendulum_atlas_core::model::{Chain, ModelParams};
use pendulum_atlas_core::reduce::{AttractorRule, Fingerprint, InstanceResult};
use serde::Serialize;

/// What one ensemble of a path's step brings back, in the order of its cells.
pub(crate) struct StepRun {
    /// Each cell's results.
    pub results: Vec<InstanceResult>,
    /// Each cell's stroboscopic tail.
    pub strobe_tail: Vec<Vec<f64>>,
    /// Each cell's final state `[θ; θ̇; v]`.
    pub final_state: Vec<Vec<f64>>,
}

/// One direction's run over the whole grid.
#[derive(Debug, Clone, Serialize)]
pub struct Leg {
    /// Up or down.
    pub direction: Direction,
    /// Per grid point, in grid order.
    #[serde(skip)]
    pub results: Vec<InstanceResult>,
    /// Per grid point, its stroboscopic tail.
    #[serde(skip)]
    pub strobe_tail: Vec<Vec<f64>>,
    /// Cells that started from the scene's state because their predecessor failed or ended
    /// beyond their bumpers.
    pub restarted: usize,
    /// Of those, the cells whose predecessor's final state lay beyond their bumpers.
    pub beyond_bumpers: usize,
}

/// A stretch of one grid line along the axis where the two directions differ.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Band {
    /// The other axes' values of the line (in `map.axes` order, the continuation axis left out).
    pub line: Vec<f64>,
    /// The smallest and largest axis value of the stretch (the axis's unit).
    pub from: f64,
    /// See `from`.
    pub to: f64,
    /// Cells in the stretch.
    pub cells: usize,
}

/// Where the two directions of a map run both ways differ.
#[derive(Debug, Clone, Serialize)]
pub struct Hysteresis {
    /// Per grid point, whether up and down ended on different attractors.
    #[serde(skip)]
    pub differs: Vec<bool>,
    /// Cells that differ.
    pub cells: usize,
    /// The stretches of differing cells, line by line.
    pub bands: Vec<Band>,
    /// The rule that compared the two runs of a cell.
    pub rule: AttractorRule,
}

/// A map run by continuation: one leg per direction, and the hysteresis of both.
#[derive(Debug, Clone, Serialize)]
pub struct ContinuationRun {
    /// The axis key, the direction(s).
    pub spec: ContinuationSpec,
    /// One per direction, in the order run; the first one's results are the map's arrays.
    pub legs: Vec<Leg>,
    /// With both directions: where they differ.
    pub hysteresis: Option<Hysteresis>,
}

/// Whether a state `y` that a cell of `prev` ended in may start a cell of `next`: on each
/// side, it lies no deeper beyond `next`'s bumper than it lay beyond `prev`'s (or not beyond
/// it at all). A state leaning on its bumper is carried on; one that a smaller clearance would
/// put inside the bumper is not (the penalty contact would start from a penetration no motion
/// of the beam produced).
pub(crate) fn carried_state_fits(prev: &ModelParams, next: &ModelParams, y: &[f64]) -> bool {
    let depth = |p: &ModelParams| Chain::<f64>::new(p).penetrations(y);
    match (depth(prev), depth(next)) {
        (Some((pr, pl)), Some((nr, nl))) => {
            let tol = 1e-12;
            nr <= pr.max(0.0) + tol && nl <= pl.max(0.0) + tol
        }
        _ => true,
    }
}

/// Run `spec`'s continuation: `run(cells, starts)` integrates and reduces the grid points
/// `cells` together, each from its start (`None`: the scene's state); `fits(cell,
/// predecessor, state)` says whether a predecessor's final state may start the cell
/// ([`carried_state_fits`] of their parameters).
pub(crate) fn continue_map(
    spec: &MapSpec,
    cs: &ContinuationSpec,
    fits: impl Fn(usize, usize, &[f64]) -> bool,
    mut run: impl FnMut(&[usize], Vec<Option<Vec<f64>>>) -> Result<StepRun, EngineError>,
) -> Result<ContinuationRun, EngineError> {
    let legs = cs
        .sweep
        .directions()
        .iter()
        .map(|&d| run_leg(spec, cs, d, &fits, &mut run))
        .collect::<Result<Vec<Leg>, EngineError>>()?;
    let hysteresis = (legs.len() == 2).then(|| hysteresis(spec, cs, &legs[0], &legs[1]));
    Ok(ContinuationRun {
        spec: cs.clone(),
        legs,
        hysteresis,
    })
}

/// The grid points at the `j`-th axis value of every line, as (point, predecessor) pairs.
pub(crate) fn step_cells(
    shape: &[usize],
    axis: usize,
    order: &[usize],
    j: usize,
) -> Vec<(usize, Option<usize>)> {
    let n: usize = shape.iter().product();
    let stride: usize = shape[axis + 1..].iter().product();
    (0..n)
        .filter(|&k| c_order_index(shape, k)[axis] == order[j])
        .map(|k| {
            let prev = (j > 0).then(|| k + stride * order[j - 1] - stride * order[j]);
            (k, prev)
        })
        .collect()
}

fn run_leg(
    spec: &MapSpec,
    cs: &ContinuationSpec,
    direction: Direction,
    fits: &impl Fn(usize, usize, &[f64]) -> bool,
    run: &mut impl FnMut(&[usize], Vec<Option<Vec<f64>>>) -> Result<StepRun, EngineError>,
) -> Result<Leg, EngineError> {
    let shape = spec.shape();
    let n: usize = shape.iter().product();
    let order = cs.order(&spec.axes, direction);
    let mut results: Vec<Option<InstanceResult>> = vec![None; n];
    let mut tails = vec![Vec::new(); n];
    let mut finals: Vec<Option<Vec<f64>>> = vec![None; n];
    let (mut restarted, mut beyond_bumpers) = (0, 0);
    for j in 0..order.len() {
        let pairs = step_cells(&shape, cs.axis, &order, j);
        let cells: Vec<usize> = pairs.iter().map(|p| p.0).collect();
        let starts: Vec<Option<Vec<f64>>> = pairs
            .iter()
            .map(|&(k, prev)| {
                let (p, y) = (prev?, finals[prev?].clone()?);
                let fit = fits(k, p, &y);
                beyond_bumpers += usize::from(!fit);
                fit.then_some(y)
            })
            .collect();
        restarted += pairs
            .iter()
            .zip(&starts)
            .filter(|((_, prev), s)| prev.is_some() && s.is_none())
            .count();
        let step = run(&cells, starts)?;
        for (i, &k) in cells.iter().enumerate() {
            let r = step.results[i];
            finals[k] = r.status.is_ok().then(|| step.final_state[i].clone());
            results[k] = Some(r);
            tails[k] = step.strobe_tail[i].clone();
        }
    }
    Ok(Leg {
        direction,
        results: results
            .into_iter()
            .map(|r| r.expect("every step covers its cells"))
            .collect(),
        strobe_tail: tails,
        restarted,
        beyond_bumpers,
    })
}

/// Whether the two runs of one cell ended on different attractors.
fn cell_differs(
    a: (&InstanceResult, &[f64]),
    b: (&InstanceResult, &[f64]),
    rule: AttractorRule,
) -> bool {
    match (Fingerprint::of(a.0, a.1), Fingerprint::of(b.0, b.1)) {
        (Some(x), Some(y)) => !x.same_as(&y, rule.cycle_tol_rad, rule.range_overlap),
        (None, None) => false,
        _ => true,
    }
}

fn hysteresis(spec: &MapSpec, cs: &ContinuationSpec, up: &Leg, down: &Leg) -> Hysteresis {
    let rule = AttractorRule::for_period_tol(spec.period_tol_rad);
    let differs: Vec<bool> = (0..up.results.len())
        .map(|k| {
            cell_differs(
                (&up.results[k], &up.strobe_tail[k]),
                (&down.results[k], &down.strobe_tail[k]),
                rule,
            )
        })
        .collect();
    Hysteresis {
        cells: differs.iter().filter(|&&d| d).count(),
        bands: bands(spec, cs, &differs),
        differs,
        rule,
    }
}

/// The stretches of differing cells along the axis, line by line, in the up direction.
fn bands(spec: &MapSpec, cs: &ContinuationSpec, differs: &[bool]) -> Vec<Band> {
    let shape = spec.shape();
    let order = cs.order(&spec.axes, Direction::Up);
    let values = &spec.axes[cs.axis].values;
    let starts = step_cells(&shape, cs.axis, &order, 0);
    let stride: usize = shape[cs.axis + 1..].iter().product();
    let mut out = Vec::new();
    for (first, _) in starts {
        let base = first - stride * order[0];
        let idx = c_order_index(&shape, first);
        let line: Vec<f64> = (0..shape.len())
            .filter(|&d| d != cs.axis)
            .map(|d| spec.axes[d].values[idx[d]])
            .collect();
        let mut open: Option<Band> = None;
        for &i in &order {
            let v = values[i];
            match (differs[base + stride * i], open.as_mut()) {
                (true, Some(b)) => {
                    b.to = v;
                    b.cells += 1;
                }
                (true, None) => {
                    open = Some(Band {
                        line: line.clone(),
                        from: v,
                        to: v,
                        cells: 1,
                    })
                }
                (false, _) => out.extend(open.take()),
            }
        }
        out.extend(open);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_step_pairs_each_cell_with_its_neighbour_on_the_previous_value() {
        // A 3 × 4 grid continued along axis 1 downwards: order 3, 2, 1, 0.
        let shape = [3, 4];
        let order = [3, 2, 1, 0];
        assert_eq!(
            step_cells(&shape, 1, &order, 0),
            vec![(3, None), (7, None), (11, None)]
        );
        assert_eq!(
            step_cells(&shape, 1, &order, 2),
            vec![(1, Some(2)), (5, Some(6)), (9, Some(10))]
        );
        // Along axis 0 upwards: a step is a row, its predecessor the row before.
        assert_eq!(
            step_cells(&shape, 0, &[0, 1, 2], 1),
            vec![(4, Some(0)), (5, Some(1)), (6, Some(2)), (7, Some(3))]
        );
    }
}

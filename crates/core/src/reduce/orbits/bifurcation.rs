//! Bifurcation curves: where an orbit family changes between two neighbouring cells.
//!
//! ```text
//! indicator g:    period doubling  μ₋ + 1   (μ₋: the real multiplier nearest −1)
//!                 fold             μ₊ − 1   (μ₊: the real multiplier nearest +1)
//!                 grazing          the orbit's least bumper margin (m)
//! crossing:       one family at both cells, g of opposite signs there
//! located:        bisection along the segment between the cells' parameters, the orbit
//!                 corrected at each midpoint from the bracket's ends (LOCATE_STEPS halvings:
//!                 to 1/2^(LOCATE_STEPS+1) of the cell step, or less where shooting failed)
//! curves:         on a plane, the crossings of one kind and period on the four edges of a
//!                 grid square joined two by two, segments chained into polylines; elsewhere
//!                 each crossing is a curve of one point
//! ```

use super::{Orbit, OrbitMap, Strobe, find_orbit, scales};
use crate::config::c_order_index;
use crate::engine::plan::InstancePlan;
use rayon::prelude::*;
use serde::Serialize;

/// Halvings of a crossing's bracket.
pub const LOCATE_STEPS: u32 = 4;

/// What changes at a crossing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BifurcationKind {
    /// A real multiplier crosses −1.
    PeriodDoubling,
    /// A real multiplier crosses +1.
    Fold,
    /// The orbit's least bumper margin crosses zero.
    Grazing,
}

impl BifurcationKind {
    /// Every kind.
    pub const ALL: [BifurcationKind; 3] = [
        BifurcationKind::PeriodDoubling,
        BifurcationKind::Fold,
        BifurcationKind::Grazing,
    ];

    /// The name `bifurcations.json` gives it.
    pub fn name(self) -> &'static str {
        match self {
            BifurcationKind::PeriodDoubling => "period_doubling",
            BifurcationKind::Fold => "fold",
            BifurcationKind::Grazing => "grazing",
        }
    }

    /// The indicator g of an orbit (NaN where it has none).
    pub fn indicator(self, o: &Orbit) -> f64 {
        match self {
            BifurcationKind::PeriodDoubling => o.multipliers.near_minus_one + 1.0,
            BifurcationKind::Fold => o.multipliers.near_plus_one - 1.0,
            BifurcationKind::Grazing => o.margin_m,
        }
    }
}

/// A crossing on the edge between two neighbouring cells.
#[derive(Debug, Clone, Serialize)]
pub struct Crossing {
    /// What crosses.
    pub kind: BifurcationKind,
    /// The orbit family.
    pub family: usize,
    /// Its period.
    pub period: u32,
    /// The two cells (the second one step further along `axis`).
    pub cells: (usize, usize),
    /// The axis between them.
    pub axis: usize,
    /// Where, as a share of the step from the first cell to the second.
    pub at: f64,
    /// Half the final bracket (share of the step): the crossing lies within `at ± tol`.
    pub tol: f64,
}

/// A bifurcation curve: crossings of one kind and period, joined.
#[derive(Debug, Clone, Serialize)]
pub struct Curve {
    /// What crosses.
    pub kind: BifurcationKind,
    /// The orbit families it was found on (one, unless continuation left one branch in
    /// several families).
    pub families: Vec<usize>,
    /// The orbits' period.
    pub period: u32,
    /// Points in axis values (one value per axis).
    pub points: Vec<Vec<f64>>,
    /// The largest bracket of its points (share of a cell step).
    pub tol: f64,
}

/// Cell `k`'s axis values.
pub type ValuesOf<'a> = &'a (dyn Fn(usize) -> Vec<f64> + Sync);
/// The instance planned at a point of the grid's parameter space (`None`: it cannot be).
pub type PlanAt<'a> = &'a (dyn Fn(&[f64]) -> Option<InstancePlan> + Sync);

/// Find, locate and join the crossings of `map`. `plan_at(values)` plans the instance at any
/// point of the grid's parameter space; `values(k)` gives cell `k`'s axis values.
pub fn curves(
    map: &OrbitMap,
    plans: &[InstancePlan],
    values: ValuesOf,
    plan_at: PlanAt,
) -> Vec<Curve> {
    let edges = crossing_edges(map);
    let crossings: Vec<Crossing> = edges
        .par_iter()
        .map(|e| locate(map, e, &plans[e.a.0], (values, plan_at)))
        .collect();
    join(map, &crossings, values)
}

/// An edge with a crossing before it is located: kind, (cell, orbit) at both ends, axis.
struct Edge {
    kind: BifurcationKind,
    a: (usize, usize),
    b: (usize, usize),
    axis: usize,
}

/// Every (kind, family) whose indicator changes sign between neighbouring cells.
fn crossing_edges(map: &OrbitMap) -> Vec<Edge> {
    let shape = &map.shape;
    let mut out = Vec::new();
    for c in 0..map.known.len() {
        let idx = c_order_index(shape, c);
        for axis in 0..shape.len() {
            if idx[axis] + 1 == shape[axis] {
                continue;
            }
            let n = c + shape[axis + 1..].iter().product::<usize>();
            for (i, oa) in map.known[c].iter().enumerate() {
                for (j, ob) in map.known[n].iter().enumerate() {
                    if oa.family != ob.family || oa.orbit.period != ob.orbit.period {
                        continue;
                    }
                    for kind in BifurcationKind::ALL {
                        let (ga, gb) = (kind.indicator(&oa.orbit), kind.indicator(&ob.orbit));
                        if ga * gb < 0.0 {
                            out.push(Edge {
                                kind,
                                a: (c, i),
                                b: (n, j),
                                axis,
                            });
                        }
                    }
                }
            }
        }
    }
    out
}

/// Locate the crossing on `e` by bisection.
fn locate(
    map: &OrbitMap,
    e: &Edge,
    plan_a: &InstancePlan,
    (values, plan_at): (ValuesOf, PlanAt),
) -> Crossing {
    let oa = &map.known[e.a.0][e.a.1];
    let ob = &map.known[e.b.0][e.b.1];
    let (va, vb) = (values(e.a.0), values(e.b.0));
    let (mut lo, mut hi) = (0.0, 1.0);
    let mut x_lo = oa.orbit.x().to_vec();
    let s_a = scales(&Strobe::<f64>::new(plan_a));
    let mut x_hi = ob.orbit.points[ob.orbit.nearest_point(oa.orbit.x(), &s_a).0].clone();
    let g_lo = e.kind.indicator(&oa.orbit);
    for _ in 0..LOCATE_STEPS {
        let mid = 0.5 * (lo + hi);
        let at: Vec<f64> = va.iter().zip(&vb).map(|(a, b)| a + mid * (b - a)).collect();
        let Some(plan) = plan_at(&at) else { break };
        let s = scales(&Strobe::<f64>::new(&plan));
        let guess: Vec<f64> = x_lo.iter().zip(&x_hi).map(|(a, b)| 0.5 * (a + b)).collect();
        let Ok(orbit) = find_orbit::<f64>(&plan, &guess, oa.orbit.period) else {
            break;
        };
        let g = e.kind.indicator(&orbit);
        if !g.is_finite() || orbit.period != oa.orbit.period {
            break;
        }
        // Keep the bracket's states on the same stroboscopic point.
        let x = orbit.points[orbit.nearest_point(&x_lo, &s).0].clone();
        if (g < 0.0) == (g_lo < 0.0) {
            (lo, x_lo) = (mid, x);
        } else {
            (hi, x_hi) = (mid, x);
        }
    }
    Crossing {
        kind: e.kind,
        family: oa.family,
        period: oa.orbit.period,
        cells: (e.a.0, e.b.0),
        axis: e.axis,
        at: 0.5 * (lo + hi),
        tol: 0.5 * (hi - lo),
    }
}

/// The crossings joined into curves (module doc).
fn join(map: &OrbitMap, crossings: &[Crossing], values: ValuesOf) -> Vec<Curve> {
    let point = |c: &Crossing| -> Vec<f64> {
        let (va, vb) = (values(c.cells.0), values(c.cells.1));
        va.iter()
            .zip(&vb)
            .map(|(a, b)| a + c.at * (b - a))
            .collect()
    };
    let links = if map.shape.len() == 2 {
        square_links(&map.shape, crossings)
    } else {
        vec![Vec::new(); crossings.len()]
    };
    let mut seen = vec![false; crossings.len()];
    let mut curves = Vec::new();
    // Open chains first (from an end), then closed loops.
    let starts: Vec<usize> = (0..crossings.len())
        .filter(|&i| links[i].len() < 2)
        .chain(0..crossings.len())
        .collect();
    for s in starts {
        if seen[s] {
            continue;
        }
        let mut chain = vec![s];
        seen[s] = true;
        let mut at = s;
        while let Some(&next) = links[at].iter().find(|&&j| !seen[j]) {
            seen[next] = true;
            chain.push(next);
            at = next;
        }
        let c0 = &crossings[s];
        let mut families: Vec<usize> = chain.iter().map(|&i| crossings[i].family).collect();
        families.sort_unstable();
        families.dedup();
        curves.push(Curve {
            kind: c0.kind,
            families,
            period: c0.period,
            points: chain.iter().map(|&i| point(&crossings[i])).collect(),
            tol: chain.iter().map(|&i| crossings[i].tol).fold(0.0, f64::max),
        });
    }
    curves
}

/// On a plane: for each crossing, the crossings it is joined to (the other crossing of its
/// kind and period on a grid square both edges bound; of four, paired in the order found).
/// Not by family: where continuation did not reach across, one branch carries several
/// family labels, and its curve would break at each.
fn square_links(shape: &[usize], crossings: &[Crossing]) -> Vec<Vec<usize>> {
    let mut links = vec![Vec::new(); crossings.len()];
    // The squares an edge bounds: an edge from (i, j) along axis 0 bounds the squares with
    // lower corners (i, j−1) and (i, j); along axis 1, (i−1, j) and (i, j).
    // Ordered, so that the curves come out the same in every run.
    let mut by_square: std::collections::BTreeMap<
        (usize, usize, BifurcationKind, u32),
        Vec<usize>,
    > = Default::default();
    for (n, c) in crossings.iter().enumerate() {
        let idx = c_order_index(shape, c.cells.0);
        let (i, j) = (idx[0], idx[1]);
        let squares: Vec<(usize, usize)> = if c.axis == 0 {
            [(i, j.wrapping_sub(1)), (i, j)].into()
        } else {
            [(i.wrapping_sub(1), j), (i, j)].into()
        };
        for (si, sj) in squares {
            if si + 1 < shape[0] && sj + 1 < shape[1] {
                by_square
                    .entry((si, sj, c.kind, c.period))
                    .or_default()
                    .push(n);
            }
        }
    }
    for members in by_square.values() {
        let mut m = members.clone();
        m.sort_unstable();
        for pair in m.chunks(2).filter(|p| p.len() == 2) {
            links[pair[0]].push(pair[1]);
            links[pair[1]].push(pair[0]);
        }
    }
    links
}

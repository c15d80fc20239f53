//! Attractors of a map run from several starts per cell (`map.initial_states`;
//! `docs/analysis.md`, "Attractors"): each run's settled tail is fingerprinted, the runs of a
//! cell that share an attractor are grouped by a stated distance rule, and neighbouring cells'
//! attractors matched by the same rule (looser for periodic cycles, which move with the
//! parameters) so that one family keeps one label across a region.
//!
//! The fingerprint of a run that ended `ok` is its regime, its period and, for a periodic
//! orbit, its stroboscopic cycle (the last `p` stroboscopic α samples), its α range, the wells
//! it visits (α > 0 only, α < 0 only, or both), its hops and its mean power. Two fingerprints
//! are one attractor when they have the same regime, period and wells, and
//! - both are periodic and their cycles, compared over every rotation, differ by at most
//!   `cycle_tol_rad` at every sample (`min_r max_j |a_j − b_{(j+r) mod p}|`); or
//! - neither is periodic and their α ranges overlap by at least `RANGE_OVERLAP` of their
//!   union.
//!
//! A failed run (diverged, non-finite) belongs to no attractor; its share is counted apart, so
//! that the basin fractions and the failed share of a cell sum to 1.

use super::{InstanceResult, Regime};
use crate::config::c_order_index;
use serde::{Deserialize, Serialize};

/// Least overlap of two α ranges, over their union, for non-periodic runs to be one
/// attractor.
pub(crate) const RANGE_OVERLAP: f64 = 0.5;

/// Cycle tolerances of the distance rule.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AttractorRule {
    /// Largest sample difference of two periodic cycles of one attractor within a cell (rad).
    pub cycle_tol_rad: f64,
    /// The same between neighbouring cells, where a cycle moves with the parameters (rad).
    pub family_tol_rad: f64,
    /// Least overlap over union of the α ranges of non-periodic runs.
    pub range_overlap: f64,
}

impl AttractorRule {
    /// The rule for a map whose period test has tolerance `period_tol_rad`: ten times it
    /// within a cell (runs that converged to one orbit agree to the period test's own
    /// precision), 0.1 rad (5.7°) between neighbouring cells.
    pub fn for_period_tol(period_tol_rad: f64) -> AttractorRule {
        AttractorRule {
            cycle_tol_rad: 10.0 * period_tol_rad,
            family_tol_rad: 0.1_f64.max(10.0 * period_tol_rad),
            range_overlap: RANGE_OVERLAP,
        }
    }
}

/// The wells a run visits after the transient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Wells {
    /// α > 0 throughout.
    Positive,
    /// α < 0 throughout.
    Negative,
    /// Both signs of α.
    Both,
}

impl Wells {
    /// The wells of an α range (rad).
    pub(crate) fn of_range(min_rad: f64, max_rad: f64) -> Wells {
        if min_rad > 0.0 {
            Wells::Positive
        } else if max_rad < 0.0 {
            Wells::Negative
        } else {
            Wells::Both
        }
    }

    /// The wells of the mirror image α → −α.
    pub fn mirrored(self) -> Wells {
        match self {
            Wells::Positive => Wells::Negative,
            Wells::Negative => Wells::Positive,
            Wells::Both => Wells::Both,
        }
    }
}

/// What tells one run's attractor from another's.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Fingerprint {
    /// The run's verdict.
    pub regime: Regime,
    /// Period in forcing periods (0 unless periodic).
    pub period: u32,
    /// A periodic orbit's stroboscopic cycle (rad), `period` samples, rotated to start at its
    /// smallest; empty otherwise.
    pub cycle_rad: Vec<f64>,
    /// Smallest and largest α after the transient (rad).
    pub alpha_range_rad: (f64, f64),
    /// The wells it visits.
    pub wells: Wells,
    /// Hops after the transient.
    #[serde(deserialize_with = "nan_if_null")]
    pub hops: f64,
    /// Mean harvested power (W; NaN without the piezo, written as `null`).
    #[serde(deserialize_with = "nan_if_null")]
    pub power_w: f64,
}

/// A number that JSON wrote as `null` because it was NaN.
fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl Fingerprint {
    /// The fingerprint of a run that ended `ok`, from its results and its stroboscopic tail
    /// (at least `period` samples for a periodic orbit); `None` for a failed run.
    pub fn of(r: &InstanceResult, tail: &[f64]) -> Option<Fingerprint> {
        if !r.status.is_ok() {
            return None;
        }
        let period = match r.regime {
            Regime::Periodic if r.period >= 1.0 && (r.period as usize) <= tail.len() => {
                r.period as u32
            }
            _ => 0,
        };
        let regime = if period == 0 && r.regime == Regime::Periodic {
            Regime::Undecided
        } else {
            r.regime
        };
        let cycle_rad = canonical_cycle(&tail[tail.len() - period as usize..]);
        Some(Fingerprint {
            regime,
            period,
            cycle_rad,
            alpha_range_rad: (r.alpha_min_rad, r.alpha_max_rad),
            wells: Wells::of_range(r.alpha_min_rad, r.alpha_max_rad),
            hops: r.hops,
            power_w: r.power_w,
        })
    }

    /// The fingerprint of the mirror image (α, α̇, t) → (−α, −α̇, t + T/2), which the model
    /// maps onto another of its motions (`docs/model.md`, "Symmetry"): the cycle and the α
    /// range negated, the wells swapped; regime, period, hops and power unchanged.
    pub fn mirrored(&self) -> Fingerprint {
        let negated: Vec<f64> = self.cycle_rad.iter().map(|a| -a).collect();
        Fingerprint {
            cycle_rad: canonical_cycle(&negated),
            alpha_range_rad: (-self.alpha_range_rad.1, -self.alpha_range_rad.0),
            wells: self.wells.mirrored(),
            ..self.clone()
        }
    }

    /// Whether `self` and `other` are one attractor, periodic cycles within `cycle_tol_rad`.
    pub fn same_as(&self, other: &Fingerprint, cycle_tol_rad: f64, overlap: f64) -> bool {
        if self.regime != other.regime || self.period != other.period || self.wells != other.wells {
            return false;
        }
        if self.period > 0 {
            return cycle_distance(&self.cycle_rad, &other.cycle_rad) <= cycle_tol_rad;
        }
        range_overlap(self.alpha_range_rad, other.alpha_range_rad) >= overlap
    }
}

/// `cycle` rotated to start at its smallest sample.
fn canonical_cycle(cycle: &[f64]) -> Vec<f64> {
    let start = (0..cycle.len())
        .min_by(|&a, &b| cycle[a].total_cmp(&cycle[b]))
        .unwrap_or(0);
    cycle[start..]
        .iter()
        .chain(&cycle[..start])
        .copied()
        .collect()
}

/// `min_r max_j |a_j − b_{(j+r) mod p}|` for cycles of one length (∞ otherwise).
pub(crate) fn cycle_distance(a: &[f64], b: &[f64]) -> f64 {
    if a.len() != b.len() || a.is_empty() {
        return f64::INFINITY;
    }
    let p = a.len();
    (0..p)
        .map(|r| {
            (0..p)
                .map(|j| (a[j] - b[(j + r) % p]).abs())
                .fold(0.0, f64::max)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Overlap over union of two intervals (0 when disjoint, 1 when equal; NaN ends give 0).
pub fn range_overlap(a: (f64, f64), b: (f64, f64)) -> f64 {
    let inter = a.1.min(b.1) - a.0.max(b.0);
    let union = a.1.max(b.1) - a.0.min(b.0);
    if !(inter >= 0.0 && union > 0.0) {
        return if inter == 0.0 && union == 0.0 {
            1.0
        } else {
            0.0
        };
    }
    inter / union
}

/// One attractor family across the map (as `attractors.json` lists it).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Family {
    /// Its label (0 is the family that the most runs reached).
    pub label: usize,
    /// The fingerprint of its first run (in grid and start order).
    pub fingerprint: Fingerprint,
    /// Cells where some start reached it.
    pub cells: usize,
    /// Runs that reached it.
    pub runs: usize,
    /// Its first run: cell and start.
    pub first: (usize, usize),
}

/// The attractors of a map: per cell, per label and per run.
#[derive(Debug, Clone, Serialize)]
pub struct AttractorMap {
    /// Starts per cell.
    pub starts: usize,
    /// The distance rule.
    pub rule: AttractorRule,
    /// The families, by label.
    pub families: Vec<Family>,
    /// Distinct attractors per cell (failed runs not counted).
    #[serde(skip)]
    pub count: Vec<u16>,
    /// Share of the cell's starts on each label: `fractions[label][cell]`.
    #[serde(skip)]
    pub fractions: Vec<Vec<f64>>,
    /// Share of the cell's starts that failed.
    #[serde(skip)]
    pub failed: Vec<f64>,
    /// The label most starts reached per cell (the lowest label on a tie; −1 when all failed).
    #[serde(skip)]
    pub most_likely: Vec<i32>,
    /// The start whose results stand for the cell: the first that reached `most_likely`
    /// (start 0 when all failed).
    #[serde(skip)]
    pub representative: Vec<usize>,
    /// Label of every run, `cell·starts + start` (−1 for a failed run).
    #[serde(skip)]
    pub run_label: Vec<i32>,
}

impl AttractorMap {
    /// The first start of each cell that reached each label: `[label][cell]`, −1 where no
    /// start of the cell reached it (what runs one attractor of one cell again).
    pub fn first_starts(&self) -> Vec<Vec<i32>> {
        let k = self.starts;
        let cells = self.most_likely.len();
        let mut out = vec![vec![-1; cells]; self.families.len()];
        for (i, &label) in self.run_label.iter().enumerate().rev() {
            if label >= 0 {
                out[label as usize][i / k] = (i % k) as i32;
            }
        }
        out
    }
}

/// One cell's attractors: each with the starts that reached it.
struct Local {
    fingerprint: Fingerprint,
    starts: Vec<usize>,
}

/// The attractors of a grid of `shape` run from `starts` starts per cell: `results[i]` and
/// `tails[i]` of run `i = cell·starts + start`.
pub fn attractor_map(
    shape: &[usize],
    starts: usize,
    results: &[InstanceResult],
    tails: &[Vec<f64>],
    rule: AttractorRule,
) -> AttractorMap {
    let cells: usize = shape.iter().product();
    let locals: Vec<Vec<Local>> = (0..cells)
        .map(|c| {
            let runs = c * starts..(c + 1) * starts;
            group_cell(&results[runs.clone()], &tails[runs], rule)
        })
        .collect();
    let component = link_neighbours(shape, &locals, rule);
    label_map(starts, &locals, &component, rule)
}

/// The attractors of a basin picture: a grid of `cells` starts of one scene (its axes are the
/// start's keys), every run compared with every other by the in-cell rule, since all share
/// the scene's parameters. Cell `c` is its own run: one start, its label, its share 0 or 1.
pub fn basin_map(
    results: &[InstanceResult],
    tails: &[Vec<f64>],
    rule: AttractorRule,
) -> AttractorMap {
    let cells = results.len();
    let one = attractor_map(&[1], cells, results, tails, rule);
    let labels = one.families.len();
    let mut fractions = vec![vec![0.0; cells]; labels];
    for (c, &l) in one.run_label.iter().enumerate() {
        if l >= 0 {
            fractions[l as usize][c] = 1.0;
        }
    }
    AttractorMap {
        starts: 1,
        rule,
        families: one
            .families
            .into_iter()
            .map(|f| Family {
                cells: f.runs,
                first: (f.first.1, 0),
                ..f
            })
            .collect(),
        count: one.run_label.iter().map(|&l| u16::from(l >= 0)).collect(),
        failed: one
            .run_label
            .iter()
            .map(|&l| f64::from(u8::from(l < 0)))
            .collect(),
        most_likely: one.run_label.clone(),
        representative: vec![0; cells],
        run_label: one.run_label,
        fractions,
    }
}

/// Group a cell's runs into attractors, each compared with the first run of each group.
fn group_cell(results: &[InstanceResult], tails: &[Vec<f64>], rule: AttractorRule) -> Vec<Local> {
    let mut locals: Vec<Local> = Vec::new();
    for (s, (r, tail)) in results.iter().zip(tails).enumerate() {
        let Some(f) = Fingerprint::of(r, tail) else {
            continue;
        };
        match locals.iter_mut().find(|l| {
            l.fingerprint
                .same_as(&f, rule.cycle_tol_rad, rule.range_overlap)
        }) {
            Some(l) => l.starts.push(s),
            None => locals.push(Local {
                fingerprint: f,
                starts: vec![s],
            }),
        }
    }
    locals
}

/// Union the attractors of neighbouring cells (one step along any axis) that match with the
/// family tolerance; the component root of every (cell, local attractor), flattened.
fn link_neighbours(shape: &[usize], locals: &[Vec<Local>], rule: AttractorRule) -> Vec<Vec<usize>> {
    let offset: Vec<usize> = locals
        .iter()
        .scan(0, |acc, l| {
            let o = *acc;
            *acc += l.len();
            Some(o)
        })
        .collect();
    let total = locals.iter().map(Vec::len).sum();
    let mut parent: Vec<usize> = (0..total).collect();
    let stride: Vec<usize> = (0..shape.len())
        .map(|d| shape[d + 1..].iter().product())
        .collect();
    for c in 0..locals.len() {
        let idx = c_order_index(shape, c);
        for d in 0..shape.len() {
            if idx[d] + 1 == shape[d] {
                continue;
            }
            let n = c + stride[d];
            for (i, a) in locals[c].iter().enumerate() {
                for (j, b) in locals[n].iter().enumerate() {
                    if a.fingerprint.same_as(
                        &b.fingerprint,
                        rule.family_tol_rad,
                        rule.range_overlap,
                    ) {
                        union(&mut parent, offset[c] + i, offset[n] + j);
                    }
                }
            }
        }
    }
    locals
        .iter()
        .enumerate()
        .map(|(c, l)| {
            (0..l.len())
                .map(|i| find(&mut parent, offset[c] + i))
                .collect()
        })
        .collect()
}

/// The root of `x` in the union-find forest `parent` (paths halved on the way).
pub(crate) fn find(parent: &mut [usize], mut x: usize) -> usize {
    while parent[x] != x {
        parent[x] = parent[parent[x]];
        x = parent[x];
    }
    x
}

/// Join the trees of `a` and `b` under the smaller root.
pub(crate) fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        parent[ra.max(rb)] = ra.min(rb);
    }
}

/// Labels by component, the most-run family first (ties by first appearance); per-cell counts,
/// fractions, the most likely label and its representative start.
fn label_map(
    starts: usize,
    locals: &[Vec<Local>],
    component: &[Vec<usize>],
    rule: AttractorRule,
) -> AttractorMap {
    let cells = locals.len();
    // Runs and first appearance per component root.
    let mut roots: Vec<(usize, usize, usize)> = Vec::new(); // (root, runs, first order)
    for (c, l) in locals.iter().enumerate() {
        for (i, a) in l.iter().enumerate() {
            let root = component[c][i];
            match roots.iter_mut().find(|r| r.0 == root) {
                Some(r) => r.1 += a.starts.len(),
                None => roots.push((root, a.starts.len(), roots.len())),
            }
        }
    }
    roots.sort_by(|a, b| b.1.cmp(&a.1).then(a.2.cmp(&b.2)));
    let label_of = |root: usize| {
        roots
            .iter()
            .position(|r| r.0 == root)
            .expect("every root ranked")
    };
    let labels = roots.len();
    let mut out = AttractorMap {
        starts,
        rule,
        families: Vec::with_capacity(labels),
        count: vec![0; cells],
        fractions: vec![vec![0.0; cells]; labels],
        failed: vec![0.0; cells],
        most_likely: vec![-1; cells],
        representative: vec![0; cells],
        run_label: vec![-1; cells * starts],
    };
    let mut family: Vec<Option<Family>> = vec![None; labels];
    for (c, l) in locals.iter().enumerate() {
        out.count[c] = l.len() as u16;
        let mut best: Option<(usize, usize, usize)> = None; // (runs, label, first start)
        for (i, a) in l.iter().enumerate() {
            let label = label_of(component[c][i]);
            out.fractions[label][c] += a.starts.len() as f64 / starts as f64;
            for &s in &a.starts {
                out.run_label[c * starts + s] = label as i32;
            }
            let f = family[label].get_or_insert_with(|| Family {
                label,
                fingerprint: a.fingerprint.clone(),
                cells: 0,
                runs: 0,
                first: (c, a.starts[0]),
            });
            f.cells += 1;
            f.runs += a.starts.len();
            let candidate = (a.starts.len(), label, a.starts[0]);
            if best.is_none_or(|b| candidate.0 > b.0 || (candidate.0 == b.0 && candidate.1 < b.1)) {
                best = Some(candidate);
            }
        }
        let reached: usize = l.iter().map(|a| a.starts.len()).sum();
        out.failed[c] = (starts - reached) as f64 / starts as f64;
        if let Some((_, label, start)) = best {
            out.most_likely[c] = label as i32;
            out.representative[c] = start;
        }
    }
    out.families = family
        .into_iter()
        .map(|f| f.expect("every label has runs"))
        .collect();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Status;

    fn periodic(alpha: (f64, f64)) -> InstanceResult {
        let mut r = InstanceResult::unset(Status::Ok, 1);
        r.regime = Regime::Periodic;
        r.period = 1.0;
        r.alpha_min_rad = alpha.0;
        r.alpha_max_rad = alpha.1;
        r.hops = 0.0;
        r
    }

    #[test]
    fn cycles_compare_over_every_rotation() {
        assert_eq!(cycle_distance(&[1.0, 2.0, 3.0], &[3.0, 1.0, 2.0]), 0.0);
        assert!((cycle_distance(&[1.0, 2.0], &[2.5, 1.0]) - 0.5).abs() < 1e-15);
        assert_eq!(cycle_distance(&[1.0], &[1.0, 2.0]), f64::INFINITY);
        assert_eq!(range_overlap((0.0, 2.0), (1.0, 3.0)), 1.0 / 3.0);
        assert_eq!(range_overlap((0.0, 1.0), (2.0, 3.0)), 0.0);
    }

    #[test]
    fn two_wells_are_two_attractors_and_fractions_sum_to_one() {
        // One cell, four starts: two in each well, one failed.
        let up = periodic((0.2, 0.3));
        let down = periodic((-0.3, -0.2));
        let failed = InstanceResult::unset(Status::Diverged, 1);
        let results = [up, down, up, failed];
        let tails = [vec![0.25], vec![-0.25], vec![0.2501], vec![]];
        let m = attractor_map(
            &[1],
            4,
            &results,
            &tails,
            AttractorRule::for_period_tol(1e-3),
        );
        assert_eq!(m.count, vec![2]);
        assert_eq!(m.families.len(), 2);
        assert_eq!(m.most_likely, vec![0]);
        assert_eq!(m.run_label, vec![0, 1, 0, -1]);
        let total: f64 = m.fractions.iter().map(|f| f[0]).sum::<f64>() + m.failed[0];
        assert!((total - 1.0).abs() < 1e-15);
        assert_eq!(m.fractions[0][0], 0.5);
        assert_eq!(m.failed[0], 0.25);
    }

    #[test]
    fn a_family_keeps_its_label_across_neighbouring_cells() {
        // Three cells in a row; the positive-well orbit drifts by 0.05 rad a cell (beyond the
        // in-cell tolerance, within the family's), the negative one appears in the last cell.
        let tails = |a: f64| vec![a];
        let results = [
            periodic((0.1, 0.2)),
            periodic((0.1, 0.2)),
            periodic((0.1, 0.2)),
            periodic((-0.2, -0.1)),
        ];
        let t = [tails(0.20), tails(0.25), tails(0.30), tails(-0.3)];
        // Cells 0 and 1 hold one start each, cell 2 two: give every cell two starts.
        let r2 = [
            results[0], results[0], results[1], results[1], results[2], results[3],
        ];
        let t2 = [
            t[0].clone(),
            t[0].clone(),
            t[1].clone(),
            t[1].clone(),
            t[2].clone(),
            t[3].clone(),
        ];
        let m = attractor_map(&[3], 2, &r2, &t2, AttractorRule::for_period_tol(1e-3));
        assert_eq!(m.families.len(), 2, "{:?}", m.families);
        assert_eq!(m.most_likely, vec![0, 0, 0]);
        assert_eq!(m.count, vec![1, 1, 2]);
        assert_eq!(m.run_label, vec![0, 0, 0, 0, 0, 1]);
    }
}

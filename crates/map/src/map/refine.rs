//! Adaptive refinement, the map planner's stage (`docs/analysis.md`, "Adaptive refinement"):
//! compute a coarse lattice, refine only where neighbouring cells differ, fill the inside of
//! uniform blocks from their corners, and audit a random share of what was filled.
//!
//! Stages of [`refine`]:
//! 1. **Coarse lattice**: every grid point whose index along each axis (of more than one value)
//!    is a multiple of the spacing `s`. The lattice cuts the grid into blocks of `s` cells per
//!    axis, with 2^d computed corners each (d ≤ 3 axes).
//! 2. **Refinement**: a block whose corners all agree ([`RefineFollow`]: the same regime, and
//!    the same period when periodic; or one metric within a threshold) is *uniform* and final;
//!    any other is split in 2^d blocks of half the spacing, whose new corners are computed,
//!    down to blocks of one cell.
//! 3. **Fill**: every point left uncomputed lies in a uniform block (a point on the face of two
//!    uniform blocks gets the same value from both: they share corners) and takes the result
//!    of that block's nearest corner, marked *inferred*, with 0 steps.
//! 4. **Audit, by class**: a seeded random share of the inferred points is computed and
//!    compared with what was filled, by the same rule. The points are grouped by the *class*
//!    of their fill (its regime, and period where periodic; one class when a metric is
//!    followed). A class whose agreement is below `audit_min` goes one level deeper: every
//!    uniform block of that class (of more than one cell) is split as in stage 2 and refined
//!    again, and a new share of the points still inferred is audited, until every class
//!    passes or nothing is left to split. Audited points keep their computed result.
//!
//! A class rather than a block is deepened because a class's error is a property of the
//! region it paints (a chaotic sea holds periodic windows smaller than a block; the inside of
//! a period-3 tongue holds none), which the audit measures, and a block holding one wrong
//! audited point would not find the others.

use pendulum_atlas_core::config::{MapSpec, RefineFollow, RefineSpec, c_order_index};
use pendulum_atlas_core::engine::EngineError;
use pendulum_atlas_core::reduce::{InstanceResult, Regime};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// What refinement did, for `map.json`.
#[derive(Debug, Clone, Serialize)]
pub struct RefineReport {
    /// Spacing of the coarse lattice (cells).
    pub spacing: u32,
    /// What neighbouring cells were compared by.
    pub follow: RefineFollow,
    /// Points computed at each level, coarse lattice first (spacing halves from level to
    /// level).
    pub computed_per_level: Vec<usize>,
    /// Points computed in all (audit included).
    pub computed: usize,
    /// Points filled from their block (after the audit).
    pub inferred: usize,
    /// The audit.
    pub audit: AuditReport,
}

/// The audit of the inferred points.
#[derive(Debug, Clone, Serialize)]
pub struct AuditReport {
    /// Share of the inferred points drawn in each round.
    pub share: f64,
    /// Seed of the draws.
    pub seed: u64,
    /// Points drawn and computed, every round.
    pub checked: usize,
    /// Of them, how many the fill got right.
    pub agreed: usize,
    /// The first round's agreement: how often the fill, as refinement first made it, is the
    /// computed cell (1 when nothing was inferred).
    pub agreement: f64,
    /// The last round's agreement: that of the fill that stands.
    pub final_agreement: f64,
    /// Agreement of a class below which its blocks go one level deeper.
    pub min_agreement: f64,
    /// Uniform blocks split because their class fell below the minimum.
    pub deeper_blocks: usize,
    /// Points those splits computed.
    pub deeper_points: usize,
    /// Each round of the audit.
    pub rounds: Vec<AuditRound>,
}

/// One round of the audit.
#[derive(Debug, Clone, Serialize)]
pub struct AuditRound {
    /// Points drawn and computed.
    pub checked: usize,
    /// Of them, how many the fill got right.
    pub agreed: usize,
    /// The classes that fell below the minimum and went one level deeper (e.g. "chaotic",
    /// "periodic 3").
    pub deeper_classes: Vec<String>,
    /// Uniform blocks split.
    pub deeper_blocks: usize,
    /// Points the deeper refinement computed.
    pub deeper_points: usize,
}

/// The refined map: a result per grid point, which of them were filled, and the report.
#[derive(Debug, Clone)]
pub struct Refined {
    /// Results in grid order.
    pub results: Vec<InstanceResult>,
    /// Whether each was filled from its block.
    pub inferred: Vec<bool>,
    /// What was done.
    pub report: RefineReport,
}

/// A block of the lattice: its lowest corner and its spacing.
#[derive(Debug, Clone, Copy)]
struct Block<'a> {
    origin: [usize; 3],
    h: usize,
    grid: &'a Grid,
}

/// The grid's shape, padded to three axes (an axis of one value has extent 1).
#[derive(Debug, Clone)]
struct Grid {
    shape: [usize; 3],
    dims: usize,
}

impl Grid {
    fn new(spec: &MapSpec) -> Grid {
        let s = spec.shape();
        let mut shape = [1usize; 3];
        shape[..s.len()].copy_from_slice(&s);
        Grid {
            shape,
            dims: s.len(),
        }
    }

    fn flat(&self, idx: [usize; 3]) -> usize {
        (0..self.dims).fold(0, |k, a| k * self.shape[a] + idx[a])
    }

    fn index(&self, k: usize) -> [usize; 3] {
        let mut out = [0usize; 3];
        out[..self.dims].copy_from_slice(&c_order_index(&self.shape[..self.dims], k));
        out
    }

    /// Whether axis `a` is refined (more than one value).
    fn active(&self, a: usize) -> bool {
        self.shape[a] > 1
    }

    /// Every point whose active indices are multiples of `h`.
    fn lattice(&self, h: usize) -> Vec<usize> {
        (0..self.shape.iter().product::<usize>())
            .filter(|&k| {
                let i = self.index(k);
                (0..3).all(|a| !self.active(a) || i[a].is_multiple_of(h))
            })
            .collect()
    }

    /// The blocks of spacing `h` that tile the grid.
    fn blocks(&self, h: usize) -> Vec<Block<'_>> {
        let starts = |a: usize| -> Vec<usize> {
            if self.active(a) {
                (0..self.shape[a] - 1).step_by(h).collect()
            } else {
                vec![0]
            }
        };
        let mut out = Vec::new();
        for &x in &starts(0) {
            for &y in &starts(1) {
                for &z in &starts(2) {
                    out.push(Block {
                        origin: [x, y, z],
                        h,
                        grid: self,
                    });
                }
            }
        }
        out
    }
}

impl<'a> Block<'a> {
    /// Extent of the block along axis `a` (0 on an inactive axis).
    fn extent(&self, a: usize) -> usize {
        if self.grid.active(a) { self.h } else { 0 }
    }

    /// Flat indices of its 2^d corners.
    fn corners(&self) -> Vec<usize> {
        self.points(self.h.max(1))
    }

    /// Flat indices of its closure's points whose offsets are multiples of `step`.
    fn points(&self, step: usize) -> Vec<usize> {
        let range = |a: usize| (0..=self.extent(a)).step_by(step);
        let mut out = Vec::new();
        for dx in range(0) {
            for dy in range(1) {
                for dz in range(2) {
                    let o = self.origin;
                    out.push(self.grid.flat([o[0] + dx, o[1] + dy, o[2] + dz]));
                }
            }
        }
        out
    }

    /// Its 2^d halves.
    fn split(&self) -> Vec<Block<'a>> {
        let h = self.h / 2;
        let offs = |a: usize| {
            if self.grid.active(a) {
                vec![0, h]
            } else {
                vec![0]
            }
        };
        let mut out = Vec::new();
        for &x in &offs(0) {
            for &y in &offs(1) {
                for &z in &offs(2) {
                    let o = self.origin;
                    out.push(Block {
                        origin: [o[0] + x, o[1] + y, o[2] + z],
                        h,
                        grid: self.grid,
                    });
                }
            }
        }
        out
    }

    /// The corner nearest to point `k` (index distance; the lower corner on ties).
    fn nearest_corner(&self, k: usize) -> usize {
        let i = self.grid.index(k);
        let mut c = self.origin;
        for a in 0..3 {
            if self.grid.active(a) && 2 * (i[a] - self.origin[a]) > self.h {
                c[a] += self.h;
            }
        }
        self.grid.flat(c)
    }
}

/// Whether two cells agree under `follow` (the refinement's and the audit's rule).
pub fn agree(a: &InstanceResult, b: &InstanceResult, follow: RefineFollow) -> bool {
    match follow {
        RefineFollow::Regime => {
            a.regime == b.regime
                && (a.regime != Regime::Periodic || a.period.to_bits() == b.period.to_bits())
        }
        RefineFollow::Metric { metric, threshold } => {
            let (x, y) = (a.metric(metric), b.metric(metric));
            match (x.is_nan(), y.is_nan()) {
                (true, true) => a.status == b.status,
                (false, false) => (x - y).abs() <= threshold && a.status == b.status,
                _ => false,
            }
        }
    }
}

/// The class of a fill, by which the audit groups its points: the regime, and the period
/// where periodic, when the regime is followed; one class when a metric is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum Class {
    Regime(i8, u64),
    Metric,
}

impl Class {
    fn of(r: &InstanceResult, follow: RefineFollow) -> Class {
        match follow {
            RefineFollow::Regime if r.regime == Regime::Periodic => {
                Class::Regime(r.regime.code(), r.period.to_bits())
            }
            RefineFollow::Regime => Class::Regime(r.regime.code(), 0),
            RefineFollow::Metric { .. } => Class::Metric,
        }
    }

    fn describe(&self) -> String {
        match *self {
            Class::Regime(code, period) => {
                let regime = Regime::ALL
                    .into_iter()
                    .find(|r| r.code() == code)
                    .map_or("?", |r| r.name());
                if period == 0 {
                    regime.to_string()
                } else {
                    format!("{regime} {}", f64::from_bits(period))
                }
            }
            Class::Metric => "every filled cell".into(),
        }
    }
}

/// The refinement in progress: the cells computed so far, the uniform blocks, and the points
/// computed per level.
struct Refiner<'g, F> {
    rs: &'g RefineSpec,
    results: Vec<Option<InstanceResult>>,
    uniform: Vec<Block<'g>>,
    per_level: Vec<usize>,
    run: F,
}

impl<'g, F> Refiner<'g, F>
where
    F: FnMut(&[usize]) -> Result<Vec<InstanceResult>, EngineError>,
{
    fn get(&self, k: usize) -> &InstanceResult {
        self.results[k].as_ref().expect("a computed corner")
    }

    /// Compute the points of `points` not yet known; how many were computed.
    fn compute(&mut self, points: impl IntoIterator<Item = usize>) -> Result<usize, EngineError> {
        let mut todo: Vec<usize> = points
            .into_iter()
            .filter(|&k| self.results[k].is_none())
            .collect();
        todo.sort_unstable();
        todo.dedup();
        if todo.is_empty() {
            return Ok(0);
        }
        for (k, r) in todo.iter().zip((self.run)(&todo)?) {
            self.results[*k] = Some(r);
        }
        Ok(todo.len())
    }

    /// Count `n` points computed at blocks of spacing `h`.
    fn tally(&mut self, h: usize, n: usize) {
        let level = (self.rs.spacing as usize / h).trailing_zeros() as usize;
        if self.per_level.len() <= level {
            self.per_level.resize(level + 1, 0);
        }
        self.per_level[level] += n;
    }

    /// Whether the corners of `b` all agree.
    fn agrees(&self, b: &Block) -> bool {
        let c = b.corners();
        let first = self.get(c[0]);
        c.iter().all(|&k| agree(first, self.get(k), self.rs.follow))
    }

    /// Stage 2 for `blocks`, whose corners are computed: keep the uniform ones, split the
    /// others (computing their new corners) down to single cells; the points computed.
    fn descend(&mut self, mut blocks: Vec<Block<'g>>) -> Result<usize, EngineError> {
        let mut computed = 0;
        while !blocks.is_empty() {
            let (mixed, same): (Vec<Block>, Vec<Block>) = blocks
                .into_iter()
                .filter(|b| b.h > 1)
                .partition(|b| !self.agrees(b));
            self.uniform.extend(same);
            blocks = Vec::new();
            for h in distinct_spacings(&mixed) {
                let split: Vec<&Block> = mixed.iter().filter(|b| b.h == h).collect();
                let n = self.compute(split.iter().flat_map(|b| b.points(h / 2)))?;
                self.tally(h / 2, n);
                computed += n;
                blocks.extend(split.iter().flat_map(|b| b.split()));
            }
        }
        Ok(computed)
    }

    /// Stage 3: every point not computed, from the nearest corner of its uniform block.
    fn fill(&self) -> Vec<Option<InstanceResult>> {
        let mut filled: Vec<Option<InstanceResult>> = vec![None; self.results.len()];
        for b in &self.uniform {
            for k in b.points(1) {
                if self.results[k].is_none() && filled[k].is_none() {
                    let mut r = *self.get(b.nearest_corner(k));
                    r.steps = 0;
                    filled[k] = Some(r);
                }
            }
        }
        filled
    }

    /// The class of a uniform block: that of its corners.
    fn class_of_block(&self, b: &Block) -> Class {
        Class::of(self.get(b.corners()[0]), self.rs.follow)
    }

    /// Send the uniform blocks of `classes` one level deeper; (blocks split, points computed).
    fn deepen(&mut self, classes: &[Class]) -> Result<(usize, usize), EngineError> {
        let (deeper, keep): (Vec<Block>, Vec<Block>) = std::mem::take(&mut self.uniform)
            .into_iter()
            .partition(|b| classes.contains(&self.class_of_block(b)));
        self.uniform = keep;
        let mut computed = 0;
        for h in distinct_spacings(&deeper) {
            let these: Vec<&Block> = deeper.iter().filter(|b| b.h == h).collect();
            let n = self.compute(these.iter().flat_map(|b| b.points(h / 2)))?;
            self.tally(h / 2, n);
            computed += n;
            let halves: Vec<Block> = these.iter().flat_map(|b| b.split()).collect();
            computed += self.descend(halves)?;
        }
        Ok((deeper.len(), computed))
    }
}

/// The spacings among `blocks`, largest first.
fn distinct_spacings(blocks: &[Block]) -> Vec<usize> {
    let mut hs: Vec<usize> = blocks.iter().map(|b| b.h).collect();
    hs.sort_unstable_by(|a, b| b.cmp(a));
    hs.dedup();
    hs
}

/// Refine `spec`'s grid, computing cells with `run` (grid indices in, results in that order
/// out): see the module doc.
pub fn refine(
    spec: &MapSpec,
    rs: &RefineSpec,
    run: impl FnMut(&[usize]) -> Result<Vec<InstanceResult>, EngineError>,
) -> Result<Refined, EngineError> {
    let grid = Grid::new(spec);
    if let Some(a) = (0..grid.dims)
        .find(|&a| grid.active(a) && !(grid.shape[a] - 1).is_multiple_of(rs.spacing as usize))
    {
        return Err(EngineError::Config(
            pendulum_atlas_core::config::ConfigError::Inconsistent {
                key: "map.refine_spacing".into(),
                reason: format!(
                    "spacing {} does not divide the {} intervals of axis {}",
                    rs.spacing,
                    grid.shape[a] - 1,
                    spec.axes[a].key
                ),
            },
        ));
    }
    let n = spec.instances();
    let mut r = Refiner {
        rs,
        results: vec![None; n],
        uniform: Vec::new(),
        per_level: Vec::new(),
        run,
    };
    let h = rs.spacing as usize;
    let coarse = r.compute(grid.lattice(h))?;
    r.tally(h, coarse);
    r.descend(grid.blocks(h))?;
    let audit = audit(&mut r)?;
    let filled = r.fill();
    let inferred: Vec<bool> = filled.iter().map(Option::is_some).collect();
    let results: Vec<InstanceResult> = (0..n)
        .map(|k| {
            r.results[k]
                .or(filled[k])
                .expect("every point is computed or inferred")
        })
        .collect();
    let inferred_count = inferred.iter().filter(|&&i| i).count();
    Ok(Refined {
        results,
        inferred,
        report: RefineReport {
            spacing: rs.spacing,
            follow: rs.follow,
            computed: n - inferred_count,
            inferred: inferred_count,
            computed_per_level: r.per_level,
            audit,
        },
    })
}

/// Stage 4: rounds of a seeded draw of the inferred points, computed and compared by class;
/// the classes below the minimum go one level deeper, until every class passes.
fn audit<F>(r: &mut Refiner<'_, F>) -> Result<AuditReport, EngineError>
where
    F: FnMut(&[usize]) -> Result<Vec<InstanceResult>, EngineError>,
{
    let rs = *r.rs;
    let mut rng = ChaCha8Rng::seed_from_u64(rs.audit_seed);
    let mut rounds: Vec<AuditRound> = Vec::new();
    let mut agreements = Vec::new();
    loop {
        let filled = r.fill();
        let candidates: Vec<usize> = (0..filled.len()).filter(|&k| filled[k].is_some()).collect();
        let draw =
            ((rs.audit_share * candidates.len() as f64).ceil() as usize).min(candidates.len());
        if draw == 0 {
            break;
        }
        let drawn: Vec<usize> = rand::seq::index::sample(&mut rng, candidates.len(), draw)
            .into_iter()
            .map(|i| candidates[i])
            .collect();
        r.compute(drawn.iter().copied())?;
        // Per class of the fill: (checked, agreed).
        let mut by_class: std::collections::BTreeMap<Class, (usize, usize)> = Default::default();
        for &k in &drawn {
            let fill = filled[k].as_ref().expect("inferred");
            let e = by_class.entry(Class::of(fill, rs.follow)).or_default();
            e.0 += 1;
            e.1 += usize::from(agree(r.get(k), fill, rs.follow));
        }
        let agreed: usize = by_class.values().map(|c| c.1).sum();
        agreements.push(agreed as f64 / drawn.len() as f64);
        let failing: Vec<Class> = by_class
            .iter()
            .filter(|&(_, &(checked, ok))| {
                ok < checked && (ok as f64) < rs.audit_min * checked as f64
            })
            .map(|(c, _)| *c)
            .collect();
        let (blocks, points) = if failing.is_empty() {
            (0, 0)
        } else {
            r.deepen(&failing)?
        };
        rounds.push(AuditRound {
            checked: drawn.len(),
            agreed,
            deeper_classes: failing.iter().map(Class::describe).collect(),
            deeper_blocks: blocks,
            deeper_points: points,
        });
        if failing.is_empty() {
            break;
        }
    }
    let sum = |f: fn(&AuditRound) -> usize| rounds.iter().map(f).sum::<usize>();
    Ok(AuditReport {
        share: rs.audit_share,
        seed: rs.audit_seed,
        checked: sum(|a| a.checked),
        agreed: sum(|a| a.agreed),
        agreement: agreements.first().copied().unwrap_or(1.0),
        final_agreement: agreements.last().copied().unwrap_or(1.0),
        min_agreement: rs.audit_min,
        deeper_blocks: sum(|a| a.deeper_blocks),
        deeper_points: sum(|a| a.deeper_points),
        rounds,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_core::model::Status;

    /// A 17 × 17 grid (spacing 8) and the regime map `truth` over it.
    fn grid_and(truth: impl Fn(usize, usize) -> (Regime, f64)) -> (MapSpec, Vec<InstanceResult>) {
        let axis = |key: &str, a: f64, b: f64| {
            format!("[[map.axes]]\nkey = \"{key}\"\nstart = {a}\nend = {b}\ncount = 17\n")
        };
        let text = format!(
            "[beam]\nsegments = 3\n[map]\nmetrics = [\"K\", \"period\", \"regime\"]\nrefine = true\n{}{}",
            axis("excitation.frequency_hz", 4.0, 12.0),
            axis("excitation.amplitude_m", 0.004, 0.02)
        );
        let spec = map_from_toml(&text, "<test>", &[]).expect("valid map");
        let cells = (0..17 * 17)
            .map(|k| {
                let (regime, period) = truth(k / 17, k % 17);
                let mut r = InstanceResult::unset(Status::Ok, 100);
                r.regime = regime;
                r.period = period;
                r.k = k as f64;
                r
            })
            .collect();
        (spec, cells)
    }

    fn run(spec: &MapSpec, rs: &RefineSpec, truth: &[InstanceResult]) -> Refined {
        refine(spec, rs, |idx| Ok(idx.iter().map(|&k| truth[k]).collect())).expect("refined")
    }

    #[test]
    fn a_uniform_map_is_its_coarse_lattice_and_one_audit_round() {
        let (spec, truth) = grid_and(|_, _| (Regime::Chaotic, 0.0));
        let rs = *spec.refine().expect("refine");
        let out = run(&spec, &rs, &truth);
        assert_eq!(out.report.computed_per_level, vec![9]);
        assert_eq!(out.report.audit.rounds.len(), 1);
        assert_eq!(out.report.audit.agreement, 1.0);
        assert_eq!(out.report.computed, 9 + out.report.audit.checked);
        assert!(out.results.iter().all(|r| r.regime == Regime::Chaotic));
    }

    #[test]
    fn only_the_class_the_audit_finds_wrong_goes_deeper() {
        // A chaotic sea (x < 8) speckled with period-1 cells off the even lattice, and a
        // period-3 region (x ≥ 9) with no speckle: the chaotic fill is wrong in one cell of
        // eight, the period-3 fill never.
        let (spec, truth) = grid_and(|x, y| {
            if x >= 9 {
                (Regime::Periodic, 3.0)
            } else if x % 2 == 1 && y % 2 == 1 && (x + y) % 4 == 2 {
                (Regime::Periodic, 1.0)
            } else {
                (Regime::Chaotic, 0.0)
            }
        });
        let rs = RefineSpec {
            audit_share: 0.5,
            ..*spec.refine().expect("refine")
        };
        let out = run(&spec, &rs, &truth);
        let audit = &out.report.audit;
        assert!(audit.agreement < rs.audit_min, "{audit:?}");
        assert!(
            audit.rounds[0]
                .deeper_classes
                .contains(&"chaotic".to_string())
        );
        assert!(
            audit
                .rounds
                .iter()
                .all(|r| !r.deeper_classes.iter().any(|c| c.starts_with("periodic"))),
            "{audit:?}"
        );
        assert_eq!(audit.final_agreement, 1.0);
        for (k, want) in truth.iter().enumerate() {
            assert!(agree(&out.results[k], want, rs.follow), "cell {k}");
            if out.inferred[k] {
                assert!(k / 17 >= 9, "only the period-3 region is filled: cell {k}");
            }
        }
        assert!(out.inferred.iter().any(|&i| i));
    }
}

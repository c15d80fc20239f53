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
//! 4. **Audit**: a seeded random share of the inferred points is computed and compared with
//!    what was filled, by the same rule; the agreement is reported. When it is below
//!    `audit_min`, every uniform block holding a disagreeing point is computed in full (one
//!    level deeper there: down to single cells). Audited points keep their computed result.

use crate::config::{MapSpec, RefineFollow, RefineSpec, c_order_index};
use crate::engine::EngineError;
use crate::reduce::{InstanceResult, Regime};
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
    /// Share of the inferred points drawn.
    pub share: f64,
    /// Seed of the draw.
    pub seed: u64,
    /// Points drawn and computed.
    pub checked: usize,
    /// Of them, how many the fill got right.
    pub agreed: usize,
    /// agreed / checked (1 when nothing was inferred).
    pub agreement: f64,
    /// Agreement below which disagreeing blocks are computed in full.
    pub min_agreement: f64,
    /// Uniform blocks computed in full because the agreement fell below the minimum.
    pub deeper_blocks: usize,
    /// Points those blocks added.
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

    /// Whether the grid point `k` lies in its closure.
    fn holds(&self, k: usize) -> bool {
        let i = self.grid.index(k);
        (0..3).all(|a| i[a] >= self.origin[a] && i[a] <= self.origin[a] + self.extent(a))
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

/// The cells computed so far.
struct Known {
    results: Vec<Option<InstanceResult>>,
}

impl Known {
    fn get(&self, k: usize) -> &InstanceResult {
        self.results[k].as_ref().expect("a computed corner")
    }

    /// Compute the points of `points` not yet known; how many were computed.
    fn compute(
        &mut self,
        points: impl IntoIterator<Item = usize>,
        run: &mut impl FnMut(&[usize]) -> Result<Vec<InstanceResult>, EngineError>,
    ) -> Result<usize, EngineError> {
        let mut todo: Vec<usize> = points
            .into_iter()
            .filter(|&k| self.results[k].is_none())
            .collect();
        todo.sort_unstable();
        todo.dedup();
        if todo.is_empty() {
            return Ok(0);
        }
        for (k, r) in todo.iter().zip(run(&todo)?) {
            self.results[*k] = Some(r);
        }
        Ok(todo.len())
    }
}

/// Refine `spec`'s grid, computing cells with `run` (grid indices in, results in that order
/// out): see the module doc.
pub fn refine(
    spec: &MapSpec,
    rs: &RefineSpec,
    mut run: impl FnMut(&[usize]) -> Result<Vec<InstanceResult>, EngineError>,
) -> Result<Refined, EngineError> {
    let grid = Grid::new(spec);
    if let Some(a) = (0..grid.dims)
        .find(|&a| grid.active(a) && !(grid.shape[a] - 1).is_multiple_of(rs.spacing as usize))
    {
        return Err(EngineError::Config(
            crate::config::ConfigError::Inconsistent {
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
    let mut known = Known {
        results: vec![None; n],
    };
    let mut h = rs.spacing as usize;
    let mut per_level = vec![known.compute(grid.lattice(h), &mut run)?];
    let mut blocks = grid.blocks(h);
    let mut uniform: Vec<Block> = Vec::new();
    while h > 1 && !blocks.is_empty() {
        let (mixed, same): (Vec<Block>, Vec<Block>) = blocks.into_iter().partition(|b| {
            let c = b.corners();
            let first = known.get(c[0]);
            !c.iter().all(|&k| agree(first, known.get(k), rs.follow))
        });
        uniform.extend(same);
        h /= 2;
        let new = mixed.iter().flat_map(|b| b.points(h));
        per_level.push(known.compute(new, &mut run)?);
        blocks = mixed.iter().flat_map(Block::split).collect();
    }
    let mut inferred = vec![false; n];
    let mut filled: Vec<Option<InstanceResult>> = vec![None; n];
    for b in &uniform {
        for k in b.points(1) {
            if known.results[k].is_none() && filled[k].is_none() {
                let mut r = *known.get(b.nearest_corner(k));
                r.steps = 0;
                filled[k] = Some(r);
                inferred[k] = true;
            }
        }
    }
    let audit = audit(rs, &uniform, &mut known, &filled, &mut inferred, &mut run)?;
    let results: Vec<InstanceResult> = (0..n)
        .map(|k| {
            known.results[k]
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
            computed_per_level: per_level,
            audit,
        },
    })
}

/// Stage 4: compute a seeded share of the inferred points, compare, and go deeper in the
/// blocks of the disagreeing ones when the agreement is below the minimum.
fn audit(
    rs: &RefineSpec,
    uniform: &[Block],
    known: &mut Known,
    filled: &[Option<InstanceResult>],
    inferred: &mut [bool],
    run: &mut impl FnMut(&[usize]) -> Result<Vec<InstanceResult>, EngineError>,
) -> Result<AuditReport, EngineError> {
    let candidates: Vec<usize> = (0..inferred.len()).filter(|&k| inferred[k]).collect();
    let draw = ((rs.audit_share * candidates.len() as f64).ceil() as usize).min(candidates.len());
    let mut rng = ChaCha8Rng::seed_from_u64(rs.audit_seed);
    let drawn: Vec<usize> = rand::seq::index::sample(&mut rng, candidates.len(), draw)
        .into_iter()
        .map(|i| candidates[i])
        .collect();
    known.compute(drawn.iter().copied(), run)?;
    let wrong: Vec<usize> = drawn
        .iter()
        .copied()
        .filter(|&k| {
            !agree(
                known.get(k),
                filled[k].as_ref().expect("inferred"),
                rs.follow,
            )
        })
        .collect();
    for &k in &drawn {
        inferred[k] = false;
    }
    let agreement = if drawn.is_empty() {
        1.0
    } else {
        (drawn.len() - wrong.len()) as f64 / drawn.len() as f64
    };
    let (mut deeper_blocks, mut deeper_points) = (0, 0);
    if agreement < rs.audit_min {
        let deeper: Vec<&Block> = uniform
            .iter()
            .filter(|b| wrong.iter().any(|&k| b.holds(k)))
            .collect();
        deeper_blocks = deeper.len();
        let points: Vec<usize> = deeper.iter().flat_map(|b| b.points(1)).collect();
        deeper_points = known.compute(points.iter().copied(), run)?;
        for k in points {
            inferred[k] = false;
        }
    }
    Ok(AuditReport {
        share: rs.audit_share,
        seed: rs.audit_seed,
        checked: drawn.len(),
        agreed: drawn.len() - wrong.len(),
        agreement,
        min_agreement: rs.audit_min,
        deeper_blocks,
        deeper_points,
    })
}

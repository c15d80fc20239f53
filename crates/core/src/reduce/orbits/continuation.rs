//! Orbits over the grid: each cell's own orbit shot from its end state, then continued into
//! the neighbouring cells (one step along any axis), families joined.
//!
//! ```text
//! own:       a periodic cell's end state x_k and period p → its orbit (stage `shooting`);
//!            the cell's own only where x_k lies within NEAR (scaled) of one of its points
//!            (Newton may converge to an orbit elsewhere: kept as known there, `distant`)
//! continue:  wave by wave, an orbit at cell c (depth d < reach) is predicted at each
//!            neighbour n by its own x* and corrected there by Newton; depth of the result
//!            d + 1 (a cell's own orbit has depth 0)
//! skip:      n already holds an orbit of the family, or one of period p within NEAR (scaled)
//!            of x*: the family is joined to it without shooting
//! family:    an orbit and the orbit it was continued from; two orbits at a cell within
//!            SAME (scaled) of each other are one orbit, their families joined
//! ```
//!
//! A corrected orbit whose least period is not the family's is not kept (it is another
//! branch, which its own cells find). Continuation finds an orbit where the map's trajectory
//! went elsewhere: unstable, or beside a chaotic or other attractor.

use super::{Orbit, OrbitStatus, ShootError, Strobe, find_orbit, scales};
use crate::config::c_order_index;
use crate::engine::plan::InstancePlan;
use crate::reduce::attractors::{find, union};
use rayon::prelude::*;
use serde::Serialize;

/// An orbit with the same period and a point within this (scaled) of x* is one the
/// continuation would converge to: its family is joined without shooting.
const NEAR: f64 = 0.05;
/// Two converged orbits within this (scaled) are one.
const SAME: f64 = 1e-5;

/// Where a cell's own orbit starts.
#[derive(Debug, Clone, PartialEq)]
pub struct Seed {
    /// The cell's end state, at a whole forcing period.
    pub x: Vec<f64>,
    /// The period the map's verdict gives it.
    pub period: u32,
}

/// An orbit known at a cell.
#[derive(Debug, Clone, Serialize)]
pub struct KnownOrbit {
    /// The orbit.
    #[serde(flatten)]
    pub orbit: Orbit,
    /// Its family (the same across the cells it was continued over).
    pub family: usize,
    /// Cells from the nearest cell that found it from its own end state (0: this one).
    pub depth: u32,
}

/// The orbits of a map.
#[derive(Debug, Clone, Serialize)]
pub struct OrbitMap {
    /// Shape of the grid.
    pub shape: Vec<usize>,
    /// How far orbits were continued beyond the cells that found them (cells).
    pub reach: u32,
    /// Per cell, what shooting from its own end state gave.
    pub status: Vec<OrbitStatus>,
    /// Per cell, the index in `known` of its own orbit.
    pub own: Vec<Option<usize>>,
    /// Per cell, every orbit known there.
    pub known: Vec<Vec<KnownOrbit>>,
    /// Families (labels 0..families).
    pub families: usize,
    /// Newton runs of continuation (successful or not).
    pub continued_tries: usize,
    /// Of those, the orbits found (new at their cell).
    pub continued_found: usize,
    /// Cells whose verdict's period the map's stage replaced by their own stable orbit's
    /// least period (`crates/map/src/map/orbits.rs`).
    pub periods_corrected: usize,
    /// Periodic cells whose own orbit converged unstable: their verdict held below firm
    /// (`crates/map/src/map/orbits.rs`).
    pub unstable_own: usize,
    /// Wall time of each step (s).
    pub timings: OrbitTimings,
    /// The bifurcation curves (filled by the bifurcation step).
    pub curves: Vec<super::Curve>,
}

impl OrbitMap {
    /// The cell's own orbit, where shooting converged.
    pub fn own_orbit(&self, k: usize) -> Option<&KnownOrbit> {
        self.own[k].map(|i| &self.known[k][i])
    }
}

/// Wall time of the orbit stage's steps (s).
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct OrbitTimings {
    /// Shooting from the cells' own end states.
    pub shoot_s: f64,
    /// Continuation.
    pub continue_s: f64,
    /// Locating and joining the bifurcation curves.
    pub curves_s: f64,
}

/// Shoot every seeded cell, then continue the orbits up to `reach` cells.
pub fn orbit_map(
    shape: &[usize],
    plans: &[InstancePlan],
    seeds: &[Option<Seed>],
    status_of_unseeded: &[OrbitStatus],
    reach: u32,
) -> OrbitMap {
    let t0 = std::time::Instant::now();
    let own: Vec<Result<Orbit, ShootError>> = seeds
        .par_iter()
        .enumerate()
        .map(|(k, s)| match s {
            Some(s) => find_orbit::<f64>(&plans[k], &s.x, s.period),
            None => Err(ShootError::Singular),
        })
        .collect();
    let mut map = OrbitMap {
        shape: shape.to_vec(),
        reach,
        status: Vec::with_capacity(seeds.len()),
        own: vec![None; seeds.len()],
        known: vec![Vec::new(); seeds.len()],
        families: 0,
        continued_tries: 0,
        continued_found: 0,
        periods_corrected: 0,
        unstable_own: 0,
        timings: OrbitTimings::default(),
        curves: Vec::new(),
    };
    let mut parent = Vec::new();
    let mut frontier = Vec::new();
    let s = plans.first().map(|p| scales(&Strobe::<f64>::new(p)));
    for (k, res) in own.into_iter().enumerate() {
        let status = match (&seeds[k], res) {
            (None, _) => status_of_unseeded[k],
            (Some(seed), Ok(orbit)) => {
                let s = s.as_deref().unwrap_or_default();
                let own = orbit.nearest_point(&seed.x, s).1 <= NEAR;
                parent.push(parent.len());
                map.known[k].push(KnownOrbit {
                    orbit,
                    family: parent.len() - 1,
                    depth: 0,
                });
                frontier.push((k, 0));
                if own {
                    map.own[k] = Some(0);
                    OrbitStatus::Converged
                } else {
                    OrbitStatus::Distant
                }
            }
            (Some(_), Err(e)) => OrbitStatus::of_error(&e),
        };
        map.status.push(status);
    }
    map.timings.shoot_s = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    join_own(&mut map, plans, &mut parent);
    while !frontier.is_empty() {
        frontier = wave(&mut map, plans, &mut parent, &frontier);
    }
    relabel(&mut map, &mut parent);
    map.timings.continue_s = t1.elapsed().as_secs_f64();
    map
}

/// A continuation to try: target cell, source (cell, orbit).
type Task = (usize, usize, usize);

/// One wave of continuation from `frontier`; the orbits it added.
fn wave(
    map: &mut OrbitMap,
    plans: &[InstancePlan],
    parent: &mut [usize],
    frontier: &[(usize, usize)],
) -> Vec<(usize, usize)> {
    let s = scales(&Strobe::<f64>::new(&plans[0]));
    let mut tasks: Vec<Task> = Vec::new();
    for &(c, i) in frontier {
        if map.known[c][i].depth >= map.reach {
            continue;
        }
        for n in grid_neighbours(&map.shape, c) {
            let fam = find(parent, map.known[c][i].family);
            let has = map.known[n].iter().any(|o| find(parent, o.family) == fam);
            let planned = tasks
                .iter()
                .any(|&(t, c2, i2)| t == n && find(parent, map.known[c2][i2].family) == fam);
            if has || planned {
                continue;
            }
            let src = &map.known[c][i].orbit;
            let near = map.known[n].iter().find(|o| {
                o.orbit.period == src.period && o.orbit.nearest_point(src.x(), &s).1 <= NEAR
            });
            match near {
                Some(o) => union(parent, fam, o.family),
                None => tasks.push((n, c, i)),
            }
        }
    }
    map.continued_tries += tasks.len();
    let found: Vec<Option<Orbit>> = tasks
        .par_iter()
        .map(|&(n, c, i)| {
            let src = &map.known[c][i].orbit;
            find_orbit::<f64>(&plans[n], src.x(), src.period)
                .ok()
                .filter(|o| o.period == src.period)
        })
        .collect();
    let mut next = Vec::new();
    for (&(n, c, i), orbit) in tasks.iter().zip(found) {
        let Some(orbit) = orbit else { continue };
        let (family, depth) = (map.known[c][i].family, map.known[c][i].depth + 1);
        if let Some(o) = map.known[n]
            .iter()
            .find(|o| o.orbit.same_as(&orbit, &s, SAME))
        {
            union(parent, family, o.family);
            continue;
        }
        map.known[n].push(KnownOrbit {
            orbit,
            family,
            depth,
        });
        next.push((n, map.known[n].len() - 1));
    }
    map.continued_found += next.len();
    next
}

/// Join the families of neighbouring cells' own orbits of one period within [`NEAR`] of each
/// other (whatever the reach).
fn join_own(map: &mut OrbitMap, plans: &[InstancePlan], parent: &mut [usize]) {
    let Some(first) = plans.first() else { return };
    let s = scales(&Strobe::<f64>::new(first));
    for c in 0..map.known.len() {
        let Some(a) = map.own_orbit(c) else { continue };
        for n in grid_neighbours(&map.shape, c)
            .into_iter()
            .filter(|&n| n > c)
        {
            let Some(b) = map.own_orbit(n) else { continue };
            let near = a.orbit.period == b.orbit.period
                && b.orbit.nearest_point(a.orbit.x(), &s).1 <= NEAR;
            if near {
                union(parent, a.family, b.family);
            }
        }
    }
}

/// Families numbered 0.. by their roots, in order of first appearance.
fn relabel(map: &mut OrbitMap, parent: &mut [usize]) {
    let mut label = vec![usize::MAX; parent.len()];
    let mut next = 0;
    for cell in &mut map.known {
        for o in cell.iter_mut() {
            let root = find(parent, o.family);
            if label[root] == usize::MAX {
                label[root] = next;
                next += 1;
            }
            o.family = label[root];
        }
    }
    map.families = next;
}

/// The cells one step from `k` along any axis.
pub(crate) fn grid_neighbours(shape: &[usize], k: usize) -> Vec<usize> {
    let idx = c_order_index(shape, k);
    let mut out = Vec::new();
    for d in 0..shape.len() {
        let stride: usize = shape[d + 1..].iter().product();
        if idx[d] > 0 {
            out.push(k - stride);
        }
        if idx[d] + 1 < shape[d] {
            out.push(k + stride);
        }
    }
    out
}

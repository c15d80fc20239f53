//! The orbit stage, after the reductions (`docs/analysis.md`, §15 "Periodic orbits"): the
//! exact periodic orbits of a map's periodic cells, their Floquet multipliers, the orbits
//! continued into the neighbouring cells, and the bifurcation curves between cells.
//!
//! Stages, in the order a map goes through them:
//! 1. the stroboscopic map `P` of an instance ([`Strobe`], `strobe`): whole forcing periods
//!    by fixed steps of the instance's own method, in f64 (or f32, to state its precision);
//! 2. shooting ([`shoot`], `shooting`): Newton on `P^p(x) − x` from the cell's end state, the
//!    least period, the monodromy matrix by central differences;
//! 3. the multipliers ([`Multipliers`], `floquet`): eigenvalues of the monodromy, stability,
//!    the real multipliers nearest −1 and +1;
//! 4. continuation ([`orbit_map`], `continuation`): each orbit predicted at the neighbouring
//!    cells and corrected there, up to `reach` cells beyond the cells that found it, orbits
//!    matched into families;
//! 5. bifurcations ([`Curve`], `bifurcation`): where a family's multiplier crosses −1 (period
//!    doubling) or +1 (fold), or its least bumper margin crosses 0 (grazing), between two
//!    neighbouring cells, located along the axis by bisection and joined into polylines.
//!
//! Everything here runs on the CPU in f64: an orbit is a point to 1e-9, which a map's f32
//! trajectory does not resolve.

mod bifurcation;
mod continuation;
mod floquet;
mod shooting;
mod strobe;

pub use bifurcation::{BifurcationKind, Crossing, Curve, LOCATE_STEPS, curves};
pub use continuation::{KnownOrbit, OrbitMap, OrbitTimings, Seed, orbit_map};
pub use floquet::Multipliers;
pub use shooting::{
    Fixed, MAX_ITERATIONS, SAME_POINT, ShootError, TOL, distance, monodromy, scales, shoot,
};
pub use strobe::{SUBSTEPS, Strobe, Track};

use crate::engine::plan::InstancePlan;
use crate::model::Real;
use serde::Serialize;

/// A periodic orbit found by shooting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Orbit {
    /// Least period (forcing periods).
    pub period: u32,
    /// Its `period` stroboscopic points, the first `x*` (`[θ; θ̇; v]`).
    #[serde(skip)]
    pub points: Vec<Vec<f64>>,
    /// The scaled residual `‖(P^p(x*) − x*)/s‖∞`.
    pub residual: f64,
    /// Newton iterations.
    pub iterations: u32,
    /// Its Floquet multipliers.
    pub multipliers: Multipliers,
    /// The range of the holder angle θ₁ over the orbit (rad).
    pub extent_rad: f64,
    /// Its least distance to the nearer bumper (m; negative: it presses into one).
    pub margin_m: f64,
}

impl Orbit {
    /// `x*`.
    pub fn x(&self) -> &[f64] {
        &self.points[0]
    }

    /// Whether every multiplier lies inside the unit circle.
    pub fn stable(&self) -> bool {
        self.multipliers.stable()
    }

    /// Whether `other` is the same orbit: the same period, and `x*` of one within `tol`
    /// (scaled) of a point of the other.
    pub fn same_as(&self, other: &Orbit, s: &[f64], tol: f64) -> bool {
        self.period == other.period && self.nearest_point(other.x(), s).1 <= tol
    }

    /// The point of this orbit nearest `x` (scaled): its index and distance.
    pub fn nearest_point(&self, x: &[f64], s: &[f64]) -> (usize, f64) {
        self.points
            .iter()
            .enumerate()
            .map(|(i, q)| (i, distance(q, x, s)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or((0, f64::INFINITY))
    }
}

/// Shoot for the orbit of period `p` of instance `plan` from `x0`, and measure it.
pub fn find_orbit<T: Real>(plan: &InstancePlan, x0: &[f64], p: u32) -> Result<Orbit, ShootError> {
    let strobe = Strobe::<T>::new(plan);
    let fixed = shoot(&strobe, x0, p)?;
    let (end, track) = strobe
        .track(&fixed.x, fixed.period)
        .map_err(ShootError::Failed)?;
    let m = monodromy(&strobe, &fixed.x, &end, fixed.period).map_err(ShootError::Failed)?;
    let multipliers = Multipliers::of(m).ok_or(ShootError::NoMultipliers)?;
    Ok(Orbit {
        period: fixed.period,
        points: track.points,
        residual: fixed.residual,
        iterations: fixed.iterations,
        multipliers,
        extent_rad: track.theta_range.1 - track.theta_range.0,
        margin_m: track.margin_m,
    })
}

/// What shooting from a cell's own end state gave (`orbit_status.npy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OrbitStatus {
    /// The cell's verdict is not periodic: not shot.
    NotPeriodic,
    /// Converged: the cell carries its orbit.
    Converged,
    /// Newton did not reach the tolerance.
    NoConvergence,
    /// A run of the stroboscopic map failed its health check.
    Failed,
    /// `DP^p − I` was singular, or the monodromy had no eigenvalues.
    Singular,
    /// The cell kept no end state at a whole forcing period to start from.
    NoStart,
    /// Shooting converged to an orbit away from the cell's end state (beyond the continuation's
    /// `NEAR`): an orbit of the cell, kept among its known orbits, but not the one its
    /// trajectory is on.
    Distant,
}

impl OrbitStatus {
    /// Every status, in code order.
    pub const ALL: [OrbitStatus; 7] = [
        OrbitStatus::NotPeriodic,
        OrbitStatus::Converged,
        OrbitStatus::NoConvergence,
        OrbitStatus::Failed,
        OrbitStatus::Singular,
        OrbitStatus::NoStart,
        OrbitStatus::Distant,
    ];

    /// The code stored in `orbit_status.npy`: −1 not periodic, 0 converged, 1 no convergence,
    /// 2 failed, 3 singular, 4 no start, 5 distant.
    pub fn code(self) -> i8 {
        match self {
            OrbitStatus::NotPeriodic => -1,
            OrbitStatus::Converged => 0,
            OrbitStatus::NoConvergence => 1,
            OrbitStatus::Failed => 2,
            OrbitStatus::Singular => 3,
            OrbitStatus::NoStart => 4,
            OrbitStatus::Distant => 5,
        }
    }

    /// The name `map.json` gives the code.
    pub fn name(self) -> &'static str {
        match self {
            OrbitStatus::NotPeriodic => "not_periodic",
            OrbitStatus::Converged => "converged",
            OrbitStatus::NoConvergence => "no_convergence",
            OrbitStatus::Failed => "failed",
            OrbitStatus::Singular => "singular",
            OrbitStatus::NoStart => "no_start",
            OrbitStatus::Distant => "distant",
        }
    }

    /// The status of a shooting that gave `error`.
    pub fn of_error(error: &ShootError) -> OrbitStatus {
        match error {
            ShootError::Failed(_) => OrbitStatus::Failed,
            ShootError::NoConvergence { .. } => OrbitStatus::NoConvergence,
            ShootError::Singular | ShootError::NoMultipliers => OrbitStatus::Singular,
        }
    }
}

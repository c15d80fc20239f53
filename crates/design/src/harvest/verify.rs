//! Re-simulating a design the way `pendulum-atlas simulate` does: its own automatic step
//! (not rounded to a whole number of steps per forcing period), f64 RK4, power sampled at
//! the output rows, averaged over the rows after the transient. This is the independent
//! check of the powers the ensemble engine reports.

use super::error::HarvestError;
use super::search::DesignResult;
use super::spec::SearchSpec;
use pendulum_atlas_core::analysis::{ZeroOneOptions, stroboscopic, zero_one_test};
use pendulum_atlas_core::engine::{Instance, Observer, StepPlan, integrate};
use pendulum_atlas_core::model::{CartState, Chain, Real, Status, Workspace};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Mean of v²/R_L over the output rows at or after the transient, as one would compute it
/// from the `power_w` column of `trajectory.csv`; also keeps the holder angle of every row
/// for the 0–1 test.
struct PowerMeter {
    transient_s: f64,
    inv_load: f64,
    sum_w: f64,
    rows: u64,
    t_s: Vec<f64>,
    alpha_rad: Vec<f64>,
}

impl<T: Real> Observer<T> for PowerMeter {
    fn sample(
        &mut self,
        _step: u64,
        t_s: f64,
        _cart: &CartState,
        y: &[T],
        chain: &Chain<T>,
        _ws: &mut Workspace<T>,
    ) {
        self.t_s.push(t_s);
        self.alpha_rad.push(y[0].wide());
        if t_s >= self.transient_s - 1e-9 {
            let v = y[2 * chain.segments()].wide();
            self.sum_w += v * v * self.inv_load;
            self.rows += 1;
        }
    }
}

/// One (frequency, initial state) of the re-simulated design.
#[derive(Debug, Clone, Serialize)]
pub struct VerifiedPoint {
    /// Forcing frequency (Hz).
    pub frequency_hz: f64,
    /// Initial state's name.
    pub state: String,
    /// Power the search reported (W).
    pub search_w: f64,
    /// Power of the single-run re-simulation (W).
    pub simulate_w: f64,
    /// Status of the re-simulation.
    pub status: Status,
    /// Hops between wells the search counted (after the transient).
    pub hops: f64,
    /// Period of the search's stroboscopic section (0: not periodic up to 8 periods).
    pub period: f64,
    /// 0–1 test K of the re-simulated run (stroboscopic α after the transient, as
    /// `simulate` reports it): near 0 regular, near 1 chaotic.
    pub k_simulate: f64,
}

impl VerifiedPoint {
    /// Regular by both tests: a periodic stroboscopic section in the search and K < 0.5 in
    /// the re-simulation. Only such responses can be expected to match point by point; a
    /// chaotic one gives another 20-second average at another step.
    pub fn regular(&self) -> bool {
        self.period >= 1.0 && self.k_simulate < 0.5
    }
}

/// The whole re-simulation of one design.
#[derive(Debug, Clone, Serialize)]
pub struct Verification {
    /// The design re-simulated.
    pub design_id: usize,
    /// Every point, states outermost.
    pub points: Vec<VerifiedPoint>,
    /// Robust band-averaged power from the search (W).
    pub search_band_average_w: f64,
    /// Robust band-averaged power from the re-simulation (W).
    pub simulate_band_average_w: f64,
    /// Median over the points of |simulate − search| / search.
    pub median_rel_diff: f64,
    /// Median of the same over the regular points ([`VerifiedPoint::regular`]).
    pub median_rel_diff_regular: f64,
    /// Largest of the same over the regular points.
    pub max_rel_diff_regular: f64,
    /// Number of regular points.
    pub regular_points: usize,
    /// Largest relative difference and where it is.
    pub max_rel_diff: f64,
    /// Frequency of the largest difference (Hz).
    pub max_rel_diff_at_hz: f64,
    /// Wall time (s).
    pub wall_s: f64,
}

/// Relative difference |a − b| / |b| (0 when both are 0).
fn rel(a: f64, b: f64) -> f64 {
    if a == b { 0.0 } else { (a - b).abs() / b.abs() }
}

/// Median of the finite values (NaN if none).
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// What one re-simulation gives.
#[derive(Debug, Clone, Copy)]
pub struct Resimulated {
    /// Mean power over the output rows after the transient (W); NaN if the run failed.
    pub power_w: f64,
    /// 0–1 test K of the stroboscopic holder angle after the transient (NaN if too short).
    pub k: f64,
    /// How the run ended.
    pub status: Status,
}

/// One instance integrated as `simulate` integrates it.
pub fn simulate_power(
    scene: &pendulum_atlas_core::config::Scene,
) -> Result<Resimulated, HarvestError> {
    let linear = |e| HarvestError::Config(pendulum_atlas_core::config::ConfigError::from(e));
    let plan = StepPlan::for_scene(scene).map_err(linear)?;
    let inst = Instance::<f64>::from_scene(scene).map_err(linear)?;
    let mut meter = PowerMeter {
        transient_s: scene.integration.transient_s,
        inv_load: scene.piezo_params().map_or(0.0, |z| 1.0 / z.load_ohm),
        sum_w: 0.0,
        rows: 0,
        t_s: Vec::with_capacity(plan.rows()),
        alpha_rad: Vec::with_capacity(plan.rows()),
    };
    let outcome = integrate(&inst, &plan, &mut meter);
    let ok = outcome.status == Status::Ok;
    let power_w = if meter.rows == 0 || !ok {
        f64::NAN
    } else {
        meter.sum_w / meter.rows as f64
    };
    let k = if ok {
        stroboscopic(
            &meter.t_s,
            &meter.alpha_rad,
            scene.excitation.reference_frequency_hz(),
            0.0,
            scene.integration.transient_s,
        )
        .ok()
        .and_then(|s| zero_one_test(&s, &ZeroOneOptions::default()).ok())
        .map_or(f64::NAN, |r| r.k)
    } else {
        f64::NAN
    };
    Ok(Resimulated {
        power_w,
        k,
        status: outcome.status,
    })
}

/// Re-simulate a design at every band frequency from every initial state.
pub fn verify_design(
    spec: &SearchSpec,
    design: &DesignResult,
) -> Result<Verification, HarvestError> {
    let started = Instant::now();
    let points = resimulate_points(spec, design)?;
    let n_f = spec.band.frequencies_hz.len();
    let per_state: Vec<Vec<f64>> = points
        .chunks(n_f)
        .map(|c| c.iter().map(|p| p.simulate_w).collect())
        .collect();
    let ranked = spec.weighting.curve(&per_state);
    let simulate_band_average_w = super::band::band_average_w(&spec.band.frequencies_hz, &ranked);
    let diffs: Vec<f64> = points
        .iter()
        .map(|p| rel(p.simulate_w, p.search_w))
        .collect();
    let regular: Vec<f64> = points
        .iter()
        .filter(|p| p.regular())
        .map(|p| rel(p.simulate_w, p.search_w))
        .collect();
    let (max_rel_diff, max_rel_diff_at_hz) = points
        .iter()
        .zip(&diffs)
        .filter(|(_, d)| d.is_finite())
        .fold((0.0, f64::NAN), |acc, (p, &d)| {
            if d > acc.0 { (d, p.frequency_hz) } else { acc }
        });
    Ok(Verification {
        design_id: design.id,
        search_band_average_w: design.ranked(spec.weighting).0.band_average_w,
        simulate_band_average_w,
        median_rel_diff: median(diffs),
        max_rel_diff_regular: regular.iter().copied().fold(0.0, f64::max),
        regular_points: regular.len(),
        median_rel_diff_regular: median(regular),
        max_rel_diff,
        max_rel_diff_at_hz,
        wall_s: started.elapsed().as_secs_f64(),
        points,
    })
}

/// The design simulated by `simulate`'s engine at every (initial state, frequency), in
/// parallel, states outermost, each point next to the search's numbers there.
fn resimulate_points(
    spec: &SearchSpec,
    design: &DesignResult,
) -> Result<Vec<VerifiedPoint>, HarvestError> {
    let (table, scene) = spec.design_table(&design.values)?;
    let clearance = scene.limiter.clearance_deg;
    let jobs: Vec<(usize, usize)> = (0..spec.initial_states.len())
        .flat_map(|s| (0..spec.band.frequencies_hz.len()).map(move |j| (s, j)))
        .collect();
    jobs.par_iter()
        .map(|&(s, j)| -> Result<VerifiedPoint, HarvestError> {
            let state = &spec.initial_states[s];
            let f = spec.band.frequencies_hz[j];
            let scene = spec.instance_scene(&table, clearance, state, f)?;
            let re = simulate_power(&scene)?;
            Ok(VerifiedPoint {
                frequency_hz: f,
                state: state.name.clone(),
                search_w: design.power_w[s][j],
                simulate_w: re.power_w,
                k_simulate: re.k,
                status: re.status,
                hops: design.hops[s][j],
                period: design.period[s][j],
            })
        })
        .collect()
}

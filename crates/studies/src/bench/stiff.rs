//! The stiff-chain study behind `pendulum-atlas bench --stiff`: RK4 against the IMEX method
//! (`docs/model.md`, "Time step") with both readings of Table 1's damping.
//!
//! Part (a), work against precision: for each N, damping reading, method, stepping (a multiple
//! of the method's automatic step, or adaptive steps of the IMEX pair at a tolerance) and
//! engine, one instance over `HORIZON_S` at 8 Hz / 9 mm; its holder angle against the DOP853
//! reference at the same N and damping (the integration error alone), and its wall time.
//!
//! Part (b), maps: a small (f, A) map at the library damping integrated by RK4 at its
//! automatic step (f64, the reference map) and by the IMEX method at its automatic step and at
//! adaptive steps (the default tolerances) on each engine; the share of the cells RK4
//! classifies (status ok) on which K class (K > 0.5) and period agree, and the wall times.

use super::{AlphaRows, BenchError, SAMPLES_PER_PERIOD, options, run_map_scenes, timing};
use pendulum_atlas_core::config::{
    BeamDamping, ContactDamping, DEFAULT_ATOL, DEFAULT_RTOL, MethodChoice, Metric, Scene,
    StepControl, TimeStep,
};
use pendulum_atlas_core::engine::adaptive::F32_FINEST_RTOL;
use pendulum_atlas_core::engine::method::{Method, MethodSteps};
use pendulum_atlas_core::engine::{
    Engine, EngineError, EngineKind, EnsemblePlan, Instance, Precision, Readback, ReferenceOptions,
    StepPlan, integrate_reference, no_progress,
};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::reduce::ReduceOptions;
use pendulum_atlas_map::map::MapRun;
use serde::Serialize;
use std::time::Instant;

/// The horizon of part (a) (s): several impacts, before chaos separates the trajectories.
pub(crate) const HORIZON_S: f64 = 0.5;

/// Which reading of Table 1's "damping constant 0.35" (and contact damping) a scene uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reading {
    /// ζ1 = 0.0035 and Kelvin–Voigt contact damping.
    Earlier,
    /// b = 0.35 N m s/rad per joint at N = 17 (ζ1 ≈ 0.054), damping on loading only.
    Library,
}

impl Reading {
    /// Both readings.
    pub const ALL: [Reading; 2] = [Reading::Earlier, Reading::Library];

    /// Name in tables.
    pub fn name(self) -> &'static str {
        match self {
            Reading::Earlier => "earlier (ζ1 = 0.0035, Kelvin–Voigt)",
            Reading::Library => "library (b = 0.35 N m s/rad, loading)",
        }
    }

    fn apply(self, s: &mut Scene) {
        if self == Reading::Earlier {
            s.beam.damping =
                BeamDamping::Ratio(pendulum_atlas_core::config::EARLIER_READING_DAMPING_RATIO);
            s.limiter.damping_law = ContactDamping::KelvinVoigt;
        }
    }
}

/// How a run of the study steps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Stepping {
    /// `method` at `factor` times its automatic step.
    Fixed {
        /// The method.
        method: Method,
        /// Step over the automatic step.
        factor: f64,
    },
    /// Adaptive steps of `method`'s pair at relative tolerance `rtol`, absolute `rtol / 100`
    /// (the defaults' ratio).
    Adaptive {
        /// The method.
        method: Method,
        /// Relative tolerance.
        rtol: f64,
    },
}

impl Stepping {
    /// The method.
    pub fn method(self) -> Method {
        match self {
            Stepping::Fixed { method, .. } | Stepping::Adaptive { method, .. } => method,
        }
    }

    /// The relative tolerance of adaptive steps.
    pub fn rtol(self) -> Option<f64> {
        match self {
            Stepping::Fixed { .. } => None,
            Stepping::Adaptive { rtol, .. } => Some(rtol),
        }
    }

    /// Name in tables and curves ([`stepping_label`]).
    pub fn label(self) -> String {
        stepping_label(self.method(), self.rtol())
    }
}

/// The name of a run's stepping in tables and curves: the method, and "adaptive" with its
/// relative tolerance.
pub(crate) fn stepping_label(method: Method, rtol: Option<f64>) -> String {
    match rtol {
        None => method.name().into(),
        Some(r) => format!("{} adaptive {r:.0e}", method.name()),
    }
}

/// One row of part (a).
#[derive(Debug, Clone, Serialize)]
pub struct HorizonRow {
    /// Segments N.
    pub segments: usize,
    /// Damping reading.
    pub reading: Reading,
    /// Integration method.
    pub method: Method,
    /// Adaptive steps: their relative tolerance (the absolute one is 1/100 of it).
    pub rtol: Option<f64>,
    /// Step over the method's automatic step as asked (adaptive: the base step's, as planned).
    pub dt_factor: f64,
    /// Step (adaptive: base step) (s).
    pub dt_s: f64,
    /// Steps (adaptive: base steps) over the horizon.
    pub steps: u64,
    /// Engine.
    pub backend: EngineKind,
    /// Float type.
    pub precision: Precision,
    /// Max |α − α_ref| over the horizon (rad); NaN when the run failed.
    pub alpha_err_rad: f64,
    /// Wall time of the engine run, one instance (s).
    pub wall_s: f64,
    /// The run's status.
    pub status: Status,
}

/// One map of part (b).
#[derive(Debug, Clone, Serialize)]
pub struct MapRow {
    /// Integration method.
    pub method: Method,
    /// Adaptive steps: their relative tolerance.
    pub rtol: Option<f64>,
    /// Engine.
    pub backend: EngineKind,
    /// Float type.
    pub precision: Precision,
    /// Largest step of the map (s).
    pub dt_s: f64,
    /// Engine wall time (s).
    pub wall_s: f64,
    /// Cells RK4 classified (status ok on the reference map).
    pub cells: usize,
    /// Share of those with the same K class.
    pub k_class_agree: f64,
    /// Share of those with the same period.
    pub period_agree: f64,
    /// Cells not ok on this map.
    pub failed: usize,
}

/// The study.
#[derive(Debug, Clone, Serialize)]
pub struct StiffReport {
    /// `--quick` or full.
    pub quick: bool,
    /// Machine description.
    pub machine: String,
    /// Horizon of part (a) (s).
    pub horizon_s: f64,
    /// Wall time of each DOP853 reference (N, reading, s).
    pub reference_wall_s: ReferenceWalls,
    /// Part (a).
    pub horizon: Vec<HorizonRow>,
    /// Part (b): segments of its maps.
    pub map_segments: usize,
    /// Part (b): the grid.
    pub map_grid: String,
    /// Part (b): RK4's reference map first, then the IMEX maps.
    pub maps: Vec<MapRow>,
    /// Total wall time (s).
    pub total_s: f64,
}

/// Settings of the study.
pub struct StiffOptions<'a> {
    /// N = 5 only, a smaller map, fewer steps.
    pub quick: bool,
    /// The GPU engine, when the GPU is measured too.
    pub gpu: Option<&'a Engine>,
}

/// The study's scene: Table 1 at N segments, 8 Hz / 9 mm, with `reading`'s damping.
fn scene(n: usize, reading: Reading) -> Scene {
    let mut s = Scene::paper();
    s.beam.segments = n;
    reading.apply(&mut s);
    s
}

/// The same scene over the horizon, R's series at 16 samples per period (the rows compared).
fn horizon_scene(n: usize, reading: Reading) -> Scene {
    let mut s = scene(n, reading);
    timing(&mut s, HORIZON_S, 0.125);
    s
}

/// α of the DOP853 reference over the horizon at 16 samples per period.
fn reference_alpha(n: usize, reading: Reading) -> Result<Vec<f64>, EngineError> {
    let mut s = scene(n, reading);
    timing(&mut s, HORIZON_S, 0.125);
    s.output.sample_rate_hz = 8.0 * f64::from(SAMPLES_PER_PERIOD);
    let plan = StepPlan::for_scene(&s)?;
    let mut rows = AlphaRows(Vec::new());
    let opts = ReferenceOptions::for_stiffness(s.modes()?.spectral_radius_per_s);
    integrate_reference(&Instance::from_scene(&s)?, &plan, &opts, &mut rows)?;
    Ok(rows.0)
}

/// `s` stepped as `stepping` says.
fn with_stepping(mut s: Scene, stepping: Stepping) -> Result<Scene, EngineError> {
    s.integration.method = match stepping.method() {
        Method::Rk4 => MethodChoice::Rk4,
        Method::Imex => MethodChoice::Imex,
    };
    match stepping {
        Stepping::Fixed { method, factor } => {
            let auto = MethodSteps::of_scene(&s)?.auto_s(method);
            s.integration.set_fixed(TimeStep::Seconds(factor * auto));
        }
        Stepping::Adaptive { rtol, .. } => {
            s.integration.dt_s = TimeStep::Auto;
            s.integration.step = StepControl::Adaptive {
                rtol,
                atol: rtol * (DEFAULT_ATOL / DEFAULT_RTOL),
            };
        }
    }
    Ok(s)
}

/// One row of part (a).
fn horizon_row(
    s: Scene,
    engine: &Engine,
    reference: &[f64],
    stepping: Stepping,
) -> Result<HorizonRow, EngineError> {
    let n = s.beam.segments;
    let reading = if s.limiter.damping_law == ContactDamping::Loading {
        Reading::Library
    } else {
        Reading::Earlier
    };
    let method = stepping.method();
    let auto = MethodSteps::of_scene(&s)?.auto_s(method);
    let s = with_stepping(s, stepping)?;
    let plan = EnsemblePlan::from_scenes(&[s], &options(vec![Metric::R]))?;
    let readback = Readback {
        strobe: false,
        r_series: true,
        ..Readback::default()
    };
    let t0 = Instant::now();
    let run = engine.run(&plan, &ReduceOptions::default(), readback, &no_progress)?;
    let wall_s = t0.elapsed().as_secs_f64();
    let p = &plan.instances[0];
    let first = (p.r_start / p.r_every) as usize;
    let status = run.results[0].status;
    let alpha_err_rad = if status == Status::Ok {
        run.r_series[0]
            .iter()
            .enumerate()
            .map(|(j, a)| reference.get(first + j).map_or(f64::NAN, |r| (a - r).abs()))
            .fold(0.0, f64::max)
    } else {
        f64::NAN
    };
    let info = engine.info();
    Ok(HorizonRow {
        segments: n,
        reading,
        method,
        rtol: stepping.rtol(),
        dt_factor: match stepping {
            Stepping::Fixed { factor, .. } => factor,
            Stepping::Adaptive { .. } => p.dt_s / auto,
        },
        dt_s: p.dt_s,
        steps: p.total_steps(),
        backend: info.kind,
        precision: info.precision,
        alpha_err_rad,
        wall_s,
        status,
    })
}

/// The steppings of part (a). RK4 is measured at its automatic step only: a larger one is
/// unstable, a smaller one costs more and the error is already ≤ 1e-6. The adaptive IMEX runs
/// span the tolerances from 10× looser than the default to 100× tighter.
fn steps_measured(quick: bool) -> Vec<Stepping> {
    let (imex, rtols): (&[f64], &[f64]) = if quick {
        (&[4.0, 1.0, 0.25], &[1e-3, 1e-4])
    } else {
        (&[8.0, 4.0, 2.0, 1.0, 0.5, 0.25], &[1e-2, 1e-3, 1e-4, 1e-5])
    };
    let fixed = |method, factor| Stepping::Fixed { method, factor };
    std::iter::once(fixed(Method::Rk4, 1.0))
        .chain(imex.iter().map(|&f| fixed(Method::Imex, f)))
        .chain(rtols.iter().map(|&rtol| Stepping::Adaptive {
            method: Method::Imex,
            rtol,
        }))
        .collect()
}

/// Whether `stepping` is measured on `engine`: adaptive steps in f32 down to
/// [`F32_FINEST_RTOL`] (finer ones are forced to the ladder's finest level).
fn measured_on(stepping: Stepping, engine: &Engine) -> bool {
    let f32 = engine.info().precision == Precision::F32;
    !(f32 && stepping.rtol().is_some_and(|r| r < F32_FINEST_RTOL))
}

/// Wall time of each DOP853 reference: (N, reading, s).
type ReferenceWalls = Vec<(usize, Reading, f64)>;

/// Part (a) for every N, reading, method and step on every engine.
fn horizon_part(
    opts: &StiffOptions,
    engines: &[&Engine],
    progress: &dyn Fn(&str),
) -> Result<(Vec<HorizonRow>, ReferenceWalls), EngineError> {
    let ns: &[usize] = if opts.quick { &[5] } else { &[5, 9, 17] };
    let (mut rows, mut refs) = (Vec::new(), Vec::new());
    for &n in ns {
        for reading in Reading::ALL {
            let t0 = Instant::now();
            let reference = reference_alpha(n, reading)?;
            refs.push((n, reading, t0.elapsed().as_secs_f64()));
            for step in steps_measured(opts.quick) {
                for engine in engines.iter().filter(|e| measured_on(step, e)) {
                    let r = horizon_row(horizon_scene(n, reading), engine, &reference, step)?;
                    progress(&format!(
                        "N = {n:2} {:<8} {:<4} dt = {:.2e} s ({:.3}x auto) on {} {}: α error {:.2e} rad, {:.3} s",
                        format!("{reading:?}"),
                        step.label(),
                        r.dt_s,
                        r.dt_factor,
                        r.backend.name(),
                        r.precision.name(),
                        r.alpha_err_rad,
                        r.wall_s
                    ));
                    rows.push(r);
                }
            }
        }
    }
    Ok((rows, refs))
}

/// Part (b)'s grid: (f, A) cells, each run for a 2-s transient and 100 forcing periods.
fn map_cells(quick: bool) -> (Vec<(f64, f64)>, usize, String) {
    let (fs, amps, n): (&[f64], &[f64], usize) = if quick {
        (&[8.0, 12.0], &[0.009, 0.015], 5)
    } else {
        (&[8.0, 10.0, 12.0], &[0.009, 0.012], 17)
    };
    let cells = fs
        .iter()
        .flat_map(|&f| amps.iter().map(move |&a| (f, a)))
        .collect();
    let grid = format!(
        "f in {fs:?} Hz x A in {:?} mm at N = {n}, 2 s + 100 forcing periods",
        amps.iter().map(|a| a * 1e3).collect::<Vec<_>>()
    );
    (cells, n, grid)
}

fn map_scenes(
    cells: &[(f64, f64)],
    n: usize,
    stepping: Stepping,
) -> Result<Vec<Scene>, EngineError> {
    cells
        .iter()
        .map(|&(f, a)| {
            let mut s = scene(n, Reading::Library);
            s.excitation.kind =
                pendulum_atlas_core::model::ExcitationKind::Harmonic { frequency_hz: f };
            s.excitation.amplitude_m = a;
            timing(&mut s, 2.0 + 100.0 / f, 2.0);
            with_stepping(s, stepping)
        })
        .collect()
}

/// A map against the reference map, on the cells the reference classifies.
fn map_row(stepping: Stepping, engine: &Engine, map: &MapRun, reference: &MapRun) -> MapRow {
    let classified: Vec<usize> = (0..reference.results.len())
        .filter(|&c| reference.results[c].status == Status::Ok)
        .collect();
    let share = |same: &dyn Fn(usize) -> bool| {
        classified.iter().filter(|&&c| same(c)).count() as f64 / classified.len().max(1) as f64
    };
    let (a, b) = (&map.results, &reference.results);
    let info = engine.info();
    MapRow {
        method: stepping.method(),
        rtol: stepping.rtol(),
        backend: info.kind,
        precision: info.precision,
        dt_s: map.plan.dt_range_s.1,
        wall_s: map.engine_s(),
        cells: classified.len(),
        k_class_agree: share(&|c| a[c].status == Status::Ok && (a[c].k > 0.5) == (b[c].k > 0.5)),
        period_agree: share(&|c| {
            a[c].status == Status::Ok && a[c].period.to_bits() == b[c].period.to_bits()
        }),
        failed: a.iter().filter(|r| r.status != Status::Ok).count(),
    }
}

/// Part (b): RK4's reference map, then the IMEX method at its automatic step and at adaptive
/// steps (the default tolerances) on every engine.
fn map_part(
    quick: bool,
    engines: &[&Engine],
    progress: &dyn Fn(&str),
) -> Result<(usize, String, Vec<MapRow>), EngineError> {
    let (cells, n, grid) = map_cells(quick);
    let metrics = vec![Metric::K, Metric::Period];
    let rk4 = Stepping::Fixed {
        method: Method::Rk4,
        factor: 1.0,
    };
    let reference = run_map_scenes(&map_scenes(&cells, n, rk4)?, metrics.clone(), engines[0])?;
    let mut rows = vec![map_row(rk4, engines[0], &reference, &reference)];
    progress(&format!(
        "map: RK4 reference, {} cells at N = {n}, {:.1} s",
        cells.len(),
        reference.engine_s()
    ));
    let imex = [
        Stepping::Fixed {
            method: Method::Imex,
            factor: 1.0,
        },
        Stepping::Adaptive {
            method: Method::Imex,
            rtol: DEFAULT_RTOL,
        },
    ];
    for stepping in imex {
        for engine in engines {
            let scenes = map_scenes(&cells, n, stepping)?;
            let map = run_map_scenes(&scenes, metrics.clone(), engine)?;
            let row = map_row(stepping, engine, &map, &reference);
            progress(&format!(
                "map: {} on {} {}: {:.1} s, K class {:.0} %, period {:.0} % of {} cells",
                stepping.label(),
                row.backend.name(),
                row.precision.name(),
                row.wall_s,
                100.0 * row.k_class_agree,
                100.0 * row.period_agree,
                row.cells
            ));
            rows.push(row);
        }
    }
    Ok((n, grid, rows))
}

/// Run the study. `progress` receives a line per measurement.
pub fn run_stiff(opts: &StiffOptions, progress: &dyn Fn(&str)) -> Result<StiffReport, BenchError> {
    let t_all = Instant::now();
    let (cpu64, cpu32) = (Engine::cpu(Precision::F64), Engine::cpu(Precision::F32));
    let mut engines = vec![&cpu64, &cpu32];
    engines.extend(opts.gpu);
    let (horizon, reference_wall_s) = horizon_part(opts, &engines, progress)?;
    let (map_segments, map_grid, maps) = map_part(opts.quick, &engines, progress)?;
    Ok(StiffReport {
        quick: opts.quick,
        machine: super::machine(opts.gpu),
        horizon_s: HORIZON_S,
        reference_wall_s,
        horizon,
        map_segments,
        map_grid,
        maps,
        total_s: t_all.elapsed().as_secs_f64(),
    })
}

//! The map's accuracy, `pendulum-atlas bench --verdict`: how often the default map's verdict
//! per cell is the one a converged run gives, and at what wall time.
//!
//! Stages of [`run_verdict`]:
//! 1. **Subgrid**: the embedded default map (`configs/maps/default.toml`) thinned to every
//!    [`THIN`]th frequency and amplitude (16 × 12 = 192 cells), same scene and start.
//! 2. **Reference**: the subgrid on the CPU engine in f64 for [`REFERENCE_S`] seconds and for
//!    twice that (transient half the run), every indicator of the verdict at its strictest
//!    useful setting (period window [`REFERENCE_PERIOD_WINDOW`], tolerance
//!    [`REFERENCE_PERIOD_TOL_RAD`] rad). The share of cells whose verdict changes on doubling
//!    shows that the reference has converged; the longer run's verdict is the reference, and a
//!    cell is **settled** where both runs reach the same decided verdict.
//! 3. **Candidates**: the subgrid under the settings a map could use — duration, the λ1
//!    window, float type, engine, and which indicators decide ([`Decider`]) — each scored on
//!    the settled cells: the share with the reference's verdict, the share of its periodic cells
//!    whose period is the reference's, and the share of cells it leaves undecided.
//! 4. **Cost**: the whole default map with today's metrics (no λ1) against the same map with
//!    the verdict, on the engine the study runs on.
//! 5. **Reliability** of `verdict_confidence` ([`super::reliability`]).
//! 6. **Settling**: transient chaos, and `map.settle_max_s`'s accuracy against its cost
//!    ([`super::settling`]).

use super::reference::Reference;
use super::reliability::{Reliability, reliability, score_subgrid};
use super::settling::{Settling, Subgrid, settling};
use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, MapSpec, map_from_toml};
use pendulum_atlas_core::engine::{Engine, EngineError, EngineKind, Precision, no_progress};
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_map::map::confidence::SHIPPED;
use pendulum_atlas_map::map::{MapRun, run_map};
use serde::Serialize;
use std::time::Instant;

/// Every this-many-th frequency and amplitude of the default map's grid.
pub const THIN: usize = 4;

/// The reference's shorter run (s); the longer is twice this.
pub const REFERENCE_S: f64 = 2000.0;

/// The reference's period window (stroboscopic samples that must repeat).
pub const REFERENCE_PERIOD_WINDOW: u32 = 64;

/// The reference's period tolerance (rad). With the maps' own 1e-3, 5 of the 192 cells change
/// their verdict when the run doubles from 2000 to 4000 s (chaotic bands narrower than 1e-3 rad
/// that pass for an orbit in one run and not in the other); with 1e-4, 2. The price: a stable
/// orbit of the fixed-step map that jitters by 1e-4 to 1e-3 rad from return to return (the
/// onset of a contact falls at another point of a step each time) has no period in the
/// reference, which calls it regular where a map may call it periodic.
pub const REFERENCE_PERIOD_TOL_RAD: f64 = 1e-4;

/// Which indicators decide a cell's verdict.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Decider {
    /// The regime rule (`src/reduce/regime.rs`): λ1, the period and K together.
    Rule,
    /// Before λ1: K ≥ 0.5 is chaotic, else periodic with a period, else regular.
    KAndPeriod,
}

impl Decider {
    /// The label of the report.
    pub fn name(self) -> &'static str {
        match self {
            Decider::Rule => "λ1 + period + K (rule)",
            Decider::KAndPeriod => "K + period",
        }
    }
}

/// One setting of a candidate map.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Candidate {
    /// Run length (s).
    pub duration_s: f64,
    /// Transient (s).
    pub transient_s: f64,
    /// λ1's window (s; `None`: the whole run after the transient).
    pub window_s: Option<f64>,
    /// Float type.
    pub precision: Precision,
    /// Engine.
    pub backend: EngineKind,
    /// Which indicators decide.
    pub decider: Decider,
}

/// How a candidate fared against the reference.
#[derive(Debug, Clone, Serialize)]
pub struct Score {
    /// The setting.
    pub candidate: Candidate,
    /// Wall time of the subgrid run (s).
    pub wall_s: f64,
    /// Settled cells of the reference.
    pub settled: usize,
    /// Of those, cells with the reference's verdict.
    pub agree: usize,
    /// Cells the candidate calls periodic.
    pub periodic: usize,
    /// Of those, cells the reference calls periodic with the same period.
    pub period_right: usize,
    /// Cells the candidate leaves undecided (of all cells).
    pub undecided: usize,
    /// Cells in the subgrid.
    pub cells: usize,
}

impl Score {
    /// Share of settled cells with the reference's verdict (%).
    pub fn agree_pct(&self) -> f64 {
        pct(self.agree, self.settled)
    }
    /// Share of periodic cells with the right period (%).
    pub fn period_pct(&self) -> f64 {
        pct(self.period_right, self.periodic)
    }
    /// Share of undecided cells (%).
    pub fn undecided_pct(&self) -> f64 {
        pct(self.undecided, self.cells)
    }
}

fn pct(a: usize, b: usize) -> f64 {
    if b == 0 {
        f64::NAN
    } else {
        100.0 * a as f64 / b as f64
    }
}

/// The whole default map's wall time with and without the verdict.
#[derive(Debug, Clone, Serialize)]
pub struct Cost {
    /// Engine and float type.
    pub engine: String,
    /// Cells.
    pub cells: usize,
    /// Wall time with today's metrics, no λ1 (s).
    pub baseline_s: f64,
    /// Wall time of the default map as shipped (s).
    pub verdict_s: f64,
}

/// Everything the study measured.
#[derive(Debug, Clone, Serialize)]
pub struct VerdictReport {
    /// The subgrid takes every this-many-th value of each axis.
    pub thin: usize,
    /// Subgrid shape (frequencies, amplitudes).
    pub shape: [usize; 2],
    /// The reference.
    pub reference: Reference,
    /// The reference of the second subgrid (from the `thin/2`th value), for the reliability.
    pub second: Reference,
    /// One score per candidate.
    pub scores: Vec<Score>,
    /// The whole map's cost (not in `--quick`).
    pub cost: Option<Cost>,
    /// Whether `verdict_confidence` predicts the verdict's error.
    pub reliability: Reliability,
    /// Transient chaos, and settling's accuracy against its cost.
    pub settling: Settling,
    /// Wall time of the study (s).
    pub total_s: f64,
}

/// Options of [`run_verdict`].
pub struct VerdictOptions<'a> {
    /// A tenth of the reference and a quarter of the grid (a test of the study, not a result).
    pub quick: bool,
    /// The GPU engine, when one is open: its candidates join the CPU's.
    pub gpu: Option<&'a Engine>,
}

/// The default map with `sets` applied, thinned to every `thin`th value of each axis.
fn subgrid(sets: &[String], thin: usize) -> Result<MapSpec, EngineError> {
    subgrid_at(sets, thin, 0)
}

/// The same from the `offset`th value of each axis.
/// The map is raw (`map.settle = false`) unless `sets` asks for settling: the study's
/// candidates and references are each one run of their length.
fn subgrid_at(sets: &[String], thin: usize, offset: usize) -> Result<MapSpec, EngineError> {
    let mut sets = sets.to_vec();
    if !sets.iter().any(|s| s.starts_with("map.settle")) {
        sets.push("map.settle=false".into());
    }
    let mut spec = map_from_toml(DEFAULT_MAP_TOML, "the default map", &sets)?;
    for axis in &mut spec.axes {
        axis.values = axis
            .values
            .iter()
            .skip(offset)
            .step_by(thin)
            .copied()
            .collect();
    }
    Ok(spec)
}

/// The `--set` overrides of a run of `duration` s with transient `transient`.
fn timing_sets(duration: f64, transient: f64, metrics: &str) -> Vec<String> {
    vec![
        format!("integration.duration_s={duration}"),
        format!("integration.transient_s={transient}"),
        format!("map.metrics={metrics}"),
    ]
}

fn timed(spec: &MapSpec, engine: &Engine) -> Result<(MapRun, f64), EngineError> {
    let t0 = Instant::now();
    let run = run_map(spec, engine, &no_progress)?;
    Ok((run, t0.elapsed().as_secs_f64()))
}

/// Stage 2: the reference runs and their agreement, on the subgrid from `offset`.
fn reference_run(quick: bool, thin: usize, offset: usize) -> Result<Reference, EngineError> {
    let short = if quick {
        REFERENCE_S / 10.0
    } else {
        REFERENCE_S
    };
    let engine = Engine::cpu(Precision::F64);
    let mut runs = Vec::new();
    let mut wall = 0.0;
    for d in [short, 2.0 * short] {
        let mut sets = timing_sets(d, d / 2.0, "[\"K\", \"period\", \"regime\"]");
        sets.push(format!("map.period_window={REFERENCE_PERIOD_WINDOW}"));
        sets.push(format!("map.period_tol_rad={REFERENCE_PERIOD_TOL_RAD}"));
        sets.push("map.lyapunov_window_s=\"whole\"".into());
        let (run, s) = timed(&subgrid_at(&sets, thin, offset)?, &engine)?;
        wall += s;
        runs.push(run);
    }
    let (a, b) = (&runs[0].results, &runs[1].results);
    let decided = |r: Regime| matches!(r, Regime::Periodic | Regime::Regular | Regime::Chaotic);
    let is_settled: Vec<bool> = a
        .iter()
        .zip(b)
        .map(|(x, y)| decided(y.regime) && x.regime == y.regime)
        .collect();
    let mut counts = [0usize; 5];
    for r in b {
        counts[(r.regime.code() + 1) as usize] += 1;
    }
    Ok(Reference {
        durations_s: [short, 2.0 * short],
        wall_s: wall,
        changed: a
            .iter()
            .zip(b)
            .filter(|(x, y)| x.regime != y.regime)
            .count(),
        settled: is_settled.iter().filter(|s| **s).count(),
        cells: b.len(),
        regime: b.iter().map(|r| r.regime.code()).collect(),
        period: b.iter().map(|r| r.period).collect(),
        is_settled,
        stop_s: stop_times(&runs[1]),
        counts,
    })
}

/// When the early stop stopped each instance of `run` (s; NaN where it ran to its end).
fn stop_times(run: &MapRun) -> Vec<f64> {
    run.results
        .iter()
        .zip(&run.plan.instances)
        .map(|(r, p)| match r.steps < p.total_steps() {
            true => r.steps as f64 * p.dt_s,
            false => f64::NAN,
        })
        .collect()
}

/// The verdict of a cell under `decider`.
fn verdict(r: &pendulum_atlas_core::reduce::InstanceResult, decider: Decider) -> Regime {
    match decider {
        Decider::Rule => r.regime,
        Decider::KAndPeriod if r.status != pendulum_atlas_core::model::Status::Ok => Regime::Failed,
        Decider::KAndPeriod if r.k >= 0.5 => Regime::Chaotic,
        Decider::KAndPeriod if r.period > 0.0 => Regime::Periodic,
        Decider::KAndPeriod => Regime::Regular,
    }
}

/// Stage 3: one candidate on the subgrid, scored against `reference`.
fn score(
    c: Candidate,
    engine: &Engine,
    reference: &Reference,
    thin: usize,
) -> Result<Score, EngineError> {
    let metrics = match c.decider {
        Decider::Rule => "[\"K\", \"period\", \"regime\"]",
        Decider::KAndPeriod => "[\"K\", \"period\"]",
    };
    let mut sets = timing_sets(c.duration_s, c.transient_s, metrics);
    sets.push(match c.window_s {
        Some(w) => format!("map.lyapunov_window_s={w}"),
        None => "map.lyapunov_window_s=\"whole\"".into(),
    });
    let (run, wall_s) = timed(&subgrid(&sets, thin)?, engine)?;
    let got: Vec<Regime> = run.results.iter().map(|r| verdict(r, c.decider)).collect();
    let settled: Vec<usize> = (0..got.len())
        .filter(|&k| reference.is_settled[k])
        .collect();
    let periodic: Vec<usize> = (0..got.len())
        .filter(|&k| got[k] == Regime::Periodic)
        .collect();
    Ok(Score {
        candidate: c,
        wall_s,
        settled: settled.len(),
        agree: settled
            .iter()
            .filter(|&&k| got[k].code() == reference.regime[k])
            .count(),
        periodic: periodic.len(),
        period_right: periodic
            .iter()
            .filter(|&&k| {
                reference.regime[k] == Regime::Periodic.code()
                    && reference.period[k] == run.results[k].period
            })
            .count(),
        undecided: got.iter().filter(|r| **r == Regime::Undecided).count(),
        cells: got.len(),
    })
}

/// The candidates of the study on one engine.
fn candidates(quick: bool, backend: EngineKind) -> Vec<Candidate> {
    let c = |duration_s, transient_s, window_s, precision, decider| Candidate {
        duration_s,
        transient_s,
        window_s,
        precision,
        backend,
        decider,
    };
    use Decider::{KAndPeriod, Rule};
    use Precision::{F32, F64};
    if backend == EngineKind::Gpu {
        return vec![
            c(34.0, 10.0, None, F32, Rule),
            c(68.0, 20.0, None, F32, Rule),
        ];
    }
    let mut v = vec![
        c(34.0, 10.0, None, F64, KAndPeriod),
        c(34.0, 10.0, None, F64, Rule),
        c(34.0, 10.0, Some(12.0), F64, Rule),
        c(34.0, 10.0, Some(6.0), F64, Rule),
        c(34.0, 10.0, None, F32, Rule),
    ];
    if !quick {
        v.extend([
            c(68.0, 20.0, None, F64, KAndPeriod),
            c(68.0, 20.0, None, F64, Rule),
            c(68.0, 20.0, Some(12.0), F64, Rule),
            c(136.0, 40.0, None, F64, KAndPeriod),
            c(136.0, 40.0, None, F64, Rule),
            c(272.0, 80.0, None, F64, Rule),
            c(544.0, 160.0, None, F64, Rule),
        ]);
    }
    v
}

/// Stage 4: the whole default map without and with the verdict; the latter's run too.
fn cost(engine: &Engine) -> Result<(Cost, MapRun), EngineError> {
    let baseline = subgrid(
        &[
            "map.metrics=[\"K\", \"R\", \"period\", \"hops\", \"impacts_per_s\", \"alpha_range\"]"
                .into(),
        ],
        1,
    )?;
    let shipped = subgrid(&[], 1)?;
    let (run, baseline_s) = timed(&baseline, engine)?;
    let (whole, verdict_s) = timed(&shipped, engine)?;
    let info = engine.info();
    let cost = Cost {
        engine: format!("{} {}", info.kind.name(), info.precision.name()),
        cells: run.results.len(),
        baseline_s,
        verdict_s,
    };
    Ok((cost, whole))
}

/// Run the study, reporting each stage through `progress`.
pub fn run_verdict(
    opts: &VerdictOptions,
    progress: &dyn Fn(&str),
) -> Result<VerdictReport, EngineError> {
    let t0 = Instant::now();
    let thin = if opts.quick { 2 * THIN } else { THIN };
    let reference = reference_run(opts.quick, thin, 0)?;
    progress(&format!(
        "reference: {} of {} cells change on doubling, {} settled ({:.0} s)",
        reference.changed, reference.cells, reference.settled, reference.wall_s
    ));
    let mut scores = Vec::new();
    let mut engines: Vec<(EngineKind, Option<&Engine>)> = vec![(EngineKind::Cpu, None)];
    if let Some(g) = opts.gpu {
        engines.push((EngineKind::Gpu, Some(g)));
    }
    for (kind, gpu) in engines {
        for c in candidates(opts.quick, kind) {
            let cpu = Engine::cpu(c.precision);
            let s = score(c, gpu.unwrap_or(&cpu), &reference, thin)?;
            progress(&format!(
                "{} {} {} s, window {:?} s, {}: {:.1} % agree, {:.1} % periods right, {:.1} % undecided ({:.1} s)",
                kind.name(),
                c.precision.name(),
                c.duration_s,
                c.window_s,
                c.decider.name(),
                s.agree_pct(),
                s.period_pct(),
                s.undecided_pct(),
                s.wall_s
            ));
            scores.push(s);
        }
    }
    let cpu64 = Engine::cpu(Precision::F64);
    let (cost, whole) = if opts.quick {
        (None, run_map(&subgrid(&[], 1)?, &cpu64, &no_progress)?)
    } else {
        let (c, whole) = cost(&cpu64)?;
        (Some(c), whole)
    };
    let second = reference_run(opts.quick, thin, thin / 2)?;
    progress(&format!(
        "reference B (from value {}): {} of {} cells change on doubling, {} settled ({:.0} s)",
        thin / 2 + 1,
        second.changed,
        second.cells,
        second.settled,
        second.wall_s
    ));
    let shape = subgrid(&[], 1)?.shape();
    let score = |name, offset, r: &Reference| {
        score_subgrid(
            name,
            &whole,
            &shape,
            (thin, offset),
            &r.regime,
            &r.is_settled,
        )
    };
    let reliability = reliability(
        &score("A", 0, &reference),
        &score("B", thin / 2, &second),
        &SHIPPED,
    );
    let grids = [
        Subgrid {
            name: "A",
            offset: 0,
            reference: &reference,
        },
        Subgrid {
            name: "B",
            offset: thin / 2,
            reference: &second,
        },
    ];
    let spec_with = |sets: &[String]| subgrid(sets, 1);
    let settling = settling(&whole, &spec_with, (&grids, thin), opts.quick, progress)?;
    let shape = {
        let spec = subgrid(&[], thin)?;
        [spec.axes[0].values.len(), spec.axes[1].values.len()]
    };
    Ok(VerdictReport {
        thin,
        shape,
        reference,
        second,
        scores,
        cost,
        reliability,
        settling,
        total_s: t0.elapsed().as_secs_f64(),
    })
}

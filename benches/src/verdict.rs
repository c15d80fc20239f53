//! The map's accuracy, `pendulum-atlas-lab verdict`: how often the default map's verdict
//! per cell is the one a converged run gives, and at what wall time.
//!
//! Stages of [`run_verdict`]:
//! 1. **Subgrid**: the study's [`Plane`] (by default the embedded default map,
//!    `configs/maps/default.toml`) thinned to every [`THIN`]th value of each axis
//!    (16 × 12 = 192 cells), same scene and start.
//! 2. **Reference**: the subgrid on the CPU engine in f64 for [`REFERENCE_S`] seconds and for
//!    twice that (transient half the run), adaptive steps at tolerances [`REFERENCE_RTOL`] and
//!    [`REFERENCE_ATOL`], every indicator of the verdict at its strictest useful setting (period
//!    window [`REFERENCE_PERIOD_WINDOW`], tolerance [`REFERENCE_PERIOD_TOL_RAD`] rad). Two
//!    checks show that it has converged: the share of cells whose verdict changes on doubling
//!    the run (its length), and on subgrid A the share whose verdict or period changes when the
//!    shorter run's tolerances are divided by ten (its steps). The longer run's verdict is the
//!    reference, and a cell is **settled** where both runs reach the same decided verdict.
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
use pendulum_atlas_core::reduce::{InstanceResult, Regime};
use pendulum_atlas_map::map::confidence::SHIPPED;
use pendulum_atlas_map::map::{MapRun, run_map};
use serde::Serialize;
use std::time::Instant;

/// Every this-many-th value of each axis of the plane's grid.
pub const THIN: usize = 4;

/// The plane a study runs on: a map scene of 64 × 48 cells over two keys, which the study
/// thins into its subgrids A and B. Each plane builds its own reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Plane {
    /// The embedded default map: forcing frequency × amplitude.
    Forcing,
    /// Frequency × the bumpers' clearance at A = 9 mm.
    Clearance,
    /// The forcing plane with the piezo patch harvesting.
    Piezo,
}

impl Plane {
    /// Every plane, in the study's order.
    pub const ALL: [Plane; 3] = [Plane::Forcing, Plane::Clearance, Plane::Piezo];

    /// The plane's name (`--plane`).
    pub fn name(self) -> &'static str {
        match self {
            Plane::Forcing => "forcing",
            Plane::Clearance => "clearance",
            Plane::Piezo => "piezo",
        }
    }

    /// Where its scene lives in the repository.
    pub fn path(self) -> &'static str {
        match self {
            Plane::Forcing => "configs/maps/default.toml",
            Plane::Clearance => "configs/maps/verdict_clearance.toml",
            Plane::Piezo => "configs/maps/verdict_piezo.toml",
        }
    }

    /// Its map scene (TOML).
    pub fn scene(self) -> &'static str {
        match self {
            Plane::Forcing => DEFAULT_MAP_TOML,
            Plane::Clearance => include_str!("../../configs/maps/verdict_clearance.toml"),
            Plane::Piezo => include_str!("../../configs/maps/verdict_piezo.toml"),
        }
    }
}

/// The reference's shorter run (s); the longer is twice this.
pub const REFERENCE_S: f64 = 1000.0;

/// The reference's relative tolerance of adaptive steps. At the maps' 1e-3 the strobe of a
/// stable orbit jitters from return to return by more than the reference's period tolerance
/// (each return takes other steps), and the reference called 20 cells of subgrid A regular that
/// are period 3 at 1e-5, 1e-6 and 1e-7. At those three (400-s runs of subgrid A) the verdicts
/// agree on 188 of 192 cells and the regular class is empty but for one cell.
pub const REFERENCE_RTOL: f64 = 1e-6;

/// The reference's absolute tolerance (rad, rad/s), with [`REFERENCE_RTOL`].
pub const REFERENCE_ATOL: f64 = 1e-8;

/// The reference's period window (stroboscopic samples that must repeat).
pub const REFERENCE_PERIOD_WINDOW: u32 = 64;

/// The reference's period tolerance (rad). With the maps' own 1e-3, 5 of the 192 cells changed
/// their verdict when the run doubled from 2000 to 4000 s (chaotic bands narrower than 1e-3 rad
/// that pass for an orbit in one run and not in the other); with 1e-4, 2. It needs steps whose
/// error stays well below it from return to return ([`REFERENCE_RTOL`]).
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
    /// Settled cells the reference calls periodic.
    pub ref_periodic: usize,
    /// Of those, cells the candidate calls periodic with the reference's period.
    pub ref_period_found: usize,
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
    /// Share of the reference's periodic cells given their period (%).
    pub fn found_pct(&self) -> f64 {
        pct(self.ref_period_found, self.ref_periodic)
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
    /// The plane.
    pub plane: Plane,
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
    /// Where the references were kept from (`None`: run by this study).
    pub reference_kept_from: Option<String>,
}

/// Options of [`run_verdict`].
pub struct VerdictOptions<'a> {
    /// A twentieth of the reference, a 4 × 3 subgrid, and the map scored and settled at every
    /// 8th value instead of the whole plane (a test of the study, not a result).
    pub quick: bool,
    /// The GPU engine, when one is open: its candidates join the CPU's.
    pub gpu: Option<&'a Engine>,
    /// The plane.
    pub plane: Plane,
    /// The references of an earlier study of the plane, kept instead of run again.
    pub kept: Option<Kept>,
}

/// References kept from an earlier study ([`super::kept::kept_references`]).
pub struct Kept {
    /// The folder they were read from.
    pub from: String,
    /// Subgrid A's.
    pub a: Reference,
    /// Subgrid B's.
    pub b: Reference,
}

/// The default map with `sets` applied, thinned to every `thin`th value of each axis.
fn subgrid(plane: Plane, sets: &[String], thin: usize) -> Result<MapSpec, EngineError> {
    subgrid_at(plane, sets, thin, 0)
}

/// The same from the `offset`th value of each axis.
/// The map is raw (`map.settle = false`) unless `sets` asks for settling: the study's
/// candidates and references are each one run of their length.
pub(crate) fn subgrid_at(
    plane: Plane,
    sets: &[String],
    thin: usize,
    offset: usize,
) -> Result<MapSpec, EngineError> {
    let mut sets = sets.to_vec();
    if !sets.iter().any(|s| s.starts_with("map.settle")) {
        sets.push("map.settle=false".into());
    }
    let mut spec = map_from_toml(plane.scene(), plane.path(), &sets)?;
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

pub(crate) fn timed(spec: &MapSpec, engine: &Engine) -> Result<(MapRun, f64), EngineError> {
    let t0 = Instant::now();
    let run = run_map(spec, engine, &no_progress)?;
    Ok((run, t0.elapsed().as_secs_f64()))
}

/// Which checks of convergence a reference run makes besides doubling its length.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Checks {
    /// Doubling only.
    Length,
    /// Doubling, and the shorter run again at a tenth of the tolerances.
    LengthAndSteps,
}

/// The reference's `--set` overrides of a run of `duration` s at tolerances `rtol`, `atol`.
pub(crate) fn reference_sets(duration: f64, rtol: f64, atol: f64) -> Vec<String> {
    let mut sets = timing_sets(duration, duration / 2.0, "[\"K\", \"period\", \"regime\"]");
    sets.extend([
        format!("map.period_window={REFERENCE_PERIOD_WINDOW}"),
        format!("map.period_tol_rad={REFERENCE_PERIOD_TOL_RAD}"),
        "map.lyapunov_window_s=\"whole\"".into(),
        format!("integration.rtol={rtol:e}"),
        format!("integration.atol={atol:e}"),
    ]);
    sets
}

/// The reference's two run lengths (s): [`REFERENCE_S`] and twice that, a twentieth of both in
/// `--quick`.
pub fn reference_durations(quick: bool) -> [f64; 2] {
    let short = if quick {
        REFERENCE_S / 20.0
    } else {
        REFERENCE_S
    };
    [short, 2.0 * short]
}

/// The subgrid's thinning: [`THIN`], four times that in `--quick` (a 4 × 3 subgrid of the
/// 64 × 48 plane).
pub fn thinning(quick: bool) -> usize {
    if quick { 4 * THIN } else { THIN }
}

/// Stage 2: the reference runs and their agreement, on the subgrid from `offset`.
fn reference_run(
    plane: Plane,
    quick: bool,
    thin: usize,
    offset: usize,
    checks: Checks,
) -> Result<Reference, EngineError> {
    let [short, _] = reference_durations(quick);
    let engine = Engine::cpu(Precision::F64);
    let mut runs = Vec::new();
    let mut wall = 0.0;
    for d in [short, 2.0 * short] {
        let sets = reference_sets(d, REFERENCE_RTOL, REFERENCE_ATOL);
        let (run, s) = timed(&subgrid_at(plane, &sets, thin, offset)?, &engine)?;
        wall += s;
        runs.push(run);
    }
    let tightened = match checks {
        Checks::Length => None,
        Checks::LengthAndSteps => {
            let sets = reference_sets(short, REFERENCE_RTOL / 10.0, REFERENCE_ATOL / 10.0);
            let (fine, s) = timed(&subgrid_at(plane, &sets, thin, offset)?, &engine)?;
            wall += s;
            let moved = |(x, y): (&InstanceResult, &InstanceResult)| {
                x.regime != y.regime || x.period != y.period
            };
            Some(
                runs[0]
                    .results
                    .iter()
                    .zip(&fine.results)
                    .filter(|p| moved(*p))
                    .count(),
            )
        }
    };
    let (a, b) = (&runs[0].results, &runs[1].results);
    let is_settled: Vec<bool> = a
        .iter()
        .zip(b)
        .map(|(x, y)| decided(y.regime.code()) && x.regime == y.regime)
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
        tightened,
        rtol: REFERENCE_RTOL,
        settled: is_settled.iter().filter(|s| **s).count(),
        cells: b.len(),
        regime: b.iter().map(|r| r.regime.code()).collect(),
        period: b.iter().map(|r| r.period).collect(),
        is_settled,
        stop_s: stop_times(&runs[1]),
        counts,
    })
}

/// Whether a verdict code is decided (periodic, regular or chaotic).
pub(crate) fn decided(code: i8) -> bool {
    [Regime::Periodic, Regime::Regular, Regime::Chaotic]
        .iter()
        .any(|g| g.code() == code)
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
fn verdict(r: &InstanceResult, decider: Decider) -> Regime {
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
    (plane, thin): (Plane, usize),
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
    let (run, wall_s) = timed(&subgrid(plane, &sets, thin)?, engine)?;
    let got: Vec<Regime> = run.results.iter().map(|r| verdict(r, c.decider)).collect();
    let settled: Vec<usize> = (0..got.len())
        .filter(|&k| reference.is_settled[k])
        .collect();
    let periodic: Vec<usize> = (0..got.len())
        .filter(|&k| got[k] == Regime::Periodic)
        .collect();
    let ref_periodic: Vec<usize> = settled
        .iter()
        .copied()
        .filter(|&k| reference.regime[k] == Regime::Periodic.code())
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
            .filter(|&&k| same_period(k, reference, &run.results[k]))
            .count(),
        ref_periodic: ref_periodic.len(),
        ref_period_found: ref_periodic
            .iter()
            .filter(|&&k| got[k] == Regime::Periodic && same_period(k, reference, &run.results[k]))
            .count(),
        undecided: got.iter().filter(|r| **r == Regime::Undecided).count(),
        cells: got.len(),
    })
}

/// Whether the reference calls cell `k` periodic with the period of `r`.
fn same_period(k: usize, reference: &Reference, r: &InstanceResult) -> bool {
    reference.regime[k] == Regime::Periodic.code() && reference.period[k] == r.period
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
fn cost(plane: Plane, engine: &Engine) -> Result<(Cost, MapRun), EngineError> {
    let baseline = subgrid(
        plane,
        &[
            "map.metrics=[\"K\", \"R\", \"period\", \"hops\", \"impacts_per_s\", \"alpha_range\"]"
                .into(),
        ],
        1,
    )?;
    let shipped = subgrid(plane, &[], 1)?;
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
    let plane = opts.plane;
    let thin = thinning(opts.quick);
    // The map the subgrids are scored on: the whole plane, or in `--quick` every (thin/2)th
    // value of each axis, which holds both subgrids (A from the first value, B from the
    // (thin/2 + 1)th) at a 64th of the cells. In its coordinates a subgrid takes every
    // (thin/base)th value from the (offset/base)th.
    let base = if opts.quick { thin / 2 } else { 1 };
    let (reference, kept_b) = match &opts.kept {
        Some(k) => (k.a.clone(), Some(k.b.clone())),
        None => (
            reference_run(plane, opts.quick, thin, 0, Checks::LengthAndSteps)?,
            None,
        ),
    };
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
            let s = score(c, gpu.unwrap_or(&cpu), &reference, (plane, thin))?;
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
        (
            None,
            run_map(&subgrid(plane, &[], base)?, &cpu64, &no_progress)?,
        )
    } else {
        let (c, whole) = cost(plane, &cpu64)?;
        (Some(c), whole)
    };
    let second = match kept_b {
        Some(b) => b,
        None => reference_run(plane, opts.quick, thin, thin / 2, Checks::Length)?,
    };
    progress(&format!(
        "reference B (from value {}): {} of {} cells change on doubling, {} settled ({:.0} s)",
        thin / 2 + 1,
        second.changed,
        second.cells,
        second.settled,
        second.wall_s
    ));
    let shape = subgrid(plane, &[], base)?.shape();
    let score = |name, offset: usize, r: &Reference| {
        score_subgrid(
            name,
            &whole,
            &shape,
            (thin / base, offset / base),
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
            offset: thin / 2 / base,
            reference: &second,
        },
    ];
    let spec_with = |sets: &[String]| subgrid(plane, sets, base);
    let settling = settling(
        &whole,
        &spec_with,
        (&grids, thin / base),
        opts.quick,
        progress,
    )?;
    let shape = {
        let spec = subgrid(plane, &[], thin)?;
        [spec.axes[0].values.len(), spec.axes[1].values.len()]
    };
    Ok(VerdictReport {
        plane,
        thin,
        shape,
        reference,
        second,
        scores,
        cost,
        reliability,
        settling,
        total_s: t0.elapsed().as_secs_f64(),
        reference_kept_from: opts.kept.as_ref().map(|k| k.from.clone()),
    })
}

//! Reproducing the paper in one call: every case of Łygas et al. (2019) simulated, analysed the
//! paper's way, set next to the published numbers, drawn as the paper's figures, and judged in
//! a generated `REPORT.md`.
//!
//! Stages of [`reproduce`], in order:
//! 1. [`paper_cases`]: the scenes of `configs/paper/` (embedded), validated before any work, with
//!    the `--quick` overrides when asked;
//! 2. [`simulate`]: every run — the ten cases and a twin of each Table 2 case started
//!    [`TWIN_PERTURBATION_DEG`] lower — in parallel with rayon, longest first, each distinct
//!    scene once;
//! 3. [`analyse_stationary`] and [`analyse_sweep`]: K three ways, R in two conventions, spectra,
//!    hops, twin divergence, wavelet windows;
//! 4. [`CaseRow`]: `table2.csv`, `table2.md`, `experiments.csv`, `summary.json`;
//! 5. the figures (`fig3a…fig12c`), one PNG per panel group;
//! 6. [`case_basins`]: each Table 2 case from several starts through the attractor stage;
//! 7. [`report_markdown`]: `REPORT.md`, written from the numbers.

mod basins;
mod cases;
mod error;
mod figures;
mod indicators;
mod report;
mod run;
mod table;

pub use basins::{BASIN_STARTS, BasinAttractor, CaseBasins, case_basins};
pub use cases::{
    CaseKind, PaperCase, QUICK_DURATION_S, QUICK_SEGMENTS, QUICK_TRANSIENT_S, paper_cases,
};
pub use error::ReproduceError;
pub use figures::FIG10_WINDOW_S;
pub use indicators::{
    K_CHAOTIC_THRESHOLD, R_PAPER_SYNC_THRESHOLD, Regime, StationaryAnalysis, SweepAnalysis,
    SweepWindow, SyncClass, TWIN_PERTURBATION_DEG, TwinDivergence, TwinVerdict, analyse_stationary,
    analyse_sweep, line_prominence, regime, sync_class,
};
pub use report::{CaseResult, ReportInput, report_markdown};
pub use run::{RunStats, Simulation, simulate};
pub use table::{CaseRow, table2_document, table2_markdown};

use pendulum_atlas_core::config::Scene;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How to reproduce.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReproduceOptions {
    /// A 3-segment chain and 24 s runs: the same pipeline in seconds, for CI and a first look.
    pub quick: bool,
}

/// What a reproduction produced.
#[derive(Debug, Clone)]
pub struct Reproduction {
    /// Every file written, in the order written.
    pub files: Vec<PathBuf>,
    /// The six rows of Table 2.
    pub table2: Vec<CaseRow>,
    /// The three simulated experiments.
    pub experiments: Vec<CaseRow>,
    /// The sweep's windows.
    pub sweep_windows: Vec<SweepWindow>,
    /// The Table 2 cases from several starts.
    pub basins: Vec<CaseBasins>,
    /// Wall time of the whole reproduction (s).
    pub wall_s: f64,
}

/// One simulation to run: a case, or its twin.
struct Job {
    case: usize,
    twin: bool,
    scene: Scene,
    /// Index of an earlier job with the same scene, whose result this job reuses.
    same_as: Option<usize>,
}

/// The indicators of one case.
enum Analysed {
    Stationary(Box<StationaryAnalysis>),
    Sweep(Box<SweepAnalysis>),
}

/// `summary.json`: the settings and every number of the run.
#[derive(Serialize)]
struct Summary<'a> {
    quick: bool,
    settings: &'a str,
    cases: &'a [PaperCase],
    runs: Vec<(&'a str, &'a RunStats)>,
    table2: &'a [CaseRow],
    experiments: &'a [CaseRow],
    sweep_windows: &'a [SweepWindow],
    earlier_reading: &'a [CaseRow],
    basins: &'a [CaseBasins],
    wall_s: f64,
}

/// Run every case of the paper and write the tables, figures and report into `out` (created if
/// needed). `progress` receives one line per finished simulation.
pub fn reproduce(
    out: &Path,
    opts: &ReproduceOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Reproduction, ReproduceError> {
    let started = Instant::now();
    let cases = paper_cases();
    let jobs = plan_jobs(&cases, opts, &[])?;
    std::fs::create_dir_all(out).map_err(|e| ReproduceError::io(out, e))?;
    let unique = simulate_jobs(&cases, &jobs, progress)?;
    let integration_s: f64 = unique.iter().flatten().map(|s| s.stats.wall_s).sum();
    let simulations = unique.iter().flatten().count();
    let (main, twins) = runs_per_case(&cases, &jobs, &unique);
    let analysed = analyse_cases(&cases, &main, &twins)?;
    let figures = draw_figures(out, &cases, &main, &analysed)?;
    let sorted = Sorted::new(&cases, &main, &analysed);
    let settings = settings_text(opts, &main);
    let table2_rows: Vec<CaseRow> = sorted.table2.iter().map(|t| t.2.clone()).collect();
    let exp_rows: Vec<CaseRow> = sorted.experiments.iter().map(|t| t.2.clone()).collect();
    let earlier = earlier_reading_rows(&cases, opts, progress)?;
    let tagged = |line: &str| progress(&format!("basins: {line}"));
    let basins = case_basins(&cases, opts.quick, &tagged)?;
    let mut files = write_tables(out, &table2_rows, &exp_rows, &settings)?;
    let earlier_csv = out.join("earlier_reading.csv");
    table::write_csv(&earlier_csv, &earlier)?;
    files.push(earlier_csv);
    let sweep_windows = sorted
        .sweep
        .map(|s| s.1.windows.clone())
        .unwrap_or_default();
    let names = file_names(&figures);
    let report_input = ReportInput {
        quick: opts.quick,
        settings: &settings,
        wall_s: started.elapsed().as_secs_f64(),
        integration_s,
        threads: rayon::current_num_threads(),
        first_clamped_hz: first_clamped_hz(&cases[0], opts)?,
        simulations,
        table2: case_results(&sorted.table2),
        experiments: case_results(&sorted.experiments),
        sweep: sorted.sweep,
        figures: &names,
        earlier_reading: &earlier,
        basins: &basins,
    };
    files.push(write_text(
        out,
        "REPORT.md",
        &report_markdown(&report_input),
    )?);
    let wall_s = started.elapsed().as_secs_f64();
    let summary = Summary {
        quick: opts.quick,
        settings: &settings,
        cases: &cases,
        runs: cases
            .iter()
            .map(|c| c.id)
            .zip(main.iter().map(|s| &s.stats))
            .collect(),
        table2: &table2_rows,
        experiments: &exp_rows,
        sweep_windows: &sweep_windows,
        earlier_reading: &earlier,
        basins: &basins,
        wall_s,
    };
    files.push(write_summary(out, &summary)?);
    files.extend(figures);
    Ok(Reproduction {
        files,
        table2: table2_rows,
        experiments: exp_rows,
        sweep_windows,
        basins,
        wall_s,
    })
}

/// The overrides of the earlier reading of Table 1's damping: ζ1 = 0.35 % of the first clamped
/// mode and Kelvin–Voigt contact damping (`docs/model.md`, "Damping").
pub(crate) const EARLIER_READING: [&str; 2] = [
    "beam.damping_ratio=0.0035",
    "limiter.damping_law=\"kelvin_voigt\"",
];

/// The Table 2 cases and the experiments again with the [`EARLIER_READING`], for the report's
/// side-by-side table: their rows in the cases' order (no figures, no sweep).
fn earlier_reading_rows(
    cases: &[PaperCase],
    opts: &ReproduceOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<CaseRow>, ReproduceError> {
    let stationary: Vec<PaperCase> = cases
        .iter()
        .filter(|c| c.kind != CaseKind::Sweep)
        .cloned()
        .collect();
    let extra: Vec<String> = EARLIER_READING.iter().map(|s| s.to_string()).collect();
    let jobs = plan_jobs(&stationary, opts, &extra)?;
    let tagged = |line: &str| progress(&format!("earlier reading: {line}"));
    let unique = simulate_jobs(&stationary, &jobs, &tagged)?;
    let (main, twins) = runs_per_case(&stationary, &jobs, &unique);
    let analysed = analyse_cases(&stationary, &main, &twins)?;
    Ok(stationary
        .iter()
        .zip(&main)
        .zip(&analysed)
        .filter_map(|((c, sim), a)| match a {
            Analysed::Stationary(a) => {
                Some(CaseRow::new(c, sim.scene.beam.segments, a, &sim.stats))
            }
            Analysed::Sweep(_) => None,
        })
        .collect())
}

/// Integrate every job in parallel, longest first (the jobs' order), reporting each finished
/// one. A scene that equals an earlier one (the 8 Hz/9 mm and 10 Hz/12 mm experiments are
/// Table 2 cases) is integrated once: its slot stays `None` and [`runs_per_case`] copies the
/// earlier result, which is exact since the engine is deterministic.
fn simulate_jobs(
    cases: &[PaperCase],
    jobs: &[Job],
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<Option<Simulation>>, ReproduceError> {
    let results: Vec<Option<Result<Simulation, ReproduceError>>> = jobs
        .par_iter()
        .with_max_len(1)
        .map(|j| {
            if j.same_as.is_some() {
                return None;
            }
            let id = cases[j.case].id;
            Some(simulate(id, &j.scene).inspect(|sim| {
                progress(&format!(
                    "{id}{}: {} steps in {:.1} s",
                    if j.twin { " (twin)" } else { "" },
                    sim.stats.steps,
                    sim.stats.wall_s
                ))
            }))
        })
        .collect();
    let mut unique: Vec<Option<Simulation>> = Vec::with_capacity(jobs.len());
    for r in results {
        unique.push(r.transpose()?);
    }
    Ok(unique)
}

/// Each case's run (in the cases' order) and its twin's, if it has one, from the jobs'
/// results, copying a shared scene's result to every job that reuses it.
fn runs_per_case(
    cases: &[PaperCase],
    jobs: &[Job],
    unique: &[Option<Simulation>],
) -> (Vec<Simulation>, Vec<Option<Simulation>>) {
    let mut main: Vec<Option<Simulation>> = vec![None; cases.len()];
    let mut twins: Vec<Option<Simulation>> = vec![None; cases.len()];
    for (i, j) in jobs.iter().enumerate() {
        let sim = unique[j.same_as.unwrap_or(i)].clone();
        let slot = if j.twin { &mut twins } else { &mut main };
        slot[j.case] = sim;
    }
    (main.into_iter().flatten().collect(), twins)
}

/// The indicators of every case, in parallel: stationary ones (with the twin) or the sweep's.
fn analyse_cases(
    cases: &[PaperCase],
    main: &[Simulation],
    twins: &[Option<Simulation>],
) -> Result<Vec<Analysed>, ReproduceError> {
    cases
        .par_iter()
        .zip(main)
        .enumerate()
        .map(|(i, (c, sim))| match c.kind {
            CaseKind::Sweep => analyse_sweep(c.id, sim).map(|a| Analysed::Sweep(Box::new(a))),
            CaseKind::Table2 | CaseKind::Experiment => {
                analyse_stationary(c.id, sim, twins[i].as_ref())
                    .map(|a| Analysed::Stationary(Box::new(a)))
            }
        })
        .collect()
}

/// Every case's figures, drawn in parallel; the paths in the cases' order.
fn draw_figures(
    out: &Path,
    cases: &[PaperCase],
    main: &[Simulation],
    analysed: &[Analysed],
) -> Result<Vec<PathBuf>, ReproduceError> {
    let figures: Vec<Vec<PathBuf>> = cases
        .par_iter()
        .zip(main)
        .zip(analysed)
        .map(|((c, sim), a)| draw_case(out, c, sim, a))
        .collect::<Result<_, _>>()?;
    Ok(figures.into_iter().flatten().collect())
}

/// A stationary case with its indicators and table row.
type StationaryCase<'a> = (&'a PaperCase, &'a StationaryAnalysis, CaseRow);

/// The analysed cases sorted by where the report puts them.
struct Sorted<'a> {
    /// The six Table 2 cases.
    table2: Vec<StationaryCase<'a>>,
    /// The simulated experiments.
    experiments: Vec<StationaryCase<'a>>,
    /// The sweep, its analysis and its clearance (deg).
    sweep: Option<(&'a PaperCase, &'a SweepAnalysis, f64)>,
}

impl<'a> Sorted<'a> {
    /// Sort the cases, making the table row of each stationary one.
    fn new(cases: &'a [PaperCase], main: &'a [Simulation], analysed: &'a [Analysed]) -> Self {
        let mut sorted = Sorted {
            table2: Vec::new(),
            experiments: Vec::new(),
            sweep: None,
        };
        for ((c, sim), a) in cases.iter().zip(main).zip(analysed) {
            match a {
                Analysed::Stationary(a) => {
                    let row = CaseRow::new(c, sim.scene.beam.segments, a, &sim.stats);
                    match c.kind {
                        CaseKind::Table2 => sorted.table2.push((c, a.as_ref(), row)),
                        _ => sorted.experiments.push((c, a.as_ref(), row)),
                    }
                }
                Analysed::Sweep(a) => {
                    sorted.sweep = Some((c, a.as_ref(), sim.scene.limiter.clearance_deg));
                }
            }
        }
        sorted
    }
}

/// The report's view of stationary cases.
fn case_results<'a>(cases: &'a [StationaryCase<'a>]) -> Vec<CaseResult<'a>> {
    cases
        .iter()
        .map(|(c, a, r)| CaseResult {
            case: c,
            analysis: a,
            row: r,
        })
        .collect()
}

/// The file names of `paths`, for the report's list of figures.
fn file_names(paths: &[PathBuf]) -> Vec<String> {
    paths
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect()
}

/// Write `text` to `out/name`; returns the path.
fn write_text(out: &Path, name: &str, text: &str) -> Result<PathBuf, ReproduceError> {
    let p = out.join(name);
    Ok(pendulum_atlas_map::output::files::write_bytes(
        &p,
        text.as_bytes(),
    )?)
}

/// `table2.csv`, `table2.md` and `experiments.csv`; returns their paths in that order.
fn write_tables(
    out: &Path,
    table2_rows: &[CaseRow],
    exp_rows: &[CaseRow],
    settings: &str,
) -> Result<Vec<PathBuf>, ReproduceError> {
    let table2_csv = out.join("table2.csv");
    table::write_csv(&table2_csv, table2_rows)?;
    let table2_md = write_text(out, "table2.md", &table2_document(table2_rows, settings))?;
    let experiments_csv = out.join("experiments.csv");
    table::write_csv(&experiments_csv, exp_rows)?;
    Ok(vec![table2_csv, table2_md, experiments_csv])
}

/// `summary.json`; returns its path.
fn write_summary(out: &Path, summary: &Summary) -> Result<PathBuf, ReproduceError> {
    let json = serde_json::to_string_pretty(summary)
        .map_err(|e| ReproduceError::io(&out.join("summary.json"), std::io::Error::other(e)))?;
    write_text(out, "summary.json", &json)
}

/// Validate every scene (and its twin) before any integration, longest runs first.
fn plan_jobs(
    cases: &[PaperCase],
    opts: &ReproduceOptions,
    extra: &[String],
) -> Result<Vec<Job>, ReproduceError> {
    let mut jobs = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        let scene = c.scene(opts.quick, extra)?;
        if c.kind == CaseKind::Table2 {
            let twin_angle = scene.initial.angle_deg - TWIN_PERTURBATION_DEG;
            let mut sets = extra.to_vec();
            sets.push(format!("initial.angle_deg={twin_angle:?}"));
            let twin = c.scene(opts.quick, &sets)?;
            jobs.push(Job {
                case: i,
                twin: true,
                scene: twin,
                same_as: None,
            });
        }
        jobs.push(Job {
            case: i,
            twin: false,
            scene,
            same_as: None,
        });
    }
    let cost = |j: &Job| j.scene.integration.duration_s * j.scene.beam.segments as f64;
    jobs.sort_by(|a, b| cost(b).total_cmp(&cost(a)));
    for i in 0..jobs.len() {
        jobs[i].same_as =
            (0..i).find(|&k| jobs[k].same_as.is_none() && jobs[k].scene == jobs[i].scene);
    }
    Ok(jobs)
}

/// The figures of one case.
fn draw_case(
    out: &Path,
    c: &PaperCase,
    sim: &Simulation,
    a: &Analysed,
) -> Result<Vec<PathBuf>, ReproduceError> {
    let mut v = Vec::new();
    match (c.kind, a) {
        (CaseKind::Table2, Analysed::Stationary(a)) => {
            v.push(figures::time_series_fig3_5(out, c, sim, a)?);
            if let Some(p) = c.zero_one_panel {
                v.push(figures::zero_one_fig6(out, c, p, a)?);
                v.push(figures::phase_fig7(out, c, p, a)?);
            }
        }
        (CaseKind::Experiment, Analysed::Stationary(a)) => {
            v.push(figures::experiment_fig10(out, c, sim)?);
            v.push(figures::experiment_fig11(out, c, a)?);
            v.push(figures::experiment_fig12(out, c, sim, a)?);
        }
        (CaseKind::Sweep, Analysed::Sweep(s)) => {
            v.push(figures::sweep_fig9a(out, c, sim)?);
            v.push(figures::sweep_fig9b(out, c, s, true)?);
            v.push(figures::sweep_fig9b(out, c, s, false)?);
        }
        _ => {}
    }
    Ok(v)
}

/// First natural frequency of the clamped beam (no gravity, no bumpers) at the run's N (Hz).
fn first_clamped_hz(case: &PaperCase, opts: &ReproduceOptions) -> Result<f64, ReproduceError> {
    let scene = case.scene(opts.quick, &[])?;
    let omega = scene
        .model_params()
        .and_then(|p| pendulum_atlas_core::model::linear::clamped_first_omega(&p))
        .map_err(|e| ReproduceError::Scene {
            case: case.id.to_string(),
            source: e.into(),
        })?;
    Ok(omega / std::f64::consts::TAU)
}

/// One paragraph on the fidelity of the run.
fn settings_text(opts: &ReproduceOptions, sims: &[Simulation]) -> String {
    let seg: Vec<usize> = sims.iter().map(|s| s.scene.beam.segments).collect();
    let (dt_lo, dt_hi) = sims.iter().fold((f64::INFINITY, 0.0f64), |a, s| {
        (a.0.min(s.stats.dt_s), a.1.max(s.stats.dt_s))
    });
    let stationary = sims
        .iter()
        .find(|s| s.scene.integration.transient_s > 0.0)
        .map(|s| &s.scene.integration);
    let step = if (dt_hi - dt_lo) <= 1e-3 * dt_hi {
        format!("{:.3} µs", dt_lo * 1e6)
    } else {
        format!("{:.3}–{:.3} µs", dt_lo * 1e6, dt_hi * 1e6)
    };
    let first = sims.first().map(|s| &s.scene);
    let method = first
        .and_then(|s| pendulum_atlas_core::engine::StepPlan::for_scene(s).ok())
        .map_or("–", |p| p.method.name());
    let damping = first.map_or("–".into(), |s| {
        let Ok(d) = s.damping_report() else {
            return "joint dampers: not computable for this scene".to_string();
        };
        format!(
            "joint dampers β = {:.3e} s (b = {:.3} N m s/rad per joint, ζ1 = {:.4}), contact damping {}",
            d.damping_time_s,
            d.joint_damping_nms,
            d.first_mode_damping_ratio,
            match s.limiter.damping_law {
                pendulum_atlas_core::config::ContactDamping::Loading => "on loading only",
                pendulum_atlas_core::config::ContactDamping::KelvinVoigt => "Kelvin–Voigt",
            }
        )
    });
    format!(
        "{} run: N = {} segments; {} per stationary case with a {} transient; \
         {} in f64 at the automatic step ({step}); {damping}; every other parameter from Table 1 \
         (configs/paper/*.toml).",
        if opts.quick { "Quick" } else { "Full" },
        seg.first().copied().unwrap_or(0),
        stationary.map_or("–".into(), |i| format!("{} s", i.duration_s)),
        stationary.map_or("–".into(), |i| format!("{} s", i.transient_s)),
        method.to_uppercase(),
    )
}

//! `pendulum-atlas simulate`: one run, written as trajectory.csv and run.json.

use super::SceneArgs;
use indicatif::{ProgressBar, ProgressStyle};
use pendulum_atlas_core::config::{MapSpec, Scene, StepControl, read_scene_file};
use pendulum_atlas_core::engine::{
    EnsemblePlan, Integrator, Outcome, Precision as EnginePrecision, RunLyapunov, SceneRun,
    StepPlan, run_scene,
};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::text::num;
use pendulum_atlas_map::map::cell::{map_cell_report, read_cell_scene};
use pendulum_atlas_map::output::budget::RunSize;
use pendulum_atlas_map::output::files::write_json;
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::output::run_analysis::write_run_analysis;
use pendulum_atlas_map::output::{RunFacts, RunReport, record_analysis, run_warnings};
use pendulum_atlas_map::output::{TrajectoryRecorder, write_trajectory_csv};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Which integrator `simulate` uses.
#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorChoice {
    /// The engine's stepper, as the maps take it: the scene's `integration.method` (RK4 or
    /// IMEX, or the cheaper of the two for "auto"), at adaptive steps within the plan's base
    /// step (`integration.step = "adaptive"`, the default) or at its fixed dt. `rk4` is
    /// accepted for it too.
    #[value(alias = "rk4")]
    Engine,
    /// Adaptive DOP853 with contact events, f64 (for validation; slower).
    Reference,
}

impl From<IntegratorChoice> for Integrator {
    fn from(i: IntegratorChoice) -> Integrator {
        match i {
            IntegratorChoice::Engine => Integrator::Engine,
            IntegratorChoice::Reference => Integrator::Reference,
        }
    }
}

/// Floating-point precision of the RK4 engine.
#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// Double precision (the CPU reference).
    F64,
    /// Single precision (what the GPU computes).
    F32,
}

/// Arguments of `simulate`.
#[derive(Debug, clap::Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Integrator.
    #[arg(long, value_enum, default_value = "engine")]
    integrator: IntegratorChoice,
    /// Precision of the fixed-step engine (the reference is f64 only).
    #[arg(long, value_enum)]
    precision: Option<Precision>,
    /// Output folder (created if needed).
    #[arg(long)]
    out: PathBuf,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    force: bool,
}

/// Run one simulation and write its files.
pub fn run(a: SimulateArgs) -> anyhow::Result<()> {
    super::catch_interrupts();
    if a.integrator == IntegratorChoice::Reference && a.precision == Some(Precision::F32) {
        anyhow::bail!(
            "--integrator reference runs in f64 only: drop --precision f32, or use --integrator engine for an f32 run"
        );
    }
    let (scene, cell) = load_cell_scene(&a.scene)?;
    if let Some(spec) = &cell {
        // The cell's map is planned before any step, so that a `[cell]` its run cannot serve
        // (too short for the 0–1 test's samples, say) is refused now, not after the run.
        EnsemblePlan::new(spec).map_err(|e| {
            anyhow::anyhow!("the scene's [cell] (its map's values of this cell) cannot run: {e}")
        })?;
    }
    let m = scene.modes()?;
    let plan = StepPlan::for_scene(&scene)?;
    let f32 = a.precision == Some(Precision::F32);
    pendulum_atlas_core::engine::adaptive::check_f32_tolerance(plan.control, f32)?;
    let piezo = scene.piezo_params();
    let size = run_size(&scene, &plan, &a.out)?;
    let inputs: Vec<&std::path::Path> = a.scene.scene.iter().map(|p| p.as_path()).collect();
    super::claim_out_reading(Product::Simulate, &a.out, a.force, &inputs)?;
    announce(&plan, a.integrator, &size);
    let (rec, run, wall) = integrate_with_progress(&a, &scene, &plan)?;
    super::stop_if_interrupted(&format!(
        "at step {} of {}",
        run.outcome.steps_done, plan.steps
    ))?;
    let csv_path = a.out.join("trajectory.csv");
    write_trajectory_csv(&csv_path, &rec.rows, piezo.is_some())?;
    let mut warnings = run_warnings(&plan, &run.outcome);
    // An analysis the record does not allow is a warning; files that cannot be written (a
    // full disk) fail the run.
    let analysis = match run.outcome.status {
        Status::Ok => match record_analysis(&scene, &plan, &rec.rows) {
            Ok(r) => {
                write_run_analysis(&scene, &plan, &rec.rows, &r, &a.out)?;
                Some(r)
            }
            Err(e) => {
                warnings.push(format!("analysis of the run skipped: {e}"));
                None
            }
        },
        _ => None,
    };
    let facts = RunFacts {
        scene: &scene,
        plan: &plan,
        integrator: a.integrator.into(),
        run: &run,
        modes: &m,
        rows: rec.rows.len(),
        wall_time_s: wall,
    };
    let mut report = RunReport::new(facts, &warnings, analysis.as_ref());
    if let Some(spec) = &cell {
        let values = map_cell_report(spec, &super::until_interrupted)?;
        say_map_cell(&values);
        report.map_cell = Some(values);
    }
    super::stop_if_interrupted("while the run's files were written")?;
    // The manifest last: its presence means the folder is complete.
    write_json(&a.out.join("run.json"), &report)?;
    if let RunLyapunov::Measured {
        per_s, se_per_s, ..
    } = &run.lyapunov
    {
        tell!(
            "largest Lyapunov exponent lambda1 = {per_s:.4} ± {se_per_s:.4} 1/s (twin trajectory)"
        );
    }
    let outcome = &run.outcome;
    finish(&a.out, &plan, outcome, wall, &warnings, analysis.is_some())
}

/// The steps a run took: fixed steps, or adaptive steps' base steps and the sub-steps taken
/// within them.
fn steps_taken(plan: &StepPlan, outcome: &Outcome) -> String {
    let (n, dt) = (outcome.steps_done, plan.dt_s);
    match &outcome.substeps {
        Some(st) => format!(
            "{n} base steps of {dt:.3e} s ({} sub-steps from {:.2e} to {:.2e} s, {} rejected)",
            st.accepted, st.smallest_s, st.largest_s, st.rejected
        ),
        None => format!("{n} steps of {dt:.3e} s"),
    }
}

/// Print the warnings found while running and what was written; a run that ended badly is a
/// failed run (exit 3) after its files are written.
fn finish(
    out: &std::path::Path,
    plan: &StepPlan,
    outcome: &Outcome,
    wall: f64,
    warnings: &[String],
    analysed: bool,
) -> anyhow::Result<()> {
    for w in &warnings[plan.warnings.len()..] {
        tell!("warning: {w}");
    }
    tell!(
        "{} in {wall:.2} s, status {}: wrote {} files to {} (trajectory.csv, run.json{})",
        steps_taken(plan, outcome),
        outcome.status,
        Product::Simulate.files_in(out)?.len(),
        out.display(),
        if analysed {
            ", the analysis' figures and arrays"
        } else {
            ""
        }
    );
    if outcome.status != Status::Ok {
        return Err(super::RunFailed(format!(
            "the run stopped with status `{}` at t = {:.6} s; what it integrated is in {}",
            outcome.status,
            outcome.failed_at_s.unwrap_or(f64::NAN),
            out.display()
        ))
        .into());
    }
    Ok(())
}

/// Integrate with a progress bar: the recorded rows, the run (outcome, λ1, precision) and the
/// wall time (s).
/// The scene with its overrides, and the map of its one cell where it is a map cell (a
/// `[cell]` section, as `explore` and `Scene.cell` write it; `map::cell`).
fn load_cell_scene(args: &SceneArgs) -> anyhow::Result<(Scene, Option<MapSpec>)> {
    let Some(path) = &args.scene else {
        return Ok((args.load()?, None));
    };
    let text = read_scene_file(path)?;
    let (scene, cell) = read_cell_scene(&text, &path.display().to_string(), &args.sets)?;
    for note in &scene.notes {
        tell!("warning: {note}");
    }
    Ok((scene, cell))
}

/// A map cell's values as its map computes them, on one line.
fn say_map_cell(report: &serde_json::Value) {
    let values: Vec<String> = report["values"]
        .as_object()
        .into_iter()
        .flatten()
        .filter(|(name, _)| {
            ["K", "R", "period", "hops", "lyapunov", "regime"].contains(&name.as_str())
        })
        .map(|(name, v)| match v {
            serde_json::Value::String(s) => format!("{name} {s}"),
            serde_json::Value::Number(x) => {
                format!("{name} {}", num(x.as_f64().unwrap_or(f64::NAN)))
            }
            _ => format!("{name} none"),
        })
        .collect();
    tell!(
        "as its map computes this cell (cpu f64): {}",
        values.join(", ")
    );
}

fn integrate_with_progress(
    a: &SimulateArgs,
    scene: &Scene,
    plan: &StepPlan,
) -> anyhow::Result<(TrajectoryRecorder, SceneRun, f64)> {
    let mut rec = TrajectoryRecorder {
        load_ohm: scene.piezo_params().map(|z| z.load_ohm),
        ..Default::default()
    };
    let bar = progress_bar(plan, scene.beam.segments, a.integrator);
    let b = bar.clone();
    rec.on_row = Some(Box::new(move |step| {
        if let Some(b) = &b {
            b.set_position(step);
        }
        super::go_on()
    }));
    let started = Instant::now();
    let precision = match a.precision.unwrap_or(Precision::F64) {
        Precision::F64 => EnginePrecision::F64,
        Precision::F32 => EnginePrecision::F32,
    };
    let run = run_scene(scene, plan, a.integrator.into(), precision, &mut rec)?;
    let wall = started.elapsed().as_secs_f64();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok((rec, run, wall))
}

/// The run's steps, rows, memory and CSV size, refused when it takes no step or does not fit
/// (see `output::budget`).
fn run_size(scene: &Scene, plan: &StepPlan, out: &std::path::Path) -> anyhow::Result<RunSize> {
    let size = RunSize::of_run(scene, plan)?;
    size.check(out)?;
    Ok(size)
}

/// Print the engine's method and step, the run's size, and the plan's warnings.
fn announce(plan: &StepPlan, integrator: IntegratorChoice, size: &RunSize) {
    let adaptive = integrator == IntegratorChoice::Engine
        && matches!(plan.control, StepControl::Adaptive { .. });
    if integrator == IntegratorChoice::Engine {
        tell!(
            "method: {} ({}), {} = {:.3e} s",
            plan.method.name(),
            plan.method_reason,
            if adaptive { "base step" } else { "dt" },
            plan.dt_s
        );
    }
    tell!(
        "run: {} {}steps, {} rows (about {} in memory, {} of trajectory.csv)",
        size.steps,
        if adaptive { "base " } else { "" },
        size.rows,
        pendulum_atlas_core::text::bytes(size.memory_bytes),
        pendulum_atlas_core::text::bytes(size.csv_bytes)
    );
    for w in &plan.warnings {
        tell!("warning: {w}");
    }
}

/// A progress bar for runs expected to take more than a second or two.
fn progress_bar(plan: &StepPlan, segments: usize, integ: IntegratorChoice) -> Option<ProgressBar> {
    let work = plan.steps as f64 * segments as f64;
    // The reference integrator's steps follow the stiffness (a 1e12 N/m bumper takes
    // seconds per millisecond simulated), so its bar, with its estimate, is always shown.
    if integ == IntegratorChoice::Engine && work < 2e7 {
        return None;
    }
    let bar = ProgressBar::new(plan.steps);
    bar.set_style(
        ProgressStyle::with_template("{spinner} simulating [{bar:40}] {percent}% eta {eta}")
            .expect("valid template"),
    );
    Some(bar)
}

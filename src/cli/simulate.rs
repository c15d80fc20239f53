//! `pendulum-atlas simulate`: one run, written as trajectory.csv and run.json.

use super::SceneArgs;
use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use pendulum_atlas::config::Scene;
use pendulum_atlas::integrate::{
    Instance, Outcome, ReferenceOptions, StepPlan, integrate, integrate_reference,
};
use pendulum_atlas::model::{ModelParams, Modes, modes};
use pendulum_atlas::output::{TrajectoryRecorder, write_trajectory_csv};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Which integrator `simulate` uses.
#[derive(Debug, Clone, Copy, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorChoice {
    /// Fixed-step classical RK4 at the plan's dt (the engine the maps use).
    Rk4,
    /// Adaptive DOP853 with contact events, f64 (for validation; slower).
    Reference,
}

/// Floating-point precision of the RK4 engine.
#[derive(Debug, Clone, Copy, clap::ValueEnum, Serialize)]
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
    #[arg(long, value_enum, default_value = "rk4")]
    integrator: IntegratorChoice,
    /// Precision of the RK4 engine (the reference is always f64).
    #[arg(long, value_enum, default_value = "f64")]
    precision: Precision,
    /// Output folder (created if needed).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Serialize)]
struct RunJson<'a> {
    scene: &'a Scene,
    integrator: IntegratorChoice,
    precision: &'a str,
    dt_s: f64,
    dt_source: &'a str,
    dt_stable_s: f64,
    steps: u64,
    steps_done: u64,
    rows: usize,
    wall_time_s: f64,
    status: &'a str,
    failed_at_s: Option<f64>,
    impacts: u64,
    modes: &'a Modes,
    warnings: &'a [String],
}

/// Run one simulation and write its files.
pub fn run(a: SimulateArgs) -> anyhow::Result<()> {
    let scene = a.scene.load()?;
    let m = modes(&scene);
    let plan = StepPlan::for_scene(&scene, &m);
    for w in &plan.warnings {
        eprintln!("warning: {w}");
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create output folder {}", a.out.display()))?;
    let params = ModelParams::from_scene(&scene);
    let mut rec = TrajectoryRecorder {
        load_ohm: params.piezo.as_ref().map(|z| z.load_ohm),
        ..Default::default()
    };
    let bar = progress_bar(&plan, scene.beam.segments, a.integrator);
    if let Some(b) = bar.clone() {
        rec.on_row = Some(Box::new(move |step| b.set_position(step)));
    }
    let started = Instant::now();
    let (outcome, precision): (Outcome, &str) = match (a.integrator, a.precision) {
        (IntegratorChoice::Reference, _) => {
            let inst = Instance::<f64>::from_scene(&scene, &params);
            let o = integrate_reference(&inst, &plan, &ReferenceOptions::default(), &mut rec)
                .map_err(anyhow::Error::msg)?;
            (o, "f64")
        }
        (IntegratorChoice::Rk4, Precision::F64) => {
            let inst = Instance::<f64>::from_scene(&scene, &params);
            (integrate(&inst, &plan, &mut rec), "f64")
        }
        (IntegratorChoice::Rk4, Precision::F32) => {
            let inst = Instance::<f32>::from_scene(&scene, &params);
            (integrate(&inst, &plan, &mut rec), "f32")
        }
    };
    let wall = started.elapsed().as_secs_f64();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let csv_path = a.out.join("trajectory.csv");
    write_trajectory_csv(&csv_path, &rec.rows, params.piezo.is_some())?;
    let mut warnings = plan.warnings.clone();
    if let Some(t) = outcome.failed_at_s {
        warnings.push(format!(
            "run stopped at t = {t:.6} s with status `{}`: rows after that time are not written",
            outcome.status.as_str()
        ));
    }
    let json = RunJson {
        scene: &scene,
        integrator: a.integrator,
        precision,
        dt_s: plan.dt_s,
        dt_source: plan.dt_source,
        dt_stable_s: plan.dt_stable_s,
        steps: plan.steps,
        steps_done: outcome.steps_done,
        rows: rec.rows.len(),
        wall_time_s: wall,
        status: outcome.status.as_str(),
        failed_at_s: outcome.failed_at_s,
        impacts: outcome.impacts,
        modes: &m,
        warnings: &warnings,
    };
    std::fs::write(a.out.join("run.json"), serde_json::to_string_pretty(&json)?)?;
    eprintln!(
        "{} steps of {:.3e} s in {wall:.2} s, status {}: wrote {} and run.json",
        outcome.steps_done,
        plan.dt_s,
        outcome.status.as_str(),
        csv_path.display()
    );
    Ok(())
}

/// A progress bar for runs expected to take more than a second or two.
fn progress_bar(plan: &StepPlan, segments: usize, integ: IntegratorChoice) -> Option<ProgressBar> {
    let work = plan.steps as f64 * segments as f64;
    let factor = match integ {
        IntegratorChoice::Rk4 => 1.0,
        IntegratorChoice::Reference => 20.0,
    };
    if work * factor < 2e7 {
        return None;
    }
    let bar = ProgressBar::new(plan.steps);
    bar.set_style(
        ProgressStyle::with_template("{spinner} simulating [{bar:40}] {percent}% eta {eta}")
            .expect("valid template"),
    );
    Some(bar)
}

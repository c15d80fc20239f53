//! `pendulum-atlas simulate`: one run, written as trajectory.csv and run.json.

use super::SceneArgs;
use indicatif::{ProgressBar, ProgressStyle};
use pendulum_atlas::analysis::{RecordAnalysis, analyze_record};
use pendulum_atlas::config::LyapunovSettings;
use pendulum_atlas::config::{DampingReport, Scene};
use pendulum_atlas::engine::method::MethodSteps;
use pendulum_atlas::engine::{
    DtSource, Instance, Outcome, ReferenceOptions, SingleTwin, StepPlan, integrate_reference,
    integrate_with_twin,
};
use pendulum_atlas::model::{Modes, Status};
use pendulum_atlas::output::Row;
use pendulum_atlas::output::budget::{self, RunSize};
use pendulum_atlas::output::files::write_json;
use pendulum_atlas::output::folder::Product;
use pendulum_atlas::output::{BASE_COLUMNS, PIEZO_COLUMNS};
use pendulum_atlas::output::{TrajectoryRecorder, write_trajectory_csv};
use pendulum_atlas::reduce::lyapunov::{SEPARATION_F32, SEPARATION_F64};
use pendulum_atlas::render::{self, Panel, Series};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Which integrator `simulate` uses.
#[derive(Debug, Clone, Copy, PartialEq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorChoice {
    /// The fixed-step engine the maps use: the scene's `integration.method` (RK4 or IMEX, or
    /// the cheaper of the two for "auto") at the plan's dt. `rk4` is accepted for it too.
    #[value(alias = "rk4")]
    Engine,
    /// Adaptive DOP853 with contact events, f64 (for validation; slower).
    Reference,
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
    /// Replace an earlier run in --out: delete the files this command writes there first
    /// (other files are left alone). Without it, a folder holding such files is refused.
    #[arg(long)]
    force: bool,
}

#[derive(Serialize)]
struct RunJson<'a> {
    scene: &'a Scene,
    integrator: IntegratorChoice,
    precision: &'a str,
    method: &'a str,
    method_reason: &'a str,
    method_steps: &'a MethodSteps,
    damping: DampingReport,
    dt_s: f64,
    dt_source: DtSource,
    dt_stable_s: f64,
    steps: u64,
    steps_done: u64,
    rows: usize,
    wall_time_s: f64,
    status: Status,
    failed_at_s: Option<f64>,
    impacts: u64,
    modes: &'a Modes,
    warnings: &'a [String],
    analysis: Option<&'a RecordAnalysis>,
    lyapunov: LyapunovJson,
}

/// `run.json`'s `lyapunov`: λ1 of the run from its twin, or why there is none.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
enum LyapunovJson {
    /// λ1 and how it was measured.
    Measured {
        /// λ1 (1/s).
        per_s: f64,
        /// Its standard error from the block means (1/s).
        se_per_s: f64,
        /// The twin's schedule and separation.
        twin: SingleTwin,
    },
    /// Why the run has no λ1.
    Skipped {
        /// The reason.
        skipped: String,
    },
}

/// Run one simulation and write its files.
pub fn run(a: SimulateArgs) -> anyhow::Result<()> {
    if a.integrator == IntegratorChoice::Reference && a.precision == Some(Precision::F32) {
        anyhow::bail!(
            "--integrator reference runs in f64 only: drop --precision f32, or use --integrator engine for an f32 run"
        );
    }
    let scene = a.scene.load()?;
    let m = scene.modes();
    let plan = StepPlan::for_scene(&scene);
    let piezo = scene.piezo_params();
    let size = run_size(&scene, &plan, piezo.is_some(), &a.out)?;
    super::claim_out(Product::Simulate, &a.out, a.force)?;
    announce(&plan, a.integrator, &size);
    let (rec, (outcome, lyapunov), precision, wall) =
        integrate_with_progress(&a, &scene, &plan, &m)?;
    let csv_path = a.out.join("trajectory.csv");
    write_trajectory_csv(&csv_path, &rec.rows, piezo.is_some())?;
    let mut warnings = plan.warnings.clone();
    if let Some(t) = outcome.failed_at_s {
        warnings.push(format!(
            "run stopped at t = {t:.6} s with status `{}`: rows after that time are not written",
            outcome.status
        ));
    }
    let analysis = if outcome.status != Status::Ok {
        None
    } else {
        analyse_run(&scene, &rec.rows, &a.out)
            .map_err(|e| warnings.push(format!("analysis of the run skipped: {e:#}")))
            .ok()
    };
    let json = RunJson {
        scene: &scene,
        integrator: a.integrator,
        precision,
        method: match a.integrator {
            IntegratorChoice::Engine => plan.method.name(),
            IntegratorChoice::Reference => "dop853",
        },
        method_reason: &plan.method_reason,
        method_steps: &plan.method_steps,
        damping: scene.damping_report(),
        dt_s: plan.dt_s,
        dt_source: plan.dt_source,
        dt_stable_s: plan.dt_stable_s,
        steps: plan.steps,
        steps_done: outcome.steps_done,
        rows: rec.rows.len(),
        wall_time_s: wall,
        status: outcome.status,
        failed_at_s: outcome.failed_at_s,
        impacts: outcome.impacts,
        modes: &m,
        warnings: &warnings,
        analysis: analysis.as_ref(),
        lyapunov,
    };
    // The manifest last: its presence means the folder is complete.
    write_json(&a.out.join("run.json"), &json)?;
    if let LyapunovJson::Measured {
        per_s, se_per_s, ..
    } = &json.lyapunov
    {
        eprintln!(
            "largest Lyapunov exponent lambda1 = {per_s:.4} ± {se_per_s:.4} 1/s (twin trajectory)"
        );
    }
    finish(&a.out, &plan, &outcome, wall, &warnings, analysis.is_some())
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
        eprintln!("warning: {w}");
    }
    eprintln!(
        "{} steps of {:.3e} s in {wall:.2} s, status {}: wrote {} files to {} (trajectory.csv, run.json{})",
        outcome.steps_done,
        plan.dt_s,
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

/// Integrate with a progress bar: the recorded rows, the outcome with λ1, the precision's
/// name and the wall time (s).
fn integrate_with_progress(
    a: &SimulateArgs,
    scene: &Scene,
    plan: &StepPlan,
    m: &Modes,
) -> anyhow::Result<(
    TrajectoryRecorder,
    (Outcome, LyapunovJson),
    &'static str,
    f64,
)> {
    let mut rec = TrajectoryRecorder {
        load_ohm: scene.piezo_params().map(|z| z.load_ohm),
        ..Default::default()
    };
    let bar = progress_bar(plan, scene.beam.segments, a.integrator);
    if let Some(b) = bar.clone() {
        rec.on_row = Some(Box::new(move |step| b.set_position(step)));
    }
    let started = Instant::now();
    let precision = a.precision.unwrap_or(Precision::F64);
    let (outcome, precision) = integrate_run(scene, plan, m, (a.integrator, precision), &mut rec)?;
    let wall = started.elapsed().as_secs_f64();
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    Ok((rec, outcome, precision, wall))
}

/// The run's steps, rows, memory and CSV size, refused when it takes no step or does not fit
/// (see `output::budget`).
fn run_size(
    scene: &Scene,
    plan: &StepPlan,
    piezo: bool,
    out: &std::path::Path,
) -> anyhow::Result<RunSize> {
    let duration = scene.integration.duration_s;
    let columns = BASE_COLUMNS.len() + if piezo { PIEZO_COLUMNS.len() } else { 0 };
    let size = RunSize::new(duration, plan.dt_s, plan.sample_every, columns)?;
    if size.steps == 0 {
        anyhow::bail!(
            "integration.duration_s = {duration} s is shorter than half a step (dt = {:e} s): the run would take no step; lengthen integration.duration_s or shorten integration.dt_s",
            plan.dt_s
        );
    }
    size.check(out)?;
    Ok(size)
}

/// Print the engine's method and step, the run's size, and the plan's warnings.
fn announce(plan: &StepPlan, integrator: IntegratorChoice, size: &RunSize) {
    if integrator == IntegratorChoice::Engine {
        eprintln!(
            "method: {} ({}), dt = {:.3e} s",
            plan.method.name(),
            plan.method_reason,
            plan.dt_s
        );
    }
    eprintln!(
        "run: {} steps, {} rows (about {} in memory, {} of trajectory.csv)",
        size.steps,
        size.rows,
        budget::bytes(size.memory_bytes),
        budget::bytes(size.csv_bytes)
    );
    for w in &plan.warnings {
        eprintln!("warning: {w}");
    }
}

/// Integrate the run with the chosen integrator and precision: the outcome with λ1 (from the
/// engine's twin), and the precision's name.
fn integrate_run(
    scene: &Scene,
    plan: &StepPlan,
    m: &Modes,
    (integrator, precision): (IntegratorChoice, Precision),
    rec: &mut TrajectoryRecorder,
) -> anyhow::Result<((Outcome, LyapunovJson), &'static str)> {
    let twin =
        |d0: f64| SingleTwin::for_run(scene, plan, d0, LyapunovSettings::default().align_periods);
    Ok(match (integrator, precision) {
        (IntegratorChoice::Reference, _) => {
            let inst = Instance::<f64>::from_scene(scene);
            let opts = ReferenceOptions::for_stiffness(m.spectral_radius_per_s);
            let skipped = LyapunovJson::Skipped {
                skipped: "the DOP853 reference takes adaptive steps; lambda1 comes from the fixed-step engine's twin trajectory (--integrator engine)".into(),
            };
            (
                (integrate_reference(&inst, plan, &opts, rec)?, skipped),
                "f64",
            )
        }
        (IntegratorChoice::Engine, Precision::F64) => (
            engine_run::<f64>(scene, plan, twin(SEPARATION_F64), rec),
            "f64",
        ),
        (IntegratorChoice::Engine, Precision::F32) => (
            engine_run::<f32>(scene, plan, twin(SEPARATION_F32), rec),
            "f32",
        ),
    })
}

/// A run of the fixed-step engine in `T`, with λ1's twin when the run is long enough.
fn engine_run<T: pendulum_atlas::model::Real>(
    scene: &Scene,
    plan: &StepPlan,
    twin: Result<SingleTwin, String>,
    rec: &mut TrajectoryRecorder,
) -> (Outcome, LyapunovJson) {
    let inst = Instance::<T>::from_scene(scene);
    let (outcome, lyapunov) = integrate_with_twin(&inst, plan, twin.clone().ok(), rec);
    let json = match (twin, lyapunov) {
        (Err(skipped), _) => LyapunovJson::Skipped { skipped },
        (Ok(twin), Some(l)) => LyapunovJson::Measured {
            per_s: l.per_s,
            se_per_s: l.se_per_s,
            twin,
        },
        (Ok(_), None) => LyapunovJson::Skipped {
            skipped: format!(
                "the twin trajectory broke off (status {}, or a separation that was zero or not finite)",
                outcome.status
            ),
        },
    };
    (outcome, json)
}

/// A progress bar for runs expected to take more than a second or two.
fn progress_bar(plan: &StepPlan, segments: usize, integ: IntegratorChoice) -> Option<ProgressBar> {
    let work = plan.steps as f64 * segments as f64;
    let factor = match integ {
        IntegratorChoice::Engine => 1.0,
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

/// The paper's analysis of one run: holder angle against cart position, after the transient.
fn analyse_run(
    scene: &Scene,
    rows: &[Row],
    out: &std::path::Path,
) -> anyhow::Result<RecordAnalysis> {
    let rate = scene.output.sample_rate_hz;
    let alpha: Vec<f64> = rows.iter().map(|r| r.alpha_rad).collect();
    let cart: Vec<f64> = rows.iter().map(|r| r.x0_m).collect();
    let opts = scene.record_options();
    let r = analyze_record(&alpha, Some(&cart), rate, 0.0, &opts)?;
    super::report::write_analysis(out, &r, &alpha, Some(&cart), rate, 0.0)?;
    time_series_figure(scene, rows, out)?;
    Ok(r)
}

/// The paper's Figs. 3–5 for one run: cart, holder angle and chord reduction with the spectra.
fn time_series_figure(scene: &Scene, rows: &[Row], out: &std::path::Path) -> anyhow::Result<()> {
    let t: Vec<f64> = rows.iter().map(|r| r.t_s).collect();
    let col = |f: fn(&Row) -> f64| -> Vec<f64> { rows.iter().map(f).collect() };
    let x0 = col(|r| r.x0_m * 1e3);
    let alpha = col(|r| r.alpha_rad);
    let chord = col(|r| r.chord_m * 1e3);
    let rate = scene.output.sample_rate_hz;
    let skip = ((scene.integration.transient_s * rate).ceil() as usize).min(rows.len());
    let spec_a = pendulum_atlas::analysis::amplitude_spectrum(&alpha[skip..], rate)?;
    let spec_c = pendulum_atlas::analysis::amplitude_spectrum(&chord[skip..], rate)?;
    // Show the band of the paper's spectra: up to six times the forcing frequency.
    let f_max = 6.0 * scene.excitation.reference_frequency_hz();
    let keep = spec_a
        .frequency_hz
        .iter()
        .take_while(|&&f| f <= f_max)
        .count();
    let line = |name, x, y| Panel {
        x_label: "time (s)",
        y_label: name,
        series: vec![Series { name, x, y }],
        log_y: false,
    };
    let path = out.join("time_series.png");
    pendulum_atlas::output::files::draw(&path, |p| {
        render::stacked_panels(
            p,
            &format!(
                "f = {} Hz, A = {} mm, N = {}",
                scene.excitation.reference_frequency_hz(),
                scene.excitation.amplitude_m * 1e3,
                scene.beam.segments
            ),
            &[
                line("cart x0 (mm)", &t, &x0),
                line("holder angle α (rad)", &t, &alpha),
                line("chord reduction (mm)", &t, &chord),
                Panel {
                    x_label: "frequency (Hz)",
                    y_label: "amplitude",
                    series: vec![
                        Series {
                            name: "α (rad)",
                            x: &spec_a.frequency_hz[..keep],
                            y: &spec_a.amplitude[..keep],
                        },
                        Series {
                            name: "chord (mm)",
                            x: &spec_c.frequency_hz[..keep],
                            y: &spec_c.amplitude[..keep],
                        },
                    ],
                    log_y: true,
                },
            ],
        )
    })?;
    Ok(())
}

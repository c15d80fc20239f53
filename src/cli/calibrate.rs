//! `pendulum-atlas calibrate`: which values of the unknowns reproduce the observations.

use super::engine::{EngineArgs, hint};
use pendulum_atlas_design::about::StudyAbout;
use pendulum_atlas_design::calibrate::{load_calibration, run_calibration, write_calibration};
use pendulum_atlas_map::output::folder::Product;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Calibration scene (TOML with a \[calibrate\] section: cases with their observations and
    /// the unknowns with their ranges; see configs/calibrate/).
    pub scene: PathBuf,
    /// Override a scene or calibrate key, e.g. `--set calibrate.initial_states=5`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Output folder.
    #[arg(long, default_value = "runs/calibrate")]
    pub out: PathBuf,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Run `calibrate`.
pub fn run(a: CalibrateArgs) -> anyhow::Result<()> {
    super::catch_interrupts();
    let spec = load_calibration(&a.scene, &a.sets)?;
    let base = pendulum_atlas_core::config::Scene::from_table(spec.base_table.clone())?;
    for note in &base.notes {
        tell!("warning: {note}");
    }
    let engine = a.engine.open(&base)?;
    super::claim_out_reading(Product::Calibrate, &a.out, a.force, &[&a.scene])?;
    let bar = super::progress_bar(
        a.quiet,
        "{spinner} calibrate [{bar:40}] {pos}/{len} {elapsed_precise}",
    );
    let progress = super::bar_progress(&bar);
    let started = Instant::now();
    let run = run_calibration(&spec, &engine, &progress).map_err(|e| match e {
        pendulum_atlas_design::calibrate::CalibrateError::Engine(e) => hint(e),
        other => other.into(),
    })?;
    bar.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();
    let about = StudyAbout::new(&a.scene, &a.sets, engine.info().clone(), wall);
    let files = write_calibration(&a.out, &spec, &run, &about)?;
    let best = run.best();
    let values: Vec<String> = spec
        .unknowns
        .iter()
        .zip(&best.values)
        .map(|(u, v)| format!("{} = {v}", u.key))
        .collect();
    say!(
        "calibrate: {} candidates, {} instances in {wall:.1} s on {}; best matches {} of {} observations at {}",
        run.candidates.len(),
        run.instances,
        engine.info().kind.name(),
        best.matched,
        run.observations,
        values.join(", ")
    );
    say!("wrote {} files to {}", files.len(), a.out.display());
    if !run.usable() {
        return Err(super::RunFailed(format!(
            "no run of any of the {} candidates ended ok (every one diverged, turned non-finite or escaped): nothing could be compared with the observations; see candidates.csv in {}",
            run.candidates.len(),
            a.out.display()
        ))
        .into());
    }
    Ok(())
}

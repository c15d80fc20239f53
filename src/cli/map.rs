//! `pendulum-atlas map`: a chaos/bifurcation map over 1–3 scene keys on the GPU or the CPU.

use super::engine::{EngineArgs, hint};
use pendulum_atlas::config::load_map;
use pendulum_atlas::engine::ProgressUnit;
use pendulum_atlas::map::run_map;
use pendulum_atlas::model::Status;
use pendulum_atlas::output::folder::Product;
use pendulum_atlas::output::map::write_map;
use std::path::PathBuf;

/// Arguments of `map`.
#[derive(Debug, clap::Args)]
pub struct MapArgs {
    /// Map scene (TOML with a [map] section; see configs/maps/). Omit it to run the embedded
    /// default map (configs/maps/default.toml).
    pub scene: Option<PathBuf>,
    /// Override a scene or map key, e.g. `--set beam.segments=5 --set map.samples_per_period=32`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<String>,
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Output folder.
    #[arg(long, default_value = "runs/map")]
    pub out: PathBuf,
    /// Replace an earlier run in --out: delete the files this command writes there first
    /// (other files are left alone). Without it, a folder holding such files is refused.
    #[arg(long)]
    pub force: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Run `map`.
pub fn run(a: MapArgs) -> anyhow::Result<()> {
    let spec = load_map(a.scene.as_deref(), &a.sets)?;
    let engine = a.engine.open()?;
    super::claim_out(Product::Map, &a.out, a.force)?;
    let bar = super::progress_bar(
        a.quiet,
        "{spinner} {msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
    );
    bar.set_message(format!("map of {} instances", spec.instances()));
    let progress = |done: u64, total: u64, unit: ProgressUnit| {
        bar.set_length(total);
        bar.set_position(done);
        bar.set_prefix(unit.name());
    };
    let run = run_map(&spec, &engine, &progress).map_err(hint)?;
    bar.finish_and_clear();
    let files = write_map(&a.out, &spec, &run)?;
    let ok = run
        .results
        .iter()
        .filter(|r| r.status == Status::Ok)
        .count();
    println!(
        "map: {} instances ({} ok) on {} [{}], N = {}, {:.2e} instance-steps in {:.1} s ({:.3e} instance-steps/s, {:.3e} segment-steps/s)",
        run.results.len(),
        ok,
        run.engine.kind.name(),
        run.engine.device,
        run.plan.segments,
        run.plan.total_steps as f64,
        run.timings.total_s,
        run.instance_steps_per_s(),
        run.segment_steps_per_s()
    );
    for w in &run.plan.warnings {
        eprintln!("warning: {w}");
    }
    println!(
        "method: {} ({}), dt {:.3e}..{:.3e} s",
        run.plan.method.name(),
        run.plan.method_reason,
        run.plan.dt_range_s.0,
        run.plan.dt_range_s.1
    );
    println!("wrote {} files to {}", files.len(), a.out.display());
    if ok == 0 {
        return Err(super::RunFailed(format!(
            "no instance of the map ended ok ({} failed; see status_counts in map.json)",
            run.results.len()
        ))
        .into());
    }
    Ok(())
}

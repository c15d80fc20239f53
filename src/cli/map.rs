//! `pendulum-atlas map`: a chaos/bifurcation map over 1–3 scene keys on the GPU or the CPU.

use indicatif::{ProgressBar, ProgressStyle};
use pendulum_atlas::config::load_map;
use pendulum_atlas::map::{Backend, Precision, run_map};
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
    /// Engine: `auto` (a hardware GPU, else the software adapter lavapipe, else the CPU),
    /// `gpu` (any wgpu adapter, lavapipe included) or `cpu`.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Float type of the CPU engine (the GPU integrates in f32).
    #[arg(long, value_enum)]
    pub precision: Option<Precision>,
    /// Output folder.
    #[arg(long, default_value = "runs/map")]
    pub out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Run `map`.
pub fn run(a: MapArgs) -> anyhow::Result<()> {
    let spec = load_map(a.scene.as_deref(), &a.sets)?;
    let precision = a.precision.unwrap_or(match a.backend {
        Backend::Cpu => Precision::F64,
        _ => Precision::F32,
    });
    let bar = if a.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(1)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} {msg} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_message(format!("map of {} instances", spec.instances()));
    let progress = |done: u64, total: u64, unit: &str| {
        bar.set_length(total);
        bar.set_position(done);
        bar.set_prefix(unit.to_string());
    };
    let run = run_map(&spec, a.backend, precision, &progress)?;
    bar.finish_and_clear();
    let files = write_map(&a.out, &spec, &run)?;
    let ok = run
        .results
        .iter()
        .filter(|r| r.status == pendulum_atlas::integrate::Status::Ok)
        .count();
    println!(
        "map: {} instances ({} ok) on {} [{}], N = {}, {:.2e} instance-steps in {:.1} s ({:.3e} instance-steps/s, {:.3e} segment-steps/s)",
        run.results.len(),
        ok,
        run.backend,
        run.device,
        run.plan.segments,
        run.plan.total_steps as f64,
        run.timings.total_s,
        run.instance_steps_per_s(),
        run.segment_steps_per_s()
    );
    for w in &run.plan.warnings {
        eprintln!("warning: {w}");
    }
    println!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

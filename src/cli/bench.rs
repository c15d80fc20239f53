//! `pendulum-atlas bench`: the work-precision study and scaling measurements.

use pendulum_atlas::bench::{BenchOptions, report::write_bench, run_bench};
use pendulum_atlas::map::Backend;
use std::path::PathBuf;

/// Arguments of `bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Engines to measure: `auto` (the CPU, plus the GPU when an adapter exists), `gpu`
    /// (GPU configurations only, besides the CPU references) or `cpu`.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Fewer configurations and shorter runs (a few minutes on 2 cores).
    #[arg(long)]
    pub quick: bool,
    /// Output folder.
    #[arg(long, default_value = "runs/bench")]
    pub out: PathBuf,
}

/// Run `bench`.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    let gpu_available = || {
        pendulum_atlas::integrate::gpu::GpuContext::new(
            pendulum_atlas::integrate::gpu::AdapterChoice::Any,
        )
        .is_ok()
    };
    let backends = match a.backend {
        Backend::Cpu => vec![Backend::Cpu],
        Backend::Gpu => vec![Backend::Cpu, Backend::Gpu],
        Backend::Auto if gpu_available() => vec![Backend::Cpu, Backend::Gpu],
        Backend::Auto => vec![Backend::Cpu],
    };
    let report = run_bench(
        &BenchOptions {
            quick: a.quick,
            backends,
        },
        &|line| eprintln!("{line}"),
    )?;
    let files = write_bench(&a.out, &report)?;
    println!(
        "bench: {} configurations in {:.0} s",
        report.configs.len(),
        report.total_s
    );
    println!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

//! `pendulum-atlas bench`: the work-precision study and scaling measurements.

use super::engine::BackendArg;
use pendulum_atlas::bench::cpu_report::write_cpu_throughput;
use pendulum_atlas::bench::cpu_throughput::{CpuThroughputOptions, run_cpu_throughput};
use pendulum_atlas::bench::stiff::{StiffOptions, run_stiff};
use pendulum_atlas::bench::stiff_map::{StiffMapOptions, run_stiff_map};
use pendulum_atlas::bench::stiff_map_report::write_stiff_map;
use pendulum_atlas::bench::stiff_report::write_stiff;
use pendulum_atlas::bench::{BenchOptions, report::write_bench, run_bench};
use pendulum_atlas::output::folder::Product;
use std::path::PathBuf;

/// Arguments of `bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Engines to measure: `auto` (the CPU, plus the GPU when an adapter exists), `gpu`
    /// (GPU configurations only, besides the CPU references) or `cpu`.
    #[arg(long, value_enum, default_value_t = BackendArg::Auto)]
    pub backend: BackendArg,
    /// Fewer configurations and shorter runs (a few minutes on 2 cores).
    #[arg(long)]
    pub quick: bool,
    /// The stiff-chain study instead: RK4 against the IMEX method on both damping readings
    /// (writes STIFF.md, stiff.json and stiff_work_precision.png).
    #[arg(long)]
    pub stiff: bool,
    /// The stiff-chain map study instead: a 48-cell (f, A) map at N = 17 with the library
    /// damping, RK4 at its limit against the IMEX method, its twin from a perturbed start and
    /// its half step (writes STIFF_MAP.md, stiff_map.csv and stiff_map.json; over an hour on
    /// 2 cores, `--quick` minutes).
    #[arg(long, conflicts_with = "stiff")]
    pub stiff_map: bool,
    /// The CPU throughput study instead: scalar and SIMD loop, f32 and f64, one thread and
    /// all, N = 3, 9, 17, against the machine's flop ceiling; the default map on each engine;
    /// the peers' results from --peers (writes CPU.md, cpu_throughput.json and the peers'
    /// cases peer_case_N*.json; minutes on 2 cores, `--quick` about one).
    #[arg(long, conflicts_with_all = ["stiff", "stiff_map"])]
    pub cpu_throughput: bool,
    /// A folder of peer results (`jax_*.json`, see benches/peers/README.md) to compare with
    /// (only with --cpu-throughput).
    #[arg(long, requires = "cpu_throughput")]
    pub peers: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "runs/bench")]
    pub out: PathBuf,
    /// Replace an earlier run in --out: delete the files this study writes there first
    /// (other files are left alone). Without it, a folder holding such files is refused.
    #[arg(long)]
    pub force: bool,
}

/// The study asked for, as the files it writes.
fn study(a: &BenchArgs) -> Product {
    if a.cpu_throughput {
        Product::BenchCpu
    } else if a.stiff_map {
        Product::BenchStiffMap
    } else if a.stiff {
        Product::BenchStiff
    } else {
        Product::Bench
    }
}

/// Run `bench`.
pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    super::claim_out(study(&a), &a.out, a.force)?;
    // The GPU device is opened once here and reused by every configuration.
    let gpu = match a.backend {
        BackendArg::Cpu => None,
        BackendArg::Gpu => Some(super::engine::EngineArgs::gpu_engine()?),
        BackendArg::Auto => super::engine::EngineArgs::gpu_engine().ok(),
    };
    if a.cpu_throughput {
        return cpu_throughput(&a, gpu.as_ref());
    }
    if a.stiff_map {
        let report = run_stiff_map(
            &StiffMapOptions {
                quick: a.quick,
                gpu: gpu.as_ref(),
            },
            &|line| eprintln!("{line}"),
        )?;
        let files = write_stiff_map(&a.out, &report)?;
        println!(
            "bench --stiff-map: {} cells in {:.0} s",
            report.cells.len(),
            report.total_s
        );
        println!("wrote {} files to {}", files.len(), a.out.display());
        return Ok(());
    }
    if a.stiff {
        let report = run_stiff(
            &StiffOptions {
                quick: a.quick,
                gpu: gpu.as_ref(),
            },
            &|line| eprintln!("{line}"),
        )?;
        let files = write_stiff(&a.out, &report)?;
        println!(
            "bench --stiff: {} runs in {:.0} s",
            report.horizon.len(),
            report.total_s
        );
        println!("wrote {} files to {}", files.len(), a.out.display());
        return Ok(());
    }
    let report = run_bench(
        &BenchOptions {
            quick: a.quick,
            gpu: gpu.as_ref(),
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

/// `bench --cpu-throughput`.
fn cpu_throughput(
    a: &BenchArgs,
    gpu: Option<&pendulum_atlas::engine::Engine>,
) -> anyhow::Result<()> {
    let report = run_cpu_throughput(
        &CpuThroughputOptions {
            quick: a.quick,
            peers: a.peers.clone(),
            gpu,
        },
        &|line| eprintln!("{line}"),
    )?;
    let files = write_cpu_throughput(&a.out, &report)?;
    println!(
        "bench --cpu-throughput: {} configurations in {:.0} s",
        report.rows.len(),
        report.total_s
    );
    println!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

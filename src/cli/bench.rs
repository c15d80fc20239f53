//! `pendulum-atlas bench`: the work-precision study and scaling measurements.

use super::engine::BackendArg;
use pendulum_atlas_core::engine::gpu::kernels::GpuKernel;
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_studies::bench::cpu_report::write_cpu_throughput;
use pendulum_atlas_studies::bench::cpu_throughput::{CpuThroughputOptions, run_cpu_throughput};
use pendulum_atlas_studies::bench::gpu_report::write_throughput;
use pendulum_atlas_studies::bench::gpu_throughput::{SEGMENTS, ThroughputOptions, run_throughput};
use pendulum_atlas_studies::bench::stiff::{StiffOptions, run_stiff};
use pendulum_atlas_studies::bench::stiff_map::{StiffMapOptions, run_stiff_map};
use pendulum_atlas_studies::bench::stiff_map_report::write_stiff_map;
use pendulum_atlas_studies::bench::stiff_report::write_stiff;
use pendulum_atlas_studies::bench::{BenchOptions, report::write_bench, run_bench};
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
    /// the peers' results from --peers (writes CPU.md and cpu_throughput.json; minutes on 2
    /// cores, `--quick` about one; the peers' cases come from `pendulum-atlas-lab peer-cases`).
    #[arg(long, conflicts_with_all = ["stiff", "stiff_map"])]
    pub cpu_throughput: bool,
    /// The GPU throughput study instead: the ensemble engine at N = 3, 9, 17 on the default
    /// and paper scenes, RK4 and IMEX, 1e3 to 1e6 instances (each rung within --row-budget-s),
    /// against the adapter's FP32 peak, with the CPU engine beside it; K only against all
    /// metrics; the peers' results from --peers (writes GPU.md and gpu_throughput.json).
    #[arg(long, conflicts_with_all = ["stiff", "stiff_map", "cpu_throughput"])]
    pub throughput: bool,
    /// What the early stop and adaptive refinement skip instead: the default map's scene on a
    /// 257 × 193 grid in full, with the early stop, and with both, on the CPU engine and (when
    /// open) the GPU engine: instance-steps, wall time, equal regimes (writes REFINE.md and
    /// refine.json; about 15 minutes on 2 cores, `--quick` half a minute).
    #[arg(long, conflicts_with_all = ["stiff", "stiff_map", "cpu_throughput", "throughput"])]
    pub refine: bool,
    /// The largest rung of the --throughput ladder (instances, 1000 to 1000000).
    #[arg(long, default_value_t = 1_000_000, requires = "throughput",
          value_parser = clap::value_parser!(u64).range(1000..=1_000_000))]
    pub max_instances: u64,
    /// The longest a --throughput row may take (seconds, 0.1 to 3600): a rung still running
    /// then is stopped and gives the rate of the steps it took; its larger rungs are skipped.
    #[arg(long, default_value_t = 20.0, requires = "throughput", value_parser = budget_s)]
    pub row_budget_s: f64,
    /// The GPU adapter's FP32 peak (TFLOP/s, above 0 and at most 10000) where the built-in
    /// table does not know the adapter (only with --throughput).
    #[arg(long, requires = "throughput", value_parser = peak_tflops)]
    pub peak_tflops: Option<f64>,
    /// Segment counts of the --throughput study (default 3,9,17; each 1 to 64).
    #[arg(long, value_delimiter = ',', requires = "throughput",
          value_parser = clap::value_parser!(u64).range(1..=64))]
    pub segments: Vec<u64>,
    /// The GPU's integration kernels the --throughput study measures, each with its ladders
    /// (default and only one: thread).
    #[arg(
        long,
        value_delimiter = ',',
        requires = "throughput",
        default_value = "thread"
    )]
    pub kernels: Vec<KernelArg>,
    /// Leave the CPU engine out of the --throughput study.
    #[arg(long, requires = "throughput")]
    pub no_cpu: bool,
    /// A folder of peer results to compare with: `jax_*.json` for --cpu-throughput,
    /// `jax_gpu_*.json` and `cuda_*.json` for --throughput (see benches/peers/README.md).
    #[arg(long)]
    pub peers: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "runs/bench")]
    pub out: PathBuf,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    pub force: bool,
}

/// The study asked for, as the files it writes.
fn study(a: &BenchArgs) -> Product {
    if a.refine {
        Product::BenchRefine
    } else if a.throughput {
        Product::BenchGpu
    } else if a.cpu_throughput {
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
    if a.peers.is_some() && !(a.cpu_throughput || a.throughput) {
        anyhow::bail!("--peers needs --cpu-throughput or --throughput");
    }
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
    if a.throughput {
        return throughput(&a, gpu.as_ref());
    }
    if a.refine {
        return refine(&a, gpu.as_ref());
    }
    if a.stiff_map {
        let report = run_stiff_map(
            &StiffMapOptions {
                quick: a.quick,
                gpu: gpu.as_ref(),
            },
            &|line| tell!("{line}"),
        )?;
        let files = write_stiff_map(&a.out, &report)?;
        say!(
            "bench --stiff-map: {} cells in {:.0} s",
            report.cells.len(),
            report.total_s
        );
        say!("wrote {} files to {}", files.len(), a.out.display());
        return Ok(());
    }
    if a.stiff {
        let report = run_stiff(
            &StiffOptions {
                quick: a.quick,
                gpu: gpu.as_ref(),
            },
            &|line| tell!("{line}"),
        )?;
        let files = write_stiff(&a.out, &report)?;
        say!(
            "bench --stiff: {} runs in {:.0} s",
            report.horizon.len(),
            report.total_s
        );
        say!("wrote {} files to {}", files.len(), a.out.display());
        return Ok(());
    }
    let report = run_bench(
        &BenchOptions {
            quick: a.quick,
            gpu: gpu.as_ref(),
        },
        &|line| tell!("{line}"),
    )?;
    let files = write_bench(&a.out, &report)?;
    say!(
        "bench: {} configurations in {:.0} s",
        report.configs.len(),
        report.total_s
    );
    say!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

/// `bench --cpu-throughput`.
fn cpu_throughput(
    a: &BenchArgs,
    gpu: Option<&pendulum_atlas_core::engine::Engine>,
) -> anyhow::Result<()> {
    let report = run_cpu_throughput(
        &CpuThroughputOptions {
            quick: a.quick,
            peers: a.peers.clone(),
            gpu,
        },
        &|line| tell!("{line}"),
    )?;
    let files = write_cpu_throughput(&a.out, &report)?;
    say!(
        "bench --cpu-throughput: {} configurations in {:.0} s",
        report.rows.len(),
        report.total_s
    );
    say!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

/// `bench --refine`.
fn refine(a: &BenchArgs, gpu: Option<&pendulum_atlas_core::engine::Engine>) -> anyhow::Result<()> {
    use pendulum_atlas_studies::bench::refine::{RefineOptions, run_refine, write_refine};
    let report = run_refine(
        &RefineOptions {
            quick: a.quick,
            gpu,
        },
        &|line| tell!("{line}"),
    )?;
    let files = write_refine(&a.out, &report)?;
    say!(
        "bench --refine: {} maps in {:.0} s",
        report.rows.len(),
        report.total_s
    );
    say!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

/// A row budget in seconds, 0.1 to 3600.
fn budget_s(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of seconds"))?;
    if (0.1..=3600.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} s is outside the accepted 0.1 to 3600 s"))
    }
}

/// A peak in TFLOP/s, above 0 and at most 10000.
fn peak_tflops(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of TFLOP/s"))?;
    if v > 0.0 && v <= 1e4 {
        Ok(v)
    } else {
        Err(format!("{v} TFLOP/s is outside the accepted (0, 10000]"))
    }
}

/// `bench --throughput`.
fn throughput(
    a: &BenchArgs,
    gpu: Option<&pendulum_atlas_core::engine::Engine>,
) -> anyhow::Result<()> {
    if gpu.is_none() && a.no_cpu {
        anyhow::bail!("bench --throughput --no-cpu needs a GPU adapter, and none was found");
    }
    let segments = if a.segments.is_empty() {
        SEGMENTS.to_vec()
    } else {
        a.segments.iter().map(|&n| n as usize).collect()
    };
    let report = run_throughput(
        &ThroughputOptions {
            gpu,
            cpu: !a.no_cpu,
            max_instances: a.max_instances as usize,
            row_budget_s: a.row_budget_s,
            peak_flop_per_s: a.peak_tflops.map(|t| t * 1e12),
            peers: a.peers.clone(),
            segments,
            kernels: a.kernels.iter().map(|&k| k.into()).collect(),
        },
        &|line| tell!("{line}"),
    )?;
    let files = write_throughput(&a.out, &report)?;
    let measured = report.rows.iter().filter(|r| r.skipped.is_none()).count();
    say!(
        "bench --throughput: {measured} of {} rows measured in {:.0} s",
        report.rows.len(),
        report.total_s
    );
    say!("wrote {} files to {}", files.len(), a.out.display());
    Ok(())
}

/// A GPU integration kernel of the --throughput study (`gpu.kernel`'s words).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum KernelArg {
    /// One invocation per instance (the only kernel since issue 73).
    Thread,
}

impl From<KernelArg> for GpuKernel {
    fn from(k: KernelArg) -> GpuKernel {
        match k {
            KernelArg::Thread => GpuKernel::Thread,
        }
    }
}

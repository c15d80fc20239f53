//! `bench --cpu-throughput`: the CPU engine against the machine's ceiling.
//!
//! Stages of [`run_cpu_throughput`]:
//! 1. [`super::cost`]: the flop count of one RK4 step at N = 3, 9, 17, from the table the lab
//!    counted by running the engine's step on a counting number type;
//! 2. the ceiling: cores × clock × the FMA peak at the engine's vector width (2 FMA units ×
//!    8 `f32` lanes × 2 flop = 32 flop per cycle and core in `f32`, 16 in `f64`, with AVX2;
//!    twice that where the build targets AVX-512);
//! 3. the throughput grid: a slice of the default map at each N (RK4, `instances` spread over
//!    its forcing plane, about `steps` steps each), scalar and SIMD loop, `f32` and `f64`, one
//!    thread and all; median of the integration time over `repeats` runs;
//! 4. the default map itself on each loop and precision (and on the software adapter, when
//!    one is given): wall time, integration, reductions and their share;
//! 5. the peers' results (`benches/peers/`, JSON), when a folder of them is given.

use super::cost::{FlopCount, step_flops};
use super::workload::{WorkloadError, default_map_plan};
use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, map_from_toml};
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_core::engine::{
    CpuLoop, Engine, EngineError, EnsemblePlan, Precision, Readback, no_progress,
};
use pendulum_atlas_core::model::{F32Lanes, F64Lanes, Lane};
use pendulum_atlas_core::reduce::ReduceOptions;
use pendulum_atlas_map::map::run_map;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;
use std::time::Instant;

/// Settings of the study.
pub struct CpuThroughputOptions<'a> {
    /// Fewer instances and steps, one repeat, a small default map (a minute on 2 cores).
    pub quick: bool,
    /// A folder of peer results (`jax_*.json` from `benches/peers/`).
    pub peers: Option<PathBuf>,
    /// The software adapter, for the default-map comparison.
    pub gpu: Option<&'a Engine>,
}

/// The machine's floating-point ceiling.
#[derive(Debug, Clone, Serialize)]
pub struct Ceiling {
    /// Cores used (rayon threads).
    pub cores: usize,
    /// Clock (GHz) as the kernel reports it (`/proc/cpuinfo`), `None` where unknown.
    pub ghz: Option<f64>,
    /// flop per cycle and core in f32 (2 FMA units × the engine's lanes × 2: 32 with AVX2).
    pub f32_flop_per_cycle: f64,
    /// flop per cycle and core in f64 (half the f32 lanes).
    pub f64_flop_per_cycle: f64,
}

impl Ceiling {
    /// flop/s of all cores in `p`, if the clock is known.
    pub fn flop_per_s(&self, p: Precision, threads: usize) -> Option<f64> {
        let per_cycle = match p {
            Precision::F32 => self.f32_flop_per_cycle,
            Precision::F64 => self.f64_flop_per_cycle,
        };
        self.ghz.map(|g| g * 1e9 * per_cycle * threads as f64)
    }
}

/// One measured configuration of the throughput grid.
#[derive(Debug, Clone, Serialize)]
pub struct ThroughputRow {
    /// Segments N.
    pub segments: usize,
    /// Scalar or SIMD.
    pub cpu_loop: CpuLoop,
    /// f32 or f64.
    pub precision: Precision,
    /// rayon threads.
    pub threads: usize,
    /// Instances.
    pub instances: usize,
    /// Instance-steps integrated per run.
    pub instance_steps: u64,
    /// Integration wall time of every run (s).
    pub runs_s: Vec<f64>,
    /// Their median (s).
    pub median_s: f64,
    /// Instance-steps per second (median run).
    pub instance_steps_per_s: f64,
    /// Segment-steps per second.
    pub segment_steps_per_s: f64,
    /// flop/s achieved (counted flop per step × steps / time).
    pub flop_per_s: f64,
    /// Share of the ceiling of the threads used, where the clock is known.
    pub share_of_ceiling: Option<f64>,
}

/// The default map on one engine.
#[derive(Debug, Clone, Serialize)]
pub struct DefaultMapRow {
    /// The engine, in words.
    pub engine: String,
    /// Instances.
    pub instances: usize,
    /// Integration (s; on the GPU the device's integration dispatches).
    pub integrate_s: f64,
    /// Reductions (s; host reductions on the CPU, the device's on the GPU).
    pub reduce_s: f64,
    /// The whole map (s).
    pub total_s: f64,
    /// Instance-steps per second of the integration.
    pub instance_steps_per_s: f64,
    /// Reductions' share of the whole map's wall time.
    pub reduce_share: f64,
}

/// A peer's result, as its JSON reports it (`benches/peers/jax_cpu.py`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerRow {
    /// The peer's name.
    pub peer: String,
    /// Its variant (`researcher`, `tuned`).
    pub variant: String,
    /// f32 or f64.
    pub precision: String,
    /// Segments N.
    pub segments: usize,
    /// Instances.
    pub instances: usize,
    /// Steps per instance.
    pub steps: u64,
    /// Median time (s).
    pub median_s: f64,
    /// Instance-steps per second.
    pub instance_steps_per_s: f64,
    /// Largest |Δy| against our f64 engine after the case's check steps (f64 check).
    pub check_max_abs_err: f64,
}

/// Everything the study measured.
#[derive(Debug, Clone, Serialize)]
pub struct CpuThroughputReport {
    /// The machine, in words.
    pub machine: String,
    /// Its ceiling.
    pub ceiling: Ceiling,
    /// Flop per RK4 step at each N.
    pub flops: Vec<FlopCount>,
    /// The throughput grid.
    pub rows: Vec<ThroughputRow>,
    /// The default map per engine.
    pub default_map: Vec<DefaultMapRow>,
    /// Peers' results.
    pub peers: Vec<PeerRow>,
    /// Segment counts of the grid.
    pub segments: Vec<usize>,
    /// Wall time of the study (s).
    pub total_s: f64,
}

/// What can stop the study.
#[derive(Debug, thiserror::Error)]
pub enum CpuThroughputError {
    /// A plan or a run failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// The default map could not be made.
    #[error(transparent)]
    Case(#[from] WorkloadError),
    /// A thread pool could not be built.
    #[error("thread pool: {0}")]
    Pool(String),
    /// A peer result could not be read.
    #[error("peer result {path}: {reason}")]
    Peer {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// Segment counts of the grid.
pub const SEGMENTS: [usize; 3] = [3, 9, 17];

/// Run the study.
pub fn run_cpu_throughput(
    opts: &CpuThroughputOptions,
    progress: &dyn Fn(&str),
) -> Result<CpuThroughputReport, CpuThroughputError> {
    // The peers' results are read first: a bad --peers costs nothing.
    let peers = match &opts.peers {
        Some(dir) => read_peers(dir)?,
        None => Vec::new(),
    };
    let t0 = Instant::now();
    let threads = rayon::current_num_threads();
    let mut flops = Vec::new();
    let mut rows = Vec::new();
    for n in SEGMENTS {
        let plan = workload(n, opts.quick)?;
        let count = step_flops(Method::Rk4, &plan.instances[0].params);
        rows.extend(grid_rows(&plan, &count, opts.quick, threads, progress)?);
        flops.push(count);
    }
    let default_map = default_map_rows(opts, progress)?;
    Ok(CpuThroughputReport {
        machine: super::machine(opts.gpu),
        ceiling: ceiling(threads),
        flops,
        rows,
        default_map,
        peers,
        segments: SEGMENTS.to_vec(),
        total_s: t0.elapsed().as_secs_f64(),
    })
}

/// The default map at N with RK4 on the earlier reading of the damping (ζ1 = 0.0035, where
/// RK4's step at N = 17 is 3.5e-6 s instead of 2.2e-7 s), α range only (the integration is
/// what is timed), over about `steps` steps but at least 0.5 s (two periods at the plane's
/// lowest 4 Hz: the first is always transient), its instances spread over the forcing plane:
/// as many as make about `budget` instance-steps, between 32 and 1024.
pub fn workload(n: usize, quick: bool) -> Result<EnsemblePlan, WorkloadError> {
    let (budget, steps) = if quick { (1e6, 400.0) } else { (4e6, 2000.0) };
    let only = [
        "integration.transient_s=0.0",
        "map.metrics=[\"alpha_range\"]",
        "beam.damping_ratio=0.0035",
    ];
    let probe = default_map_plan(n, 1, &[&only[..], &["integration.duration_s=1.0"]].concat())?;
    let per_s = probe.instances[0].total_steps() as f64;
    let seconds = (steps / per_s).max(0.5);
    let duration = format!("integration.duration_s={seconds}");
    let instances = ((budget / (seconds * per_s)) as usize).clamp(32, 1024) / 16 * 16;
    default_map_plan(n, instances, &[&only[..], &[duration.as_str()]].concat())
}

fn grid_rows(
    plan: &EnsemblePlan,
    count: &FlopCount,
    quick: bool,
    all: usize,
    progress: &dyn Fn(&str),
) -> Result<Vec<ThroughputRow>, CpuThroughputError> {
    let repeats = if quick { 1 } else { 3 };
    let ceiling = ceiling(all);
    let mut rows = Vec::new();
    for precision in [Precision::F64, Precision::F32] {
        for cpu_loop in [CpuLoop::Scalar, CpuLoop::Simd] {
            for threads in [1, all] {
                let runs_s = timed(plan, precision, cpu_loop, threads, repeats)?;
                let mut sorted = runs_s.clone();
                sorted.sort_by(f64::total_cmp);
                let median_s = sorted[sorted.len() / 2];
                let rate = plan.total_steps as f64 / median_s;
                let flop_per_s = rate * count.flop_per_step as f64;
                progress(&format!(
                    "cpu-throughput: N = {}, {} {} {threads} thread(s): {rate:.3e} instance-steps/s",
                    plan.segments,
                    cpu_loop.name(),
                    precision.name()
                ));
                rows.push(ThroughputRow {
                    segments: plan.segments,
                    cpu_loop,
                    precision,
                    threads,
                    instances: plan.instances.len(),
                    instance_steps: plan.total_steps,
                    runs_s,
                    median_s,
                    instance_steps_per_s: rate,
                    segment_steps_per_s: rate * plan.segments as f64,
                    flop_per_s,
                    share_of_ceiling: ceiling
                        .flop_per_s(precision, threads)
                        .map(|c| flop_per_s / c),
                });
            }
        }
    }
    Ok(rows)
}

/// Integration wall times of `repeats` runs on `threads` threads.
fn timed(
    plan: &EnsemblePlan,
    precision: Precision,
    cpu_loop: CpuLoop,
    threads: usize,
    repeats: usize,
) -> Result<Vec<f64>, CpuThroughputError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| CpuThroughputError::Pool(e.to_string()))?;
    let engine = Engine::cpu_with(precision, cpu_loop);
    let opts = ReduceOptions::default();
    (0..repeats)
        .map(|_| {
            let run =
                pool.install(|| engine.run(plan, &opts, Readback::default(), &no_progress))?;
            Ok(run.integration_s())
        })
        .collect()
}

fn default_map_rows(
    opts: &CpuThroughputOptions,
    progress: &dyn Fn(&str),
) -> Result<Vec<DefaultMapRow>, CpuThroughputError> {
    // The quick study's map: the same plane on an 8 × 6 grid.
    let text = if opts.quick {
        DEFAULT_MAP_TOML
            .replace("count = 64", "count = 8")
            .replace("count = 48", "count = 6")
    } else {
        DEFAULT_MAP_TOML.to_string()
    };
    let spec = map_from_toml(
        &text,
        "configs/maps/default.toml",
        &["map.settle=false".into()],
    )
    .map_err(WorkloadError::from)?;
    let engines: Vec<Engine> = [Precision::F64, Precision::F32]
        .iter()
        .flat_map(|&p| [CpuLoop::Scalar, CpuLoop::Simd].map(|l| Engine::cpu_with(p, l)))
        .collect();
    let mut rows = Vec::new();
    for engine in engines.iter().chain(opts.gpu) {
        let run = run_map(&spec, engine, &no_progress)?;
        let t = &run.timings;
        let (integrate_s, reduce_s) = match &t.gpu {
            Some(g) => (g.integrate_s, g.reduce_s),
            None => (t.integrate_s, t.reduce_s),
        };
        progress(&format!(
            "cpu-throughput: default map on {}: {:.1} s",
            engine.info().device,
            t.total_s
        ));
        rows.push(DefaultMapRow {
            engine: engine.info().device.clone(),
            instances: run.results.len(),
            integrate_s,
            reduce_s,
            total_s: t.total_s,
            instance_steps_per_s: run.instance_steps_per_s(),
            reduce_share: reduce_s / t.total_s.max(1e-12),
        });
    }
    Ok(rows)
}

/// The machine's ceiling on `cores` threads, at the vector width the CPU engine was built
/// with (two FMA units, each a fused multiply-add per lane and cycle: AVX2's 32 flop per cycle
/// in f32 with 8 lanes, AVX-512's 64 with 16).
fn ceiling(cores: usize) -> Ceiling {
    let fma = |lanes: usize| (2 * lanes * 2) as f64;
    Ceiling {
        cores,
        ghz: cpu_ghz(),
        f32_flop_per_cycle: fma(F32Lanes::LANES),
        f64_flop_per_cycle: fma(F64Lanes::LANES),
    }
}

/// The clock of the first core in `/proc/cpuinfo` (GHz).
pub(crate) fn cpu_ghz() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("cpu MHz"))?;
    let mhz: f64 = line.split(':').nth(1)?.trim().parse().ok()?;
    Some(mhz / 1e3)
}

/// Every `jax_*.json` in `dir`.
fn read_peers(dir: &std::path::Path) -> Result<Vec<PeerRow>, CpuThroughputError> {
    read_peer_files(dir, |n| n.starts_with("jax_"))
        .map_err(|(path, reason)| CpuThroughputError::Peer { path, reason })
}

/// The JSON files in `dir` whose names `accept` takes, parsed, sorted by name; the file and
/// the reason on failure.
pub(crate) fn read_peer_files<T: serde::de::DeserializeOwned>(
    dir: &std::path::Path,
    accept: impl Fn(&str) -> bool,
) -> Result<Vec<T>, (PathBuf, String)> {
    let entries = std::fs::read_dir(dir).map_err(|e| (dir.to_path_buf(), e.to_string()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| accept(n) && n.ends_with(".json"))
        })
        .collect();
    paths.sort();
    paths
        .iter()
        .map(|p| {
            let text = std::fs::read_to_string(p).map_err(|e| (p.clone(), e.to_string()))?;
            serde_json::from_str(&text).map_err(|e| {
                let name = p
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into());
                (p.clone(), pendulum_atlas_core::text::json_damage(&name, &e))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ceiling follows the vector width the engine was built with: two FMA units, two flop
    /// per lane and cycle (32 f32 flop with AVX2's 8 lanes, 64 with AVX-512's 16), f64 half.
    #[test]
    fn the_ceiling_is_the_fma_peak_of_the_engines_lanes() {
        let c = ceiling(2);
        assert_eq!(c.f32_flop_per_cycle, 4.0 * F32Lanes::LANES as f64);
        assert_eq!(c.f64_flop_per_cycle, c.f32_flop_per_cycle / 2.0);
        assert!([32.0, 64.0].contains(&c.f32_flop_per_cycle), "{c:?}");
    }
}

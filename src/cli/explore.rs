//! `pendulum-atlas explore`: serve a finished map, calibration or search folder as an
//! interactive page.

use pendulum_atlas_explore::{CellLimits, RunFolder, ServeOptions, serve};
use std::io::Write;
use std::net::IpAddr;
use std::path::PathBuf;

/// Most cell runs that may wait in the queue.
const MAX_QUEUE: usize = 1000;
/// Longest time limit of one cell run (s): a day.
const MAX_CELL_S: f64 = 86_400.0;
/// Largest memory limit of one cell run (MB).
const MAX_CELL_MB: u64 = 1_000_000;

/// Arguments of `explore`.
#[derive(Debug, clap::Args)]
pub struct ExploreArgs {
    /// A finished run folder: `pendulum-atlas map --out DIR` (or `merge`), `calibrate` or `search`.
    pub run_dir: PathBuf,
    /// Port to listen on (0: any free port, printed at start).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Address to listen on. The default serves this machine only; 0.0.0.0 serves the network
    /// (anyone who reaches it can start cell runs).
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Cells integrated at once (1 to the number of cores).
    #[arg(long, default_value_t = 1)]
    pub workers: usize,
    /// Cell runs allowed to wait; clicks beyond it are refused until one finishes (1 to 1000).
    #[arg(long, default_value_t = 16)]
    pub queue: usize,
    /// A cell run still integrating after this many seconds is stopped, and the page says so
    /// (above 0, at most 86400).
    #[arg(long, default_value_t = CellLimits::DEFAULT.wall_s)]
    pub cell_time_limit_s: f64,
    /// A cell run estimated to hold more memory than this (MB, 10^6 bytes) is refused before
    /// it starts (1 to 1000000).
    #[arg(long, default_value_t = CellLimits::DEFAULT.memory_bytes / 1_000_000)]
    pub cell_memory_mb: u64,
}

/// Run `explore` until stopped (Ctrl-C).
pub fn run(a: ExploreArgs) -> anyhow::Result<()> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if a.workers == 0 || a.workers > cores {
        anyhow::bail!(
            "--workers {}: give 1 to {cores} (this machine's cores)",
            a.workers
        );
    }
    if a.queue == 0 || a.queue > MAX_QUEUE {
        anyhow::bail!("--queue {}: give 1 to {MAX_QUEUE}", a.queue);
    }
    let limits = cell_limits(&a)?;
    let folder = RunFolder::open(&a.run_dir)?;
    let cells = folder.cells();
    let opts = ServeOptions {
        bind: a.bind,
        port: a.port,
        workers: a.workers,
        queue: a.queue,
        limits,
    };
    serve(folder, &opts, |addr| {
        say!(
            "explore: {} cells of {} at http://{addr}/ (Ctrl-C stops)",
            cells,
            a.run_dir.display()
        );
        let _ = std::io::stdout().flush();
    })
    .map_err(|e| anyhow::anyhow!("cannot serve on {}:{}: {e}", a.bind, a.port))
}

/// The limits of one cell run, checked.
fn cell_limits(a: &ExploreArgs) -> anyhow::Result<CellLimits> {
    let t = a.cell_time_limit_s;
    if !(t > 0.0 && t <= MAX_CELL_S) {
        anyhow::bail!("--cell-time-limit-s {t}: give a time above 0 and at most {MAX_CELL_S} s");
    }
    if a.cell_memory_mb == 0 || a.cell_memory_mb > MAX_CELL_MB {
        anyhow::bail!(
            "--cell-memory-mb {}: give 1 to {MAX_CELL_MB} MB",
            a.cell_memory_mb
        );
    }
    Ok(CellLimits {
        wall_s: t,
        memory_bytes: a.cell_memory_mb * 1_000_000,
    })
}

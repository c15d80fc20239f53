//! `pendulum-atlas explore`: serve a finished map, calibration or search folder as an
//! interactive page.

use pendulum_atlas::explore::{RunFolder, ServeOptions, serve};
use std::io::Write;
use std::net::IpAddr;
use std::path::PathBuf;

/// Most cell runs that may wait in the queue.
const MAX_QUEUE: usize = 1000;

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
    let folder = RunFolder::open(&a.run_dir)?;
    let cells = folder.cells();
    let opts = ServeOptions {
        bind: a.bind,
        port: a.port,
        workers: a.workers,
        queue: a.queue,
    };
    serve(folder, &opts, |addr| {
        println!(
            "explore: {} cells of {} at http://{addr}/ (Ctrl-C stops)",
            cells,
            a.run_dir.display()
        );
        let _ = std::io::stdout().flush();
    })
    .map_err(|e| anyhow::anyhow!("cannot serve on {}:{}: {e}", a.bind, a.port))
}

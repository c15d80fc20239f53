//! pendulum-atlas-explore (`pendulum-atlas explore`): a finished map, calibration or search in the browser. Every quantity of the
//! grid as a heat map with its colour bar, and a click on a cell runs that cell again with its
//! motion kept (α(t) and the cart, the phase portrait, the stroboscopic section, the spectrum
//! and the scalogram).
//!
//! Stages, in the order a request flows through them:
//! 1. [`RunFolder::open`] (`folder`, with `map_folder`, `calibrate_folder`, `search_folder`):
//!    the manifest, the run's scene and its per-cell files, read and checked once at start;
//! 2. [`field`] (`field`): one quantity over one slice, coloured by the PNG heat maps' rule;
//! 3. [`cell_scene`] / [`run_cell`] (`cell`): a cell's scene with its command's method and
//!    step pinned, integrated and analysed exactly as `simulate` does;
//! 4. [`Jobs`] (`jobs`): a bounded queue of cell runs on a fixed set of worker threads, each
//!    run within [`CellLimits`] and cancellable from the page;
//! 5. [`serve`] (`server`): the embedded page and the JSON API on a local port.
//!
//! Errors are [`ExploreError`]s; the server answers each with one HTTP status and a JSON
//! `{"error": ...}` that names the problem and what is accepted.

mod calibrate_folder;
mod cell;
mod error;
mod field;
mod folder;
mod jobs;
mod map_folder;
mod open;
mod seal;
mod search_folder;
mod server;
mod sources;

pub use cell::{CellControl, CellRun, CellScene, cell_memory_bytes, cell_scene, run_cell};
pub use error::ExploreError;
pub use field::{Field, field};
pub use folder::{Axis, Column, RunFolder, Source};
pub use jobs::{JobView, Jobs};

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;

/// What one cell run may take: it is refused before it starts when its estimated memory
/// exceeds `memory_bytes`, and stopped when it runs longer than `wall_s`. The page says both,
/// and offers the cell's scene for `simulate`, which has no such limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellLimits {
    /// Longest integration of one cell (s).
    pub wall_s: f64,
    /// Most memory one cell run may hold: its rows and their analysis (bytes).
    pub memory_bytes: u64,
}

impl CellLimits {
    /// 5 minutes and 2 GB: a click answers within minutes and a few clicks fit a laptop.
    pub const DEFAULT: CellLimits = CellLimits {
        wall_s: 300.0,
        memory_bytes: 2_000_000_000,
    };
}

/// How the server runs.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// Address to bind (127.0.0.1 unless told otherwise).
    pub bind: IpAddr,
    /// Port (0: any free port).
    pub port: u16,
    /// Cells integrated at once.
    pub workers: usize,
    /// Cell runs allowed to wait.
    pub queue: usize,
    /// What one cell run may take.
    pub limits: CellLimits,
}

/// Serve `folder` until the process is stopped; `ready` is called with the bound address
/// once the server accepts connections.
pub fn serve(
    folder: RunFolder,
    opts: &ServeOptions,
    ready: impl FnOnce(SocketAddr),
) -> std::io::Result<()> {
    let seal = seal::Seal::take(&folder.dir, folder.product.manifest());
    let folder = Arc::new(folder);
    let jobs = Jobs::start(folder.clone(), opts.workers, opts.queue, opts.limits);
    let app = Arc::new(server::App { folder, jobs, seal });
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_io()
        .enable_time()
        .build()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(SocketAddr::new(opts.bind, opts.port)).await?;
        ready(listener.local_addr()?);
        axum::serve(listener, server::router(app)).await
    })
}

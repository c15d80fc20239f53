//! What can go wrong while exploring: a folder that is not a complete map, and requests the
//! server refuses (each maps to one HTTP status in `server`).

/// An error of `explore`, naming the file or the request and what is accepted.
#[derive(Debug, thiserror::Error)]
pub enum ExploreError {
    /// The folder lacks a file a map folder has.
    #[error("`{path}` is missing: {hint}")]
    MissingFile {
        /// The file looked for.
        path: String,
        /// What the folder is instead, or how to make the file.
        hint: String,
    },
    /// A file of the folder cannot be read or disagrees with `map.json`.
    #[error("`{path}`: {reason}")]
    BadFile {
        /// The file.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A metric the map does not hold.
    #[error("unknown metric `{name}`: this map holds {accepted}")]
    UnknownMetric {
        /// The name asked for.
        name: String,
        /// The metrics of the map, comma-separated.
        accepted: String,
    },
    /// A cell or slice index outside the grid, or not a whole number.
    #[error("{what} `{given}` is out of range: give a whole number from 0 to {last}")]
    OutOfRange {
        /// `cell` or `slice`.
        what: &'static str,
        /// The index as given.
        given: String,
        /// The largest index accepted.
        last: usize,
    },
    /// A slice that does not give one index per axis beyond the second.
    #[error(
        "slice `{given}`: give one index per axis beyond the second, separated by commas (this grid has {axes} such axes)"
    )]
    BadSlice {
        /// The slice as given.
        given: String,
        /// How many indices the grid needs.
        axes: usize,
    },
    /// No job with that id (never made, or forgotten to make room).
    #[error("no job {0}: click the cell again to run it")]
    UnknownJob(u64),
    /// A job id that is not a whole number.
    #[error("`{0}` is not a job id: ids are the whole numbers that POST /api/cell/K/run answers")]
    BadJobId(String),
    /// The queue of cell simulations is full.
    #[error(
        "{waiting} cell runs are waiting already (the most this server queues): try again when one has finished"
    )]
    QueueFull {
        /// Jobs waiting.
        waiting: usize,
    },
    /// A file of the folder that is not served (not listed in `map.json`, or not a picture).
    #[error("`{0}` is not a picture of this map")]
    NotServed(String),
    /// A cell run that would hold more memory than the server allows one run.
    #[error(
        "cell {cell}: its run would hold about {need} of memory and this server allows {limit} a run (explore --cell-memory-mb): download its scene and run `pendulum-atlas simulate` on it"
    )]
    TooLarge {
        /// Cell index.
        cell: usize,
        /// Memory the run needs, readable.
        need: String,
        /// The limit, readable.
        limit: String,
    },
    /// A cell run stopped at the server's time limit.
    #[error(
        "cell {cell}: the run was stopped at this server's limit of {limit_s} s a run (explore --cell-time-limit-s), {done_percent:.0} % done: download its scene and run `pendulum-atlas simulate` on it"
    )]
    TooLong {
        /// Cell index.
        cell: usize,
        /// The limit (s).
        limit_s: f64,
        /// Share of the steps done (%).
        done_percent: f64,
    },
    /// A cell run cancelled from the page.
    #[error("cell {0}: the run was cancelled; click the cell to run it again")]
    Cancelled(usize),
    /// The folder was deleted, replaced or rerun since the server opened it.
    #[error(
        "{0} was replaced or rerun since explore opened it: this page shows the earlier run; stop explore (Ctrl-C) and start it again to see the new one"
    )]
    Replaced(String),
    /// The cell's scene could not be rebuilt, integrated or analysed.
    #[error("{0}")]
    Cell(String),
}

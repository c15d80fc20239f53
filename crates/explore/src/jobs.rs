//! The queue of cell runs. A fixed number of worker threads run cells one at a time each; at
//! most `capacity` more wait. A cell (and variant) asked for again gets its earlier job (done,
//! running or waiting), so a burst of clicks on the same cells costs one run each, and a burst on many
//! cells is refused once the queue is full instead of starting threads without bound.
//! Finished runs are kept (the newest [`KEEP_DONE`]) to answer repeated clicks at once.
//! Each run is held to the server's [`CellLimits`], and a cancel stops a waiting job at once
//! and a running one at its next output row.

use super::CellLimits;
use super::cell::{CellControl, CellRun, run_cell};
use super::error::ExploreError;
use super::folder::RunFolder;
use serde::Serialize;
use std::collections::{HashMap, VecDeque};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// Finished jobs kept for repeated clicks.
pub(crate) const KEEP_DONE: usize = 64;

/// Where a job stands, as the page polls it.
#[derive(Debug, Clone, Serialize)]
#[serde(tag = "state", rename_all = "lowercase")]
pub enum JobView {
    /// Waiting; `ahead` jobs wait before it.
    Queued {
        /// Job id.
        job: u64,
        /// Cell index.
        cell: usize,
        /// Jobs ahead of it in the queue.
        ahead: usize,
    },
    /// Being integrated; `progress` from 0 to 1.
    Running {
        /// Job id.
        job: u64,
        /// Cell index.
        cell: usize,
        /// Share of the steps done.
        progress: f64,
    },
    /// Finished.
    Done {
        /// Job id.
        job: u64,
        /// Cell index.
        cell: usize,
        /// The run.
        result: Arc<CellRun>,
    },
    /// Failed, with the reason.
    Failed {
        /// Job id.
        job: u64,
        /// Cell index.
        cell: usize,
        /// What went wrong.
        error: String,
    },
}

#[derive(Debug)]
enum Stage {
    Queued,
    Running(Arc<CellControl>),
    Done(Arc<CellRun>),
    Failed(String),
}

/// A cell and the variant it runs as.
type Cell = (usize, usize);

#[derive(Debug, Default)]
struct State {
    next_id: u64,
    stages: HashMap<u64, (Cell, Stage)>,
    by_cell: HashMap<Cell, u64>,
    queue: VecDeque<u64>,
    finished: VecDeque<u64>,
}

/// The queue and its workers.
pub struct Jobs {
    state: Mutex<State>,
    wake: Condvar,
    capacity: usize,
    limits: CellLimits,
}

impl Jobs {
    /// Start `workers` threads running cells of `folder` within `limits`, with at most
    /// `capacity` waiting.
    pub fn start(
        folder: Arc<RunFolder>,
        workers: usize,
        capacity: usize,
        limits: CellLimits,
    ) -> Arc<Jobs> {
        let jobs = Arc::new(Jobs {
            state: Mutex::new(State::default()),
            wake: Condvar::new(),
            capacity,
            limits,
        });
        for _ in 0..workers.max(1) {
            let (j, f) = (jobs.clone(), folder.clone());
            std::thread::spawn(move || j.work(&f));
        }
        jobs
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A worker that panicked left consistent state behind (it holds no lock while running).
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The job of `cell` run as `variant`: the existing one, or a new one at the end of the
    /// queue.
    pub fn submit(&self, cell: usize, variant: usize) -> Result<JobView, ExploreError> {
        let cell = (cell, variant);
        let mut s = self.lock();
        if let Some(&id) = s.by_cell.get(&cell) {
            return Ok(view(&s, id).expect("indexed jobs exist"));
        }
        if s.queue.len() >= self.capacity {
            return Err(ExploreError::QueueFull {
                waiting: s.queue.len(),
            });
        }
        let id = s.next_id;
        s.next_id += 1;
        s.stages.insert(id, (cell, Stage::Queued));
        s.by_cell.insert(cell, id);
        s.queue.push_back(id);
        self.wake.notify_one();
        Ok(view(&s, id).expect("just inserted"))
    }

    /// Where job `id` stands.
    pub fn get(&self, id: u64) -> Result<JobView, ExploreError> {
        view(&self.lock(), id).ok_or(ExploreError::UnknownJob(id))
    }

    /// What one cell run may take.
    pub fn limits(&self) -> CellLimits {
        self.limits
    }

    /// Cancel job `id`: a waiting job leaves the queue and fails as cancelled at once, a
    /// running one stops at its next output row; a finished job stays as it is.
    pub fn cancel(&self, id: u64) -> Result<JobView, ExploreError> {
        let mut s = self.lock();
        let (cell, stage) = s.stages.get(&id).ok_or(ExploreError::UnknownJob(id))?;
        let cell = *cell;
        match stage {
            Stage::Queued => {
                s.queue.retain(|&q| q != id);
                drop(s);
                self.finish(id, cell, Err(ExploreError::Cancelled(cell.0)));
                return self.get(id);
            }
            Stage::Running(control) => control.cancel(),
            Stage::Done(_) | Stage::Failed(_) => {}
        }
        Ok(view(&s, id).expect("looked up above"))
    }

    /// A worker: take the oldest waiting job, run it, record the outcome; forever.
    fn work(&self, folder: &RunFolder) {
        loop {
            let (id, cell, progress) = {
                let mut s = self.lock();
                let id = loop {
                    match s.queue.pop_front() {
                        Some(id) => break id,
                        None => s = self.wake.wait(s).unwrap_or_else(|p| p.into_inner()),
                    }
                };
                let control = Arc::new(CellControl::default());
                let entry = s.stages.get_mut(&id).expect("queued jobs exist");
                entry.1 = Stage::Running(control.clone());
                (id, entry.0, control)
            };
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run_cell(folder, cell.0, cell.1, &progress, self.limits)
            }))
            .unwrap_or_else(|_| {
                Err(ExploreError::Cell(format!(
                    "the run of cell {} panicked (a bug: please report it with the folder)",
                    cell.0
                )))
            });
            self.finish(id, cell, outcome);
        }
    }

    /// Record a finished job, forgetting the oldest beyond [`KEEP_DONE`]. A cancelled or
    /// stopped run is forgotten by its cell, so that the next click runs it again.
    fn finish(&self, id: u64, cell: Cell, outcome: Result<CellRun, ExploreError>) {
        let mut s = self.lock();
        let stage = match outcome {
            Ok(run) => Stage::Done(Arc::new(run)),
            Err(e) => {
                if matches!(e, ExploreError::Cancelled(_) | ExploreError::TooLong { .. }) {
                    s.by_cell.remove(&cell);
                }
                Stage::Failed(e.to_string())
            }
        };
        s.stages.insert(id, (cell, stage));
        s.finished.push_back(id);
        while s.finished.len() > KEEP_DONE {
            let old = s.finished.pop_front().expect("longer than KEEP_DONE");
            if let Some((c, _)) = s.stages.remove(&old)
                && s.by_cell.get(&c) == Some(&old)
            {
                s.by_cell.remove(&c);
            }
        }
    }
}

fn view(s: &State, id: u64) -> Option<JobView> {
    let (cell, stage) = s.stages.get(&id)?;
    let (job, cell) = (id, cell.0);
    Some(match stage {
        Stage::Queued => JobView::Queued {
            job,
            cell,
            ahead: s.queue.iter().position(|&q| q == id).unwrap_or(0),
        },
        Stage::Running(c) => JobView::Running {
            job,
            cell,
            progress: c.progress(),
        },
        Stage::Done(r) => JobView::Done {
            job,
            cell,
            result: r.clone(),
        },
        Stage::Failed(e) => JobView::Failed {
            job,
            cell,
            error: e.clone(),
        },
    })
}

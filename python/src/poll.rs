//! Running the engine off the interpreter: the work runs on its own thread with the GIL
//! released, while the calling (main) thread wakes every [`TICK`] to move the progress bar
//! and to notice Ctrl-C, which only the main thread can see.

use pendulum_atlas_core::engine::ProgressUnit;
use pyo3::prelude::*;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};
use std::thread;
use std::time::Duration;

/// How often the main thread looks at the progress and for signals.
const TICK: Duration = Duration::from_millis(100);

/// What the work reports and what the caller asks of it.
#[derive(Default)]
pub struct Ticker {
    done: AtomicU64,
    total: AtomicU64,
    /// 0: steps, 1: instances.
    unit: AtomicU8,
    cancel: AtomicBool,
}

impl Ticker {
    /// Record progress; [`ControlFlow::Break`] once the caller has cancelled.
    pub fn report(&self, done: u64, total: u64, unit: ProgressUnit) -> ControlFlow<()> {
        self.done.store(done, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
        let code = match unit {
            ProgressUnit::Steps => 0,
            ProgressUnit::Instances => 1,
            ProgressUnit::Planned => 2,
        };
        self.unit.store(code, Ordering::Relaxed);
        if self.cancel.load(Ordering::Relaxed) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    fn unit_name(&self) -> &'static str {
        match self.unit.load(Ordering::Relaxed) {
            0 => ProgressUnit::Steps.name(),
            1 => ProgressUnit::Instances.name(),
            _ => ProgressUnit::Planned.name(),
        }
    }
}

/// Run `work` on its own thread; call `progress(done, total, unit)` on this thread as it
/// goes. Ctrl-C (or an exception raised by `progress`) cancels the work, which stops at its
/// next progress point (a few thousand runs planned, a map's instance or dispatch, a single run's output row); the call
/// waits for that and then raises.
pub fn run_polled<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(&Arc<Ticker>) -> T + Send + 'static,
) -> PyResult<T> {
    let ticker = Arc::new(Ticker::default());
    let main = thread::current();
    let worker = {
        let ticker = Arc::clone(&ticker);
        thread::Builder::new()
            .name("pendulum-atlas".into())
            .spawn(move || {
                let out = work(&ticker);
                main.unpark();
                out
            })
            .map_err(|e| {
                pyo3::exceptions::PyRuntimeError::new_err(format!("cannot start a thread: {e}"))
            })?
    };
    while !worker.is_finished() {
        py.detach(|| thread::park_timeout(TICK));
        if worker.is_finished() {
            break;
        }
        let polled = py.check_signals().and_then(|()| match progress {
            Some(cb) => cb
                .call1((
                    ticker.done.load(Ordering::Relaxed),
                    ticker.total.load(Ordering::Relaxed),
                    ticker.unit_name(),
                ))
                .map(drop),
            None => Ok(()),
        });
        if let Err(e) = polled {
            ticker.cancel.store(true, Ordering::Relaxed);
            py.detach(|| {
                while !worker.is_finished() {
                    thread::park_timeout(TICK)
                }
            });
            return Err(e);
        }
    }
    worker.join().map_err(|_| {
        pyo3::exceptions::PyRuntimeError::new_err(
            "pendulum-atlas stopped on an internal error (a panic); please report it with the scene",
        )
    })
}

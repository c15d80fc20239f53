//! `map.settle_max_s`: how long a cell whose verdict is not firm may run on before its verdict
//! is final (`docs/analysis.md`, §10 "Settling").
//!
//! A cell chaotic at the map's length can be transient chaos that settles on a periodic orbit
//! later. The map's settling stage reruns every cell whose `verdict_confidence` is below
//! [`FIRM`] (or undecided) for `settle_max_s` seconds, with the early stop, so that a cell that
//! settles stops soon after its orbit is confirmed:
//!
//! ```text
//! rerun:      duration T_s = settle_max_s,  transient T_s − (T − T_tr)
//!             (the indicators' window T − T_tr keeps the map's length)
//! ```
//!
//! These keys are checked here, before any work: the number itself, the verdict it needs
//! (`regime` among the metrics), the early stop, a plain map, and no axis over the run's length.

use super::error::ConfigError;
use super::mode::MapMode;
use super::reader::{Range, Reader};
use super::scene::Scene;
use super::sweep::MapAxis;
use crate::schema::Metric;

/// The `verdict_confidence` from which a verdict is firm: cells below it are run on.
pub const FIRM: f64 = 0.9;

/// The longest run a cell is allowed to settle in (s).
pub const SETTLE_LIMIT_S: f64 = 100_000.0;

/// The keys of the run's length, which an axis of a settled map may not sweep.
const LENGTH_KEYS: [&str; 2] = ["integration.duration_s", "integration.transient_s"];

/// What a settled map needs besides the number: `(metrics, early stop, mode, axes)`.
pub(super) struct SettleContext<'a> {
    /// The map's metrics.
    pub metrics: &'a [Metric],
    /// `map.early_stop`.
    pub early_stop: bool,
    /// How the cells run.
    pub mode: &'a MapMode,
    /// The swept keys.
    pub axes: &'a [MapAxis],
}

/// `map.settle_max_s`: `None` (the default) or a time above the run's length.
pub(super) fn read_settle(
    r: &mut Reader,
    scene: &Scene,
    cx: SettleContext,
) -> Result<Option<f64>, ConfigError> {
    let key = "map.settle_max_s";
    let duration = scene.integration.duration_s;
    let Some(max_s) = r.number_opt(
        key,
        Range::OpenClosed(duration, SETTLE_LIMIT_S),
        "s (above integration.duration_s)",
    )?
    else {
        return Ok(None);
    };
    let refused = |reason: &str| {
        Err(ConfigError::Inconsistent {
            key: key.into(),
            reason: reason.into(),
        })
    };
    if !cx.metrics.contains(&Metric::Regime) {
        return refused(
            "settling reruns the cells whose verdict is not firm, and the verdict needs \"regime\" in map.metrics",
        );
    }
    if !cx.early_stop {
        return refused(
            "settling stops each cell once its orbit is confirmed: set map.early_stop = true",
        );
    }
    if !matches!(cx.mode, MapMode::Plain) {
        return refused(
            "settling works on a plain map (one start per cell, no continuation, no refinement)",
        );
    }
    if let Some(a) = cx
        .axes
        .iter()
        .find(|a| LENGTH_KEYS.contains(&a.key.as_str()))
    {
        return Err(ConfigError::Inconsistent {
            key: key.into(),
            reason: format!(
                "settling lengthens every rerun cell's run, so no axis may sweep {}",
                a.key
            ),
        });
    }
    Ok(Some(max_s))
}

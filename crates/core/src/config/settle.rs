//! `map.settle` and `map.settle_max_s`: whether, and how long, a cell whose verdict is not
//! firm runs on before its verdict is final (`docs/analysis.md`, §10 "Settling").
//!
//! A cell chaotic at the map's length can be transient chaos that settles on a periodic orbit
//! later. The map's settling stage (on by default) runs every cell whose `verdict_confidence`
//! is below [`FIRM`] (or undecided) on to `settle_max_s` seconds, with the early stop, so
//! that a cell that settles stops soon after its orbit is confirmed:
//!
//! ```text
//! default:    settle_max_s = 2 T   (T = integration.duration_s; a map whose 2 T is over
//!                                   the limit runs raw unless given a settle_max_s)
//! continued:  from the state at T for T_s − T, transient T_s − T − W
//!             (the indicators' window W = T − T_tr keeps the map's length and ends at T_s)
//! accepted:   T + W ≤ T_s ≤ 100 000 s
//! ```
//!
//! Settling needs the verdict (`regime` among the metrics), the early stop, a plain map and
//! no axis over the run's length. Where a map lacks one of them, settling is off by default,
//! and asked for (`map.settle = true` or a `map.settle_max_s`) it is refused with the reason.
//! `map.settle = false` keeps the raw map.

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

/// Where a cell run on by the settling stage starts again (`map.settle_from`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SettleFrom {
    /// From its state at the map's end (the default): the first `T` is not integrated
    /// again. The run on is the cell's run of `T_s` from period `P` on, with the summation's
    /// compensation started again at zero, so a chaotic cell takes another, equally accurate
    /// trajectory than one run of `T_s` would.
    #[default]
    End,
    /// From its start: one run of `T_s`, bit for bit; the first `T` is integrated twice.
    Start,
}

impl SettleFrom {
    /// `"end"` or `"start"`.
    pub fn name(self) -> &'static str {
        match self {
            SettleFrom::End => "end",
            SettleFrom::Start => "start",
        }
    }
}

/// `map.settle_from`: `"end"` (default) or `"start"`.
pub(super) fn read_settle_from(r: &mut Reader) -> Result<SettleFrom, ConfigError> {
    let all = [SettleFrom::End, SettleFrom::Start];
    let names = all.map(SettleFrom::name);
    let word = r.choice("map.settle_from", SettleFrom::End.name(), &names)?;
    Ok(all
        .into_iter()
        .find(|f| f.name() == word)
        .unwrap_or_default())
}

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

/// `map.settle_max_s` as the map runs it: `None` where it does not settle.
pub(super) fn read_settle(
    r: &mut Reader,
    scene: &Scene,
    cx: SettleContext,
) -> Result<Option<f64>, ConfigError> {
    let i = &scene.integration;
    let window = i.duration_s - i.transient_s;
    let least = i.duration_s + window;
    let max_s = r.number_opt(
        "map.settle_max_s",
        Range::Closed(least, SETTLE_LIMIT_S),
        "s (at least integration.duration_s plus the indicators' window, duration_s − transient_s)",
    )?;
    let asked = r.given("map.settle")?;
    let on = r.boolean("map.settle", true)?;
    if !on {
        return match max_s {
            Some(_) => Err(ConfigError::Inconsistent {
                key: "map.settle_max_s".into(),
                reason: "map.settle = false keeps the raw map: drop map.settle_max_s, or the other"
                    .into(),
            }),
            None => Ok(None),
        };
    }
    let key = if max_s.is_some() {
        "map.settle_max_s"
    } else {
        "map.settle"
    };
    let why = why_not(&cx).or_else(|| {
        (max_s.is_none() && 2.0 * i.duration_s > SETTLE_LIMIT_S).then(|| {
            format!(
                "twice integration.duration_s, the default settling time, is beyond its limit of {SETTLE_LIMIT_S} s: set map.settle_max_s (or map.settle = false)"
            )
        })
    });
    match why {
        None => Ok(Some(max_s.unwrap_or(2.0 * i.duration_s))),
        Some(_) if !asked && max_s.is_none() => Ok(None),
        Some(reason) => Err(ConfigError::Inconsistent {
            key: key.into(),
            reason,
        }),
    }
}

/// Why a map cannot settle (`None`: it can).
fn why_not(cx: &SettleContext) -> Option<String> {
    if !cx.metrics.contains(&Metric::Regime) {
        return Some(
            "settling runs on the cells whose verdict is not firm, and the verdict needs \"regime\" in map.metrics (or map.settle = false)".into(),
        );
    }
    if !cx.early_stop {
        return Some(
            "settling stops each cell once its orbit is confirmed: set map.early_stop = true (or map.settle = false)".into(),
        );
    }
    if !matches!(cx.mode, MapMode::Plain | MapMode::Refined(_)) {
        return Some(
            "settling works on a map of one start per cell (plain or refined, no continuation): set map.settle = false".into(),
        );
    }
    cx.axes
        .iter()
        .find(|a| LENGTH_KEYS.contains(&a.key.as_str()))
        .map(|a| {
            format!(
                "settling lengthens every run-on cell's run, so no axis may sweep {} (or map.settle = false)",
                a.key
            )
        })
}

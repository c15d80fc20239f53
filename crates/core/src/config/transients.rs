//! `map.transient_copies` and `map.transient_nudge_deg_s`: the nudged copies that settling
//! runs from the end state of each cell still not firm (`docs/analysis.md`, §16).
//!
//! ```text
//! default:   copies = 4 on a map that settles, none otherwise; nudge = 1e-3 deg/s
//! copy j:    the cell's end state, the first segment's rate raised by j · nudge (j = 1..M)
//! accepted:  copies 0..=64 (0: no copies), nudge in (0, 1] deg/s
//! asked:     copies on a map that does not settle are refused with the reason
//! ```

use super::error::ConfigError;
use super::reader::{Range, Reader};
use serde::Serialize;

/// The most copies a cell may run.
pub const COPIES_MAX: u32 = 64;

/// The copies a cell not firm after settling runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TransientSpec {
    /// Copies per cell (M ≥ 1).
    pub copies: u32,
    /// The nudge step of the first segment's rate (deg/s): copy j is nudged by j times it.
    pub nudge_deg_s: f64,
}

impl TransientSpec {
    /// Copy `j`'s nudge of the first segment's rate (rad/s), `j` counted from 0.
    pub fn nudge_rad_s(&self, j: u32) -> f64 {
        f64::from(j + 1) * self.nudge_deg_s.to_radians()
    }
}

/// `map.transient_copies` as the map runs it: `None` where no copies run (`settles`: the map
/// has a settling stage).
pub(super) fn read_transients(
    r: &mut Reader,
    settles: bool,
) -> Result<Option<TransientSpec>, ConfigError> {
    let asked = r.given("map.transient_copies")?;
    let copies = r.integer("map.transient_copies", 4, 0, i64::from(COPIES_MAX))? as u32;
    let nudge_deg_s = r.number(
        "map.transient_nudge_deg_s",
        1e-3,
        Range::OpenClosed(0.0, 1.0),
        "deg/s",
    )?;
    if copies == 0 {
        let why = "map.transient_copies = 0";
        super::scene::note_unused(r, (&["map.transient_nudge_deg_s"], why))?;
        return Ok(None);
    }
    if !settles {
        if asked {
            return Err(ConfigError::Inconsistent {
                key: "map.transient_copies".into(),
                reason: "the copies run from the end states of the cells settling leaves not firm, and this map does not settle (see map.settle; or map.transient_copies = 0)".into(),
            });
        }
        let why = "this map does not settle";
        super::scene::note_unused(r, (&["map.transient_nudge_deg_s"], why))?;
        return Ok(None);
    }
    Ok(Some(TransientSpec {
        copies,
        nudge_deg_s,
    }))
}

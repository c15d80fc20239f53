//! What a single run will cost before it starts: steps, output rows, memory and disk, checked
//! against the engines' step limit and what the machine has, so that `duration_s = 1e12` or
//! `dt_s = 1e-300` is refused with the numbers instead of running until memory or patience ends.
//!
//! - steps ≤ 2³² (the limit the map engines have too);
//! - memory: every row is held until it is written (`size_of::<Row>()` bytes) plus the copies the
//!   analysis makes (α and the cart, 16 bytes a row): at most `MEMORY_SHARE` of what the
//!   machine has available;
//! - disk: `CSV_BYTES_PER_VALUE` bytes per CSV value (the shortest round-trip decimal of an
//!   f64 and its separator, about 20 characters), at most the space left on the output's
//!   file system.

use super::Row;
use crate::machine::{free_space, memory_available};
use pendulum_atlas_core::text::bytes;
use std::path::Path;

/// The share of available memory a run may plan to use.
pub(crate) const MEMORY_SHARE: f64 = 0.8;

/// Bytes per value of `trajectory.csv` (digits, sign, exponent and the separator).
pub const CSV_BYTES_PER_VALUE: u64 = 21;

/// The largest number of steps of one run.
pub(crate) const MAX_STEPS: u64 = u32::MAX as u64;

/// The size of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSize {
    /// Integration steps.
    pub steps: u64,
    /// Output rows (t = 0 included).
    pub rows: u64,
    /// Memory held for the rows (bytes).
    pub memory_bytes: u64,
    /// Size of `trajectory.csv` (bytes, estimated).
    pub csv_bytes: u64,
}

/// Why a run is too large.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TooLarge {
    /// More steps than the engines count.
    #[error(
        "the run needs {steps:.3e} {}steps; the limit is {MAX_STEPS} (2^32 - 1): shorten integration.duration_s or {}",
        if *adaptive { "base " } else { "" },
        if *adaptive {
            "lower output.sample_rate_hz (adaptive steps take base steps of the method's automatic step, at most the output interval)"
        } else {
            "lengthen integration.dt_s"
        }
    )]
    Steps {
        /// Steps the run needs.
        steps: f64,
        /// The steps are the base steps of adaptive steps (where `integration.dt_s` would
        /// switch to fixed steps).
        adaptive: bool,
    },
    /// A run shorter than half a step.
    #[error(
        "integration.duration_s = {} s is shorter than half a step (dt = {dt_s:e} s): the run would take no step; lengthen integration.duration_s or shorten integration.dt_s", pendulum_atlas_core::text::num(*duration_s)
    )]
    NoStep {
        /// The scene's duration (s).
        duration_s: f64,
        /// The plan's step (s).
        dt_s: f64,
    },
    /// More memory than the machine has available.
    #[error(
        "the run's {rows} output rows need about {need} of memory and {available} is available: lower output.sample_rate_hz or shorten integration.duration_s"
    )]
    Memory {
        /// Rows.
        rows: u64,
        /// Memory needed, readable.
        need: String,
        /// Memory available, readable.
        available: String,
    },
    /// A larger trajectory than the output's file system can hold.
    #[error(
        "trajectory.csv would take about {need} and {dir} has {available} free: lower output.sample_rate_hz, shorten integration.duration_s or choose another --out"
    )]
    Disk {
        /// The output folder.
        dir: String,
        /// Bytes needed, readable.
        need: String,
        /// Bytes free, readable.
        available: String,
    },
    /// A map's files larger than the output's file system can hold.
    #[error(
        "the map's files would take up to about {need} and {dir} has {available} free: free some space, choose another --out, or map fewer cells or metrics"
    )]
    MapDisk {
        /// The output folder.
        dir: String,
        /// Bytes needed, readable.
        need: String,
        /// Bytes free, readable.
        available: String,
    },
}

/// Bytes one picture of a map may take at most (a PNG heat map with its axes and colour bar;
/// the default map's are 60–73 kB).
pub const PICTURE_BYTES: u64 = 512 * 1024;

/// The most bytes a map of `spec` writes (or one of `shards` shards of it), estimated before
/// any work: per run of the grid (cells × starts) and stored field,
/// 8 bytes of `.npy` and [`CSV_BYTES_PER_VALUE`] of `grid.csv`; the bifurcation's samples
/// (8 bytes each); and [`PICTURE_BYTES`] per picture, one per metric and slice of a third
/// axis, three more for the regime's, the confidence's and the bifurcation's.
pub fn map_bytes(spec: &pendulum_atlas_core::config::MapSpec, shards: u32) -> u64 {
    let runs = (spec.instances() * spec.starts_per_cell()).div_ceil(shards.max(1) as usize) as u64;
    let fields = super::map::map_fields().count() as u64 + spec.axes.len() as u64;
    let strobe = if spec.bifurcation {
        spec.bifurcation_samples as u64 * 8
    } else {
        0
    };
    let slices = spec.axes.get(2).map_or(1, |a| a.values.len()) as u64;
    let pictures = (spec.metrics.len() as u64 * slices + 3) * PICTURE_BYTES;
    runs * (fields * (8 + CSV_BYTES_PER_VALUE) + strobe) + pictures
}

/// Refuse a map (or shard) whose files [`map_bytes`] would not fit in `disk_free` bytes
/// (`None` where it cannot be read: no check) on `out`'s file system.
pub fn check_map_disk(
    spec: &pendulum_atlas_core::config::MapSpec,
    shards: u32,
    disk_free: Option<u64>,
    out: &Path,
) -> Result<(), TooLarge> {
    let need = map_bytes(spec, shards);
    match disk_free {
        Some(free) if need > free => Err(TooLarge::MapDisk {
            dir: out.display().to_string(),
            need: bytes(need),
            available: bytes(free),
        }),
        _ => Ok(()),
    }
}

/// [`check_map_disk`] against the space free on `out`'s file system now.
pub fn check_map_fits(
    spec: &pendulum_atlas_core::config::MapSpec,
    shards: u32,
    out: &Path,
) -> Result<(), TooLarge> {
    check_map_disk(spec, shards, free_space(out), out)
}

impl RunSize {
    /// The size of a single run of `scene` over `plan` (the trajectory's columns with the
    /// piezo's when it is on); refused when it takes no step or more than the engines count.
    pub fn of_run(
        scene: &pendulum_atlas_core::config::Scene,
        plan: &pendulum_atlas_core::engine::StepPlan,
    ) -> Result<RunSize, TooLarge> {
        let duration_s = scene.integration.duration_s;
        let columns = super::row_columns(scene.piezo_params().is_some()).len();
        let adaptive = matches!(
            plan.control,
            pendulum_atlas_core::config::StepControl::Adaptive { .. }
        );
        let size = RunSize::new(duration_s, plan.dt_s, plan.sample_every, columns).map_err(
            |e| match e {
                TooLarge::Steps { steps, .. } => TooLarge::Steps { steps, adaptive },
                other => other,
            },
        )?;
        if size.steps == 0 {
            return Err(TooLarge::NoStep {
                duration_s,
                dt_s: plan.dt_s,
            });
        }
        Ok(size)
    }

    /// The size of a run of `duration_s / dt_s` steps writing a row every `sample_every` steps
    /// with `columns` CSV columns. Counts are computed in floating point first, so a step of
    /// 1e-300 s is a huge number, not a saturated integer.
    pub fn new(
        duration_s: f64,
        dt_s: f64,
        sample_every: u64,
        columns: usize,
    ) -> Result<RunSize, TooLarge> {
        let steps = (duration_s / dt_s).round();
        if steps.is_nan() || steps > MAX_STEPS as f64 {
            return Err(TooLarge::Steps {
                steps,
                adaptive: false,
            });
        }
        let steps = steps as u64;
        let rows = steps / sample_every.max(1) + 1;
        let per_row = std::mem::size_of::<Row>() as u64 + 16;
        Ok(RunSize {
            steps,
            rows,
            memory_bytes: rows * per_row,
            csv_bytes: rows * (columns as u64 * CSV_BYTES_PER_VALUE + 1),
        })
    }

    /// Refuse a run larger than the memory available now or the space free on `out`'s file
    /// system.
    pub fn check(&self, out: &Path) -> Result<(), TooLarge> {
        self.check_against(memory_available(), free_space(out), out)
    }

    /// Refuse a run larger than `memory_available` or `disk_free` on `out`'s file system
    /// (bytes; `None` where it cannot be read: no check).
    pub fn check_against(
        &self,
        memory_available: Option<u64>,
        disk_free: Option<u64>,
        out: &Path,
    ) -> Result<(), TooLarge> {
        if let Some(available) = memory_available
            && self.memory_bytes as f64 > MEMORY_SHARE * available as f64
        {
            return Err(TooLarge::Memory {
                rows: self.rows,
                need: bytes(self.memory_bytes),
                available: bytes(available),
            });
        }
        if let Some(free) = disk_free
            && self.csv_bytes > free
        {
            return Err(TooLarge::Disk {
                dir: out.display().to_string(),
                need: bytes(self.csv_bytes),
                available: bytes(free),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_vanishing_step_is_too_many_steps_not_a_saturated_count() {
        let e = RunSize::new(2.0, 1e-300, 1, 9).unwrap_err();
        assert!(
            matches!(e, TooLarge::Steps { steps, .. } if steps > 1e299),
            "{e}"
        );
        let ok = RunSize::new(2.0, 5e-4, 2, 9).unwrap();
        assert_eq!((ok.steps, ok.rows), (4000, 2001));
        assert_eq!(ok.csv_bytes, 2001 * (9 * 21 + 1));
    }

    /// A map is checked against the disk before any work (issue 71: a map that filled the
    /// disk ran whole first); the estimate holds the default map's files with room.
    #[test]
    fn a_map_larger_than_the_free_disk_is_refused_before_any_work() {
        let spec = pendulum_atlas_core::config::load_map(None, &[]).unwrap();
        let need = map_bytes(&spec, 1);
        // The default map writes 1.46 MB (runs/map, 2026-11-29); the bound is above it.
        assert!((1_460_000..40_000_000).contains(&need), "{need}");
        assert!(map_bytes(&spec, 4) < need);
        let e = check_map_disk(&spec, 1, Some(need - 1), Path::new("/full")).unwrap_err();
        assert!(matches!(e, TooLarge::MapDisk { .. }), "{e}");
        assert!(e.to_string().contains("/full has"), "{e}");
        assert!(check_map_disk(&spec, 1, Some(need), Path::new("/roomy")).is_ok());
        assert!(check_map_disk(&spec, 1, None, Path::new("/unknown")).is_ok());
    }

    #[test]
    fn memory_and_disk_beyond_the_machine_are_refused() {
        let big = RunSize::new(1e9, 1.0, 1, 9).unwrap();
        let e = big
            .check_against(Some(1_000_000), None, Path::new("."))
            .unwrap_err();
        assert!(matches!(e, TooLarge::Memory { .. }), "{e}");
        assert!(e.to_string().contains("1.0 MB"), "{e}");
        let e = big
            .check_against(None, Some(1_000_000_000), Path::new("/out"))
            .unwrap_err();
        assert!(matches!(e, TooLarge::Disk { .. }), "{e}");
        assert!(e.to_string().contains("/out has 1.0 GB free"), "{e}");
        let small = RunSize::new(2.0, 5e-4, 2, 9).unwrap();
        assert!(
            small
                .check_against(Some(1 << 30), Some(1 << 30), Path::new("."))
                .is_ok()
        );
        assert_eq!(bytes(999), "999 B");
        assert_eq!(bytes(1_500_000), "1.5 MB");
    }
}

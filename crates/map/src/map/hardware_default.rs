//! The embedded default map on a hardware GPU: the paper's N = 17 and the finest grid of
//! `GRIDS` that a probe on the adapter says finishes within `TARGET_S`, or the map as
//! written when none does.
//!
//! The CPU engine and the software adapter keep the embedded map as it is (N = 3, 64 × 48):
//! there it takes about ten seconds. A hardware GPU may have the throughput for the paper's
//! chain, so `map` without a scene asks this module for overrides:
//! 1. none when the user set `beam.segments` or `map.axes` (their choice stands);
//! 2. else, grid by grid from coarse to fine, a probe: the grid's own cells at N = 17 over two
//!    periods of 4 Hz (the first is the shortest transient a plan allows), α range only,
//!    gives the adapter's rate r(n) (instance-steps/s) at that grid's instance count n. The
//!    rate depends on n: a map of a few thousand instances fills a large GPU only partly (on
//!    an H200, 3072 instances of N = 17 ran 10× slower per instance-step than 16 384);
//! 3. the estimate of a grid is its work (the planned steps plus λ1's twin steps) / r(n) ×
//!    `REDUCE_MARGIN` (the reductions and the transfers). r(n)/n cannot grow with n, so the
//!    estimates grow with the grid and the probes stop at the first grid over the target;
//! 4. the finest grid within `TARGET_S` is taken; when even the coarsest is over it, the
//!    embedded map runs as written, and the message says what N = 17 would have cost.

use pendulum_atlas_core::config::{ConfigError, DEFAULT_MAP_TOML, map_from_toml};
use pendulum_atlas_core::engine::{Engine, EngineError, EnsemblePlan, Readback, no_progress};
use pendulum_atlas_core::reduce::ReduceOptions;

/// Grids (frequency count × amplitude count) from coarse to fine.
pub(crate) const GRIDS: [(usize, usize); 3] = [(64, 48), (128, 96), (256, 192)];

/// The wall time a default map should stay within (s).
pub(crate) const TARGET_S: f64 = 60.0;

/// Factor on the integration estimate for the reductions and transfers.
pub(crate) const REDUCE_MARGIN: f64 = 1.3;

/// The paper's segment count.
pub(crate) const PAPER_SEGMENTS: usize = 17;

/// What can stop the choice.
#[derive(Debug, thiserror::Error)]
pub enum HardwareDefaultError {
    /// The default map with the overrides is not a valid scene.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Planning or the probe failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

/// The overrides chosen for a hardware GPU and why.
#[derive(Debug, Clone, PartialEq)]
pub struct HardwareDefault {
    /// `--set` overrides to append (none: the map as written).
    pub sets: Vec<String>,
    /// One line for the user: each probed grid's rate and estimate, and the choice.
    pub reason: String,
}

/// One probed grid: its rate at its own instance count and its estimated wall time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct GridEstimate {
    /// Frequency count × amplitude count.
    pub grid: (usize, usize),
    /// Instance-steps per second of the probe at this grid's instance count.
    pub rate: f64,
    /// Work / rate × [`REDUCE_MARGIN`] (s).
    pub seconds: f64,
}

/// The `--set` override of the default map's axes on `grid`.
pub(crate) fn axes_set((nf, na): (usize, usize)) -> String {
    format!(
        "map.axes=[{{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count={nf}}},\
{{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count={na}}}]"
    )
}

/// Whether the user's overrides leave the choice to us.
pub fn applies(user_sets: &[String]) -> bool {
    !user_sets.iter().any(|s| {
        let key = s.split('=').next().unwrap_or("").trim();
        key == "beam.segments" || key.starts_with("map.axes")
    })
}

/// The finest probed grid within [`TARGET_S`] (estimates from coarse to fine), or `None`.
pub(crate) fn choose_grid(estimates: &[GridEstimate]) -> Option<(usize, usize)> {
    estimates
        .iter()
        .rev()
        .find(|e| e.seconds <= TARGET_S)
        .map(|e| e.grid)
}

/// The probe's overrides on `grid`: its cells over two periods of 4 Hz, α range only.
fn probe_sets(grid: (usize, usize)) -> Vec<String> {
    vec![
        axes_set(grid),
        "integration.transient_s=0.0".into(),
        "integration.duration_s=0.5".into(),
        "map.metrics=[\"alpha_range\"]".into(),
    ]
}

/// Steps a plan integrates: every instance's steps, plus its λ1 twin's over the twin's
/// periods (the twin is a second state integrated beside the main one).
pub(crate) fn work_steps(plan: &EnsemblePlan) -> u64 {
    plan.instances
        .iter()
        .map(|p| {
            let twin = p
                .twin
                .as_ref()
                .map_or(0, |t| u64::from(t.align + t.window) * u64::from(p.spp));
            p.total_steps() + twin
        })
        .sum()
}

/// Probe `engine` (a hardware GPU) and choose N = 17 with the finest grid that fits, or the
/// map as written.
pub fn hardware_default(
    engine: &Engine,
    user_sets: &[String],
) -> Result<Option<HardwareDefault>, HardwareDefaultError> {
    if !applies(user_sets) {
        return Ok(None);
    }
    let n_set = format!("beam.segments={PAPER_SEGMENTS}");
    let plan_of = |extra: &[String]| -> Result<EnsemblePlan, HardwareDefaultError> {
        let mut sets = user_sets.to_vec();
        sets.push(n_set.clone());
        sets.extend_from_slice(extra);
        let spec = map_from_toml(DEFAULT_MAP_TOML, "configs/maps/default.toml", &sets)?;
        Ok(EnsemblePlan::new(&spec)?)
    };
    let run = |plan: &EnsemblePlan| {
        engine.run(
            plan,
            &ReduceOptions::default(),
            Readback::default(),
            &no_progress,
        )
    };
    // The rate counts the integration dispatches alone, not the kernels' compilation.
    let mut estimates = Vec::new();
    for grid in GRIDS {
        let probe = plan_of(&probe_sets(grid))?;
        let rate = probe.total_steps as f64 / run(&probe)?.integration_s().max(1e-9);
        let work = work_steps(&plan_of(&[axes_set(grid)])?);
        let seconds = work as f64 / rate * REDUCE_MARGIN;
        estimates.push(GridEstimate {
            grid,
            rate,
            seconds,
        });
        if seconds > TARGET_S {
            break;
        }
    }
    Ok(Some(choice(&estimates, &n_set)))
}

/// The overrides and the message for the probed `estimates`.
fn choice(estimates: &[GridEstimate], n_set: &str) -> HardwareDefault {
    let listed: Vec<String> = estimates
        .iter()
        .map(|e| {
            format!(
                "{}x{} ~{:.0} s at {:.2e} instance-steps/s",
                e.grid.0, e.grid.1, e.seconds, e.rate
            )
        })
        .collect();
    let probes = format!(
        "probes at N = {PAPER_SEGMENTS}: {}; target {TARGET_S:.0} s",
        listed.join(", ")
    );
    match choose_grid(estimates) {
        Some((nf, na)) => HardwareDefault {
            sets: vec![n_set.to_string(), axes_set((nf, na))],
            reason: format!(
                "hardware GPU: the default map runs at the paper's N = {PAPER_SEGMENTS} on a {nf} x {na} grid \
({probes}; --set beam.segments or map.axes to choose yourself)"
            ),
        },
        None => HardwareDefault {
            sets: Vec::new(),
            reason: format!(
                "hardware GPU: the paper's N = {PAPER_SEGMENTS} would not finish within the target on this \
adapter ({probes}), so the default map runs as written (N = 3, 64 x 48); \
--set beam.segments=17 runs the paper's chain anyway"
            ),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimates(seconds: &[f64]) -> Vec<GridEstimate> {
        GRIDS
            .iter()
            .zip(seconds)
            .map(|(&grid, &seconds)| GridEstimate {
                grid,
                rate: 1e8,
                seconds,
            })
            .collect()
    }

    #[test]
    fn the_finest_grid_within_the_target_is_chosen() {
        assert_eq!(
            choose_grid(&estimates(&[13.0, 52.0, 208.0])),
            Some(GRIDS[1])
        );
        assert_eq!(choose_grid(&estimates(&[5.0, 20.0, 59.0])), Some(GRIDS[2]));
        // The probes stopped at the first grid over the target.
        assert_eq!(choose_grid(&estimates(&[13.0, 75.0])), Some(GRIDS[0]));
    }

    #[test]
    fn nothing_within_the_target_runs_the_map_as_written() {
        let c = choice(&estimates(&[290.0]), "beam.segments=17");
        assert!(c.sets.is_empty(), "{c:?}");
        assert!(
            c.reason.contains("as written") && c.reason.contains("~290 s"),
            "{}",
            c.reason
        );
        let c = choice(&estimates(&[30.0, 90.0]), "beam.segments=17");
        assert_eq!(
            c.sets,
            vec!["beam.segments=17".to_string(), axes_set(GRIDS[0])]
        );
    }

    #[test]
    fn the_work_counts_the_twin() {
        let plan = |sets: &[&str]| {
            let mut all = vec![format!("beam.segments=3"), axes_set((4, 2))];
            all.extend(sets.iter().map(|s| s.to_string()));
            EnsemblePlan::new(&map_from_toml(DEFAULT_MAP_TOML, "default", &all).unwrap()).unwrap()
        };
        let without = plan(&["map.metrics=[\"K\"]"]);
        assert_eq!(work_steps(&without), without.total_steps);
        let with = plan(&[]);
        assert!(
            work_steps(&with) > with.total_steps,
            "the default map has λ1"
        );
    }

    #[test]
    fn the_users_segments_or_axes_stand() {
        assert!(applies(&["map.metrics=[\"K\"]".into()]));
        assert!(!applies(&["beam.segments=5".into()]));
        assert!(!applies(&[axes_set((8, 8))]));
        assert!(!applies(&["map.axes[0].count = 8".into()]));
    }

    #[test]
    fn the_probe_is_a_valid_plan() {
        let mut sets = vec![format!("beam.segments={PAPER_SEGMENTS}")];
        sets.extend(probe_sets(GRIDS[0]));
        let spec = map_from_toml(DEFAULT_MAP_TOML, "default", &sets).unwrap();
        let plan = EnsemblePlan::new(&spec).unwrap();
        assert_eq!(plan.instances.len(), GRIDS[0].0 * GRIDS[0].1);
    }

    #[test]
    fn every_grid_is_a_valid_default_map() {
        for g in GRIDS {
            let sets = vec![format!("beam.segments={PAPER_SEGMENTS}"), axes_set(g)];
            let spec = map_from_toml(DEFAULT_MAP_TOML, "default", &sets).unwrap();
            assert_eq!(spec.instances(), g.0 * g.1);
        }
    }
}

//! The embedded default map on a hardware GPU: the paper's N = 17 and the finest grid of
//! [`GRIDS`] that a probe on the adapter says finishes within [`TARGET_S`].
//!
//! The CPU engine and the software adapter keep the embedded map as it is (N = 3, 64 × 48):
//! there it takes about ten seconds. A hardware GPU has the throughput for the paper's chain,
//! so `map` without a scene asks this module for overrides:
//! 1. none when the user set `beam.segments` or `map.axes` (their choice stands);
//! 2. else a probe: [`PROBE_INSTANCES`] instances of the map at N = 17 over two periods of its
//!    lowest frequency (the first is the shortest transient a plan allows), α range only,
//!    gives the adapter's rate r (instance-steps/s);
//! 3. the estimate of a grid is its planned instance-steps / r × [`REDUCE_MARGIN`] (the
//!    reductions and the transfers); the finest grid within [`TARGET_S`] is taken, the
//!    coarsest when none is.

use pendulum_atlas_core::config::{ConfigError, DEFAULT_MAP_TOML, map_from_toml};
use pendulum_atlas_core::engine::{Engine, EngineError, EnsemblePlan, Readback, no_progress};
use pendulum_atlas_core::reduce::ReduceOptions;

/// Grids (frequency count × amplitude count) from coarse to fine.
pub const GRIDS: [(usize, usize); 3] = [(64, 48), (128, 96), (256, 192)];

/// The wall time a default map should stay within (s).
pub const TARGET_S: f64 = 60.0;

/// Instances of the probe.
pub const PROBE_INSTANCES: usize = 16_384;

/// Factor on the integration estimate for the reductions and transfers.
pub const REDUCE_MARGIN: f64 = 1.3;

/// The paper's segment count.
pub const PAPER_SEGMENTS: usize = 17;

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
    /// `--set` overrides to append.
    pub sets: Vec<String>,
    /// One line for the user: the probe's rate and each grid's estimate.
    pub reason: String,
}

/// The `--set` override of the default map's axes on `grid`.
pub fn axes_set((nf, na): (usize, usize)) -> String {
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

/// The finest grid whose estimate (instance-steps / rate × margin) is within [`TARGET_S`],
/// else the coarsest; with each grid's estimate (s).
pub fn choose_grid(steps_per_grid: &[u64], rate: f64) -> (usize, Vec<f64>) {
    let est: Vec<f64> = steps_per_grid
        .iter()
        .map(|&s| s as f64 / rate * REDUCE_MARGIN)
        .collect();
    let pick = est.iter().rposition(|&t| t <= TARGET_S).unwrap_or(0);
    (pick, est)
}

/// The probe's overrides: [`PROBE_INSTANCES`] cells over two periods of 4 Hz, α range only.
fn probe_sets() -> Vec<String> {
    vec![
        axes_set((128, PROBE_INSTANCES / 128)),
        "integration.transient_s=0.0".into(),
        "integration.duration_s=0.5".into(),
        "map.metrics=[\"alpha_range\"]".into(),
    ]
}

/// Probe `engine` (a hardware GPU) and choose N = 17 with the finest grid that fits.
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
    let probe = plan_of(&probe_sets())?;
    engine.run(
        &probe,
        &ReduceOptions::default(),
        Readback::default(),
        &no_progress,
    )?;
    let run = engine.run(
        &probe,
        &ReduceOptions::default(),
        Readback::default(),
        &no_progress,
    )?;
    let rate = probe.total_steps as f64 / run.integration_s().max(1e-9);
    let steps: Vec<u64> = GRIDS
        .iter()
        .map(|&g| plan_of(&[axes_set(g)]).map(|p| p.total_steps))
        .collect::<Result<_, _>>()?;
    let (pick, est) = choose_grid(&steps, rate);
    let (nf, na) = GRIDS[pick];
    let listed: Vec<String> = GRIDS
        .iter()
        .zip(&est)
        .map(|((f, a), t)| format!("{f}x{a} ~{t:.0} s"))
        .collect();
    Ok(Some(HardwareDefault {
        sets: vec![n_set, axes_set((nf, na))],
        reason: format!(
            "hardware GPU: the default map runs at the paper's N = {PAPER_SEGMENTS} on a {nf} x {na} grid \
(probe: {rate:.3e} instance-steps/s at N = {PAPER_SEGMENTS}; estimates {}; target {TARGET_S:.0} s; \
--set beam.segments or map.axes to choose yourself)",
            listed.join(", ")
        ),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_finest_grid_within_the_target_is_chosen() {
        let steps = [1_000_000_u64, 4_000_000, 16_000_000];
        // 1e5 instance-steps/s: 13, 52 and 208 s (× 1.3) → the middle grid.
        let (pick, est) = choose_grid(&steps, 1e5);
        assert_eq!(pick, 1);
        assert!((est[0] - 13.0).abs() < 1e-9 && (est[2] - 208.0).abs() < 1e-9);
        assert_eq!(choose_grid(&steps, 1e7).0, 2);
        // Nothing fits: the coarsest.
        assert_eq!(choose_grid(&steps, 1e3).0, 0);
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
        sets.extend(probe_sets());
        let spec = map_from_toml(DEFAULT_MAP_TOML, "default", &sets).unwrap();
        let plan = EnsemblePlan::new(&spec).unwrap();
        assert_eq!(plan.instances.len(), PROBE_INSTANCES);
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

//! The workloads the throughput studies time: the default map at N segments with RK4 at fixed
//! steps, a few of its instances spread over its plane. The lab's peer cases (`benches/`) are
//! made from the same plans, so that the peers integrate what the studies time.

use pendulum_atlas_core::config::{ConfigError, DEFAULT_MAP_TOML, map_from_toml};
use pendulum_atlas_core::engine::{EngineError, EnsemblePlan};

/// Why a workload could not be planned.
#[derive(Debug, thiserror::Error)]
pub enum WorkloadError {
    /// The default map with the overrides is not a valid scene.
    #[error(transparent)]
    Config(#[from] ConfigError),
    /// Its plan could not be made.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

/// The default map at N segments with RK4 at fixed steps (and the overrides `extra`), the plan
/// of its `count` instances spread evenly over the grid.
pub fn default_map_plan(
    n: usize,
    count: usize,
    extra: &[&str],
) -> Result<EnsemblePlan, WorkloadError> {
    let mut sets = vec![
        format!("beam.segments={n}"),
        "integration.method=\"rk4\"".to_string(),
        "integration.step=\"fixed\"".to_string(),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let spec = map_from_toml(DEFAULT_MAP_TOML, "configs/maps/default.toml", &sets)?;
    let plan = EnsemblePlan::new(&spec)?;
    let total = plan.instances.len();
    let members: Vec<usize> = (0..count.min(total)).map(|i| i * total / count).collect();
    Ok(plan.select(&members))
}

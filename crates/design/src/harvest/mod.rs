//! Broadband-harvesting design search (issue 7): which clearance, bumper position, tip mass
//! and load give the most power over the widest band, against the linear clamped cantilever.
//!
//! The stages, in the order a search runs them:
//!
//! 1. [`spec`]: a harvester scene (piezo on) plus a `[search]` section, validated into a
//!    [`SearchSpec`]: design variables (any numeric scene keys), the band and its base
//!    excitation (constant acceleration or constant amplitude), initial states, threshold.
//! 2. [`search`]: the linear baseline, the grid of designs and the refinement rounds, each
//!    one batch of designs × initial states × frequencies on the ensemble engine
//!    ([`pendulum_atlas_map::map::run_plan`] on the engine the caller opened once), reduced to P(f) curves and ranked.
//! 3. [`band`]: the band metric of a P(f) curve: bandwidth above a threshold, band-averaged
//!    power, peak; robust (smallest over initial states) and mean curves.
//! 4. [`verify`]: the best design re-simulated with `simulate`'s own engine and step.
//! 5. [`files`] and [`figures`]: `designs.csv`, `instances.csv`, `best.md`,
//!    `best_design.toml`, `search.json`, `pareto.png`, `power_vs_frequency.png`.

pub mod band;
mod error;
pub mod figures;
pub mod files;
pub mod search;
pub mod spec;
pub mod verify;

pub use band::{BandMetrics, band_average_w, band_metrics, bandwidth_hz, mean_curve, robust_curve};
pub use error::HarvestError;
pub use files::{SearchManifest, write_search};
pub use search::{
    Baseline, DesignResult, SearchProgress, SearchRun, StageReport, TOP_POWER_SHARE, TopAttractor,
    run_search,
};
pub use spec::{
    BaseExcitation, DEFAULT_SEARCH_TOML, DesignVariable, InitialState, Objective, SearchSpec,
    Threshold, Weighting, load_search, search_from_toml,
};
pub use verify::{Resimulated, Verification, VerifiedPoint, simulate_power, verify_design};

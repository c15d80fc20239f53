//! What can stop a design search.

use thiserror::Error;

/// Errors of the search, its check and its files.
#[derive(Debug, Error)]
pub enum HarvestError {
    /// A design or instance scene is invalid.
    #[error(transparent)]
    Config(#[from] pendulum_atlas_core::config::ConfigError),
    /// A batch could not be integrated.
    #[error("{stage}: {source}")]
    Engine {
        /// The stage whose batch failed (`baseline`, `grid`, `refine 1`, ...).
        stage: String,
        /// The engine's reason.
        source: pendulum_atlas_core::engine::EngineError,
    },
    /// The linear baseline has no stable mode to zoom on.
    #[error("the clamped baseline has no stable mode")]
    NoBaselineMode,
    /// A threshold relative to the baseline needs a baseline with power.
    #[error(
        "the bandwidth threshold is relative to the linear baseline's peak, but the baseline has no valid power (peak {peak_w} W): give search.threshold.power_w instead"
    )]
    NoBaselinePower {
        /// The baseline's peak (W).
        peak_w: f64,
    },
    /// The best design could not be written as TOML.
    #[error("cannot write the best design as TOML: {0}")]
    Toml(toml::ser::Error),
    /// A file could not be written.
    #[error(transparent)]
    Output(#[from] pendulum_atlas_map::output::OutputError),
}

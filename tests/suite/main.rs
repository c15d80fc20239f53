//! The test suite, one binary split into modules by pipeline stage:
//! config → model → engine (every engine runs the same suite) → single runs → analysis →
//! outputs → command line.

mod analysis;
mod analyze_cli;
mod bench;
mod calibrate;
mod cli;
mod config;
mod contact;
mod engine;
mod explore;
mod harvest;
mod imex;
mod map;
mod messages;
mod model;
mod render;
mod reproduce;
mod shard;
mod single_run;
mod slurm;
mod throughput;

use pendulum_atlas::config::{PAPER_SCENE_TOML, Scene};

/// `map` arguments of a two-cell map (7.8 and 8 Hz at 1 mm, N = 3) run from 6 starts per
/// cell: both cells hold the two wells' period-1 orbits (the pinned bistable cell and its
/// neighbour).
pub const STARTS_MAP_SETS: [&str; 10] = [
    "--set",
    "map.axes=[{key=\"excitation.frequency_hz\",values=[7.8,8.0]},{key=\"excitation.amplitude_m\",values=[0.001]}]",
    "--set",
    "beam.segments=3",
    "--set",
    "integration.duration_s=30",
    "--set",
    "integration.transient_s=15",
    "--set",
    "map.initial_states=6",
];

/// The paper scene with `section.key=value` overrides.
pub fn scene(sets: &[&str]) -> Scene {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    Scene::from_toml(PAPER_SCENE_TOML, "<paper>", &sets).expect("valid test scene")
}

/// Error message of a scene that must fail validation.
pub fn scene_error(sets: &[&str]) -> String {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    Scene::from_toml(PAPER_SCENE_TOML, "<paper>", &sets)
        .expect_err("scene must be rejected")
        .to_string()
}

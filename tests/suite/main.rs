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

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
mod orbits;
mod render;
mod reproduce;
mod schema;
mod shard;
mod single_run;
mod slurm;
mod throughput;
mod transients;

use pendulum_atlas_core::config::{PAPER_SCENE_TOML, Scene};

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

/// `map` arguments of the pinned hysteresis (engine suite, `continuation.rs`): six cells from
/// 9 to 12 Hz at 1 mm (N = 3), run up and down; sweeping down holds a period-2 orbit from
/// 12 Hz to 10 Hz that sweeping up never reaches.
pub const HYSTERESIS_MAP_SETS: [&str; 16] = [
    "--set",
    "map.axes=[{key=\"excitation.frequency_hz\",values=[9.0,10.0,10.5,11.0,11.5,12.0]}]",
    "--set",
    "beam.segments=3",
    "--set",
    "integration.duration_s=36",
    "--set",
    "integration.transient_s=12",
    "--set",
    "excitation.amplitude_m=0.001",
    "--set",
    "map.metrics=[\"period\",\"alpha_range\",\"regime\"]",
    "--set",
    "map.lyapunov_window_s=6",
    "--set",
    "map.continuation=both",
];

/// `pendulum-atlas map --backend cpu --quiet --out OUT ARGS`, which must succeed: its stdout.
pub fn map_cli(out: &std::path::Path, args: &[&str]) -> String {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(out)
        .args(args)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

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

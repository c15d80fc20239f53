//! Planning a map: the default scene's forcing plane at 257 × 193 cells (the resolution of
//! `docs/bench/REFINE.md`), from the map scene to the ensemble plan the engines take.
//!
//! `cargo bench -p pendulum-atlas-core --bench plan` prints the median of five runs of each
//! stage: the map scene read and validated once; every cell's scene, read from its own table
//! (as every map was planned before the typed fields) and from typed fields
//! ([`MapSpec::run_scenes`]); and the whole plan (scenes, model parameters, steps, sampling)
//! both ways.
//!
//! [`MapSpec::run_scenes`]: pendulum_atlas_core::config::MapSpec::run_scenes

use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, map_from_toml};
use pendulum_atlas_core::engine::{EnsembleOptions, EnsemblePlan};
use rayon::prelude::*;
use std::time::Instant;

const RUNS: usize = 5;

fn median_s(mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..RUNS)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[RUNS / 2]
}

fn main() {
    let sets = [
        "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=257},{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=193}]".to_string(),
    ];
    let spec = map_from_toml(DEFAULT_MAP_TOML, "<default>", &sets).expect("default map");
    let cells = spec.instances();
    let read = median_s(|| {
        map_from_toml(DEFAULT_MAP_TOML, "<default>", &sets).expect("default map");
    });
    let table_scenes = median_s(|| {
        let scenes: Vec<_> = (0..cells)
            .into_par_iter()
            .map(|k| spec.run_scene(k).expect("scene"))
            .collect();
        std::hint::black_box(scenes);
    });
    let typed_scenes = median_s(|| {
        std::hint::black_box(spec.run_scenes().expect("scenes"));
    });
    let table_plan = median_s(|| {
        let scenes: Vec<_> = (0..cells)
            .into_par_iter()
            .map(|k| spec.run_scene(k).expect("scene"))
            .collect();
        let opts = EnsembleOptions::from_spec(&spec);
        std::hint::black_box(EnsemblePlan::from_scenes(&scenes, &opts).expect("plan"));
    });
    let plan = median_s(|| {
        std::hint::black_box(EnsemblePlan::new(&spec).expect("plan"));
    });
    println!("planning the default map at 257 x 193 = {cells} cells, median of {RUNS} runs:");
    println!("  map scene read and validated               {read:10.4} s");
    println!("  every cell's scene, each read from a table {table_scenes:10.4} s");
    println!("  every cell's scene, typed fields           {typed_scenes:10.4} s");
    println!("  the ensemble plan, scenes from tables      {table_plan:10.4} s");
    println!("  the ensemble plan (EnsemblePlan::new)      {plan:10.4} s");
}

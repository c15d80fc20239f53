//! Criterion benches of the hot pieces: the equations of motion (RHS), one RK4 step, and the
//! reductions K, R and the wavelet transform. `cargo bench` runs them; the end-to-end
//! work-precision study is `pendulum-atlas bench`.

use criterion::{Criterion, criterion_group, criterion_main};
use pendulum_atlas_core::analysis::{
    PhaseConvention, WaveletOptions, ZeroOneOptions, morlet_cwt, phase_sync, zero_one_test,
};
use pendulum_atlas_core::config::{PAPER_SCENE_TOML, Scene};
use pendulum_atlas_core::engine::rk4::{Rk4Scratch, rk4_step};
use pendulum_atlas_core::model::{Chain, ContactLaw};
use std::hint::black_box;

fn scene(n: usize) -> Scene {
    Scene::from_toml(PAPER_SCENE_TOML, "<bench>", &[format!("beam.segments={n}")]).unwrap()
}

fn rhs_and_step(c: &mut Criterion) {
    for n in [3usize, 17, 64] {
        let s = scene(n);
        let p = s.model_params().unwrap();
        let chain: Chain<f64> = Chain::new(&p);
        let mut ws = chain.workspace();
        let y = s.initial_state(&p);
        let mut dy = vec![0.0; y.len()];
        c.bench_function(&format!("rhs f64 N={n}"), |b| {
            b.iter(|| {
                chain.derivative(
                    &mut ws,
                    black_box(1.0),
                    black_box(&y),
                    &mut dy,
                    ContactLaw::Exact,
                )
            })
        });
        let chain32: Chain<f32> = Chain::new(&p);
        let mut ws32 = chain32.workspace();
        let mut y32: Vec<f32> = y.iter().map(|&v| v as f32).collect();
        let mut scratch = Rk4Scratch::new(y.len());
        c.bench_function(&format!("rk4 step f32 N={n}"), |b| {
            b.iter(|| {
                rk4_step(
                    &chain32,
                    &mut ws32,
                    &mut y32,
                    &mut scratch,
                    1e-7,
                    [1.0, 1.0, 1.0],
                )
            })
        });
    }
}

fn reductions(c: &mut Criterion) {
    // A chaotic series (logistic map) and a sine pair.
    let mut x = 0.1;
    let strobe: Vec<f64> = (0..500)
        .map(|_| {
            x = 3.97 * x * (1.0 - x);
            x
        })
        .collect();
    c.bench_function("K (0-1 test, 500 samples, 100 c)", |b| {
        b.iter(|| zero_one_test(black_box(&strobe), &ZeroOneOptions::default()).unwrap())
    });
    let t: Vec<f64> = (0..1024).map(|i| i as f64 / 128.0).collect();
    let a: Vec<f64> = t.iter().map(|t| (8.0 * t).sin()).collect();
    let b2: Vec<f64> = t
        .iter()
        .map(|t| (8.0 * t + 0.3 * (0.5 * t).sin()).sin())
        .collect();
    c.bench_function("R (phase sync, 1024 samples)", |b| {
        b.iter(|| phase_sync(black_box(&a), black_box(&b2), PhaseConvention::Standard).unwrap())
    });
    let sig: Vec<f64> = (0..2048)
        .map(|i| (i as f64 * 0.05).sin() + 0.3 * (i as f64 * 0.31).cos())
        .collect();
    c.bench_function("wavelet (Morlet, 2048 samples)", |b| {
        b.iter(|| morlet_cwt(black_box(&sig), 0.01, &WaveletOptions::default()).unwrap())
    });
}

criterion_group!(benches, rhs_and_step, reductions);
criterion_main!(benches);

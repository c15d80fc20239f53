//! A plan larger than one GPU run may hold is split into consecutive batches: the results, the
//! read-back series and the statuses equal those of a single run bit for bit, in plan order.

use super::gpu;
use pendulum_atlas_core::config::{Metric, PAPER_SCENE_TOML, Scene};
use pendulum_atlas_core::engine::{Backend, Engine, EnsembleOptions, EnsemblePlan, Readback};
use pendulum_atlas_core::reduce::ReduceOptions;

/// Eleven paper scenes across 6–11 Hz at N = 3, short enough for a test, every metric.
fn plan() -> EnsemblePlan {
    let scenes: Vec<Scene> = (0..11)
        .map(|i| {
            let sets = vec![
                "beam.segments=3".to_string(),
                format!("excitation.frequency_hz={}", 6.0 + 0.5 * i as f64),
                "integration.duration_s=18.0".to_string(),
                "integration.transient_s=1.0".to_string(),
            ];
            Scene::from_toml(PAPER_SCENE_TOML, "<paper>", &sets).unwrap()
        })
        .collect();
    let opts = EnsembleOptions {
        metrics: Metric::ALL[..6].to_vec(),
        keep_strobe: true,
        samples_per_period: 16,
        strobe_phase: 0.0,
        r_max_samples: 256,
        early_stop: None,
        lyapunov: Default::default(),
    };
    EnsemblePlan::from_scenes(&scenes, &opts).unwrap()
}

#[test]
fn a_plan_run_in_batches_equals_one_run_bit_for_bit() {
    if gpu().is_none() {
        return;
    }
    let plan = plan();
    let readback = Readback {
        strobe: true,
        r_series: true,
        ..Readback::default()
    };
    let run = |max: Option<usize>| {
        let mut engine = Engine::open(Backend::Gpu, None).unwrap();
        engine.set_gpu_max_batch(max);
        engine
            .run(&plan, &ReduceOptions::default(), readback, &|_, _, _| {
                std::ops::ControlFlow::Continue(())
            })
            .unwrap()
    };
    let whole = run(None);
    let batched = run(Some(4));
    assert_eq!(whole.results.len(), plan.instances.len());
    assert_eq!(batched.results.len(), plan.instances.len());
    for (i, (a, b)) in whole.results.iter().zip(&batched.results).enumerate() {
        let bits = |r: &pendulum_atlas_core::reduce::InstanceResult| {
            [
                r.k,
                r.r,
                r.period,
                r.hops,
                r.impacts_per_s,
                r.alpha_min_rad,
                r.alpha_max_rad,
                r.power_w,
                r.line,
            ]
            .map(f64::to_bits)
        };
        assert_eq!(bits(a), bits(b), "instance {i}: results differ");
        assert_eq!((a.status, a.steps), (b.status, b.steps), "instance {i}");
    }
    assert_eq!(whole.strobe, batched.strobe, "stroboscopic series");
    assert_eq!(whole.r_series, batched.r_series, "R series");
    assert!(whole.strobe.iter().all(|s| !s.is_empty()));
    assert!(
        batched.dispatches > whole.dispatches,
        "three batches take more dispatches than one run ({} against {})",
        batched.dispatches,
        whole.dispatches
    );
}

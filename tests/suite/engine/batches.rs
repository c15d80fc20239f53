//! A plan larger than one GPU run may hold is split into consecutive batches: the results, the
//! read-back series and the statuses equal those of a single run bit for bit, in plan order.

use super::{EVERY_METHOD_AND_STEP, gpu};
use pendulum_atlas_core::config::{Metric, PAPER_SCENE_TOML, Scene};
use pendulum_atlas_core::engine::{Backend, Engine, EnsembleOptions, EnsemblePlan, Readback};
use pendulum_atlas_core::reduce::ReduceOptions;

/// Eleven paper scenes across 6–11 Hz at N = 3, short enough for a test, the first six
/// metrics.
fn plan() -> EnsemblePlan {
    plan_with(&Metric::ALL[..6])
}

/// [`plan`] with `metrics`.
fn plan_with(metrics: &[Metric]) -> EnsemblePlan {
    paper_plan(metrics, (0..11).map(|i| 6.0 + 0.5 * i as f64), &[])
}

/// The paper's scene at N = 3 over 18 s (1 s transient) at each of `frequencies` (Hz), with
/// the settings `sets`, asking for `metrics`.
fn paper_plan(
    metrics: &[Metric],
    frequencies: impl Iterator<Item = f64>,
    sets: &[String],
) -> EnsemblePlan {
    let scenes: Vec<Scene> = frequencies
        .map(|f| {
            let mut all = vec![
                "beam.segments=3".to_string(),
                format!("excitation.frequency_hz={f}"),
                "integration.duration_s=18.0".to_string(),
                "integration.transient_s=1.0".to_string(),
            ];
            all.extend_from_slice(sets);
            Scene::from_toml(PAPER_SCENE_TOML, "<paper>", &all).unwrap()
        })
        .collect();
    let opts = EnsembleOptions {
        metrics: metrics.to_vec(),
        keep_strobe: true,
        samples_per_period: 16,
        strobe_phase: 0.0,
        r_max_samples: 256,
        early_stop: None,
        lyapunov: Default::default(),
        gpu_kernel: Default::default(),
    };
    EnsemblePlan::from_scenes(&scenes, &opts).unwrap()
}

/// The bits of a result's every float, to compare two runs bit for bit.
fn result_bits(r: &pendulum_atlas_core::reduce::InstanceResult) -> [u64; 10] {
    [
        r.k,
        r.r,
        r.period,
        r.hops,
        r.alpha_min_rad,
        r.alpha_max_rad,
        r.line,
        r.lyapunov_per_s,
        r.lyapunov_se_per_s,
        r.regime_confidence,
    ]
    .map(f64::to_bits)
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
    // The instances run different numbers of steps, so some finish and leave the live list
    // (compacted on the device, in blocks whose order is the device's) while others run on.
    let steps: std::collections::BTreeSet<u64> =
        plan.instances.iter().map(|p| p.total_steps()).collect();
    assert!(steps.len() > 5, "{steps:?}");
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

/// The GPU's round trips: the 0–1 test's passes go in one submission whatever the number of c
/// values, and the run reports its submissions and the bytes it read back (issue 44).
#[test]
fn the_zero_one_passes_take_one_submission_and_the_run_counts_its_round_trips() {
    let Some(engine) = gpu() else {
        return;
    };
    let plan = plan();
    let counts = |n_c: usize| {
        let mut reduce = ReduceOptions::default();
        reduce.zero_one.n_c = n_c;
        let run = engine
            .run(&plan, &reduce, Readback::default(), &|_, _, _| {
                std::ops::ControlFlow::Continue(())
            })
            .unwrap();
        let g = run.timings.gpu.expect("a GPU run has GPU timings");
        (g.submissions, g.read_back_bytes, run.dispatches)
    };
    // Each integration dispatch (their number follows the wall time) is one submission and
    // one read of one word, the device's count of the instances still integrating (the
    // compaction runs on the device); the rest is the reductions and results (and the kernel
    // clock's read, where the adapter has timestamps: one per 64 dispatches).
    let rest = |(subs, bytes, dispatches): (u64, u64, u32)| {
        let d = u64::from(dispatches);
        assert!(
            subs >= 2 * d && bytes >= 4 * d,
            "{subs} submissions, {bytes} bytes"
        );
        (subs - 2 * d, bytes - 4 * d)
    };
    let (few, bytes_few) = rest(counts(10));
    let (many, bytes_many) = rest(counts(100));
    assert_eq!(few, many, "10 and 100 c values take the same submissions");
    assert!(few <= 12, "{few} submissions besides the integration");
    // The accumulators of every instance come back, and no more with more c values.
    assert!(bytes_few >= 11 * 64, "{bytes_few} bytes");
    assert_eq!(bytes_few, bytes_many);
}

/// Only what is kept is read back: asking for each instance's last 8 stroboscopic samples
/// gives exactly the tails of the whole series, and copies fewer bytes back.
#[test]
fn a_strobe_tail_is_the_end_of_the_whole_series_and_costs_fewer_bytes() {
    let Some(engine) = gpu() else {
        return;
    };
    let plan = plan();
    let run = |last: Option<u32>| {
        let readback = Readback {
            strobe: true,
            strobe_last: last,
            ..Readback::default()
        };
        engine
            .run(&plan, &ReduceOptions::default(), readback, &|_, _, _| {
                std::ops::ControlFlow::Continue(())
            })
            .unwrap()
    };
    let whole = run(None);
    let tail = run(Some(8));
    for (i, (w, t)) in whole.strobe.iter().zip(&tail.strobe).enumerate() {
        assert!(w.len() > 8, "instance {i}: {} samples", w.len());
        assert_eq!(t.as_slice(), &w[w.len() - 8..], "instance {i}");
    }
    let bytes = |r: &pendulum_atlas_core::engine::EngineRun| {
        let g = r.timings.gpu.as_ref().unwrap();
        g.read_back_bytes - 4 * u64::from(r.dispatches)
    };
    assert!(
        bytes(&tail) < bytes(&whole),
        "{} vs {}",
        bytes(&tail),
        bytes(&whole)
    );
}

/// A run's results do not depend on how its steps are split into dispatches: the state's
/// summation compensation is carried from one dispatch to the next (`shaders/integrate.wgsl`),
/// so dispatches of at most 50 and 137 steps give the results of dispatches sized by wall time,
/// bit for bit, with λ1's twin, on fixed and adaptive RK4 and IMEX steps (with adaptive steps a
/// dispatch counts passes and may end within a base step). (Before, the compensation restarted at
/// zero with each dispatch; on hardware, where dispatches are sized by wall time, a map run twice
/// could differ.)
#[test]
fn results_do_not_depend_on_the_dispatch_size() {
    if gpu().is_none() {
        return;
    }
    for (method, step) in EVERY_METHOD_AND_STEP {
        let metrics = [
            Metric::K,
            Metric::R,
            Metric::Period,
            Metric::Hops,
            Metric::Lyapunov,
        ];
        let sets = [
            format!("integration.method=\"{method}\""),
            format!("integration.step=\"{step}\""),
        ];
        let plan = paper_plan(&metrics, (0..6).map(|i| 6.0 + i as f64), &sets);
        let run = |steps: Option<u64>| {
            let mut engine = Engine::open(Backend::Gpu, None).unwrap();
            engine.set_gpu_dispatch_steps(steps);
            let r = engine
                .run(
                    &plan,
                    &ReduceOptions::default(),
                    Readback::default(),
                    &|_, _, _| std::ops::ControlFlow::Continue(()),
                )
                .unwrap();
            (r.dispatches, r.results)
        };
        let (n_whole, whole) = run(None);
        assert!(
            whole.iter().any(|r| r.lyapunov_per_s.is_finite()),
            "{method}"
        );
        for steps in [50, 137] {
            let (n, split) = run(Some(steps));
            assert!(
                n > n_whole,
                "{method}: {n} dispatches of {steps} steps, {n_whole} whole"
            );
            for (i, (a, b)) in whole.iter().zip(&split).enumerate() {
                assert_eq!(
                    result_bits(a),
                    result_bits(b),
                    "{method}, {steps} steps a dispatch, instance {i}"
                );
            }
        }
    }
}

/// The reductions run in slices (dispatches over part of the instances, `slices.rs`): with
/// slices of three instances, and with the first pass timed over four and the slices sized
/// from it, every metric equals that of unsliced dispatches, bit for bit.
#[test]
fn reductions_in_slices_equal_unsliced_reductions_bit_for_bit() {
    use pendulum_atlas_core::engine::gpu::slices::Slicing;
    if gpu().is_none() {
        return;
    }
    let plan = plan_with(&Metric::ALL);
    let run = |slicing: Option<Slicing>| {
        let mut engine = Engine::open(Backend::Gpu, None).unwrap();
        engine.set_gpu_reduce_slice(slicing);
        engine
            .run(
                &plan,
                &ReduceOptions::default(),
                Readback::default(),
                &|_, _, _| std::ops::ControlFlow::Continue(()),
            )
            .unwrap()
            .results
    };
    let whole = run(None);
    assert!(
        whole
            .iter()
            .any(|r| r.k.is_finite() && r.lyapunov_per_s.is_finite())
    );
    for slicing in [Slicing::Fixed(3), Slicing::Probe(4)] {
        let sliced = run(Some(slicing));
        for (i, (a, b)) in whole.iter().zip(&sliced).enumerate() {
            assert_eq!(
                result_bits(a),
                result_bits(b),
                "{slicing:?}, instance {i}: results differ"
            );
            assert_eq!(a.regime, b.regime, "{slicing:?}, instance {i}");
        }
    }
}

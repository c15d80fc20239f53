//! The work-precision report: files, table and pictures from a study's results.

use pendulum_atlas_core::engine::{EngineKind, Precision};
use pendulum_atlas_studies::bench::report::write_bench;
use pendulum_atlas_studies::bench::{BenchConfig, BenchReport, ConfigResult, KOnly, Scaling};

fn config(n: usize, precision: Precision, err: f64, cost: f64) -> ConfigResult {
    ConfigResult {
        config: BenchConfig {
            segments: n,
            dt_factor: 1.0,
            precision,
            backend: EngineKind::Cpu,
        },
        dt_s: 1e-4,
        alpha_err_rad: err,
        map_wall_s: cost * 100.0,
        cost_per_instance_s: cost,
        instance_steps_per_s: 1e6,
        segment_steps_per_s: 1e6 * n as f64,
        mean_abs_dk: 0.1,
        mean_abs_dr: 0.05,
        k_class_changed: 0.125,
        period_changed: 0.0,
        failed: 0,
    }
}

#[test]
fn bench_report_writes_table_json_and_pictures() {
    let report = BenchReport {
        quick: true,
        machine: "test".into(),
        horizon_s: 0.5,
        reference_map: "tiny".into(),
        reference_wall_s: 1.0,
        reference_map_wall_s: 2.0,
        configs: vec![
            config(3, Precision::F64, 1e-2, 1e-3),
            config(9, Precision::F64, 2e-4, 1e-2),
            config(3, Precision::F32, 1.1e-2, 8e-4),
            config(9, Precision::F32, 3e-4, 9e-3),
        ],
        scaling: Scaling {
            per_step_vs_segments: vec![(1, 200.0, 200.0), (4, 500.0, 125.0)],
            wall_vs_instances: vec![(16, 0.1)],
            wall_vs_duration: vec![(2.0, 0.1)],
            threads: Some((2.0, 1.0, 2.0)),
            gpu: None,
        },
        k_only: vec![KOnly {
            backend: EngineKind::Cpu,
            all_metrics_s: 1.0,
            k_only_s: 0.5,
            speedup: 2.0,
        }],
        total_s: 3.0,
    };
    let dir = std::env::temp_dir().join(format!("pendulum-atlas-bench-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    write_bench(&dir, &report).unwrap();
    let md = std::fs::read_to_string(dir.join("BENCHMARKS.md")).unwrap();
    assert!(md.contains("| 9 | cpu f32 dt=1x auto |"), "{md}");
    assert!(md.contains("speed-up 2.00x"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("bench.json")).unwrap()).unwrap();
    assert_eq!(json["configs"].as_array().unwrap().len(), 4);
    for png in ["work_precision.png", "map_error.png"] {
        let img = image::open(dir.join(png)).unwrap();
        assert!(img.width() >= 600 && img.height() >= 400);
    }
}

#[test]
fn the_stiff_study_compares_rk4_and_imex_against_the_reference() {
    use pendulum_atlas_core::engine::method::Method;
    use pendulum_atlas_studies::bench::stiff::{Reading, StiffOptions, run_stiff};
    use pendulum_atlas_studies::bench::stiff_report::markdown;
    let r = run_stiff(
        &StiffOptions {
            quick: true,
            gpu: None,
        },
        &|_| {},
    )
    .expect("study");
    // N = 5, both readings, RK4 at 1x, IMEX at 4, 1 and 0.25x and adaptive at rtol 1e-3 and
    // 1e-4, CPU f64 and f32.
    assert_eq!(r.horizon.len(), 2 * 6 * 2);
    assert_eq!(r.horizon.iter().filter(|h| h.rtol.is_some()).count(), 8);
    for h in &r.horizon {
        assert_eq!(h.segments, 5);
        assert!(h.alpha_err_rad.is_finite(), "{h:?}");
        // Each method at its automatic step, and adaptive steps 10x tighter than the default
        // tolerance, are within 1e-4 rad of DOP853 over 0.5 s.
        if (h.dt_factor == 1.0 && h.rtol.is_none()) || h.rtol == Some(1e-4) {
            assert!(h.alpha_err_rad < 1e-4, "{h:?}");
        }
    }
    // The library damping shortens RK4's step (stiffer joints), not the IMEX method's.
    let dt = |reading: Reading, method: Method| {
        r.horizon
            .iter()
            .find(|h| {
                h.reading == reading && h.method == method && h.dt_factor == 1.0 && h.rtol.is_none()
            })
            .map(|h| h.dt_s)
            .expect("row")
    };
    assert!(dt(Reading::Library, Method::Rk4) < 0.5 * dt(Reading::Earlier, Method::Rk4));
    assert_eq!(
        dt(Reading::Library, Method::Imex),
        dt(Reading::Earlier, Method::Imex)
    );
    // Maps: RK4's reference against itself, then IMEX at fixed and at adaptive steps on each
    // CPU engine.
    assert_eq!(r.maps.len(), 5);
    assert_eq!(r.maps.iter().filter(|m| m.rtol.is_some()).count(), 2);
    assert_eq!(r.maps[0].k_class_agree, 1.0);
    assert!(r.maps.iter().all(|m| m.cells > 0));
    let page = markdown(&r);
    assert!(page.contains("Wall time at the same α error"), "{page}");
}

#[test]
fn the_stiff_map_study_counts_agreement_on_classified_and_settled_cells() {
    use pendulum_atlas_studies::bench::stiff_map::{StiffMapOptions, agreement, run_stiff_map};
    use pendulum_atlas_studies::bench::stiff_map_report::markdown;
    let r = run_stiff_map(
        &StiffMapOptions {
            quick: true,
            gpu: None,
        },
        &|_| {},
    )
    .expect("study");
    let labels: Vec<&str> = r.maps.iter().map(|m| m.label.as_str()).collect();
    assert_eq!(labels, ["rk4", "imex", "imex-twin", "imex-half", "imex"]);
    assert_eq!(r.cells.len(), 4);
    assert!(r.maps.iter().all(|m| m.k.len() == 4 && m.period.len() == 4));
    // The half step is half the IMEX step (to within the fit to whole steps per sample).
    let ratio = r.maps[3].dt_s / r.maps[1].dt_s;
    assert!((ratio - 0.5).abs() < 0.01, "{ratio}");
    // The reference agrees with itself on every classified cell.
    let own = agreement(&r.maps[0], &r.maps[0], &r.classified);
    assert_eq!(
        (own.k_class, own.period, own.both),
        (own.cells, own.cells, own.cells)
    );
    // Settled: exactly the classified cells where imex, its twin and its half step agree.
    for &c in &r.classified {
        let same = |i: usize| r.maps[1].agrees(&r.maps[i], c) == (true, true);
        assert_eq!(r.settled.contains(&c), same(2) && same(3), "cell {c}");
    }
    assert_eq!(r.over_classified.len(), 4);
    assert!(r.over_settled.iter().all(|a| a.cells == r.settled.len()));
    let page = markdown(&r);
    assert!(page.contains("The floor"), "{page}");
}

#[test]
fn every_map_of_the_study_gives_k_enough_samples() {
    // A study that stops on its own map with "the 0-1 test needs at least 95 samples" is a
    // broken command: plan each of its maps with K the way the study does.
    use pendulum_atlas_core::config::Metric;
    use pendulum_atlas_core::engine::{EnsembleOptions, EnsemblePlan};
    for quick in [true, false] {
        let opts = EnsembleOptions {
            metrics: vec![Metric::K, Metric::R, Metric::Period],
            keep_strobe: false,
            samples_per_period: 16,
            strobe_phase: 0.0,
            r_max_samples: 1024,
            early_stop: None,
            lyapunov: Default::default(),
            gpu_kernel: Default::default(),
        };
        for s in pendulum_atlas_studies::bench::study_scenes(quick).unwrap() {
            EnsemblePlan::from_scenes(std::slice::from_ref(&s), &opts)
                .unwrap_or_else(|e| panic!("quick = {quick}: {e}"));
        }
    }
}

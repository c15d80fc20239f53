//! The work-precision report: files, table and pictures from a study's results.

use pendulum_atlas_core::config::SettleFrom;
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
        };
        for s in pendulum_atlas_studies::bench::study_scenes(quick).unwrap() {
            EnsemblePlan::from_scenes(std::slice::from_ref(&s), &opts)
                .unwrap_or_else(|e| panic!("quick = {quick}: {e}"));
        }
    }
}

/// Every plane of the verdict study is a map of 64 × 48 cells (so that its subgrids thin
/// alike) over two keys, with the verdict among its metrics and settling on.
#[test]
fn every_plane_of_the_verdict_study_is_a_settling_map_of_64_by_48_cells() {
    use pendulum_atlas_core::config::Metric;
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_studies::bench::verdict::Plane;
    let mut keys = Vec::new();
    for p in Plane::ALL {
        let spec = map_from_toml(p.scene(), p.path(), &[]).unwrap_or_else(|e| panic!("{p:?}: {e}"));
        assert_eq!(spec.shape(), vec![64, 48], "{p:?}");
        assert!(spec.metrics.contains(&Metric::Regime), "{p:?}");
        assert!(spec.settle_max_s.is_some(), "{p:?} does not settle");
        keys.push((
            spec.axes.iter().map(|a| a.key.clone()).collect::<Vec<_>>(),
            spec.scene.piezo.enabled,
        ));
    }
    // No two planes are the same map.
    assert!(
        keys[0] != keys[1] && keys[1] != keys[2] && keys[0] != keys[2],
        "{keys:?}"
    );
}

#[test]
fn the_verdict_study_scores_candidates_on_the_settled_cells_of_its_reference() {
    use pendulum_atlas_studies::bench::verdict::{Decider, Plane, VerdictOptions, run_verdict};
    use pendulum_atlas_studies::bench::verdict_report::write_verdict;
    let r = run_verdict(
        &VerdictOptions {
            quick: true,
            gpu: None,
            plane: Plane::Forcing,
            kept: None,
        },
        &|_| {},
    )
    .expect("study");
    let f = &r.reference;
    // The default map's 64 x 48 grid at every 8th value.
    assert_eq!((r.shape, f.cells), ([8, 6], 48));
    assert_eq!(f.regime.len(), 48);
    assert_eq!(f.counts.iter().sum::<usize>(), 48);
    assert_eq!(f.settled, f.is_settled.iter().filter(|s| **s).count());
    assert!(f.settled + f.changed <= 48, "{f:?}");
    // Subgrid A's reference checks its steps as well as its length; B's its length only.
    assert!(f.tightened.is_some_and(|n| n <= 48), "{f:?}");
    assert_eq!(r.second.tightened, None);
    for s in &r.scores {
        assert_eq!((s.settled, s.cells), (f.settled, 48));
        assert!(
            s.agree <= s.settled && s.period_right <= s.periodic,
            "{s:?}"
        );
        assert!(
            s.ref_periodic <= s.settled && s.ref_period_found <= s.ref_periodic,
            "{s:?}"
        );
    }
    // K and the period alone always decide; the rule may leave cells undecided.
    let k = &r.scores[0];
    assert_eq!(k.candidate.decider, Decider::KAndPeriod);
    assert_eq!(k.undecided, 0);
    assert!(
        r.scores
            .iter()
            .any(|s| s.candidate.decider == Decider::Rule)
    );
    // The reliability: every settled cell with a verdict is in one bin, the firm cells are
    // those of the bins from 0.9, and every fitted accuracy is a share (or NaN: no cell).
    let rel = &r.reliability;
    for (name, rows, firm) in &rel.tables {
        let binned: usize = rows.iter().map(|b| b.cells).sum();
        assert!(
            binned <= firm.settled,
            "{name}: {binned} of {}",
            firm.settled
        );
        let from_09: usize = rows.iter().filter(|b| b.from >= 0.9).map(|b| b.cells).sum();
        assert_eq!(firm.cells, from_09, "{name}");
        assert!(rows.iter().all(|b| b.right <= b.cells), "{name}");
    }
    assert_eq!(rel.tables[0].2.settled, f.settled);
    assert_eq!(rel.tables[1].2.settled, r.second.settled);
    for (_, t, _) in &rel.cross {
        for v in [t.chaotic_all, t.chaotic_some, t.periodic_half, t.regular] {
            assert!(v.is_nan() || (0.0..=1.0).contains(&v), "{t:?}");
        }
    }
    // Settling: the transient-chaos cells are chaotic cells of the map, each stopped by the
    // reference or run to its end; the curve starts unsettled, then runs cells on at 68 s.
    let g = &r.settling;
    let t = &g.transient;
    assert_eq!(t.settled, f.settled + r.second.settled);
    assert!(
        t.settle_later <= t.chaotic && t.chaotic <= t.settled,
        "{t:?}"
    );
    assert_eq!(t.stop_s.len() + t.not_stopped, t.settle_later);
    let longest = f.durations_s[1];
    assert!(t.stop_s.windows(2).all(|w| w[0] <= w[1]), "{t:?}");
    assert!(t.stop_s.iter().all(|&x| x > 0.0 && x <= longest), "{t:?}");
    assert_eq!(g.curve.len(), 3);
    let (off, on, start) = (&g.curve[0], &g.curve[1], &g.curve[2]);
    assert_eq!((off.settle_max_s, off.rerun, off.changed), (None, 0, 0));
    assert_eq!(on.settle_max_s, Some(68.0));
    assert_eq!(
        (on.from, start.from),
        (Some(SettleFrom::End), Some(SettleFrom::Start))
    );
    assert!(on.rerun > 0 && on.changed <= on.rerun, "{on:?}");
    // Both ways run the same cells on (their first runs are the same map).
    assert_eq!(start.rerun, on.rerun, "{start:?}");
    for p in &g.curve {
        assert_eq!(p.settled, t.settled);
        assert!(
            p.right <= p.settled && p.transient_right <= t.settle_later,
            "{p:?}"
        );
        assert!(
            p.firm.right <= p.firm.cells && p.firm.cells <= p.settled,
            "{p:?}"
        );
    }
    assert_eq!(
        g.reliability.shipped,
        pendulum_atlas_map::map::confidence::SETTLED
    );
    let dir = std::env::temp_dir().join(format!("pendulum-atlas-verdict-{}", std::process::id()));
    let files = write_verdict(&dir, &r).expect("files");
    let page = std::fs::read_to_string(dir.join("VERDICT.md")).unwrap();
    assert!(
        page.contains("change the verdict") || page.contains("changes the verdict"),
        "{page}"
    );
    assert!(page.contains("λ1 + period + K (rule)"), "{page}");
    assert!(
        page.contains("## Reliability of `verdict_confidence`"),
        "{page}"
    );
    assert!(
        page.contains("## Transient chaos and settling (`map.settle_max_s`)"),
        "{page}"
    );
    assert_eq!(files.len(), 2);
    // A fit across planes reads the scored cells back: the raw map's and the settled map's,
    // both subgrids, as the study scored them.
    let back = pendulum_atlas_studies::bench::planes::read_plane(&dir).expect("read back");
    assert_eq!(back.plane, Plane::Forcing);
    assert_eq!(back.raw.len(), f.settled + r.second.settled);
    assert_eq!(back.settled.len(), back.raw.len());
    let right = |cells: &[pendulum_atlas_studies::bench::reliability::ScoredCell]| {
        cells.iter().filter(|c| c.right).count()
    };
    let binned = |rel: &pendulum_atlas_studies::bench::reliability::Reliability| {
        rel.tables[2].1.iter().map(|b| b.right).sum::<usize>()
    };
    let unbinned = |cells: &[pendulum_atlas_studies::bench::reliability::ScoredCell]| {
        cells
            .iter()
            .filter(|c| c.confidence.is_none() && c.right)
            .count()
    };
    assert_eq!(right(&back.raw), binned(rel) + unbinned(&back.raw));
    assert_eq!(
        right(&back.settled),
        binned(&g.reliability) + unbinned(&back.settled)
    );
    // A later study may keep both references (`--reference-from`): they read back as they
    // were, NaN periods included; another plane or subgrid is refused by name.
    use pendulum_atlas_studies::bench::reference::kept_references;
    use pendulum_atlas_studies::bench::verdict::{reference_durations, thinning};
    let (ka, kb) = kept_references(
        &dir,
        Plane::Forcing,
        thinning(true),
        reference_durations(true),
    )
    .expect("kept references");
    let same = |x: &[f64], y: &[f64]| {
        x.len() == y.len()
            && x.iter()
                .zip(y)
                .all(|(a, b)| a == b || (a.is_nan() && b.is_nan()))
    };
    assert_eq!((&ka.regime, &ka.is_settled), (&f.regime, &f.is_settled));
    assert!(same(&ka.period, &f.period) && same(&ka.stop_s, &f.stop_s));
    assert_eq!(
        (&kb.regime, kb.settled),
        (&r.second.regime, r.second.settled)
    );
    let other = kept_references(
        &dir,
        Plane::Clearance,
        thinning(true),
        reference_durations(true),
    )
    .expect_err("another plane");
    assert!(
        other.to_string().contains("its plane is `forcing`"),
        "{other}"
    );
    let full = kept_references(
        &dir,
        Plane::Forcing,
        thinning(false),
        reference_durations(false),
    )
    .expect_err("another subgrid");
    assert!(full.to_string().contains("every 8th value"), "{full}");
    std::fs::remove_dir_all(&dir).ok();
}

//! The lab's verdict study (`pendulum-atlas-lab verdict`): its planes, a quick study scored
//! against its own reference, its files read back, and its references kept for a later study.

use pendulum_atlas_core::config::SettleFrom;

/// Every plane of the verdict study is a map of 64 × 48 cells (so that its subgrids thin
/// alike) over two keys, with the verdict among its metrics and settling on.
#[test]
fn every_plane_of_the_verdict_study_is_a_settling_map_of_64_by_48_cells() {
    use pendulum_atlas_core::config::Metric;
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_lab::verdict::Plane;
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
    use pendulum_atlas_lab::verdict::{Decider, Plane, VerdictOptions, run_verdict};
    use pendulum_atlas_lab::verdict_report::write_verdict;
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
    // The default map's 64 x 48 grid at every 16th value.
    assert_eq!((r.shape, f.cells), ([4, 3], 12));
    assert_eq!(f.regime.len(), 12);
    assert_eq!(f.counts.iter().sum::<usize>(), 12);
    assert_eq!(f.settled, f.is_settled.iter().filter(|s| **s).count());
    assert!(f.settled + f.changed <= 12, "{f:?}");
    // Subgrid A's reference checks its steps as well as its length; B's its length only.
    assert!(f.tightened.is_some_and(|n| n <= 12), "{f:?}");
    assert_eq!(r.second.tightened, None);
    for s in &r.scores {
        assert_eq!((s.settled, s.cells), (f.settled, 12));
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
    let back = pendulum_atlas_lab::planes::read_plane(&dir).expect("read back");
    assert_eq!(back.plane, Plane::Forcing);
    assert_eq!(back.raw.len(), f.settled + r.second.settled);
    assert_eq!(back.settled.len(), back.raw.len());
    let right = |cells: &[pendulum_atlas_lab::reliability::ScoredCell]| {
        cells.iter().filter(|c| c.right).count()
    };
    let binned = |rel: &pendulum_atlas_lab::reliability::Reliability| {
        rel.tables[2].1.iter().map(|b| b.right).sum::<usize>()
    };
    let unbinned = |cells: &[pendulum_atlas_lab::reliability::ScoredCell]| {
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
    use pendulum_atlas_lab::kept::kept_references;
    use pendulum_atlas_lab::verdict::{reference_durations, thinning};
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
    assert!(full.to_string().contains("every 16th value"), "{full}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The lab's command refuses what it cannot do by name, with a non-zero status and no folder
/// left behind: one study to fit across planes, and references it cannot read.
#[test]
fn the_lab_refuses_a_single_plane_and_a_missing_reference_by_name() {
    let lab = env!("CARGO_BIN_EXE_pendulum-atlas-lab");
    let tmp = std::env::temp_dir().join(format!("pendulum-atlas-lab-cli-{}", std::process::id()));
    let out = tmp.join("out");
    let run = |args: &[&str]| {
        std::process::Command::new(lab)
            .args(args)
            .output()
            .expect("the lab runs")
    };
    let one = run(&["verdict-fit", "docs/bench", "--out", out.to_str().unwrap()]);
    assert_eq!(one.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&one.stderr).contains("required"),
        "{}",
        String::from_utf8_lossy(&one.stderr)
    );
    let missing = tmp.join("no-such-study");
    let kept = run(&[
        "verdict",
        "--quick",
        "--reference-from",
        missing.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(kept.status.code(), Some(2));
    let err = String::from_utf8_lossy(&kept.stderr);
    assert!(
        err.contains("cannot read") && err.contains("verdict.json"),
        "{err}"
    );
    assert!(
        !out.exists(),
        "the refused study left {} behind",
        out.display()
    );
    std::fs::remove_dir_all(&tmp).ok();
}

//! What a map skips, on every engine (cases of the engine suite, see `mod.rs`): the early stop
//! of a confirmed periodic orbit gives the indicators the full run gives, and adaptive
//! refinement keeps every cell it computes as the full map has it and fills only blocks whose
//! corners agree.

use super::Under;
use super::cases::tiny_map;
use pendulum_atlas_core::config::MapSpec;
use pendulum_atlas_core::engine::early::EARLY_LYAPUNOV_REL_SE;
use pendulum_atlas_core::engine::no_progress;
use pendulum_atlas_core::reduce::{InstanceResult, Regime};
use pendulum_atlas_map::map::{MapRun, run_map};

fn map_on(under: Under, spec: &MapSpec) -> Option<MapRun> {
    let engine = under.engine()?;
    Some(run_map(spec, engine, &no_progress).expect("map"))
}

/// The default map's plane at a period-3 cell of its subharmonic tongue (8.44 Hz, 23.7 mm,
/// which settles and whose λ1 is precise enough to stop on every engine), chaotic and
/// settling cells, every metric of the default map and the line, λ1 over the last 12 s.
fn plane_cells(under: Under, early: bool) -> MapSpec {
    tiny_map(
        under,
        "[integration]\nduration_s = 34.0\ntransient_s = 10.0",
        &format!(
            "metrics = [\"K\", \"R\", \"period\", \"hops\", \"impacts_per_s\", \"alpha_range\", \"regime\", \"line\"]\n\
             lyapunov_window_s = 12.0\nearly_stop = {early}\n\
             [[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [4.0, 8.444444444444445, 11.11111111111111]\n\
             [[map.axes]]\nkey = \"excitation.amplitude_m\"\nvalues = [0.009, 0.023659574468085108]\n"
        ),
    )
}

pub fn a_map_with_the_early_stop_equals_the_map_without_it(under: Under) {
    let (Some(full), Some(early)) = (
        map_on(under, &plane_cells(under, false)),
        map_on(under, &plane_cells(under, true)),
    ) else {
        return;
    };
    assert_eq!(full.stopped_early, 0);
    assert!(
        early.stopped_early >= 1,
        "the period-3 orbit at 8.44 Hz, 23.7 mm settles and stops"
    );
    // The continued cycle repeats within the confirmation tolerance (1e-5 in f64, 1e-4 in f32).
    let (k_tol, r_tol, line_tol) = if under.is_f32() {
        (5e-3, 1e-4, 1e-5)
    } else {
        (1e-4, 1e-6, 1e-8)
    };
    for (k, (a, b)) in full.results.iter().zip(&early.results).enumerate() {
        let at = format!("cell {k}: {a:?} vs {b:?}");
        assert_eq!(a.regime, b.regime, "{at}");
        assert_eq!(a.period.to_bits(), b.period.to_bits(), "{at}");
        assert_eq!(a.hops.to_bits(), b.hops.to_bits(), "{at}");
        assert_eq!(a.impacts_per_s.to_bits(), b.impacts_per_s.to_bits(), "{at}");
        assert!((a.k - b.k).abs() <= k_tol, "K {at}");
        assert!((a.r - b.r).abs() <= r_tol, "R {at}");
        assert!((a.alpha_max_rad - b.alpha_max_rad).abs() <= 1e-6, "{at}");
        assert!((a.alpha_min_rad - b.alpha_min_rad).abs() <= 1e-6, "{at}");
        assert!(
            (a.line - b.line).abs() <= line_tol || (a.line.is_nan() && b.line.is_nan()),
            "line {at}"
        );
        if b.steps < a.steps {
            assert_eq!(
                b.regime,
                Regime::Periodic,
                "only a stable orbit stops: {at}"
            );
            assert!(b.lyapunov_per_s < 0.0, "{at}");
            // Its λ1 is the confirmed cycle's, measured to the early stop's precision.
            assert!(
                b.lyapunov_se_per_s <= EARLY_LYAPUNOV_REL_SE * b.lyapunov_per_s.abs(),
                "{at}"
            );
            let spread = 2.0 * (a.lyapunov_se_per_s + b.lyapunov_se_per_s);
            assert!(
                (a.lyapunov_per_s - b.lyapunov_per_s).abs()
                    <= 0.05 * a.lyapunov_per_s.abs() + spread,
                "λ1 of the stopped cycle against the full run's: {at}"
            );
        } else {
            assert_eq!(
                a.lyapunov_per_s.to_bits(),
                b.lyapunov_per_s.to_bits(),
                "{at}"
            );
        }
    }
}

/// A 9 × 5 grid of the default map's plane, refined from a lattice of every 4th point.
fn refined_plane(under: Under, refine: bool, audit: f64) -> MapSpec {
    tiny_map(
        under,
        "[integration]\nduration_s = 34.0\ntransient_s = 10.0",
        &format!(
            "metrics = [\"K\", \"period\", \"regime\"]\nlyapunov_window_s = 12.0\n\
             refine = {refine}\nrefine_spacing = 4\nrefine_audit = {audit}\n\
             [[map.axes]]\nkey = \"excitation.frequency_hz\"\nstart = 4.0\nend = 12.0\ncount = 9\n\
             [[map.axes]]\nkey = \"excitation.amplitude_m\"\nstart = 0.004\nend = 0.025\ncount = 5\n"
        ),
    )
}

fn same_cell(a: &InstanceResult, b: &InstanceResult) -> bool {
    a.regime == b.regime
        && a.period.to_bits() == b.period.to_bits()
        && a.k.to_bits() == b.k.to_bits()
}

pub fn a_refined_map_keeps_its_computed_cells_and_fills_only_uniform_blocks(under: Under) {
    let (Some(full), Some(refined)) = (
        map_on(under, &refined_plane(under, false, 0.02)),
        map_on(under, &refined_plane(under, true, 0.02)),
    ) else {
        return;
    };
    let report = refined.refine.as_ref().expect("a refinement report");
    let inferred: Vec<usize> = (0..45).filter(|&k| refined.inferred[k]).collect();
    assert_eq!(report.inferred, inferred.len());
    assert_eq!(report.computed + report.inferred, 45);
    assert_eq!(
        report.computed_per_level[0],
        3 * 2,
        "the coarse lattice of every 4th point"
    );
    for k in 0..45 {
        let (a, b) = (&full.results[k], &refined.results[k]);
        if refined.inferred[k] {
            assert_eq!(b.steps, 0);
            assert!(
                refined
                    .results
                    .iter()
                    .enumerate()
                    .any(|(j, c)| !refined.inferred[j] && same_cell(c, b)),
                "inferred cell {k} is a copy of a computed one"
            );
        } else {
            assert!(same_cell(a, b), "computed cell {k}: {a:?} vs {b:?}");
        }
    }
    // Auditing every inferred cell computes the whole grid: the full map, cell for cell.
    let Some(all) = map_on(under, &refined_plane(under, true, 1.0)) else {
        return;
    };
    assert!(all.inferred.iter().all(|&i| !i));
    let audit = &all.refine.as_ref().unwrap().audit;
    assert_eq!(
        audit.checked,
        report.inferred + report.audit.checked,
        "every cell the refinement filled"
    );
    for (k, (a, b)) in full.results.iter().zip(&all.results).enumerate() {
        assert!(same_cell(a, b), "cell {k}: {a:?} vs {b:?}");
    }
}

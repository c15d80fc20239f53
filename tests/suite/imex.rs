//! The stiff-aware method: its order, its stability on the stiff part, its accuracy against
//! the reference where RK4 is slowest, the choice between the methods, and the reference
//! integrator's step cap for stiff chains.

use super::scene;
use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::imex::{AE, AI, B, B_HAT, C, GAMMA};
use pendulum_atlas_core::engine::method::{Method, MethodSteps};
use pendulum_atlas_core::engine::{
    Instance, ReferenceOptions, StepPlan, integrate, integrate_reference,
};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_map::output::{Row, TrajectoryRecorder};

/// The library reading of the joint damping (ζ1 of the first clamped mode at N = 17).
const LIBRARY_ZETA: &str = "beam.damping_ratio=0.0546";

fn run(s: &Scene) -> (Vec<Row>, StepPlan, Status) {
    let plan = StepPlan::for_scene(s).unwrap();
    let mut rec = TrajectoryRecorder::default();
    let o = integrate(&Instance::<f64>::from_scene(s).unwrap(), &plan, &mut rec);
    (rec.rows, plan, o.status)
}

fn reference(s: &Scene, opts: &ReferenceOptions) -> Vec<Row> {
    let plan = StepPlan::for_scene(s).unwrap();
    let mut rec = TrajectoryRecorder::default();
    let o = integrate_reference(
        &Instance::<f64>::from_scene(s).unwrap(),
        &plan,
        opts,
        &mut rec,
    )
    .unwrap();
    assert_eq!(o.status, Status::Ok);
    rec.rows
}

fn max_alpha_diff(a: &[Row], b: &[Row]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x.alpha_rad - y.alpha_rad).abs())
        .fold(0.0, f64::max)
}

#[test]
fn imex_converges_at_third_order_on_a_smooth_case() {
    // Forced, with the library damping, no contact: smooth, so the method shows its order.
    let base = [
        "beam.segments=9",
        LIBRARY_ZETA,
        "limiter.enabled=false",
        "initial.angle_deg=3",
        "integration.duration_s=0.25",
        "integration.method=imex",
    ];
    let truth = reference(&scene(&base), &ReferenceOptions::default());
    let mut errors = Vec::new();
    for dt in ["2e-4", "1e-4", "5e-5"] {
        let key = format!("integration.dt_s={dt}");
        let mut sets = base.to_vec();
        sets.push(&key);
        let (rows, plan, status) = run(&scene(&sets));
        assert_eq!((plan.method, status), (Method::Imex, Status::Ok));
        errors.push(max_alpha_diff(&rows, &truth));
    }
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        // Third order halves the step for 8x less error; order 2 would give 4.
        assert!(
            (6.0..10.0).contains(&ratio),
            "error ratio {ratio} ({errors:?})"
        );
    }
}

#[test]
fn the_implicit_tableau_is_a_and_l_stable_and_both_are_consistent() {
    // R(z) = 1 + z bᵀ(I − zA)⁻¹1 of the implicit tableau (lower triangular: forward solve).
    let r = |z: num_complex::Complex64| {
        let mut k = [num_complex::Complex64::new(0.0, 0.0); 4];
        for i in 0..4 {
            let mut s = num_complex::Complex64::new(1.0, 0.0);
            for (j, kj) in k.iter().enumerate().take(i) {
                s += z * AI[i][j] * kj;
            }
            k[i] = s / (1.0 - z * AI[i][i]);
        }
        1.0 + z * (0..4).map(|i| B[i] * k[i]).sum::<num_complex::Complex64>()
    };
    for y in [1e-2, 1.0, 10.0, 1e3, 1e6] {
        assert!(
            r(num_complex::Complex64::new(0.0, y)).norm() <= 1.0 + 1e-12,
            "|R(i{y})|"
        );
        assert!(
            r(num_complex::Complex64::new(-y, 0.0)).norm() <= 1.0 + 1e-12,
            "|R(-{y})|"
        );
    }
    // L-stable: R(z) → 0 as z → −∞, like 1/z (stiff modes are damped in one step).
    let far = |x: f64| r(num_complex::Complex64::new(-x, 0.0)).norm();
    assert!(
        far(1e4) < 1e-2 && far(1e6) < 1e-4,
        "R(-1e4) = {}, R(-1e6) = {}",
        far(1e4),
        far(1e6)
    );
    for i in 0..4 {
        let (ae, ai): (f64, f64) = (AE[i].iter().sum(), AI[i].iter().sum());
        assert!(
            (ae - C[i]).abs() < 1e-12 && (ai - C[i]).abs() < 1e-12,
            "row {i}"
        );
    }
    assert!((B.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert!((B_HAT.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert_eq!(AI[3], [B[0], B[1], B[2], GAMMA], "stiffly accurate");
}

#[test]
fn imex_is_stable_at_n64_with_the_library_damping_far_beyond_rk4s_limit() {
    let base = [
        "beam.segments=64",
        LIBRARY_ZETA,
        "integration.duration_s=0.2",
        "integration.step=\"fixed\"",
        "integration.method=imex",
    ];
    let s = scene(&base);
    let steps = MethodSteps::of_scene(&s).unwrap();
    // RK4 would need a step below 1e-9 s here; the IMEX step is set by accuracy.
    assert!(steps.rk4_stable_s < 1e-8, "{steps:?}");
    assert!(steps.imex_auto_s / steps.rk4_stable_s > 1e4, "{steps:?}");
    let (rows, plan, status) = run(&s);
    assert_eq!(status, Status::Ok);
    assert!(
        rows.iter()
            .all(|r| r.alpha_rad.is_finite() && r.energy_j.is_finite())
    );
    // Halving the step changes α by far less than the motion: the result is converged, not
    // merely bounded.
    let dt = format!("integration.dt_s={:e}", plan.dt_s / 2.0);
    let mut sets = base.to_vec();
    sets.push(&dt);
    let (half, _, status) = run(&scene(&sets));
    assert_eq!(status, Status::Ok);
    let swing = rows
        .iter()
        .map(|r| (r.alpha_rad - rows[0].alpha_rad).abs())
        .fold(0.0, f64::max);
    let diff = max_alpha_diff(&rows, &half);
    assert!(
        swing > 1e-3 && diff < 1e-3 * swing,
        "swing {swing:e}, diff {diff:e}"
    );
}

#[test]
fn imex_at_its_automatic_step_matches_the_reference_with_stiff_dampers_and_impacts() {
    let s = scene(&[
        "beam.segments=9",
        LIBRARY_ZETA,
        "integration.duration_s=0.3",
        "integration.method=imex",
    ]);
    let (rows, plan, status) = run(&s);
    assert_eq!((plan.method, status), (Method::Imex, Status::Ok));
    let truth = reference(
        &s,
        &ReferenceOptions::for_stiffness(s.modes().unwrap().spectral_radius_per_s),
    );
    assert!(
        truth.iter().any(|r| r.contact_force_n.abs() > 1.0),
        "no impact to test"
    );
    let err = max_alpha_diff(&rows, &truth);
    assert!(err < 1e-4, "α error {err:e} rad at dt = {:e} s", plan.dt_s);
    // 21× at N = 9 (the IMEX step is the accuracy bound 1/(500 f1), RK4's the dampers').
    assert!(
        plan.dt_s > 15.0 * plan.method_steps.rk4_auto_s,
        "{:?}",
        plan.method_steps
    );
}

#[test]
fn the_step_cap_of_the_reference_changes_nothing_but_the_steps() {
    // A non-stiff scene with impacts: the capped reference is the reference.
    let s = scene(&["beam.segments=3", "integration.duration_s=0.5"]);
    let free = reference(&s, &ReferenceOptions::default());
    let capped = reference(
        &s,
        &ReferenceOptions::for_stiffness(s.modes().unwrap().spectral_radius_per_s),
    );
    assert!(
        free.iter().any(|r| r.contact_force_n.abs() > 1.0),
        "no impact"
    );
    let d = max_alpha_diff(&free, &capped);
    assert!(d < 1e-9, "capped reference differs by {d:e} rad");
}

#[test]
fn auto_picks_the_cheaper_method_and_says_why() {
    let earlier =
        StepPlan::for_scene(&scene(&["beam.segments=3", "beam.damping_ratio=0.0035"])).unwrap();
    assert_eq!(earlier.method, Method::Rk4, "{}", earlier.method_reason);
    let library = StepPlan::for_scene(&scene(&["beam.segments=17", LIBRARY_ZETA])).unwrap();
    assert_eq!(library.method, Method::Imex, "{}", library.method_reason);
    assert!(
        library.method_reason.starts_with("auto: imex is"),
        "{}",
        library.method_reason
    );
    // A given step beyond RK4's stable limit: the method that is stable there.
    let beyond =
        StepPlan::for_scene(&scene(&["beam.segments=17", "integration.dt_s=1e-4"])).unwrap();
    assert_eq!(beyond.method, Method::Imex, "{}", beyond.method_reason);
    let forced = StepPlan::for_scene(&scene(&[
        "beam.segments=17",
        "integration.dt_s=1e-4",
        "integration.method=rk4",
    ]))
    .unwrap();
    assert_eq!(forced.method, Method::Rk4);
    assert!(
        forced
            .warnings
            .iter()
            .any(|w| w.contains("RK4 stability limit"))
    );
}

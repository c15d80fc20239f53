//! Single runs (what `simulate` integrates): energy conservation, convergence order,
//! f32/f64/reference agreement, the piezo energy balance, and divergence flagging.

use super::{scene, scene_error};
use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::{
    Instance, ReferenceOptions, StepPlan, integrate, integrate_batch, integrate_reference,
};
use pendulum_atlas_core::model::{Real, Status};
use pendulum_atlas_map::output::{Row, TrajectoryRecorder};

fn run_rk4<T: Real>(s: &Scene) -> (Vec<Row>, Status) {
    let plan = StepPlan::for_scene(s).unwrap();
    let inst = Instance::<T>::from_scene(s).unwrap();
    let mut rec = TrajectoryRecorder {
        load_ohm: s.piezo_params().map(|z| z.load_ohm),
        ..Default::default()
    };
    let o = integrate(&inst, &plan, &mut rec);
    (rec.rows, o.status)
}

fn run_reference(s: &Scene) -> Vec<Row> {
    let plan = StepPlan::for_scene(s).unwrap();
    let inst = Instance::<f64>::from_scene(s).unwrap();
    let mut rec = TrajectoryRecorder {
        load_ohm: s.piezo_params().map(|z| z.load_ohm),
        ..Default::default()
    };
    let o = integrate_reference(&inst, &plan, &ReferenceOptions::default(), &mut rec).unwrap();
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

fn relative_energy_drift(rows: &[Row]) -> f64 {
    let e0 = rows[0].energy_j;
    let scale = rows.iter().map(|r| r.energy_j.abs()).fold(0.0, f64::max);
    rows.iter()
        .map(|r| (r.energy_j - e0).abs())
        .fold(0.0, f64::max)
        / scale
}

const CONSERVATIVE: [&str; 6] = [
    "excitation.amplitude_m=0",
    "beam.damping_ratio=0",
    "limiter.enabled=false",
    "piezo.enabled=false",
    "initial.angle_deg=5",
    "integration.duration_s=2",
];

#[test]
fn energy_is_conserved_without_forcing_damping_or_contact() {
    for n in ["beam.segments=3", "beam.segments=17"] {
        // The clamped, plucked beam rings in all its modes (up to 19 kHz at N = 17), which
        // makes it a slow reference run; N = 3 covers the clamped root.
        let pivots: &[&str] = if n.ends_with("=3") {
            &["pivot.mode=hinged", "pivot.mode=clamped"]
        } else {
            &["pivot.mode=hinged"]
        };
        for &pivot in pivots {
            let mut sets = CONSERVATIVE.to_vec();
            sets.extend([n, pivot]);
            let s = scene(&sets);
            let rows = run_reference(&s);
            let reference = relative_energy_drift(&rows);
            assert!(
                reference < 1e-9,
                "{n} {pivot}: reference drift {reference:e}"
            );
            // The pendulum really moves (hinged: it falls; clamped: it rings), so the test bites.
            let swing = rows
                .iter()
                .map(|r| (r.alpha_rad - rows[0].alpha_rad).abs())
                .fold(0.0, f64::max);
            assert!(swing > 1e-4, "{n} {pivot}: no motion");
        }
        // RK4 at the automatic step, on the paper's hinged pendulum. (A straight tilted beam on
        // a clamped root is "plucked": it puts energy into the highest discrete mode, which RK4
        // near its stability limit damps numerically; with the model's own damping that mode is
        // overdamped anyway. The reference integrator covers the clamped case above.)
        let mut sets = CONSERVATIVE.to_vec();
        sets.push(n);
        let (rows, status) = run_rk4::<f64>(&scene(&sets));
        assert_eq!(status, Status::Ok);
        let rk4 = relative_energy_drift(&rows);
        assert!(rk4 < 1e-5, "{n}: RK4 drift {rk4:e}");
    }
}

#[test]
fn rk4_converges_at_fourth_order_on_a_smooth_case() {
    // Forced, damped, no contact: smooth, so RK4 must show its order.
    let base = [
        "beam.segments=3",
        "limiter.enabled=false",
        "integration.duration_s=0.25",
        "initial.angle_deg=3",
    ];
    let truth = run_reference(&scene(&base));
    let mut errors = Vec::new();
    for dt in ["2e-4", "1e-4", "5e-5"] {
        let mut sets = base.to_vec();
        let key = format!("integration.dt_s={dt}");
        sets.push(&key);
        let (rows, _) = run_rk4::<f64>(&scene(&sets));
        errors.push(max_alpha_diff(&rows, &truth));
    }
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (12.0..20.0).contains(&ratio),
            "error ratio per halving {ratio} ({errors:?})"
        );
    }
}

#[test]
fn f32_f64_and_reference_agree_on_a_short_horizon_with_contacts() {
    for n in ["beam.segments=3", "beam.segments=17"] {
        let s = scene(&[n, "integration.duration_s=0.3"]);
        let truth = run_reference(&s);
        let (r64, st64) = run_rk4::<f64>(&s);
        let (r32, st32) = run_rk4::<f32>(&s);
        assert_eq!((st64, st32), (Status::Ok, Status::Ok));
        // The beam really hits the bumper in this window.
        assert!(
            truth.iter().any(|r| r.contact_force_n.abs() > 1.0),
            "{n}: no contact"
        );
        let e64 = max_alpha_diff(&r64, &truth);
        let e32 = max_alpha_diff(&r32, &truth);
        assert!(e64 < 1e-4, "{n}: f64 RK4 vs reference {e64:e}");
        assert!(e32 < 2e-3, "{n}: f32 RK4 vs reference {e32:e}");
    }
}

#[test]
fn piezo_energy_balance_holds() {
    // Clamped, tilted straight beam rings down through the dampers and the load resistor:
    // E(t) − E(0) = −∫ (damper + resistor power) dt.
    let s = scene(&[
        "beam.segments=3",
        "piezo.segments=1",
        "pivot.mode=clamped",
        "gravity.g_m_s2=0",
        "limiter.enabled=false",
        "excitation.amplitude_m=0",
        "piezo.enabled=true",
        "piezo.coupling_nm_per_v=2e-3",
        "piezo.load_ohm=1e5",
        "piezo.capacitance_f=1e-7",
        "initial.angle_deg=2",
        "integration.duration_s=0.3",
        "output.sample_rate_hz=50000",
    ]);
    let rows = run_reference(&s);
    let mut dissipated = 0.0;
    let mut worst: f64 = 0.0;
    for w in rows.windows(2) {
        dissipated += 0.5 * (w[0].dissipation_w + w[1].dissipation_w) * (w[1].t_s - w[0].t_s);
        let balance = w[1].energy_j - rows[0].energy_j + dissipated;
        worst = worst.max(balance.abs());
    }
    let e0 = rows[0].energy_j;
    assert!(
        dissipated > 0.05 * e0,
        "too little dissipation to test: {dissipated:e} of {e0:e}"
    );
    let harvested: f64 = rows
        .windows(2)
        .map(|w| 0.5 * (w[0].power_w + w[1].power_w) * (w[1].t_s - w[0].t_s))
        .sum();
    assert!(
        harvested > 1e-3 * dissipated,
        "the load harvests nothing: {harvested:e}"
    );
    assert!(
        worst < 1e-4 * e0,
        "energy balance off by {worst:e} J of {e0:e} J"
    );
}

#[test]
fn a_step_three_times_the_limit_is_flagged_not_returned() {
    let s0 = scene(&[
        "beam.segments=5",
        "integration.duration_s=0.5",
        "integration.method=rk4",
    ]);
    let m = s0.modes().unwrap();
    let dt = format!("integration.dt_s={}", 3.0 * m.dt_stable_s);
    let s = scene(&[
        "beam.segments=5",
        "integration.duration_s=0.5",
        "integration.method=rk4",
        &dt,
    ]);
    let plan = StepPlan::for_scene(&s).unwrap();
    assert!(
        plan.warnings.iter().any(|w| w.contains("stability limit")),
        "{:?}",
        plan.warnings
    );
    let (rows, status) = run_rk4::<f64>(&s);
    assert_ne!(status, Status::Ok);
    assert!(
        rows.iter()
            .all(|r| r.alpha_rad.is_finite() && r.energy_j.is_finite())
    );
}

#[test]
fn batch_equals_single_runs_and_keeps_order() {
    let scenes: Vec<Scene> = [5.0, 8.0, 10.0]
        .iter()
        .map(|f| {
            scene(&[
                "beam.segments=3",
                "integration.duration_s=0.5",
                &format!("excitation.frequency_hz={f}"),
            ])
        })
        .collect();
    let plan = StepPlan::for_scene(&scenes[0]).unwrap();
    let insts: Vec<Instance<f64>> = scenes
        .iter()
        .map(|s| Instance::from_scene(s).unwrap())
        .collect();
    let mut recs: Vec<TrajectoryRecorder> = (0..3).map(|_| TrajectoryRecorder::default()).collect();
    integrate_batch(&insts, &plan, &mut recs);
    for (i, inst) in insts.iter().enumerate() {
        let mut single = TrajectoryRecorder::default();
        integrate(inst, &plan, &mut single);
        assert_eq!(single.rows, recs[i].rows, "instance {i}");
    }
    assert_ne!(recs[0].rows.last(), recs[2].rows.last());
}

/// The mirror symmetry of the model, row by row: x0 = A sin(2πft + φ0) with φ0 = 180° and the
/// mirrored start give α(t) → −α(t), x0 → −x0 and the piezo voltage → −v, for the DOP853
/// reference and for RK4, bumpers and piezo on (3 s, through impacts).
#[test]
fn half_a_period_of_phase_and_the_mirrored_start_mirror_every_row() {
    let common = [
        "beam.segments=4",
        "integration.duration_s=3",
        "piezo.enabled=true",
        "excitation.frequency_hz=7.5",
    ];
    let with = |extra: [&str; 3]| -> Scene {
        let sets: Vec<&str> = common.iter().chain(extra.iter()).copied().collect();
        scene(&sets)
    };
    let plain = with([
        "initial.angle_deg=8",
        "initial.rate_deg_s=60",
        "excitation.phase_deg=0",
    ]);
    let mirror = with([
        "initial.angle_deg=-8",
        "initial.rate_deg_s=-60",
        "excitation.phase_deg=180",
    ]);
    let pairs = [
        // The adaptive reference takes different steps in the two runs (its error estimates
        // differ in the last bits), so the two agree to its tolerance; RK4's fixed steps
        // agree to rounding amplified by the impacts (measured: 6.4e-7 rad and 5.4e-4 V for
        // DOP853, 2.5e-9 rad and 1.7e-6 V for RK4). A wrong sign moves α by ~0.1 rad.
        (
            "DOP853",
            run_reference(&plain),
            run_reference(&mirror),
            (3e-6, 1.5e-3),
        ),
        (
            "RK4",
            run_rk4::<f64>(&plain).0,
            run_rk4::<f64>(&mirror).0,
            (1e-8, 1e-5),
        ),
    ];
    for (name, a, b, (alpha_tol, volt_tol)) in pairs {
        assert_eq!(a.len(), b.len());
        let impacts = a.iter().filter(|r| r.contact_force_n != 0.0).count();
        assert!(impacts > 0, "the run meets the bumpers");
        let worst = |f: fn(&Row) -> f64| {
            a.iter()
                .zip(&b)
                .map(|(x, y)| (f(x) + f(y)).abs())
                .fold(0.0, f64::max)
        };
        let (alpha, cart, volt) = (
            worst(|r| r.alpha_rad),
            worst(|r| r.x0_m),
            worst(|r| r.piezo_v),
        );
        eprintln!(
            "{name}: largest |α + α'| {alpha:e} rad, |x0 + x0'| {cart:e} m, |v + v'| {volt:e} V"
        );
        assert!(
            alpha < alpha_tol && cart < 1e-12 && volt < volt_tol,
            "{name}: {alpha:e} {cart:e} {volt:e}"
        );
    }
    assert!(scene_error(&["excitation.phase_deg=360"]).contains("excitation.phase_deg"));
}

/// A recorder whose caller stops the run at the first chance after `after_step` (a cancel or a
/// time limit), counting the rows it saw.
fn stopping_recorder(after_step: u64) -> TrajectoryRecorder {
    TrajectoryRecorder {
        on_row: Some(Box::new(move |step| {
            if step >= after_step {
                std::ops::ControlFlow::Break(())
            } else {
                std::ops::ControlFlow::Continue(())
            }
        })),
        ..Default::default()
    }
}

#[test]
fn a_cancel_between_sparse_rows_is_seen_within_a_bounded_number_of_steps() {
    use pendulum_atlas_core::engine::POLL_STEPS;
    // One row every 500 s of a 1000 s run: before, a cancel waited for the row at 500 s.
    let s = scene(&[
        "beam.segments=3",
        "integration.duration_s=1000",
        "output.sample_rate_hz=0.002",
    ]);
    let plan = StepPlan::for_scene(&s).unwrap();
    assert!(plan.sample_every > 100 * POLL_STEPS, "{plan:?}");
    let inst = Instance::<f64>::from_scene(&s).unwrap();
    let mut rec = stopping_recorder(1);
    let o = integrate(&inst, &plan, &mut rec);
    assert!(rec.stopped);
    assert_eq!(o.status, Status::Ok);
    assert_eq!(
        o.steps_done, POLL_STEPS,
        "the engine stops at its first poll"
    );
    assert_eq!(rec.rows.len(), 1, "only the row at t = 0 was written");
    // The reference stops at its first poll too: one poll interval of simulated time.
    let mut rec = stopping_recorder(1);
    let o = integrate_reference(&inst, &plan, &ReferenceOptions::default(), &mut rec).unwrap();
    assert!(rec.stopped);
    assert!(o.steps_done <= POLL_STEPS + 1, "{o:?}");
    assert_eq!(rec.rows.len(), 1);
}

/// A run of `s` with adaptive steps at relative tolerance `rtol` (absolute `rtol / 100`): its
/// rows and what the controller did.
fn run_adaptive(
    sets: &[&str],
    rtol: f64,
) -> (
    Vec<Row>,
    pendulum_atlas_core::engine::adaptive::SubstepStats,
) {
    let tol = [
        "integration.step=\"adaptive\"".to_string(),
        format!("integration.rtol={rtol:e}"),
        format!("integration.atol={:e}", rtol / 100.0),
    ];
    let all: Vec<&str> = sets
        .iter()
        .copied()
        .chain(tol.iter().map(String::as_str))
        .collect();
    let s = scene(&all);
    let plan = StepPlan::for_scene(&s).unwrap();
    let inst = Instance::<f64>::from_scene(&s).unwrap();
    let mut rec = TrajectoryRecorder::default();
    let o = integrate(&inst, &plan, &mut rec);
    assert_eq!(o.status, Status::Ok);
    (
        rec.rows,
        o.substeps.expect("adaptive steps report their controller"),
    )
}

#[test]
fn adaptive_steps_follow_the_reference_through_impacts_and_converge_with_the_tolerance() {
    let pairs = [
        ("beam.segments=3", "integration.method=\"rk4\"", None),
        ("beam.segments=3", "integration.method=\"imex\"", None),
        ("beam.segments=17", "integration.method=\"imex\"", Some(())),
    ];
    for (n, method, fixed_evaluations) in pairs {
        let sets = [n, method, "integration.duration_s=0.3"];
        let n = format!("{n}, {method}");
        let s = scene(&sets);
        let truth = run_reference(&s);
        assert!(
            truth.iter().any(|r| r.contact_force_n.abs() > 1.0),
            "{n}: no contact"
        );
        let (coarse, c) = run_adaptive(&sets, 1e-3);
        let (fine, f) = run_adaptive(&sets, 1e-5);
        // Every row on the sample grid, at the reference's instants.
        for rows in [&coarse, &fine] {
            assert_eq!(rows.len(), truth.len(), "{n}");
            for (a, b) in rows.iter().zip(&truth) {
                assert!((a.t_s - b.t_s).abs() < 1e-12, "{n}: {} vs {}", a.t_s, b.t_s);
            }
        }
        let (ec, ef) = (
            max_alpha_diff(&coarse, &truth),
            max_alpha_diff(&fine, &truth),
        );
        assert!(
            ec < 1e-4,
            "{n}: default tolerance {ec:e} rad off the reference"
        );
        assert!(
            ef < ec / 5.0,
            "{n}: tighter tolerance {ef:e} against {ec:e}"
        );
        // The controller refined at the impacts and paid for the tighter tolerance.
        assert!(c.rejected > 0 && c.smallest_s <= 1e-3 / 8.0, "{n}: {c:?}");
        assert!(f.evaluations() > c.evaluations(), "{n}: {f:?} vs {c:?}");
        assert_eq!(c.forced, 0, "{n}: {c:?}");
        if fixed_evaluations.is_some() {
            // The fixed IMEX step is set for the impacts and spent everywhere.
            let fixed_scene = scene(&[sets[0], sets[1], sets[2], "integration.step=\"fixed\""]);
            let plan = StepPlan::for_scene(&fixed_scene).unwrap();
            let fixed = 4 * plan.steps;
            assert!(
                2 * c.evaluations() < fixed,
                "{n}: {} evaluations adaptive against {fixed} fixed",
                c.evaluations()
            );
        }
    }
}

/// The explicit pair's estimate, `h (k₄ − k₅)/6`, is RK4 less its embedded third-order
/// solution: on a smooth free swing (no bumpers) it falls by about 2⁴ = 16 per halving of the
/// step (an estimate of lower order would fall by 8 or less).
#[test]
fn the_explicit_pairs_estimate_is_of_fourth_order_in_the_step() {
    use pendulum_atlas_core::engine::ladder::Rungs;
    use pendulum_atlas_core::engine::rk4::Rk4Rungs;
    let s = scene(&[
        "beam.segments=3",
        "limiter.enabled=false",
        "initial.angle_deg=3.0",
    ]);
    let inst = Instance::<f64>::from_scene(&s).unwrap();
    let (chain, y0) = (&inst.chain, &inst.y0);
    let mut ws = chain.workspace();
    // The largest component of the estimate at each step h = 2 ms / 2^k, the cart's
    // acceleration growing at 500 m/s³ (the stages' times matter).
    let estimate = |k: usize, ws: &mut _| {
        let h = 2e-3 / f64::from(1u32 << k);
        let acc = |c: f64| 500.0 * c * h;
        let mut r = Rk4Rungs::<f64>::new(2e-3, y0.len());
        let mut e = vec![0.0; y0.len()];
        r.stages(k, chain, ws, y0, &acc);
        r.error(k, chain, ws, (y0, &acc), &mut e);
        e.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let e: Vec<f64> = (2..6).map(|k| estimate(k, &mut ws)).collect();
    for w in e.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            (12.0..22.0).contains(&ratio),
            "estimates {e:?}: ratio {ratio} per halving"
        );
    }
}

/// λ1's twin takes the main trajectory's sub-steps: on the linear clamped cantilever (no
/// bumpers, 0.1 mm at 8 Hz, the default map's 34 s) λ1 of an adaptive run is the least-damped
/// eigenvalue of the Jacobian, in f64 and f32.
#[test]
fn lambda1_of_an_adaptive_run_is_the_least_damped_eigenvalue_of_a_linear_chain() {
    use pendulum_atlas_core::engine::{Integrator, Precision, RunLyapunov, run_scene};
    let s = scene(&[
        "beam.segments=3",
        "pivot.mode=\"clamped\"",
        "limiter.enabled=false",
        "initial.angle_deg=0.0",
        "excitation.amplitude_m=0.0001",
        "integration.duration_s=34.0",
        "integration.transient_s=10.0",
        "integration.step=\"adaptive\"",
    ]);
    let want = pendulum_atlas_core::model::linear::jacobian_eigenvalues(&s.model_params().unwrap())
        .unwrap()
        .iter()
        .map(|z| z.re)
        .fold(f64::NEG_INFINITY, f64::max);
    let plan = StepPlan::for_scene(&s).unwrap();
    for precision in [Precision::F64, Precision::F32] {
        let mut rec = TrajectoryRecorder::default();
        let run = run_scene(&s, &plan, Integrator::Engine, precision, &mut rec).unwrap();
        assert!(run.outcome.substeps.is_some());
        let RunLyapunov::Measured { per_s, .. } = run.lyapunov else {
            panic!("{precision:?}: no λ1: {:?}", run.lyapunov);
        };
        assert!(
            (per_s - want).abs() < 0.01 * want.abs(),
            "{precision:?}: λ1 {per_s} against {want}"
        );
    }
}

//! One bumper impact under the two contact damping laws of `docs/model.md` ("Amplitude
//! limiters"), held against the closed-form linear impact and against the energy the chain
//! loses.
//!
//! The set-up isolates the contact: a rigid beam (N = 1, so no joint dampers), no gravity, no
//! forcing, started at 19.5° turning at 20 °/s towards the bumper at 20°. The penetration is
//! then small (about 0.2 mm, 0.4° of holder angle), so the impact is the linear oscillator
//! `m_e δ̈ + c_c δ̇ + k_c δ = 0` with `m_e = I/(s_b cos θ_c)²`, to within the change of the
//! lever `s_b cos θ` over the impact (< 0.3 %).

use super::scene;
use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::{Instance, ReferenceOptions, StepPlan, integrate_reference};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_map::output::{Row, TrajectoryRecorder};

const IMPACT: [&str; 9] = [
    "beam.segments=1",
    "gravity.g_m_s2=0",
    "excitation.amplitude_m=0",
    "initial.angle_deg=19.5",
    "initial.rate_deg_s=20",
    "integration.duration_s=0.2",
    "integration.transient_s=0",
    "output.sample_rate_hz=20000",
    "pivot.damping_nms=0",
];

fn impact(law: &str) -> (Scene, Vec<Row>) {
    let mut sets = IMPACT.to_vec();
    let law = format!("limiter.damping_law=\"{law}\"");
    sets.push(&law);
    let s = scene(&sets);
    let plan = StepPlan::for_scene(&s).unwrap();
    let mut rec = TrajectoryRecorder::default();
    let o = integrate_reference(
        &Instance::<f64>::from_scene(&s).unwrap(),
        &plan,
        &ReferenceOptions::default(),
        &mut rec,
    )
    .expect("reference");
    assert_eq!(o.status, Status::Ok);
    (s, rec.rows)
}

/// The linear impact's natural frequency ω (rad/s) and damping ratio ζ for scene `s`.
fn linear_impact(s: &Scene) -> (f64, f64) {
    let (l, m, tip) = (s.beam.length_m, s.beam.mass_kg, s.tip.mass_kg);
    let inertia = m * l * l / 3.0 + tip * l * l;
    let lever = s.limiter.contact_arc_m * s.limiter.clearance_deg.to_radians().cos();
    let m_e = inertia / (lever * lever);
    let (k, c) = (s.limiter.stiffness_n_per_m, s.limiter.damping_ns_per_m);
    let omega = (k / m_e).sqrt();
    (omega, c / (2.0 * (k * m_e).sqrt()))
}

/// Outgoing over incoming speed of the linear impact with damping on loading only: the
/// damped compression ends at δ̇ = 0 with δ_max = (v₀/ω) exp(−ζ ω t*), ω_d t* = atan(√(1−ζ²)/ζ),
/// and the undamped restitution returns ω δ_max.
fn restitution_loading(zeta: f64) -> f64 {
    let s = (1.0 - zeta * zeta).sqrt();
    (-zeta / s * (s / zeta).atan()).exp()
}

/// The same for Kelvin–Voigt: δ(t) = (v₀/ω_d) e^{−ζωt} sin ω_d t until the force k δ + c δ̇
/// falls to zero (found by bisection, in units ω = v₀ = 1), then |δ̇| there.
fn restitution_kelvin_voigt(zeta: f64) -> f64 {
    let wd = (1.0 - zeta * zeta).sqrt();
    let delta = |t: f64| (-zeta * t).exp() * (wd * t).sin() / wd;
    let rate = |t: f64| (-zeta * t).exp() * ((wd * t).cos() - zeta / wd * (wd * t).sin());
    let force = |t: f64| delta(t) + 2.0 * zeta * rate(t);
    // The force is positive from t = 0+ until after the turning point, and zero before δ is.
    let (mut lo, mut hi) = (std::f64::consts::FRAC_PI_2 / wd, std::f64::consts::PI / wd);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if force(mid) > 0.0 { lo = mid } else { hi = mid }
    }
    rate(lo).abs()
}

/// The holder rate once the beam has left the bumper (free flight: constant).
fn rebound_rate(rows: &[Row]) -> f64 {
    let last = rows.last().expect("rows");
    assert_eq!(last.contact_force_n, 0.0, "still in contact at the end");
    last.alpha_dot_rad_s
}

#[test]
fn loading_only_damping_rebounds_faster_than_kelvin_voigt_as_the_linear_impact_predicts() {
    let (s, loading) = impact("loading");
    let (_, kv) = impact("kelvin_voigt");
    let (_, zeta) = linear_impact(&s);
    let incoming = 20f64.to_radians();
    let e_loading = -rebound_rate(&loading) / incoming;
    let e_kv = -rebound_rate(&kv) / incoming;
    let (want_loading, want_kv) = (restitution_loading(zeta), restitution_kelvin_voigt(zeta));
    // ζ ≈ 0.23 here: the laws differ by ~10 %, the lever's change over the impact is < 0.3 %.
    assert!(
        zeta > 0.1,
        "ζ = {zeta}: too little damping to tell the laws apart"
    );
    assert!(
        (e_loading / want_loading - 1.0).abs() < 0.01,
        "loading: e = {e_loading}, linear impact {want_loading} (ζ = {zeta})"
    );
    assert!(
        (e_kv / want_kv - 1.0).abs() < 0.01,
        "Kelvin–Voigt: e = {e_kv}, linear impact {want_kv} (ζ = {zeta})"
    );
    assert!(e_loading > e_kv * 1.05, "{e_loading} vs {e_kv}");
}

#[test]
fn the_bumper_never_pulls_and_the_loading_law_lets_go_without_a_jump() {
    for law in ["loading", "kelvin_voigt"] {
        let (_, rows) = impact(law);
        // The +x bumper pushes towards −x, or not at all.
        assert!(
            rows.iter().all(|r| r.contact_force_n <= 0.0),
            "{law}: the bumper pulls"
        );
        let peak = rows.iter().map(|r| -r.contact_force_n).fold(0.0, f64::max);
        assert!(peak > 0.1, "{law}: no impact (peak force {peak} N)");
        // The force at the last sample in contact is a small part of the peak: with 50 µs
        // samples over a ~70 ms impact, a force that jumped to zero at release would leave
        // the last sample near the peak's scale.
        let last = rows
            .iter()
            .rev()
            .find(|r| r.contact_force_n < 0.0)
            .expect("a contact sample");
        assert!(
            -last.contact_force_n < 0.01 * peak,
            "{law}: {} N just before release (peak {peak} N)",
            -last.contact_force_n
        );
    }
}

#[test]
fn the_energy_lost_in_an_impact_is_the_work_of_the_contact_damper() {
    for law in ["loading", "kelvin_voigt"] {
        let (s, rows) = impact(law);
        let e_before = rows[0].energy_j;
        let e_after = rows.last().expect("rows").energy_j;
        let lost = e_before - e_after;
        // The damper's work from the rows alone: δ = s_b sin α − g, δ̇ = s_b cos α α̇, and the
        // damping part of the bumper's force |F| − k_c δ. Kelvin–Voigt lets go while δ > 0
        // (at k_c δ + c_c δ̇ = 0): the bumper, massless, then relaxes through its own damper,
        // and the ½ k_c δ² it still holds is lost too, at the rate −k_c δ δ̇ (F = 0 there).
        let (sb, k) = (s.limiter.contact_arc_m, s.limiter.stiffness_n_per_m);
        let gap = sb * s.limiter.clearance_deg.to_radians().sin();
        let damper_power = |r: &Row| {
            let delta = sb * r.alpha_rad.sin() - gap;
            if delta <= 0.0 {
                return 0.0;
            }
            let rate = sb * r.alpha_rad.cos() * r.alpha_dot_rad_s;
            (-r.contact_force_n - k * delta) * rate
        };
        let trapezoid = |f: &dyn Fn(&Row) -> f64| {
            rows.windows(2)
                .map(|w| 0.5 * (f(&w[0]) + f(&w[1])) * (w[1].t_s - w[0].t_s))
                .sum::<f64>()
        };
        let work = trapezoid(&damper_power);
        let reported = trapezoid(&|r: &Row| r.dissipation_w);
        assert!(
            lost > 0.1 * e_before,
            "{law}: lost only {lost:e} of {e_before:e} J"
        );
        // Trapezoid sums over 50 µs samples (the loading law's damper switches on with a jump
        // at onset): agreement to 1 % of the loss; the model's own bookkeeping closer.
        assert!(
            (work / lost - 1.0).abs() < 0.01,
            "{law}: damper work {work:e} J, energy lost {lost:e} J"
        );
        assert!(
            (reported / lost - 1.0).abs() < 0.01,
            "{law}: reported dissipation {reported:e} J, energy lost {lost:e} J"
        );
    }
}

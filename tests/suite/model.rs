//! The model against MODEL.md's reference numbers and against its own dense form.

use super::scene;
use pendulum_atlas_core::model::{Chain, ContactDamping, ContactLaw, ModelParams, dense, linear};

const CLAMPED_G0: [&str; 3] = [
    "pivot.mode=clamped",
    "gravity.g_m_s2=0",
    "limiter.enabled=false",
];

fn clamped(n: usize) -> Vec<f64> {
    let seg = format!("beam.segments={n}");
    let mut sets: Vec<&str> = CLAMPED_G0.to_vec();
    sets.push(&seg);
    scene(&sets).modes().unwrap().frequencies_hz
}

#[test]
fn clamped_first_frequency_matches_model_md() {
    let f3 = clamped(3)[0];
    let f17 = clamped(17)[0];
    let f68 = clamped(68)[0];
    assert!((f3 - 24.41).abs() < 0.01, "N=3: {f3}");
    assert!((f17 - 25.35).abs() < 0.01, "N=17: {f17}");
    assert!((f68 - 25.375).abs() < 0.002, "N=68: {f68}");
    // Converges to Euler–Bernoulli with tip mass (25.377 Hz) within 0.1 % by N = 68.
    assert!((f68 / 25.377 - 1.0).abs() < 1e-3, "N=68: {f68}");
    // ... as O(1/N²): the error shrinks ~16x from N=17 to N=68.
    let (e17, e68) = (25.377 - f17, 25.377 - f68);
    assert!(e17 / e68 > 8.0, "errors {e17} {e68}");
    // Second mode approaches 178.8 Hz.
    assert!((clamped(68)[1] - 178.8).abs() < 0.5);
}

#[test]
fn hinged_upright_chain_has_one_falling_mode() {
    let m = scene(&[]).modes().unwrap();
    assert_eq!(
        m.unstable_rates_per_s.len(),
        1,
        "{:?}",
        m.unstable_rates_per_s
    );
    let lambda2 = m.unstable_rates_per_s[0].powi(2);
    assert!((lambda2 - 34.1).abs() < 0.1, "λ² = {lambda2}");
    assert_eq!(m.frequencies_hz.len(), 16);
    assert!(m.frequencies_hz.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn spectral_radius_and_auto_step_match_model_md() {
    let r = |sets: &[&str]| scene(sets).modes().unwrap().spectral_radius_per_s;
    let n3 = r(&["beam.segments=3", "beam.damping_ratio=0.0035"]);
    let n17_undamped = r(&["beam.damping_ratio=0"]);
    let n17_earlier = r(&["beam.damping_ratio=0.0035"]);
    let n17 = r(&[]);
    assert!((n3 / 2.5e3 - 1.0).abs() < 0.05, "N=3: {n3}");
    assert!(
        (n17_undamped / 1.2e5 - 1.0).abs() < 0.05,
        "N=17 undamped: {n17_undamped}"
    );
    assert!(
        (n17_earlier / 6.3e5 - 1.0).abs() < 0.05,
        "N=17 ζ1 = 0.0035: {n17_earlier}"
    );
    assert!((n17 / 1.0e7 - 1.0).abs() < 0.05, "N=17 library: {n17}");
    let m = scene(&[]).modes().unwrap();
    assert!((m.dt_auto_s - 0.8 * 2.78 / n17).abs() < 1e-12);
    // The automatic step lies inside the RK4 stability limit.
    assert!(m.dt_auto_s < m.dt_stable_s);
}

/// ζ = −Re λ / |λ| of the eigenvalue pair of the clamped chain closest to its first mode.
fn first_mode_zeta(sets: &[&str]) -> f64 {
    let mut all = CLAMPED_G0.to_vec();
    all.extend_from_slice(sets);
    let s = scene(&all);
    let eig = linear::jacobian_eigenvalues(&s.model_params().unwrap()).unwrap();
    let w1 = 2.0 * std::f64::consts::PI * s.modes().unwrap().frequencies_hz[0];
    let lam = eig
        .iter()
        .filter(|z| z.im > 0.0)
        .min_by(|a, b| (a.norm() - w1).abs().total_cmp(&(b.norm() - w1).abs()))
        .unwrap();
    -lam.re / lam.norm()
}

#[test]
fn damping_gives_the_requested_ratio_on_the_first_clamped_mode() {
    let zeta = first_mode_zeta(&["beam.damping_ratio=0.0035"]);
    assert!((zeta - 0.0035).abs() < 1e-6, "ζ = {zeta}");
}

#[test]
fn the_library_reading_gives_zeta_0_054_at_seventeen_segments() {
    // b = 0.35 N m s/rad per joint at N = 17 (MODEL.md, "Damping"): ζ1 ≈ 0.054.
    let zeta = first_mode_zeta(&[]);
    assert!((zeta - 0.054).abs() <= 0.001, "ζ1 = {zeta}");
    let s = scene(&[]);
    let report = s.damping_report().unwrap();
    assert!(
        (report.joint_damping_nms - 0.35).abs() < 1e-12,
        "{report:?}"
    );
    assert!(
        (report.first_mode_damping_ratio - 0.054).abs() <= 0.001,
        "{report:?}"
    );
    // The same β at any N: b scales with the joint stiffness EI/(L/N).
    let n5 = scene(&["beam.segments=5"]).damping_report().unwrap();
    assert!((n5.damping_time_s - report.damping_time_s).abs() < 1e-18);
    assert!(
        (n5.joint_damping_nms - 0.35 * 5.0 / 17.0).abs() < 1e-12,
        "{n5:?}"
    );
    // The three keys name the same damping.
    let beta = report.damping_time_s;
    for set in [
        format!("beam.damping_time_s={beta:e}"),
        "beam.joint_damping_nms=0.35".to_string(),
        format!("beam.damping_ratio={:e}", report.first_mode_damping_ratio),
    ] {
        let other = scene(&[&set]).damping_report().unwrap();
        assert!(
            (other.damping_time_s / beta - 1.0).abs() < 1e-9,
            "{set}: {other:?}"
        );
    }
}

/// Pseudo-random numbers in [−1, 1) without a dependency (a fixed LCG is enough here).
fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

/// Applied couples of MODEL.md written out independently: springs, dampers, bumpers, piezo.
fn applied_couples(p: &ModelParams, th: &[f64], om: &[f64], v: f64) -> Vec<f64> {
    let n = p.segments;
    let mut q = vec![0.0; n];
    q[0] -= p.root_stiffness_nm * th[0] + p.root_damping_nms * om[0];
    for i in 1..n {
        let tau =
            p.joint_stiffness_nm * (th[i] - th[i - 1]) + p.joint_damping_nms * (om[i] - om[i - 1]);
        q[i] -= tau;
        q[i - 1] += tau;
    }
    if let Some(c) = &p.contact {
        let x: f64 = c
            .levers_m
            .iter()
            .enumerate()
            .map(|(i, l)| l * th[i].sin())
            .sum();
        let xd: f64 = c
            .levers_m
            .iter()
            .enumerate()
            .map(|(i, l)| l * th[i].cos() * om[i])
            .sum();
        // Penetration δ and its rate on each side; MODEL.md's two laws.
        let force = |delta: f64, rate: f64| {
            if delta <= 0.0 {
                return 0.0;
            }
            match c.law {
                ContactDamping::Loading => {
                    c.stiffness_n_per_m * delta + c.damping_ns_per_m * rate.max(0.0)
                }
                ContactDamping::KelvinVoigt => {
                    (c.stiffness_n_per_m * delta + c.damping_ns_per_m * rate).max(0.0)
                }
            }
        };
        let fr = force(x - c.gap_m, xd);
        let fl = force(-x - c.gap_m, -xd);
        for (i, l) in c.levers_m.iter().enumerate() {
            q[i] += (fl - fr) * l * th[i].cos();
        }
    }
    if let Some(z) = &p.piezo {
        q[0] += z.coupling_nm_per_v * v;
        q[z.last_segment] -= z.coupling_nm_per_v * v;
    }
    q
}

#[test]
fn recursive_solve_equals_dense_solve() {
    let mut seed = 7u64;
    for (n, extra) in [
        (1, vec!["pivot.holder_inertia_kgm2=1e-4"]),
        (
            2,
            vec![
                "pivot.mode=clamped",
                "piezo.enabled=true",
                "piezo.segments=1",
            ],
        ),
        (
            5,
            vec!["limiter.contact_arc_m=0.2", "pivot.damping_nms=0.01"],
        ),
        (
            17,
            vec!["piezo.enabled=true", "pivot.holder_inertia_kgm2=2e-5"],
        ),
        (33, vec!["tip.mass_kg=0"]),
        (5, vec!["limiter.damping_law=\"kelvin_voigt\""]),
    ] {
        let seg = format!("beam.segments={n}");
        let mut sets = extra.clone();
        sets.push(&seg);
        let p = scene(&sets).model_params().unwrap();
        let chain = Chain::<f64>::new(&p);
        let mut ws = chain.workspace();
        for _ in 0..20 {
            let th: Vec<f64> = (0..n).map(|_| 0.6 * lcg(&mut seed)).collect();
            let om: Vec<f64> = (0..n).map(|_| 8.0 * lcg(&mut seed)).collect();
            let v = 3.0 * lcg(&mut seed);
            let acc = 20.0 * lcg(&mut seed);
            let mut y = th.clone();
            y.extend(&om);
            y.push(v);
            let mut dy = vec![0.0; y.len()];
            chain.derivative(&mut ws, acc, &y, &mut dy, ContactLaw::Exact);
            let q = applied_couples(&p, &th, &om, v);
            let dense = dense::accelerations(&p, &th, &om, acc, &q);
            let scale = dense.amax().max(1.0);
            for i in 0..n {
                let diff = (dy[n + i] - dense[i]).abs();
                assert!(
                    diff < 1e-9 * scale,
                    "N={n} i={i}: O(N) {} vs dense {}",
                    dy[n + i],
                    dense[i]
                );
            }
        }
    }
}

#[test]
fn a_linearisation_that_cannot_be_computed_is_an_error_not_a_hang_or_a_panic() {
    let p = scene(&[]).model_params().unwrap();
    // A stiffness that overflowed: the QR iterations either stop at EIGEN_MAX_ITERATIONS or
    // end on values that are not numbers; both are errors, never NaN frequencies.
    let mut q = p.clone();
    q.joint_stiffness_nm = f64::NAN;
    let failed = |e: &linear::LinearError| {
        matches!(
            e,
            linear::LinearError::NoConvergence { .. } | linear::LinearError::NotFinite { .. }
        )
    };
    let e = linear::generalized_eigenvalues(&q).unwrap_err();
    assert!(failed(&e), "{e}");
    let e = linear::jacobian_eigenvalues(&q).unwrap_err();
    assert!(failed(&e), "{e}");
    assert!(linear::modes(&q, 0.5).is_err());
    // A mass matrix that is not positive definite is said, not a panic in Cholesky.
    let mut m = p.clone();
    m.seg_mass_kg = -1.0;
    let e = linear::generalized_eigenvalues(&m).unwrap_err();
    assert!(e.to_string().contains("not positive definite"), "{e}");
    // The method's steps and the damping ratio carry the same error.
    assert!(pendulum_atlas_core::engine::method::MethodSteps::of(&q, 0.5).is_err());
    assert!(linear::first_mode_damping_ratio(&m).is_err());
}

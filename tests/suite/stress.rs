//! Numerical stability stress suite, on the CPU engine and (when an adapter exists) the GPU:
//! extreme steps, forcing, clearances, contact stiffness, segment counts and run lengths.
//! Nothing may panic, no `ok` instance may carry a non-finite number, and every instance that
//! blows up must be flagged and carry no numbers.

use pendulum_atlas::config::{MapSpec, Metric, map_from_toml};
use pendulum_atlas::integrate::Status;
use pendulum_atlas::map::{Backend, MapRun, Precision, run_map};

/// A scene of configs/stress/ (the same cases a user can run with `pendulum-atlas map`).
fn stress_scene(name: &str, sets: &[&str]) -> MapSpec {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("configs/stress")
        .join(name);
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    pendulum_atlas::config::load_map(Some(&path), &sets).expect("valid stress scene")
}

fn spec(scene: &str, map: &str) -> MapSpec {
    map_from_toml(&format!("{scene}\n[map]\n{map}"), "<stress>", &[]).expect("valid stress scene")
}

/// The map on the CPU (f64 and f32) and on the GPU when there is one.
fn run_everywhere(s: &MapSpec) -> Vec<(String, MapRun)> {
    let mut out = Vec::new();
    for p in [Precision::F64, Precision::F32] {
        let r = run_map(s, Backend::Cpu, p, &|_, _, _| {}).expect("cpu map");
        out.push((format!("cpu {p:?}"), r));
    }
    if crate::gpu::gpu().is_some() {
        let r = run_map(s, Backend::Gpu, Precision::F32, &|_, _, _| {}).expect("gpu map");
        out.push(("gpu".to_string(), r));
    }
    out
}

/// Every `ok` instance has finite values for every requested metric; every failed one has none.
fn assert_consistent(name: &str, s: &MapSpec, run: &MapRun) {
    for (k, r) in run.results.iter().enumerate() {
        for m in &s.metrics {
            let v = r.metric(*m);
            match r.status {
                Status::Ok => assert!(
                    v.is_finite(),
                    "{name}: instance {k} ({:?}) is ok but {} = {v}",
                    s.values_of(k),
                    m.name()
                ),
                _ => assert!(
                    v.is_nan(),
                    "{name}: failed instance {k} carries {} = {v}",
                    m.name()
                ),
            }
        }
    }
}

/// (clearance, stiffness) of instance k of the clearance × stiffness map.
fn spec_values(run: &MapRun, k: usize) -> (f64, f64) {
    let p = &run.plan.instances[k].params;
    let c = p.contact.as_ref().expect("bumpers");
    (
        (c.gap_m / 0.03).asin().to_degrees().round(),
        c.stiffness_n_per_m,
    )
}

fn statuses(run: &MapRun) -> Vec<Status> {
    run.results.iter().map(|r| r.status).collect()
}

const N3: &str = "[beam]\nsegments = 3\n[integration]\nduration_s = 3.0\ntransient_s = 0.5";

#[test]
fn step_beyond_the_stability_limit_is_flagged_not_returned() {
    let scene = pendulum_atlas::config::Scene::from_toml(N3, "<stress>", &[]).unwrap();
    let m = pendulum_atlas::model::modes(&scene);
    for (factor, must_fail) in [(0.5, false), (1.0, false), (3.0, true)] {
        let dt = factor * m.dt_auto_s / scene.integration.dt_safety;
        let set = format!("integration.dt_s={dt:e}");
        let s = stress_scene("dt_beyond_limit.toml", &[&set]);
        for (name, run) in run_everywhere(&s) {
            assert_consistent(&name, &s, &run);
            let st = statuses(&run);
            if must_fail {
                assert!(
                    st.iter().all(|s| *s != Status::Ok),
                    "{name}: dt = 3x the RK4 limit must be flagged, got {st:?}"
                );
                assert!(
                    !run.plan.warnings.is_empty(),
                    "{name}: no warning for dt beyond the limit"
                );
            } else {
                assert!(
                    st.iter().all(|s| *s == Status::Ok),
                    "{name}: {factor}x: {st:?}"
                );
            }
        }
    }
}

#[test]
fn violent_forcing_up_to_a_tenth_of_a_metre_and_fifty_hertz() {
    let s = stress_scene("violent_forcing.toml", &[]);
    for (name, run) in run_everywhere(&s) {
        assert_consistent(&name, &s, &run);
    }
}

#[test]
fn clearances_from_half_a_degree_to_sixty_and_stiff_bumpers() {
    let s = stress_scene("clearance_and_stiffness.toml", &[]);
    for (name, run) in run_everywhere(&s) {
        assert_consistent(&name, &s, &run);
        // The automatic step follows each instance's contact stiffness: nothing diverges
        // numerically. At 60° the softest bumper cannot hold the beam, which swings over it:
        // that instance must be flagged `escaped`, never reported as an orbit.
        let st = statuses(&run);
        for (k, s) in st.iter().enumerate() {
            let v = spec_values(&run, k);
            if v == (60.0, 1e3) {
                assert_eq!(*s, Status::Escaped, "{name}: {v:?}");
            } else {
                assert_eq!(*s, Status::Ok, "{name}: {v:?}");
            }
        }
        for r in run.results.iter().filter(|r| r.status == Status::Ok) {
            assert!(
                r.alpha_max_rad.abs() < 1.5 && r.alpha_min_rad.abs() < 1.5,
                "{name}: {r:?}"
            );
        }
    }
}

#[test]
fn sixty_four_segments_integrate_on_both_engines() {
    // Undamped (see the scene): with the dampers the automatic step at N = 64 is 16 ns.
    let s = stress_scene("sixty_four_segments.toml", &[]);
    for (name, run) in run_everywhere(&s) {
        assert_consistent(&name, &s, &run);
        assert!(statuses(&run).iter().all(|s| *s == Status::Ok), "{name}");
    }
}

#[test]
fn ten_thousand_forcing_periods_in_f32_keep_the_phase_and_the_energy() {
    // A damped clamped cantilever (no bumpers) forced below resonance settles on a period-1
    // orbit. If the forcing phase drifted in f32, the stroboscopic samples would drift too.
    let s = stress_scene("ten_thousand_periods_f32.toml", &[]);
    for (name, run) in run_everywhere(&s) {
        assert_consistent(&name, &s, &run);
        let r = &run.results[0];
        assert_eq!(run.plan.instances[0].total_periods, 10_000);
        assert_eq!(r.status, Status::Ok, "{name}");
        assert_eq!(r.period, 1.0, "{name}: the stroboscopic section drifted");
        // Energy bounded: the response amplitude stays that of the steady state.
        assert!(r.alpha_max_rad - r.alpha_min_rad < 0.05, "{name}: {r:?}");
    }
}

#[test]
fn metrics_not_requested_are_not_computed() {
    let s = spec(
        N3,
        "metrics = [\"hops\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [5.0, 8.0]",
    );
    for (name, run) in run_everywhere(&s) {
        assert!(!run.plan.want_strobe && !run.plan.want_rseries, "{name}");
        for r in &run.results {
            assert!(r.k.is_nan() && r.r.is_nan() && r.period.is_nan(), "{name}");
            assert!(r.metric(Metric::Hops).is_finite());
        }
    }
}

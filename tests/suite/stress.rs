//! Numerical stability stress suite, on the CPU engine and (when an adapter exists) the GPU:
//! extreme steps, forcing, clearances, contact stiffness, segment counts and run lengths.
//! Nothing may panic, no `ok` instance may carry a non-finite number, and every instance that
//! blows up must be flagged and carry no numbers.

use pendulum_atlas::config::{MapSpec, Metric, map_from_toml};
use pendulum_atlas::integrate::Status;
use pendulum_atlas::map::{Backend, MapRun, Precision, run_map};

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
        let s = spec(
            &format!("{N3}\ndt_s = {dt:e}"),
            "metrics = [\"R\", \"hops\", \"alpha_range\", \"impacts_per_s\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [5.0, 8.0, 10.0]",
        );
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
    let s = spec(
        "[beam]\nsegments = 3\n[integration]\nduration_s = 1.0\ntransient_s = 0.4",
        "metrics = [\"R\", \"hops\", \"alpha_range\", \"impacts_per_s\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [5.0, 20.0, 50.0]\n[[map.axes]]\nkey = \"excitation.amplitude_m\"\nvalues = [0.001, 0.02, 0.1]",
    );
    for (name, run) in run_everywhere(&s) {
        assert_consistent(&name, &s, &run);
    }
}

#[test]
fn clearances_from_half_a_degree_to_sixty_and_stiff_bumpers() {
    let s = spec(
        N3,
        "metrics = [\"R\", \"hops\", \"alpha_range\", \"impacts_per_s\"]\n[[map.axes]]\nkey = \"limiter.clearance_deg\"\nvalues = [0.5, 5.0, 30.0, 60.0]\n[[map.axes]]\nkey = \"limiter.stiffness_n_per_m\"\nvalues = [1e3, 1e5, 1e7]",
    );
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
    // Undamped: with the stiffness-proportional dampers the automatic step at N = 64 is
    // 16 ns (max|λ| = 1.4e8 1/s), 80x shorter than undamped, which only makes the test slow.
    let s = spec(
        "[beam]\nsegments = 64\ndamping_ratio = 0.0\n[integration]\nduration_s = 0.03\ntransient_s = 0.01",
        "metrics = [\"alpha_range\", \"impacts_per_s\"]\nsamples_per_period = 4\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [100.0]",
    );
    for (name, run) in run_everywhere(&s) {
        assert_consistent(&name, &s, &run);
        assert!(statuses(&run).iter().all(|s| *s == Status::Ok), "{name}");
    }
}

#[test]
fn ten_thousand_forcing_periods_in_f32_keep_the_phase_and_the_energy() {
    // A damped clamped cantilever (no bumpers) forced below resonance settles on a period-1
    // orbit. If the forcing phase drifted in f32, the stroboscopic samples would drift too.
    let s = spec(
        "[beam]\nsegments = 1\n[pivot]\nmode = \"clamped\"\n[limiter]\nenabled = false\n[excitation]\nfrequency_hz = 10.0\namplitude_m = 0.001\n[integration]\nduration_s = 1000.0\ntransient_s = 900.0",
        "metrics = [\"period\", \"alpha_range\"]\nsamples_per_period = 8\nperiod_tol_rad = 1e-5\n[[map.axes]]\nkey = \"beam.damping_ratio\"\nvalues = [0.02]",
    );
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

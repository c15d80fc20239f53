//! Calibration: the spec refuses what it cannot judge, and a calibration recovers an unknown
//! from observations the model itself produced at a known value.

use pendulum_atlas_core::engine::{Engine, EnsembleOptions, EnsemblePlan, Precision, no_progress};
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions};
use pendulum_atlas_design::calibrate::{Observation, calibration_from_toml, run_calibration};
use pendulum_atlas_map::map::run_plan;

/// N = 3, 22-s runs (2 s transient: 100 stroboscopic samples at 5 Hz for K), the paper's
/// bumpers.
const BASE: &str = "[beam]\nsegments = 3\n[integration]\nduration_s = 22.0\ntransient_s = 2.0\n";

const CASES: [(f64, f64); 2] = [(8.0, 0.009), (5.0, 0.012)];

fn case_set(f: f64, a: f64) -> String {
    format!("set = {{ \"excitation.frequency_hz\" = {f}, \"excitation.amplitude_m\" = {a} }}")
}

/// What the model does in each case at `limiter.clearance_deg = clearance` (one run each).
fn truth(clearance: f64) -> Vec<InstanceResult> {
    let scenes: Vec<_> = CASES
        .iter()
        .map(|&(f, a)| {
            pendulum_atlas_core::config::Scene::from_toml(
                BASE,
                "<truth>",
                &[
                    format!("limiter.clearance_deg={clearance}"),
                    format!("excitation.frequency_hz={f}"),
                    format!("excitation.amplitude_m={a}"),
                ],
            )
            .unwrap()
        })
        .collect();
    let opts = EnsembleOptions {
        metrics: pendulum_atlas_core::config::Metric::ALL.to_vec(),
        keep_strobe: false,
        samples_per_period: 16,
        strobe_phase: 0.0,
        r_max_samples: 1024,
        early_stop: None,
        lyapunov: Default::default(),
        gpu_kernel: Default::default(),
    };
    let plan = EnsemblePlan::from_scenes(&scenes, &opts).unwrap();
    let engine = Engine::cpu(Precision::F64);
    run_plan(plan, &ReduceOptions::default(), None, &engine, &no_progress)
        .unwrap()
        .results
}

#[test]
fn calibration_recovers_a_clearance_from_the_models_own_observations() {
    let observed = truth(15.0);
    let mut text = format!(
        "{BASE}[calibrate]\ninitial_states = 1\nphase_convention = \"standard\"\n\
         refine = {{ rounds = 1, top = 1, shrink = 0.5 }}\n\
         [[calibrate.unknowns]]\nkey = \"limiter.clearance_deg\"\nvalues = [10.0, 12.5, 15.0, 17.5, 20.0]\n"
    );
    for (&(f, a), r) in CASES.iter().zip(&observed) {
        let range = r.alpha_max_rad - r.alpha_min_rad;
        // The dominant line as the nearest 64th of the forcing frequency, within 3 % plus what
        // that rounding moved it (up to 1/128 of f: 9 % of a line at 5/64).
        let sixty_fourths = (r.line * 64.0).round().max(1.0);
        let line = format!("{sixty_fourths}/64");
        let line_tol = 0.03 + (r.line - sixty_fourths / 64.0).abs() / (sixty_fourths / 64.0);
        text.push_str(&format!(
            "[[calibrate.cases]]\nname = \"{f} Hz\"\n{}\nk_class = \"{}\"\nhops = {}\n\
             alpha_range_rad = [{}, {}]\nline = {{ fraction = \"{line}\", tol = {line_tol} }}\n",
            case_set(f, a),
            if r.k > 0.5 { "chaotic" } else { "regular" },
            r.hops > 0.0,
            0.98 * range,
            1.02 * range
        ));
    }
    let spec = calibration_from_toml(&text, "<test>", &[]).unwrap();
    let run = run_calibration(&spec, &Engine::cpu(Precision::F64), &no_progress).unwrap();
    assert_eq!(run.observations, 8);
    let best = run.best();
    assert_eq!(best.matched, 8, "{best:?}");
    assert!((best.values[0] - 15.0).abs() <= 1.25, "{best:?}");
    // The observations discriminate: the grid's ends match fewer.
    for c in run.candidates.iter().filter(|c| c.stage == "grid") {
        if (c.values[0] - 15.0).abs() >= 5.0 {
            assert!(
                c.matched < 8,
                "clearance {} matches everything",
                c.values[0]
            );
        }
    }
    // Refinement added the neighbours of the best grid point.
    assert!(run.candidates.iter().any(|c| c.stage == "refine 1"));
}

#[test]
fn the_spec_reads_every_observation_and_refuses_what_it_cannot_judge() {
    let with = |case: &str, unknown: &str| {
        format!(
            "{BASE}[calibrate]\n[[calibrate.unknowns]]\n{unknown}\n[[calibrate.cases]]\n{}\n{case}\n",
            case_set(8.0, 0.009)
        )
    };
    let arc = "key = \"limiter.contact_arc_m\"\nstart = 0.1\nend = 0.3\ncount = 3";
    let spec = calibration_from_toml(
        &with(
            "k_class = \"regular\"\nk = { value = 0.0, tol = 0.2 }\nr = { value = 0.88, tol = 0.1 }\n\
             period = 3\nline = \"1/3\"\nhops = false\nalpha_range_rad = [0.1, 0.3]",
            arc,
        ),
        "<t>",
        &[],
    )
    .unwrap();
    assert_eq!(spec.cases[0].observations.len(), 7);
    assert_eq!(
        spec.cases[0].observations[3],
        Observation::Period { period: 3 }
    );
    assert_eq!(
        spec.cases[0].observations[4],
        Observation::Line {
            p: 1,
            q: 3,
            rel_tol: 0.05
        }
    );
    assert_eq!(spec.unknowns[0].values, vec![0.1, 0.2, 0.3]);
    assert_eq!(spec.angle_offsets_deg(), vec![-1.0, 0.0, 1.0]);
    for (case, unknown, says) in [
        ("", arc, "at least one observation"),
        ("k_class = \"maybe\"", arc, "k_class"),
        ("k = { value = 0.1 }", arc, "tolerance"),
        ("alpha_range_rad = [0.3, 0.1]", arc, "lo < hi"),
        ("period = 2\nperiod_typo = 3", arc, "period_typo"),
        ("period = 9", arc, "integers in [0, 8]"),
        ("line = \"third\"", arc, "\"p/q\""),
        ("line = \"1/0\"", arc, "1 <= q <= 64"),
        ("line = { fraction = \"1/3\", tol = 2.0 }", arc, "line.tol"),
        (
            "line = { fraction = \"1/3\", tolerance = 0.1 }",
            arc,
            "tolerance",
        ),
        (
            "hops = true",
            "key = \"excitation.frequency_hz\"\nvalues = [5.0]",
            "cannot be an unknown",
        ),
        (
            "hops = true",
            "key = \"limiter.no_such_key\"\nvalues = [1.0]",
            "no_such_key",
        ),
    ] {
        let e = calibration_from_toml(&with(case, unknown), "<t>", &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{case} / {unknown}: {e}");
    }
    // 10 000 candidates × 7 cases × 64 initial states: 4.48e6 instances, over a map's limit.
    let mut huge = format!(
        "{BASE}[calibrate]\ninitial_states = 64\n[[calibrate.unknowns]]\n{}\ncount = 10000\n",
        "key = \"limiter.contact_arc_m\"\nstart = 0.1\nend = 0.3"
    );
    for _ in 0..7 {
        huge.push_str(&format!(
            "[[calibrate.cases]]\n{}\nhops = true\n",
            case_set(8.0, 0.009)
        ));
    }
    let e = calibration_from_toml(&huge, "<t>", &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("4480000 instances") && e.contains("at most 4000000"),
        "{e}"
    );
    let fixed = format!(
        "{BASE}[calibrate]\n[[calibrate.unknowns]]\n{arc}\n[[calibrate.cases]]\n\
         set = {{ \"limiter.contact_arc_m\" = 0.2 }}\nhops = true\n"
    );
    let e = calibration_from_toml(&fixed, "<t>", &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("is an unknown of this calibration"), "{e}");
}

#[test]
fn a_calibration_where_every_run_fails_says_so_and_exits_3() {
    let dir =
        std::env::temp_dir().join(format!("pendulum-atlas-calib-fail-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let spec = dir.join("spec.toml");
    // A step forty times the explicit method's limit: every run blows up.
    std::fs::write(
        &spec,
        format!(
            "{BASE}dt_s = 0.02\nmethod = \"rk4\"\n[calibrate]\ninitial_states = 1\n\
             [[calibrate.unknowns]]\nkey = \"limiter.clearance_deg\"\nvalues = [10.0, 20.0]\n\
             [[calibrate.cases]]\nname = \"8 Hz\"\n{}\nk_class = \"chaotic\"\n",
            case_set(8.0, 0.009)
        ),
    )
    .unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
        .args(["calibrate", "--backend", "cpu", "--quiet", "--out"])
        .arg(dir.join("out"))
        .arg(&spec)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("no run of any of the") && err.contains("candidates ended ok"),
        "{err}"
    );
    // The files say so too: the report first, the manifest, and every candidate's row.
    let out = dir.join("out");
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(report.contains("**Every run failed.**"), "{report}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("calibrate.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["usable"], false, "{manifest}");
    let csv = std::fs::read_to_string(out.join("candidates.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let judged = header
        .iter()
        .position(|h| *h == "judged")
        .expect("a judged column");
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(!rows.is_empty(), "{csv}");
    assert!(rows.iter().all(|r| r[judged] == "0"), "{csv}");
}

#[test]
fn a_spread_that_takes_the_starts_past_the_bumpers_reach_names_the_spread() {
    let text = format!(
        "{BASE}[calibrate]\ninitial_states = 3\ninitial_spread_deg = 85.0\n\
         [[calibrate.unknowns]]\nkey = \"limiter.clearance_deg\"\nvalues = [10.0, 20.0]\n\
         [[calibrate.cases]]\nname = \"8 Hz\"\n{}\nk_class = \"chaotic\"\n",
        case_set(8.0, 0.009)
    );
    let e = calibration_from_toml(&text, "<test>", &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("calibrate.initial_spread_deg"), "{e}");
    assert!(!e.contains("`initial.angle_deg`"), "{e}");
    // The range named is the binding one: the start follows the clearance, so the 20 deg
    // end of the unknown's range binds (70), not the 10 deg end met first (80).
    assert!(e.contains("[0, 70) deg"), "{e}");
}

//! The command line end to end: files, columns and keys named exactly as documented.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

fn out_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("pendulum-atlas-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn simulate_writes_trajectory_and_run_json() {
    let out = out_dir("simulate");
    let st = bin()
        .args(["simulate", "configs/paper.toml", "--set", "beam.segments=3", "--set", "integration.duration_s=0.5"])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,x0_m,alpha_rad,alpha_dot_rad_s,tip_x_m,tip_y_m,chord_m,contact_force_n,energy_j"
    );
    assert_eq!(lines.count(), 501);
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    for key in ["scene", "dt_s", "steps", "wall_time_s", "integrator", "status"] {
        assert!(run.get(key).is_some(), "run.json lacks {key}");
    }
    assert_eq!(run["status"], "ok");
    assert_eq!(run["scene"]["beam"]["segments"], 3);
}

#[test]
fn simulate_with_piezo_adds_its_columns_and_reference_runs() {
    let out = out_dir("piezo");
    let st = bin()
        .args(["simulate", "--integrator", "reference"])
        .args(["--set", "beam.segments=3", "--set", "piezo.enabled=true", "--set", "integration.duration_s=0.1"])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(csv.lines().next().unwrap().ends_with(",energy_j,piezo_v,power_w"));
}

#[test]
fn modes_json_has_the_documented_keys() {
    let o = bin()
        .args(["modes", "--json", "--set", "pivot.mode=clamped", "--set", "gravity.g_m_s2=0", "--set", "beam.segments=3"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = v["frequencies_hz"].as_array().unwrap();
    assert!((f[0].as_f64().unwrap() - 24.41).abs() < 0.01);
    assert!(v["unstable_rates_per_s"].as_array().unwrap().is_empty());
    assert!(v["dt_auto_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_input_gives_a_clear_error_and_no_panic() {
    let o = bin().args(["modes", "--set", "beam.mass_kg=-1"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("`beam.mass_kg` = -1 is out of range"), "{err}");
    assert!(!err.contains("panicked"));
    let o = bin().args(["modes", "no/such/scene.toml"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot read scene file"));
}

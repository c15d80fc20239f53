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
        .args([
            "simulate",
            "configs/paper.toml",
            "--set",
            "beam.segments=3",
            "--set",
            "integration.duration_s=0.5",
        ])
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
    for key in [
        "scene",
        "dt_s",
        "steps",
        "wall_time_s",
        "integrator",
        "status",
    ] {
        assert!(run.get(key).is_some(), "run.json lacks {key}");
    }
    assert_eq!(run["status"], "ok");
    assert_eq!(run["scene"]["beam"]["segments"], 3);
    // The method, both automatic steps and the damping in its three forms.
    assert_eq!(run["integrator"], "engine");
    assert!(["rk4", "imex"].contains(&run["method"].as_str().unwrap()));
    assert!(run["method_reason"].as_str().unwrap().contains("auto"));
    for key in ["rk4_auto_s", "imex_auto_s", "rk4_stable_s"] {
        assert!(run["method_steps"][key].as_f64().unwrap() > 0.0, "{key}");
    }
    let zeta = run["damping"]["first_mode_damping_ratio"].as_f64().unwrap();
    assert!((zeta - 0.054).abs() < 0.003, "ζ1 = {zeta} at N = 3");
    let beta = run["damping"]["damping_time_s"].as_f64().unwrap();
    assert!((beta - 6.86e-4).abs() < 0.01e-4, "β = {beta}");
    assert!(run["damping"]["joint_damping_nms"].as_f64().unwrap() > 0.0);
    // Half a second leaves no forcing period for λ1's twin: said, not an error.
    assert!(
        run["lyapunov"]["skipped"]
            .as_str()
            .unwrap()
            .contains("lengthen integration.duration_s"),
        "{}",
        run["lyapunov"]
    );
}

#[test]
fn simulate_reports_lambda1_of_an_engine_run_and_says_why_the_reference_has_none() {
    let out = out_dir("lambda1");
    let o = bin()
        .args(["simulate", "--set", "beam.segments=3"])
        .args([
            "--set",
            "excitation.frequency_hz=4.0",
            "--set",
            "excitation.amplitude_m=0.004",
        ])
        .args([
            "--set",
            "integration.duration_s=40.0",
            "--set",
            "integration.transient_s=20.0",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("lambda1 = "));
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let l = &run["lyapunov"];
    // The impacting period-2 orbit of the engine suite: its Floquet exponent is −3.30 1/s.
    let lambda = l["per_s"].as_f64().unwrap();
    assert!((lambda + 3.3).abs() < 0.33, "{l}");
    assert!(l["se_per_s"].as_f64().unwrap() >= 0.0);
    assert_eq!(l["twin"]["plan"]["period_s"].as_f64().unwrap(), 0.25);
    assert_eq!(l["twin"]["d0"].as_f64().unwrap(), 1e-8);
    let out = out_dir("lambda1-ref");
    let o = bin()
        .args([
            "simulate",
            "--integrator",
            "reference",
            "--set",
            "beam.segments=3",
        ])
        .args(["--set", "integration.duration_s=0.3"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert!(
        run["lyapunov"]["skipped"]
            .as_str()
            .unwrap()
            .contains("--integrator engine")
    );
}

#[test]
fn simulate_refuses_the_reference_in_f32() {
    let out = out_dir("reference_f32");
    let o = bin()
        .args([
            "simulate",
            "--integrator",
            "reference",
            "--precision",
            "f32",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("f64 only"), "{err}");
    assert!(!out.join("run.json").exists());
}

#[test]
fn simulate_with_piezo_adds_its_columns_and_reference_runs() {
    let out = out_dir("piezo");
    let st = bin()
        .args(["simulate", "--integrator", "reference"])
        .args([
            "--set",
            "beam.segments=3",
            "--set",
            "piezo.enabled=true",
            "--set",
            "integration.duration_s=0.1",
        ])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(
        csv.lines()
            .next()
            .unwrap()
            .ends_with(",energy_j,piezo_v,power_w")
    );
}

#[test]
fn modes_json_has_the_documented_keys() {
    let o = bin()
        .args([
            "modes",
            "--json",
            "--set",
            "pivot.mode=clamped",
            "--set",
            "gravity.g_m_s2=0",
            "--set",
            "beam.segments=3",
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let f = v["frequencies_hz"].as_array().unwrap();
    assert!((f[0].as_f64().unwrap() - 24.41).abs() < 0.01);
    assert!(v["unstable_rates_per_s"].as_array().unwrap().is_empty());
    assert!(v["dt_auto_s"].as_f64().unwrap() > 0.0);
    assert!(v["method_steps"]["imex_auto_s"].as_f64().unwrap() > 0.0);
    assert!(v["damping"]["damping_time_s"].as_f64().unwrap() > 0.0);
    assert!(["rk4", "imex"].contains(&v["method"].as_str().unwrap()));
}

#[test]
fn bad_input_gives_a_clear_error_and_no_panic() {
    let o = bin()
        .args(["modes", "--set", "beam.mass_kg=-1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("`beam.mass_kg` = -1 is out of range"), "{err}");
    assert!(!err.contains("panicked"));
    let o = bin()
        .args(["modes", "no/such/scene.toml"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot read scene file"));
}

#[test]
fn simulate_analyses_its_own_run() {
    let out = out_dir("simulate-analysis");
    let st = bin()
        .args([
            "simulate",
            "--set",
            "beam.segments=3",
            "--set",
            "integration.duration_s=20",
            "--set",
            "integration.transient_s=5",
        ])
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let k = run["analysis"]["zero_one"]["K"].as_f64().unwrap();
    assert!(k.is_finite());
    assert!(run["analysis"]["phase_sync"]["R"].as_f64().unwrap() <= 1.0);
    for f in [
        "time_series.png",
        "spectrum.png",
        "scalogram.png",
        "zero_one.png",
        "phase_hist.png",
        "portrait.png",
    ] {
        let img = image::open(out.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        assert!(img.width() >= 600 && img.height() >= 400, "{f} too small");
    }
}

/// A record with a 1/3 subharmonic response to 8 Hz forcing, written as CSV.
fn write_record(path: &std::path::Path, nan_at: Option<usize>) {
    let mut s = String::from("t_s,cart_m,angle_rad\n");
    for i in 0..16000 {
        let t = i as f64 / 200.0;
        let cart = 0.009 * (std::f64::consts::TAU * 8.0 * t).sin();
        let angle = 0.3 * (std::f64::consts::TAU * 8.0 / 3.0 * t).sin();
        if nan_at == Some(i) {
            s.push_str(&format!("{t},{cart},NaN\n"));
        } else {
            s.push_str(&format!("{t},{cart},{angle}\n"));
        }
    }
    std::fs::write(path, s).unwrap();
}

#[test]
fn analyze_writes_the_documented_files_and_keys() {
    let out = out_dir("analyze");
    std::fs::create_dir_all(&out).unwrap();
    let data = out.join("rig.csv");
    write_record(&data, None);
    let st = bin()
        .arg("analyze")
        .arg(&data)
        .args([
            "--signal",
            "angle_rad",
            "--reference",
            "cart_m",
            "--time",
            "t_s",
            "--forcing-hz",
            "8",
        ])
        .args(["--phase-convention", "paper", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("analysis.json")).unwrap()).unwrap();
    assert!(
        j["zero_one"]["K"].as_f64().unwrap().abs() < 0.1,
        "{}",
        j["zero_one"]
    );
    assert_eq!(j["zero_one"]["method"], "correlation");
    assert!(j["zero_one"]["n_samples"].as_u64().unwrap() > 50);
    assert!(j["zero_one"]["warnings"].is_array());
    assert_eq!(j["phase_sync"]["convention"], "paper");
    // A 1/3 subharmonic is not 1:1 locked to its forcing: Δφ drifts uniformly, and the paper
    // convention (Δφ mod π) then gives its "random" value 2/π.
    let r = j["phase_sync"]["R"].as_f64().unwrap();
    assert!((r - 2.0 / std::f64::consts::PI).abs() < 0.05, "R = {r}");
    assert!((j["spectrum"]["dominant_hz"].as_f64().unwrap() - 8.0 / 3.0).abs() < 0.02);
    assert_eq!(j["spectrum"]["ratio_label"], "1/3");
    assert!((j["spectrum"]["ratio_to_forcing"].as_f64().unwrap() - 1.0 / 3.0).abs() < 0.01);
    assert!(j["options"]["forcing_hz"].as_f64().is_some());
    for f in [
        "spectrum.csv",
        "wavelet_power.npy",
        "wavelet_period_s.npy",
        "wavelet_coi_s.npy",
        "phase_diff_rad.npy",
        "spectrum.png",
        "scalogram.png",
        "zero_one.png",
        "phase_hist.png",
        "portrait.png",
    ] {
        assert!(out.join(f).is_file(), "missing {f}");
    }
    let spec = std::fs::read_to_string(out.join("spectrum.csv")).unwrap();
    assert!(spec.starts_with("frequency_hz,amplitude\n"));
}

#[test]
fn analyze_rejects_bad_records_clearly() {
    let out = out_dir("analyze-bad");
    std::fs::create_dir_all(&out).unwrap();
    let data = out.join("rig.csv");
    write_record(&data, Some(100));
    let run = |extra: &[&str]| {
        let o = bin()
            .arg("analyze")
            .arg(&data)
            .args(extra)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        let e = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(!e.contains("panicked"), "{e}");
        e
    };
    let e = run(&[
        "--signal",
        "angle_rad",
        "--time",
        "t_s",
        "--forcing-hz",
        "8",
    ]);
    assert!(e.contains("line 102") && e.contains("not finite"), "{e}");
    let e = run(&["--signal", "encoder", "--time", "t_s", "--forcing-hz", "8"]);
    assert!(
        e.contains("no column `encoder`") && e.contains("cart_m"),
        "{e}"
    );
    // Stroboscopic sampling without the forcing frequency cannot be done: say which flag.
    let e = run(&[
        "--signal",
        "cart_m",
        "--time",
        "t_s",
        "--sampling",
        "stroboscopic",
    ]);
    assert!(e.contains("--forcing-hz"), "{e}");
    std::fs::write(&data, "t_s,angle_rad\n").unwrap();
    let e = run(&[
        "--signal",
        "angle_rad",
        "--time",
        "t_s",
        "--forcing-hz",
        "8",
    ]);
    assert!(e.contains("no data rows"), "{e}");
    // 20 rows whose time steps alternate 0.1 s and 0.15 s: not uniform.
    let rows: String = (0..20)
        .map(|i| {
            format!(
                "{},{}\n",
                0.125 * f64::from(i) - 0.025 * f64::from(i % 2),
                i
            )
        })
        .collect();
    std::fs::write(&data, format!("t_s,angle_rad\n{rows}")).unwrap();
    let e = run(&[
        "--signal",
        "angle_rad",
        "--time",
        "t_s",
        "--sampling",
        "uniform",
    ]);
    assert!(e.contains("--resample"), "{e}");
}

#[test]
fn a_run_of_no_step_is_refused() {
    // A 10-ms scene at dt = 50 ms (which still resolves the 8-Hz forcing), and a 1-ns scene
    // at the automatic step.
    for (duration, dt) in [("0.01", "0.05"), ("1e-9", "\"auto\"")] {
        let set = format!("integration.duration_s={duration}");
        let step = format!("integration.dt_s={dt}");
        let out = out_dir("no_step");
        let o = bin()
            .args([
                "simulate",
                "--set",
                "beam.segments=3",
                "--set",
                &set,
                "--set",
                &step,
            ])
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{set}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("no step") && err.contains("integration.duration_s"),
            "{err}"
        );
        assert!(!out.join("run.json").exists(), "{set}");
    }
}

/// `simulate` with RK4 at ten times its stable step (N = 3, 2 s): the run blows up.
fn blown_up_simulate(out: &std::path::Path) -> std::process::Output {
    bin()
        .args(["simulate", "--set", "beam.segments=3", "--set"])
        .args(["integration.method=rk4", "--set", "integration.dt_s=1e-2"])
        .args(["--set", "integration.duration_s=2", "--out"])
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn a_failed_run_writes_its_files_and_exits_3() {
    // RK4 at ten times its stable step: the run blows up and is flagged.
    let out = out_dir("failed_run");
    let o = blown_up_simulate(&out);
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_ne!(run["status"], "ok");
    assert!(String::from_utf8_lossy(&o.stderr).contains("stopped with status"));
    // A map none of whose instances ends ok exits 3 too, after writing map.json.
    let map_out = out_dir("failed_map");
    let o = bin()
        .args([
            "map",
            "configs/stress/dt_beyond_limit.toml",
            "--backend",
            "cpu",
            "--quiet",
        ])
        .args([
            "--set",
            "integration.method=rk4",
            "--set",
            "integration.dt_s=1e-2",
        ])
        .arg("--out")
        .arg(&map_out)
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(map_out.join("map.json").exists());
}

#[test]
fn simulate_prints_its_warnings_and_every_file_it_wrote() {
    // RK4 beyond its stable step: the run stops early, run.json carries the warning that rows
    // after that time are not written, and it must be printed too; the last line counts the
    // files this run wrote, not the user's own file beside them.
    let out = out_dir("feedback");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("notes.txt"), "the user's own file").unwrap();
    let o = blown_up_simulate(&out);
    assert_eq!(o.status.code(), Some(3));
    let err = String::from_utf8_lossy(&o.stderr);
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let warnings = run["warnings"].as_array().unwrap();
    assert!(!warnings.is_empty());
    for w in warnings {
        assert!(
            err.contains(w.as_str().unwrap()),
            "{w} not printed in:\n{err}"
        );
    }
    // Everything but the user's file and the run's hidden folder lock.
    let written = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            !e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with('.')
        })
        .count()
        - 1;
    assert!(
        err.contains(&format!("wrote {written} files to {}", out.display())),
        "{err}"
    );
}

/// `simulate` of a 1-s N = 3 run into `out`, with extra arguments.
fn small_simulate(out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    bin()
        .args([
            "simulate",
            "--set",
            "beam.segments=3",
            "--set",
            "integration.duration_s=1",
        ])
        .args(extra)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

#[test]
fn a_rerun_into_a_used_folder_is_refused_unless_forced_and_force_clears_only_its_files() {
    let out = out_dir("rerun");
    assert!(small_simulate(&out, &[]).status.success());
    let run_json = std::fs::read(out.join("run.json")).unwrap();
    // What an earlier, different run could have left, and a file of the user's.
    std::fs::write(out.join("wavelet_signif_ratio.npy"), b"old").unwrap();
    std::fs::write(out.join("notes.txt"), b"mine").unwrap();
    std::fs::write(out.join("R_of_my_rig.npy"), b"mine").unwrap();
    let o = small_simulate(&out, &["--set", "excitation.frequency_hz=5"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("already holds") && e.contains("--force") && e.contains("run.json"),
        "{e}"
    );
    assert_eq!(std::fs::read(out.join("run.json")).unwrap(), run_json);
    let o = small_simulate(&out, &["--set", "excitation.frequency_hz=5", "--force"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("--force: ") && e.contains("set aside"), "{e}");
    let stale = std::fs::read(out.join("wavelet_signif_ratio.npy")).unwrap_or_default();
    assert_ne!(stale, b"old", "the earlier run's file is gone or rewritten");
    assert_eq!(std::fs::read(out.join("notes.txt")).unwrap(), b"mine");
    assert_eq!(std::fs::read(out.join("R_of_my_rig.npy")).unwrap(), b"mine");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(run["scene"]["excitation"]["kind"]["frequency_hz"], 5.0);
}

#[test]
fn a_folder_holding_another_commands_run_is_refused_even_with_force() {
    let out = out_dir("other-run");
    assert!(small_simulate(&out, &[]).status.success());
    let o = bin()
        .args([
            "map",
            "--backend",
            "cpu",
            "--set",
            "beam.segments=3",
            "--force",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("`simulate` run") && e.contains("run.json"),
        "{e}"
    );
    assert!(out.join("trajectory.csv").is_file());
    assert!(!out.join("map.json").exists());
}

#[test]
fn map_checks_its_output_folder_before_any_work() {
    let dir = out_dir("map-out-is-a-file");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("x");
    std::fs::write(&file, b"").unwrap();
    // A map of days of work: only a check made first can answer in time.
    let mut child = bin()
        .args([
            "map",
            "--backend",
            "cpu",
            "--quiet",
            "--set",
            "integration.duration_s=1e4",
            // Raw: settling to 2e4 s would make it a huge map, refused as such first.
            "--set",
            "map.settle=false",
        ])
        .arg("--out")
        .arg(&file)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if started.elapsed().as_secs() > 120 {
            child.kill().unwrap();
            panic!("map computed before checking --out");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let mut e = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut e).unwrap();
    assert_eq!(status.code(), Some(2), "{e}");
    assert!(
        e.contains("is a file") && e.contains(&*file.to_string_lossy()),
        "{e}"
    );
}

#[test]
fn simulate_refuses_a_run_beyond_the_step_limit_or_the_machine_before_starting() {
    for (set, says) in [
        ("integration.dt_s=1e-300", "limit is 4294967295"),
        ("integration.duration_s=1e12", "limit is 4294967295"),
        // 4e9 rows of 112 bytes: more memory than a test machine has.
        ("output.sample_rate_hz=1e9", "of memory"),
    ] {
        let out = out_dir("too-large");
        let o = bin()
            .args(["simulate", "--set", "beam.segments=3", "--set"])
            .args(["integration.duration_s=4", "--set", set])
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{set}: {e}");
        assert!(e.contains(says), "{set}: {e}");
        assert!(!out.exists(), "{set}: the folder was created");
    }
}

#[test]
fn a_missing_scene_is_named_once_with_its_reason() {
    for cmd in ["simulate", "map", "modes"] {
        let o = bin()
            .args([cmd, "no-such-scene.toml"])
            .args(if cmd == "modes" {
                vec![]
            } else {
                vec!["--out", "/nonexistent-out"]
            })
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {e}");
        assert_eq!(e.matches("no-such-scene.toml").count(), 1, "{cmd}: {e}");
        assert_eq!(e.matches("No such file").count(), 1, "{cmd}: {e}");
    }
}

#[test]
fn calibrate_writes_its_candidates_best_scene_report_and_manifest() {
    let out = out_dir("calibrate");
    let o = bin()
        .args([
            "calibrate",
            "configs/calibrate/paper.toml",
            "--backend",
            "cpu",
            "--quiet",
        ])
        .args([
            "--set",
            "beam.segments=3",
            "--set",
            "calibrate.initial_states=1",
        ])
        .args(["--set", "calibrate.refine.rounds=0"])
        .args([
            "--set",
            "calibrate.unknowns=[{key=\"limiter.contact_arc_m\",values=[0.03,0.3]},{key=\"limiter.clearance_deg\",values=[15.0,25.0]}]",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("calibrate.json")).unwrap())
            .unwrap();
    // Table 2: 6 cases × (K class, R) and three lines; the experiments: R and no period each,
    // and one line.
    assert_eq!(json["observations"], 6 * 2 + 3 + 3 * 2 + 1);
    // 2 × 2 candidates × 9 cases × 1 initial state.
    assert_eq!(json["instances"], 4 * 9);
    let best = json["best"]["values"][0].as_f64().unwrap();
    let best_clearance = json["best"]["values"][1].as_f64().unwrap();
    let csv = std::fs::read_to_string(out.join("candidates.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 5, "{csv}");
    assert!(
        rows[1].starts_with(&format!("1,grid,{best},{best_clearance},")),
        "{csv}"
    );
    let png = out.join("agreement_limiter_contact_arc_m_limiter_clearance_deg.png");
    image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display()));
    // The best scene is a scene `simulate` reads, with the best value in it.
    let scene = std::fs::read_to_string(out.join("best_scene.toml")).unwrap();
    let parsed = pendulum_atlas_core::config::Scene::from_toml(&scene, "<best>", &[]).unwrap();
    assert_eq!(parsed.limiter.contact_arc_m, best);
    assert!(!scene.contains("[calibrate]"), "{scene}");
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(
        report.contains("Best candidate") && report.contains("Never matched"),
        "{report}"
    );
}

#[test]
fn cpu_loop_is_recorded_and_refused_on_the_gpu() {
    let out = out_dir("cpu-loop");
    std::fs::create_dir_all(&out).unwrap();
    let tiny = out.join("tiny.toml");
    std::fs::write(
        &tiny,
        "[beam]\nsegments = 3\n[integration]\nduration_s = 3.0\ntransient_s = 1.0\n[map]\nmetrics = [\"hops\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [6.0, 8.0, 10.0]\n",
    )
    .unwrap();
    let st = bin()
        .args(["map", "--backend", "cpu", "--cpu-loop", "scalar"])
        .arg(&tiny)
        .arg("--out")
        .arg(out.join("run"))
        .status()
        .unwrap();
    assert!(st.success());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run").join("map.json")).unwrap())
            .unwrap();
    assert!(
        json["adapter"].as_str().unwrap().contains("scalar loop"),
        "{}",
        json["adapter"]
    );
    let share = &json["wall_share"];
    let sum: f64 = ["plan", "device", "integrate", "reduce"]
        .iter()
        .map(|k| share[k].as_f64().unwrap())
        .sum();
    assert!(sum > 0.5 && sum <= 1.0 + 1e-9, "{share}");
    let refused = bin()
        .args(["map", "--backend", "gpu", "--cpu-loop", "simd"])
        .arg(&tiny)
        .arg("--out")
        .arg(out_dir("cpu-loop-gpu"))
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        err.contains("--cpu-loop applies to the CPU engine") || err.contains("no GPU adapter"),
        "{err}"
    );
}

#[test]
fn slurm_refuses_an_out_folder_that_would_inject_a_line_into_its_scripts() {
    let base = out_dir("slurm-inject");
    std::fs::create_dir_all(&base).unwrap();
    let pwned = base.join("pwned");
    for bad in [
        format!(
            "{}/x\n#SBATCH --wrap=touch {}\ny",
            base.display(),
            pwned.display()
        ),
        format!("{}/x\ntouch {}", base.display(), pwned.display()),
        format!("{}/q\"uote", base.display()),
    ] {
        let o = bin()
            .args(["slurm", "--shards", "2", "--out", &bad])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {err}");
        assert!(
            err.contains("--out") && err.contains("control characters"),
            "{err}"
        );
        assert!(err.lines().count() <= 3, "{err}");
    }
    let left: Vec<_> = std::fs::read_dir(&base).unwrap().collect();
    assert!(left.is_empty(), "nothing written: {left:?}");
    assert!(!pwned.exists());
}

#[test]
fn bench_reads_its_peers_before_the_study() {
    let peers = out_dir("bad-peers");
    std::fs::create_dir_all(&peers).unwrap();
    std::fs::write(peers.join("jax_cpu_N3.json"), "{ not json").unwrap();
    std::fs::write(peers.join("jax_gpu_N3.json"), "{ not json").unwrap();
    for study in ["--cpu-throughput", "--throughput"] {
        let out = out_dir("bad-peers-out");
        let o = bin()
            .args(["bench", study, "--quick", "--backend", "cpu", "--peers"])
            .arg(&peers)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_ne!(o.status.code(), Some(0), "{study}: {err}");
        assert!(err.contains("jax_"), "{study}: {err}");
        // Nothing of the study ran: its progress lines never came.
        assert!(err.lines().count() <= 3, "{study}: {err}");
    }
}

#[test]
fn an_input_named_like_an_output_in_out_is_refused_and_kept() {
    let dir = out_dir("input-is-output");
    std::fs::create_dir_all(&dir).unwrap();
    let record = dir.join("spectrum.csv");
    let rows: String = (0..2000)
        .map(|i| format!("{},{}\n", i as f64 / 200.0, (i as f64 * 0.1).sin()))
        .collect();
    std::fs::write(&record, format!("t_s,x\n{rows}")).unwrap();
    let before = std::fs::read(&record).unwrap();
    let o = bin()
        .args([
            "analyze", "--signal", "x", "--time", "t_s", "--force", "--out",
        ])
        .arg(&dir)
        .arg(&record)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("is an input of this run"), "{err}");
    assert_eq!(
        std::fs::read(&record).unwrap(),
        before,
        "the input is untouched"
    );
    // A map scene saved as the folder's own map_scene.toml, likewise.
    let scene = dir.join("map_scene.toml");
    std::fs::write(&scene, pendulum_atlas_core::config::DEFAULT_MAP_TOML).unwrap();
    let o = bin()
        .args(["map", "--backend", "cpu", "--force", "--out"])
        .arg(&dir)
        .arg(&scene)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("map_scene.toml") && err.contains("input"),
        "{err}"
    );
}

#[test]
fn simulate_analyses_rows_at_the_rate_they_were_written() {
    // A given step longer than the output interval: a row every step (4e-4 s), not every
    // 1/4000 s. The analysis must read the rows at 2500 Hz, as a run asking for 2500 Hz does.
    let run = |rate: &str, name: &str| {
        let out = out_dir(name);
        let o = bin()
            .args(["simulate", "--set", "beam.segments=3", "--set"])
            .args([
                "integration.duration_s=20.0",
                "--set",
                "integration.dt_s=4e-4",
            ])
            .args(["--set", &format!("output.sample_rate_hz={rate}"), "--out"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
        j
    };
    let (fast, matched) = (run("4000", "rows-4000"), run("2500", "rows-2500"));
    assert_eq!(fast["rows"], matched["rows"]);
    for (section, key) in [
        ("spectrum", "dominant_hz"),
        ("zero_one", "K"),
        ("phase_sync", "R"),
        ("statistics", "period"),
    ] {
        let (a, b) = (
            fast["analysis"][section][key].as_f64().unwrap(),
            matched["analysis"][section][key].as_f64().unwrap(),
        );
        // The two rates differ in the last bits at most (1/(1 · 4e-4) against 2500).
        assert!(
            (a - b).abs() <= 1e-9 * b.abs().max(1.0),
            "{section}.{key}: {a} vs {b}"
        );
    }
    assert!(
        fast["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|w| w.as_str().unwrap().contains("not a multiple")),
        "{fast}"
    );
}

#[test]
fn a_step_that_cannot_sample_the_forcing_is_refused() {
    for sets in [
        ["excitation.frequency_hz=10.0", "integration.dt_s=0.05"],
        ["excitation.frequency_hz=10.0", "integration.dt_s=0.1"],
        ["excitation.kind=\"sweep\"", "integration.dt_s=0.07"],
    ] {
        let o = bin()
            .args(["simulate", "--set", sets[0], "--set", sets[1], "--out"])
            .arg(out_dir("nyquist"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{sets:?}: {err}");
        assert!(
            err.contains("integration.dt_s") && err.contains("steps per forcing period"),
            "{err}"
        );
    }
}

#[test]
fn a_second_run_into_a_folder_in_use_is_refused() {
    let out = out_dir("busy");
    let mut first = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .spawn()
        .unwrap();
    let lock = out.join(".pendulum-atlas.lock");
    let started = std::time::Instant::now();
    while !lock.exists() && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let second = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--force", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let still_running = first.try_wait().unwrap().is_none();
    let _ = first.kill();
    let _ = first.wait();
    assert!(still_running, "the first map ran for the whole check");
    let err = String::from_utf8_lossy(&second.stderr);
    assert_eq!(second.status.code(), Some(2), "{err}");
    assert!(err.contains("in use by another run"), "{err}");
}

#[test]
fn inputs_that_would_take_unbounded_memory_are_refused_with_a_short_message() {
    let dir = out_dir("unbounded");
    std::fs::create_dir_all(&dir).unwrap();
    let run = |args: &[&str]| {
        let o = bin().args(args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.len() < 1500 && err.lines().count() <= 6,
            "{args:?}: {err}"
        );
        err
    };
    let out = dir.join("out");
    let out = out.to_str().unwrap();
    // A record with one stray time stamp at the end.
    let csv = dir.join("stray.csv");
    let mut text = String::from("t_s,x\n");
    for i in 0..4000 {
        text.push_str(&format!(
            "{},{}\n",
            i as f64 / 200.0,
            (i as f64 * 0.3).sin()
        ));
    }
    text.push_str("1e9,0.0\n");
    std::fs::write(&csv, text).unwrap();
    let csv = csv.to_str().unwrap();
    let e = run(&[
        "analyze",
        csv,
        "--signal",
        "x",
        "--time",
        "t_s",
        "--resample",
        "--allow-gaps",
        "--out",
        out,
    ]);
    assert!(e.contains("far from the others"), "{e}");
    // A scale spacing near zero.
    let uniform = dir.join("uniform.csv");
    std::fs::write(
        &uniform,
        text_without_last_line(&std::fs::read_to_string(csv).unwrap()),
    )
    .unwrap();
    let uniform = uniform.to_str().unwrap();
    let e = run(&[
        "analyze",
        uniform,
        "--signal",
        "x",
        "--time",
        "t_s",
        "--wavelet-dj",
        "1e-12",
        "--out",
        out,
    ]);
    assert!(e.contains("raise dj"), "{e}");
    // Endless streams and huge one-line files as scenes or records.
    let e = run(&["simulate", "/dev/zero", "--out", out]);
    assert!(e.contains("more than the 1048576 bytes"), "{e}");
    let e = run(&[
        "analyze",
        "/dev/zero",
        "--signal",
        "x",
        "--sample-rate-hz",
        "100",
        "--out",
        out,
    ]);
    assert!(e.contains("no line ends within its first"), "{e}");
    let long = dir.join("long.toml");
    std::fs::write(
        &long,
        format!("[beam]\nsegments = {}\n", "9".repeat(500_000)),
    )
    .unwrap();
    run(&["simulate", long.to_str().unwrap(), "--out", out]);
    let huge = dir.join("huge.toml");
    std::fs::write(&huge, "#".repeat(2 << 20)).unwrap();
    let e = run(&["map", huge.to_str().unwrap(), "--out", out]);
    assert!(e.contains("not a scene file"), "{e}");
}

fn text_without_last_line(text: &str) -> String {
    let mut lines: Vec<&str> = text.lines().collect();
    lines.pop();
    lines.join("\n") + "\n"
}

#[test]
fn simulate_fails_when_its_analysis_cannot_be_written_and_leaves_no_temporary_file() {
    let out = out_dir("unwritable-analysis");
    // A folder where the analysis' spectrum.csv goes: its write fails as a full disk would.
    std::fs::create_dir_all(out.join("spectrum.csv").join("x")).unwrap();
    let o = bin()
        .args(["simulate", "--set", "beam.segments=3", "--set"])
        .args(["integration.duration_s=20.0", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_ne!(o.status.code(), Some(0), "{err}");
    assert!(err.contains("spectrum.csv"), "{err}");
    assert!(
        !out.join("run.json").exists(),
        "no manifest: the folder is not complete"
    );
    let temporaries: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(temporaries.is_empty(), "{temporaries:?}");
}

#[test]
fn force_deletes_only_the_files_of_the_earlier_run() {
    let out = out_dir("force-ours-only");
    let small = [
        "--set",
        "map.axes=[{key=\"excitation.frequency_hz\",values=[5.0,8.0]}]",
        "--set",
        "integration.duration_s=22.0",
        "--set",
        "integration.transient_s=2.0",
    ];
    let map = |force: bool| {
        let mut c = bin();
        c.args(["map", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args(small);
        if force {
            c.arg("--force");
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    map(false);
    for own in ["rig_photo.png", "calib.npy", "notes.txt"] {
        std::fs::write(out.join(own), "the user's").unwrap();
    }
    map(true);
    for own in ["rig_photo.png", "calib.npy", "notes.txt"] {
        assert_eq!(
            std::fs::read_to_string(out.join(own)).unwrap(),
            "the user's",
            "{own}"
        );
    }
    assert!(out.join("K.npy").is_file() && out.join("map.json").is_file());
}

#[test]
fn a_reference_run_says_it_ran_dop853_and_why() {
    let out = out_dir("dop853-reason");
    let o = bin()
        .args([
            "simulate",
            "--integrator",
            "reference",
            "--set",
            "beam.segments=3",
        ])
        .args(["--set", "integration.duration_s=0.3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    assert_eq!(run["method"], "dop853");
    let reason = run["method_reason"].as_str().unwrap();
    assert!(
        reason.contains("DOP853") && !reason.contains("cheaper"),
        "{reason}"
    );
}

/// The automatic step resolves the forcing as a given step must: a 2000 Hz forcing gets at
/// least 16 steps per period (with a warning that says so), so the cart moves.
#[test]
fn the_automatic_step_resolves_a_fast_forcing() {
    let out = out_dir("fast-forcing");
    let o = small_simulate(
        &out,
        &[
            "--set",
            "excitation.frequency_hz=2000",
            "--set",
            "excitation.amplitude_m=1e-7",
            "--set",
            "output.sample_rate_hz=8000",
            "--set",
            "integration.duration_s=0.05",
            "--set",
            "integration.transient_s=0",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
    let dt = run["dt_s"].as_f64().unwrap();
    assert!(dt * 2000.0 <= 1.0 / 16.0 + 1e-12, "dt = {dt}");
    let warned = run["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .any(|w| w.as_str().unwrap().contains("automatic step is shortened"));
    assert!(warned, "{:?}", run["warnings"]);
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let x0: Vec<f64> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let span =
        x0.iter().cloned().fold(f64::MIN, f64::max) - x0.iter().cloned().fold(f64::MAX, f64::min);
    assert!(
        span > 1.5e-7,
        "the cart moves through its stroke: span {span}"
    );
}

/// A scene and a record read from a pipe (`/dev/stdin`, as `<(...)` or `cat x |` give them)
/// are read like files, up to the size cap of each.
#[test]
fn scenes_and_records_are_read_from_pipes() {
    use std::io::Write;
    use std::process::Stdio;
    let piped = |args: &[&str], input: &[u8]| {
        let mut child = bin()
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        child.stdin.take().unwrap().write_all(input).unwrap();
        let o = child.wait_with_output().unwrap();
        assert!(
            o.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    };
    let run = out_dir("pipe-scene");
    let scene = "[beam]\nsegments = 3\n[integration]\nduration_s = 4.0\ntransient_s = 1.0\n";
    piped(
        &["simulate", "/dev/stdin", "--out", run.to_str().unwrap()],
        scene.as_bytes(),
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run.join("run.json")).unwrap()).unwrap();
    assert_eq!(report["scene"]["beam"]["segments"], 3, "{report}");
    let record = std::fs::read(run.join("trajectory.csv")).unwrap();
    let analysed = out_dir("pipe-record");
    piped(
        &[
            "analyze",
            "/dev/stdin",
            "--signal",
            "alpha_rad",
            "--time",
            "t_s",
            "--forcing-hz",
            "8",
            "--out",
            analysed.to_str().unwrap(),
        ],
        &record,
    );
    assert!(analysed.join("analysis.json").is_file());
}

/// A `[cell]` section holds only the map keys that shape a cell's values: anything else is
/// refused before any work, naming the key and the keys it takes.
#[test]
fn a_cell_section_with_a_key_it_does_not_take_is_refused() {
    let out = out_dir("cell-section");
    std::fs::create_dir_all(&out).unwrap();
    let scene = out.join("cell.toml");
    std::fs::write(&scene, "[beam]\nsegments = 3\n[cell]\naxes = []\n").unwrap();
    let o = bin()
        .arg("simulate")
        .arg(&scene)
        .arg("--out")
        .arg(out.join("sim"))
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("cell.axes") && e.contains("k_seed"), "{e}");
    assert!(!out.join("sim").exists(), "nothing is written");
}

/// The packages `cargo run` at the workspace root chooses among (the root's `default-members`)
/// and the `default-run` each names, read from their manifests as Cargo reads them.
fn default_runs() -> Vec<(String, Option<String>)> {
    let read = |p: &str| -> toml::Table {
        toml::from_str(&std::fs::read_to_string(p).unwrap()).unwrap_or_else(|e| panic!("{p}: {e}"))
    };
    let root = read("Cargo.toml");
    let members = root["workspace"]["default-members"].as_array().unwrap();
    let mut runs = Vec::new();
    for m in members {
        let pattern = m.as_str().unwrap();
        let dirs: Vec<std::path::PathBuf> = match pattern.strip_suffix("/*") {
            Some(parent) => std::fs::read_dir(parent)
                .unwrap()
                .map(|e| e.unwrap().path())
                .filter(|p| p.join("Cargo.toml").is_file())
                .collect(),
            None => vec![std::path::PathBuf::from(pattern)],
        };
        for d in dirs {
            let manifest = read(d.join("Cargo.toml").to_str().unwrap());
            let package = manifest["package"].as_table().unwrap();
            let run = package
                .get("default-run")
                .and_then(|v| v.as_str())
                .map(String::from);
            runs.push((package["name"].as_str().unwrap().to_string(), run));
        }
    }
    runs
}

/// The README's main command, `cargo run --release -- map`, names no binary: Cargo takes the
/// one `default-run` among the default members, and fails on a fresh clone when there is none
/// and two of them have binaries (the lab's `pendulum-atlas-lab` beside the command line).
/// `.ci/run` runs the command as written too.
#[test]
fn the_readme_main_command_runs_the_command_line_on_a_fresh_clone() {
    let readme = std::fs::read_to_string("README.md").unwrap();
    assert!(
        readme.contains("\ncargo run --release -- map\n"),
        "the README's main command changed: update this test and .ci/run"
    );
    let ci = std::fs::read_to_string(".ci/run").unwrap();
    assert!(
        ci.lines().any(|l| l.trim() == "cargo run --release -- map"),
        ".ci/run does not run the README's main command as written"
    );
    let named: Vec<(String, String)> = default_runs()
        .into_iter()
        .filter_map(|(p, r)| r.map(|r| (p, r)))
        .collect();
    assert_eq!(
        named,
        vec![("pendulum-atlas".to_string(), "pendulum-atlas".to_string())],
        "exactly one default member may name a default-run, the command line's binary"
    );
}

/// Every file of `dir` (the lock aside) with its bytes, sorted by name; hidden folders count
/// as names.
fn snapshot(dir: &std::path::Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_name() != ".pendulum-atlas.lock")
        .map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).unwrap_or_default())
        })
        .collect();
    files.sort();
    files
}

/// Start `args`, wait until `ready` holds (the command has claimed its folder), let it work
/// for `work`, send it SIGINT as Ctrl-C does, and return its exit code and stderr.
fn interrupt(
    args: &[&str],
    out: &std::path::Path,
    ready: impl Fn() -> bool,
    work: std::time::Duration,
) -> (Option<i32>, String) {
    let child = bin()
        .args(args)
        .arg("--out")
        .arg(out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = std::time::Instant::now();
    while !ready() {
        assert!(
            t0.elapsed().as_secs() < 120,
            "the command never claimed {out:?}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(work);
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Ctrl-C while `simulate` integrates: exit 130, nothing of the truncated run kept, and the
/// earlier run that `--force` set aside back as it was (issue 71: the truncated run was saved
/// as a complete one, status "ok", exit 0).
#[test]
fn ctrl_c_on_simulate_keeps_nothing_and_puts_the_earlier_run_back() {
    let out = out_dir("ctrl-c-simulate");
    let scene = ["simulate", "configs/paper.toml", "--set", "beam.segments=3"];
    let earlier = bin()
        .args(scene)
        .args(["--set", "integration.duration_s=0.5", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(earlier.success());
    let before = snapshot(&out);
    let aside = out.join(".pendulum-atlas.earlier");
    let long = [
        &scene[..],
        &[
            "--set",
            "integration.duration_s=5000",
            "--set",
            "output.sample_rate_hz=10",
        ],
        &["--force"],
    ]
    .concat();
    let (code, e) = interrupt(
        &long,
        &out,
        || aside.exists(),
        std::time::Duration::from_millis(700),
    );
    assert_eq!(code, Some(130), "{e}");
    assert!(e.contains("nothing of this run is kept"), "{e}");
    assert_eq!(
        snapshot(&out),
        before,
        "the earlier run, whole, and nothing else"
    );
    // In a new folder, nothing at all stays.
    let fresh = out_dir("ctrl-c-simulate-new");
    let lock = fresh.join(".pendulum-atlas.lock");
    let (code, e) = interrupt(
        &long[..long.len() - 1],
        &fresh,
        || lock.exists(),
        std::time::Duration::from_millis(700),
    );
    assert_eq!(code, Some(130), "{e}");
    assert!(!fresh.exists(), "{:?}", snapshot(&fresh));
    let _ = std::fs::remove_dir_all(&out);
}

/// Ctrl-C in a command whose engines do not poll for it (`reproduce` here; `search`,
/// `analyze` and `bench` take the same handler when they claim their folder): exit 130, an
/// earlier run that `--force` set aside put back, and a folder the command made removed
/// with what it wrote (issue 71: they died by the signal, the earlier run left hidden).
#[test]
fn ctrl_c_on_a_command_without_progress_reports_stops_it_cleanly() {
    let out = out_dir("ctrl-c-reproduce");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("table2.csv"), "case,K\n").unwrap();
    std::fs::write(out.join("REPORT.md"), "# an earlier report\n").unwrap();
    std::fs::write(out.join("notes.txt"), "the user's own\n").unwrap();
    let before = snapshot(&out);
    let aside = out.join(".pendulum-atlas.earlier");
    let args = ["reproduce", "--quick", "--force"];
    let (code, e) = interrupt(
        &args,
        &out,
        || aside.exists(),
        std::time::Duration::from_millis(500),
    );
    assert_eq!(code, Some(130), "{e}");
    assert_eq!(snapshot(&out), before, "{e}");
    let fresh = out_dir("ctrl-c-reproduce-new");
    let lock = fresh.join(".pendulum-atlas.lock");
    let (code, e) = interrupt(
        &args[..2],
        &fresh,
        || lock.exists(),
        std::time::Duration::from_millis(500),
    );
    assert_eq!(code, Some(130), "{e}");
    assert!(!fresh.exists(), "{:?}", snapshot(&fresh));
    let _ = std::fs::remove_dir_all(&out);
}

/// A cell scene whose `[cell]` its run cannot serve (here a run shortened to 15 s, too short
/// for the 0–1 test's 95 stroboscopic samples) is refused before any step, writing nothing
/// (issue 71: it integrated, wrote 18 files, then exited 2).
#[test]
fn a_cell_scene_whose_cell_cannot_run_is_refused_before_any_step() {
    let dir = out_dir("cell-scene-short");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("cell.toml");
    let paper = std::fs::read_to_string("configs/paper.toml").unwrap();
    std::fs::write(&scene, format!("{paper}\n[cell]\nmetrics = [\"K\"]\n")).unwrap();
    let out = dir.join("run");
    let o = bin()
        .arg("simulate")
        .arg(&scene)
        .args([
            "--set",
            "beam.segments=3",
            "--set",
            "integration.duration_s=15",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("[cell]") && e.contains("cannot run"), "{e}");
    // Refused before the run was planned and announced (`run: N steps, ...`).
    assert!(!e.lines().any(|l| l.starts_with("run: ")), "it ran: {e}");
    assert!(!out.exists(), "{out:?} was written");
    // The same cell at the paper's 30 s runs, with the map's values of it.
    let o = bin()
        .arg("simulate")
        .arg(&scene)
        .args(["--set", "beam.segments=3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("as its map computes this cell"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

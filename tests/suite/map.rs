//! `pendulum-atlas map` end to end on both backends, and its input errors.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

fn out_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("pendulum-atlas-map-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

const TINY: [&str; 8] = [
    "--set",
    "integration.duration_s=21.0",
    "--set",
    "integration.transient_s=1.5",
    "--set",
    "map.axes=[{key=\"excitation.frequency_hz\",start=5.0,end=10.0,count=3},{key=\"limiter.clearance_deg\",start=10.0,end=30.0,count=2}]",
    "--set",
    "map.bifurcation=false",
];

fn png_size(path: &std::path::Path) -> (u32, u32) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (img.width(), img.height())
}

fn check_map_dir(out: &std::path::Path, backend: &str) {
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    assert_eq!(json["backend"], backend);
    assert_eq!(json["shape"], serde_json::json!([3, 2]));
    for key in [
        "adapter",
        "dt_s",
        "steps",
        "timings_s",
        "throughput",
        "status_counts",
        "axes",
        "method",
        "method_reason",
    ] {
        assert!(json.get(key).is_some(), "map.json lacks `{key}`");
    }
    assert!(json["throughput"]["instance_steps_per_s"].as_f64().unwrap() > 0.0);
    assert_eq!(json["status_counts"]["ok"], 6);
    let damping = &json["damping_of_base_scene"];
    for key in [
        "damping_time_s",
        "joint_damping_nms",
        "first_mode_damping_ratio",
    ] {
        assert!(damping[key].as_f64().unwrap() > 0.0, "damping.{key}");
    }
    assert!(
        json["method_steps_of_base_scene"]["imex_auto_s"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    let csv = std::fs::read_to_string(out.join("grid.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "excitation.frequency_hz,limiter.clearance_deg,K,R,period,hops,impacts_per_s,alpha_min_rad,alpha_max_rad,power_w,line_ratio,lyapunov,lyapunov_se,regime_confidence,regime,status"
    );
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 6);
    // C order: the clearance (last axis) varies fastest.
    assert!(
        rows[0].starts_with("5,10,") && rows[1].starts_with("5,30,"),
        "{rows:?}"
    );
    for r in &rows {
        let cells: Vec<&str> = r.split(',').collect();
        let k: f64 = cells[2].parse().unwrap();
        let rr: f64 = cells[3].parse().unwrap();
        assert!(k.is_finite() && (-0.5..=1.5).contains(&k), "K = {k}");
        assert!((0.0..=1.0).contains(&rr), "R = {rr}");
        assert_eq!(cells[9], "nan", "power without a piezo is NaN");
        assert_eq!(cells[10], "nan", "the line was not asked for");
        let (lambda, se): (f64, f64) = (cells[11].parse().unwrap(), cells[12].parse().unwrap());
        assert!(lambda.is_finite() && se.is_finite() && se >= 0.0, "{r}");
        let regime = cells[14];
        assert!(
            ["periodic", "regular", "chaotic", "undecided"].contains(&regime),
            "{r}"
        );
        let confidence: f64 = cells[13].parse().unwrap_or(f64::NAN);
        assert_eq!(
            regime == "undecided",
            confidence.is_nan(),
            "a decided cell has a confidence, an undecided one none: {r}"
        );
        assert!(
            confidence.is_nan() || (0.5..=1.0).contains(&confidence),
            "{r}"
        );
        assert_eq!(cells[15], "ok");
    }
    for f in [
        "K",
        "R",
        "period",
        "hops",
        "impacts_per_s",
        "alpha_range",
        "lyapunov",
        "regime",
    ] {
        let (w, h) = png_size(&out.join(format!("{f}.png")));
        assert!(w >= 600 && h >= 400, "{f}.png is {w}x{h}");
    }
    for f in [
        "K.npy",
        "R.npy",
        "status.npy",
        "axis0.npy",
        "axis1.npy",
        "lyapunov.npy",
        "lyapunov_se.npy",
        "regime_confidence.npy",
        "regime.npy",
    ] {
        let bytes = std::fs::read(out.join(f)).unwrap();
        assert_eq!(&bytes[..6], b"\x93NUMPY", "{f}");
    }
    let header =
        String::from_utf8_lossy(&std::fs::read(out.join("K.npy")).unwrap()[..128]).into_owned();
    assert!(header.contains("'shape': (3, 2"), "K.npy header {header}");
    // regime.npy: int8 codes −1…3 shaped like the grid, the names of grid.csv.
    let (shape, codes) =
        pendulum_atlas::output::npy::read_npy::<i8>(&out.join("regime.npy")).unwrap();
    assert_eq!(shape, vec![3, 2]);
    let names: Vec<&str> = rows.iter().map(|r| r.split(',').nth(14).unwrap()).collect();
    for (c, n) in codes.iter().zip(&names) {
        let r = pendulum_atlas::reduce::Regime::from_code(i64::from(*c)).expect("a code");
        assert_eq!(r.name(), *n);
    }
    let counts = &json["regime"]["counts"];
    let total: u64 = ["failed", "undecided", "periodic", "regular", "chaotic"]
        .iter()
        .map(|k| counts[k].as_u64().unwrap())
        .sum();
    assert_eq!(total, 6, "{counts}");
    assert!(json["lyapunov"]["separation"].as_f64().unwrap() > 0.0);
}

#[test]
fn map_runs_end_to_end_on_the_cpu() {
    let out = out_dir("cpu");
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet"])
        .args(TINY)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_map_dir(&out, "cpu");
}

#[test]
fn map_runs_end_to_end_on_the_gpu() {
    if crate::engine::gpu().is_none() {
        return;
    }
    let out = out_dir("gpu");
    let o = bin()
        .args(["map", "--backend", "gpu", "--quiet"])
        .args(TINY)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_map_dir(&out, "gpu");
}

#[test]
fn bifurcation_diagram_of_a_one_axis_map() {
    let out = out_dir("bif");
    let o = bin()
        .args([
            "map",
            "configs/maps/bifurcation_f.toml",
            "--backend",
            "cpu",
            "--quiet",
        ])
        .args([
            "--set",
            "integration.duration_s=22.0",
            "--set",
            "integration.transient_s=2.0",
            "--set",
            "map.axes=[{key=\"excitation.frequency_hz\",start=5.0,end=10.0,count=4}]",
        ])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (w, h) = png_size(&out.join("bifurcation.png"));
    assert!(w >= 600 && h >= 400);
    assert!(out.join("K.png").exists());
}

#[test]
fn gpu_backend_without_an_adapter_fails_clearly() {
    // No Vulkan driver is visible to this process: no adapter at all.
    let out = out_dir("noadapter");
    let o = bin()
        .args(["map", "--backend", "gpu", "--quiet"])
        .args(TINY)
        .arg("--out")
        .arg(&out)
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("no GPU adapter found"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

fn map_error(sets: &[&str]) -> String {
    let mut c = bin();
    c.args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(out_dir("err"));
    for s in sets {
        c.args(["--set", s]);
    }
    let o = c.output().unwrap();
    assert!(!o.status.success(), "map {sets:?} must fail");
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn lambda1_settings_that_cannot_work_are_refused_before_any_work() {
    // The default map runs 34 s with a 10 s transient: at 12 Hz 288 periods, at 4 Hz 96.
    let e = map_error(&["map.lyapunov_window_s=30"]);
    assert!(
        e.contains("lambda1")
            && e.contains("map.lyapunov_window_s = 30")
            && e.contains("lengthen integration.duration_s by"),
        "{e}"
    );
    let e = map_error(&["map.lyapunov_align_periods=90"]);
    assert!(e.contains("lambda1") && e.contains("90 to align"), "{e}");
    let e = map_error(&["map.lyapunov_window_s=2"]);
    assert!(e.contains("at least 16 renormalisations"), "{e}");
    let e = map_error(&["map.lyapunov_perturbation=0.5"]);
    assert!(
        e.contains("map.lyapunov_perturbation") && e.contains("0.001"),
        "{e}"
    );
    let e = map_error(&["map.lyapunov_perturbation=\"small\""]);
    assert!(e.contains("\"auto\""), "{e}");
    let e = map_error(&["map.lyapunov_window_s=\"half\""]);
    assert!(
        e.contains("map.lyapunov_window_s") && e.contains("\"whole\""),
        "{e}"
    );
}

#[test]
fn an_f32_engine_refuses_a_separation_below_its_rounding() {
    let out = out_dir("f32sep");
    let o = bin()
        .args(["map", "--backend", "cpu", "--precision", "f32", "--quiet"])
        .args(TINY)
        .args(["--set", "map.lyapunov_perturbation=1e-6", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("map.lyapunov_perturbation = 1e-6")
            && err.contains("f32")
            && err.contains("1e-4"),
        "{err}"
    );
    assert!(!out.join("map.json").exists());
}

#[test]
fn bad_map_scenes_are_refused_with_the_key_named() {
    let e = map_error(&["map.axes=[{key=\"excitation.frequncy_hz\",start=1.0,end=2.0,count=2}]"]);
    assert!(
        e.contains("excitation.frequncy_hz") && e.contains("did you mean"),
        "{e}"
    );
    let e = map_error(&["map.axes=[{key=\"excitation.frequency_hz\",start=5.0,end=5.0,count=3}]"]);
    assert!(e.contains("map.axes[1].end") && e.contains("empty"), "{e}");
    let e = map_error(&[
        "map.axes=[{key=\"excitation.frequency_hz\",start=1.0,end=2.0,count=100000},{key=\"excitation.amplitude_m\",start=0.001,end=0.02,count=100000}]",
    ]);
    assert!(e.contains("at most") && e.contains("instances"), "{e}");
    let e = map_error(&["map.axes=[{key=\"tip.mass_kg\",start=-0.01,end=0.02,count=3}]"]);
    assert!(
        e.contains("tip.mass_kg") && e.contains("out of range"),
        "{e}"
    );
    let e = map_error(&["map.metrics=[\"K\", \"lyapunv\"]"]);
    assert!(e.contains("lyapunv") && e.contains("\"lyapunov\""), "{e}");
    let e = map_error(&["map.metrics=[\"power\"]"]);
    assert!(e.contains("piezo.enabled"), "{e}");
    let e = map_error(&["map.axes=[{key=\"beam.segments\",start=3,end=5,count=3}]"]);
    assert!(e.contains("beam.segments"), "{e}");
    let e = map_error(&["map.samples_per_perod=8"]);
    assert!(
        e.contains("map.samples_per_perod") && e.contains("did you mean"),
        "{e}"
    );
    let e = map_error(&["integration.duration_s=2.0", "integration.transient_s=1.0"]);
    assert!(e.contains("stroboscopic samples"), "{e}");
}

#[test]
fn early_stop_ends_confirmed_periodic_orbits_and_keeps_their_metrics() {
    use pendulum_atlas::config::map_from_toml;
    use pendulum_atlas::engine::{Engine, Precision, no_progress};
    use pendulum_atlas::map::run_map;
    let cpu = Engine::cpu(Precision::F64);
    let text = |early: bool| {
        format!(
            "[beam]\nsegments = 1\ndamping_ratio = 0.05\n[pivot]\nmode = \"clamped\"\n[limiter]\nenabled = false\n\
             [excitation]\namplitude_m = 0.001\n[integration]\nduration_s = 60.0\ntransient_s = 20.0\n\
             [map]\nmetrics = [\"K\", \"period\", \"alpha_range\"]\nearly_stop = {early}\n\
             [[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [5.0, 10.0]\n"
        )
    };
    let full = map_from_toml(&text(false), "<t>", &[]).unwrap();
    let early = map_from_toml(&text(true), "<t>", &[]).unwrap();
    let a = run_map(&full, &cpu, &no_progress).unwrap();
    let b = run_map(&early, &cpu, &no_progress).unwrap();
    assert_eq!(
        b.stopped_early, 2,
        "both forced linear responses settle on period 1"
    );
    for (x, y) in a.results.iter().zip(&b.results) {
        assert!(
            y.steps < x.steps / 2,
            "stopped at {} of {} steps",
            y.steps,
            x.steps
        );
        assert_eq!(x.period, y.period);
        assert!((x.k - y.k).abs() < 0.05, "K {} vs {}", x.k, y.k);
        assert!((x.alpha_max_rad - y.alpha_max_rad).abs() < 1e-6);
    }
    // A metric that needs the whole run switches it off, with a warning.
    let spec = map_from_toml(
        &text(true).replace("\"alpha_range\"]", "\"alpha_range\", \"hops\"]"),
        "<t>",
        &[],
    )
    .unwrap();
    let c = run_map(&spec, &cpu, &no_progress).unwrap();
    assert_eq!(c.stopped_early, 0);
    assert!(
        c.plan
            .warnings
            .iter()
            .any(|w| w.contains("early_stop ignored"))
    );
}

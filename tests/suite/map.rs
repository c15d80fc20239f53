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
        "excitation.frequency_hz,limiter.clearance_deg,K,R,period,hops,impacts_per_s,alpha_min_rad,alpha_max_rad,power_w,line_ratio,lyapunov,lyapunov_se,regime_confidence,verdict_confidence,regime,ran_on,status,inferred"
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
        let regime = cells[15];
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
        assert!(["0", "1"].contains(&cells[16]), "ran_on: {r}");
        assert_eq!(cells[17], "ok");
        let verdict: f64 = cells[14].parse().unwrap_or(f64::NAN);
        assert_eq!(verdict.is_nan(), confidence.is_nan(), "{r}");
        assert!(
            verdict.is_nan() || verdict <= confidence,
            "capped by λ1's: {r}"
        );
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
        "verdict_confidence.npy",
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
        pendulum_atlas_map::output::npy::read_npy::<i8>(&out.join("regime.npy")).unwrap();
    assert_eq!(shape, vec![3, 2]);
    let names: Vec<&str> = rows.iter().map(|r| r.split(',').nth(15).unwrap()).collect();
    for (c, n) in codes.iter().zip(&names) {
        let r = pendulum_atlas_core::reduce::Regime::from_code(i64::from(*c)).expect("a code");
        assert_eq!(r.name(), *n);
    }
    check_verdict_confidence(out, &codes, (3, 2));
    let counts = &json["regime"]["counts"];
    let total: u64 = ["failed", "undecided", "periodic", "regular", "chaotic"]
        .iter()
        .map(|k| counts[k].as_u64().unwrap())
        .sum();
    assert_eq!(total, 6, "{counts}");
    assert!(json["lyapunov"]["separation"].as_f64().unwrap() > 0.0);
}

/// `verdict_confidence.npy` of the `nx` × `ny` map in `out` is its table's accuracy for each
/// cell's verdict and the share of its neighbours (cells one step away along either axis or
/// both) with the same verdict, capped by `regime_confidence`; counted here with plain loops
/// over the grid. The table: the settled one where `map.json` says the map settled, else the
/// shipped one.
pub fn check_verdict_confidence(out: &std::path::Path, codes: &[i8], shape: (i64, i64)) {
    use pendulum_atlas_map::map::confidence::{SETTLED, SHIPPED};
    let settled = !map_json(out)["settle"].is_null();
    let table = if settled { &SETTLED } else { &SHIPPED };
    let said = &map_json(out)["regime"]["confidence"]["table"];
    assert_eq!(said, if settled { "settled" } else { "shipped" });
    check_verdict_confidence_with(out, codes, shape, table);
}

/// [`check_verdict_confidence`] with the table `table`.
pub fn check_verdict_confidence_with(
    out: &std::path::Path,
    codes: &[i8],
    (nx, ny): (i64, i64),
    table: &pendulum_atlas_map::map::confidence::Calibration,
) {
    use pendulum_atlas_core::reduce::Regime;
    use pendulum_atlas_map::output::npy::read_npy;
    let t = table;
    let (_, got) = read_npy::<f64>(&out.join("verdict_confidence.npy")).unwrap();
    let (_, lambda_conf) = read_npy::<f64>(&out.join("regime_confidence.npy")).unwrap();
    let optional = |stem: &str| {
        let p = out.join(format!("{stem}.npy"));
        p.is_file().then(|| read_npy::<f64>(&p).unwrap().1)
    };
    // The transient stage's start sensitivity and the orbit stage's own orbits hold it lower.
    let sensitivity = optional("start_sensitivity");
    let floquet_max = optional("floquet_max");
    let orbit_status = out
        .join("orbit_status.npy")
        .is_file()
        .then(|| read_npy::<i8>(&out.join("orbit_status.npy")).unwrap().1);
    for x in 0..nx {
        for y in 0..ny {
            let k = (x * ny + y) as usize;
            let (mut same, mut all) = (0, 0);
            for dx in -1..=1 {
                for dy in -1..=1 {
                    let (u, v) = (x + dx, y + dy);
                    if (dx, dy) == (0, 0) || u < 0 || v < 0 || u >= nx || v >= ny {
                        continue;
                    }
                    all += 1;
                    same += i32::from(codes[(u * ny + v) as usize] == codes[k]);
                }
            }
            let a = f64::from(same) / f64::from(all);
            let table = match Regime::from_code(i64::from(codes[k])).unwrap() {
                Regime::Chaotic if a >= 1.0 => t.chaotic_all,
                Regime::Chaotic => t.chaotic_some,
                Regime::Periodic if a >= 0.5 => t.periodic_half,
                Regime::Periodic => t.periodic_few,
                Regime::Regular => t.regular,
                _ => f64::NAN,
            };
            let mut want = table.min(lambda_conf[k]);
            if let Some(s) = sensitivity.as_ref().map(|s| s[k]).filter(|&s| s > 0.0) {
                want = want.min(0.9 * (1.0 - s));
            }
            let own_unstable = orbit_status.as_ref().is_some_and(|o| o[k] == 0)
                && floquet_max.as_ref().is_some_and(|f| f[k] >= 1.0);
            if own_unstable && Regime::from_code(i64::from(codes[k])) == Some(Regime::Periodic) {
                want = want.min(0.5);
            }
            assert!(
                got[k] == want || (got[k].is_nan() && want.is_nan()),
                "cell ({x}, {y}): verdict_confidence {} against {want} (agreement {a})",
                got[k]
            );
        }
    }
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
            && e.contains("lengthen integration.duration_s by")
            && e.contains("ask for a window of at most"),
        "{e}"
    );
    let e = map_error(&["map.lyapunov_align_periods=90"]);
    assert!(e.contains("lambda1") && e.contains("90 to align"), "{e}");
    let e = map_error(&["map.lyapunov_window_s=2"]);
    assert!(e.contains("at least 16 renormalisations"), "{e}");
    assert!(e.contains("ask for a window of at least 16 periods"), "{e}");
    for sets in [
        &["map.lyapunov_window_s=30"][..],
        &["map.lyapunov_window_s=2"],
        &["map.lyapunov_align_periods=90"],
    ] {
        let e = map_error(sets);
        assert!(
            !e.contains("by 0.00 s") && !e.contains("by 0.0 s") && !e.contains("16 to 16"),
            "a refusal proposes a change that changes nothing: {e}"
        );
    }
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
fn refinement_that_cannot_work_is_refused_before_any_work() {
    let grid = "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=9},{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=5}]";
    let e = map_error(&[grid, "map.refine=true", "map.metrics=[\"K\"]"]);
    assert!(
        e.contains("map.refine_follow") && e.contains("regime"),
        "{e}"
    );
    let e = map_error(&[grid, "map.refine=true", "map.refine_follow=\"power\""]);
    assert!(e.contains("not among map.metrics"), "{e}");
    let e = map_error(&[grid, "map.refine=true", "map.refine_spacing=8"]);
    assert!(e.contains("does not divide") && e.contains("2, 4"), "{e}");
    let e = map_error(&[grid, "map.refine=true", "map.refine_spacing=3"]);
    assert!(e.contains("powers of two"), "{e}");
    for share in ["0", "1.5", "-0.1"] {
        let e = map_error(&[
            grid,
            "map.refine=true",
            &format!("map.refine_audit={share}"),
        ]);
        assert!(
            e.contains("map.refine_audit") && e.contains("(0, 1]"),
            "{e}"
        );
    }
    let e = map_error(&[
        grid,
        "map.refine=true",
        "map.refine_spacing=4",
        "map.bifurcation=true",
    ]);
    assert!(
        e.contains("map.bifurcation") || e.contains("bifurcation"),
        "{e}"
    );
    let mut c = bin();
    let o = c
        .args([
            "map",
            "--backend",
            "cpu",
            "--quiet",
            "--shard",
            "0/2",
            "--out",
        ])
        .arg(out_dir("refine-shard"))
        .args([
            "--set",
            grid,
            "--set",
            "map.refine=true",
            "--set",
            "map.refine_spacing=4",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("cannot be split"),
        "{err}"
    );
}

#[test]
fn a_refined_map_marks_its_inferred_cells_in_every_file() {
    let out = out_dir("refined");
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args([
            "--set",
            "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=17},{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=9}]",
            "--set",
            "map.refine=true",
            "--set",
            "map.refine_spacing=4",
            // The raw refined map, whose steps are refinement's alone (settling's runs on
            // add theirs: `a_refined_map_settles_as_the_plain_map_does`).
            "--set",
            "map.settle=false",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    let inferred = json["refine"]["inferred"].as_u64().unwrap();
    assert!(inferred > 0, "{}", json["refine"]);
    assert_eq!(json["steps"]["inferred"].as_u64().unwrap(), inferred);
    assert!(json["refine"]["audit"]["checked"].as_u64().unwrap() >= 1);
    let saved = json["steps"]["saved_by_refinement"].as_u64().unwrap();
    let total = json["steps"]["total_instance_steps"].as_u64().unwrap();
    let done = json["steps"]["integrated_instance_steps"].as_u64().unwrap();
    assert!(saved > 0 && done < total);
    assert_eq!(
        json["steps"]["saved_instance_steps"].as_u64().unwrap(),
        total - done
    );
    let flags: npyz::NpyFile<_> =
        npyz::NpyFile::new(std::fs::File::open(out.join("inferred.npy")).unwrap()).unwrap();
    assert_eq!(flags.shape(), &[17, 9]);
    let flags: Vec<u8> = flags.into_vec().unwrap();
    assert_eq!(flags.iter().filter(|&&f| f == 1).count() as u64, inferred);
    let csv = std::fs::read_to_string(out.join("grid.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "inferred")
        .expect("inferred column");
    let marked = csv
        .lines()
        .skip(1)
        .filter(|l| l.split(',').nth(col) == Some("1"))
        .count();
    assert_eq!(marked as u64, inferred);
    assert!(
        json["files"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f == "inferred.npy")
    );
}

#[test]
fn a_given_step_is_shortened_to_divide_the_period_never_lengthened() {
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_core::engine::EnsemblePlan;
    for dt in [4.1e-4, 5e-4, 6.9e-4, 1.3e-3] {
        let spec = map_from_toml(
            "[beam]\nsegments = 3\n[integration]\nduration_s = 30.0\ntransient_s = 5.0\n\
             [map]\nmetrics = [\"K\"]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\n\
             start = 4.0\nend = 12.0\ncount = 17\n",
            "<test>",
            &[format!("integration.dt_s={dt}")],
        )
        .unwrap();
        let plan = EnsemblePlan::new(&spec).unwrap();
        for p in &plan.instances {
            assert!(p.dt_s <= dt * (1.0 + 1e-12), "dt {} > {dt} asked", p.dt_s);
            assert!(p.dt_s > dt / 2.0, "dt {} much shorter than {dt}", p.dt_s);
        }
    }
}

#[test]
fn a_map_larger_than_the_memory_is_refused_before_planning() {
    // 4 million instances at N = 256: about 200 GB to plan, refused at once.
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--set", "beam.segments=256", "--set"])
        .arg("map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=2000},{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=2000}]")
        .arg("--out")
        .arg(out_dir("too-large"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("4000000 instances") && err.contains("of memory"),
        "{err}"
    );
}

#[test]
fn starts_that_cannot_be_run_are_refused_before_any_work() {
    // The default map is 41 × 31 cells: 4 000 000 runs allow 3146 starts each.
    let e = map_error(&[
        "map.initial_states=1024",
        "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=4000}]",
    ]);
    assert!(
        e.contains("1024 starts in each of 4000 cells") && e.contains("give at most 1000 starts"),
        "{e}"
    );
    let e = map_error(&["map.initial_states=2000"]);
    assert!(e.contains("integers in [1, 1024]"), "{e}");
    // Beyond the bumpers' reach (the default clearance is 20 deg).
    let e = map_error(&["map.initial_states=8", "map.initial_angle_max_deg=25"]);
    assert!(
        e.contains("map.initial_angle_max_deg") && e.contains("[-20, 20] deg"),
        "{e}"
    );
    let e = map_error(&["map.initial_states=[{angle_deg=30.0,rate_deg_s=0.0}]"]);
    assert!(e.contains("map.initial_states[0].angle_deg"), "{e}");
    let e = map_error(&[
        "map.initial_states=8",
        "map.initial_rate_min_deg_s=50",
        "map.initial_rate_max_deg_s=-50",
    ]);
    assert!(e.contains("the range is empty"), "{e}");
    // The start as an axis and as a set of starts at once; refinement of labelled maps.
    let e = map_error(&[
        "map.initial_states=8",
        "map.axes=[{key=\"initial.angle_deg\",start=-10.0,end=10.0,count=3}]",
    ]);
    assert!(e.contains("initial.angle_deg is an axis"), "{e}");
    let e = map_error(&[
        "map.initial_states=8",
        "map.refine=true",
        "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=9},{key=\"excitation.amplitude_m\",start=0.004,end=0.02,count=9}]",
    ]);
    assert!(
        e.contains("map.refine") && e.contains("not supported yet"),
        "{e}"
    );
    let e = map_error(&["map.initial_states=\"many\""]);
    assert!(e.contains("a number of starts"), "{e}");
}

#[test]
fn a_map_with_starts_writes_its_attractor_files() {
    let out = out_dir("starts");
    let stdout = crate::map_cli(&out, &crate::STARTS_MAP_SETS);
    assert!(
        stdout.contains("from 6 starts each: 12 runs") && stdout.contains("2 attractor families"),
        "{stdout}"
    );
    for f in [
        "attractors.npy",
        "attractor.npy",
        "basin_fraction.npy",
        "failed_fraction.npy",
        "attractors.json",
        "attractors.png",
        "attractor.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let read = |name: &str| -> (Vec<u64>, Vec<f64>) {
        let bytes = std::fs::read(out.join(name)).unwrap();
        let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
        let shape = npy.shape().to_vec();
        let data = match npy.dtype() {
            npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Int => npy
                .into_vec::<i32>()
                .unwrap()
                .into_iter()
                .map(f64::from)
                .collect(),
            _ => npy.into_vec::<f64>().unwrap(),
        };
        (shape, data)
    };
    let (shape, fractions) = read("basin_fraction.npy");
    let (_, failed) = read("failed_fraction.npy");
    let labels = shape[0] as usize;
    assert_eq!(shape[1..], [2, 1]);
    for c in 0..2 {
        let sum: f64 = (0..labels).map(|l| fractions[l * 2 + c]).sum::<f64>() + failed[c];
        assert!((sum - 1.0).abs() < 1e-12, "cell {c}: {sum}");
    }
    let (_, count) = read("attractors.npy");
    assert_eq!(count, vec![2.0, 2.0], "both wells' orbits in each cell");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    assert_eq!(manifest["attractors"]["runs"]["runs"], 12);
    assert_eq!(
        manifest["attractors"]["starts"]["source"]["kind"],
        "sampled"
    );
    assert_eq!(
        manifest["attractors"]["starts"]["states"]
            .as_array()
            .unwrap()
            .len(),
        6
    );
}

#[test]
fn continuation_that_cannot_be_run_is_refused_before_any_work() {
    let axes2 = "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=5},{key=\"excitation.amplitude_m\",values=[0.002,0.004]}]";
    let e = map_error(&[
        "map.continuation=both",
        "map.continuation_axis=beam.segments",
        axes2,
    ]);
    assert!(
        e.contains("\"beam.segments\" is not an axis of this map")
            && e.contains("excitation.frequency_hz, excitation.amplitude_m"),
        "{e}"
    );
    let e = map_error(&["map.continuation=sideways"]);
    assert!(
        e.contains("map.continuation") && e.contains("\"both\""),
        "{e}"
    );
    let e = map_error(&["map.continuation_axis=excitation.frequency_hz"]);
    assert!(e.contains("only read with map.continuation"), "{e}");
    let e = map_error(&[
        "map.continuation=up",
        "map.axes=[{key=\"excitation.frequency_hz\",values=[8.0]}]",
    ]);
    assert!(e.contains("continuation needs at least 2"), "{e}");
    let e = map_error(&[
        "map.continuation=up",
        "map.axes=[{key=\"initial.angle_deg\",start=-10.0,end=10.0,count=3}]",
    ]);
    assert!(e.contains("replaces initial.angle_deg"), "{e}");
    let e = map_error(&["map.continuation=up", "map.initial_states=4", axes2]);
    assert!(e.contains("one start per cell"), "{e}");
    let e = map_error(&[
        "map.continuation=up",
        "map.refine=true",
        "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=9},{key=\"excitation.amplitude_m\",start=0.004,end=0.02,count=9}]",
    ]);
    assert!(e.contains("set map.refine = false"), "{e}");
    // A map whose cells run one after another is not split into shards.
    let o = bin()
        .args([
            "map",
            "--backend",
            "cpu",
            "--quiet",
            "--shard",
            "1/2",
            "--out",
        ])
        .arg(out_dir("cont-shard"))
        .args(["--set", "map.continuation=up", "--set", axes2])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("cannot be sharded"), "{err}");
}

#[test]
fn a_map_run_both_ways_writes_both_directions_and_where_they_differ() {
    // The pinned hysteresis of the engine suite (1 mm; P2 sweeping down, P1 sweeping up).
    let out = out_dir("both-ways");
    let args: Vec<&str> = crate::HYSTERESIS_MAP_SETS
        .iter()
        .copied()
        .chain(["--set", "map.bifurcation=true"])
        .collect();
    let stdout = crate::map_cli(&out, &args);
    assert!(
        stdout.contains("continuation along excitation.frequency_hz (up, then down)")
            && stdout.contains("differ on 5 cells, in 1 band (10–12 Hz"),
        "{stdout}"
    );
    let read = |name: &str| -> Vec<f64> {
        let bytes = std::fs::read(out.join(name)).unwrap();
        let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
        match npy.dtype() {
            npyz::DType::Plain(t) if t.type_char() == npyz::TypeChar::Uint => npy
                .into_vec::<u8>()
                .unwrap()
                .into_iter()
                .map(f64::from)
                .collect(),
            _ => npy.into_vec::<f64>().unwrap(),
        }
    };
    assert_eq!(read("period.npy"), vec![1.0; 6]);
    assert_eq!(read("period_down.npy"), vec![1.0, 2.0, 2.0, 2.0, 2.0, 2.0]);
    assert_eq!(read("hysteresis.npy"), vec![0.0, 1.0, 1.0, 1.0, 1.0, 1.0]);
    for f in [
        "status_down.npy",
        "regime_down.npy",
        "hysteresis.png",
        "bifurcation.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    let c = &manifest["continuation"];
    assert_eq!(c["sweep"], "both");
    assert_eq!(c["directions"][1]["direction"], "down");
    let band = &c["hysteresis"]["bands"][0];
    assert_eq!(
        (band["from"].as_f64(), band["to"].as_f64()),
        (Some(10.0), Some(12.0))
    );
    assert_eq!(band["cells"], 5);
}

#[test]
fn a_shard_of_a_map_that_cannot_be_split_is_refused_before_planning() {
    // The second cell's step cannot resolve its forcing (600 Hz at dt = 1 ms), which planning
    // would report; the refusal to shard must come first, for every kind of split map.
    let bad_cell = "map.axes=[{key=\"excitation.frequency_hz\",values=[8.0,600.0]}]";
    for (mode, key) in [
        ("map.initial_states=2", "map.initial_states"),
        ("map.continuation=up", "map.continuation"),
    ] {
        let out = out_dir(&format!("unsplittable-{key}"));
        let o = bin()
            .args([
                "map",
                "--backend",
                "cpu",
                "--quiet",
                "--shard",
                "0/2",
                "--out",
            ])
            .arg(&out)
            .args(["--set", "integration.dt_s=1e-3", "--set", bad_cell])
            .args(["--set", mode])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{mode}: {err}");
        assert!(
            err.contains("cannot be sharded") && err.contains(key),
            "{mode}: {err}"
        );
        assert!(!err.contains("grid point"), "{mode}: {err}");
        assert!(!out.exists(), "{mode}: refused before its folder is made");
    }
}

/// The files of a map folder, the lock file aside, sorted.
fn folder_files(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != ".pendulum-atlas.lock")
        .collect();
    names.sort();
    names
}

/// A forced map killed outright leaves the earlier map set aside beside its own partial
/// files; the next run into the folder puts the earlier map back, whole, before its checks, so
/// that it is refused as a folder that holds a map (issue 61).
#[test]
fn an_earlier_map_left_aside_by_a_killed_run_is_put_back() {
    let out = out_dir("killed-force");
    let run = |extra: &[&str]| {
        bin()
            .args(["map", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args(TINY)
            .args(extra)
            .output()
            .unwrap()
    };
    assert!(run(&[]).status.success());
    let before: Vec<(String, Vec<u8>)> = folder_files(&out)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    // What a forced run killed while writing leaves: the earlier files aside, a partial array
    // and a temporary file of its own.
    let aside = out.join(".pendulum-atlas.earlier");
    std::fs::create_dir(&aside).unwrap();
    for (name, _) in &before {
        std::fs::rename(out.join(name), aside.join(name)).unwrap();
    }
    std::fs::write(out.join("K.npy"), "partial").unwrap();
    std::fs::write(out.join(".R.tmp-999.npy"), "partial").unwrap();
    let o = run(&[]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("already holds"), "{e}");
    let after: Vec<(String, Vec<u8>)> = folder_files(&out)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap_or_default()))
        .collect();
    assert_eq!(after, before, "the earlier map, whole, and nothing else");
}

/// `--force` deletes exactly the files the earlier map's own `map.json` lists, whatever
/// feature wrote them (attractors, basins, starts), so that none is left beside a new map.
#[test]
fn force_replaces_every_file_the_earlier_maps_manifest_lists() {
    let out = out_dir("force-starts");
    let run = |sets: &[&str], extra: &[&str]| {
        let o = bin()
            .args(["map", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args(sets)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&crate::STARTS_MAP_SETS, &[]);
    let first = folder_files(&out);
    for name in [
        "attractors.json",
        "basin_fraction.npy",
        "start.npy",
        "attractor.png",
    ] {
        assert!(first.contains(&name.to_string()), "{name} in {first:?}");
    }
    run(&TINY, &["--force"]);
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    let mut listed: Vec<String> = manifest["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap().to_string())
        .chain(["map.json".to_string()])
        .collect();
    listed.sort();
    assert_eq!(
        folder_files(&out),
        listed,
        "only the new map's files are left"
    );
}

/// A map killed before its manifest leaves files and temporary files of every feature: the
/// earlier-run check knows them by the names the map's writer gives (and leaves the user's
/// own files alone).
#[test]
fn a_killed_maps_files_and_temporary_files_are_found_by_their_names() {
    let out = out_dir("force-killed");
    std::fs::create_dir_all(&out).unwrap();
    let left = [
        "basin_fraction.npy",
        "K_down.npy",
        "regime_down.png",
        "hysteresis.png",
        "attractors.json",
        "start.npy",
        ".attractor.tmp-4242.npy",
        ".failed_fraction.tmp-7.npy",
    ];
    for name in left.iter().chain(&["notes.txt", "rig_photo.png"]) {
        std::fs::write(out.join(name), b"x").unwrap();
    }
    let map = |force: bool| {
        let mut cmd = bin();
        cmd.args(["map", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args(TINY);
        if force {
            cmd.arg("--force");
        }
        cmd.output().unwrap()
    };
    let o = map(false);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("{} file(s)", left.len())), "{err}");
    let o = map(true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let now = folder_files(&out);
    for name in left.iter().filter(|n| !n.starts_with('.')) {
        let listed: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
        let written = listed["files"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f == name);
        assert!(
            written || !now.contains(&name.to_string()),
            "{name} left in {now:?}"
        );
    }
    assert!(now.iter().all(|n| !n.contains(".tmp-")), "{now:?}");
    assert!(now.contains(&"notes.txt".to_string()) && now.contains(&"rig_photo.png".to_string()));
}

/// An output the map cannot write (`R.npy` a folder) is refused before any work, naming it.
#[test]
fn an_output_that_is_a_folder_is_refused_before_the_run() {
    let out = out_dir("blocked-output");
    std::fs::create_dir_all(out.join("R.npy")).unwrap();
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args(TINY)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("R.npy") && err.contains("is a folder"),
        "{err}"
    );
    assert!(!out.join("map.json").exists() && !out.join("K.npy").exists());
}

/// A lock file replaced by a symlink to a FIFO is refused at once: never followed, never
/// waited on.
#[cfg(unix)]
#[test]
fn a_lock_file_that_is_a_symlink_to_a_fifo_is_refused_without_hanging() {
    let out = out_dir("fifo-lock");
    std::fs::create_dir_all(&out).unwrap();
    let fifo = out.with_extension("fifo");
    let _ = std::fs::remove_file(&fifo);
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    std::os::unix::fs::symlink(&fifo, out.join(".pendulum-atlas.lock")).unwrap();
    let o = Command::new("timeout")
        .arg("60")
        .arg(env!("CARGO_BIN_EXE_pendulum-atlas"))
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args(TINY)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("lock file is not a regular file"), "{err}");
    let _ = std::fs::remove_file(&fifo);
}

/// A map key of a feature that is switched off is accepted and named, as a scene key of a
/// part that is off is: on stderr and in `map.json`'s warnings.
#[test]
fn map_keys_of_a_switched_off_feature_are_named_as_unused() {
    let out = out_dir("unused-map-keys");
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args(TINY)
        .args([
            "--set",
            "map.metrics=[\"K\",\"period\"]",
            "--set",
            "map.refine_spacing=4",
            "--set",
            "map.lyapunov_window_s=5",
            "--set",
            "map.initial_seed=3",
            "--set",
            "map.early_stop=false",
            "--set",
            "map.early_stop_tol=1e-3",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    let warnings = manifest["warnings"].to_string();
    for (key, why) in [
        ("map.refine_spacing", "map.refine is not true"),
        ("map.lyapunov_window_s", "lambda1 is not among map.metrics"),
        (
            "map.initial_seed",
            "map.initial_states does not draw starts",
        ),
        ("map.early_stop_tol", "map.early_stop = false"),
    ] {
        let said = format!("{key} is set but not used: {why}");
        assert!(err.contains(&said), "stderr lacks `{said}`: {err}");
        assert!(
            warnings.contains(&said),
            "map.json lacks `{said}`: {warnings}"
        );
    }
}

/// A locked `--out` deleted and made again while the map runs is not written into: the run
/// fails naming it, and the new folder holds none of its files (two maps never mix).
#[test]
fn a_folder_deleted_and_made_again_during_the_run_is_not_written_into() {
    let out = out_dir("replaced-folder");
    let child = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args(TINY)
        .args(["--set", "integration.duration_s=400.0"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let lock = out.join(".pendulum-atlas.lock");
    let started = std::time::Instant::now();
    while !lock.exists() {
        assert!(
            started.elapsed().as_secs() < 60,
            "the map never locked its folder"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    std::fs::remove_dir_all(&out).unwrap();
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("notes.txt"), b"another run's folder").unwrap();
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("was deleted or replaced"), "{err}");
    assert_eq!(folder_files(&out), ["notes.txt"], "{err}");
}

/// A cancel reaches an instance while it runs: the CPU engine asks the progress callback
/// every few forcing periods, so that a cell settling for minutes (or a 2000-s run, as here)
/// stops within milliseconds of Ctrl-C instead of at its end (issue 61). The first question
/// comes while no instance has finished, and the cancelled instance asks no more.
#[test]
fn a_cancel_reaches_an_instance_while_it_runs() {
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_core::engine::{
        CpuLoop, Engine, EngineError, EnsemblePlan, Precision, ProgressUnit, Readback,
    };
    use pendulum_atlas_core::reduce::ReduceOptions;
    use std::sync::Mutex;
    let spec = map_from_toml(
        "[beam]\nsegments = 3\n[integration]\nduration_s = 2000.0\ntransient_s = 5.0\n\
         [map]\nmetrics = [\"K\"]\n\
         [[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [8.0]\n",
        "<test>",
        &[],
    )
    .unwrap();
    let plan = EnsemblePlan::new(&spec).unwrap();
    for cpu_loop in [CpuLoop::Scalar, CpuLoop::Simd] {
        let asked: Mutex<Vec<u64>> = Mutex::new(Vec::new());
        let cancel = |done: u64, _: u64, unit: ProgressUnit| {
            if unit == ProgressUnit::Instances {
                asked.lock().unwrap().push(done);
            }
            std::ops::ControlFlow::Break(())
        };
        let engine = Engine::cpu_with(Precision::F64, cpu_loop);
        let err = engine
            .run(
                &plan,
                &ReduceOptions::from_spec(&spec),
                Readback::default(),
                &cancel,
            )
            .expect_err("a cancelled run");
        assert!(matches!(err, EngineError::Cancelled), "{cpu_loop:?}: {err}");
        let asked = asked.into_inner().unwrap();
        assert_eq!(
            asked.first(),
            Some(&0),
            "{cpu_loop:?}: asked while running: {asked:?}"
        );
        assert!(
            asked.len() <= 2,
            "{cpu_loop:?}: asked again after the cancel: {asked:?}"
        );
    }
}

/// Planning a huge map reports its progress every few thousand runs, and a cancel there
/// (Ctrl-C in `pa.map`) stops it at once with `Cancelled`, before the ensemble is built.
#[test]
fn a_cancel_while_a_map_is_planned_stops_the_planning() {
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_core::engine::{EngineError, EnsemblePlan, ProgressUnit};
    use std::sync::atomic::{AtomicUsize, Ordering};
    let spec = map_from_toml(
        "[beam]\nsegments = 3\n[integration]\nduration_s = 30.0\ntransient_s = 5.0\n\
         [map]\nmetrics = [\"K\"]\n\
         [[map.axes]]\nkey = \"excitation.frequency_hz\"\nstart = 4.0\nend = 12.0\ncount = 512\n\
         [[map.axes]]\nkey = \"excitation.amplitude_m\"\nstart = 0.001\nend = 0.02\ncount = 512\n",
        "<test>",
        &[],
    )
    .unwrap();
    let calls = AtomicUsize::new(0);
    let cancel = |done: u64, total: u64, unit: ProgressUnit| {
        assert_eq!(unit, ProgressUnit::Planned);
        assert_eq!(total, 512 * 512);
        assert!(
            done < total,
            "the planning ran to its end before the first report"
        );
        calls.fetch_add(1, Ordering::SeqCst);
        std::ops::ControlFlow::Break(())
    };
    let err = EnsemblePlan::new_with(&spec, &cancel).expect_err("a cancelled plan");
    assert!(matches!(err, EngineError::Cancelled), "{err}");
    let (calls, threads) = (calls.load(Ordering::SeqCst), rayon::current_num_threads());
    // 64 checks in all; after the cancel, only the checks already in flight report again.
    assert!(calls <= 2 * threads + 1, "{calls} reports after the cancel");
}

/// A huge map is refused before it is planned, with its runs, memory and estimated time and
/// how to accept it; accepted (`map.accept_huge`, what `--yes` sets), it passes the check with
/// the same figures.
#[test]
fn a_huge_map_is_refused_with_its_figures_unless_accepted() {
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_map::map::size::check_map_size;
    let grid = "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=1001},\
                {key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=1000}]";
    let out = out_dir("huge-map");
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args(["--set", grid])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for part in [
        "1001000 runs",
        "instance-steps",
        "of memory",
        "--yes",
        "map.accept_huge",
    ] {
        assert!(err.contains(part), "{part}: {err}");
    }
    assert!(!out.exists(), "nothing is written for a refused map");
    let accepted = map_from_toml(
        pendulum_atlas_core::config::DEFAULT_MAP_TOML,
        "default",
        &[grid.to_string(), "map.accept_huge=true".into()],
    )
    .unwrap();
    let engine =
        pendulum_atlas_core::engine::Engine::cpu(pendulum_atlas_core::engine::Precision::F32);
    let figures = check_map_size(&accepted, 1, &engine)
        .unwrap()
        .expect("a huge map");
    assert!(figures.to_string().contains("accepted"), "{figures}");
    let small = map_from_toml(
        pendulum_atlas_core::config::DEFAULT_MAP_TOML,
        "default",
        &[],
    )
    .unwrap();
    assert!(check_map_size(&small, 1, &engine).unwrap().is_none());
}

/// The guard counts settling at its most: the default map settling to 1e5 s (3.5e11
/// instance-steps if every cell runs on) is refused with the settling named, while the same
/// map settling to 68 s passes.
#[test]
fn settling_counts_in_the_huge_map_guard() {
    use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, map_from_toml};
    use pendulum_atlas_map::map::size::check_map_size;
    let engine =
        pendulum_atlas_core::engine::Engine::cpu(pendulum_atlas_core::engine::Precision::F32);
    let settling = |max_s: &str| {
        let spec = map_from_toml(
            DEFAULT_MAP_TOML,
            "default",
            &[format!("map.settle_max_s={max_s}")],
        )
        .unwrap();
        check_map_size(&spec, 1, &engine)
    };
    let refused = settling("100000.0").unwrap_err().to_string();
    assert!(
        refused.contains("more settling") && refused.contains("map.settle_max_s"),
        "{refused}"
    );
    assert!(settling("68.0").unwrap().is_none());
}

/// Continuation down a clearance axis: the state a cell ended in, leaning on its 4° bumper,
/// lies 2° inside the next cell's bumper, so that cell starts from the scene's state (counted
/// and said); up the axis, a state leaning on a 2° bumper fits within 4° and is carried on.
#[test]
fn continuation_never_starts_a_cell_beyond_its_bumpers() {
    use pendulum_atlas_core::config::map_from_toml;
    use pendulum_atlas_core::engine::{Engine, Precision, no_progress};
    use pendulum_atlas_map::map::run_map;
    let run = |direction: &str| {
        let spec = map_from_toml(
            pendulum_atlas_core::config::DEFAULT_MAP_TOML,
            "default",
            &[
                "map.axes=[{key=\"limiter.clearance_deg\",values=[2.0,4.0]}]".into(),
                format!("map.continuation=\"{direction}\""),
                "map.metrics=[\"alpha_range\"]".into(),
                "map.bifurcation=false".into(),
                "excitation.frequency_hz=4.0".into(),
                "excitation.amplitude_m=0.0002".into(),
                "initial.angle_deg=1.5".into(),
                "integration.duration_s=10.0".into(),
                "integration.transient_s=5.0".into(),
            ],
        )
        .unwrap();
        run_map(&spec, &Engine::cpu(Precision::F64), &no_progress).unwrap()
    };
    let down = run("down");
    let leg = &down.continuation.as_ref().unwrap().legs[0];
    assert_eq!((leg.beyond_bumpers, leg.restarted), (1, 1), "{leg:?}");
    assert!(
        down.plan
            .warnings
            .iter()
            .any(|w| w.contains("beyond their bumpers")),
        "{:?}",
        down.plan.warnings
    );
    let up = run("up");
    let leg = &up.continuation.as_ref().unwrap().legs[0];
    assert_eq!((leg.beyond_bumpers, leg.restarted), (0, 0), "{leg:?}");
}

/// The default map's 6 × 4 corner by the periodic windows (10.4–11.8 Hz), in 34 s.
const WINDOWS: &str = "map.axes=[{key=\"excitation.frequency_hz\",start=10.4,end=11.8,count=6},{key=\"excitation.amplitude_m\",start=0.01,end=0.025,count=4}]";

fn npy_f64(dir: &std::path::Path, name: &str) -> Vec<f64> {
    pendulum_atlas_map::output::npy::read_npy::<f64>(&dir.join(name))
        .unwrap()
        .1
}

fn map_json(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("map.json")).unwrap()).unwrap()
}

fn run_windows(backend: &str, name: &str, extra: &[&str]) -> (std::path::PathBuf, String) {
    let out = out_dir(&format!("{name}-{backend}"));
    let mut cmd = bin();
    cmd.args(["map", "--backend", backend, "--set", WINDOWS]);
    for e in extra {
        cmd.args(["--set", e]);
    }
    let o = cmd.arg("--out").arg(&out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (out, String::from_utf8_lossy(&o.stdout).into_owned())
}

#[test]
fn settling_from_the_start_runs_the_cells_that_are_not_firm_as_the_longer_map_runs_them() {
    settling_case("cpu");
}

#[test]
fn settling_runs_on_the_gpu_as_on_the_cpu() {
    if crate::engine::gpu().is_none() {
        return;
    }
    settling_case("gpu");
}

/// The settled map of [`WINDOWS`] on `backend` against its plain map and its 68-s map.
fn settling_case(backend: &str) {
    use pendulum_atlas_map::output::npy::read_npy;
    let (plain, _) = run_windows(backend, "settle-plain", &["map.settle=false"]);
    let (settled, said) = run_windows(
        backend,
        "settle-68",
        // Settling alone: the copies of the transient stage would change cells further.
        &[
            "map.settle_max_s=68.0",
            "map.settle_from=\"start\"",
            "map.transient_copies=0",
        ],
    );
    // The same cells for 68 s in one run, the indicators' window kept at 24 s: what a cell
    // rerun from its start must give.
    let (long, _) = run_windows(
        backend,
        "settle-long",
        &[
            "integration.duration_s=68.0",
            "integration.transient_s=44.0",
            "map.settle=false",
        ],
    );
    let (_, before) = read_npy::<i8>(&plain.join("regime.npy")).unwrap();
    let (_, after) = read_npy::<i8>(&settled.join("regime.npy")).unwrap();
    let (_, longer) = read_npy::<i8>(&long.join("regime.npy")).unwrap();
    let confidence = npy_f64(&plain, "verdict_confidence.npy");
    // Not firm: below 0.9 or undecided (NaN); a failed cell (-1) is final.
    let rerun: Vec<bool> = (0..24)
        .map(|k| {
            let firm = confidence[k] >= 0.9;
            before[k] != -1 && !firm
        })
        .collect();
    let n = rerun.iter().filter(|r| **r).count();
    assert!(n > 0 && n < 24, "{n} cells not firm: pick another corner");
    for name in ["K.npy", "R.npy", "period.npy", "lyapunov.npy", "hops.npy"] {
        let (a, b, c) = (
            npy_f64(&plain, name),
            npy_f64(&settled, name),
            npy_f64(&long, name),
        );
        for k in 0..24 {
            let want = if rerun[k] { c[k] } else { a[k] };
            assert!(
                b[k] == want || (b[k].is_nan() && want.is_nan()),
                "{name}, cell {k} (rerun {}): {} against {want}",
                rerun[k],
                b[k]
            );
        }
    }
    let changed = (0..24).filter(|&k| after[k] != before[k]).count();
    for k in 0..24 {
        assert_eq!(
            after[k],
            if rerun[k] { longer[k] } else { before[k] },
            "cell {k}"
        );
    }
    let chaos_settled = (0..24)
        .filter(|&k| before[k] == 3 && (after[k] == 1 || after[k] == 2))
        .count();
    let j = map_json(&settled);
    if backend == "gpu" {
        // The settling runs' device work counts in the map's GPU times, which its throughput
        // divides every counted step by (they once held the first pass's alone).
        let submissions = |j: &serde_json::Value| j["timings_s"]["gpu"]["submissions"].as_u64();
        let (first, all) = (submissions(&map_json(&plain)), submissions(&j));
        assert!(all > first && first > Some(0), "{first:?} then {all:?}");
    }
    let report = &j["settle"];
    assert_eq!(report["max_s"], 68.0);
    assert_eq!(report["cells"].as_u64(), Some(n as u64), "{report}");
    assert_eq!(report["changed"].as_u64(), Some(changed as u64), "{report}");
    assert_eq!(
        report["chaos_settled"].as_u64(),
        Some(chaos_settled as u64),
        "{report}"
    );
    assert!(map_json(&plain)["settle"].is_null());
    assert_eq!(
        (report["continued"].as_u64(), report["rerun"].as_u64()),
        (Some(0), Some(n as u64)),
        "{report}"
    );
    assert!(
        said.contains(&format!(
            "settled: {n} cells below confidence 0.9 ran on to 68 s (0 continued from the map's end, {n} rerun from their start;"
        )),
        "{said}"
    );
    assert_eq!(
        npy_u8(&settled, "ran_on.npy"),
        rerun.iter().map(|&r| u8::from(r)).collect::<Vec<_>>()
    );
    // Steps: a continued cell integrated the long run's steps, a rerun cell both runs.
    let steps = |d: &std::path::Path| {
        map_json(d)["steps"]["integrated_instance_steps"]
            .as_u64()
            .unwrap()
    };
    assert!(
        steps(&settled) > steps(&plain),
        "{} {}",
        steps(&settled),
        steps(&plain)
    );
    // The settled map's confidence comes from the table measured on settled maps.
    check_verdict_confidence_with(
        &settled,
        &after,
        (6, 4),
        &pendulum_atlas_map::map::confidence::SETTLED,
    );
    continued_case(backend, (&plain, &settled, &long), &rerun);
    for d in [plain, settled, long] {
        std::fs::remove_dir_all(d).ok();
    }
}

fn npy_u8(dir: &std::path::Path, name: &str) -> Vec<u8> {
    pendulum_atlas_map::output::npy::read_npy::<u8>(&dir.join(name))
        .unwrap()
        .1
}

/// The default settling (from the map's end) of [`WINDOWS`] on `backend` against the same
/// map's raw run `plain`, its settling from the start `restarted` and its 68-s map `long`:
/// the same cells run on; a cell that ran the whole 34 s goes on from there, which saves
/// integrating those 34 s again; a cell whose orbit settles in both ends on the 68-s run's
/// orbit (the compensation of the sums restarts at zero, so only a stable orbit is the same).
fn continued_case(
    backend: &str,
    (plain, restarted, long): (&std::path::Path, &std::path::Path, &std::path::Path),
    run_on: &[bool],
) {
    let (settled, _) = run_windows(backend, "settle-end", &[]);
    let report = map_json(&settled)["settle"].clone();
    assert_eq!(report["from"], "end", "{report}");
    let (continued, rerun) = (report["continued"].as_u64(), report["rerun"].as_u64());
    let n = run_on.iter().filter(|r| **r).count() as u64;
    assert_eq!(
        continued.zip(rerun).map(|(c, r)| c + r),
        Some(n),
        "{report}"
    );
    assert!(continued > Some(0), "{report}");
    let want: Vec<u8> = run_on.iter().map(|&r| u8::from(r)).collect();
    assert_eq!(npy_u8(&settled, "ran_on.npy"), want);
    let steps = |d: &std::path::Path| map_json(d)["settle"]["steps"].as_u64().unwrap();
    assert!(steps(&settled) < steps(restarted), "{report}");
    let regime = |d: &std::path::Path| {
        pendulum_atlas_map::output::npy::read_npy::<i8>(&d.join("regime.npy"))
            .unwrap()
            .1
    };
    let (end, one) = (regime(&settled), regime(long));
    let (period_end, period_one) = (npy_f64(&settled, "period.npy"), npy_f64(long, "period.npy"));
    let mut compared = 0;
    for k in (0..24).filter(|&k| run_on[k]) {
        if end[k] != 1 || one[k] != 1 || period_end[k] != period_one[k] {
            continue;
        }
        let (r_end, r_one) = (npy_f64(&settled, "R.npy")[k], npy_f64(long, "R.npy")[k]);
        assert!(
            (r_end - r_one).abs() < 1e-3,
            "R, cell {k}: {r_end} against {r_one}"
        );
        // λ1 of a settled orbit within three standard errors: the early stop ends each run
        // once its estimate is good to about 10 %, at its own instant.
        let l = |d: &std::path::Path, name: &str| npy_f64(d, name)[k];
        let (l_end, l_one) = (l(&settled, "lyapunov.npy"), l(long, "lyapunov.npy"));
        let se = l(&settled, "lyapunov_se.npy") + l(long, "lyapunov_se.npy");
        assert!(
            (l_end - l_one).abs() <= 3.0 * se,
            "λ1, cell {k}: {l_end} against {l_one} ± {se}"
        );
        compared += 1;
    }
    assert!(
        compared > 0,
        "no continued cell settled on the 68-s run's orbit"
    );
    // The cells that stay as they were are the raw map's.
    let (k_end, k_plain) = (npy_f64(&settled, "K.npy"), npy_f64(plain, "K.npy"));
    for k in (0..24).filter(|&k| !run_on[k]) {
        assert_eq!(k_end[k].to_bits(), k_plain[k].to_bits(), "cell {k}");
    }
    std::fs::remove_dir_all(settled).ok();
}

#[test]
fn settling_is_refused_where_it_cannot_run() {
    let cases: [(&[&str], &str); 5] = [
        (
            &["map.settle_max_s=50.0"],
            "at least integration.duration_s plus the indicators' window",
        ),
        (&["map.settle_max_s=1e6"], "100000"),
        (
            &["map.settle_max_s=68.0", "map.metrics=[\"K\", \"period\"]"],
            "\"regime\" in map.metrics",
        ),
        (
            &["map.settle_max_s=68.0", "map.early_stop=false"],
            "map.early_stop = true",
        ),
        (
            &["map.settle_max_s=68.0", "map.initial_states=4"],
            "one start per cell",
        ),
    ];
    for (sets, says) in cases {
        let err = refused_windows(sets);
        assert!(
            err.contains("map.settle_max_s") && err.contains(says),
            "{sets:?}: {err}"
        );
    }
    // Asked for by map.settle alone, with the reason.
    let err = refused_windows(&["map.settle=true", "map.early_stop=false"]);
    assert!(
        err.contains("`map.settle`") && err.contains("map.early_stop = true"),
        "{err}"
    );
    // map.settle = false with a settling time is a contradiction.
    let err = refused_windows(&["map.settle=false", "map.settle_max_s=68.0"]);
    assert!(
        err.contains("map.settle = false keeps the raw map"),
        "{err}"
    );
}

/// The stderr of the [`WINDOWS`] map with `sets` on the CPU, which must be refused (exit 2)
/// before it writes anything.
fn refused_windows(sets: &[&str]) -> String {
    let out = out_dir("settle-refused");
    let mut cmd = bin();
    cmd.args(["map", "--backend", "cpu", "--set", WINDOWS]);
    for s in sets {
        cmd.args(["--set", s]);
    }
    let o = cmd.arg("--out").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{sets:?}: {err}");
    assert!(!out.join("map.json").exists(), "{sets:?}");
    std::fs::remove_dir_all(&out).ok();
    err
}

#[test]
fn settling_is_on_by_default_where_a_map_can_settle_and_off_where_it_cannot() {
    let (settled, _) = run_windows("cpu", "settle-default", &[]);
    assert_eq!(map_json(&settled)["settle"]["max_s"], 68.0);
    // Without the early stop a map cannot settle: unasked, it runs raw.
    let (raw, _) = run_windows("cpu", "settle-default-raw", &["map.early_stop=false"]);
    assert!(map_json(&raw)["settle"].is_null());
    for d in [settled, raw] {
        std::fs::remove_dir_all(d).ok();
    }
}

#[test]
fn a_sharded_map_settles_in_its_merge_as_the_whole_map_does() {
    let (whole, _) = run_windows("cpu", "settle-whole", &[]);
    let shards: Vec<std::path::PathBuf> = (0..2)
        .map(|i| {
            let d = out_dir(&format!("settle-shard-{i}"));
            let o = bin()
                .args(["map", "--backend", "cpu", "--set", WINDOWS])
                .args(["--shard", &format!("{i}/2"), "--out"])
                .arg(&d)
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            assert!(d.join("shard_state.npy").exists());
            d
        })
        .collect();
    let merged = out_dir("settle-merged");
    let o = bin()
        .arg("merge")
        .args(&shards)
        .arg("--out")
        .arg(&merged)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = map_json(&merged)["settle"].clone();
    assert_eq!(
        report["cells"],
        map_json(&whole)["settle"]["cells"],
        "{report}"
    );
    assert!(report["continued"].as_u64() > Some(0), "{report}");
    for name in [
        "K.npy",
        "R.npy",
        "period.npy",
        "lyapunov.npy",
        "verdict_confidence.npy",
    ] {
        let (a, b) = (npy_f64(&whole, name), npy_f64(&merged, name));
        for k in 0..a.len() {
            assert!(
                a[k].to_bits() == b[k].to_bits(),
                "{name}, cell {k}: whole {} against merged {}",
                a[k],
                b[k]
            );
        }
    }
    // --no-settle keeps the shards' own cells: the raw map's.
    let (raw, _) = run_windows("cpu", "settle-raw", &["map.settle=false"]);
    let o = bin()
        .arg("merge")
        .args(&shards)
        .args(["--no-settle", "--out"])
        .arg(&merged)
        .arg("--force")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(map_json(&merged)["settle"].is_null());
    let bits = |d: &std::path::Path| -> Vec<u64> {
        npy_f64(d, "K.npy").iter().map(|v| v.to_bits()).collect()
    };
    assert_eq!(bits(&raw), bits(&merged));
    for d in shards.into_iter().chain([whole, merged, raw]) {
        std::fs::remove_dir_all(d).ok();
    }
}

/// A map with adaptive steps runs in the CPU engine's SIMD lanes and on the GPU, each cell's
/// twin on its sub-steps: on the linear clamped cantilever every cell's λ1 is the least-damped
/// eigenvalue on both.
#[test]
fn a_map_with_adaptive_steps_has_lambda1_on_its_sub_steps_on_every_engine() {
    let sets = [
        "map.axes=[{key=\"excitation.frequency_hz\",values=[5.0,8.0,11.0]}]",
        "pivot.mode=\"clamped\"",
        "limiter.enabled=false",
        "initial.angle_deg=0.0",
        "excitation.amplitude_m=0.0001",
        "map.metrics=[\"K\", \"period\", \"lyapunov\"]",
        "integration.step=\"adaptive\"",
    ];
    // The chain of every cell: the default map's N = 3, clamped, no bumpers.
    let chain = pendulum_atlas_core::config::Scene::from_toml(
        pendulum_atlas_core::config::PAPER_SCENE_TOML,
        "<paper>",
        &[
            "beam.segments=3".into(),
            "pivot.mode=\"clamped\"".into(),
            "limiter.enabled=false".into(),
        ],
    )
    .unwrap();
    let want =
        pendulum_atlas_core::model::linear::jacobian_eigenvalues(&chain.model_params().unwrap())
            .unwrap()
            .iter()
            .map(|z| z.re)
            .fold(f64::NEG_INFINITY, f64::max);
    let mut backends = vec!["cpu"];
    if crate::engine::gpu().is_some() {
        backends.push("gpu");
    }
    for backend in backends {
        let out = out_dir(&format!("adaptive-{backend}"));
        let mut cmd = bin();
        cmd.args(["map", "--quiet", "--backend", backend]);
        for s in sets {
            cmd.args(["--set", s]);
        }
        let o = cmd.arg("--out").arg(&out).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j = map_json(&out);
        assert_eq!(j["backend"], backend, "{j}");
        // At N = 3 `auto` picks RK4, and so the explicit pair, whose steps the SIMD lanes take
        // each their own.
        assert_eq!(j["method"], "rk4");
        let reason = j["method_reason"].as_str().unwrap();
        assert!(reason.contains("third-order"), "{reason}");
        if backend == "cpu" {
            let adapter = j["adapter"].as_str().unwrap();
            assert!(adapter.contains("simd loop"), "{adapter}");
        }
        let lyap = npy_f64(&out, "lyapunov.npy");
        assert_eq!(lyap.len(), 3);
        for l in lyap {
            assert!(
                (l - want).abs() < 0.01 * want.abs(),
                "{backend}: λ1 {l} against {want}"
            );
        }
        std::fs::remove_dir_all(&out).ok();
    }
}

/// `map.json` counts the sub-steps an adaptive map tried (`steps.sub_steps_tried`), on every
/// engine, and `null` at fixed steps. On an impacting periodic cell of the default map the
/// scalar loop and the SIMD lanes take the same steps, the GPU about as many as the CPU engine
/// in f32, and the bumper contacts ask for more sub-steps than base steps. The GPU and f32 are
/// compared without the early stop: on this cell its decision (λ1 precise enough after one
/// window, or the window doubled) sits on a threshold that a rounding difference crosses, so
/// with it the two stop a whole window apart (20 264 against 13 383 sub-steps, while without
/// it they tried 45 532 and 45 617; at 9.30, 9.32, 9.34 and 9.36 Hz they stop at the same step).
#[test]
fn map_json_counts_the_sub_steps_an_adaptive_map_tried_on_every_engine() {
    let cell = "map.axes=[{key=\"excitation.frequency_hz\",values=[9.333]},{key=\"excitation.amplitude_m\",values=[0.025]}]";
    let run = |args: &[&str], name: &str| {
        let out = out_dir(&format!("sub-steps-{name}"));
        let o = bin()
            .args(["map", "--quiet", "--set", cell])
            .args(args)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let steps = map_json(&out)["steps"].clone();
        std::fs::remove_dir_all(&out).ok();
        let base = steps["integrated_instance_steps"].as_u64().unwrap();
        (base, steps["sub_steps_tried"].as_u64())
    };
    let (base, scalar) = run(&["--backend", "cpu", "--cpu-loop", "scalar"], "scalar");
    let scalar = scalar.expect("an adaptive map counts its sub-steps");
    assert!(
        scalar > base && scalar < 2 * base,
        "{scalar} sub-steps in {base} base steps"
    );
    let (_, simd) = run(&["--backend", "cpu", "--cpu-loop", "simd"], "simd");
    let simd = simd.unwrap() as f64;
    assert!(
        (simd / scalar as f64 - 1.0).abs() < 0.01,
        "SIMD lanes {simd} against the scalar loop's {scalar}"
    );
    if crate::engine::gpu().is_some() {
        let whole = ["--set", "map.early_stop=false"];
        let (_, gpu) = run(&[&["--backend", "gpu"][..], &whole].concat(), "gpu");
        let f32_args = [&["--backend", "cpu", "--precision", "f32"][..], &whole].concat();
        let (_, f32) = run(&f32_args, "f32");
        let (gpu, f32) = (gpu.unwrap() as f64, f32.unwrap() as f64);
        assert!(
            (gpu / f32 - 1.0).abs() < 0.02,
            "GPU {gpu} against the CPU's {f32} in f32"
        );
    }
    let (_, fixed) = run(
        &["--backend", "cpu", "--set", "integration.step=\"fixed\""],
        "fixed",
    );
    assert_eq!(fixed, None, "fixed steps have no sub-steps");
}

/// Adaptive steps finer than f32 resolves are refused in f32, before any step, by a map, a
/// single run and a search, and accepted in f64: in f32 every sub-step would be forced to the
/// ladder's finest level (a 2-s run at rtol 1e-10 took 75.8 s). (rtol 9e-5 is just past the
/// limit, and fast in f64.)
#[test]
fn an_adaptive_tolerance_finer_than_f32_resolves_is_refused_in_f32() {
    let sets = [
        "map.axes=[{key=\"excitation.frequency_hz\",values=[8.0]},{key=\"excitation.amplitude_m\",values=[0.009]}]",
        "map.metrics=[\"hops\"]",
        "integration.duration_s=1.0",
        "integration.transient_s=0.5",
        "integration.step=\"adaptive\"",
        "integration.rtol=9e-5",
    ];
    let search = [
        "integration.duration_s=4.0",
        "integration.transient_s=2.0",
        "search.refine.rounds=0",
        "search.verify=false",
        "search.variables=[{key=\"limiter.clearance_deg\",values=[10.0]}]",
        "search.band={start_hz=20.0,end_hz=21.0,count=2,base_acceleration_m_s2=2.0}",
        "search.baseline.zoom_count=0",
        "integration.step=\"adaptive\"",
        "integration.rtol=9e-5",
    ];
    for (precision, refused) in [("f32", true), ("f64", false)] {
        let runs: [(&str, Vec<&str>, &[&str]); 3] = [
            ("map", vec!["map", "--quiet", "--backend", "cpu"], &sets),
            ("simulate", vec!["simulate"], &sets[2..]),
            (
                "search",
                vec!["search", "--quiet", "--backend", "cpu"],
                &search,
            ),
        ];
        for (name, args, sets) in runs {
            let out = out_dir(&format!("f32-tolerance-{name}-{precision}"));
            let mut cmd = bin();
            cmd.args(&args).args(["--precision", precision]);
            for s in sets {
                cmd.args(["--set", s]);
            }
            let o = cmd.arg("--out").arg(&out).output().unwrap();
            let stderr = String::from_utf8_lossy(&o.stderr);
            if refused {
                assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
                assert!(
                    stderr.contains("finer than f32 resolves"),
                    "{name}: {stderr}"
                );
                assert!(
                    stderr.contains("integration.rtol >= 1e-4"),
                    "{name}: {stderr}"
                );
            } else {
                assert!(o.status.success(), "{name}: {stderr}");
            }
            std::fs::remove_dir_all(&out).ok();
        }
    }
}

/// A map with the verdict does not warn that K comes from fewer than the comfortable number of
/// stroboscopic samples (the verdict reads such a K as not firm and decides by λ1 and the
/// period); a map of K without the verdict still does.
#[test]
fn the_short_k_warning_comes_only_where_no_verdict_weighs_k() {
    let sets = [
        "map.axes=[{key=\"excitation.frequency_hz\",values=[8.0,9.0]},{key=\"excitation.amplitude_m\",values=[0.009]}]",
        "integration.duration_s=20.0",
        "integration.transient_s=4.0",
    ];
    for (metrics, warned) in [("[\"K\",\"regime\"]", false), ("[\"K\"]", true)] {
        let out = out_dir(&format!("short-k-{warned}"));
        let mut cmd = bin();
        cmd.args(["map", "--quiet", "--backend", "cpu"]);
        for s in sets {
            cmd.args(["--set", s]);
        }
        cmd.args(["--set", &format!("map.metrics={metrics}")]);
        let o = cmd.arg("--out").arg(&out).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            stderr.contains("stroboscopic samples (fewest"),
            warned,
            "{metrics}: {stderr}"
        );
        std::fs::remove_dir_all(&out).ok();
    }
}

/// A cell of an adaptive map (the default) is pinned as adaptive steps of the base step its
/// map took, with the map's tolerances: its single run takes those base steps, not fixed steps
/// of that length (a fixed step would be another integrator: on an 8 × 6 default plane the
/// reruns then differed from the map in K class on 6 of 48 cells). A fixed-step map's cell
/// keeps its fixed step.
#[test]
fn a_cell_rerun_takes_the_step_control_and_step_its_map_took() {
    use pendulum_atlas_core::config::{StepControl, TimeStep, map_from_toml};
    use pendulum_atlas_core::engine::{EnsembleOptions, EnsemblePlan, StepPlan};
    use pendulum_atlas_map::map::cell::{PINNED_ADAPTIVE_KEYS, PINNED_KEYS, pinned_cell};
    for (step, keys) in [("adaptive", &PINNED_ADAPTIVE_KEYS), ("fixed", &PINNED_KEYS)] {
        let text = format!(
            "[beam]\nsegments = 3\n[integration]\nstep = \"{step}\"\nrtol = 3e-4\n\
             [map]\n[[map.axes]]\nkey = \"excitation.frequency_hz\"\nvalues = [7.0, 9.0]\n"
        );
        let spec = map_from_toml(&text, "<test>", &[]).expect("map");
        let plan = EnsemblePlan::new(&spec).expect("plan");
        let (table, pinned) = pinned_cell(
            spec.instance_table(1).unwrap(),
            &EnsembleOptions::from_spec(&spec),
        )
        .expect("pinned");
        assert_eq!(pinned, keys);
        let scene = pendulum_atlas_core::config::Scene::from_table(table).expect("cell scene");
        let run = StepPlan::for_scene(&scene).expect("step plan");
        let map_cell = &plan.instances[1];
        assert_eq!(run.dt_s, map_cell.dt_s, "{step}: the map's step");
        assert_eq!(
            run.control, map_cell.control,
            "{step}: the map's step control"
        );
        match step {
            "adaptive" => {
                assert_eq!(
                    scene.integration.base_step_s,
                    TimeStep::Seconds(map_cell.dt_s)
                );
                assert!(matches!(run.control, StepControl::Adaptive { rtol, .. } if rtol == 3e-4));
            }
            _ => assert_eq!(scene.integration.dt_s, TimeStep::Seconds(map_cell.dt_s)),
        }
    }
}

/// A `.pendulum-atlas.earlier` the tool did not make (a symlink to another folder, or a real
/// folder holding other files) is refused by name before anything moves: neither the
/// symlink's target nor the planted folder loses a file, and the output folder gains none
/// (issue 71).
#[test]
fn a_planted_earlier_folder_is_refused_and_nothing_moves() {
    let elsewhere = out_dir("planted-target");
    std::fs::create_dir_all(&elsewhere).unwrap();
    std::fs::write(elsewhere.join("id_rsa"), "secret").unwrap();
    std::fs::write(elsewhere.join("K.npy"), "not a map's").unwrap();
    let plant_link = |out: &std::path::Path| {
        std::os::unix::fs::symlink(&elsewhere, out.join(".pendulum-atlas.earlier")).unwrap()
    };
    // A symlink where the earlier run's manifest would be, to a FIFO: refused, never read
    // (a read would wait on the FIFO for ever).
    let plant_fifo = |out: &std::path::Path| {
        let d = out.join(".pendulum-atlas.earlier");
        std::fs::create_dir(&d).unwrap();
        let fifo = out.join("..").join(format!("fifo-{}", std::process::id()));
        let _ = std::fs::remove_file(&fifo);
        assert!(
            Command::new("mkfifo")
                .arg(&fifo)
                .status()
                .unwrap()
                .success()
        );
        std::os::unix::fs::symlink(&fifo, d.join("map.json")).unwrap();
    };
    let plant_folder = |out: &std::path::Path| {
        let d = out.join(".pendulum-atlas.earlier");
        std::fs::create_dir(&d).unwrap();
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        std::fs::write(d.join("K.npy"), "mine too").unwrap();
    };
    type Plant<'a> = &'a dyn Fn(&std::path::Path);
    let plants: [(&str, Plant); 3] = [
        ("a symlink", &plant_link),
        ("a file no run", &plant_folder),
        ("a symlink", &plant_fifo),
    ];
    for (i, (what, plant)) in plants.into_iter().enumerate() {
        let out = out_dir(&format!("planted-{i}"));
        std::fs::create_dir_all(&out).unwrap();
        plant(&out);
        let o = bin()
            .args(["map", "--backend", "cpu", "--quiet", "--out"])
            .arg(&out)
            .args(TINY)
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(".pendulum-atlas.earlier") && e.contains(what),
            "{e}"
        );
        assert!(e.contains("nothing was moved"), "{e}");
        assert_eq!(
            folder_files(&out),
            vec![".pendulum-atlas.earlier".to_string()]
        );
        assert_eq!(
            std::fs::read_to_string(elsewhere.join("id_rsa")).unwrap(),
            "secret"
        );
        let _ = std::fs::remove_dir_all(&out);
    }
    assert_eq!(folder_files(&elsewhere), vec!["K.npy", "id_rsa"]);
    let _ = std::fs::remove_dir_all(&elsewhere);
}

/// A refined map settles as the plain map does (issue 71: `map.refine = true` turned the
/// default's settling off without a word, so the refined map was less right than the map it
/// refines): its cells that are not firm run on, a filled cell that ran on is computed, and
/// the refinement's counts follow.
#[test]
fn a_refined_map_settles_as_the_plain_map_does() {
    let out = out_dir("refined-settled");
    let o = bin()
        .args(["map", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args([
            "--set",
            "map.axes=[{key=\"excitation.frequency_hz\",start=4.0,end=12.0,count=17},{key=\"excitation.amplitude_m\",start=0.004,end=0.025,count=9}]",
            "--set",
            "map.refine=true",
            "--set",
            "map.refine_spacing=4",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j = map_json(&out);
    let settled = j["settle"]["cells"].as_u64().unwrap();
    assert!(settled > 0, "{}", j["settle"]);
    let read_u8 = |name: &str| -> Vec<u8> {
        npyz::NpyFile::new(std::fs::File::open(out.join(name)).unwrap())
            .unwrap()
            .into_vec()
            .unwrap()
    };
    let (ran_on, inferred) = (read_u8("ran_on.npy"), read_u8("inferred.npy"));
    assert_eq!(ran_on.iter().filter(|&&r| r == 1).count() as u64, settled);
    assert!(
        ran_on
            .iter()
            .zip(&inferred)
            .all(|(&r, &i)| !(r == 1 && i == 1))
    );
    let flagged = inferred.iter().filter(|&&i| i == 1).count() as u64;
    assert_eq!(j["refine"]["inferred"].as_u64(), Some(flagged));
    assert_eq!(j["refine"]["computed"].as_u64().unwrap() + flagged, 17 * 9);
}

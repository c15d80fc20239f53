//! `analyze` end to end on small synthetic CSVs: every bad input is an error (exit 2) that
//! names the problem, the flag or file, and the accepted range; good input runs every
//! indicator it can and says what it chose or left out.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh folder for one test.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "pendulum-atlas-analyze-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `t_s,cart_m,angle_rad` rows at the given times: a 1/3 subharmonic of 8-Hz forcing.
fn write_csv(path: &Path, times: impl Iterator<Item = f64>) {
    let mut s = String::from("t_s,cart_m,angle_rad\n");
    for t in times {
        let cart = 0.009 * (TAU * 8.0 * t).sin();
        let angle = 0.3 * (TAU * 8.0 / 3.0 * t).sin();
        s.push_str(&format!("{t},{cart},{angle}\n"));
    }
    std::fs::write(path, s).unwrap();
}

/// 20 s at 200 Hz.
fn uniform_times() -> impl Iterator<Item = f64> {
    (0..4000).map(|i| i as f64 / 200.0)
}

/// Runs `analyze DATA ARGS --out OUT`.
fn analyze(data: &Path, args: &[&str], out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
        .arg("analyze")
        .arg(data)
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

/// The error text of a run that must fail with exit code 2 and no panic.
fn failure(o: &Output) -> String {
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "expected failure: {e}");
    assert!(!e.contains("panicked"), "{e}");
    e
}

/// The stderr of a run that must succeed, and its analysis.json.
fn success(o: &Output, out: &Path) -> (String, serde_json::Value) {
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{e}");
    let text = std::fs::read_to_string(out.join("analysis.json")).unwrap();
    (e, serde_json::from_str(&text).unwrap())
}

const A: [&str; 6] = [
    "--signal",
    "angle_rad",
    "--time",
    "t_s",
    "--forcing-hz",
    "8",
];

#[test]
fn negative_transient_is_an_error() {
    let d = dir("negative-transient");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    let e = failure(&analyze(
        &data,
        &[&A[..], &["--transient-s=-1"]].concat(),
        &d,
    ));
    assert!(
        e.contains("--transient-s") && e.contains("[0,") && e.contains("-1"),
        "{e}"
    );
    let e = failure(&analyze(
        &data,
        &[&A[..], &["--transient-s", "-1"]].concat(),
        &d,
    ));
    assert!(e.contains("--transient-s"), "{e}");
}

#[test]
fn transient_leaving_too_little_record_names_both_numbers() {
    let d = dir("long-transient");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    let e = failure(&analyze(
        &data,
        &[&A[..], &["--transient-s", "25"]].concat(),
        &d,
    ));
    assert!(e.contains("25 s") && e.contains("19.995 s"), "{e}");
    assert!(e.contains("--transient-s"), "{e}");
}

#[test]
fn unresolvable_forcing_is_an_error_naming_the_sample_rate() {
    let d = dir("forcing");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    for f in ["600", "1e6", "21"] {
        let started = std::time::Instant::now();
        let o = analyze(
            &data,
            &["--signal", "angle_rad", "--time", "t_s", "--forcing-hz", f],
            &d,
        );
        let e = failure(&o);
        assert!(started.elapsed().as_secs() < 10, "{f} Hz took too long");
        assert!(e.contains("200 Hz") && e.contains("(0, 20]"), "{f}: {e}");
    }
}

#[test]
fn non_positive_rates_name_the_flag_and_the_range() {
    let d = dir("rates");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    for (args, flag) in [
        (vec!["--sample-rate-hz", "0"], "--sample-rate-hz"),
        (vec!["--sample-rate-hz", "-5"], "--sample-rate-hz"),
        (
            vec!["--sample-rate-hz", "200", "--forcing-hz", "-8"],
            "--forcing-hz",
        ),
        (
            vec!["--sample-rate-hz", "200", "--forcing-hz", "0"],
            "--forcing-hz",
        ),
    ] {
        let all = [&["--signal", "angle_rad"][..], &args].concat();
        let e = failure(&analyze(&data, &all, &d));
        assert!(e.contains(flag) && e.contains("(0, inf)"), "{args:?}: {e}");
    }
}

#[test]
fn clearance_is_range_checked_like_the_scene_key() {
    let d = dir("clearance");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    for c in ["0", "90", "95", "-3"] {
        let e = failure(&analyze(
            &data,
            &[&A[..], &["--clearance-deg", c]].concat(),
            &d,
        ));
        assert!(
            e.contains("--clearance-deg") && e.contains("(0, 90)"),
            "{c}: {e}"
        );
    }
    let o = analyze(&data, &[&A[..], &["--clearance-deg", "10"]].concat(), &d);
    let (_, j) = success(&o, &d);
    assert!(j["statistics"]["hops"].is_u64());
}

#[test]
fn constant_signal_is_an_error() {
    let d = dir("constant");
    let data = d.join("r.csv");
    let mut s = String::from("t_s,angle_rad\n");
    for i in 0..4000 {
        // A resting pendulum with rounding noise of 1e-14.
        let jitter = if i % 3 == 0 { 1e-14 } else { 0.0 };
        s.push_str(&format!("{},{}\n", i as f64 / 200.0, 0.25 + jitter));
    }
    std::fs::write(&data, s).unwrap();
    let e = failure(&analyze(
        &data,
        &["--signal", "angle_rad", "--time", "t_s"],
        &d,
    ));
    assert!(e.contains("constant") && e.contains("angle_rad"), "{e}");
}

#[test]
fn duplicate_column_names_are_an_error_naming_the_column() {
    let d = dir("duplicates");
    let data = d.join("r.csv");
    let mut s = String::from("t_s,angle_rad,angle_rad\n");
    for i in 0..100 {
        s.push_str(&format!("{},{},{}\n", i as f64 / 200.0, i % 7, i % 5));
    }
    std::fs::write(&data, s).unwrap();
    let e = failure(&analyze(
        &data,
        &["--signal", "angle_rad", "--time", "t_s"],
        &d,
    ));
    assert!(
        e.contains("`angle_rad` appears twice") && e.contains("columns 2 and 3"),
        "{e}"
    );
}

/// 5 s and 6 s of 1-kHz samples around a 1-s pause.
fn times_with_gap() -> impl Iterator<Item = f64> {
    (0..=5000)
        .map(|i| i as f64 / 1000.0)
        .chain((0..=6000).map(|i| 6.0 + i as f64 / 1000.0))
}

#[test]
fn gap_is_refused_unless_allowed_and_then_reported() {
    let d = dir("gap");
    let data = d.join("r.csv");
    write_csv(&data, times_with_gap());
    let base = [&A[..], &["--resample"]].concat();
    let e = failure(&analyze(&data, &base, &d));
    assert!(
        e.contains("1 s after t = 5 s") && e.contains("--allow-gaps"),
        "{e}"
    );
    let e = failure(&analyze(&data, &A, &d));
    assert!(
        e.contains("--resample") && e.contains("1 s after t = 5 s"),
        "{e}"
    );
    let o = analyze(&data, &[&base[..], &["--allow-gaps"]].concat(), &d);
    let (stderr, j) = success(&o, &d);
    assert!(
        stderr.contains("warning: gap of 1 s after t = 5 s"),
        "{stderr}"
    );
    // Resampled at the median rate, 1 kHz, not the mean rate of ~917 Hz.
    let rate = j["input"]["sample_rate_hz"].as_f64().unwrap();
    assert!((rate - 1000.0).abs() < 1e-6, "{rate}");
    assert_eq!(j["input"]["samples"], 12001);
    assert_eq!(j["input"]["gaps"][0]["start_s"], 5.0);
    assert_eq!(j["input"]["gaps"][0]["length_s"], 1.0);
}

#[test]
fn jittered_time_is_resampled_at_the_median_rate() {
    let d = dir("jitter");
    let data = d.join("r.csv");
    // 200 Hz stamps with every tenth step 1.5 times longer: median 5 ms, mean 5.25 ms.
    let mut t = 0.0;
    let times: Vec<f64> = (0..4000)
        .map(|i| {
            let now = t;
            t += if i % 10 == 9 { 0.0075 } else { 0.005 };
            now
        })
        .collect();
    write_csv(&data, times.into_iter());
    let o = analyze(&data, &[&A[..], &["--resample"]].concat(), &d);
    let (stderr, j) = success(&o, &d);
    assert!((j["input"]["sample_rate_hz"].as_f64().unwrap() - 200.0).abs() < 1e-9);
    assert!(stderr.contains("median rate"), "{stderr}");
    assert!(j["input"]["gaps"].as_array().unwrap().is_empty());
}

#[test]
fn without_forcing_everything_but_the_section_runs() {
    let d = dir("no-forcing");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    let o = analyze(
        &data,
        &[
            "--signal",
            "angle_rad",
            "--reference",
            "cart_m",
            "--time",
            "t_s",
        ],
        &d,
    );
    let (stderr, j) = success(&o, &d);
    assert!(
        stderr.contains("note:") && stderr.contains("local extrema"),
        "{stderr}"
    );
    assert_eq!(j["zero_one"]["sampling"], "extrema");
    assert!(j["phase_sync"]["R"].is_f64());
    assert!((j["spectrum"]["dominant_hz"].as_f64().unwrap() - 8.0 / 3.0).abs() < 0.05);
    assert!(j["spectrum"]["ratio_to_forcing"].is_null());
    assert!(j["statistics"]["period"].is_null());
    for f in [
        "scalogram.png",
        "spectrum.png",
        "phase_hist.png",
        "zero_one.png",
    ] {
        assert!(d.join(f).is_file(), "missing {f}");
    }
    let e = failure(&analyze(
        &data,
        &[
            "--signal",
            "angle_rad",
            "--time",
            "t_s",
            "--sampling",
            "stroboscopic",
        ],
        &d,
    ));
    assert!(e.contains("--forcing-hz"), "{e}");
}

/// Shape of a little-endian f64 `.npy` file, read from its header (format 1.0).
fn npy_shape(path: &Path) -> Vec<usize> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
    assert!(header.contains("'descr': '<f8'"), "{header}");
    let shape = &header[header.find("'shape': (").unwrap() + 10..];
    shape[..shape.find(')').unwrap()]
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().unwrap())
        .collect()
}

#[test]
fn wavelet_settings_are_options_and_written_out() {
    let d = dir("wavelet");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    let args = [
        &A[..],
        &[
            "--wavelet-dj",
            "0.25",
            "--wavelet-s0",
            "0.1",
            "--wavelet-j",
            "20",
            "--wavelet-omega0",
            "8",
            "--wavelet-lag1",
            "0.5",
            "--wavelet-confidence",
            "0.9",
            "--wavelet-max-rate-hz",
            "50",
        ],
    ]
    .concat();
    let (_, j) = success(&analyze(&data, &args, &d), &d);
    let w = &j["wavelet"];
    assert_eq!(w["mother"]["name"], "morlet");
    assert_eq!(w["mother"]["omega0"], 8.0);
    assert_eq!(
        (w["dj"].as_f64(), w["s0_s"].as_f64()),
        (Some(0.25), Some(0.1))
    );
    assert_eq!((w["j"].as_u64(), w["lag1"].as_f64()), (Some(20), Some(0.5)));
    assert_eq!(w["lag1_source"], "given");
    assert_eq!(w["confidence"], 0.9);
    assert_eq!(w["rate_hz"], 50.0);
    let cols = w["n_samples"].as_u64().unwrap() as usize;
    assert_eq!(cols, 1000);
    for (f, shape) in [
        ("wavelet_power.npy", vec![21, cols]),
        ("wavelet_signif_ratio.npy", vec![21, cols]),
        ("wavelet_signif_level.npy", vec![21]),
        ("wavelet_global_power.npy", vec![21]),
        ("wavelet_global_signif.npy", vec![21]),
        ("wavelet_period_s.npy", vec![21]),
        ("wavelet_scale_s.npy", vec![21]),
        ("wavelet_time_s.npy", vec![cols]),
        ("wavelet_coi_s.npy", vec![cols]),
    ] {
        assert_eq!(npy_shape(&d.join(f)), shape, "{f}");
    }
    // The defaults are written too, with the estimator named.
    let (_, j) = success(&analyze(&data, &[&A[..], &["--force"]].concat(), &d), &d);
    assert_eq!(j["wavelet"]["dj"], 1.0 / 12.0);
    assert_eq!(j["wavelet"]["mother"]["omega0"], 6.0);
    assert!(
        j["wavelet"]["lag1_source"]
            .as_str()
            .unwrap()
            .contains("allen-smith"),
        "{}",
        j["wavelet"]
    );
    for (flag, value, range) in [
        ("--wavelet-dj", "0", "(0, 1]"),
        ("--wavelet-omega0", "3", "at least 5"),
        ("--wavelet-confidence", "1", "(0, 1)"),
        ("--wavelet-lag1", "1.5", "(-1, 1)"),
        ("--wavelet-s0", "-1", "(0, inf)"),
    ] {
        let e = failure(&analyze(&data, &[&A[..], &[flag, value]].concat(), &d));
        assert!(e.contains(flag) && e.contains(range), "{flag} {value}: {e}");
    }
    // A huge omega0 needs scales longer than the record: the message says so, instead of an
    // empty range for s0 ("[1591.5, 20]").
    let e = failure(&analyze(
        &data,
        &[&A[..], &["--wavelet-omega0", "1e6", "--force"]].concat(),
        &d,
    ));
    assert!(
        e.contains("omega0 = 1000000")
            && e.contains("lower omega0")
            && !e.contains("must lie in ["),
        "{e}"
    );
}

#[test]
fn time_unit_is_written_to_json() {
    let d = dir("time-unit");
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    let (_, j) = success(
        &analyze(&data, &[&A[..], &["--time-unit", "ms"]].concat(), &d),
        &d,
    );
    assert_eq!(j["time_unit"], "ms");
    assert_eq!(j["options"]["time_unit"], "ms");
    let (_, j) = success(&analyze(&data, &[&A[..], &["--force"]].concat(), &d), &d);
    assert_eq!(j["time_unit"], "s");
    let e = failure(&analyze(
        &data,
        &[&A[..], &["--time-unit", " "]].concat(),
        &d,
    ));
    assert!(e.contains("--time-unit"), "{e}");
}

#[test]
fn io_errors_name_the_path() {
    let d = dir("io");
    let e = failure(&analyze(&d, &A, &d.join("out")));
    assert!(
        e.contains(&d.display().to_string()) && e.contains("directory"),
        "{e}"
    );
    let missing = d.join("missing.csv");
    let e = failure(&analyze(&missing, &A, &d.join("out")));
    assert!(e.contains(&missing.display().to_string()), "{e}");
    // An output folder that cannot be created (a file is in the way).
    let data = d.join("r.csv");
    write_csv(&data, uniform_times());
    let blocker = d.join("blocker");
    std::fs::write(&blocker, "").unwrap();
    let e = failure(&analyze(&data, &A, &blocker.join("out")));
    assert!(e.contains(&blocker.display().to_string()), "{e}");
}

/// A CSV cell that holds terminal controls (retitle, clear, NUL) is quoted escaped.
#[test]
fn control_characters_of_a_cell_reach_the_terminal_escaped() {
    let d = dir("controls");
    let data = d.join("hostile.csv");
    write_csv(&data, uniform_times());
    let mut text = std::fs::read_to_string(&data).unwrap();
    text.push_str("20.0,0.0,\u{1b}]0;owned\u{7}\u{1b}[2J\0\n");
    std::fs::write(&data, text).unwrap();
    let e = failure(&analyze(&data, &A, &d.join("out")));
    assert!(e.contains("is not a number"), "{e}");
    assert!(!e.contains(['\u{1b}', '\u{7}', '\0']), "{e:?}");
    assert!(e.contains("\\u{1b}]0;owned\\u{7}\\u{1b}[2J\\u{0}"), "{e}");
}

#[test]
fn empty_csv_says_it_is_empty() {
    let d = dir("empty");
    let data = d.join("r.csv");
    std::fs::write(&data, "").unwrap();
    let e = failure(&analyze(&data, &A, &d));
    assert!(
        e.contains("is empty") && e.contains(&data.display().to_string()),
        "{e}"
    );
    std::fs::write(&data, "t_s,angle_rad\n").unwrap();
    let e = failure(&analyze(&data, &A, &d));
    assert!(e.contains("no data rows"), "{e}");
}

#[test]
fn messages_name_no_internal_function() {
    let d = dir("internal");
    let data = d.join("r.csv");
    // One data row: no "check_uniform_time needs at least 2 samples".
    std::fs::write(&data, "t_s,angle_rad\n0,1\n").unwrap();
    let e = failure(&analyze(
        &data,
        &["--signal", "angle_rad", "--time", "t_s"],
        &d,
    ));
    assert!(
        !e.contains("check_uniform_time") && e.contains("1 data row(s)"),
        "{e}"
    );
    // Jitter without --resample: no "resample_uniform".
    let mut s = String::from("t_s,angle_rad\n");
    for i in 0..100 {
        let t = i as f64 * 0.01 + if i == 40 { 0.002 } else { 0.0 };
        s.push_str(&format!("{t},{}\n", (i as f64).sin()));
    }
    std::fs::write(&data, s).unwrap();
    let e = failure(&analyze(
        &data,
        &["--signal", "angle_rad", "--time", "t_s"],
        &d,
    ));
    assert!(
        !e.contains("resample_uniform") && e.contains("--resample"),
        "{e}"
    );
    assert!(e.contains("line 42"), "{e}");
    // A value of 1e308: no "alpha_lag1 must be finite, got NaN".
    write_csv(&data, uniform_times());
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    lines[500] = "2.495,0.0,1e308".to_string();
    std::fs::write(&data, lines.join("\n") + "\n").unwrap();
    let e = failure(&analyze(&data, &A, &d));
    assert!(!e.contains("alpha_lag1") && e.contains("too large"), "{e}");
}

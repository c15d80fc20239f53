//! The harvesting design search (issue 7): the band metric on curves with known answers, the
//! linear baseline against the clamped beam's natural frequency, `search` end to end on both
//! backends (with its power re-checked by `simulate`, as a user would), and its input errors.

use pendulum_atlas_core::engine::{Engine, Precision};
use pendulum_atlas_design::harvest::{
    SearchSpec, band_average_w, band_metrics, bandwidth_hz, mean_curve, robust_curve, run_search,
    search_from_toml,
};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

fn out_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!(
        "pendulum-atlas-harvest-{name}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!(
        (a - b).abs() <= tol && a.is_finite(),
        "{what}: got {a}, expected {b} (tolerance {tol})"
    );
}

fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| a + (b - a) * j as f64 / (n - 1) as f64)
        .collect()
}

#[test]
fn bandwidth_of_a_triangle_and_a_plateau_is_exact() {
    // A triangle peaking at 5 Hz: P ≥ 0.5 for |f − 5| ≤ 2.5, so 5 Hz of band; its mean over
    // 0–10 Hz is 0.5. Piecewise linear, so both are exact on the integer grid.
    let f = linspace(0.0, 10.0, 11);
    let p: Vec<f64> = f.iter().map(|&x| 1.0 - (x - 5.0).abs() / 5.0).collect();
    close(bandwidth_hz(&f, &p, 0.5), 5.0, 1e-12, "triangle bandwidth");
    close(band_average_w(&f, &p), 0.5, 1e-12, "triangle average");
    let m = band_metrics(&f, &p, 0.5);
    close(m.peak_w, 1.0, 0.0, "peak");
    close(m.peak_frequency_hz, 5.0, 0.0, "peak frequency");
    // Everything above, nothing above.
    close(bandwidth_hz(&f, &p, 0.0), 10.0, 1e-12, "threshold 0");
    close(
        bandwidth_hz(&f, &p, 1.5),
        0.0,
        0.0,
        "threshold above the peak",
    );
    // A plateau at 2 W exactly on the threshold counts in full.
    let flat = vec![2.0; f.len()];
    close(bandwidth_hz(&f, &flat, 2.0), 10.0, 1e-12, "plateau");
    close(band_average_w(&f, &flat), 2.0, 1e-12, "plateau average");
}

#[test]
fn bandwidth_adds_disjoint_spans_on_a_non_uniform_grid() {
    // Two boxes, [1, 2] and [4, 7], with linear flanks over one grid interval each.
    let f = [0.0, 1.0, 2.0, 3.0, 4.0, 7.0, 8.0];
    let p = [0.0, 4.0, 4.0, 0.0, 4.0, 4.0, 0.0];
    // Threshold 1: each flank contributes 3/4 of its interval.
    let expect = 0.75 + 1.0 + 0.75 + 0.75 + 3.0 + 0.75;
    close(bandwidth_hz(&f, &p, 1.0), expect, 1e-12, "two bands");
    // Trapezoids: 2 + 4 + 2 + 2 + 12 + 2 = 24 over 8 Hz.
    close(band_average_w(&f, &p), 3.0, 1e-12, "average");
}

#[test]
fn failed_samples_count_as_no_power() {
    let f = linspace(0.0, 4.0, 5);
    let p = [1.0, 1.0, f64::NAN, 1.0, 1.0];
    // The two intervals touching the NaN are ramps from 1 to 0: half of each reaches 0.5.
    close(
        bandwidth_hz(&f, &p, 0.5),
        3.0,
        1e-12,
        "bandwidth with a NaN",
    );
    close(band_average_w(&f, &p), 0.75, 1e-12, "average with a NaN");
    let m = band_metrics(&f, &p, 0.5);
    close(m.peak_w, 1.0, 0.0, "peak ignores NaN");
}

#[test]
fn bandwidth_of_a_resonance_converges_to_its_analytic_width() {
    // Lorentzian P = 1/(1 + (2Q(f − f0)/f0)²): P ≥ 1/2 over f0/Q.
    let (f0, q) = (20.0, 50.0);
    let f = linspace(10.0, 30.0, 20_001);
    let p: Vec<f64> = f
        .iter()
        .map(|&x| 1.0 / (1.0 + (2.0 * q * (x - f0) / f0).powi(2)))
        .collect();
    close(bandwidth_hz(&f, &p, 0.5), f0 / q, 1e-4, "half-power width");
    // ∫ over f0 ± 10 Hz = (f0/2Q) · 2 atan(2Q · 10/f0).
    let integral = band_average_w(&f, &p) * 20.0;
    let exact = f0 / (2.0 * q) * 2.0 * (2.0 * q * 10.0 / f0).atan();
    close(integral, exact, 1e-6, "area");
}

#[test]
fn robust_and_mean_curves_over_initial_states() {
    let states = vec![vec![1.0, 4.0, 2.0], vec![3.0, 2.0, f64::NAN]];
    let r = robust_curve(&states);
    assert_eq!(&r[..2], &[1.0, 2.0]);
    assert!(r[2].is_nan(), "a failed state makes the robust value NaN");
    let m = mean_curve(&states);
    assert_eq!(&m[..2], &[2.0, 3.0]);
    assert!(m[2].is_nan());
}

/// A small search scene: N = 3, the default patch, short runs.
fn tiny_spec(extra_sets: &[&str]) -> SearchSpec {
    let mut sets: Vec<String> = [
        "integration.duration_s=8.0",
        "integration.transient_s=5.0",
        "search.refine.rounds=0",
        "search.verify=false",
        "search.variables=[{key=\"limiter.clearance_deg\",values=[10.0]}]",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    sets.extend(extra_sets.iter().map(|s| s.to_string()));
    search_from_toml(
        pendulum_atlas_design::harvest::DEFAULT_SEARCH_TOML,
        "<default search>",
        &sets,
    )
    .expect("valid tiny search")
}

#[test]
fn the_baseline_peaks_at_the_clamped_first_natural_frequency() {
    // The band grid alone (no zoom), 0.5 Hz steps around the clamped mode.
    let spec = tiny_spec(&[
        "search.band={start_hz=20.0,end_hz=28.0,count=17,base_acceleration_m_s2=2.0}",
        "search.baseline.zoom_count=0",
    ]);
    let run = run_search(&spec, &Engine::cpu(Precision::F64), &|_, _, _| {}).expect("search");
    // `modes` of the clamped beam, no limiter, g as given.
    let mut clamped = spec.scene.clone();
    clamped.pivot.mode = pendulum_atlas_core::config::PivotMode::Clamped;
    clamped.limiter.enabled = false;
    let f1 = clamped.modes().unwrap().frequencies_hz[0];
    close(run.baseline.first_natural_hz, f1, 1e-9, "baseline f1");
    let b = &run.baseline;
    assert_eq!(b.failed, 0);
    let (peak_f, _) = spec.band.frequencies_hz.iter().zip(&b.band_power_w).fold(
        (f64::NAN, f64::NEG_INFINITY),
        |acc, (&f, &p)| {
            if p > acc.1 { (f, p) } else { acc }
        },
    );
    assert!(
        (peak_f - f1).abs() <= spec.band.step_hz(),
        "baseline P(f) peaks at {peak_f} Hz, clamped f1 = {f1} Hz (step {} Hz): {:?}",
        spec.band.step_hz(),
        b.band_power_w
    );
    // A real resonance: the peak stands well above the band's edges (±16 % of f1). With the
    // library damping (ζ1 ≈ 0.054, Q ≈ 9) the measured peak/edge power ratio is 8.5; it was
    // above 10 with ζ1 = 0.0035.
    let edge = b.band_power_w[0].max(b.band_power_w[b.band_power_w.len() - 1]);
    assert!(b.band_metrics.peak_w > 5.0 * edge, "{:?}", b.band_power_w);
}

#[test]
fn batches_cut_into_chunks_give_the_same_results() {
    // 2 designs × 2 states × 5 frequencies = 20 instances per batch: one ensemble, or chunks
    // of 7 (the last one short), must give the same numbers in the same order.
    let sets = [
        "search.band={start_hz=6.0,end_hz=26.0,count=5,base_acceleration_m_s2=2.0}",
        "search.variables=[{key=\"limiter.clearance_deg\",values=[5.0,10.0]}]",
        "search.baseline.zoom_count=3",
    ];
    let whole = tiny_spec(&sets);
    let mut chunked = whole.clone();
    chunked.max_batch_instances = 7;
    let a = run_search(&whole, &Engine::cpu(Precision::F64), &|_, _, _| {}).expect("search");
    let b = run_search(&chunked, &Engine::cpu(Precision::F64), &|_, _, _| {}).expect("search");
    assert_eq!(a.baseline.power_w, b.baseline.power_w);
    assert_eq!(a.designs.len(), b.designs.len());
    for (x, y) in a.designs.iter().zip(&b.designs) {
        assert_eq!(x.values, y.values);
        assert_eq!(x.power_w, y.power_w, "design {}", x.id);
        // NaN here (runs too short for the period test) must stay NaN: compare the bits.
        let bits =
            |v: &Vec<Vec<f64>>| -> Vec<u64> { v.iter().flatten().map(|p| p.to_bits()).collect() };
        assert_eq!(bits(&x.period), bits(&y.period), "design {}", x.id);
    }
    assert_eq!(a.ranking, b.ranking);
}

/// The `search` arguments of a tiny run: two clearances, one refinement round.
// A step converged in power (RK4 with the penalty bumper converges slowly in power: at
// dt_safety = 0.2 two slightly different steps can differ by 2 % on an impacting response),
// so that the search and `simulate` must agree closely.
const TINY: [&str; 18] = [
    "--set",
    "integration.dt_safety=0.05",
    "--set",
    "integration.duration_s=8.0",
    "--set",
    "integration.transient_s=4.0",
    "--set",
    "search.band={start_hz=6.0,end_hz=26.0,count=5,base_acceleration_m_s2=2.0}",
    "--set",
    "search.variables=[{key=\"limiter.clearance_deg\",values=[5.0,10.0]},{key=\"limiter.contact_arc_m\",values=[0.12]}]",
    "--set",
    "search.refine={rounds=1,top=1,shrink=0.5}",
    "--set",
    "search.baseline.zoom_count=5",
    "--set",
    "search.report_top=2",
    "--set",
    "search.threshold={power_w=1e-6}",
];

fn png_size(path: &std::path::Path) -> (u32, u32) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (img.width(), img.height())
}

/// Mean of `power_w` over the rows at or after `transient_s` of a trajectory.csv.
fn mean_power_after(csv_path: &std::path::Path, transient_s: f64) -> f64 {
    let text = std::fs::read_to_string(csv_path).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|h| *h == "power_w")
        .expect("power_w column");
    let (mut sum, mut n) = (0.0, 0usize);
    for l in lines {
        let cells: Vec<&str> = l.split(',').collect();
        let t: f64 = cells[0].parse().unwrap();
        if t >= transient_s - 1e-9 {
            sum += cells[col].parse::<f64>().unwrap();
            n += 1;
        }
    }
    sum / n as f64
}

fn check_search_dir(out: &std::path::Path, backend: &str) {
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("search.json")).unwrap()).unwrap();
    assert_eq!(json["backend"], backend);
    assert_eq!(json["counts"]["grid_designs"], 2);
    let designs = json["counts"]["designs"].as_u64().unwrap();
    assert!(designs > 2, "refinement added no design: {designs}");
    assert_eq!(json["counts"]["failed_instances"], 0);
    for key in ["timings_s", "settings", "baseline", "threshold_w", "best"] {
        assert!(json.get(key).is_some(), "search.json lacks `{key}`");
    }
    assert!(json["timings_s"]["total"].as_f64().unwrap() > 0.0);
    close(
        json["threshold_w"].as_f64().unwrap(),
        1e-6,
        0.0,
        "threshold",
    );

    let csv = std::fs::read_to_string(out.join("designs.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "id,stage,limiter.clearance_deg,limiter.contact_arc_m,bandwidth_robust_hz,band_avg_power_robust_w,peak_power_robust_w,peak_frequency_robust_hz,bandwidth_mean_hz,band_avg_power_mean_w,hops_per_instance_mean,periodic_fraction,failed_instances,pareto,rank"
    );
    let rows: Vec<Vec<String>> = lines
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len() as u64, designs);
    assert!(rows[0][0] == "0" && rows[0][1] == "grid" && rows[0][2] == "5");
    assert!(rows[2][1] == "refine 1", "{rows:?}");
    for r in &rows {
        let bw: f64 = r[4].parse().unwrap();
        let avg: f64 = r[5].parse().unwrap();
        let mean_avg: f64 = r[9].parse().unwrap();
        assert!((0.0..=20.0).contains(&bw), "bandwidth {bw}");
        assert!(
            avg > 0.0 && avg <= mean_avg * (1.0 + 1e-12),
            "robust {avg} vs mean {mean_avg}"
        );
    }
    assert_eq!(rows.iter().filter(|r| r[14] == "1").count(), 1);
    // The Pareto flags, recomputed by brute force from the two columns.
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .map(|r| (r[4].parse().unwrap(), r[5].parse().unwrap()))
        .collect();
    for (r, &(bw, p)) in rows.iter().zip(&pts) {
        let dominated = pts
            .iter()
            .any(|&(b2, p2)| b2 >= bw && p2 >= p && (b2 > bw || p2 > p));
        assert_eq!(
            r[13] == "true",
            !dominated,
            "Pareto flag of design {}",
            r[0]
        );
    }

    let md = std::fs::read_to_string(out.join("best.md")).unwrap();
    for needle in [
        "## Linear baseline",
        "## Top designs",
        "## Pareto front",
        "simulate",
    ] {
        assert!(md.contains(needle), "best.md lacks `{needle}`:\n{md}");
    }
    for f in ["pareto.png", "power_vs_frequency.png"] {
        let (w, h) = png_size(&out.join(f));
        assert!(w >= 600 && h >= 400, "{f} is {w}x{h}");
    }

    // The user's check: simulate the best design as written and average its power. The
    // check point is a regular response (periodic stroboscopic section), which another step
    // must reproduce closely.
    let best = json["best"]["id"].as_u64().unwrap().to_string();
    let toml_text = std::fs::read_to_string(out.join("best_design.toml")).unwrap();
    let scene: toml::Table = toml_text.parse().unwrap();
    let f = scene["excitation"]["frequency_hz"].as_float().unwrap();
    let inst = std::fs::read_to_string(out.join("instances.csv")).unwrap();
    let row = inst
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect::<Vec<_>>())
        .find(|c| {
            c[0] == best && c[1] == "+well" && (c[2].parse::<f64>().unwrap() - f).abs() < 1e-9
        })
        .expect("the best design's check point in instances.csv");
    let reported: f64 = row[4].parse().unwrap();
    let period: f64 = row[7].parse().unwrap();
    assert!(period >= 1.0, "the check point is not regular: {row:?}");
    let sim = out.join("check");
    let o = bin()
        .args(["simulate"])
        .arg(out.join("best_design.toml"))
        .arg("--out")
        .arg(&sim)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let simulated = mean_power_after(&sim.join("trajectory.csv"), 4.0);
    let tol = if backend == "gpu" { 0.02 } else { 0.01 };
    assert!(
        (simulated - reported).abs() <= tol * reported,
        "simulate gives {simulated} W, search reported {reported} W at {f} Hz"
    );
}

#[test]
fn search_runs_end_to_end_on_the_cpu() {
    let out = out_dir("cpu");
    let o = bin()
        .args(["search", "--backend", "cpu", "--quiet"])
        .args(TINY)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_search_dir(&out, "cpu");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("search.json")).unwrap()).unwrap();
    // The built-in re-simulation agrees on the regular responses.
    let v = &json["verification"];
    assert!(v["regular_points"].as_u64().unwrap() > 0, "{v}");
    let med = v["median_rel_diff_regular"].as_f64().unwrap();
    assert!(med < 0.01, "median relative difference {med}");
}

#[test]
fn search_runs_end_to_end_on_the_gpu() {
    if crate::engine::gpu().is_none() {
        return;
    }
    let out = out_dir("gpu");
    let o = bin()
        .args(["search", "--backend", "gpu", "--quiet"])
        .args(TINY)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_search_dir(&out, "gpu");
}

fn search_error(sets: &[&str]) -> String {
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    search_from_toml(
        pendulum_atlas_design::harvest::DEFAULT_SEARCH_TOML,
        "<default search>",
        &sets,
    )
    .expect_err("search scene must be rejected")
    .to_string()
}

#[test]
fn bad_search_scenes_are_refused_with_the_key_named() {
    let e = search_error(&[
        "search.variables=[{key=\"limiter.clearence_deg\",start=2.0,end=20.0,count=3}]",
    ]);
    assert!(
        e.contains("search.variables[1].key")
            && e.contains("`limiter.clearence_deg` is not a scene key")
            && e.contains("did you mean `limiter.clearance_deg`"),
        "{e}"
    );
    let e = search_error(&[
        "search.variables=[{key=\"tip.mass_kg\",start=0.0,end=0.02,count=2},{key=\"limiter.clearance_deg\",start=20.0,end=5.0,count=3}]",
    ]);
    assert!(
        e.contains("search.variables[2].end")
            && e.contains("limiter.clearance_deg")
            && e.contains("empty"),
        "{e}"
    );
    let e = search_error(&["search.variables=[{key=\"piezo.load_ohm\",values=[]}]"]);
    assert!(e.contains("piezo.load_ohm") && e.contains("empty"), "{e}");
    let e =
        search_error(&["search.variables=[{key=\"piezo.load_ohm\",start=1e5,end=1e6,count=0}]"]);
    assert!(
        e.contains("search.variables[1].count") && e.contains("empty"),
        "{e}"
    );
    let e = search_error(&[
        "search.variables=[{key=\"limiter.clearance_deg\",start=10.0,end=95.0,count=2}]",
    ]);
    assert!(
        e.contains("limiter.clearance_deg") && e.contains("out of range"),
        "{e}"
    );
    let e = search_error(&[
        "search.variables=[{key=\"excitation.frequency_hz\",start=5.0,end=9.0,count=2}]",
    ]);
    assert!(
        e.contains("excitation.frequency_hz") && e.contains("band"),
        "{e}"
    );
    let e = search_error(&["search.variables=[{key=\"pivot.mode\",start=1.0,end=2.0,count=2}]"]);
    assert!(
        e.contains("pivot.mode") && e.contains("cannot be a design variable"),
        "{e}"
    );
    let e = search_error(&["search.band.end_hz=2.0"]);
    assert!(
        e.contains("search.band.end_hz") && e.contains("empty"),
        "{e}"
    );
    let e = search_error(&["search.band.base_amplitude_m=0.001"]);
    assert!(e.contains("not both"), "{e}");
    let e = search_error(&["search.threshold.relative_to_baseline_peak=0.1"]);
    assert!(e.contains("not both"), "{e}");
    let e = search_error(&["search.refine.roundz=2"]);
    assert!(
        e.contains("search.refine.roundz") && e.contains("did you mean"),
        "{e}"
    );
    let e = search_error(&["piezo.enabled=false"]);
    assert!(e.contains("piezo.enabled"), "{e}");
}

/// A search whose first round alone is above the map's guard (the default search with 100000
/// band frequencies) is refused before any work with its figures, and runs when accepted.
#[test]
fn a_huge_search_is_refused_before_any_work_unless_accepted() {
    let e = search_error(&["search.band.count=100000"]);
    for part in [
        "search.band.count",
        "100000 frequencies",
        "instance-steps",
        "search.accept_huge",
    ] {
        assert!(e.contains(part), "{part}: {e}");
    }
    let accepted = search_from_toml(
        pendulum_atlas_design::harvest::DEFAULT_SEARCH_TOML,
        "<default search>",
        &[
            "search.band.count=100000".into(),
            "search.accept_huge=true".into(),
        ],
    );
    assert!(accepted.is_ok(), "{:?}", accepted.err());
}

#[test]
fn a_bad_design_variable_stops_the_command_with_its_name() {
    let o = bin()
        .args(["search", "--backend", "cpu", "--quiet", "--set"])
        .arg("search.variables=[{key=\"tip.mas_kg\",start=0.0,end=0.02,count=2}]")
        .arg("--out")
        .arg(out_dir("err"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("tip.mas_kg") && err.contains("did you mean `tip.mass_kg`"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn the_expected_weighting_ranks_designs_by_the_mean_power_over_sampled_starts() {
    use pendulum_atlas_design::harvest::{TOP_POWER_SHARE, Weighting};
    let spec = tiny_spec(&[
        "search.band={start_hz=6.0,end_hz=14.0,count=3,base_acceleration_m_s2=2.0}",
        "search.variables=[{key=\"limiter.clearance_deg\",values=[8.0,12.0,16.0]}]",
        "search.baseline.zoom_count=0",
        "search.objective=power",
        "search.weighting=expected",
        "search.basin_starts=6",
    ]);
    assert_eq!(spec.weighting, Weighting::Expected { starts: 6, seed: 0 });
    // Six sampled starts, the angle a share of each design's clearance.
    assert_eq!(spec.initial_states.len(), 6);
    assert!(
        spec.initial_states
            .iter()
            .all(|s| s.well.is_some_and(|w| w.abs() < 1.0))
    );
    let run = run_search(&spec, &Engine::cpu(Precision::F64), &|_, _, _| {}).expect("search");
    for d in &run.designs {
        assert_eq!(d.power_w.len(), 6);
        for j in 0..3 {
            let mean = d.power_w.iter().map(|s| s[j]).sum::<f64>() / 6.0;
            close(
                d.mean_w[j],
                mean,
                1e-12,
                "the expected power is the starts' mean",
            );
            // The high-power attractor: the starts near the strongest one, counted among all.
            let t = d.top_attractor[j];
            let best = d
                .power_w
                .iter()
                .map(|s| s[j])
                .fold(f64::NEG_INFINITY, f64::max);
            let near = d
                .power_w
                .iter()
                .zip(&d.period)
                .filter(|(p, q)| {
                    best - p[j] <= TOP_POWER_SHARE * best && q[j].to_bits() == t.period.to_bits()
                })
                .count();
            close(t.basin_fraction, near as f64 / 6.0, 1e-12, "basin fraction");
            assert!(t.power_w <= best && t.power_w >= (1.0 - TOP_POWER_SHARE) * best);
        }
    }
    // Ranked by the mean curve's band-averaged power (the objective), not the worst start's.
    let ranked: Vec<f64> = run
        .ranking
        .iter()
        .map(|&i| run.designs[i].mean.band_average_w)
        .collect();
    assert!(ranked.windows(2).all(|w| w[0] >= w[1]), "{ranked:?}");
    // The weighting takes no named states, and its keys are not read without it.
    let e = search_error(&["search.weighting=expected", "search.initial=[{well=1.0}]"]);
    assert!(e.contains("search.initial") && e.contains("robust"), "{e}");
    let e = search_error(&["search.basin_starts=8"]);
    assert!(e.contains("only read with search.weighting"), "{e}");
    let e = search_error(&["search.weighting=expected", "search.basin_starts=1"]);
    assert!(e.contains("search.basin_starts"), "{e}");
}

#[test]
fn search_says_which_weighting_ranked_its_designs() {
    let out = out_dir("expected");
    let o = bin()
        .args(["search", "--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args([
            "--set",
            "integration.duration_s=8.0",
            "--set",
            "integration.transient_s=5.0",
            "--set",
            "search.refine.rounds=0",
            "--set",
            "search.verify=false",
            "--set",
            "search.variables=[{key=\"limiter.clearance_deg\",values=[10.0]}]",
            "--set",
            "search.band={start_hz=6.0,end_hz=14.0,count=3,base_acceleration_m_s2=2.0}",
            "--set",
            "search.baseline.zoom_count=0",
            "--set",
            "search.weighting=expected",
            "--set",
            "search.basin_starts=4",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("ranked by expected: the mean power over 4 sampled starts")
            && stdout.contains("high-power attractor")
            && stdout.contains("expected band-averaged power"),
        "{stdout}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("search.json")).unwrap()).unwrap();
    assert_eq!(json["ranked_by"]["weighting"]["kind"], "expected");
    assert_eq!(json["best"]["top_attractor"].as_array().unwrap().len(), 3);
}

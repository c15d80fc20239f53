//! `reproduce`: the paper's cases are the paper's numbers, and `reproduce --quick` writes every
//! promised file (tables, report, valid PNGs) end to end.

use pendulum_atlas_core::analysis::amplitude_spectrum;
use pendulum_atlas_core::config::ExcitationKind;
use pendulum_atlas_studies::reproduce::{
    CaseKind, QUICK_DURATION_S, QUICK_SEGMENTS, QUICK_TRANSIENT_S, line_prominence, paper_cases,
};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pendulum-atlas"))
}

fn out_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pendulum-atlas-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Every file `reproduce` promises, named after the paper's figures.
const EXPECTED: [&str; 32] = [
    "table2.csv",
    "earlier_reading.csv",
    "table2.md",
    "experiments.csv",
    "summary.json",
    "REPORT.md",
    "fig3a_f10_A9.png",
    "fig3b_f10_A12.png",
    "fig4a_f8_A9.png",
    "fig4b_f8_A12.png",
    "fig5a_f5_A9.png",
    "fig5b_f5_A12.png",
    "fig6a_f5_A9.png",
    "fig6b_f5_A12.png",
    "fig6c_f8_A9.png",
    "fig6d_f10_A9.png",
    "fig7a_f5_A9.png",
    "fig7b_f5_A12.png",
    "fig7c_f8_A9.png",
    "fig7d_f10_A9.png",
    "fig9a_sweep_4_8Hz_A9.png",
    "fig9b_base_sweep_4_8Hz_A9.png",
    "fig9b_angle_sweep_4_8Hz_A9.png",
    "fig10a_f8_A9.png",
    "fig10b_f10_A12.png",
    "fig10c_f5_A25.png",
    "fig11a_f8_A9.png",
    "fig11b_f10_A12.png",
    "fig11c_f5_A25.png",
    "fig12a_f8_A9.png",
    "fig12b_f10_A12.png",
    "fig12c_f5_A25.png",
];

fn read_csv(path: &Path) -> Vec<HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            header
                .iter()
                .cloned()
                .zip(rec.unwrap().iter().map(String::from))
                .collect()
        })
        .collect()
}

fn number(row: &HashMap<String, String>, key: &str) -> f64 {
    row.get(key)
        .unwrap_or_else(|| panic!("column {key} missing"))
        .parse()
        .unwrap_or_else(|e| panic!("column {key} = {:?}: {e}", row[key]))
}

#[test]
fn quick_reproduction_writes_every_file_with_finite_numbers() {
    let out = out_dir("reproduce");
    let o = bin()
        .args(["reproduce", "--quick", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "reproduce --quick failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    for name in EXPECTED {
        let p = out.join(name);
        assert!(p.is_file(), "{name} was not written");
        assert!(
            std::fs::metadata(&p).unwrap().len() > 100,
            "{name} is empty"
        );
    }

    let rows = read_csv(&out.join("table2.csv"));
    assert_eq!(rows.len(), 6, "Table 2 has six cases");
    let mut cases: Vec<(f64, f64)> = Vec::new();
    for r in &rows {
        for key in [
            "k_extrema",
            "k_extrema_eq10",
            "k_strobe",
            "r_paper_convention",
            "r_standard",
            "k_paper",
            "r_paper",
        ] {
            let v = number(r, key);
            assert!(v.is_finite(), "{} {key} = {v}", r["case"]);
        }
        for key in ["k_extrema", "k_strobe"] {
            let k = number(r, key);
            assert!((-1.0..=1.0).contains(&k), "{} {key} = {k}", r["case"]);
        }
        let rp = number(r, "r_paper_convention");
        assert!(
            (0.0..=1.0).contains(&rp),
            "{} R = {rp} outside [0, 1]",
            r["case"]
        );
        assert_eq!(number(r, "segments"), QUICK_SEGMENTS as f64);
        assert!(number(r, "n_extrema") >= 20.0);
        cases.push((number(r, "amplitude_mm"), number(r, "frequency_hz")));
    }
    cases.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(
        cases,
        [
            (9.0, 5.0),
            (9.0, 8.0),
            (9.0, 10.0),
            (12.0, 5.0),
            (12.0, 8.0),
            (12.0, 10.0)
        ]
    );
    assert_eq!(read_csv(&out.join("experiments.csv")).len(), 3);

    let md = std::fs::read_to_string(out.join("table2.md")).unwrap();
    let data_rows = md
        .lines()
        .filter(|l| l.starts_with("| 9 |") || l.starts_with("| 12 |"))
        .count();
    assert_eq!(data_rows, 6, "table2.md:\n{md}");

    // The report's headline count is the count in the table, not a fixed sentence.
    let agree = rows
        .iter()
        .filter(|r| r["regime_extrema"] == r["regime_paper"])
        .count();
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(
        report.contains(&format!(
            "in **{agree} of 6** cases with K on the local extrema"
        )),
        "REPORT.md does not state the computed agreement {agree}/6"
    );
    assert!(report.contains("Quick mode"));
    assert!(!report.contains("NaN"), "REPORT.md prints a NaN");
    for name in EXPECTED.iter().filter(|n| n.ends_with(".png")) {
        assert!(report.contains(name), "REPORT.md does not link {name}");
    }

    // The earlier reading of the damping, run again for every stationary case: its own numbers
    // (a different damping gives a different motion), counted in the report from its rows.
    let earlier = read_csv(&out.join("earlier_reading.csv"));
    assert_eq!(earlier.len(), 9, "6 Table 2 cases and 3 experiments");
    assert!(
        earlier
            .iter()
            .zip(&rows)
            .any(|(e, l)| number(e, "k_strobe") != number(l, "k_strobe")),
        "the earlier reading gave the library reading's numbers"
    );
    let agree_earlier = earlier[..6]
        .iter()
        .filter(|r| r["regime_extrema"] == r["regime_paper"])
        .count();
    assert!(
        report.contains(&format!(
            "**{agree} of 6** with the library reading, **{agree_earlier} of 6** with the earlier one"
        )),
        "REPORT.md does not count both readings ({agree}, {agree_earlier})"
    );

    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["quick"], true);
    assert_eq!(summary["earlier_reading"].as_array().unwrap().len(), 9);
    assert_eq!(summary["sweep_windows"].as_array().unwrap().len(), 4);
    check_basins(&summary, &rows, &report);

    for name in EXPECTED.iter().filter(|n| n.ends_with(".png")) {
        let img =
            image::open(out.join(name)).unwrap_or_else(|e| panic!("{name} does not decode: {e}"));
        let (w, h) = (img.width(), img.height());
        assert!(
            (800..=2000).contains(&w) && (600..=2000).contains(&h),
            "{name} is {w}×{h}"
        );
        // A picture, not a blank canvas: a fair share of non-white pixels.
        let rgb = img.to_rgb8();
        let inked = rgb.pixels().filter(|p| p.0 != [255, 255, 255]).count();
        assert!(
            inked * 100 > (w * h) as usize,
            "{name} has only {inked} non-white pixels"
        );
    }
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn reproduce_into_a_file_is_a_clear_error() {
    let dir = out_dir("reproduce-file");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("not-a-folder");
    std::fs::write(&file, "x").unwrap();
    let o = bin()
        .args(["reproduce", "--quick", "--out"])
        .arg(&file)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("is a file"), "stderr: {err}");
    assert!(!err.contains("panicked"), "stderr: {err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_paper_case_is_the_scene_the_paper_describes() {
    let cases = paper_cases();
    assert_eq!(cases.len(), 10);
    let count = |k| cases.iter().filter(|c| c.kind == k).count();
    assert_eq!(count(CaseKind::Table2), 6);
    assert_eq!(count(CaseKind::Experiment), 3);
    assert_eq!(count(CaseKind::Sweep), 1);
    for c in &cases {
        let s = c.scene(false, &[]).unwrap();
        assert_eq!(s.beam.segments, 17, "{}", c.id);
        assert_eq!(s.limiter.clearance_deg, 20.0, "{}", c.id);
        assert!(
            s.initial.angle_deg > 0.0,
            "{} starts in the positive well",
            c.id
        );
        assert!(
            (s.excitation.amplitude_m * 1e3 - c.amplitude_mm).abs() < 1e-9,
            "{}",
            c.id
        );
        assert!(
            std::path::Path::new(c.scene_path).is_file(),
            "{} missing",
            c.scene_path
        );
        match (s.excitation.kind, c.kind) {
            (
                ExcitationKind::Harmonic { frequency_hz },
                CaseKind::Table2 | CaseKind::Experiment,
            ) => {
                assert_eq!(Some(frequency_hz), c.frequency_hz, "{}", c.id);
                assert_eq!(s.integration.duration_s, 30.0, "{}", c.id);
            }
            (
                ExcitationKind::Sweep {
                    start_hz, end_hz, ..
                },
                CaseKind::Sweep,
            ) => assert_eq!((start_hz, end_hz), (4.0, 8.0)),
            (k, kind) => panic!("{}: excitation {k:?} for a {kind:?} case", c.id),
        }
        if c.kind == CaseKind::Table2 {
            assert!(c.published_k.is_some() && c.published_r.is_some());
        }
        let q = c.scene(true, &[]).unwrap();
        assert_eq!(q.beam.segments, QUICK_SEGMENTS);
        assert_eq!(q.integration.duration_s, QUICK_DURATION_S);
        if let ExcitationKind::Sweep { duration_s, .. } = q.excitation.kind {
            assert_eq!(
                duration_s, QUICK_DURATION_S,
                "the quick sweep covers 4 → 8 Hz"
            );
        }
    }
    // Table 2 as printed in the paper.
    let published: Vec<(f64, f64, f64, f64)> = cases
        .iter()
        .filter(|c| c.kind == CaseKind::Table2)
        .map(|c| {
            (
                c.amplitude_mm,
                c.frequency_hz.unwrap(),
                c.published_k.unwrap(),
                c.published_r.unwrap(),
            )
        })
        .collect();
    assert_eq!(
        published,
        [
            (9.0, 5.0, 0.67, 0.74),
            (9.0, 8.0, 0.70, 0.64),
            (9.0, 10.0, 0.60, 0.64),
            (12.0, 5.0, 0.13, 0.88),
            (12.0, 8.0, 0.59, 0.66),
            (12.0, 10.0, 0.00, 0.66),
        ]
    );
}

#[test]
fn a_bad_override_names_the_case() {
    let c = &paper_cases()[0];
    let e = c
        .scene(false, &["beam.segments=0".to_string()])
        .unwrap_err()
        .to_string();
    assert!(e.contains(c.id) && e.contains("beam.segments"), "{e}");
}

#[test]
fn line_prominence_tells_a_line_from_a_band() {
    let rate = 200.0;
    let n = 4000;
    let t = |i: usize| i as f64 / rate;
    let sine: Vec<f64> = (0..n)
        .map(|i| (std::f64::consts::TAU * 2.7 * t(i)).sin())
        .collect();
    let spec = amplitude_spectrum(&sine, rate).unwrap();
    assert!(line_prominence(&spec, 2.7) > 100.0);
    // A deterministic broadband signal: a logistic-map sequence at r = 4.
    let mut x = 0.3f64;
    let noise: Vec<f64> = (0..n)
        .map(|_| {
            x = 4.0 * x * (1.0 - x);
            x
        })
        .collect();
    let spec = amplitude_spectrum(&noise, rate).unwrap();
    let p = line_prominence(&spec, 2.7);
    assert!(p > 0.2 && p < 5.0, "broadband prominence {p}");
    assert!(line_prominence(&spec, 0.0).is_nan());
}

/// The basins of the Table 2 cases in `summary.json`: 16 starts each, shares that add up with
/// the failed ones to 1, the paper's class from Table 2's K, each case's sentence and the count
/// in `REPORT.md`; and one case's shares equal those of `pendulum-atlas map` run by hand on
/// the same scene with `map.initial_states = 16` (the attractor stage, not a copy of it).
fn check_basins(summary: &serde_json::Value, table2: &[HashMap<String, String>], report: &str) {
    let basins = summary["basins"]
        .as_array()
        .expect("basins in summary.json");
    assert_eq!(basins.len(), 6);
    let mut reached = 0;
    for b in basins {
        let (f, a) = (b["frequency_hz"].as_f64(), b["amplitude_mm"].as_f64());
        let row = table2
            .iter()
            .find(|r| Some(number(r, "frequency_hz")) == f && Some(number(r, "amplitude_mm")) == a)
            .unwrap_or_else(|| panic!("no Table 2 row for {}", b["id"]));
        assert_eq!(b["starts"], 16);
        let shares: Vec<f64> = b["attractors"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a["fraction"].as_f64().unwrap())
            .collect();
        assert!(
            shares.windows(2).all(|w| w[0] >= w[1]),
            "most starts first: {shares:?}"
        );
        let total = shares.iter().sum::<f64>() + b["failed_fraction"].as_f64().unwrap();
        assert!(
            (total - 1.0).abs() < 1e-12,
            "{}: shares add to {total}",
            b["id"]
        );
        assert_eq!(
            b["paper_chaotic"].as_bool(),
            Some(number(row, "k_paper") >= 0.5),
            "{}",
            b["id"]
        );
        let has_class = b["attractors"]
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["paper_class"] == true);
        reached += usize::from(has_class);
        let head = format!(
            "- {} Hz/{} mm: ",
            b["frequency_hz"].as_f64().unwrap(),
            b["amplitude_mm"].as_f64().unwrap()
        );
        assert!(report.contains(&head), "REPORT.md lacks {head:?}");
    }
    assert!(
        report.contains(&format!("was reached in {reached} of 6 cases")),
        "REPORT.md does not count the cases whose class was reached ({reached})"
    );

    let case = &basins[0];
    let id = case["id"].as_str().unwrap();
    let out = out_dir("basins-by-hand");
    let f = case["frequency_hz"].as_f64().unwrap();
    let o = bin()
        .arg("map")
        .arg(format!("configs/paper/{id}.toml"))
        .args(["--backend", "cpu", "--quiet", "--out"])
        .arg(&out)
        .args(["--set", &format!("beam.segments={QUICK_SEGMENTS}")])
        .args([
            "--set",
            &format!("integration.duration_s={QUICK_DURATION_S:?}"),
        ])
        .args([
            "--set",
            &format!("integration.transient_s={QUICK_TRANSIENT_S:?}"),
        ])
        .args(["--set", "map.initial_states=16"])
        .args([
            "--set",
            r#"map.metrics=["K", "period", "alpha_range", "hops", "regime"]"#,
        ])
        .args([
            "--set",
            &format!(r#"map.axes=[{{key="excitation.frequency_hz",values=[{f:?}]}}]"#),
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, by_hand): (Vec<usize>, Vec<f64>) =
        pendulum_atlas_map::output::npy::read_npy(&out.join("basin_fraction.npy")).unwrap();
    let mut by_hand: Vec<f64> = by_hand.into_iter().filter(|&x| x > 0.0).collect();
    by_hand.sort_by(|a, b| b.total_cmp(a));
    let ours: Vec<f64> = case["attractors"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["fraction"].as_f64().unwrap())
        .collect();
    assert_eq!(ours, by_hand, "{id}: reproduce's shares against the map's");
    let _ = std::fs::remove_dir_all(&out);
}

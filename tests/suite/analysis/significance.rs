//! The red-noise background and the wavelet's mother against independent numbers:
//! pycwt's `ar1`, scipy's `chi2.ppf`, TC98 eq. 23 evaluated with numpy, and pycwt's `cwt` with
//! a Morlet wavelet of `ω0 = 10` (tests/fixtures/make_lag1_fixture.py).

use pendulum_atlas_core::analysis::{
    AnalysisError, DEFAULT_CONFIDENCE, Lag1Estimator, MotherWavelet, WaveletOptions,
    chi2_2dof_quantile, chi2_quantile, estimate_lag1, global_significance_ar1, lag1_allen_smith,
    lag1_autocorrelation, morlet_cwt, reconstruct_variance, significance_ar1,
};

use super::common::{assert_all_close, fixture, floats};

fn series(data: &serde_json::Value, name: &str) -> Vec<f64> {
    let entry = data["lag1"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["name"] == name)
        .unwrap_or_else(|| panic!("no series {name}"));
    floats(&entry["x"])
}

#[test]
fn lag1_matches_pycwt_ar1_and_the_sample_estimate_matches_numpy() {
    let data = fixture("lag1_significance.json");
    for entry in data["lag1"].as_array().unwrap() {
        let x = floats(&entry["x"]);
        let name = entry["name"].as_str().unwrap();
        let want = entry["pycwt_ar1"].as_f64().unwrap();
        let got = lag1_allen_smith(&x).unwrap();
        eprintln!("{name}: allen-smith {got}, pycwt ar1 {want}");
        assert!((got - want).abs() < 1e-12, "{name}: {got} vs pycwt {want}");
        assert_eq!(estimate_lag1(&x, Lag1Estimator::AllenSmith).unwrap(), got);
        let sample = entry["sample"].as_f64().unwrap();
        assert!((lag1_autocorrelation(&x).unwrap() - sample).abs() < 1e-12);
        assert!((estimate_lag1(&x, Lag1Estimator::Sample).unwrap() - sample).abs() < 1e-12);
    }
}

#[test]
fn allen_smith_refuses_a_series_with_no_ar1_model() {
    // A slow ramp: its lag-1 correlation is so close to 1 that no stationary AR(1) fits.
    let ramp: Vec<f64> = (0..500).map(|k| k as f64).collect();
    let err = lag1_allen_smith(&ramp).unwrap_err();
    assert!(
        matches!(&err, AnalysisError::InvalidArgument(m) if m.contains("AR(1)")),
        "{err}"
    );
    assert!(lag1_allen_smith(&[2.0; 50]).is_err());
}

#[test]
fn chi2_quantiles_match_scipy() {
    let data = fixture("lag1_significance.json");
    for q in data["chi2_quantiles"].as_array().unwrap() {
        let (dof, p, want) = (
            q["dof"].as_f64().unwrap(),
            q["p"].as_f64().unwrap(),
            q["x"].as_f64().unwrap(),
        );
        let got = chi2_quantile(dof, p).unwrap();
        assert!(
            (got - want).abs() <= 1e-9 * want.max(1e-3),
            "chi2({dof}) at {p}: {got} vs scipy {want}"
        );
    }
    let two = chi2_quantile(2.0, DEFAULT_CONFIDENCE).unwrap();
    assert!((two - chi2_2dof_quantile(DEFAULT_CONFIDENCE).unwrap()).abs() < 1e-12);
    assert!(chi2_quantile(0.0, 0.95).is_err() && chi2_quantile(2.0, 1.0).is_err());
}

#[test]
fn global_and_local_significance_match_tc98_computed_with_numpy() {
    let data = fixture("lag1_significance.json");
    let g = &data["global"];
    let x = series(&data, g["series"].as_str().unwrap());
    let dt = g["dt"].as_f64().unwrap();
    let result = morlet_cwt(&x, dt, &WaveletOptions::default()).unwrap();
    assert_all_close(&result.scales, &floats(&g["scales"]), 1e-12, "scales");
    let a = lag1_allen_smith(&x).unwrap();
    assert!((a - g["lag1"].as_f64().unwrap()).abs() < 1e-12);
    let confidence = g["confidence"].as_f64().unwrap();
    let level = global_significance_ar1(&result, 1.0, a, confidence).unwrap();
    let want = floats(&g["level"]);
    for (j, (got, w)) in level.iter().zip(&want).enumerate() {
        assert!(
            (got - w).abs() <= 1e-9 * w,
            "global level[{j}]: {got} vs {w}"
        );
    }
    let local = significance_ar1(1.0, dt, &result.period_s, a, confidence).unwrap();
    let want = floats(&g["local_level"]);
    for (j, (got, w)) in local.iter().zip(&want).enumerate() {
        assert!(
            (got - w).abs() <= 1e-12 * w,
            "local level[{j}]: {got} vs {w}"
        );
    }
}

#[test]
fn morlet_omega0_is_honoured_as_pycwt_does() {
    let data = fixture("lag1_significance.json");
    let m = &data["morlet10"];
    let x = series(&data, m["series"].as_str().unwrap());
    let omega0 = m["omega0"].as_f64().unwrap();
    let options = WaveletOptions {
        mother: MotherWavelet::Morlet { omega0 },
        ..WaveletOptions::default()
    };
    let result = morlet_cwt(&x, m["dt"].as_f64().unwrap(), &options).unwrap();
    assert_all_close(&result.scales, &floats(&m["scales"]), 1e-12, "scales");
    assert_all_close(&result.period_s, &floats(&m["period"]), 1e-12, "periods");
    assert_all_close(&result.coi_s, &floats(&m["coi"]), 1e-12, "coi");
    let columns: Vec<usize> = floats(&m["columns"]).iter().map(|&c| c as usize).collect();
    let mut compared = 0;
    for (j, row) in m["power"].as_array().unwrap().iter().enumerate() {
        for (&col, w) in columns.iter().zip(floats(row)) {
            if result.period_s[j] > result.coi_s[col] {
                continue;
            }
            let got = result.power[j][col];
            assert!(
                (got - w).abs() <= 0.01 * w + 1e-9,
                "power[{j}][{col}]: {got} vs pycwt {w}"
            );
            compared += 1;
        }
    }
    assert!(compared > 500, "only {compared} points inside the COI");
    // C_delta is tabulated for omega0 = 6 only: reconstruction must say so, not guess.
    assert!(reconstruct_variance(&result).is_err());
    let low = WaveletOptions {
        mother: MotherWavelet::Morlet { omega0: 4.0 },
        ..WaveletOptions::default()
    };
    assert!(morlet_cwt(&x, 0.05, &low).is_err());
}

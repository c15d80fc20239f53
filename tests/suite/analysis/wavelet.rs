//! Morlet CWT against pycwt, against its own reconstruction formulas, and the COI and
//! significance formulas against hand-computed values.

use std::f64::consts::TAU;

use pendulum_atlas_core::analysis::{
    DEFAULT_CONFIDENCE, WaveletOptions, chi2_2dof_quantile, cone_of_influence,
    lag1_autocorrelation, morlet_cwt, power_averaged_inside_coi, reconstruct_signal,
    reconstruct_variance, significance_ar1,
};

use super::common::{assert_all_close, fixture, floats, white_noise};

const DT: f64 = 0.05;

fn sine(period_s: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 3.0 + 2.0 * (TAU * k as f64 * DT / period_s).sin())
        .collect()
}

/// AR(1) red noise `x_k = a x_{k−1} + e_k`, the background the significance test assumes.
fn red_noise(n: usize, a: f64, seed: u64) -> Vec<f64> {
    let e = white_noise(n, seed);
    let mut x = vec![0.0; n];
    for k in 1..n {
        x[k] = a * x[k - 1] + e[k];
    }
    x
}

#[test]
fn power_matches_pycwt_inside_the_coi() {
    let data = fixture("wavelet_pycwt.json");
    let dt = data["dt"].as_f64().unwrap();
    let result = morlet_cwt(&floats(&data["x"]), dt, &WaveletOptions::default()).unwrap();
    assert_all_close(&result.scales, &floats(&data["scales"]), 1e-12, "scales");
    assert_all_close(&result.period_s, &floats(&data["period"]), 1e-12, "periods");
    assert_all_close(&result.coi_s, &floats(&data["coi"]), 1e-12, "coi");
    let columns: Vec<usize> = floats(&data["columns"])
        .iter()
        .map(|&c| c as usize)
        .collect();
    let want = data["power"].as_array().unwrap();
    let mut compared = 0;
    let mut worst = 0.0f64;
    for (j, row) in want.iter().enumerate() {
        for (&col, w) in columns.iter().zip(floats(row)) {
            if result.period_s[j] > result.coi_s[col] {
                continue;
            }
            let got = result.power[j][col];
            assert!(
                (got - w).abs() <= 0.01 * w + 1e-9,
                "power[{j}][{col}]: got {got}, pycwt {w}"
            );
            compared += 1;
            worst = worst.max((got - w).abs() / w);
        }
    }
    eprintln!("pycwt: {compared} points inside the COI, worst relative difference {worst:e}");
    assert!(compared > 2000, "only {compared} points inside the COI");
}

#[test]
fn sine_power_peaks_at_its_period() {
    for period_s in [0.8, 1.6, 3.0] {
        let result = morlet_cwt(&sine(period_s, 800), DT, &WaveletOptions::default()).unwrap();
        let averaged = power_averaged_inside_coi(&result);
        let best = (0..averaged.len())
            .filter(|&j| averaged[j].is_some())
            .max_by(|&a, &b| averaged[a].unwrap().total_cmp(&averaged[b].unwrap()))
            .unwrap();
        let octaves = (result.period_s[best] / period_s).log2().abs();
        eprintln!("sine {period_s} s: peak {} s", result.period_s[best]);
        assert!(
            octaves <= result.dj,
            "peak at {} s for {period_s} s",
            result.period_s[best]
        );
    }
}

#[test]
fn variance_is_recovered_from_power() {
    let result = morlet_cwt(&sine(1.6, 800), DT, &WaveletOptions::default()).unwrap();
    let variance = reconstruct_variance(&result).unwrap();
    eprintln!("eq. 14 variance of a sine {variance}");
    assert!((variance - 1.0).abs() < 0.05, "eq. 14 variance {variance}");
    let red = morlet_cwt(&red_noise(1024, 0.7, 9), DT, &WaveletOptions::default()).unwrap();
    let variance = reconstruct_variance(&red).unwrap();
    eprintln!("eq. 14 variance of red noise {variance}");
    assert!(
        (variance - 1.0).abs() < 0.05,
        "eq. 14 variance of red noise {variance}"
    );
}

#[test]
fn signal_is_rebuilt_from_real_coefficients() {
    let result = morlet_cwt(&sine(1.6, 800), DT, &WaveletOptions::default()).unwrap();
    let rebuilt = reconstruct_signal(&result).unwrap();
    let variance = rebuilt.iter().map(|v| v * v).sum::<f64>() / rebuilt.len() as f64;
    eprintln!("eq. 11 variance {variance}");
    assert!((variance - 1.0).abs() < 0.05, "eq. 11 variance {variance}");
}

#[test]
fn cone_of_influence_matches_hand_values() {
    // λ/√2 · δt · (N/2 − |k − (N−1)/2|) with λ = 4π/(6 + √38), δt = 0.1, N = 5.
    let want = [
        0.036_523_608_429_259_22,
        0.109_570_825_287_777_65,
        0.182_618_042_146_296_1,
        0.109_570_825_287_777_65,
        0.036_523_608_429_259_22,
    ];
    assert_all_close(&cone_of_influence(5, 0.1), &want, 1e-15, "coi");
}

#[test]
fn significance_matches_hand_values() {
    assert!((chi2_2dof_quantile(0.95).unwrap() - 5.991_464_547_107_979).abs() < 1e-12);
    let levels = significance_ar1(2.0, 0.5, &[1.0, 2.0, 4.0], 0.5, DEFAULT_CONFIDENCE).unwrap();
    let want = [
        1.997_154_849_035_993,
        3.594_878_728_264_787,
        8.277_131_219_565_046,
    ];
    assert_all_close(&levels, &want, 1e-12, "significance");
    let white = significance_ar1(1.0, 0.5, &[1.0, 3.0], 0.0, 0.99).unwrap();
    assert_all_close(
        &white,
        &[4.605_170_185_988_091; 2],
        1e-12,
        "white significance",
    );
}

#[test]
fn lag1_autocorrelation_of_an_ar1_process() {
    let a = lag1_autocorrelation(&red_noise(50_000, 0.7, 11)).unwrap();
    assert!((a - 0.7).abs() < 0.02, "a = {a}");
}

#[test]
fn explicit_scale_count_and_no_padding() {
    let options = WaveletOptions {
        j: Some(10),
        pad: false,
        ..WaveletOptions::default()
    };
    let result = morlet_cwt(&sine(1.0, 100), DT, &options).unwrap();
    assert_eq!(result.scales.len(), 11);
    assert!(result.power.iter().all(|row| row.len() == 100));
}

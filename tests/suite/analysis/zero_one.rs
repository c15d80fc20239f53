//! The 0–1 test against dynamics of known character (ANALYSIS.md reference behaviour).

use pendulum_atlas_core::analysis::{
    AnalysisError, K01Method, ZERO_ONE_COMFORTABLE_SAMPLES, ZERO_ONE_MIN_SAMPLES, ZeroOneOptions,
    pq_path, zero_one_test,
};

use super::common::{logistic, lorenz_x, white_noise};

fn k_of(series: &[f64], options: &ZeroOneOptions) -> f64 {
    zero_one_test(series, options).expect("valid series").k
}

#[test]
fn periodic_logistic_maps_give_k_near_zero() {
    for r in [3.55, 3.83] {
        let k = k_of(&logistic(r, 2000), &ZeroOneOptions::default());
        eprintln!("logistic r = {r}: K = {k}");
        assert!(k.abs() < 0.05, "r = {r}: K = {k}");
    }
}

#[test]
fn chaotic_logistic_maps_give_k_near_one() {
    for r in [3.97, 4.0] {
        let k = k_of(&logistic(r, 2000), &ZeroOneOptions::default());
        eprintln!("logistic r = {r}: K = {k}");
        assert!(k > 0.95, "r = {r}: K = {k}");
    }
}

#[test]
fn coarsely_sampled_lorenz_is_chaotic() {
    let result = zero_one_test(&lorenz_x(100, 2000), &ZeroOneOptions::default()).unwrap();
    eprintln!("Lorenz every 0.1: K = {}", result.k);
    assert!(result.k > 0.95, "K = {}", result.k);
}

#[test]
fn oversampled_lorenz_gives_small_k_and_warns() {
    let result = zero_one_test(&lorenz_x(10, 2000), &ZeroOneOptions::default()).unwrap();
    eprintln!(
        "Lorenz every 0.01: K = {}, warnings {:?}",
        result.k, result.warnings
    );
    assert!(result.k < 0.2, "K = {}", result.k);
    assert!(result.oversampled);
    assert!(
        result.warnings.iter().any(|w| w.contains("oversampled")),
        "{:?}",
        result.warnings
    );
}

#[test]
fn same_seed_same_k_other_seed_other_c() {
    let x = logistic(3.97, 2000);
    let options = ZeroOneOptions {
        seed: 42,
        ..ZeroOneOptions::default()
    };
    let a = zero_one_test(&x, &options).unwrap();
    let b = zero_one_test(&x, &options).unwrap();
    assert_eq!(a.k.to_bits(), b.k.to_bits());
    assert_eq!(a.c_values, b.c_values);
    let c = zero_one_test(
        &x,
        &ZeroOneOptions {
            seed: 43,
            ..options
        },
    )
    .unwrap();
    assert_ne!(a.c_values, c.c_values);
}

#[test]
fn regression_method_separates_regular_from_chaotic() {
    let options = ZeroOneOptions {
        method: K01Method::Regression,
        ..ZeroOneOptions::default()
    };
    let regular = k_of(&logistic(3.55, 2000), &options);
    let chaotic = k_of(&logistic(4.0, 2000), &options);
    eprintln!("regression: regular {regular}, chaotic {chaotic}");
    assert!(
        regular < 0.2 && chaotic > 0.8,
        "regular {regular}, chaotic {chaotic}"
    );
}

#[test]
fn normalisation_does_not_change_the_verdict() {
    let options = ZeroOneOptions {
        normalize: true,
        ..ZeroOneOptions::default()
    };
    assert!(k_of(&logistic(3.55, 2000), &options).abs() < 0.05);
    assert!(k_of(&logistic(4.0, 2000), &options) > 0.95);
}

#[test]
fn result_carries_one_k_c_per_c_and_n_cut() {
    let result = zero_one_test(&logistic(4.0, 2000), &ZeroOneOptions::default()).unwrap();
    assert_eq!((result.c_values.len(), result.k_c.len()), (100, 100));
    assert_eq!((result.n_samples, result.n_cut), (2000, 200));
    assert!(result.warnings.is_empty(), "{:?}", result.warnings);
}

#[test]
fn constant_series_gives_zero_with_a_warning() {
    let result = zero_one_test(&[0.3; 100], &ZeroOneOptions::default()).unwrap();
    assert_eq!(result.k, 0.0);
    assert!(result.warnings.iter().any(|w| w.contains("constant")));
}

#[test]
fn pq_path_is_the_running_sum() {
    let x = [1.0, 2.0, -1.0];
    let c = 0.7f64;
    let (p, q) = pq_path(&x, c);
    let p3 = (c).cos() + 2.0 * (2.0 * c).cos() - (3.0 * c).cos();
    let q3 = (c).sin() + 2.0 * (2.0 * c).sin() - (3.0 * c).sin();
    assert!(
        (p[0] - c.cos()).abs() < 1e-15 && (p[2] - p3).abs() < 1e-14 && (q[2] - q3).abs() < 1e-14
    );
}

/// `n` samples repeating `values` (a period-`values.len()` stroboscopic section).
fn periodic(values: &[f64], n: usize) -> Vec<f64> {
    (0..n).map(|k| values[k % values.len()]).collect()
}

#[test]
fn period_two_series_of_25_samples_is_refused() {
    // Used to give K = 0.80, "chaotic", for the most regular motion after a fixed point.
    let err = zero_one_test(&periodic(&[0.3, -0.2], 25), &ZeroOneOptions::default()).unwrap_err();
    assert_eq!(
        err,
        AnalysisError::TooFewSamples {
            method: "0-1 test",
            needed: ZERO_ONE_MIN_SAMPLES,
            got: 25
        }
    );
}

#[test]
fn minimum_length_is_the_first_with_ten_lags() {
    // n_cut = round(N/10) (half away from zero, as Matlab's round) must reach 10.
    let n_cut = |n: usize| (n as f64 / 10.0).round() as usize;
    assert_eq!(n_cut(ZERO_ONE_MIN_SAMPLES), 10);
    assert_eq!(n_cut(ZERO_ONE_MIN_SAMPLES - 1), 9);
    let series = periodic(&[0.3, -0.2], ZERO_ONE_MIN_SAMPLES);
    let result = zero_one_test(&series, &ZeroOneOptions::default()).unwrap();
    assert_eq!(result.n_cut, 10);
    assert!(
        zero_one_test(&series[1..], &ZeroOneOptions::default()).is_err(),
        "one sample fewer must be refused"
    );
}

#[test]
fn period_two_at_the_minimum_length_is_regular() {
    for seed in 0..5 {
        let options = ZeroOneOptions {
            seed,
            ..ZeroOneOptions::default()
        };
        let k = k_of(&periodic(&[0.3, -0.2], ZERO_ONE_MIN_SAMPLES), &options);
        eprintln!("period 2, N = {ZERO_ONE_MIN_SAMPLES}, seed {seed}: K = {k}");
        assert!(k < 0.5, "seed {seed}: K = {k}");
    }
}

#[test]
fn comfortable_length_classifies_periods_up_to_twelve() {
    let n = ZERO_ONE_COMFORTABLE_SAMPLES;
    let mut worst = 0.0f64;
    for p in 1..=12 {
        for seed in 0..3 {
            let values = white_noise(p, 100 + 7 * p as u64 + seed);
            let options = ZeroOneOptions {
                seed,
                ..ZeroOneOptions::default()
            };
            let k = k_of(&periodic(&values, n), &options);
            worst = worst.max(k.abs());
            assert!(k.abs() < 0.1, "period {p}, seed {seed}: K = {k}");
        }
    }
    eprintln!("N = {n}: worst |K| over periods 1-12: {worst}");
    for r in [3.97, 4.0] {
        let k = k_of(&logistic(r, n), &ZeroOneOptions::default());
        assert!(k > 0.9, "logistic r = {r}, N = {n}: K = {k}");
    }
}

#[test]
fn short_series_warns_until_the_comfortable_length() {
    let warns = |n: usize| {
        zero_one_test(&logistic(4.0, n), &ZeroOneOptions::default())
            .unwrap()
            .warnings
            .iter()
            .any(|w| w.contains(&ZERO_ONE_COMFORTABLE_SAMPLES.to_string()))
    };
    assert!(warns(ZERO_ONE_MIN_SAMPLES));
    assert!(warns(ZERO_ONE_COMFORTABLE_SAMPLES - 1));
    assert!(!warns(ZERO_ONE_COMFORTABLE_SAMPLES));
}

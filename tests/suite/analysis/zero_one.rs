//! The 0–1 test against dynamics of known character (ANALYSIS.md reference behaviour).

use pendulum_atlas::analysis::{K01Method, ZeroOneOptions, pq_path, zero_one_test};

use super::common::{logistic, lorenz_x};

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

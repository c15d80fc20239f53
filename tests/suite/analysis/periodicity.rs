//! Period detection, hop counting, RMS and range.

use pendulum_atlas_core::analysis::{detect_period, hops, range, rms};

use super::common::logistic;

#[test]
fn periods_of_logistic_orbits() {
    assert_eq!(detect_period(&logistic(3.2, 200), 16, 32, 1e-6), 2);
    assert_eq!(detect_period(&logistic(3.5, 200), 16, 32, 1e-6), 4);
    assert_eq!(detect_period(&logistic(3.83, 400), 16, 32, 1e-6), 3);
    assert_eq!(detect_period(&logistic(4.0, 400), 16, 32, 1e-6), 0);
    assert_eq!(detect_period(&[0.25; 10], 4, 5, 1e-9), 1);
}

#[test]
fn tolerance_is_relative_for_large_signals() {
    let x: Vec<f64> = (0..40)
        .map(|k| {
            if k % 2 == 0 {
                1000.0
            } else {
                1000.5 + (k % 4) as f64 * 0.01
            }
        })
        .collect();
    assert_eq!(detect_period(&x, 4, 20, 1e-4), 2);
    assert_eq!(detect_period(&x, 4, 20, 1e-6), 4);
    assert_eq!(
        detect_period(&x[..10], 4, 20, 1e-4),
        0,
        "record shorter than m"
    );
}

#[test]
fn hops_count_well_changes_with_hysteresis() {
    let alpha = [
        0.3,
        0.05,
        -0.05,
        0.02,
        0.3,
        -0.3,
        -0.01,
        -0.3,
        0.4,
        f64::NAN,
        0.4,
    ];
    assert_eq!(hops(&alpha, 0.2), 2);
    assert_eq!(hops(&alpha, 0.0), 0);
}

#[test]
fn rms_and_range_of_a_square_wave() {
    let x = [1.0, -1.0, 1.0, -1.0, 3.0, -1.0];
    assert!((rms(&x).unwrap() - (14.0f64 / 6.0).sqrt()).abs() < 1e-15);
    assert_eq!(range(&x).unwrap(), 4.0);
}

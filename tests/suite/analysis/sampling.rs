//! Stroboscopic sections, extrema and uniform-time checks.

use std::f64::consts::{FRAC_PI_2, TAU};

use pendulum_atlas::analysis::{
    AnalysisError, check_uniform_time, local_extrema, resample_uniform, stroboscopic,
    stroboscopic_uniform,
};

#[test]
fn stroboscopic_samples_a_locked_response_at_a_constant_value() {
    let (f, rate) = (8.0, 1000.0);
    let t: Vec<f64> = (0..10_001).map(|i| i as f64 / rate).collect();
    let x: Vec<f64> = t.iter().map(|&t| (TAU * f * t).sin()).collect();
    let strobe = stroboscopic(&t, &x, f, FRAC_PI_2, 2.0).unwrap();
    assert_eq!(strobe.len(), 64, "8 periods per second over 8 s");
    assert!(strobe.iter().all(|v| (v - 1.0).abs() < 1e-3), "{strobe:?}");
}

#[test]
fn stroboscopic_sees_a_period_three_subharmonic() {
    let f = 8.0;
    let x: Vec<f64> = (0..5000)
        .map(|i| (TAU * f / 3.0 * i as f64 / 1000.0 + 0.2).sin())
        .collect();
    let strobe = stroboscopic_uniform(&x, 1000.0, 0.0, f, 0.0, 1.0).unwrap();
    for k in 3..strobe.len() {
        assert!((strobe[k] - strobe[k - 3]).abs() < 1e-3);
    }
    assert!((strobe[1] - strobe[0]).abs() > 0.1);
}

#[test]
fn extrema_in_time_order_with_plateaus_once() {
    let x = [0.0, 1.0, 1.0, 0.5, -2.0, -2.0, 3.0, 3.0, 4.0, 2.0];
    assert_eq!(local_extrema(&x).unwrap(), vec![1.0, -2.0, 4.0]);
    assert!(local_extrema(&[]).unwrap().is_empty());
}

#[test]
fn uniform_time_is_accepted_and_jitter_refused() {
    let t: Vec<f64> = (0..100).map(|i| 0.5 + i as f64 * 0.01).collect();
    assert!((check_uniform_time(&t, 1e-6).unwrap() - 0.01).abs() < 1e-15);
    let mut jittered = t.clone();
    jittered[40] += 0.002;
    let err = check_uniform_time(&jittered, 1e-3).unwrap_err();
    assert!(
        matches!(err, AnalysisError::NonUniformTime { index: 40, .. }),
        "{err}"
    );
    let mut backwards = t;
    backwards[7] = backwards[6];
    let err = check_uniform_time(&backwards, 1e-3).unwrap_err();
    assert!(
        matches!(err, AnalysisError::NonIncreasingTime { index: 7, .. }),
        "{err}"
    );
}

#[test]
fn resampling_interpolates_linearly() {
    let t = [0.0, 0.3, 1.0];
    let x = [0.0, 3.0, 10.0];
    let (tu, xu) = resample_uniform(&t, &x, 4.0).unwrap();
    assert_eq!(tu, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    assert_eq!(xu, vec![0.0, 2.5, 5.0, 7.5, 10.0]);
}

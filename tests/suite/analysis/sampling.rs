//! Stroboscopic sections, extrema and uniform-time checks.

use std::f64::consts::{FRAC_PI_2, TAU};

use pendulum_atlas_core::analysis::{
    AnalysisError, GAP_MEDIAN_STEPS, STROBE_MIN_SAMPLES_PER_PERIOD, TimeGap, check_uniform_time,
    local_extrema, median_step, resample_uniform, stroboscopic, stroboscopic_uniform, time_gaps,
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

/// A 1-kHz sine record of `seconds` (plus its last stamp).
fn khz_record(seconds: f64) -> (Vec<f64>, Vec<f64>) {
    let n = (seconds * 1000.0).round() as usize + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 / 1000.0).collect();
    let x = t.iter().map(|&t| (TAU * 8.0 * t).sin()).collect();
    (t, x)
}

#[test]
fn negative_transient_is_an_error() {
    let (t, x) = khz_record(12.0);
    let err = stroboscopic(&t, &x, 8.0, 0.0, -1.0).unwrap_err();
    assert!(
        matches!(&err, AnalysisError::InvalidArgument(m) if m.contains("transient") && m.contains(">= 0")),
        "{err}"
    );
    assert!(stroboscopic(&t, &x, 8.0, 0.0, f64::NAN).is_err());
}

#[test]
fn transient_beyond_the_record_names_both_numbers() {
    let (t, x) = khz_record(12.0);
    let err = stroboscopic(&t, &x, 8.0, 0.0, 20.0).unwrap_err();
    assert_eq!(
        err,
        AnalysisError::TransientTooLong {
            transient_s: 20.0,
            record_s: 12.0,
            remaining: 0,
            needed: 2
        }
    );
    let text = err.to_string();
    assert!(text.contains("20 s") && text.contains("12 s"), "{text}");
}

#[test]
fn unresolved_forcing_is_an_error_naming_the_sample_rate() {
    let (t, x) = khz_record(12.0);
    for forcing in [600.0, 1e6] {
        let started = std::time::Instant::now();
        let err = stroboscopic(&t, &x, forcing, 0.0, 0.0).unwrap_err();
        assert!(
            started.elapsed().as_secs_f64() < 0.5,
            "refused only after work"
        );
        let max = 1000.0 / STROBE_MIN_SAMPLES_PER_PERIOD;
        assert!(
            matches!(err, AnalysisError::ForcingUnresolved { sample_rate_hz, max_forcing_hz, .. }
                if (sample_rate_hz - 1000.0).abs() < 1e-6 && (max_forcing_hz - max).abs() < 1e-6),
            "{err}"
        );
        assert!(err.to_string().contains("1000 Hz"), "{err}");
    }
    // The limit itself is accepted: ten samples per forcing period.
    let at_limit = 1000.0 / STROBE_MIN_SAMPLES_PER_PERIOD;
    let strobe = stroboscopic_uniform(&x, 1000.0, 0.0, at_limit, 0.0, 0.0).unwrap();
    assert_eq!(strobe.len(), 1201);
}

#[test]
fn median_step_and_gaps_of_a_record_with_a_pause() {
    // 1 kHz for 5 s, a 1-s pause, 1 kHz for 6 s more: the mean rate would be ~917 Hz.
    let mut t: Vec<f64> = (0..=5000).map(|i| i as f64 / 1000.0).collect();
    t.extend((0..=6000).map(|i| 6.0 + i as f64 / 1000.0));
    let mean_rate = (t.len() - 1) as f64 / (t[t.len() - 1] - t[0]);
    assert!((mean_rate - 917.0).abs() < 1.0, "{mean_rate}");
    assert!((median_step(&t).unwrap() - 1e-3).abs() < 1e-12);
    let gaps = time_gaps(&t, GAP_MEDIAN_STEPS).unwrap();
    assert_eq!(
        gaps,
        vec![TimeGap {
            index: 5001,
            start_s: 5.0,
            length_s: 1.0
        }]
    );
    // Five median steps are not yet a gap; six are.
    let mut short: Vec<f64> = (0..100).map(|i| i as f64).collect();
    short[50..].iter_mut().for_each(|v| *v += 4.0);
    assert!(time_gaps(&short, GAP_MEDIAN_STEPS).unwrap().is_empty());
    short[50..].iter_mut().for_each(|v| *v += 1.0);
    assert_eq!(time_gaps(&short, GAP_MEDIAN_STEPS).unwrap().len(), 1);
}

#[test]
fn uniform_time_errors_name_no_internal_function() {
    let err = check_uniform_time(&[0.0], 1e-3).unwrap_err();
    assert!(!err.to_string().contains("check_uniform_time"), "{err}");
    let mut t: Vec<f64> = (0..100).map(|i| i as f64 * 0.01).collect();
    t[60] += 0.003;
    let err = check_uniform_time(&t, 1e-3).unwrap_err();
    assert!(!err.to_string().contains("resample_uniform"), "{err}");
    assert!(
        matches!(err, AnalysisError::NonUniformTime { index: 60, expected_s, .. } if (expected_s - 0.01).abs() < 1e-12),
        "{err}"
    );
}

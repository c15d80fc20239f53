//! Bad input is refused with the variant, and the message, that says what was wrong.

use pendulum_atlas_core::analysis::{
    AnalysisError, PhaseConvention, WaveletOptions, ZERO_ONE_MIN_SAMPLES, ZeroOneOptions,
    amplitude_spectrum, morlet_cwt, phase_histogram, phase_sync, rms, stroboscopic, zero_one_test,
};

#[test]
fn empty_input_is_too_few_samples() {
    let err = zero_one_test(&[], &ZeroOneOptions::default()).unwrap_err();
    assert_eq!(
        err,
        AnalysisError::TooFewSamples {
            method: "0-1 test",
            needed: ZERO_ONE_MIN_SAMPLES,
            got: 0
        }
    );
    assert_eq!(
        err.to_string(),
        format!("0-1 test needs at least {ZERO_ONE_MIN_SAMPLES} samples, got 0")
    );
    assert!(matches!(
        rms(&[]),
        Err(AnalysisError::TooFewSamples { got: 0, .. })
    ));
    assert!(matches!(
        amplitude_spectrum(&[], 10.0),
        Err(AnalysisError::TooFewSamples { .. })
    ));
}

#[test]
fn short_input_is_too_few_samples() {
    let err = morlet_cwt(&[1.0, 2.0, 3.0], 0.1, &WaveletOptions::default()).unwrap_err();
    assert_eq!(
        err.to_string(),
        "wavelet transform needs at least 8 samples, got 3"
    );
    let short = vec![0.5; ZERO_ONE_MIN_SAMPLES - 1];
    let err = zero_one_test(&short, &ZeroOneOptions::default()).unwrap_err();
    assert_eq!(
        err,
        AnalysisError::TooFewSamples {
            method: "0-1 test",
            needed: ZERO_ONE_MIN_SAMPLES,
            got: ZERO_ONE_MIN_SAMPLES - 1,
        }
    );
}

#[test]
fn nan_input_is_non_finite_with_its_index() {
    let mut x: Vec<f64> = (0..200).map(|k| (k as f64).sin()).collect();
    x[17] = f64::NAN;
    let err = zero_one_test(&x, &ZeroOneOptions::default()).unwrap_err();
    assert_eq!(
        err,
        AnalysisError::NonFinite {
            what: "0-1 test series".into(),
            index: 17
        }
    );
    assert_eq!(
        err.to_string(),
        "0-1 test series has a non-finite value (NaN or infinity) at index 17; drop or repair that sample"
    );
    let y = vec![0.0; 200];
    let err = phase_sync(&y, &x, PhaseConvention::Standard).unwrap_err();
    assert!(err.to_string().contains("phase_sync x2") && err.to_string().contains("index 17"));
}

#[test]
fn mismatched_lengths_and_bad_arguments() {
    let err = stroboscopic(&[0.0, 1.0, 2.0], &[0.0, 1.0], 8.0, 0.0, 0.0).unwrap_err();
    assert_eq!(
        err.to_string(),
        "time stamps and samples: lengths differ (3 vs 2)"
    );
    let err = stroboscopic(&[0.0, 1.0], &[0.0, 1.0], -8.0, 0.0, 0.0).unwrap_err();
    assert_eq!(
        err.to_string(),
        "invalid argument: forcing_hz must be finite and > 0, got -8"
    );
    let err = stroboscopic(&[0.0, 1.0], &[0.0, 1.0], 0.05, 0.0, -1.0).unwrap_err();
    assert!(matches!(err, AnalysisError::InvalidArgument(_)), "{err}");
    let err = phase_histogram(&[0.1], 0, PhaseConvention::Paper).unwrap_err();
    assert!(matches!(err, AnalysisError::InvalidArgument(_)), "{err}");
    let err = morlet_cwt(&[2.0; 16], 0.1, &WaveletOptions::default()).unwrap_err();
    assert!(err.to_string().contains("constant"), "{err}");
}

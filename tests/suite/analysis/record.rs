//! The whole-record analysis behind `analyze` and `simulate`: what it refuses, what it leaves
//! out (and says so), and the wavelet settings and significance arrays it reports.

use std::f64::consts::TAU;

use pendulum_atlas_core::analysis::{
    AnalysisError, FLAT_SIGNAL_REL_RANGE, Lag1Choice, MotherWavelet, RECORD_MIN_SAMPLES,
    RecordOptions, Sampling, WaveletSettings, ZERO_ONE_MIN_SAMPLES, analyze_record,
    chi2_2dof_quantile,
};

use super::common::white_noise;

const RATE: f64 = 200.0;

/// A 1/3-subharmonic response to 8-Hz forcing, `seconds` long at 200 Hz, and the cart
/// position that forces it.
fn record(seconds: f64) -> (Vec<f64>, Vec<f64>) {
    let n = (seconds * RATE) as usize;
    let signal = (0..n)
        .map(|i| 0.3 * (TAU * 8.0 / 3.0 * i as f64 / RATE).sin())
        .collect();
    let cart = (0..n)
        .map(|i| 0.009 * (TAU * 8.0 * i as f64 / RATE).sin())
        .collect();
    (signal, cart)
}

fn forced(forcing_hz: f64) -> RecordOptions {
    RecordOptions {
        forcing_hz: Some(forcing_hz),
        ..RecordOptions::default()
    }
}

#[test]
fn negative_transient_is_an_error() {
    let (x, _) = record(20.0);
    let opts = RecordOptions {
        transient_s: -1.0,
        ..forced(8.0)
    };
    let err = analyze_record(&x, None, RATE, 0.0, &opts).unwrap_err();
    assert!(
        matches!(&err, AnalysisError::InvalidArgument(m) if m.contains("transient")),
        "{err}"
    );
}

#[test]
fn transient_leaving_too_little_record_names_both_numbers() {
    let (x, _) = record(12.0);
    let opts = RecordOptions {
        transient_s: 11.9375,
        ..forced(8.0)
    };
    let err = analyze_record(&x, None, RATE, 0.0, &opts).unwrap_err();
    // 2400 samples over 11.995 s; 11.9375 s · 200 Hz = 2387.5: 2388 dropped, 12 left.
    assert!(
        matches!(
            err,
            AnalysisError::TransientTooLong {
                remaining: 12,
                needed: RECORD_MIN_SAMPLES,
                ..
            }
        ),
        "{err}"
    );
    let text = err.to_string();
    assert!(
        text.contains("11.9375 s") && text.contains("11.995 s"),
        "{text}"
    );
}

#[test]
fn unresolved_forcing_is_refused_before_any_work() {
    let (x, _) = record(12.0);
    for f in [600.0, 1e6, 21.0] {
        let err = analyze_record(&x, None, RATE, 0.0, &forced(f)).unwrap_err();
        assert!(
            matches!(err, AnalysisError::ForcingUnresolved { sample_rate_hz, .. } if sample_rate_hz == RATE),
            "{f} Hz: {err}"
        );
    }
    assert!(analyze_record(&x, None, RATE, 0.0, &forced(20.0)).is_ok());
}

#[test]
fn constant_signal_is_an_error() {
    let n = 4000;
    let noise = white_noise(n, 5);
    let flat: Vec<f64> = noise.iter().map(|e| 0.3 + 1e-14 * e).collect();
    let opts = RecordOptions {
        sampling: Sampling::Extrema,
        ..RecordOptions::default()
    };
    let err = analyze_record(&flat, None, RATE, 0.0, &opts).unwrap_err();
    assert!(
        matches!(&err, AnalysisError::ConstantSignal { rel_range, .. } if *rel_range == FLAT_SIGNAL_REL_RANGE),
        "{err}"
    );
    assert!(err.to_string().contains("constant"), "{err}");
    let zeros = vec![0.0; n];
    assert!(matches!(
        analyze_record(&zeros, None, RATE, 0.0, &opts),
        Err(AnalysisError::ConstantSignal { .. })
    ));
    // A constant reference leaves R undefined.
    let (x, _) = record(20.0);
    let err = analyze_record(&x, Some(&vec![1.0; x.len()]), RATE, 0.0, &opts).unwrap_err();
    assert!(err.to_string().contains("reference"), "{err}");
    // Motion of a millionth of the offset is motion.
    let small: Vec<f64> = noise.iter().map(|e| 0.3 + 1e-7 * e).collect();
    assert!(analyze_record(&small, None, RATE, 0.0, &opts).is_ok());
}

#[test]
fn huge_values_are_an_overflow_not_a_nan() {
    let (mut x, _) = record(20.0);
    x[1000] = 1e308;
    let opts = RecordOptions {
        sampling: Sampling::Extrema,
        ..RecordOptions::default()
    };
    let err = analyze_record(&x, None, RATE, 0.0, &opts).unwrap_err();
    assert!(
        matches!(err, AnalysisError::Overflow { max_abs, .. } if max_abs == 1e308),
        "{err}"
    );
    assert!(!err.to_string().contains("alpha_lag1"), "{err}");
}

#[test]
fn without_forcing_everything_but_the_section_is_computed() {
    let (x, cart) = record(20.0);
    let opts = RecordOptions {
        sampling: Sampling::Extrema,
        ..RecordOptions::default()
    };
    let r = analyze_record(&x, Some(&cart), RATE, 0.0, &opts).unwrap();
    let zo = r.zero_one.as_ref().expect("K from the extrema");
    assert_eq!(zo.sampling, Sampling::Extrema);
    // 2.67 Hz over 20 s: two extrema per period, 106 of them.
    assert!((100..=110).contains(&zo.n_samples), "{}", zo.n_samples);
    assert!(r.phase_sync.is_some());
    assert!((r.spectrum.dominant_hz.unwrap() - 8.0 / 3.0).abs() < 0.05);
    assert_eq!(r.spectrum.ratio_to_forcing, None);
    assert_eq!(r.statistics.period, None);
    assert!(r.wavelet_significance.is_some());
    assert!(r.skipped.is_empty(), "{:?}", r.skipped);
}

#[test]
fn too_short_a_section_skips_k_and_period_with_the_reason() {
    let (x, _) = record(12.0);
    let opts = RecordOptions {
        transient_s: 11.0,
        ..forced(8.0)
    };
    let r = analyze_record(&x, None, RATE, 0.0, &opts).unwrap();
    assert!(r.zero_one.is_none());
    let why = &r.skipped["K"];
    // Forcing instants k/8 s from 11 s to the last stamp, 11.995 s: k = 88…95.
    assert!(why.contains(&ZERO_ONE_MIN_SAMPLES.to_string()), "{why}");
    assert!(why.contains("8 samples"), "{why}");
    assert_eq!(r.statistics.period, None);
    assert!(r.skipped.contains_key("period"));
    assert!(r.spectrum.dominant_hz.is_some());
}

#[test]
fn wavelet_settings_are_applied_and_reported() {
    let (x, _) = record(20.0);
    let settings = WaveletSettings {
        mother: MotherWavelet::Morlet { omega0: 8.0 },
        dj: 0.25,
        s0_s: Some(0.1),
        j: Some(20),
        lag1: Lag1Choice::Fixed(0.5),
        confidence: 0.9,
        max_rate_hz: 50.0,
    };
    let opts = RecordOptions {
        wavelet: settings,
        ..forced(8.0)
    };
    let r = analyze_record(&x, None, RATE, 0.0, &opts).unwrap();
    let w = &r.wavelet;
    assert_eq!((w.j, w.dj, w.s0_s), (20, 0.25, 0.1));
    assert_eq!((w.block_average, w.rate_hz), (4, 50.0));
    assert_eq!(
        (w.lag1, w.lag1_source, w.confidence),
        (Some(0.5), "given", 0.9)
    );
    assert_eq!(w.mother, MotherWavelet::Morlet { omega0: 8.0 });
    let lambda = 4.0 * std::f64::consts::PI / (8.0 + (2.0f64 + 64.0).sqrt());
    assert!((w.period_range_s.0 - lambda * 0.1).abs() < 1e-12);
    assert!((w.period_range_s.1 - lambda * 0.1 * 2f64.powi(5)).abs() < 1e-9);
    // The first transformed sample is the mean of samples 0..4: centred at 1.5 / 200 s.
    assert!((w.t0_s - 1.5 / RATE).abs() < 1e-15);
    assert_eq!(r.wavelet_full.scales.len(), 21);
}

#[test]
fn significance_arrays_follow_their_definition() {
    let (x, _) = record(20.0);
    let opts = RecordOptions {
        wavelet: WaveletSettings {
            lag1: Lag1Choice::Fixed(0.6),
            ..WaveletSettings::default()
        },
        ..forced(8.0)
    };
    let r = analyze_record(&x, None, RATE, 0.0, &opts).unwrap();
    let wt = &r.wavelet_full;
    let sig = r.wavelet_significance.as_ref().unwrap();
    let chi2_half = chi2_2dof_quantile(0.95).unwrap() / 2.0;
    let a = 0.6f64;
    for (j, period) in wt.period_s.iter().enumerate() {
        let red = (1.0 - a * a) / (1.0 + a * a - 2.0 * a * (TAU * wt.dt_s / period).cos());
        assert!((sig.level[j] - red * chi2_half).abs() < 1e-12 * sig.level[j]);
        let mean: f64 = wt.power[j].iter().sum::<f64>() / wt.power[j].len() as f64;
        assert!((sig.global_power[j] - mean).abs() < 1e-12 * mean);
        let k = wt.power[j].len() / 2;
        assert!((sig.ratio[j][k] - wt.power[j][k] / sig.level[j]).abs() < 1e-12);
        // Averaging many times gives more degrees of freedom: a lower level than one value's.
        assert!(sig.global_level[j] < sig.level[j]);
    }
}

#[test]
fn bad_wavelet_settings_are_refused_with_their_range() {
    let (x, _) = record(20.0);
    let with = |w: WaveletSettings| RecordOptions {
        wavelet: w,
        ..forced(8.0)
    };
    let d = WaveletSettings::default();
    let cases = [
        (WaveletSettings { dj: 0.0, ..d }, "(0, 1]"),
        (WaveletSettings { dj: 2.0, ..d }, "(0, 1]"),
        (
            WaveletSettings {
                confidence: 1.0,
                ..d
            },
            "(0, 1)",
        ),
        (
            WaveletSettings {
                lag1: Lag1Choice::Fixed(1.0),
                ..d
            },
            "(-1, 1)",
        ),
        (
            WaveletSettings {
                mother: MotherWavelet::Morlet { omega0: 3.0 },
                ..d
            },
            ">= 5",
        ),
        (
            WaveletSettings {
                s0_s: Some(1e-4),
                ..d
            },
            "s0",
        ),
        (
            WaveletSettings {
                j: Some(10_000),
                ..d
            },
            "J must lie in [0, ",
        ),
    ];
    for (w, range) in cases {
        let err = analyze_record(&x, None, RATE, 0.0, &with(w)).unwrap_err();
        assert!(err.to_string().contains(range), "{w:?}: {err}");
    }
}

//! Amplitude spectrum scaling, peak location and naming of frequency ratios.

use std::f64::consts::TAU;

use pendulum_atlas_core::analysis::{amplitude_spectrum, dominant_peak, ratio_to_forcing};

fn tone(amplitude: f64, freq_hz: f64, rate_hz: f64, duration_s: f64) -> Vec<f64> {
    let n = (rate_hz * duration_s).round() as usize;
    (0..n)
        .map(|i| 0.4 + amplitude * (TAU * freq_hz * i as f64 / rate_hz + 0.3).sin())
        .collect()
}

#[test]
fn sine_peak_has_its_amplitude_at_its_frequency() {
    let spectrum = amplitude_spectrum(&tone(0.7, 5.0, 1000.0, 10.0), 1000.0).unwrap();
    let peak = dominant_peak(&spectrum).unwrap();
    assert!(
        (peak.amplitude - 0.7).abs() < 0.007,
        "amplitude {}",
        peak.amplitude
    );
    assert!(
        (peak.frequency_hz - 5.0).abs() < 0.01,
        "frequency {}",
        peak.frequency_hz
    );
    assert!(
        spectrum.amplitude[0] < 1e-12,
        "mean not removed: {}",
        spectrum.amplitude[0]
    );
}

#[test]
fn off_bin_tone_is_located_within_a_fraction_of_a_bin() {
    // 0.1 Hz bins; 2.667 Hz falls 2/3 of the way between two of them.
    let spectrum = amplitude_spectrum(&tone(1.0, 2.667, 200.0, 10.0), 200.0).unwrap();
    let peak = dominant_peak(&spectrum).unwrap();
    assert!(
        (peak.frequency_hz - 2.667).abs() < 0.01,
        "frequency {}",
        peak.frequency_hz
    );
    assert!(
        (peak.amplitude - 1.0).abs() < 0.05,
        "amplitude {}",
        peak.amplitude
    );
}

#[test]
fn subharmonic_of_eight_hertz_is_named_one_third() {
    let spectrum = amplitude_spectrum(&tone(1.0, 2.667, 200.0, 10.0), 200.0).unwrap();
    let peak = dominant_peak(&spectrum).unwrap();
    let report = ratio_to_forcing(peak.frequency_hz, 8.0).unwrap();
    assert_eq!(report.label, "1/3");
    assert_eq!(report.fraction, Some((1, 3)));
}

#[test]
fn simple_ratios_and_incommensurate_ones() {
    let label = |f: f64| ratio_to_forcing(f, 8.0).unwrap().label;
    assert_eq!(label(2.67), "1/3");
    assert_eq!(label(16.0), "2/1");
    assert_eq!(label(8.0), "1/1");
    assert_eq!(label(3.0), "3/8");
    assert_eq!(label(8.0 * 0.155), "incommensurate");
    assert_eq!(ratio_to_forcing(1.24, 8.0).unwrap().fraction, None);
}

#[test]
fn zero_signal_has_no_dominant_peak() {
    let spectrum = amplitude_spectrum(&[2.0; 64], 10.0).unwrap();
    assert_eq!(dominant_peak(&spectrum), None);
}

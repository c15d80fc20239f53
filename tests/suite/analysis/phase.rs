//! Analytic signal against scipy, and the synchronisation index on known cases.

use std::f64::consts::{FRAC_2_PI, PI};

use pendulum_atlas_core::analysis::{
    PhaseConvention, analytic_signal, phase_histogram, phase_sync,
};

use super::common::{assert_all_close, fixture, floats, white_noise};

fn check_against_scipy(name: &str) {
    let data = fixture(name);
    let z = analytic_signal(&floats(&data["x"]));
    let re: Vec<f64> = z.iter().map(|c| c.re).collect();
    let im: Vec<f64> = z.iter().map(|c| c.im).collect();
    assert_all_close(&re, &floats(&data["re"]), 1e-10, &format!("{name} re"));
    assert_all_close(&im, &floats(&data["im"]), 1e-10, &format!("{name} im"));
}

#[test]
fn analytic_signal_matches_scipy_for_even_length() {
    check_against_scipy("hilbert_64.json");
}

#[test]
fn analytic_signal_matches_scipy_for_odd_length() {
    check_against_scipy("hilbert_63.json");
}

#[test]
fn identical_signals_are_fully_synchronised() {
    let x: Vec<f64> = (0..500)
        .map(|k| (0.05 * k as f64).sin() + 0.3 * (0.13 * k as f64).cos())
        .collect();
    for convention in [PhaseConvention::Standard, PhaseConvention::Paper] {
        let result = phase_sync(&x, &x, convention).unwrap();
        assert!(
            (result.r - 1.0).abs() < 1e-12,
            "{convention:?}: R = {}",
            result.r
        );
        assert_eq!(result.convention, convention);
    }
}

#[test]
fn independent_noise_gives_the_conventions_random_values() {
    let (a, b) = (white_noise(20_000, 1), white_noise(20_000, 2));
    let standard = phase_sync(&a, &b, PhaseConvention::Standard).unwrap();
    let paper = phase_sync(&a, &b, PhaseConvention::Paper).unwrap();
    assert!(standard.r < 0.05, "standard R = {}", standard.r);
    assert!((paper.r - FRAC_2_PI).abs() < 0.03, "paper R = {}", paper.r);
}

#[test]
fn paper_differences_lie_in_their_half_open_interval() {
    let (a, b) = (white_noise(2000, 3), white_noise(2000, 4));
    let result = phase_sync(&a, &b, PhaseConvention::Paper).unwrap();
    assert!(
        result
            .delta_phi_rad
            .iter()
            .all(|d| (-PI / 2.0..PI / 2.0).contains(d))
    );
}

#[test]
fn histogram_is_a_density_over_the_conventions_range() {
    let (a, b) = (white_noise(5000, 5), white_noise(5000, 6));
    for convention in [PhaseConvention::Standard, PhaseConvention::Paper] {
        let d = phase_sync(&a, &b, convention).unwrap().delta_phi_rad;
        let h = phase_histogram(&d, 36, convention).unwrap();
        let (lo, hi) = convention.range_rad();
        assert_eq!(h.edges_rad.len(), 37);
        assert!((h.edges_rad[0] - lo).abs() < 1e-15 && (h.edges_rad[36] - hi).abs() < 1e-12);
        let width = (hi - lo) / 36.0;
        let integral: f64 = h.density_per_rad.iter().map(|p| p * width).sum();
        assert!((integral - 1.0).abs() < 1e-12, "{convention:?}: {integral}");
    }
}

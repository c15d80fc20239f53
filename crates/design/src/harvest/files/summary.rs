//! What the search's reports say of a design, shared by `designs.csv`, `best.md` and
//! `best_design.toml`: powers and ratios for reading, a design's values in short, its mean
//! hops and periodic share, and the frequency `simulate` checks it at.

use crate::harvest::search::DesignResult;
use crate::harvest::spec::SearchSpec;
use crate::harvest::verify::Verification;

/// A power in engineering units for reports.
pub(super) fn watts(p: f64) -> String {
    if !p.is_finite() {
        return format!("{p}");
    }
    let a = p.abs();
    let (scale, unit) = if a >= 1.0 || a == 0.0 {
        (1.0, "W")
    } else if a >= 1e-3 {
        (1e3, "mW")
    } else if a >= 1e-6 {
        (1e6, "µW")
    } else {
        (1e9, "nW")
    };
    format!("{:.3} {unit}", p * scale)
}

/// `key = value, ...` with values rounded for reading (best_design.toml has them exactly).
pub(super) fn short_design(spec: &SearchSpec, values: &[f64]) -> String {
    spec.variables
        .iter()
        .zip(values)
        .map(|(v, &x)| format!("`{}` = {}", v.key, pendulum_atlas_map::render::fmt_num(x)))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A ratio `a/b` for reports ("—" when b is 0).
pub(super) fn ratio(a: f64, b: f64) -> String {
    if b > 0.0 && a.is_finite() {
        format!("{:.2}×", a / b)
    } else {
        "—".into()
    }
}

/// Mean hops per instance (after the transient) over a design's ok instances.
pub(super) fn mean_hops(d: &DesignResult) -> f64 {
    let v: Vec<f64> = d
        .hops
        .iter()
        .flatten()
        .copied()
        .filter(|h| h.is_finite())
        .collect();
    if v.is_empty() {
        f64::NAN
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// Share of a design's instances whose stroboscopic section is periodic (period ≥ 1).
pub(super) fn periodic_fraction(d: &DesignResult) -> f64 {
    let all: Vec<f64> = d.period.iter().flatten().copied().collect();
    all.iter().filter(|&&p| p >= 1.0).count() as f64 / all.len().max(1) as f64
}

/// The frequency at which the best design is checked by `simulate`, from the first initial
/// state: its robust peak if the response there is regular, otherwise the regular frequency
/// of highest power, otherwise the robust peak. Regular: a periodic stroboscopic section in
/// the search and, when the design was re-simulated, K < 0.5 there too. Irregular
/// (chaotic) responses depend on the step, so only a regular one can be expected to match a
/// re-simulation with another step closely.
pub(super) fn check_point(
    spec: &SearchSpec,
    d: &DesignResult,
    verification: Option<&Verification>,
) -> (f64, usize) {
    let freqs = &spec.band.frequencies_hz;
    let peak = freqs
        .iter()
        .position(|&x| x == d.robust.peak_frequency_hz)
        .unwrap_or(0);
    let regular = |j: usize| match verification.filter(|v| v.design_id == d.id) {
        // Points are stored states outermost: the first state's come first.
        Some(v) => v.points[j].regular(),
        None => d.period[0][j] >= 1.0,
    };
    let j = if regular(peak) {
        peak
    } else {
        (0..freqs.len())
            .filter(|&j| regular(j) && d.power_w[0][j].is_finite())
            .max_by(|&a, &b| d.power_w[0][a].total_cmp(&d.power_w[0][b]))
            .unwrap_or(peak)
    };
    (freqs[j], j)
}

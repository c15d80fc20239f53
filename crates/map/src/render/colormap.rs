//! Perceptually ordered colour maps: matplotlib's viridis (11 stops, linearly interpolated),
//! and the interpolation every stop table of [`super::palette`] shares.

use plotters::style::RGBColor;

/// Viridis sampled at 0, 0.1, …, 1 (matplotlib values).
const VIRIDIS: [(u8, u8, u8); 11] = [
    (0x44, 0x01, 0x54),
    (0x48, 0x24, 0x75),
    (0x41, 0x44, 0x87),
    (0x35, 0x5f, 0x8d),
    (0x2a, 0x78, 0x8e),
    (0x21, 0x91, 0x8c),
    (0x22, 0xa8, 0x84),
    (0x44, 0xbf, 0x70),
    (0x7a, 0xd1, 0x51),
    (0xbd, 0xdf, 0x26),
    (0xfd, 0xe7, 0x25),
];

/// Viridis colour for `t` in [0, 1] (clamped; NaN maps to the low end).
pub fn viridis(t: f64) -> RGBColor {
    lerp_stops(&VIRIDIS, t)
}

/// The colour at `t` in [0, 1] (clamped; NaN maps to the low end) of evenly spaced `stops`,
/// linearly interpolated.
pub(crate) fn lerp_stops(stops: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let s = t * (stops.len() - 1) as f64;
    let i = (s.floor() as usize).min(stops.len() - 2);
    let f = s - i as f64;
    let (a, b) = (stops[i], stops[i + 1]);
    let mix = |p: u8, q: u8| (p as f64 + f * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Blends `c` towards `other` by `alpha` (0 = `c`, 1 = `other`).
pub(crate) fn blend(c: RGBColor, other: RGBColor, alpha: f64) -> RGBColor {
    let m = |p: u8, q: u8| (p as f64 * (1.0 - alpha) + q as f64 * alpha).round() as u8;
    RGBColor(m(c.0, other.0), m(c.1, other.1), m(c.2, other.2))
}

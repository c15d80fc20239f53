//! The paper's figures, one PNG per panel group, named after the figure they stand for:
//! `fig4a_f8_A9.png` is our Fig. 4a (f = 8 Hz, A = 9 mm).

use super::cases::PaperCase;
use super::error::ReproduceError;
use super::indicators::{StationaryAnalysis, SweepAnalysis};
use super::run::Simulation;
use pendulum_atlas_core::analysis::{Spectrum, ZeroOneResult};
use pendulum_atlas_map::render::{self, Panel, Series};
use std::path::{Path, PathBuf};

/// Length of the time window of Fig. 10 (s), as the paper's experimental records.
pub const FIG10_WINDOW_S: f64 = 8.0;

/// Draw a figure at `path` (through a temporary file), the error naming the file.
fn drawn(
    path: PathBuf,
    render: impl FnOnce(&Path) -> Result<(), pendulum_atlas_map::render::RenderError>,
) -> Result<PathBuf, ReproduceError> {
    Ok(pendulum_atlas_map::output::files::draw(&path, render)?)
}

/// The bins of `spec` up to `f_max_hz`, as (frequency, amplitude) slices.
fn band(spec: &Spectrum, f_max_hz: f64) -> (&[f64], &[f64]) {
    let keep = spec
        .frequency_hz
        .iter()
        .take_while(|&&f| f <= f_max_hz)
        .count();
    (&spec.frequency_hz[..keep], &spec.amplitude[..keep])
}

fn line<'a>(x_label: &'a str, y_label: &'a str, x: &'a [f64], y: &'a [f64]) -> Panel<'a> {
    Panel {
        x_label,
        y_label,
        series: vec![Series {
            name: y_label,
            x,
            y,
        }],
        log_y: false,
    }
}

/// Figs. 3–5: cart displacement, holder angle and chord reduction over the whole run, and the
/// spectra of angle and chord after the transient (log scale, up to six times the forcing).
pub(crate) fn time_series_fig3_5(
    out: &Path,
    case: &PaperCase,
    sim: &Simulation,
    a: &StationaryAnalysis,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!("{}_{}.png", case.figure, case.file_tag()));
    let t = sim.column(|r| r.t_s);
    let x0 = sim.column(|r| r.x0_m * 1e3);
    let alpha = sim.column(|r| r.alpha_rad.to_degrees());
    let chord = sim.column(|r| r.chord_m * 1e3);
    let f_max = 6.0 * a.forcing_hz;
    let (fa, sa) = band(&a.spectrum_alpha_deg, f_max);
    let (fc, sc) = band(&a.spectrum_chord_mm, f_max);
    let title = format!(
        "{} (sim.): {}, N = {}; K = {:.2}, R = {:.2}",
        case.figure_name(),
        case.label(),
        sim.scene.beam.segments,
        a.k_extrema.k,
        a.r_paper
    );
    let spec_label = format!(
        "frequency (Hz), after {} s",
        sim.scene.integration.transient_s
    );
    let mut spec_a = line(&spec_label, "α spectrum (deg)", fa, sa);
    spec_a.log_y = true;
    let mut spec_c = line(&spec_label, "chord spectrum (mm)", fc, sc);
    spec_c.log_y = true;
    drawn(path, |p| {
        render::stacked_panels(
            p,
            &title,
            &[
                line("time (s)", "cart x0 (mm)", &t, &x0),
                line("time (s)", "holder angle α (deg)", &t, &alpha),
                line("time (s)", "chord reduction (mm)", &t, &chord),
                spec_a,
                spec_c,
            ],
        )
    })
}

/// c and K_c of a 0–1 test, sorted by c (the test draws c at random), for a line plot.
fn k_c_by_c(r: &ZeroOneResult) -> (Vec<f64>, Vec<f64>) {
    let mut pairs: Vec<(f64, f64)> = r.c_values.iter().copied().zip(r.k_c.clone()).collect();
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    pairs.into_iter().unzip()
}

/// The first and last of the sorted `c` (0 and 1 when empty): the span of a median line.
fn c_ends(c: &[f64]) -> Vec<f64> {
    vec![
        c.first().copied().unwrap_or(0.0),
        c.last().copied().unwrap_or(1.0),
    ]
}

/// Fig. 6: the local extrema of α (upper panel) and K_c against c for both estimators with
/// their medians (lower panel).
pub(crate) fn zero_one_fig6(
    out: &Path,
    case: &PaperCase,
    panel: char,
    a: &StationaryAnalysis,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!("fig6{panel}_{}.png", case.file_tag()));
    let index: Vec<f64> = (1..=a.extrema.len()).map(|i| i as f64).collect();
    let extrema_deg: Vec<f64> = a.extrema.iter().map(|v| v.to_degrees()).collect();
    let (c1, k1) = k_c_by_c(&a.k_extrema);
    let (c2, k2) = k_c_by_c(&a.k_extrema_eq10);
    let (m1x, m1y) = (c_ends(&c1), vec![a.k_extrema.k; 2]);
    let (m2x, m2y) = (c_ends(&c2), vec![a.k_extrema_eq10.k; 2]);
    let name1 = format!("K_c, correlation: median K = {:.2}", a.k_extrema.k);
    let name2 = format!(
        "K_c, eq. 10 regression: median K = {:.2}",
        a.k_extrema_eq10.k
    );
    let title = format!(
        "Fig. 6{panel} (sim.): {} extrema of α, {}{}",
        a.extrema.len(),
        case.short_label(),
        case.published_k
            .map(|k| format!(", paper K = {k:.2}"))
            .unwrap_or_default()
    );
    drawn(path, |p| {
        render::stacked_panels(
            p,
            &title,
            &[
                line(
                    "extremum number",
                    "local extrema of α (deg)",
                    &index,
                    &extrema_deg,
                ),
                Panel {
                    x_label: "c (rad)",
                    y_label: "K_c",
                    series: vec![
                        Series {
                            name: &name1,
                            x: &c1,
                            y: &k1,
                        },
                        Series {
                            name: &name2,
                            x: &c2,
                            y: &k2,
                        },
                        Series {
                            name: "median (correlation)",
                            x: &m1x,
                            y: &m1y,
                        },
                        Series {
                            name: "median (eq. 10)",
                            x: &m2x,
                            y: &m2y,
                        },
                    ],
                    log_y: false,
                },
            ],
        )
    })
}

/// Fig. 7: histogram of Δφ (cart → holder angle) in the paper's convention.
pub(crate) fn phase_fig7(
    out: &Path,
    case: &PaperCase,
    panel: char,
    a: &StationaryAnalysis,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!("fig7{panel}_{}.png", case.file_tag()));
    let title = format!(
        "Fig. 7{panel} (sim.): Δφ, {}, R = {:.2}{}",
        case.short_label(),
        a.r_paper,
        case.published_r
            .map(|r| format!(" (paper {r:.2})"))
            .unwrap_or_default()
    );
    drawn(path, |p| {
        render::histogram(
            p,
            &title,
            &a.phase_hist_paper.edges_rad,
            &a.phase_hist_paper.density_per_rad,
            "Δφ = φ(α) − φ(x0), modulo π (rad)",
            "pdf (1/rad)",
        )
    })
}

/// Fig. 9a: cart displacement, holder angle and angular velocity of the sweep.
pub(crate) fn sweep_fig9a(
    out: &Path,
    case: &PaperCase,
    sim: &Simulation,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!("fig9a_{}.png", case.file_tag()));
    let t = sim.column(|r| r.t_s);
    let x0 = sim.column(|r| r.x0_m * 1e3);
    let alpha = sim.column(|r| r.alpha_rad.to_degrees());
    let rate = sim.column(|r| r.alpha_dot_rad_s.to_degrees());
    let title = format!(
        "Fig. 9a (sim.): {}, {} s, N = {}",
        case.label(),
        sim.scene.integration.duration_s,
        sim.scene.beam.segments
    );
    drawn(path, |p| {
        render::stacked_panels(
            p,
            &title,
            &[
                line("time (s)", "displacement (mm)", &t, &x0),
                line("time (s)", "angle (deg)", &t, &alpha),
                line("time (s)", "ang. velocity (deg/s)", &t, &rate),
            ],
        )
    })
}

/// Fig. 9b: scalograms of the cart displacement (`which = "base"`) or of the angle.
pub(crate) fn sweep_fig9b(
    out: &Path,
    case: &PaperCase,
    s: &SweepAnalysis,
    base: bool,
) -> Result<PathBuf, ReproduceError> {
    let (name, wt, sig) = if base {
        ("base", &s.base, &s.base_significance)
    } else {
        ("angle", &s.angle, &s.angle_significance)
    };
    let path = out.join(format!("fig9b_{name}_{}.png", case.file_tag()));
    let title = format!(
        "Fig. 9b (sim.): wavelet power of the {}",
        if base {
            "base displacement"
        } else {
            "holder angle"
        },
    );
    drawn(path, |p| {
        render::scalogram(
            p,
            &title,
            &s.times_s,
            &wt.period_s,
            &wt.power,
            &wt.coi_s,
            Some(sig),
            "time (s)",
        )
    })
}

/// Fig. 10: the last [`FIG10_WINDOW_S`] seconds of displacement, angle and angular velocity.
pub(crate) fn experiment_fig10(
    out: &Path,
    case: &PaperCase,
    sim: &Simulation,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!("{}_{}.png", case.figure, case.file_tag()));
    let end = sim.rows.last().map_or(0.0, |r| r.t_s);
    let from = (end - FIG10_WINDOW_S).max(sim.scene.integration.transient_s.min(end));
    let win: Vec<_> = sim.rows.iter().filter(|r| r.t_s >= from).collect();
    let t: Vec<f64> = win.iter().map(|r| r.t_s - from).collect();
    let x0: Vec<f64> = win.iter().map(|r| r.x0_m * 1e3).collect();
    let alpha: Vec<f64> = win.iter().map(|r| r.alpha_rad.to_degrees()).collect();
    let rate: Vec<f64> = win.iter().map(|r| r.alpha_dot_rad_s.to_degrees()).collect();
    let title = format!(
        "{} (sim.): {}, limiter {}°, t = {:.0}–{:.0} s",
        case.figure_name(),
        case.short_label(),
        sim.scene.limiter.clearance_deg,
        from,
        end
    );
    let x_label = format!("time (s) from t = {from:.0} s");
    drawn(path, |p| {
        render::stacked_panels(
            p,
            &title,
            &[
                line(&x_label, "displacement (mm)", &t, &x0),
                line(&x_label, "angle (deg)", &t, &alpha),
                line(&x_label, "ang. velocity (deg/s)", &t, &rate),
            ],
        )
    })
}

/// Fig. 11: spectra of displacement, angle and angular velocity after the transient.
pub(crate) fn experiment_fig11(
    out: &Path,
    case: &PaperCase,
    a: &StationaryAnalysis,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!(
        "{}_{}.png",
        case.figure.replace("fig10", "fig11"),
        case.file_tag()
    ));
    let f_max = (3.0 * a.forcing_hz).max(25.0);
    let (f1, s1) = band(&a.spectrum_x0_mm, f_max);
    let (f2, s2) = band(&a.spectrum_alpha_deg, f_max);
    let (f3, s3) = band(&a.spectrum_rate_deg_s, f_max);
    let title = format!(
        "{} (sim.): spectra, {}, after {} s",
        case.figure_name().replace("Fig. 10", "Fig. 11"),
        case.short_label(),
        a.transient_s
    );
    drawn(path, |p| {
        render::stacked_panels(
            p,
            &title,
            &[
                line("frequency (Hz)", "displacement (mm)", f1, s1),
                line("frequency (Hz)", "angle (deg)", f2, s2),
                line("frequency (Hz)", "ang. velocity (deg/s)", f3, s3),
            ],
        )
    })
}

/// Fig. 12: phase portrait, holder angle against cart displacement, after the transient.
pub(crate) fn experiment_fig12(
    out: &Path,
    case: &PaperCase,
    sim: &Simulation,
    a: &StationaryAnalysis,
) -> Result<PathBuf, ReproduceError> {
    let path = out.join(format!(
        "{}_{}.png",
        case.figure.replace("fig10", "fig12"),
        case.file_tag()
    ));
    let skip = sim.transient_rows();
    let x0: Vec<f64> = sim.rows[skip..].iter().map(|r| r.x0_m * 1e3).collect();
    let alpha: Vec<f64> = sim.rows[skip..]
        .iter()
        .map(|r| r.alpha_rad.to_degrees())
        .collect();
    let title = format!(
        "{} (sim.): α vs x0, {}, R = {:.2}{}",
        case.figure_name().replace("Fig. 10", "Fig. 12"),
        case.short_label(),
        a.r_paper,
        case.published_r
            .map(|r| format!(" (exp. {r:.2})"))
            .unwrap_or_default()
    );
    drawn(path, |p| {
        render::scatter(
            p,
            &title,
            "displacement x0 (mm)",
            "angle α (deg)",
            &x0,
            &alpha,
            true,
        )
    })
}

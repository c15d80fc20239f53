//! The files of the analysis of one simulated run (`pendulum-atlas simulate`): the paper's
//! indicators of the holder angle against the cart after the transient
//! (`super::analysis::write_analysis`) and the time series figure (the paper's Figs. 3–5).

use super::OutputError;
use super::analysis::write_analysis;
use super::files::draw;
use super::trajectory::Row;
use crate::render::{self, Panel, Series};
use pendulum_atlas_core::analysis::{RecordAnalysis, amplitude_spectrum};
use pendulum_atlas_core::config::Scene;
use pendulum_atlas_core::engine::StepPlan;

/// The files of the paper's analysis of one run (holder angle against cart position, after
/// the transient): its arrays and pictures, and the time series figure.
pub fn write_run_analysis(
    scene: &Scene,
    plan: &StepPlan,
    rows: &[Row],
    r: &RecordAnalysis,
    out: &std::path::Path,
) -> Result<(), OutputError> {
    let rate = plan.row_rate_hz;
    let alpha: Vec<f64> = rows.iter().map(|r| r.alpha_rad).collect();
    let cart: Vec<f64> = rows.iter().map(|r| r.x0_m).collect();
    write_analysis(out, r, &alpha, Some(&cart), rate, 0.0)?;
    time_series_figure(scene, rate, rows, out)
}

/// The paper's Figs. 3–5 for one run: cart, holder angle and chord reduction with the spectra.
fn time_series_figure(
    scene: &Scene,
    rate: f64,
    rows: &[Row],
    out: &std::path::Path,
) -> Result<(), OutputError> {
    let t: Vec<f64> = rows.iter().map(|r| r.t_s).collect();
    let col = |f: fn(&Row) -> f64| -> Vec<f64> { rows.iter().map(f).collect() };
    let x0 = col(|r| r.x0_m * 1e3);
    let alpha = col(|r| r.alpha_rad);
    let chord = col(|r| r.chord_m * 1e3);
    let skip = ((scene.integration.transient_s * rate).ceil() as usize).min(rows.len());
    let path = out.join("time_series.png");
    let failed = |source| OutputError::Figure {
        path: path.display().to_string(),
        source,
    };
    let spec_a = amplitude_spectrum(&alpha[skip..], rate).map_err(failed)?;
    let spec_c = amplitude_spectrum(&chord[skip..], rate).map_err(failed)?;
    // Show the band of the paper's spectra: up to six times the forcing frequency.
    let f_max = 6.0 * scene.excitation.reference_frequency_hz();
    let keep = spec_a
        .frequency_hz
        .iter()
        .take_while(|&&f| f <= f_max)
        .count();
    let line = |name, x, y| Panel {
        x_label: "time (s)",
        y_label: name,
        series: vec![Series { name, x, y }],
        log_y: false,
    };
    draw(&path, |p| {
        render::stacked_panels(
            p,
            &format!(
                "f = {} Hz, A = {} mm, N = {}",
                scene.excitation.reference_frequency_hz(),
                scene.excitation.amplitude_m * 1e3,
                scene.beam.segments
            ),
            &[
                line("cart x0 (mm)", &t, &x0),
                line("holder angle α (rad)", &t, &alpha),
                line("chord reduction (mm)", &t, &chord),
                Panel {
                    x_label: "frequency (Hz)",
                    y_label: "amplitude",
                    series: vec![
                        Series {
                            name: "α (rad)",
                            x: &spec_a.frequency_hz[..keep],
                            y: &spec_a.amplitude[..keep],
                        },
                        Series {
                            name: "chord (mm)",
                            x: &spec_c.frequency_hz[..keep],
                            y: &spec_c.amplitude[..keep],
                        },
                    ],
                    log_y: true,
                },
            ],
        )
    })?;
    Ok(())
}

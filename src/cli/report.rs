//! Files of a record analysis: arrays a numpy user loads directly, and the pictures.

use pendulum_atlas::analysis::{RecordAnalysis, pq_path};
use pendulum_atlas::output::npy::write_npy_f64;
use pendulum_atlas::render::{self, Series};
use std::path::Path;

/// Write spectrum.csv, the wavelet and phase arrays (.npy) and the PNGs of an analysis.
pub fn write_analysis(
    out: &Path,
    r: &RecordAnalysis,
    signal: &[f64],
    reference: Option<&[f64]>,
    rate_hz: f64,
    start_s: f64,
) -> anyhow::Result<()> {
    let spec = &r.spectrum_full;
    let mut w = csv::Writer::from_path(out.join("spectrum.csv"))?;
    w.write_record(["frequency_hz", "amplitude"])?;
    for (f, a) in spec.frequency_hz.iter().zip(&spec.amplitude) {
        w.write_record([f.to_string(), a.to_string()])?;
    }
    w.flush()?;
    render::line_chart(
        &out.join("spectrum.png"),
        &format!(
            "Amplitude spectrum (Hann){}",
            r.spectrum
                .dominant_hz
                .map(|f| format!(": peak {f:.3} Hz{}", ratio_text(r)))
                .unwrap_or_default()
        ),
        "frequency (Hz)",
        "amplitude (signal units)",
        &[Series {
            name: "spectrum",
            x: &spec.frequency_hz,
            y: &spec.amplitude,
        }],
        false,
        true,
    )?;
    if let Some(wt) = &r.wavelet {
        let rows = wt.power.len();
        let cols = wt.power.first().map_or(0, Vec::len);
        let flat: Vec<f64> = wt.power.iter().flatten().copied().collect();
        write_npy_f64(&out.join("wavelet_power.npy"), &[rows, cols], &flat)?;
        write_npy_f64(&out.join("wavelet_period_s.npy"), &[rows], &wt.period_s)?;
        write_npy_f64(&out.join("wavelet_coi_s.npy"), &[cols], &wt.coi_s)?;
        let t0 = start_s + r.options.transient_s;
        let times: Vec<f64> = (0..cols).map(|i| t0 + i as f64 * wt.dt_s).collect();
        render::scalogram(
            &out.join("scalogram.png"),
            "Morlet wavelet power (normalised), 95 % red-noise contour, COI shaded",
            &times,
            &wt.period_s,
            &wt.power,
            &wt.coi_s,
            Some(&r.significance_ratio),
            "time (s)",
        )?;
    }
    write_npy_f64(
        &out.join("phase_diff_rad.npy"),
        &[r.phase_diff_rad.len()],
        &r.phase_diff_rad,
    )?;
    let zo = &r.zero_one_full;
    // The (p, q) path for the c whose K_c is closest to the median.
    if let Some((i, _)) = zo
        .k_c
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - zo.k).abs().total_cmp(&(b.1 - zo.k).abs()))
    {
        let (p, q) = pq_path(&r.zero_one_series, zo.c_values[i]);
        render::zero_one_figure(
            &out.join("zero_one.png"),
            &p,
            &q,
            &zo.c_values,
            &zo.k_c,
            zo.k,
        )?;
    }
    if let (Some(h), Some(ps)) = (&r.phase_hist, &r.phase_sync) {
        render::histogram(
            &out.join("phase_hist.png"),
            &format!(
                "Phase difference, R = {:.3} ({:?} convention)",
                ps.r, ps.convention
            ),
            &h.edges_rad,
            &h.density_per_rad,
            "phase difference Δφ (rad)",
            "probability density (1/rad)",
        )?;
    }
    if let Some(reference) = reference {
        let skip = ((r.options.transient_s * rate_hz).ceil() as usize).min(signal.len());
        render::scatter(
            &out.join("portrait.png"),
            "Phase portrait (after the transient)",
            "reference",
            "signal",
            &reference[skip..],
            &signal[skip..],
            true,
        )?;
    }
    Ok(())
}

fn ratio_text(r: &RecordAnalysis) -> String {
    match (&r.spectrum.ratio_label, r.spectrum.ratio_to_forcing) {
        (Some(l), Some(x)) => format!(" = {x:.3} × forcing ({l})"),
        _ => String::new(),
    }
}

//! Files of a record analysis (`pendulum-atlas analyze`, and the analysis of a single run):
//! arrays a numpy user loads directly (`.npy`, `numpy.load`), the pictures, every axis
//! labelled in the record's time unit, and `analysis.json` last.

use crate::output::OutputError;
use crate::output::files::{commit_csv, create_csv, csv_error, draw, write_json};
use crate::output::npy::write_npy_f64;
use crate::record::Record;
use crate::render::{self, Series};
use pendulum_atlas_core::analysis::TimeGap;
use pendulum_atlas_core::analysis::{RecordAnalysis, pq_path};
use serde::Serialize;
use std::path::Path;

/// Write spectrum.csv, the wavelet and phase arrays (.npy) and the PNGs of an analysis of the
/// uniform record `signal` (and `reference`) sampled at `rate_hz` from `start_s`.
pub(crate) fn write_analysis(
    out: &Path,
    r: &RecordAnalysis,
    signal: &[f64],
    reference: Option<&[f64]>,
    rate_hz: f64,
    start_s: f64,
) -> Result<(), OutputError> {
    let unit = r.options.time_unit.as_str();
    write_spectrum(out, r, unit)?;
    write_wavelet(out, r, unit)?;
    npy(
        out,
        "phase_diff_rad.npy",
        &[r.phase_diff_rad.len()],
        &r.phase_diff_rad,
    )?;
    zero_one_picture(out, r)?;
    phase_pictures(out, r, signal, reference, rate_hz, start_s)
}

/// `frequency (Hz)` for seconds, `frequency (1/ms)` for another unit.
fn frequency_label(unit: &str) -> String {
    if unit == "s" {
        "frequency (Hz)".to_string()
    } else {
        format!("frequency (1/{unit})")
    }
}

/// Writes one array as `.npy`, naming the file in any error.
fn npy(out: &Path, name: &str, shape: &[usize], data: &[f64]) -> Result<(), OutputError> {
    write_npy_f64(&out.join(name), shape, data).map(drop)
}

/// A 2-D `[rows][cols]` array as one row-major `.npy`.
fn npy_2d(out: &Path, name: &str, rows: &[Vec<f64>]) -> Result<(), OutputError> {
    let cols = rows.first().map_or(0, Vec::len);
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    npy(out, name, &[rows.len(), cols], &flat)
}

/// spectrum.csv and spectrum.png.
fn write_spectrum(out: &Path, r: &RecordAnalysis, unit: &str) -> Result<(), OutputError> {
    let spec = &r.spectrum_full;
    let path = out.join("spectrum.csv");
    let mut w = create_csv(&path)?;
    w.write_record(["frequency_hz", "amplitude"])
        .map_err(csv_error(&path))?;
    for (f, a) in spec.frequency_hz.iter().zip(&spec.amplitude) {
        w.write_record([f.to_string(), a.to_string()])
            .map_err(csv_error(&path))?;
    }
    commit_csv(w, &path)?;
    let freq_unit = if unit == "s" {
        "Hz".to_string()
    } else {
        format!("1/{unit}")
    };
    let png = out.join("spectrum.png");
    draw(&png, |p| {
        render::line_chart(
            p,
            &format!(
                "Amplitude spectrum (Hann){}",
                r.spectrum
                    .dominant_hz
                    .map(|f| format!(": peak {f:.3} {freq_unit}{}", ratio_text(r)))
                    .unwrap_or_default()
            ),
            &frequency_label(unit),
            "amplitude (signal units)",
            &[Series {
                name: "spectrum",
                x: &spec.frequency_hz,
                y: &spec.amplitude,
            }],
            false,
            true,
        )
    })
    .map(drop)
}

/// The wavelet arrays, their significance and scalogram.png.
fn write_wavelet(out: &Path, r: &RecordAnalysis, unit: &str) -> Result<(), OutputError> {
    let wt = &r.wavelet_full;
    let cols = wt.power.first().map_or(0, Vec::len);
    let times: Vec<f64> = (0..cols)
        .map(|i| r.wavelet.t0_s + i as f64 * wt.dt_s)
        .collect();
    npy_2d(out, "wavelet_power.npy", &wt.power)?;
    npy(
        out,
        "wavelet_period_s.npy",
        &[wt.period_s.len()],
        &wt.period_s,
    )?;
    npy(out, "wavelet_scale_s.npy", &[wt.scales.len()], &wt.scales)?;
    npy(out, "wavelet_time_s.npy", &[cols], &times)?;
    npy(out, "wavelet_coi_s.npy", &[cols], &wt.coi_s)?;
    if let Some(sig) = &r.wavelet_significance {
        npy(
            out,
            "wavelet_signif_level.npy",
            &[sig.level.len()],
            &sig.level,
        )?;
        npy_2d(out, "wavelet_signif_ratio.npy", &sig.ratio)?;
        npy(
            out,
            "wavelet_global_power.npy",
            &[sig.global_power.len()],
            &sig.global_power,
        )?;
        npy(
            out,
            "wavelet_global_signif.npy",
            &[sig.global_level.len()],
            &sig.global_level,
        )?;
    }
    let percent = r.wavelet.confidence * 100.0;
    let contour = match &r.wavelet_significance {
        Some(_) => format!(", {percent:.0} % red-noise contour"),
        None => ", no significance (lag-1 not estimable)".to_string(),
    };
    let png = out.join("scalogram.png");
    draw(&png, |p| {
        render::scalogram(
            p,
            &format!("Morlet wavelet power (normalised){contour}, COI shaded; period in {unit}"),
            &times,
            &wt.period_s,
            &wt.power,
            &wt.coi_s,
            r.wavelet_significance.as_ref().map(|s| s.ratio.as_slice()),
            &format!("time ({unit})"),
        )
    })
    .map(drop)
}

/// zero_one.png: the (p, q) path for the c whose K_c is closest to the median, and K_c(c).
fn zero_one_picture(out: &Path, r: &RecordAnalysis) -> Result<(), OutputError> {
    let Some(zo) = &r.zero_one_full else {
        return Ok(());
    };
    let Some((i, _)) = zo
        .k_c
        .iter()
        .enumerate()
        .min_by(|a, b| (a.1 - zo.k).abs().total_cmp(&(b.1 - zo.k).abs()))
    else {
        return Ok(());
    };
    let (p, q) = pq_path(&r.zero_one_series, zo.c_values[i]);
    let png = out.join("zero_one.png");
    draw(&png, |path| {
        render::zero_one_figure(path, &p, &q, &zo.c_values, &zo.k_c, zo.k)
    })
    .map(drop)
}

/// phase_hist.png and portrait.png, when a reference was given.
fn phase_pictures(
    out: &Path,
    r: &RecordAnalysis,
    signal: &[f64],
    reference: Option<&[f64]>,
    rate_hz: f64,
    start_s: f64,
) -> Result<(), OutputError> {
    if let (Some(h), Some(ps)) = (&r.phase_hist, &r.phase_sync) {
        let png = out.join("phase_hist.png");
        draw(&png, |p| {
            render::histogram(
                p,
                &format!(
                    "Phase difference, R = {:.3} ({:?} convention)",
                    ps.r, ps.convention
                ),
                &h.edges_rad,
                &h.density_per_rad,
                "phase difference Δφ (rad)",
                "probability density (1/rad)",
            )
        })
        .map(drop)?;
    }
    if let Some(reference) = reference {
        let skip =
            (((r.analysed_from_s - start_s) * rate_hz).round().max(0.0) as usize).min(signal.len());
        let png = out.join("portrait.png");
        draw(&png, |p| {
            render::scatter(
                p,
                "Phase portrait (after the transient)",
                "reference",
                "signal",
                &reference[skip..],
                &signal[skip..],
                true,
            )
        })
        .map(drop)?;
    }
    Ok(())
}

/// " = 0.333 × forcing (1/3)", or nothing without a forcing.
fn ratio_text(r: &RecordAnalysis) -> String {
    match (&r.spectrum.ratio_label, r.spectrum.ratio_to_forcing) {
        (Some(l), Some(x)) => format!(" = {x:.3} × forcing ({l})"),
        _ => String::new(),
    }
}

/// Where an analysed record came from (`input` of `analysis.json`).
#[derive(Debug, Clone, Serialize)]
pub struct RecordInput {
    /// The CSV file.
    pub file: String,
    /// The column analysed.
    pub signal: String,
    /// The reference column.
    pub reference: Option<String>,
    /// The time column.
    pub time: Option<String>,
    /// The time unit's name.
    pub time_unit: String,
    /// Samples per time unit of the analysed (uniform) record.
    pub sample_rate_hz: f64,
    /// Time of its first sample.
    pub start_s: f64,
    /// Its samples.
    pub samples: usize,
    /// Whether it was resampled.
    pub resampled: bool,
    /// Gaps of the time column.
    pub gaps: Vec<TimeGap>,
}

/// `analysis.json`: every number, setting and warning of the analysis, its time unit and its
/// input. Written last: its presence means the folder is complete.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct AnalysisManifest<'a> {
    /// The analysis.
    #[serde(flatten)]
    pub analysis: &'a RecordAnalysis,
    /// The name of the time unit.
    pub time_unit: &'a str,
    /// The record analysed.
    pub input: RecordInput,
}

impl AnalysisManifest<'_> {
    /// The manifest's name in its folder.
    pub const NAME: &'static str = "analysis.json";
}

/// Every file of the analysis of `record` into `out`: `write_analysis`, then
/// `analysis.json` (`AnalysisManifest`).
pub fn write_record_analysis(
    out: &Path,
    analysis: &RecordAnalysis,
    record: &Record,
    input: RecordInput,
) -> Result<(), OutputError> {
    write_analysis(
        out,
        analysis,
        &record.signal,
        record.reference.as_deref(),
        record.rate,
        record.start,
    )?;
    let manifest = AnalysisManifest {
        analysis,
        time_unit: &analysis.options.time_unit,
        input,
    };
    write_json(&out.join(AnalysisManifest::NAME), &manifest).map(drop)
}

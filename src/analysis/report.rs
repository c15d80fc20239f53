//! One record in, every indicator of the paper out: the analysis that `analyze` runs on
//! measured data and `simulate` runs on its own trajectory.

use super::{
    AnalysisError, K01Method, PhaseConvention, PhaseHistogram, Spectrum, WaveletOptions,
    WaveletResult, ZeroOneOptions, ZeroOneResult, amplitude_spectrum, detect_period, dominant_peak,
    hops, lag1_autocorrelation, local_extrema, morlet_cwt, phase_histogram, phase_sync, range,
    ratio_to_forcing, rms, significance_ar1, stroboscopic_uniform,
};
use serde::Serialize;

/// Which samples of the signal the 0–1 test sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// One sample per forcing period at a fixed phase, after the transient (needs the forcing).
    Stroboscopic,
    /// Local maxima and minima of the signal (the paper's Fig. 6).
    Extrema,
    /// Every sample of the uniform record (usually oversampled: expect a warning).
    Uniform,
}

/// Options of a record analysis (all stated in the output JSON).
#[derive(Debug, Clone, Serialize)]
pub struct RecordOptions {
    /// Forcing frequency (Hz), if known: enables stroboscopic sampling and the ratio.
    pub forcing_hz: Option<f64>,
    /// Samples for the 0–1 test.
    pub sampling: Sampling,
    /// Forcing phase of the stroboscopic samples (rad).
    pub strobe_phase_rad: f64,
    /// Leading time discarded (s).
    pub transient_s: f64,
    /// 0–1 test settings.
    pub zero_one: ZeroOneOptions,
    /// Phase-difference convention of R.
    pub phase_convention: PhaseConvention,
    /// Bins of the Δφ histogram.
    pub phase_bins: usize,
    /// Clearance θ_c (rad) for counting hops between wells, if known.
    pub clearance_rad: Option<f64>,
    /// Largest period (forcing periods) the periodicity detector tries.
    pub period_max: usize,
    /// Stroboscopic samples that must repeat for a period to count.
    pub period_window: usize,
    /// Tolerance of the periodicity detector (see `detect_period`).
    pub period_tol: f64,
    /// Largest sample rate fed to the wavelet transform (Hz); the record is block-averaged
    /// down to it (the scalogram needs periods of the forcing and slower, not kHz detail).
    pub wavelet_max_rate_hz: f64,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions {
            forcing_hz: None,
            sampling: Sampling::Stroboscopic,
            strobe_phase_rad: 0.0,
            transient_s: 0.0,
            zero_one: ZeroOneOptions::default(),
            phase_convention: PhaseConvention::Standard,
            phase_bins: 36,
            clearance_rad: None,
            period_max: 12,
            period_window: 12,
            period_tol: 1e-3,
            wavelet_max_rate_hz: 200.0,
        }
    }
}

/// The 0–1 test summary as written to JSON.
#[derive(Debug, Clone, Serialize)]
pub struct ZeroOneSummary {
    /// The median K.
    #[serde(rename = "K")]
    pub k: f64,
    /// correlation or regression.
    pub method: K01Method,
    /// Samples fed to the test.
    pub n_samples: usize,
    /// Which samples.
    pub sampling: Sampling,
    /// Oversampling and other diagnostics.
    pub warnings: Vec<String>,
}

/// Phase synchronisation summary.
#[derive(Debug, Clone, Serialize)]
pub struct PhaseSummary {
    /// R = |mean exp(iΔφ)|.
    #[serde(rename = "R")]
    pub r: f64,
    /// standard or paper.
    pub convention: PhaseConvention,
    /// Samples used.
    pub n_samples: usize,
}

/// Spectrum summary.
#[derive(Debug, Clone, Serialize)]
pub struct SpectrumSummary {
    /// Frequency of the highest peak other than DC (Hz).
    pub dominant_hz: Option<f64>,
    /// Its amplitude (signal units).
    pub dominant_amplitude: Option<f64>,
    /// dominant_hz / forcing_hz.
    pub ratio_to_forcing: Option<f64>,
    /// The nearest simple fraction ("1/3") or "incommensurate".
    pub ratio_label: Option<String>,
}

/// Per-record statistics of ANALYSIS.md.
#[derive(Debug, Clone, Serialize)]
pub struct Statistics {
    /// Period in forcing periods from the stroboscopic samples (0: none found).
    pub period: Option<usize>,
    /// Hops between wells (needs the clearance).
    pub hops: Option<usize>,
    /// Smallest value after the transient.
    pub min: f64,
    /// Largest value after the transient.
    pub max: f64,
    /// Peak-to-peak range.
    pub range: f64,
    /// RMS about zero.
    pub rms: f64,
}

/// Everything computed from one record.
#[derive(Debug, Clone, Serialize)]
pub struct RecordAnalysis {
    /// Options used.
    pub options: RecordOptions,
    /// 0–1 test.
    pub zero_one: ZeroOneSummary,
    /// Phase synchronisation (when a reference signal is given).
    pub phase_sync: Option<PhaseSummary>,
    /// Fourier spectrum summary.
    pub spectrum: SpectrumSummary,
    /// Statistics.
    pub statistics: Statistics,
    /// Sample rate of the wavelet transform (Hz).
    pub wavelet_rate_hz: f64,
    /// Lag-1 autocorrelation used for the red-noise significance.
    pub wavelet_lag1: f64,
    /// Anything the user should know.
    pub warnings: Vec<String>,
    /// Full 0–1 result (c values, K_c) for pictures.
    #[serde(skip)]
    pub zero_one_full: ZeroOneResult,
    /// The series the 0–1 test saw.
    #[serde(skip)]
    pub zero_one_series: Vec<f64>,
    /// The amplitude spectrum.
    #[serde(skip)]
    pub spectrum_full: Spectrum,
    /// Wavelet power and COI.
    #[serde(skip)]
    pub wavelet: Option<WaveletResult>,
    /// Power / 95 % red-noise level, [scale][time].
    #[serde(skip)]
    pub significance_ratio: Vec<Vec<f64>>,
    /// Δφ (rad) and its histogram.
    #[serde(skip)]
    pub phase_diff_rad: Vec<f64>,
    /// Histogram of Δφ.
    #[serde(skip)]
    pub phase_hist: Option<PhaseHistogram>,
}

/// Analyse a uniformly sampled record `signal` (and optionally a `reference`, e.g. the cart
/// position) starting at `start_s`. Fails with a clear error when the record is too short
/// for a method; softer problems become warnings.
pub fn analyze_record(
    signal: &[f64],
    reference: Option<&[f64]>,
    sample_rate_hz: f64,
    start_s: f64,
    opts: &RecordOptions,
) -> Result<RecordAnalysis, AnalysisError> {
    let mut warnings = Vec::new();
    let skip = ((opts.transient_s * sample_rate_hz).ceil() as usize).min(signal.len());
    let tail = &signal[skip..];
    if tail.len() < 16 {
        return Err(AnalysisError::TooFewSamples {
            method: "analysis after the transient",
            needed: 16,
            got: tail.len(),
        });
    }
    let series = match opts.sampling {
        Sampling::Stroboscopic => {
            let f = opts.forcing_hz.ok_or_else(|| {
                AnalysisError::InvalidArgument(
                    "stroboscopic sampling needs the forcing frequency (--forcing-hz); or choose --sampling extrema|uniform".into(),
                )
            })?;
            stroboscopic_uniform(
                signal,
                sample_rate_hz,
                start_s,
                f,
                opts.strobe_phase_rad,
                opts.transient_s,
            )?
        }
        Sampling::Extrema => local_extrema(tail)?,
        Sampling::Uniform => tail.to_vec(),
    };
    let zo = super::zero_one_test(&series, &opts.zero_one)?;
    let strobe = match opts.forcing_hz {
        Some(f) => Some(stroboscopic_uniform(
            signal,
            sample_rate_hz,
            start_s,
            f,
            opts.strobe_phase_rad,
            opts.transient_s,
        )?),
        None => None,
    };
    let period = strobe
        .as_ref()
        .map(|s| detect_period(s, opts.period_max, opts.period_window, opts.period_tol));
    let (phase, phase_diff, phase_hist) = match reference {
        Some(r) => {
            let r_tail = &r[skip.min(r.len())..];
            let ps = phase_sync(r_tail, tail, opts.phase_convention)?;
            let hist = phase_histogram(&ps.delta_phi_rad, opts.phase_bins, opts.phase_convention)?;
            (
                Some(PhaseSummary {
                    r: ps.r,
                    convention: ps.convention,
                    n_samples: tail.len(),
                }),
                ps.delta_phi_rad,
                Some(hist),
            )
        }
        None => (None, Vec::new(), None),
    };
    let spec = amplitude_spectrum(tail, sample_rate_hz)?;
    let peak = dominant_peak(&spec);
    let ratio = match (peak, opts.forcing_hz) {
        (Some(p), Some(f)) => Some(ratio_to_forcing(p.frequency_hz, f)?),
        _ => None,
    };
    let (wavelet, sig_ratio, wrate, lag1) = wavelet_of(tail, sample_rate_hz, opts, &mut warnings)?;
    let lo = tail.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = tail.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Ok(RecordAnalysis {
        options: opts.clone(),
        zero_one: ZeroOneSummary {
            k: zo.k,
            method: zo.method,
            n_samples: zo.n_samples,
            sampling: opts.sampling,
            warnings: zo.warnings.clone(),
        },
        phase_sync: phase,
        spectrum: SpectrumSummary {
            dominant_hz: peak.map(|p| p.frequency_hz),
            dominant_amplitude: peak.map(|p| p.amplitude),
            ratio_to_forcing: ratio.as_ref().map(|r| r.ratio),
            ratio_label: ratio.map(|r| r.label),
        },
        statistics: Statistics {
            period,
            hops: opts.clearance_rad.map(|c| hops(tail, c)),
            min: lo,
            max: hi,
            range: range(tail)?,
            rms: rms(tail)?,
        },
        wavelet_rate_hz: wrate,
        wavelet_lag1: lag1,
        warnings,
        zero_one_full: zo,
        zero_one_series: series,
        spectrum_full: spec,
        wavelet: Some(wavelet),
        significance_ratio: sig_ratio,
        phase_diff_rad: phase_diff,
        phase_hist,
    })
}

type WaveletParts = (WaveletResult, Vec<Vec<f64>>, f64, f64);

/// Block-average the record down to at most `wavelet_max_rate_hz`, transform the normalised
/// series, and compare its power with the AR(1) red-noise 95 % level.
fn wavelet_of(
    tail: &[f64],
    rate_hz: f64,
    opts: &RecordOptions,
    warnings: &mut Vec<String>,
) -> Result<WaveletParts, AnalysisError> {
    let factor = ((rate_hz / opts.wavelet_max_rate_hz).floor() as usize).max(1);
    let reduced: Vec<f64> = tail
        .chunks_exact(factor)
        .map(|c| c.iter().sum::<f64>() / factor as f64)
        .collect();
    let w_rate = rate_hz / factor as f64;
    if factor > 1 {
        warnings.push(format!(
            "wavelet computed on the record block-averaged by {factor} to {w_rate} Hz"
        ));
    }
    let dt = 1.0 / w_rate;
    let wt = morlet_cwt(&reduced, dt, &WaveletOptions::default())?;
    let lag1 = lag1_autocorrelation(&reduced)?.clamp(-0.999_999, 0.999_999);
    let level = significance_ar1(1.0, dt, &wt.period_s, lag1, 0.95)?;
    let ratio = wt
        .power
        .iter()
        .zip(&level)
        .map(|(row, l)| row.iter().map(|p| p / l).collect())
        .collect();
    Ok((wt, ratio, w_rate, lag1))
}

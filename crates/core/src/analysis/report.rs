//! One record in, every indicator of the paper out: the analysis that `analyze` runs on
//! measured data and `simulate` runs on its own trajectory.
//!
//! Policy: input that no indicator can use (a transient that leaves less than
//! [`RECORD_MIN_SAMPLES`], a constant or overflowing signal, a forcing the sampling cannot
//! resolve, invalid settings) is an error. An indicator that cannot be computed from otherwise
//! good input (too few samples for the 0–1 test, too short a section for the period, a series
//! with no AR(1) model for the wavelet significance) is left out, and
//! [`RecordAnalysis::skipped`] says why: the other indicators are still valid.

use crate::text::num;
use std::collections::BTreeMap;

use super::checks::{ensure_finite, ensure_positive, ensure_same_len, ensure_varying};
use super::{
    AnalysisError, K01Method, Lag1Estimator, MotherWavelet, PhaseConvention, PhaseHistogram,
    Spectrum, WAVELET_MIN_SAMPLES, WaveletOptions, WaveletResult, ZeroOneOptions, ZeroOneResult,
    amplitude_spectrum, detect_period, dominant_peak, ensure_forcing_resolved, estimate_lag1,
    global_significance_ar1, global_wavelet_spectrum, hops, local_extrema, morlet_cwt,
    phase_histogram, phase_sync, range, ratio_to_forcing, rms, significance_ar1,
    stroboscopic_uniform,
};
use serde::Serialize;

/// Fewest samples the record must keep after the transient: the spectrum then has nine bins
/// and the wavelet transform two octaves of scales, the least that says anything about
/// frequencies. The 0–1 test needs far more of its own samples
/// ([`super::ZERO_ONE_MIN_SAMPLES`]) and is left out, not refused, when they are missing.
pub const RECORD_MIN_SAMPLES: usize = 16;

/// Which samples of the signal the 0–1 test sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// One sample per forcing period at a fixed phase, after the transient (needs the forcing).
    Stroboscopic,
    /// Local maxima and minima of the signal (the paper's Fig. 6; the default without forcing).
    Extrema,
    /// Every sample of the uniform record (usually oversampled: expect a warning).
    Uniform,
}

impl Sampling {
    /// The sampling when none is asked for: stroboscopic with a known forcing frequency,
    /// else the local extrema (the paper's choice for its Fig. 6).
    pub fn default_for(forcing_hz: Option<f64>) -> Sampling {
        match forcing_hz {
            Some(_) => Sampling::Stroboscopic,
            None => Sampling::Extrema,
        }
    }

    /// The sampling named `name` (`stroboscopic`, `extrema` or `uniform`).
    pub fn from_name(name: &str) -> Option<Sampling> {
        [Sampling::Stroboscopic, Sampling::Extrema, Sampling::Uniform]
            .into_iter()
            .find(|s| s.name() == name)
    }

    /// Its name, as `analysis.json` writes it.
    pub fn name(self) -> &'static str {
        match self {
            Sampling::Stroboscopic => "stroboscopic",
            Sampling::Extrema => "extrema",
            Sampling::Uniform => "uniform",
        }
    }

    /// What the series of this sampling is called in messages.
    fn describe(self) -> &'static str {
        match self {
            Sampling::Stroboscopic => "stroboscopic section",
            Sampling::Extrema => "series of local extrema",
            Sampling::Uniform => "uniform record",
        }
    }
}

/// The lag-1 coefficient of the red-noise background: estimated from the series, or given.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Lag1Choice {
    /// Estimated from the (block-averaged) series after the transient.
    Estimate(Lag1Estimator),
    /// Given by the user, in (−1, 1).
    Fixed(f64),
}

/// Settings of the wavelet transform and its significance test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WaveletSettings {
    /// The mother wavelet (Morlet, `ω0 = 6`).
    pub mother: MotherWavelet,
    /// Scale spacing in octaves, in (0, 1].
    pub dj: f64,
    /// Smallest scale (time units); `None` gives a shortest Fourier period of two steps.
    pub s0_s: Option<f64>,
    /// Number of scales less one; `None` ends the ladder at the record's length.
    pub j: Option<usize>,
    /// Lag-1 coefficient of the AR(1) background.
    pub lag1: Lag1Choice,
    /// Confidence level of the significance arrays, in (0, 1).
    pub confidence: f64,
    /// Largest sample rate fed to the transform (per time unit); the record is block-averaged
    /// down to it (the scalogram needs periods of the forcing and slower, not kHz detail).
    pub max_rate_hz: f64,
}

impl Default for WaveletSettings {
    fn default() -> Self {
        WaveletSettings {
            mother: MotherWavelet::default(),
            dj: 1.0 / 12.0,
            s0_s: None,
            j: None,
            lag1: Lag1Choice::Estimate(Lag1Estimator::AllenSmith),
            confidence: super::DEFAULT_CONFIDENCE,
            max_rate_hz: 200.0,
        }
    }
}

/// Options of a record analysis (all stated in the output JSON).
#[derive(Debug, Clone, Serialize)]
pub struct RecordOptions {
    /// Forcing frequency (Hz), if known: enables stroboscopic sampling, the period and the ratio.
    pub forcing_hz: Option<f64>,
    /// Samples for the 0–1 test.
    pub sampling: Sampling,
    /// Forcing phase of the stroboscopic samples (rad).
    pub strobe_phase_rad: f64,
    /// Leading time discarded (s), at least 0.
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
    /// Wavelet transform and significance settings.
    pub wavelet: WaveletSettings,
    /// Name of the time unit of the record ("s" unless the data say otherwise): a label only;
    /// rates and frequencies are per this unit.
    pub time_unit: String,
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
            wavelet: WaveletSettings::default(),
            time_unit: "s".to_string(),
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

/// Per-record statistics of docs/analysis.md.
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

/// The wavelet transform as it was computed: every setting resolved to its value.
#[derive(Debug, Clone, Serialize)]
pub struct WaveletSummary {
    /// The mother wavelet.
    pub mother: MotherWavelet,
    /// Scale spacing (octaves).
    pub dj: f64,
    /// Smallest scale (time units).
    pub s0_s: f64,
    /// Number of scales less one.
    pub j: usize,
    /// Shortest and longest Fourier period (time units).
    pub period_range_s: (f64, f64),
    /// Sample rate of the transformed series (per time unit).
    pub rate_hz: f64,
    /// Record samples averaged into one transformed sample.
    pub block_average: usize,
    /// Time of the first transformed sample (the centre of its block).
    pub t0_s: f64,
    /// Transformed samples.
    pub n_samples: usize,
    /// Zero-padded to the next power of two.
    pub padded: bool,
    /// Transformed `(x − mean)/σ`, so power is in units of the variance.
    pub normalized: bool,
    /// Lag-1 coefficient of the red-noise background (absent when it could not be estimated).
    pub lag1: Option<f64>,
    /// Where it came from: "allen-smith" (pycwt's `ar1`), "sample", "sample (allen-smith has no
    /// solution)" (the fallback for series too close to a random walk) or "given".
    pub lag1_source: &'static str,
    /// Confidence level of the significance arrays.
    pub confidence: f64,
    /// Degrees of freedom of one power value.
    pub dof_min: f64,
    /// Decorrelation factor γ used for the global significance.
    pub gamma: f64,
}

/// Significance of the wavelet power against AR(1) red noise.
#[derive(Debug, Clone)]
pub struct WaveletSignificance {
    /// Power level per scale above which a value is significant.
    pub level: Vec<f64>,
    /// Power / level, `[scale][time]`: above 1 is significant.
    pub ratio: Vec<Vec<f64>>,
    /// Global (time-averaged) power per scale.
    pub global_power: Vec<f64>,
    /// Level per scale above which the global power is significant (TC98 eq. 23).
    pub global_level: Vec<f64>,
}

/// Everything computed from one record.
#[derive(Debug, Clone, Serialize)]
pub struct RecordAnalysis {
    /// Options used.
    pub options: RecordOptions,
    /// 0–1 test (absent when its series is too short: see `skipped`).
    pub zero_one: Option<ZeroOneSummary>,
    /// Phase synchronisation (when a reference signal is given).
    pub phase_sync: Option<PhaseSummary>,
    /// Fourier spectrum summary.
    pub spectrum: SpectrumSummary,
    /// Statistics.
    pub statistics: Statistics,
    /// The wavelet transform's settings and red-noise background.
    pub wavelet: WaveletSummary,
    /// Indicators left out, each with the reason.
    pub skipped: BTreeMap<&'static str, String>,
    /// Anything the user should know.
    pub warnings: Vec<String>,
    /// Time of the first sample after the transient.
    pub analysed_from_s: f64,
    /// Full 0–1 result (c values, K_c) for pictures.
    #[serde(skip)]
    pub zero_one_full: Option<ZeroOneResult>,
    /// The series the 0–1 test saw.
    #[serde(skip)]
    pub zero_one_series: Vec<f64>,
    /// The amplitude spectrum.
    #[serde(skip)]
    pub spectrum_full: Spectrum,
    /// Wavelet power and COI.
    #[serde(skip)]
    pub wavelet_full: WaveletResult,
    /// Significance arrays (absent when the lag-1 coefficient could not be estimated).
    #[serde(skip)]
    pub wavelet_significance: Option<WaveletSignificance>,
    /// Δφ (rad).
    #[serde(skip)]
    pub phase_diff_rad: Vec<f64>,
    /// Histogram of Δφ.
    #[serde(skip)]
    pub phase_hist: Option<PhaseHistogram>,
}

/// Analyse a uniformly sampled record `signal` (and optionally a `reference`, e.g. the cart
/// position) starting at `start_s`. Fails with a clear error on input no indicator can use;
/// an indicator that cannot be computed is listed in `skipped` instead.
pub fn analyze_record(
    signal: &[f64],
    reference: Option<&[f64]>,
    sample_rate_hz: f64,
    start_s: f64,
    opts: &RecordOptions,
) -> Result<RecordAnalysis, AnalysisError> {
    validate_record_input(signal, reference, sample_rate_hz, start_s, opts)?;
    let skip = transient_samples(signal.len(), sample_rate_hz, opts.transient_s)?;
    let tail = &signal[skip..];
    ensure_varying("the signal after the transient", tail)?;
    let r_tail = reference.map(|r| &r[skip..]);
    if let Some(r) = r_tail {
        ensure_varying("the reference after the transient", r)?;
    }
    let analysed_from_s = start_s + skip as f64 / sample_rate_hz;
    let mut skipped = BTreeMap::new();
    let mut warnings = Vec::new();
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
    let series = zero_one_series(tail, strobe.as_deref(), opts.sampling)?;
    let zero_one_full = zero_one_of(&series, opts, &mut skipped)?;
    let period = period_of(strobe.as_deref(), opts, &mut skipped);
    let phase = r_tail.map(|r| phase_of(r, tail, opts)).transpose()?;
    let spectrum_full = amplitude_spectrum(tail, sample_rate_hz)?;
    let spectrum = spectrum_summary(&spectrum_full, opts.forcing_hz)?;
    let wavelet = wavelet_of(tail, sample_rate_hz, analysed_from_s, &opts.wavelet)?;
    if wavelet.summary.block_average > 1 {
        warnings.push(format!(
            "wavelet computed on the record block-averaged by {} to {} samples per {}",
            wavelet.summary.block_average,
            num(wavelet.summary.rate_hz),
            opts.time_unit
        ));
    }
    if let Some(reason) = wavelet.skipped {
        skipped.insert("wavelet significance", reason);
    }
    warnings.extend(wavelet.warning);
    Ok(RecordAnalysis {
        options: opts.clone(),
        zero_one: zero_one_full.as_ref().map(|zo| ZeroOneSummary {
            k: zo.k,
            method: zo.method,
            n_samples: zo.n_samples,
            sampling: opts.sampling,
            warnings: zo.warnings.clone(),
        }),
        phase_sync: phase.as_ref().map(|p| p.0.clone()),
        spectrum,
        statistics: statistics_of(tail, period, opts)?,
        wavelet: wavelet.summary,
        skipped,
        warnings,
        analysed_from_s,
        zero_one_full,
        zero_one_series: series,
        spectrum_full,
        wavelet_full: wavelet.result,
        wavelet_significance: wavelet.significance,
        phase_hist: phase.as_ref().map(|p| p.2.clone()),
        phase_diff_rad: phase.map(|p| p.1).unwrap_or_default(),
    })
}

/// Checks the arrays, the rate and every setting before any work is done.
fn validate_record_input(
    signal: &[f64],
    reference: Option<&[f64]>,
    sample_rate_hz: f64,
    start_s: f64,
    opts: &RecordOptions,
) -> Result<(), AnalysisError> {
    ensure_finite("signal", signal)?;
    if let Some(r) = reference {
        ensure_same_len("signal and reference", signal.len(), r.len())?;
        ensure_finite("reference", r)?;
    }
    ensure_positive("sample rate", sample_rate_hz)?;
    if !start_s.is_finite() {
        return Err(AnalysisError::InvalidArgument(format!(
            "the start time must be finite, got {}",
            num(start_s)
        )));
    }
    if let Some(f) = opts.forcing_hz {
        ensure_forcing_resolved(f, sample_rate_hz)?;
    }
    if let Some(c) = opts.clearance_rad
        && !(c.is_finite() && c > 0.0 && c < std::f64::consts::FRAC_PI_2)
    {
        return Err(AnalysisError::InvalidArgument(format!(
            "the clearance must lie in the open interval (0, 90) deg, got {} deg",
            num(c.to_degrees())
        )));
    }
    validate_wavelet_settings(&opts.wavelet)
}

/// Refuses wavelet settings outside their ranges (those that depend on the record, `s0` and
/// `J`, are checked by the transform).
fn validate_wavelet_settings(w: &WaveletSettings) -> Result<(), AnalysisError> {
    w.mother.validate()?;
    if !(w.dj.is_finite() && w.dj > 0.0 && w.dj <= 1.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the wavelet scale spacing dj must lie in (0, 1] octave, got {}",
            num(w.dj)
        )));
    }
    if !(w.confidence > 0.0 && w.confidence < 1.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the confidence level must lie in (0, 1), got {}",
            num(w.confidence)
        )));
    }
    if let Lag1Choice::Fixed(a) = w.lag1
        && !(a.is_finite() && a.abs() < 1.0)
    {
        return Err(AnalysisError::InvalidArgument(format!(
            "the lag-1 autocorrelation must lie in (-1, 1), got {}",
            num(a)
        )));
    }
    ensure_positive("the wavelet's largest sample rate", w.max_rate_hz)
}

/// Samples dropped as the transient; refuses a negative transient and one that leaves fewer
/// than [`RECORD_MIN_SAMPLES`].
fn transient_samples(len: usize, rate_hz: f64, transient_s: f64) -> Result<usize, AnalysisError> {
    if !(transient_s.is_finite() && transient_s >= 0.0) {
        return Err(AnalysisError::InvalidArgument(format!(
            "the transient must be finite and >= 0 s, got {}",
            num(transient_s)
        )));
    }
    let skip = ((transient_s * rate_hz).ceil() as usize).min(len);
    if len - skip < RECORD_MIN_SAMPLES {
        return Err(AnalysisError::TransientTooLong {
            transient_s,
            record_s: len.saturating_sub(1) as f64 / rate_hz,
            remaining: len - skip,
            needed: RECORD_MIN_SAMPLES,
        });
    }
    Ok(skip)
}

/// The series the 0–1 test sees.
fn zero_one_series(
    tail: &[f64],
    strobe: Option<&[f64]>,
    sampling: Sampling,
) -> Result<Vec<f64>, AnalysisError> {
    match (sampling, strobe) {
        (Sampling::Stroboscopic, Some(s)) => Ok(s.to_vec()),
        (Sampling::Stroboscopic, None) => Err(AnalysisError::InvalidArgument(
            "stroboscopic sampling needs the forcing frequency; give it, or sample the local \
             extrema or the uniform record instead"
                .into(),
        )),
        (Sampling::Extrema, _) => local_extrema(tail),
        (Sampling::Uniform, _) => Ok(tail.to_vec()),
    }
}

/// The 0–1 test, or `None` with the reason in `skipped` when its series is too short.
fn zero_one_of(
    series: &[f64],
    opts: &RecordOptions,
    skipped: &mut BTreeMap<&'static str, String>,
) -> Result<Option<ZeroOneResult>, AnalysisError> {
    match super::zero_one_test(series, &opts.zero_one) {
        Ok(r) => Ok(Some(r)),
        Err(AnalysisError::TooFewSamples { needed, got, .. }) => {
            skipped.insert(
                "K",
                format!(
                    "the {} after the transient has {got} samples, but the 0-1 test needs at \
                     least {needed}: use a longer record or a shorter transient",
                    opts.sampling.describe()
                ),
            );
            Ok(None)
        }
        Err(e) => Err(e),
    }
}

/// Period of the stroboscopic section, or `None` (with the reason in `skipped` when a forcing
/// was given but the section is too short for the detector's window).
fn period_of(
    strobe: Option<&[f64]>,
    opts: &RecordOptions,
    skipped: &mut BTreeMap<&'static str, String>,
) -> Option<usize> {
    let s = strobe?;
    let needed = opts.period_window + 1;
    if s.len() < needed {
        skipped.insert(
            "period",
            format!(
                "the stroboscopic section after the transient has {} samples, but the period \
                 detector needs at least {needed}",
                s.len()
            ),
        );
        return None;
    }
    Some(detect_period(
        s,
        opts.period_max,
        opts.period_window,
        opts.period_tol,
    ))
}

/// R, Δφ and its histogram of `signal` against `reference`.
fn phase_of(
    reference: &[f64],
    signal: &[f64],
    opts: &RecordOptions,
) -> Result<(PhaseSummary, Vec<f64>, PhaseHistogram), AnalysisError> {
    let ps = phase_sync(reference, signal, opts.phase_convention)?;
    let hist = phase_histogram(&ps.delta_phi_rad, opts.phase_bins, opts.phase_convention)?;
    let summary = PhaseSummary {
        r: ps.r,
        convention: ps.convention,
        n_samples: signal.len(),
    };
    Ok((summary, ps.delta_phi_rad, hist))
}

/// Dominant line and its ratio to the forcing.
fn spectrum_summary(
    spec: &Spectrum,
    forcing_hz: Option<f64>,
) -> Result<SpectrumSummary, AnalysisError> {
    let peak = dominant_peak(spec);
    let ratio = match (peak, forcing_hz) {
        (Some(p), Some(f)) => Some(ratio_to_forcing(p.frequency_hz, f)?),
        _ => None,
    };
    Ok(SpectrumSummary {
        dominant_hz: peak.map(|p| p.frequency_hz),
        dominant_amplitude: peak.map(|p| p.amplitude),
        ratio_to_forcing: ratio.as_ref().map(|r| r.ratio),
        ratio_label: ratio.map(|r| r.label),
    })
}

/// Range, RMS, hops and the period.
fn statistics_of(
    tail: &[f64],
    period: Option<usize>,
    opts: &RecordOptions,
) -> Result<Statistics, AnalysisError> {
    let lo = tail.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = tail.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Ok(Statistics {
        period,
        hops: opts.clearance_rad.map(|c| hops(tail, c)),
        min: lo,
        max: hi,
        range: range(tail)?,
        rms: rms(tail)?,
    })
}

/// The wavelet part of a record analysis.
struct WaveletParts {
    summary: WaveletSummary,
    result: WaveletResult,
    significance: Option<WaveletSignificance>,
    skipped: Option<String>,
    warning: Option<String>,
}

/// Block-average the record down to at most `max_rate_hz` (keeping at least
/// [`WAVELET_MIN_SAMPLES`] samples), transform the normalised series, and compare its power
/// with the AR(1) red-noise level.
fn wavelet_of(
    tail: &[f64],
    rate_hz: f64,
    tail_start_s: f64,
    settings: &WaveletSettings,
) -> Result<WaveletParts, AnalysisError> {
    let by_rate = (rate_hz / settings.max_rate_hz).floor() as usize;
    let factor = by_rate.min(tail.len() / WAVELET_MIN_SAMPLES).max(1);
    let reduced: Vec<f64> = tail
        .chunks_exact(factor)
        .map(|c| c.iter().sum::<f64>() / factor as f64)
        .collect();
    let dt = factor as f64 / rate_hz;
    let options = WaveletOptions {
        dj: settings.dj,
        s0: settings.s0_s,
        j: settings.j,
        mother: settings.mother,
        ..WaveletOptions::default()
    };
    let result = morlet_cwt(&reduced, dt, &options)?;
    let (lag1, lag1_source, fallback) = lag1_of(&reduced, settings.lag1);
    let (significance, skipped) = match &lag1 {
        Ok(a) => (
            Some(significance_of(&result, *a, settings.confidence)?),
            None,
        ),
        Err(e) => (None, Some(e.to_string())),
    };
    let summary = WaveletSummary {
        mother: settings.mother,
        dj: settings.dj,
        s0_s: result.scales[0],
        j: result.scales.len() - 1,
        period_range_s: (
            result.period_s[0],
            result.period_s[result.period_s.len() - 1],
        ),
        rate_hz: rate_hz / factor as f64,
        block_average: factor,
        t0_s: tail_start_s + (factor - 1) as f64 / (2.0 * rate_hz),
        n_samples: reduced.len(),
        padded: options.pad,
        normalized: options.normalize,
        lag1: lag1.ok(),
        lag1_source,
        confidence: settings.confidence,
        dof_min: super::MORLET_DOF_MIN,
        gamma: super::MORLET_GAMMA,
    };
    Ok(WaveletParts {
        summary,
        result,
        significance,
        skipped,
        warning: fallback,
    })
}

/// The lag-1 coefficient, where it came from, and a warning when the Allen–Smith estimate
/// has no solution (a lag-1 correlation so close to 1 that the bias correction cannot bound
/// it: smooth or trending records) and the sample autocorrelation stands in for it.
fn lag1_of(
    reduced: &[f64],
    choice: Lag1Choice,
) -> (Result<f64, AnalysisError>, &'static str, Option<String>) {
    match choice {
        Lag1Choice::Fixed(a) => (Ok(a), "given", None),
        Lag1Choice::Estimate(Lag1Estimator::Sample) => (
            estimate_lag1(reduced, Lag1Estimator::Sample),
            "sample",
            None,
        ),
        Lag1Choice::Estimate(Lag1Estimator::AllenSmith) => {
            match estimate_lag1(reduced, Lag1Estimator::AllenSmith) {
                Ok(a) => (Ok(a), "allen-smith", None),
                Err(_) => {
                    let sample = estimate_lag1(reduced, Lag1Estimator::Sample);
                    let warning = sample.as_ref().ok().map(|a| {
                        format!(
                            "the Allen-Smith (pycwt ar1) lag-1 estimate has no solution for \
                             this series (its lag-1 correlation is too close to 1: a smooth or \
                             trending record); the wavelet significance uses the sample \
                             autocorrelation {} instead",
                            num(*a)
                        )
                    });
                    (sample, "sample (allen-smith has no solution)", warning)
                }
            }
        }
    }
}

/// Local and global significance levels of a normalised transform.
fn significance_of(
    wt: &WaveletResult,
    lag1: f64,
    confidence: f64,
) -> Result<WaveletSignificance, AnalysisError> {
    let level = significance_ar1(1.0, wt.dt_s, &wt.period_s, lag1, confidence)?;
    let ratio = wt
        .power
        .iter()
        .zip(&level)
        .map(|(row, l)| row.iter().map(|p| p / l).collect())
        .collect();
    Ok(WaveletSignificance {
        global_power: global_wavelet_spectrum(wt),
        global_level: global_significance_ar1(wt, 1.0, lag1, confidence)?,
        level,
        ratio,
    })
}

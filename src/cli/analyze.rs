//! `pendulum-atlas analyze`: the paper's indicators for a measured (or simulated) CSV record.
//! The flags become the library's options; the record is read by
//! `pendulum_atlas_map::record` and its files written by `pendulum_atlas_map::output::analysis`.

use anyhow::bail;
use pendulum_atlas_core::analysis::{
    AnalysisError, K01Method, Lag1Choice, Lag1Estimator, MORLET_OMEGA0_MIN, MotherWavelet,
    PhaseConvention, RecordAnalysis, RecordOptions, Sampling, WaveletSettings, ZeroOneOptions,
    analyze_record,
};
use pendulum_atlas_map::output::analysis::{RecordInput, write_record_analysis};
use pendulum_atlas_map::output::folder::Product;
use pendulum_atlas_map::record::{Record, RecordSource, TimeAxis, read_record};
use std::path::PathBuf;

/// Arguments of `analyze`.
#[derive(Debug, clap::Args)]
#[command(
    after_help = "Outputs in --out: analysis.json (every number, setting and warning), \
spectrum.csv, and the arrays as .npy files (load them with numpy.load): wavelet_power.npy \
[scale, time], wavelet_period_s.npy, wavelet_scale_s.npy, wavelet_time_s.npy, \
wavelet_coi_s.npy, wavelet_signif_level.npy [scale], wavelet_signif_ratio.npy [scale, time] \
(power over the red-noise level: above 1 is significant), wavelet_global_power.npy and \
wavelet_global_signif.npy [scale], phase_diff_rad.npy; and the pictures (PNG)."
)]
pub struct AnalyzeArgs {
    /// CSV file with a header line naming the columns (lines starting with # are skipped).
    pub data: PathBuf,
    /// Column to analyse (e.g. the holder angle).
    #[arg(long)]
    pub signal: String,
    /// Reference column for phase synchronisation (e.g. the cart position).
    #[arg(long)]
    pub reference: Option<String>,
    /// Time column. Must be uniform unless --resample is given.
    #[arg(long, conflicts_with = "sample_rate_hz")]
    pub time: Option<String>,
    /// Name of the time unit of the time column and of every time option: a label written on
    /// the pictures and in analysis.json, not a conversion. With a unit other than s, rates and
    /// frequencies (--sample-rate-hz, --forcing-hz, the spectra) are per that unit.
    #[arg(long, default_value = "s")]
    pub time_unit: String,
    /// Sample rate (Hz) when there is no time column; in (0, inf).
    #[arg(long, allow_negative_numbers = true)]
    pub sample_rate_hz: Option<f64>,
    /// Forcing frequency (Hz): enables stroboscopic sampling, the period and the spectral
    /// ratio. In (0, sample rate / 10]: a stroboscopic sample needs ten samples per period.
    #[arg(long, allow_negative_numbers = true)]
    pub forcing_hz: Option<f64>,
    /// Samples for the 0–1 test (default: stroboscopic with --forcing-hz, local extrema
    /// without it).
    #[arg(long, value_enum)]
    pub sampling: Option<SamplingArg>,
    /// 0–1 test method.
    #[arg(long, value_enum, default_value = "correlation")]
    pub k01_method: K01MethodArg,
    /// Normalise the series by its mean and standard deviation first (paper eq. 8).
    #[arg(long)]
    pub k01_normalize: bool,
    /// Phase-difference convention of R.
    #[arg(long, value_enum, default_value = "standard")]
    pub phase_convention: PhaseArg,
    /// Seed of the 0–1 test's random c values.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Leading time to discard (s); in [0, record length).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub transient_s: f64,
    /// Clearance angle (deg) for counting hops between the wells; in (0, 90).
    #[arg(long, allow_negative_numbers = true)]
    pub clearance_deg: Option<f64>,
    /// Resample non-uniform time stamps by linear interpolation at their median rate.
    #[arg(long)]
    pub resample: bool,
    /// With --resample: interpolate across gaps (steps longer than 5 median steps) instead of
    /// refusing the record; every gap is reported.
    #[arg(long, requires = "resample")]
    pub allow_gaps: bool,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    #[arg(long, help = pendulum_atlas_map::output::folder::FORCE_HELP)]
    pub force: bool,
    /// Wavelet transform and significance.
    #[command(flatten)]
    pub wavelet: Box<WaveletArgs>,
}

/// Options of the wavelet transform and its red-noise significance (defaults: TC98 and pycwt).
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Wavelet")]
pub struct WaveletArgs {
    /// Mother wavelet.
    #[arg(long, value_enum, default_value = "morlet")]
    pub wavelet_mother: MotherArg,
    /// Morlet wave number omega0; at least 5.
    #[arg(long, default_value_t = 6.0, allow_negative_numbers = true)]
    pub wavelet_omega0: f64,
    /// Wavelet scale spacing (octaves); in (0, 1].
    #[arg(long, default_value_t = 1.0 / 12.0, allow_negative_numbers = true)]
    pub wavelet_dj: f64,
    /// Smallest wavelet scale (s) [default: a Fourier period of two samples].
    #[arg(long, allow_negative_numbers = true)]
    pub wavelet_s0: Option<f64>,
    /// Number of wavelet scales less one [default: up to the record's length].
    #[arg(long)]
    pub wavelet_j: Option<usize>,
    /// Lag-1 autocorrelation of the red-noise background: allen-smith (the estimate of
    /// pycwt's ar1; a series it has no solution for, too close to a random walk, falls back
    /// to sample with a warning), sample (the plain sample autocorrelation), or a number in
    /// (-1, 1).
    #[arg(long, default_value = "allen-smith", value_parser = parse_lag1, allow_negative_numbers = true)]
    pub wavelet_lag1: Lag1Choice,
    /// Confidence level of the wavelet significance; in (0, 1).
    #[arg(long, default_value_t = 0.95)]
    pub wavelet_confidence: f64,
    /// Largest sample rate fed to the wavelet transform (Hz); the record is block-averaged
    /// down to it.
    #[arg(long, default_value_t = 200.0, allow_negative_numbers = true)]
    pub wavelet_max_rate_hz: f64,
}

/// CLI spelling of [`K01Method`].
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum K01MethodArg {
    /// Correlation method (default, robust).
    Correlation,
    /// Regression method (the paper's eq. 10).
    Regression,
}

/// CLI spelling of [`PhaseConvention`].
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum PhaseArg {
    /// Δφ on the full circle: independent phases give R → 0.
    Standard,
    /// Δφ modulo π (the paper): independent phases give R → 2/π.
    Paper,
}

/// CLI spelling of [`Sampling`].
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum SamplingArg {
    /// One sample per forcing period (needs --forcing-hz).
    Stroboscopic,
    /// Local maxima and minima of the signal (the paper's Fig. 6).
    Extrema,
    /// Every sample of the uniform record (usually oversampled).
    Uniform,
}

/// CLI spelling of [`MotherWavelet`].
#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum MotherArg {
    /// Morlet wavelet (wave number --wavelet-omega0).
    Morlet,
}

/// `--wavelet-lag1`: an estimator's name or a number.
fn parse_lag1(s: &str) -> Result<Lag1Choice, String> {
    match s {
        "allen-smith" => Ok(Lag1Choice::Estimate(Lag1Estimator::AllenSmith)),
        "sample" => Ok(Lag1Choice::Estimate(Lag1Estimator::Sample)),
        _ => match s.parse::<f64>() {
            Ok(a) if a.is_finite() && a.abs() < 1.0 => Ok(Lag1Choice::Fixed(a)),
            _ => Err(format!(
                "expected allen-smith, sample or a number in (-1, 1), got `{s}`"
            )),
        },
    }
}

/// What the command tells the user besides the numbers: notes (choices made for them) and
/// warnings (something about the data they should look at).
#[derive(Default)]
struct Messages {
    notes: Vec<String>,
    warnings: Vec<String>,
}

/// Run the analysis and write analysis.json, the arrays and the pictures.
pub fn run(a: AnalyzeArgs) -> anyhow::Result<()> {
    validate_args(&a)?;
    let time = match (&a.time, a.sample_rate_hz) {
        (Some(name), _) => Some(TimeAxis::Column {
            name: name.clone(),
            unit: a.time_unit.clone(),
            resample: a.resample,
            allow_gaps: a.allow_gaps,
        }),
        (None, Some(rate)) => Some(TimeAxis::Rate(rate)),
        (None, None) => None,
    };
    let record = read_record(&RecordSource {
        path: &a.data,
        signal: &a.signal,
        reference: a.reference.as_deref(),
        time,
    })?;
    let mut msgs = Messages {
        notes: record.notes.clone(),
        warnings: record.warnings.clone(),
    };
    let opts = record_options(&a, &mut msgs)?;
    super::claim_out_reading(Product::Analyze, &a.out, a.force, &[&a.data])?;
    let mut result = analyze_record(
        &record.signal,
        record.reference.as_deref(),
        record.rate,
        record.start,
        &opts,
    )
    .map_err(|e| explain(e, &a))?;
    let mut printed = result.warnings.clone();
    printed.extend(result.zero_one.iter().flat_map(|z| z.warnings.clone()));
    result.warnings.extend(msgs.warnings.iter().cloned());
    result.warnings.extend(msgs.notes.iter().cloned());
    msgs.warnings.extend(printed);
    write_record_analysis(&a.out, &result, &record, record_input(&a, &record))?;
    print_summary(&a, &result, &msgs);
    Ok(())
}

/// `input` of analysis.json: the file, its columns and the record analysed.
fn record_input(a: &AnalyzeArgs, record: &Record) -> RecordInput {
    RecordInput {
        file: a.data.display().to_string(),
        signal: a.signal.clone(),
        reference: a.reference.clone(),
        time: a.time.clone(),
        time_unit: a.time_unit.clone(),
        sample_rate_hz: record.rate,
        start_s: record.start,
        samples: record.signal.len(),
        resampled: record.resampled,
        gaps: record.gaps.clone(),
    }
}

/// Checks every option against its range, naming the flag.
fn validate_args(a: &AnalyzeArgs) -> anyhow::Result<()> {
    let positive = |flag: &str, v: Option<f64>, unit: &str| -> anyhow::Result<()> {
        match v {
            Some(x) if !(x.is_finite() && x > 0.0) => {
                bail!("{flag} must lie in (0, inf) {unit}, got {x}")
            }
            _ => Ok(()),
        }
    };
    positive("--sample-rate-hz", a.sample_rate_hz, "Hz")?;
    positive("--forcing-hz", a.forcing_hz, "Hz")?;
    positive("--wavelet-s0", a.wavelet.wavelet_s0, &a.time_unit)?;
    positive(
        "--wavelet-max-rate-hz",
        Some(a.wavelet.wavelet_max_rate_hz),
        "Hz",
    )?;
    if !(a.transient_s.is_finite() && a.transient_s >= 0.0) {
        bail!(
            "--transient-s must lie in [0, record length) {}, got {}",
            a.time_unit,
            a.transient_s
        );
    }
    if let Some(c) = a.clearance_deg
        && !(c.is_finite() && c > 0.0 && c < 90.0)
    {
        bail!("--clearance-deg must lie in the open interval (0, 90) deg, got {c}");
    }
    validate_wavelet_args(&a.wavelet)?;
    validate_time_unit(&a.time_unit)
}

/// Range checks of the wavelet options that do not depend on the record.
fn validate_wavelet_args(w: &WaveletArgs) -> anyhow::Result<()> {
    if !(w.wavelet_dj.is_finite() && w.wavelet_dj > 0.0 && w.wavelet_dj <= 1.0) {
        bail!(
            "--wavelet-dj must lie in (0, 1] octave, got {}",
            w.wavelet_dj
        );
    }
    if !(w.wavelet_omega0.is_finite() && w.wavelet_omega0 >= MORLET_OMEGA0_MIN) {
        bail!(
            "--wavelet-omega0 must be at least {MORLET_OMEGA0_MIN} (below, the Morlet wavelet's \
             mean does not vanish), got {}",
            w.wavelet_omega0
        );
    }
    if !(w.wavelet_confidence > 0.0 && w.wavelet_confidence < 1.0) {
        bail!(
            "--wavelet-confidence must lie in (0, 1), got {}",
            w.wavelet_confidence
        );
    }
    Ok(())
}

/// A time unit must be a short printable label.
fn validate_time_unit(unit: &str) -> anyhow::Result<()> {
    let ok = !unit.trim().is_empty()
        && unit.chars().count() <= 16
        && !unit.chars().any(char::is_control);
    if !ok {
        bail!("--time-unit must be a printable label of 1 to 16 characters, got `{unit}`");
    }
    Ok(())
}

/// The analysis options, choosing the 0–1 test's sampling when none is given.
fn record_options(a: &AnalyzeArgs, msgs: &mut Messages) -> anyhow::Result<RecordOptions> {
    let sampling = match (a.sampling, a.forcing_hz) {
        (Some(SamplingArg::Stroboscopic), None) => bail!(
            "--sampling stroboscopic needs the forcing frequency (--forcing-hz); or choose \
             --sampling extrema|uniform"
        ),
        (Some(s), _) => sampling_of(s),
        (None, Some(f)) => Sampling::default_for(Some(f)),
        (None, None) => {
            msgs.notes.push(
                "no --forcing-hz: the 0-1 test uses the local extrema of the signal (the \
                 paper's choice for its Fig. 6); give --forcing-hz for stroboscopic samples, \
                 or choose --sampling"
                    .into(),
            );
            Sampling::default_for(None)
        }
    };
    Ok(RecordOptions {
        forcing_hz: a.forcing_hz,
        sampling,
        transient_s: a.transient_s,
        zero_one: ZeroOneOptions {
            method: match a.k01_method {
                K01MethodArg::Correlation => K01Method::Correlation,
                K01MethodArg::Regression => K01Method::Regression,
            },
            seed: a.seed,
            normalize: a.k01_normalize,
            ..Default::default()
        },
        phase_convention: match a.phase_convention {
            PhaseArg::Standard => PhaseConvention::Standard,
            PhaseArg::Paper => PhaseConvention::Paper,
        },
        clearance_rad: a.clearance_deg.map(f64::to_radians),
        wavelet: wavelet_settings(&a.wavelet),
        time_unit: a.time_unit.clone(),
        ..Default::default()
    })
}

/// The library's sampling for the CLI's spelling.
fn sampling_of(s: SamplingArg) -> Sampling {
    match s {
        SamplingArg::Stroboscopic => Sampling::Stroboscopic,
        SamplingArg::Extrema => Sampling::Extrema,
        SamplingArg::Uniform => Sampling::Uniform,
    }
}

/// The wavelet options as the library takes them.
fn wavelet_settings(w: &WaveletArgs) -> WaveletSettings {
    WaveletSettings {
        mother: match w.wavelet_mother {
            MotherArg::Morlet => MotherWavelet::Morlet {
                omega0: w.wavelet_omega0,
            },
        },
        dj: w.wavelet_dj,
        s0_s: w.wavelet_s0,
        j: w.wavelet_j,
        lag1: w.wavelet_lag1,
        confidence: w.wavelet_confidence,
        max_rate_hz: w.wavelet_max_rate_hz,
    }
}

/// An analysis error with the file and column it concerns, and the flag to change where one
/// applies.
fn explain(e: AnalysisError, a: &AnalyzeArgs) -> anyhow::Error {
    let hint = match &e {
        AnalysisError::TransientTooLong { .. } => " (--transient-s)",
        AnalysisError::ForcingUnresolved { .. } => " (--forcing-hz)",
        _ => "",
    };
    anyhow::anyhow!("{}: column `{}`: {e}{hint}", a.data.display(), a.signal)
}

/// K and R on one line, then the notes and anything left out.
fn print_summary(a: &AnalyzeArgs, r: &RecordAnalysis, msgs: &Messages) {
    for n in &msgs.notes {
        tell!("note: {n}");
    }
    for w in &msgs.warnings {
        tell!("warning: {w}");
    }
    for (what, why) in &r.skipped {
        tell!("warning: {what} not computed: {why}");
    }
    let k = r
        .zero_one
        .as_ref()
        .map_or("K not computed".to_string(), |z| {
            format!("K = {:.3} ({} samples)", z.k, z.n_samples)
        });
    let rr = r
        .phase_sync
        .as_ref()
        .map(|p| format!(", R = {:.3}", p.r))
        .unwrap_or_default();
    tell!("{k}{rr}; wrote {}", a.out.display());
}

//! `pendulum-atlas analyze`: the paper's indicators for a measured (or simulated) CSV record.

use anyhow::{Context, bail};
use pendulum_atlas_core::analysis::{
    AnalysisError, GAP_MEDIAN_STEPS, K01Method, Lag1Choice, Lag1Estimator, MORLET_OMEGA0_MIN,
    MotherWavelet, PhaseConvention, RECORD_MIN_SAMPLES, RecordAnalysis, RecordOptions, Sampling,
    TimeGap, WaveletSettings, ZeroOneOptions, analyze_record, check_uniform_time, median_step,
    resample_uniform, time_gaps,
};
use pendulum_atlas_map::output::files::write_json;
use pendulum_atlas_map::output::folder::Product;
use std::path::{Path, PathBuf};

/// Relative tolerance within which every time step must equal the median step for the record
/// to count as uniformly sampled.
const UNIFORM_STEP_REL_TOL: f64 = 1e-3;

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
    /// Replace an earlier run in --out: delete the files this command writes there first
    /// (other files are left alone). Without it, a folder holding such files is refused.
    #[arg(long)]
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

/// A CSV as named numeric columns.
pub struct Table {
    path: PathBuf,
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
    lines: Vec<u64>,
}

/// A record must be a regular file whose values fit in memory: its parsed columns take at
/// most about its size again.
fn check_record_file(path: &Path) -> anyhow::Result<()> {
    let shown = path.display();
    let meta = std::fs::metadata(path).with_context(|| format!("cannot read {shown}"))?;
    if !meta.is_file() {
        bail!("{shown} is not a regular file; give the CSV file to analyse");
    }
    if let Some(available) = pendulum_atlas_map::machine::memory_available()
        && meta.len() > available / 2
    {
        bail!(
            "{shown} has {} and {} of memory is available: analyse a shorter record, or split it",
            pendulum_atlas_core::text::bytes(meta.len()),
            pendulum_atlas_core::text::bytes(available)
        );
    }
    Ok(())
}

impl Table {
    /// Read a CSV with a header; every cell of the requested columns must be a finite number.
    /// Every error names the file.
    pub fn read(path: &Path, wanted: &[&str]) -> anyhow::Result<Table> {
        let shown = path.display();
        if path.is_dir() {
            bail!("{shown} is a directory; give the CSV file to analyse");
        }
        check_record_file(path)?;
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_path(path)
            .with_context(|| format!("cannot read {shown}"))?;
        let header: Vec<String> = rdr
            .headers()
            .with_context(|| format!("cannot read the header line of {shown}"))?
            .iter()
            .map(str::to_string)
            .collect();
        if header.iter().all(String::is_empty) {
            bail!("{shown} is empty: expected a header line naming the columns, then data rows");
        }
        ensure_unique_names(path, &header)?;
        let idx = wanted
            .iter()
            .map(|w| column_index(path, &header, w))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let mut table = Table {
            path: path.to_path_buf(),
            names: wanted.iter().map(|s| s.to_string()).collect(),
            columns: vec![Vec::new(); wanted.len()],
            lines: Vec::new(),
        };
        for rec in rdr.records() {
            let rec = rec.with_context(|| format!("{shown}: malformed row"))?;
            table.push_row(&rec, &idx)?;
        }
        if table.lines.is_empty() {
            bail!("{shown} has a header but no data rows");
        }
        Ok(table)
    }

    /// Parse the wanted cells of one record.
    fn push_row(&mut self, rec: &csv::StringRecord, idx: &[usize]) -> anyhow::Result<()> {
        let line = rec.position().map_or(0, |p| p.line());
        for (k, &i) in idx.iter().enumerate() {
            let cell = rec.get(i).unwrap_or("");
            let at = || {
                format!(
                    "{}: line {line}, column `{}`",
                    self.path.display(),
                    self.names[k]
                )
            };
            let v: f64 = cell
                .parse()
                .map_err(|_| anyhow::anyhow!("{}: `{cell}` is not a number", at()))?;
            if !v.is_finite() {
                bail!(
                    "{}: {cell} is not finite (NaN/inf); clean or cut the record first",
                    at()
                );
            }
            self.columns[k].push(v);
        }
        self.lines.push(line);
        Ok(())
    }

    /// A column by name.
    pub fn col(&self, name: &str) -> &[f64] {
        let i = self
            .names
            .iter()
            .position(|n| n == name)
            .expect("requested column");
        &self.columns[i]
    }

    /// Number of data rows.
    pub fn rows(&self) -> usize {
        self.lines.len()
    }

    /// The file line of data row `row` (0-based).
    fn line(&self, row: usize) -> u64 {
        self.lines.get(row).copied().unwrap_or(0)
    }
}

/// Refuses a header in which a name appears twice (which column was meant is unknowable).
fn ensure_unique_names(path: &Path, header: &[String]) -> anyhow::Result<()> {
    for (i, name) in header.iter().enumerate() {
        if let Some(j) = header[i + 1..].iter().position(|n| n == name) {
            bail!(
                "{}: column `{name}` appears twice in the header (columns {} and {}); rename one",
                path.display(),
                i + 1,
                i + j + 2
            );
        }
    }
    Ok(())
}

/// Position of column `want` in the header, or an error listing the columns.
fn column_index(path: &Path, header: &[String], want: &str) -> anyhow::Result<usize> {
    header.iter().position(|n| n == want).ok_or_else(|| {
        // At most twelve names, each cut short: a header can be anything.
        let mut names: Vec<String> = header
            .iter()
            .take(12)
            .map(|n| pendulum_atlas_core::config::shorten_lines(&n.replace('\n', " ")))
            .collect();
        if header.len() > 12 {
            names.push(format!("… ({} columns)", header.len()));
        }
        anyhow::anyhow!(
            "{}: no column `{want}`; the columns are: {}",
            path.display(),
            pendulum_atlas_core::config::shorten_lines(&names.join(", "))
        )
    })
}

/// What the command tells the user besides the numbers: notes (choices made for them) and
/// warnings (something about the data they should look at).
#[derive(Default)]
struct Messages {
    notes: Vec<String>,
    warnings: Vec<String>,
}

/// A uniformly sampled record, ready for the analysis.
struct Record {
    signal: Vec<f64>,
    reference: Option<Vec<f64>>,
    rate: f64,
    start: f64,
    resampled: bool,
    gaps: Vec<TimeGap>,
}

/// Run the analysis and write analysis.json, the arrays and the pictures.
pub fn run(a: AnalyzeArgs) -> anyhow::Result<()> {
    validate_args(&a)?;
    let mut wanted = vec![a.signal.as_str()];
    wanted.extend(a.reference.as_deref());
    wanted.extend(a.time.as_deref());
    let table = Table::read(&a.data, &wanted)?;
    if table.rows() < RECORD_MIN_SAMPLES {
        bail!(
            "{} has {} data row(s); the analysis needs at least {RECORD_MIN_SAMPLES}",
            a.data.display(),
            table.rows()
        );
    }
    let mut msgs = Messages::default();
    let record = uniform_record(&a, &table, &mut msgs)?;
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
    write_outputs(&a, &result, &record)?;
    print_summary(&a, &result, &msgs);
    Ok(())
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

/// The signal (and reference) on a uniform grid, from the time column or the sample rate.
fn uniform_record(a: &AnalyzeArgs, table: &Table, msgs: &mut Messages) -> anyhow::Result<Record> {
    let signal = table.col(&a.signal).to_vec();
    let reference = a.reference.as_ref().map(|r| table.col(r).to_vec());
    match (&a.time, a.sample_rate_hz) {
        (Some(tc), _) => from_time_column(a, table, tc, signal, reference, msgs),
        (None, Some(rate)) => Ok(Record {
            signal,
            reference,
            rate,
            start: 0.0,
            resampled: false,
            gaps: Vec::new(),
        }),
        (None, None) => {
            bail!("give the time column (--time COL) or the sample rate (--sample-rate-hz F)")
        }
    }
}

/// Uses a uniform time column as it is; resamples a non-uniform one at its median rate when
/// --resample is given, refusing gaps unless --allow-gaps.
fn from_time_column(
    a: &AnalyzeArgs,
    table: &Table,
    tc: &str,
    signal: Vec<f64>,
    reference: Option<Vec<f64>>,
    msgs: &mut Messages,
) -> anyhow::Result<Record> {
    let t = table.col(tc);
    let at = || format!("{}: time column `{tc}`", table.path.display());
    let gaps = time_gaps(t, GAP_MEDIAN_STEPS).map_err(|e| time_error(e, table, &at()))?;
    let unit = &a.time_unit;
    match check_uniform_time(t, UNIFORM_STEP_REL_TOL) {
        Ok(dt) => Ok(Record {
            signal,
            reference,
            rate: 1.0 / dt,
            start: t[0],
            resampled: false,
            gaps,
        }),
        Err(e) if !a.resample => bail!(
            "{}{}; pass --resample to interpolate onto a uniform grid (linear), or fix the time \
             column",
            time_error(e, table, &at()),
            gap_text(&gaps, unit)
        ),
        Err(_) if !gaps.is_empty() && !a.allow_gaps => bail!(
            "{}{}; resampling would bridge each gap with a straight line: cut the record, or \
             pass --allow-gaps to interpolate across them",
            at(),
            gap_text(&gaps, unit)
        ),
        Err(_) => resampled(t, signal, reference, gaps, unit, msgs),
    }
}

/// Resample at the median rate, noting every bridged gap.
fn resampled(
    t: &[f64],
    signal: Vec<f64>,
    reference: Option<Vec<f64>>,
    gaps: Vec<TimeGap>,
    unit: &str,
    msgs: &mut Messages,
) -> anyhow::Result<Record> {
    let rate = 1.0 / median_step(t)?;
    for g in &gaps {
        msgs.warnings.push(format!(
            "gap of {} {unit} after t = {} {unit} bridged by linear interpolation",
            g.length_s, g.start_s
        ));
    }
    msgs.notes.push(format!(
        "time stamps are not uniform; resampled by linear interpolation at their median rate, \
         {rate} samples per {unit}"
    ));
    let (tt, s) = resample_uniform(t, &signal, rate)?;
    let reference = match reference {
        Some(r) => Some(resample_uniform(t, &r, rate)?.1),
        None => None,
    };
    Ok(Record {
        signal: s,
        reference,
        rate,
        start: tt[0],
        resampled: true,
        gaps,
    })
}

/// " with 2 gaps longer than 5 median steps: 1 s after t = 5 s, …", or nothing.
fn gap_text(gaps: &[TimeGap], unit: &str) -> String {
    if gaps.is_empty() {
        return String::new();
    }
    let list: Vec<String> = gaps
        .iter()
        .take(5)
        .map(|g| format!("{} {unit} after t = {} {unit}", g.length_s, g.start_s))
        .collect();
    let more = if gaps.len() > 5 { ", …" } else { "" };
    format!(
        "; it has {} gap(s) longer than {GAP_MEDIAN_STEPS} median steps: {}{more}",
        gaps.len(),
        list.join(", ")
    )
}

/// A time-axis error with the file line instead of the sample index.
fn time_error(e: AnalysisError, table: &Table, at: &str) -> anyhow::Error {
    match e {
        AnalysisError::NonIncreasingTime {
            index,
            previous_s,
            current_s,
        } => anyhow::anyhow!(
            "{at}: time stamps must increase strictly, but line {} has {current_s} after \
             {previous_s}",
            table.line(index)
        ),
        AnalysisError::NonUniformTime {
            index,
            step_s,
            expected_s,
            rel_tol,
        } => anyhow::anyhow!(
            "{at}: time stamps are not uniform: the step before line {} is {step_s}, the median \
             step {expected_s} (relative tolerance {rel_tol})",
            table.line(index)
        ),
        other => anyhow::anyhow!("{at}: {other}"),
    }
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

/// analysis.json, spectrum.csv, the arrays and the pictures.
fn write_outputs(a: &AnalyzeArgs, result: &RecordAnalysis, record: &Record) -> anyhow::Result<()> {
    super::report::write_analysis(
        &a.out,
        result,
        &record.signal,
        record.reference.as_deref(),
        record.rate,
        record.start,
    )?;
    let mut json = serde_json::to_value(result)?;
    json["time_unit"] = serde_json::json!(a.time_unit);
    json["input"] = serde_json::json!({
        "file": a.data.display().to_string(),
        "signal": a.signal,
        "reference": a.reference,
        "time": a.time,
        "time_unit": a.time_unit,
        "sample_rate_hz": record.rate,
        "start_s": record.start,
        "samples": record.signal.len(),
        "resampled": record.resampled,
        "gaps": record.gaps,
    });
    // The manifest last: its presence means the folder is complete.
    write_json(&a.out.join("analysis.json"), &json)?;
    Ok(())
}

/// K and R on one line, then the notes and anything left out.
fn print_summary(a: &AnalyzeArgs, r: &RecordAnalysis, msgs: &Messages) {
    for n in &msgs.notes {
        eprintln!("note: {n}");
    }
    for w in &msgs.warnings {
        eprintln!("warning: {w}");
    }
    for (what, why) in &r.skipped {
        eprintln!("warning: {what} not computed: {why}");
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
    eprintln!("{k}{rr}; wrote {}", a.out.display());
}

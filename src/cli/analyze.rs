//! `pendulum-atlas analyze`: the paper's indicators for a measured (or simulated) CSV record.

use anyhow::{Context, bail};
use pendulum_atlas::analysis::{
    K01Method, PhaseConvention, RecordOptions, Sampling, ZeroOneOptions, analyze_record,
    check_uniform_time, resample_uniform,
};
use std::path::{Path, PathBuf};

/// Arguments of `analyze`.
#[derive(Debug, clap::Args)]
pub struct AnalyzeArgs {
    /// CSV file with a header line.
    pub data: PathBuf,
    /// Column to analyse (e.g. the holder angle).
    #[arg(long)]
    pub signal: String,
    /// Reference column for phase synchronisation (e.g. the cart position).
    #[arg(long)]
    pub reference: Option<String>,
    /// Time column (s). Must be uniform unless --resample is given.
    #[arg(long, conflicts_with = "sample_rate_hz")]
    pub time: Option<String>,
    /// Sample rate (Hz) when there is no time column.
    #[arg(long)]
    pub sample_rate_hz: Option<f64>,
    /// Forcing frequency (Hz): enables stroboscopic sampling, the period and the spectral ratio.
    #[arg(long)]
    pub forcing_hz: Option<f64>,
    /// Samples for the 0–1 test (default: stroboscopic when --forcing-hz is given).
    #[arg(long, value_enum)]
    pub sampling: Option<Sampling>,
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
    /// Leading time to discard (s).
    #[arg(long, default_value_t = 0.0)]
    pub transient_s: f64,
    /// Clearance angle (deg) for counting hops between the wells.
    #[arg(long)]
    pub clearance_deg: Option<f64>,
    /// Resample non-uniform time stamps by linear interpolation at their mean rate.
    #[arg(long)]
    pub resample: bool,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
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

/// A CSV as named numeric columns.
pub struct Table {
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
}

impl Table {
    /// Read a CSV with a header; every cell of the requested columns must be a finite number.
    pub fn read(path: &Path, wanted: &[&str]) -> anyhow::Result<Table> {
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_path(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let names: Vec<String> = rdr.headers()?.iter().map(str::to_string).collect();
        let mut idx = Vec::new();
        for w in wanted {
            match names.iter().position(|n| n == w) {
                Some(i) => idx.push(i),
                None => bail!(
                    "{}: no column `{w}`; the columns are: {}",
                    path.display(),
                    names.join(", ")
                ),
            }
        }
        let mut columns = vec![Vec::new(); wanted.len()];
        for (row, rec) in rdr.records().enumerate() {
            let rec =
                rec.with_context(|| format!("{}: malformed row {}", path.display(), row + 2))?;
            for (k, &i) in idx.iter().enumerate() {
                let cell = rec.get(i).unwrap_or("");
                let v: f64 = cell.parse().map_err(|_| {
                    anyhow::anyhow!(
                        "{}: line {}, column `{}`: `{cell}` is not a number",
                        path.display(),
                        row + 2,
                        wanted[k]
                    )
                })?;
                if !v.is_finite() {
                    bail!(
                        "{}: line {}, column `{}`: {cell} is not finite (NaN/inf); clean or cut the record first",
                        path.display(),
                        row + 2,
                        wanted[k]
                    );
                }
                columns[k].push(v);
            }
        }
        if columns[0].is_empty() {
            bail!("{}: the file has a header but no data rows", path.display());
        }
        Ok(Table {
            names: wanted.iter().map(|s| s.to_string()).collect(),
            columns,
        })
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
}

/// Run the analysis and write analysis.json, the arrays and the pictures.
pub fn run(a: AnalyzeArgs) -> anyhow::Result<()> {
    let mut wanted = vec![a.signal.as_str()];
    if let Some(r) = &a.reference {
        wanted.push(r);
    }
    if let Some(t) = &a.time {
        wanted.push(t);
    }
    let table = Table::read(&a.data, &wanted)?;
    let mut notes = Vec::new();
    let mut signal = table.col(&a.signal).to_vec();
    let mut reference = a.reference.as_ref().map(|r| table.col(r).to_vec());
    let (rate, start) = match (&a.time, a.sample_rate_hz) {
        (Some(tc), _) => {
            let t = table.col(tc);
            match check_uniform_time(t, 1e-3) {
                Ok(dt) => (1.0 / dt, t[0]),
                Err(e) if a.resample => {
                    let rate = (t.len() - 1) as f64 / (t[t.len() - 1] - t[0]);
                    notes.push(format!(
                        "time stamps are not uniform ({e}); resampled by linear interpolation at {rate} Hz"
                    ));
                    let (tt, s) = resample_uniform(t, &signal, rate)?;
                    signal = s;
                    if let Some(r) = reference.as_mut() {
                        *r = resample_uniform(t, r, rate)?.1;
                    }
                    (rate, tt[0])
                }
                Err(e) => bail!(
                    "{e}; pass --resample to interpolate onto a uniform grid (linear), or fix the time column"
                ),
            }
        }
        (None, Some(r)) if r.is_finite() && r > 0.0 => (r, 0.0),
        (None, Some(r)) => bail!("--sample-rate-hz must be a positive number, got {r}"),
        (None, None) => {
            bail!("give the time column (--time COL) or the sample rate (--sample-rate-hz F)")
        }
    };
    let sampling = match (a.sampling, a.forcing_hz) {
        (Some(s), _) => s,
        (None, Some(_)) => Sampling::Stroboscopic,
        (None, None) => bail!(
            "the 0–1 test needs coarse samples: give --forcing-hz for stroboscopic sampling (default), or choose --sampling extrema|uniform"
        ),
    };
    if let Some(f) = a.forcing_hz
        && !(f.is_finite() && f > 0.0)
    {
        bail!("--forcing-hz must be a positive number, got {f}");
    }
    let opts = RecordOptions {
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
        ..Default::default()
    };
    let mut result = analyze_record(&signal, reference.as_deref(), rate, start, &opts)?;
    result.warnings.extend(notes);
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create output folder {}", a.out.display()))?;
    super::report::write_analysis(&a.out, &result, &signal, reference.as_deref(), rate, start)?;
    let mut json = serde_json::to_value(&result)?;
    json["input"] = serde_json::json!({
        "file": a.data.display().to_string(),
        "signal": a.signal,
        "reference": a.reference,
        "time": a.time,
        "sample_rate_hz": rate,
        "samples": signal.len(),
    });
    std::fs::write(
        a.out.join("analysis.json"),
        serde_json::to_string_pretty(&json)?,
    )?;
    eprintln!(
        "K = {:.3} ({} samples){}; wrote {}",
        result.zero_one.k,
        result.zero_one.n_samples,
        result
            .phase_sync
            .as_ref()
            .map(|p| format!(", R = {:.3}", p.r))
            .unwrap_or_default(),
        a.out.display()
    );
    Ok(())
}

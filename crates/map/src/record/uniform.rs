//! The time axis of a record: a uniform time column as it is, a non-uniform one resampled at
//! its median rate (when allowed), or a given sample rate.

use super::error::RecordError;
use super::table::Table;
use pendulum_atlas_core::analysis::{
    AnalysisError, GAP_MEDIAN_STEPS, RECORD_MIN_SAMPLES, TimeGap, check_uniform_time, median_step,
    resample_uniform, time_gaps,
};
use std::path::Path;

/// Relative tolerance within which every time step must equal the median step for the record
/// to count as uniformly sampled.
pub const UNIFORM_STEP_REL_TOL: f64 = 1e-3;

/// How a record's samples are placed in time.
#[derive(Debug, Clone, PartialEq)]
pub enum TimeAxis {
    /// A time column.
    Column {
        /// Its name.
        name: String,
        /// The name of its unit, for messages.
        unit: String,
        /// Resample a non-uniform column linearly at its median rate (`--resample`).
        resample: bool,
        /// With `resample`: bridge gaps longer than [`GAP_MEDIAN_STEPS`] median steps
        /// (`--allow-gaps`) instead of refusing the record.
        allow_gaps: bool,
    },
    /// Uniform samples at this rate (per time unit), starting at 0.
    Rate(f64),
}

/// Which columns of which file make the record.
#[derive(Debug, Clone)]
pub struct RecordSource<'a> {
    /// The CSV file.
    pub path: &'a Path,
    /// The column analysed.
    pub signal: &'a str,
    /// The reference column of phase synchronisation.
    pub reference: Option<&'a str>,
    /// The time axis; `None`: refused ([`RecordError::NoTimeAxis`]).
    pub time: Option<TimeAxis>,
}

/// A uniformly sampled record, ready for the analysis, with what was done to get it.
#[derive(Debug, Clone)]
pub struct Record {
    /// The signal.
    pub signal: Vec<f64>,
    /// The reference, when given.
    pub reference: Option<Vec<f64>>,
    /// Samples per time unit.
    pub rate: f64,
    /// Time of the first sample.
    pub start: f64,
    /// Whether it was resampled.
    pub resampled: bool,
    /// Gaps of the time column.
    pub gaps: Vec<TimeGap>,
    /// Choices made for the user (a resampling).
    pub notes: Vec<String>,
    /// What the user should look at (a bridged gap).
    pub warnings: Vec<String>,
}

/// Read the record `src` describes ([`Table::read`], then its time axis), with at least
/// [`RECORD_MIN_SAMPLES`] rows.
pub fn read_record(src: &RecordSource) -> Result<Record, RecordError> {
    let Some(time) = &src.time else {
        return Err(RecordError::NoTimeAxis);
    };
    let mut wanted = vec![src.signal];
    wanted.extend(src.reference);
    if let TimeAxis::Column { name, .. } = time {
        wanted.push(name);
    }
    let table = Table::read(src.path, &wanted)?;
    if table.rows() < RECORD_MIN_SAMPLES {
        return Err(RecordError::File {
            path: src.path.display().to_string(),
            reason: format!(
                "it has {} data row(s); the analysis needs at least {RECORD_MIN_SAMPLES}",
                table.rows()
            ),
        });
    }
    let column = |name: &str| table.col(name).unwrap_or_default().to_vec();
    let signal = column(src.signal);
    let reference = src.reference.map(column);
    match time {
        TimeAxis::Rate(rate) => Ok(Record {
            signal,
            reference,
            rate: *rate,
            start: 0.0,
            resampled: false,
            gaps: Vec::new(),
            notes: Vec::new(),
            warnings: Vec::new(),
        }),
        TimeAxis::Column {
            name,
            unit,
            resample,
            allow_gaps,
        } => {
            let t = table.col(name).unwrap_or_default();
            let at = format!("{}: time column `{name}`", table.path().display());
            let gaps = time_gaps(t, GAP_MEDIAN_STEPS).map_err(|e| time_error(e, &table, &at))?;
            let axis = TimeColumn {
                t,
                at: &at,
                unit,
                table: &table,
            };
            axis.record(signal, reference, gaps, *resample, *allow_gaps)
        }
    }
}

/// A record's time column and what its messages name.
struct TimeColumn<'a> {
    t: &'a [f64],
    at: &'a str,
    unit: &'a str,
    table: &'a Table,
}

impl TimeColumn<'_> {
    /// Uses a uniform time column as it is; resamples a non-uniform one at its median rate
    /// when `resample`, refusing gaps unless `allow_gaps`.
    fn record(
        &self,
        signal: Vec<f64>,
        reference: Option<Vec<f64>>,
        gaps: Vec<TimeGap>,
        resample: bool,
        allow_gaps: bool,
    ) -> Result<Record, RecordError> {
        let refused = |reason: String| RecordError::TimeAxis {
            at: self.at.to_string(),
            reason,
        };
        match check_uniform_time(self.t, UNIFORM_STEP_REL_TOL) {
            Ok(dt) => Ok(Record {
                signal,
                reference,
                rate: 1.0 / dt,
                start: self.t[0],
                resampled: false,
                gaps,
                notes: Vec::new(),
                warnings: Vec::new(),
            }),
            Err(e) if !resample => Err(refused(format!(
                "{}{}; pass --resample to interpolate onto a uniform grid (linear), or fix the time column",
                time_reason(e, self.table),
                gap_text(&gaps, self.unit)
            ))),
            Err(_) if !gaps.is_empty() && !allow_gaps => Err(refused(format!(
                "the time stamps are not uniform{}; resampling would bridge each gap with a straight line: cut the record, or pass --allow-gaps to interpolate across them",
                gap_text(&gaps, self.unit)
            ))),
            Err(_) => self.resampled(signal, reference, gaps),
        }
    }

    /// Resample at the median rate, noting every bridged gap.
    fn resampled(
        &self,
        signal: Vec<f64>,
        reference: Option<Vec<f64>>,
        gaps: Vec<TimeGap>,
    ) -> Result<Record, RecordError> {
        let (t, unit) = (self.t, self.unit);
        let rate = 1.0 / median_step(t)?;
        let warnings = gaps
            .iter()
            .map(|g| {
                format!(
                    "gap of {} {unit} after t = {} {unit} bridged by linear interpolation",
                    g.length_s, g.start_s
                )
            })
            .collect();
        let notes = vec![format!(
            "time stamps are not uniform; resampled by linear interpolation at their median rate, {rate} samples per {unit}"
        )];
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
            notes,
            warnings,
        })
    }
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
fn time_error(e: AnalysisError, table: &Table, at: &str) -> RecordError {
    RecordError::TimeAxis {
        at: at.to_string(),
        reason: time_reason(e, table),
    }
}

/// What is wrong with a time column, naming the file line instead of the sample index.
fn time_reason(e: AnalysisError, table: &Table) -> String {
    match e {
        AnalysisError::NonIncreasingTime {
            index,
            previous_s,
            current_s,
        } => format!(
            "time stamps must increase strictly, but line {} has {current_s} after {previous_s}",
            table.line(index)
        ),
        AnalysisError::NonUniformTime {
            index,
            step_s,
            expected_s,
            rel_tol,
        } => format!(
            "time stamps are not uniform: the step before line {} is {step_s}, the median step {expected_s} (relative tolerance {rel_tol})",
            table.line(index)
        ),
        other => other.to_string(),
    }
}

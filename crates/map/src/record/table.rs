//! A CSV record as named numeric columns.

use super::error::RecordError;
use std::path::{Path, PathBuf};

/// The wanted columns of a CSV file with a header line (lines starting with `#` skipped), every
/// cell a finite number.
#[derive(Debug, Clone)]
pub struct Table {
    path: PathBuf,
    names: Vec<String>,
    columns: Vec<Vec<f64>>,
    lines: Vec<u64>,
}

impl Table {
    /// Read the columns `wanted` of the CSV at `path`. Every error names the file (and the line
    /// and column of a bad cell).
    pub fn read(path: &Path, wanted: &[&str]) -> Result<Table, RecordError> {
        use std::io::Read;
        let cap = record_cap(path)?;
        let file_error = |reason: String| RecordError::File {
            path: path.display().to_string(),
            reason,
        };
        let mut file =
            std::fs::File::open(path).map_err(|e| file_error(format!("cannot read it: {e}")))?;
        let mut head = Vec::new();
        (&mut file)
            .take(MAX_HEADER_BYTES)
            .read_to_end(&mut head)
            .map_err(|e| file_error(format!("cannot read it: {e}")))?;
        if head.len() as u64 == MAX_HEADER_BYTES && !head.contains(&b'\n') {
            return Err(file_error(format!(
                "no line ends within its first {}: a CSV record starts with a header line naming the columns",
                pendulum_atlas_core::text::bytes(MAX_HEADER_BYTES)
            )));
        }
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(
                std::io::Cursor::new(head)
                    .chain(file)
                    .take(cap.saturating_add(1)),
            );
        let header: Vec<String> = rdr
            .headers()
            .map_err(|e| file_error(format!("cannot read the header line: {e}")))?
            .iter()
            .map(str::to_string)
            .collect();
        if header.iter().all(String::is_empty) {
            return Err(file_error(
                "the file is empty: expected a header line naming the columns, then data rows"
                    .into(),
            ));
        }
        ensure_unique_names(path, &header)?;
        let idx = wanted
            .iter()
            .map(|w| column_index(path, &header, w))
            .collect::<Result<Vec<_>, _>>()?;
        let mut table = Table {
            path: path.to_path_buf(),
            names: wanted.iter().map(|s| s.to_string()).collect(),
            columns: vec![Vec::new(); wanted.len()],
            lines: Vec::new(),
        };
        for rec in rdr.records() {
            let rec = rec.map_err(|e| file_error(format!("malformed row: {e}")))?;
            table.push_row(&rec, &idx)?;
        }
        if rdr.position().byte() > cap {
            return Err(file_error(format!(
                "it goes on past {}: a record read from a pipe may have at most {} (save it to a file), and a file must not grow while it is read",
                pendulum_atlas_core::text::bytes(cap),
                pendulum_atlas_core::text::bytes(MAX_STREAM_BYTES)
            )));
        }
        if table.lines.is_empty() {
            return Err(file_error("it has a header but no data rows".into()));
        }
        Ok(table)
    }

    /// Parse the wanted cells of one record.
    fn push_row(&mut self, rec: &csv::StringRecord, idx: &[usize]) -> Result<(), RecordError> {
        let line = rec.position().map_or(0, |p| p.line());
        for (k, &i) in idx.iter().enumerate() {
            let cell = rec.get(i).unwrap_or("");
            let bad = |reason: String| RecordError::Cell {
                path: self.path.display().to_string(),
                line,
                column: self.names[k].clone(),
                reason,
            };
            let v: f64 = cell
                .parse()
                .map_err(|_| bad(format!("`{cell}` is not a number")))?;
            if !v.is_finite() {
                return Err(bad(format!(
                    "{cell} is not finite (NaN/inf); clean or cut the record first"
                )));
            }
            self.columns[k].push(v);
        }
        self.lines.push(line);
        Ok(())
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A wanted column by name (`None` for a column that was not asked for).
    pub fn col(&self, name: &str) -> Option<&[f64]> {
        let i = self.names.iter().position(|n| n == name)?;
        Some(&self.columns[i])
    }

    /// Number of data rows.
    pub fn rows(&self) -> usize {
        self.lines.len()
    }

    /// The file line of data row `row` (0-based).
    pub fn line(&self, row: usize) -> u64 {
        self.lines.get(row).copied().unwrap_or(0)
    }
}

/// Longest first line read before a record is refused as not CSV (bytes): a header names a
/// few columns.
pub(crate) const MAX_HEADER_BYTES: u64 = 1 << 20;

/// Largest record read from a stream (a pipe, `/dev/stdin`, `<(...)`): its size is not known
/// before it is read, so it is read up to this and refused beyond it (bytes).
pub(crate) const MAX_STREAM_BYTES: u64 = 256 << 20;

/// How many bytes of the record at `path` may be read: a regular file whose values fit in
/// memory (its parsed columns take at most about its size again) is read whole; a stream is
/// read up to [`MAX_STREAM_BYTES`]; a folder is refused.
fn record_cap(path: &Path) -> Result<u64, RecordError> {
    let file_error = |reason: String| RecordError::File {
        path: path.display().to_string(),
        reason,
    };
    let meta = std::fs::metadata(path).map_err(|e| file_error(format!("cannot read it: {e}")))?;
    if meta.is_dir() {
        return Err(file_error(
            "it is a directory; give the CSV file to analyse".into(),
        ));
    }
    if !meta.is_file() {
        return Ok(MAX_STREAM_BYTES);
    }
    if let Some(available) = crate::machine::memory_available()
        && meta.len() > available / 2
    {
        return Err(file_error(format!(
            "it has {} and {} of memory is available: analyse a shorter record, or split it",
            pendulum_atlas_core::text::bytes(meta.len()),
            pendulum_atlas_core::text::bytes(available)
        )));
    }
    Ok(meta.len())
}

/// Refuses a header in which a name appears twice (which column was meant is unknowable).
fn ensure_unique_names(path: &Path, header: &[String]) -> Result<(), RecordError> {
    for (i, name) in header.iter().enumerate() {
        if let Some(j) = header[i + 1..].iter().position(|n| n == name) {
            return Err(RecordError::Header {
                path: path.display().to_string(),
                reason: format!(
                    "column `{name}` appears twice in the header (columns {} and {}); rename one",
                    i + 1,
                    i + j + 2
                ),
            });
        }
    }
    Ok(())
}

/// Position of column `want` in the header, or an error listing the columns.
fn column_index(path: &Path, header: &[String], want: &str) -> Result<usize, RecordError> {
    header.iter().position(|n| n == want).ok_or_else(|| {
        use pendulum_atlas_core::config::shorten_lines;
        // At most twelve names, each cut short: a header can be anything.
        let mut names: Vec<String> = header
            .iter()
            .take(12)
            .map(|n| shorten_lines(&n.replace('\n', " ")))
            .collect();
        if header.len() > 12 {
            names.push(format!("… ({} columns)", header.len()));
        }
        RecordError::Header {
            path: path.display().to_string(),
            reason: format!(
                "no column `{want}`; the columns are: {}",
                shorten_lines(&names.join(", "))
            ),
        }
    })
}

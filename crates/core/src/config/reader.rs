//! Raw scene handling: TOML text, `--set` overrides, and a key reader that remembers which keys
//! were read so that anything left over is reported as unknown.

use super::error::ConfigError;
use crate::text::num;
use std::collections::BTreeSet;
use toml::{Table, Value};

/// Largest scene file read (bytes): scenes are a few kilobytes; a larger file is not one.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// Longest line of a message quoted from the input (characters).
const MAX_QUOTED_LINE: usize = 160;

/// Read a scene file of at most [`MAX_SCENE_BYTES`], in UTF-8: a regular file, or a stream
/// (a pipe, `/dev/stdin`, `<(...)`) read up to that size, so that an endless one (`/dev/zero`)
/// is refused once it passes it. A folder is refused.
pub fn read_scene_file(path: &std::path::Path) -> Result<String, ConfigError> {
    use std::io::Read;
    let shown = path.display().to_string();
    let io = |source| ConfigError::Io {
        path: shown.clone(),
        source,
    };
    let refuse = |reason: String| ConfigError::NotAScene {
        path: shown.clone(),
        reason,
    };
    if std::fs::metadata(path).map_err(io)?.is_dir() {
        return Err(refuse(
            "a folder, not a file (a scene is a TOML file)".into(),
        ));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_SCENE_BYTES + 1).read_to_end(&mut bytes))
        .map_err(io)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(refuse(format!(
            "more than the {MAX_SCENE_BYTES} bytes a scene file may have"
        )));
    }
    String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text ({e})"),
        ))
    })
}

/// `message` with every line cut to `MAX_QUOTED_LINE` characters, so that an error quoting
/// a huge input line stays short.
pub fn shorten_lines(message: &str) -> String {
    message
        .lines()
        .map(|l| match l.char_indices().nth(MAX_QUOTED_LINE) {
            Some((cut, _)) => format!("{}…", &l[..cut]),
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Parse TOML text into a table; `origin` names the source in error messages.
pub fn parse_toml(text: &str, origin: &str) -> Result<Table, ConfigError> {
    text.parse::<Table>().map_err(|e| ConfigError::Toml {
        path: origin.to_string(),
        message: shorten_lines(&e.to_string()),
    })
}

/// Interpret the value part of `--set key=value`: a TOML value if it parses as one, otherwise
/// the bare word as a string (so `--set pivot.mode=clamped` works).
pub fn parse_override_value(raw: &str) -> Value {
    let doc = format!("v = {raw}");
    match doc.parse::<Table>() {
        Ok(mut t) if t.len() == 1 => t.remove("v").unwrap_or_else(|| Value::String(raw.into())),
        _ => Value::String(raw.trim().to_string()),
    }
}

/// Apply one `section.key=value` override to a scene table, creating sections as needed.
pub fn apply_override(table: &mut Table, arg: &str) -> Result<(), ConfigError> {
    let (key, raw) = arg
        .split_once('=')
        .ok_or_else(|| ConfigError::BadOverride {
            arg: arg.to_string(),
            reason: "expected `section.key=value`".into(),
        })?;
    set_key(table, key, parse_override_value(raw)).map_err(|e| match e {
        ConfigError::BadOverride { reason, .. } => ConfigError::BadOverride {
            arg: arg.to_string(),
            reason,
        },
        other => other,
    })
}

/// Set a dotted key of a scene table to a typed value, creating sections as needed (the
/// typed twin of [`apply_override`]: no text is formatted or parsed).
pub fn set_key(table: &mut Table, key: &str, value: Value) -> Result<(), ConfigError> {
    let bad = |reason: &str| ConfigError::BadOverride {
        arg: format!("{key}={value}"),
        reason: reason.to_string(),
    };
    let key = key.trim();
    if key.is_empty() || key.split('.').any(|p| p.trim().is_empty()) {
        return Err(bad("the key is empty or has an empty part"));
    }
    let parts: Vec<&str> = key.split('.').map(str::trim).collect();
    let (leaf, sections) = parts.split_last().expect("non-empty key");
    let mut cursor = table;
    for (depth, section) in sections.iter().enumerate() {
        let entry = cursor
            .entry(section.to_string())
            .or_insert_with(|| Value::Table(Table::new()));
        cursor = match entry {
            Value::Table(t) => t,
            _ => {
                return Err(bad(&format!(
                    "`{}` is a value, not a section",
                    parts[..=depth].join(".")
                )));
            }
        };
    }
    cursor.insert(leaf.to_string(), value);
    Ok(())
}

/// The dotted keys of every value (not section) in `table`.
pub(crate) fn leaf_keys(table: &Table) -> BTreeSet<String> {
    fn walk(t: &Table, prefix: &str, out: &mut BTreeSet<String>) {
        for (k, v) in t {
            let key = if prefix.is_empty() {
                k.clone()
            } else {
                format!("{prefix}.{k}")
            };
            match v {
                Value::Table(inner) => walk(inner, &key, out),
                _ => {
                    out.insert(key);
                }
            }
        }
    }
    let mut out = BTreeSet::new();
    walk(table, "", &mut out);
    out
}

/// The whole numbers from `lo` to `hi` in words, an end at the type's limit left open.
fn integer_range(lo: i64, hi: i64) -> String {
    match (lo == i64::MIN, hi == i64::MAX) {
        (true, true) => "any whole number".into(),
        (false, true) => format!("whole numbers from {lo} up"),
        (true, false) => format!("whole numbers up to {hi}"),
        (false, false) => format!("integers in [{lo}, {hi}]"),
    }
}

/// A human description of a TOML value, for type errors.
fn describe(v: &Value) -> String {
    match v {
        Value::String(s) => format!("a string \"{s}\""),
        Value::Integer(i) => format!("an integer {i}"),
        Value::Float(f) => format!("a number {}", num(*f)),
        Value::Boolean(b) => format!("a boolean {b}"),
        Value::Datetime(d) => format!("a date {d}"),
        Value::Array(_) => "an array".into(),
        Value::Table(_) => "a section".into(),
    }
}

/// An accepted numeric range, used both to check a value and to describe the range in errors.
#[derive(Debug, Clone, Copy)]
pub enum Range {
    /// Any finite number.
    Any,
    /// Strictly positive.
    Positive,
    /// Zero or positive.
    NonNegative,
    /// Open interval (lo, hi).
    Open(f64, f64),
    /// Half-open interval [lo, hi).
    ClosedOpen(f64, f64),
    /// Closed interval [lo, hi].
    Closed(f64, f64),
    /// Half-open interval (lo, hi].
    OpenClosed(f64, f64),
}

impl Range {
    fn contains(self, x: f64) -> bool {
        match self {
            Range::Any => true,
            Range::Positive => x > 0.0,
            Range::NonNegative => x >= 0.0,
            Range::Open(a, b) => x > a && x < b,
            Range::ClosedOpen(a, b) => x >= a && x < b,
            Range::Closed(a, b) => x >= a && x <= b,
            Range::OpenClosed(a, b) => x > a && x <= b,
        }
    }

    fn describe(self, unit: &str) -> String {
        let u = if unit.is_empty() {
            String::new()
        } else {
            format!(" {unit}")
        };
        match self {
            Range::Any => format!("any finite number{u}"),
            Range::Positive => format!("> 0{u}"),
            Range::NonNegative => format!(">= 0{u}"),
            Range::Open(a, b) => format!("({}, {}){u}", num(a), num(b)),
            Range::ClosedOpen(a, b) => format!("[{}, {}){u}", num(a), num(b)),
            Range::Closed(a, b) => format!("[{}, {}]{u}", num(a), num(b)),
            Range::OpenClosed(a, b) => format!("({}, {}]{u}", num(a), num(b)),
        }
    }
}

/// Reads typed keys from a scene table and remembers which ones were read.
pub struct Reader {
    table: Table,
    used: BTreeSet<String>,
    notes: Vec<String>,
    defaults: BTreeSet<String>,
}

impl Reader {
    /// Wrap a parsed (and overridden) scene table.
    pub fn new(table: Table) -> Self {
        Reader {
            table,
            used: BTreeSet::new(),
            notes: Vec::new(),
            defaults: BTreeSet::new(),
        }
    }

    /// Wrap a table whose keys `defaults` come from the embedded default scene, not from the
    /// user: [`Reader::given`] does not count them.
    pub(crate) fn with_defaults(table: Table, defaults: BTreeSet<String>) -> Self {
        Reader {
            defaults,
            ..Reader::new(table)
        }
    }

    /// Whether the user gave `key` (in their scene file or a `--set`), not the default scene.
    pub fn given(&mut self, key: &str) -> Result<bool, ConfigError> {
        Ok(self.raw(key)?.is_some() && !self.defaults.contains(key))
    }

    /// Record a remark for the user (a key given but not used, say).
    pub fn note(&mut self, text: String) {
        self.notes.push(text);
    }

    /// The remarks recorded so far.
    pub(crate) fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    /// The raw value at a dotted key, marking the key as known.
    pub fn raw(&mut self, key: &str) -> Result<Option<&Value>, ConfigError> {
        self.used.insert(key.to_string());
        let mut cursor = &self.table;
        let parts: Vec<&str> = key.split('.').collect();
        for (i, part) in parts.iter().enumerate() {
            match cursor.get(*part) {
                None => return Ok(None),
                Some(v) if i + 1 == parts.len() => return Ok(Some(v)),
                Some(Value::Table(t)) => cursor = t,
                Some(other) => {
                    return Err(ConfigError::WrongType {
                        key: parts[..=i].join("."),
                        expected: "a section".into(),
                        found: describe(other),
                    });
                }
            }
        }
        Ok(None)
    }

    /// A finite number in `range`, or `default` when the key is absent.
    pub fn number(
        &mut self,
        key: &str,
        default: f64,
        range: Range,
        unit: &str,
    ) -> Result<f64, ConfigError> {
        let x = match self.raw(key)? {
            None => default,
            Some(v) => number_of(key, v, unit)?,
        };
        check_range(key, x, range, unit)?;
        Ok(x)
    }

    /// An optional number (absent → `None`), checked like [`Reader::number`].
    pub fn number_opt(
        &mut self,
        key: &str,
        range: Range,
        unit: &str,
    ) -> Result<Option<f64>, ConfigError> {
        match self.raw(key)? {
            None => Ok(None),
            Some(v) => {
                let x = number_of(key, v, unit)?;
                check_range(key, x, range, unit)?;
                Ok(Some(x))
            }
        }
    }

    /// A non-negative integer in `[lo, hi]`.
    pub fn integer(
        &mut self,
        key: &str,
        default: i64,
        lo: i64,
        hi: i64,
    ) -> Result<i64, ConfigError> {
        let n = match self.raw(key)? {
            None => default,
            Some(Value::Integer(i)) => *i,
            Some(other) => {
                return Err(ConfigError::WrongType {
                    key: key.into(),
                    expected: "an integer".into(),
                    found: describe(other),
                });
            }
        };
        if n < lo || n > hi {
            return Err(ConfigError::OutOfRange {
                key: key.into(),
                value: n as f64,
                range: integer_range(lo, hi),
            });
        }
        Ok(n)
    }

    /// A boolean.
    pub fn boolean(&mut self, key: &str, default: bool) -> Result<bool, ConfigError> {
        match self.raw(key)? {
            None => Ok(default),
            Some(Value::Boolean(b)) => Ok(*b),
            Some(other) => Err(ConfigError::WrongType {
                key: key.into(),
                expected: "true or false".into(),
                found: describe(other),
            }),
        }
    }

    /// One of a fixed set of words.
    pub fn choice(
        &mut self,
        key: &str,
        default: &str,
        choices: &[&str],
    ) -> Result<String, ConfigError> {
        let s = match self.raw(key)? {
            None => default.to_string(),
            Some(Value::String(s)) => s.clone(),
            Some(other) => {
                return Err(ConfigError::WrongType {
                    key: key.into(),
                    expected: format!("one of {}", quote_all(choices)),
                    found: describe(other),
                });
            }
        };
        if choices.contains(&s.as_str()) {
            Ok(s)
        } else {
            Err(ConfigError::BadChoice {
                key: key.into(),
                value: s,
                choices: quote_all(choices),
            })
        }
    }

    /// After every section has been read: fail on the first key nobody read.
    pub fn finish(self) -> Result<(), ConfigError> {
        let mut leaves = Vec::new();
        collect_leaves(&self.table, "", &mut leaves);
        for leaf in leaves {
            if !self.used.contains(&leaf) {
                let suggestion = self
                    .used
                    .iter()
                    .map(|k| (strsim::damerau_levenshtein(k, &leaf), k))
                    .filter(|(d, _)| *d <= 3)
                    .min()
                    .map(|(_, k)| k.clone());
                return Err(ConfigError::UnknownKey {
                    key: leaf,
                    suggestion,
                });
            }
        }
        Ok(())
    }
}

fn quote_all(choices: &[&str]) -> String {
    choices
        .iter()
        .map(|c| format!("\"{c}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

fn number_of(key: &str, v: &Value, unit: &str) -> Result<f64, ConfigError> {
    let x = match v {
        Value::Float(f) => *f,
        Value::Integer(i) => *i as f64,
        other => {
            return Err(ConfigError::WrongType {
                key: key.into(),
                expected: if unit.is_empty() {
                    "a number".into()
                } else {
                    format!("a number ({unit})")
                },
                found: describe(other),
            });
        }
    };
    if !x.is_finite() {
        return Err(ConfigError::NotFinite {
            key: key.into(),
            value: x,
        });
    }
    Ok(x)
}

fn check_range(key: &str, x: f64, range: Range, unit: &str) -> Result<(), ConfigError> {
    if !x.is_finite() {
        return Err(ConfigError::NotFinite {
            key: key.into(),
            value: x,
        });
    }
    if range.contains(x) {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            key: key.into(),
            value: x,
            range: range.describe(unit),
        })
    }
}

fn collect_leaves(t: &Table, prefix: &str, out: &mut Vec<String>) {
    for (k, v) in t {
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            Value::Table(sub) if !sub.is_empty() => collect_leaves(sub, &path, out),
            _ => out.push(path),
        }
    }
}

//! Numbers, shapes and damaged files as messages show them to people: never 300 digits,
//! never Rust's Debug form (`Some([7, 3])`), never serde's names of our types.

/// `x` for a message: as written between 1e-4 and 1e15 in magnitude (and 0), in exponent form
/// beyond (`1e300`, not 301 digits; `1e-300`, not 300 zeros), `inf`/`-inf`/`NaN` as words.
pub fn num(x: f64) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else if x == 0.0 || (1e-4..1e15).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// An array's shape for a message: `7 × 3` (`a single value` for no axes).
pub fn shape(dims: &[usize]) -> String {
    if dims.is_empty() {
        return "a single value".into();
    }
    dims.iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(" × ")
}

/// Why a JSON file of ours does not read, in words: where it stops being JSON, or that its
/// fields are not ours (never serde's names of our types).
pub fn json_damage(name: &str, e: &serde_json::Error) -> String {
    use serde_json::error::Category;
    let at = if e.line() == 0 {
        "in its fields".to_string()
    } else {
        format!("line {}, column {}", e.line(), e.column())
    };
    match e.classify() {
        Category::Io | Category::Syntax | Category::Eof => {
            format!("{name} is not complete JSON ({at}): the file is damaged")
        }
        Category::Data => format!(
            "{name} does not hold the fields this version writes ({}): it is damaged or from another version; rerun what wrote it",
            serde_words(&e.to_string())
        ),
    }
}

/// serde's account of a value it refused, with the names of Rust's types put in words:
/// `expected usize` reads `expected a whole number from 0`, `expected struct Manifest`
/// reads `expected a table of fields`.
fn serde_words(message: &str) -> String {
    const TYPES: [(&str, &str); 9] = [
        ("usize", "a whole number from 0"),
        ("u64", "a whole number from 0"),
        ("u32", "a whole number from 0"),
        ("u16", "a whole number from 0"),
        ("u8", "a whole number from 0"),
        ("i64", "a whole number"),
        ("i32", "a whole number"),
        ("f64", "a number"),
        ("f32", "a number"),
    ];
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.find("expected ") {
        let (before, after) = rest.split_at(at + "expected ".len());
        out.push_str(before);
        let word_end = after
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(after.len());
        let (word, tail) = after.split_at(word_end);
        rest = match (word, TYPES.iter().find(|(t, _)| *t == word)) {
            (_, Some((_, words))) => {
                out.push_str(words);
                tail
            }
            ("struct" | "enum", None) => {
                out.push_str(if word == "struct" {
                    "a table of fields"
                } else {
                    "one of the names this version writes"
                });
                let name = tail.trim_start();
                let end = name
                    .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .unwrap_or(name.len());
                &name[end..]
            }
            _ => after,
        };
    }
    out.push_str(rest);
    out
}

/// `s` safe to print on a terminal: its control characters (C0 but the newline, DEL, C1) and
/// the bidirectional overrides written as escapes (`\u{1b}`, `\0`), so that an input quoted
/// in a message (a CSV cell, a key, a file name) cannot retitle, clear or move the terminal or
/// reorder what it shows. Every message the CLI and the Python package print passes here.
pub fn printable(s: &str) -> String {
    let unsafe_char = |c: char| {
        (c != '\n' && c.is_control())
            || ('\u{202a}'..='\u{202e}').contains(&c)
            || ('\u{2066}'..='\u{2069}').contains(&c)
    };
    if !s.chars().any(unsafe_char) {
        return s.to_string();
    }
    s.chars()
        .map(|c| match unsafe_char(c) {
            true => c.escape_unicode().to_string(),
            false => c.to_string(),
        })
        .collect()
}

/// A byte count for people: "1.2 GB".
pub fn bytes(n: u64) -> String {
    const UNITS: [&str; 5] = ["B", "kB", "MB", "GB", "TB"];
    let mut v = n as f64;
    let mut unit = 0;
    while v >= 1000.0 && unit + 1 < UNITS.len() {
        v /= 1000.0;
        unit += 1;
    }
    if unit == 0 {
        format!("{n} B")
    } else {
        format!("{v:.1} {}", UNITS[unit])
    }
}

/// `seconds` in the largest unit that keeps it readable: `42 s`, `12 min`, `3.2 h`, `4.1 d`.
pub fn duration(seconds: f64) -> String {
    match seconds {
        s if s < 120.0 => format!("{s:.0} s"),
        s if s < 7200.0 => format!("{:.0} min", s / 60.0),
        s if s < 172_800.0 => format!("{:.1} h", s / 3600.0),
        s => format!("{:.1} d", s / 86_400.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_are_printed_as_escapes() {
        assert_eq!(
            printable("cell `\u{1b}]0;owned\u{7}` and \u{1b}[2J\0"),
            "cell `\\u{1b}]0;owned\\u{7}` and \\u{1b}[2J\\u{0}"
        );
        assert_eq!(printable("a\nb ± é"), "a\nb ± é");
        assert_eq!(printable("x\u{202e}y\u{9b}"), "x\\u{202e}y\\u{9b}");
    }

    #[test]
    fn serde_names_of_rust_types_read_as_words() {
        assert_eq!(
            serde_words("invalid value: integer `-1`, expected usize at line 1 column 14"),
            "invalid value: integer `-1`, expected a whole number from 0 at line 1 column 14"
        );
        assert_eq!(
            serde_words("invalid type: string \"a\", expected struct ShardManifest"),
            "invalid type: string \"a\", expected a table of fields"
        );
        assert_eq!(
            serde_words("invalid type: null, expected f64"),
            "invalid type: null, expected a number"
        );
        assert_eq!(
            serde_words("invalid length 2, expected a sequence"),
            "invalid length 2, expected a sequence"
        );
    }

    #[test]
    fn durations_read_in_the_unit_that_fits() {
        assert_eq!(duration(42.0), "42 s");
        assert_eq!(duration(720.0), "12 min");
        assert_eq!(duration(3.2 * 3600.0), "3.2 h");
        assert_eq!(duration(4.1 * 86_400.0), "4.1 d");
    }

    #[test]
    fn numbers_stay_short_at_every_magnitude() {
        assert_eq!(num(8.0), "8");
        assert_eq!(num(0.35), "0.35");
        assert_eq!(num(0.0), "0");
        assert_eq!(num(1e300), "1e300");
        assert_eq!(num(-1e-300), "-1e-300");
        assert_eq!(num(f64::MAX), "1.7976931348623157e308");
        assert_eq!(num(f64::INFINITY), "inf");
        assert_eq!(num(f64::NAN), "NaN");
    }

    #[test]
    fn shapes_read_as_dimensions() {
        assert_eq!(shape(&[7, 3]), "7 × 3");
        assert_eq!(shape(&[12]), "12");
        assert_eq!(shape(&[]), "a single value");
    }
}

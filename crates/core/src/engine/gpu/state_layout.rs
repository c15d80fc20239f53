//! Where an invocation keeps its working arrays (`gpu.layout`):
//!
//! - [`StateLayout::Private`]: in `var<private>` arrays, as `common.wgsl` and `imex.wgsl`
//!   declare them (about 29 N words at N = 17, far more than a thread's registers on a GPU,
//!   so the compiler spills them to local memory);
//! - [`StateLayout::Global`]: in one storage buffer (`work`, binding 12), structure of arrays:
//!   word k of instance i at `k · n_inst + i`, so that the invocations of a warp touch
//!   neighbouring words (coalesced).
//!
//! The global source is made from the private one by [`globalise`]: each declaration
//! `var<private> X: array<f32, MAX_SEG>;` (or `array<array<f32, MAX_SEG>, R>`) is removed and
//! gets an offset in the work buffer, and each access `X[e]` (`X[r][e]`) becomes
//! `work[gw(X_OFF + e)]` (`work[gw(X_OFF + r · MAX_SEG + e)]`). The arithmetic is the same
//! operation for operation: RK4 gives the same results bit for bit, and the IMEX method the
//! same to f32 rounding (the compiler may fuse a·b + c differently in the two kernels).
//!
//! `gpu.layout = "auto"` ([`LayoutChoice::Auto`]) takes [`StateLayout::Private`] on every
//! adapter: it is the layout measured faster on both adapters the engine has run on, lavapipe
//! (16.5×) and an NVIDIA H100 (global at 0.39–0.88 of private's rate in all 29 rows measured
//! in both; `docs/model.md` §14, `docs/bench/gpu/nvidia-h100-80gb-hbm3/`).

pub use crate::config::LayoutChoice;
use serde::{Deserialize, Serialize};

/// Where the working arrays live, as the kernels are compiled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StateLayout {
    /// `var<private>` arrays.
    Private,
    /// A structure-of-arrays storage buffer.
    Global,
}

/// The layout `choice` (a map's `gpu.layout`) compiles to: `auto` is private (see the
/// module's documentation).
pub fn resolve(choice: LayoutChoice) -> StateLayout {
    match choice {
        LayoutChoice::Auto | LayoutChoice::Private => StateLayout::Private,
        LayoutChoice::Global => StateLayout::Global,
    }
}

impl StateLayout {
    /// `private` or `global`.
    pub fn name(self) -> &'static str {
        match self {
            StateLayout::Private => "private",
            StateLayout::Global => "global",
        }
    }
}

/// One working array of the private source: its name, rows of `MAX_SEG` words, and its
/// offset (in rows of `MAX_SEG`) in the work buffer.
#[derive(Debug, Clone, PartialEq)]
struct WorkArray {
    name: String,
    rows: usize,
    offset: usize,
}

/// The working arrays declared in `source` (`var<private> X: array<f32, MAX_SEG>;` or
/// `var<private> X: array<array<f32, MAX_SEG>, R>;`), in order, with their offsets.
fn work_arrays(source: &str) -> Vec<WorkArray> {
    let mut arrays = Vec::new();
    let mut offset = 0;
    for line in source.lines() {
        let Some(rest) = line.trim().strip_prefix("var<private> ") else {
            continue;
        };
        let Some((name, ty)) = rest.split_once(':') else {
            continue;
        };
        let ty = ty.split(';').next().unwrap_or("").trim();
        let rows = if ty == "array<f32, MAX_SEG>" {
            1
        } else if let Some(r) = ty
            .strip_prefix("array<array<f32, MAX_SEG>, ")
            .and_then(|t| t.strip_suffix('>'))
        {
            match r.trim().parse() {
                Ok(r) => r,
                Err(_) => continue,
            }
        } else {
            continue;
        };
        arrays.push(WorkArray {
            name: name.trim().to_string(),
            rows,
            offset,
        });
        offset += rows;
    }
    arrays
}

/// Rows of `MAX_SEG` words one instance takes in the work buffer.
pub fn work_rows(private_source: &str) -> usize {
    work_arrays(private_source).iter().map(|a| a.rows).sum()
}

/// The bracketed expression that opens at `src[open]` (a `[`): its text and the index after
/// its closing `]`.
fn bracketed(src: &str, open: usize) -> Option<(&str, usize)> {
    let mut depth = 0usize;
    for (k, ch) in src[open..].char_indices() {
        match ch {
            '[' => depth += 1,
            ']' => {
                depth -= 1;
                if depth == 0 {
                    return Some((&src[open + 1..open + k], open + k + 1));
                }
            }
            _ => {}
        }
    }
    None
}

fn is_ident(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

/// The global-layout source of `source` (see the module's documentation). `entries` are the
/// lines that name an entry point's instance (`let inst = …;`): `G_INST` is set after each.
pub fn globalise(source: &str, entries: &[&str]) -> String {
    let arrays = work_arrays(source);
    let mut out = drop_declarations(&rewrite(source, &arrays), &arrays);
    for line in entries {
        out = out.replace(line, &format!("{line}\n    G_INST = inst;"));
    }
    out
}

/// `src` with every access to one of `arrays` turned into a work-buffer word.
fn rewrite(src: &str, arrays: &[WorkArray]) -> String {
    let mut out = String::with_capacity(src.len() + src.len() / 4);
    let mut i = 0;
    while i < src.len() {
        let rest = &src[i..];
        let ch = rest.chars().next().expect("inside the source");
        let starts_word = is_ident(ch) && !src[..i].ends_with(|c: char| is_ident(c) || c == '.');
        if !starts_word {
            out.push(ch);
            i += ch.len_utf8();
            continue;
        }
        let word_len = rest.find(|c: char| !is_ident(c)).unwrap_or(rest.len());
        let word = &rest[..word_len];
        i += word_len;
        let Some(a) = arrays.iter().find(|a| a.name == word) else {
            out.push_str(word);
            continue;
        };
        let Some((first, next)) = src[i..]
            .starts_with('[')
            .then(|| bracketed(src, i))
            .flatten()
        else {
            out.push_str(word);
            continue;
        };
        let first = rewrite(first, arrays);
        i = next;
        let second = if a.rows > 1 && src[i..].starts_with('[') {
            bracketed(src, i).map(|(e, end)| {
                i = end;
                rewrite(e, arrays)
            })
        } else {
            None
        };
        let word_index = match second {
            Some(second) => format!("{}u * MAX_SEG + ({first}) * MAX_SEG + ({second})", a.offset),
            None => format!("{}u * MAX_SEG + ({first})", a.offset),
        };
        out.push_str(&format!("work[gw({word_index})]"));
    }
    out
}

/// The source without the working arrays' declarations, and with the work buffer's binding
/// and index function in their place.
fn drop_declarations(source: &str, arrays: &[WorkArray]) -> String {
    let mut out = String::with_capacity(source.len());
    let mut placed = false;
    for line in source.lines() {
        let declared = line
            .trim()
            .strip_prefix("var<private> ")
            .and_then(|r| r.split_once(':'))
            .is_some_and(|(name, _)| arrays.iter().any(|a| a.name == name.trim()));
        if declared {
            if !placed {
                out.push_str(WORK_DECLARATIONS);
                placed = true;
            }
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// The work buffer and its index: word k of the invocation's instance.
const WORK_DECLARATIONS: &str = "\
// Global layout: the working arrays in one storage buffer, word k of instance i at k·n_inst + i.
@group(0) @binding(12) var<storage, read_write> work: array<f32>;
var<private> G_INST: u32;
fn gw(k: u32) -> u32 {
    return k * ctl.n_inst + G_INST;
}
";

#[cfg(test)]
mod tests {
    use super::*;

    const SRC: &str = "\
var<private> P: InstanceParams;
var<private> th: array<f32, MAX_SEG>; // θ
var<private> f_th: array<array<f32, MAX_SEG>, 4>;
var<private> volt: f32;
fn f(inst: u32) {
    let inst = live[gid.x];
    th[i + 1u] = f_th[s][th_idx[i]] + P.th[0] + sth[0];
}
";

    #[test]
    fn the_working_arrays_are_found_with_their_offsets() {
        let a = work_arrays(SRC);
        assert_eq!(a.len(), 2);
        assert_eq!((a[0].name.as_str(), a[0].rows, a[0].offset), ("th", 1, 0));
        assert_eq!((a[1].name.as_str(), a[1].rows, a[1].offset), ("f_th", 4, 1));
        assert_eq!(work_rows(SRC), 5);
    }

    #[test]
    fn accesses_become_work_buffer_words_and_nothing_else_changes() {
        let g = globalise(SRC, &["let inst = live[gid.x];"]);
        assert!(!g.contains("var<private> th:") && !g.contains("var<private> f_th:"));
        assert!(g.contains("var<private> P: InstanceParams;"));
        assert!(g.contains("var<private> volt: f32;"));
        assert!(g.contains("@binding(12) var<storage, read_write> work"));
        assert!(g.contains("work[gw(0u * MAX_SEG + (i + 1u))] ="), "{g}");
        // A two-row access; an identifier that only starts like an array (th_idx) and a
        // struct field of the same name (P.th) are left alone; an array read inside an index.
        assert!(
            g.contains("work[gw(1u * MAX_SEG + (s) * MAX_SEG + (th_idx[i]))]"),
            "{g}"
        );
        assert!(g.contains("P.th[0]") && g.contains("sth[0]"), "{g}");
        assert!(
            g.contains("let inst = live[gid.x];\n    G_INST = inst;"),
            "{g}"
        );
    }
}

//! Scalar rules written once, in the subset of Rust that is also WGSL.
//!
//! A decision such as "a try of error `e` at level `k` is rejected" or "this sample entered the
//! other well" is a few comparisons on scalars. The CPU engine and the analysis library run it
//! as Rust; the GPU kernels need it as WGSL. `shared_rules!` defines such functions once: it
//! compiles each one as a Rust function of its module and keeps its source text, which is also
//! a WGSL function (`crate::engine::gpu::codegen` writes it into the kernels' header). So
//! there is one definition, and the kernel runs the same comparisons in the same order as the
//! CPU engine, in `f32` where the CPU engine uses `f64`.
//!
//! The subset both languages read the same way:
//!
//! - `fn name(arg: T, …) -> T { … }` with `T` one of `bool`, `i32`, `u32` and [`Float`]
//!   (`f64` in Rust, `f32` in WGSL: the header declares `alias Float = f32;`);
//! - `let` bindings (never shadowed: WGSL forbids redeclaring a name in one scope), `if` /
//!   `else if` / `else`, and `return …;` on every path, the last one included;
//! - arithmetic, comparisons, `&&`, `||`, `!`, `%`, `<<`, `>>`, and integer literals without
//!   a suffix (WGSL reads them as abstract integers, Rust infers their type);
//! - calls of other rules, of constants both sides define under one name (the header's, from
//!   the same Rust constants), and of the functions below, which each language has under these
//!   names: [`abs`], [`max`], [`min`], [`is_nan`], [`is_finite`].
//!
//! No methods, casts, loops, structs or references, and no name WGSL reserves (`class`,
//! `type`, …): anything else fails to compile as WGSL, and the kernels are compiled (and
//! validated by naga) in every test run. A rule that relies on a NaN says so with [`is_nan`]
//! or [`is_finite`], which read the bits in WGSL; `max` and `min` of a NaN are not defined
//! there. Adding a rule: write it in a `shared_rules!` block of the module it belongs to, call
//! it from the Rust there and from the stage file, and, where it is a new module's first, add
//! that module's `RULES` to `codegen::shared_rules`.

/// The floating type of a rule: `f64` in Rust, `f32` in the kernels.
pub type Float = f64;

/// `|x|` (WGSL's `abs`).
pub fn abs(x: Float) -> Float {
    x.abs()
}

/// The larger of two values (WGSL's `max`; for floats a NaN is passed over, which WGSL does
/// not promise: a rule tests [`is_nan`] first where it matters).
pub fn max<T: Extremum>(a: T, b: T) -> T {
    a.larger(b)
}

/// The smaller of two values (WGSL's `min`; a NaN as in [`max`]).
pub fn min<T: Extremum>(a: T, b: T) -> T {
    a.smaller(b)
}

/// Whether `x` is a NaN (in the kernels from its bits, which no optimiser may assume away).
pub fn is_nan(x: Float) -> bool {
    x.is_nan()
}

/// Whether `x` is neither infinite nor NaN (in the kernels from its bits).
pub fn is_finite(x: Float) -> bool {
    x.is_finite()
}

/// The types [`max`] and [`min`] take.
pub trait Extremum: Copy {
    /// The larger of `self` and `b`.
    fn larger(self, b: Self) -> Self;
    /// The smaller of `self` and `b`.
    fn smaller(self, b: Self) -> Self;
}

impl Extremum for f64 {
    fn larger(self, b: f64) -> f64 {
        self.max(b)
    }
    fn smaller(self, b: f64) -> f64 {
        self.min(b)
    }
}

impl Extremum for u32 {
    fn larger(self, b: u32) -> u32 {
        Ord::max(self, b)
    }
    fn smaller(self, b: u32) -> u32 {
        Ord::min(self, b)
    }
}

impl Extremum for i32 {
    fn larger(self, b: i32) -> i32 {
        Ord::max(self, b)
    }
    fn smaller(self, b: i32) -> i32 {
        Ord::min(self, b)
    }
}

/// The WGSL names of the functions above that WGSL lacks, and the type alias, for the
/// kernels' header.
pub const WGSL_PRELUDE: &str = "\
// The names the shared rules (src/rules.rs) and the stage files use: Float, and is_nan and
// is_finite read from the bits (WGSL lets an implementation assume that no float is NaN, so a
// comparison such as `x != x` or `!(x > 0.0)` cannot be trusted to catch one).
alias Float = f32;
fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}
";

/// One rule: its name, its Rust module, and its source, which is also its WGSL.
#[derive(Debug)]
pub struct Rule {
    /// The function's name (the same in both languages).
    pub name: &'static str,
    /// The Rust module that defines it (`module_path!`).
    pub module: &'static str,
    /// Its doc comment's lines.
    pub doc: &'static [&'static str],
    /// Its parameters, as (name, type).
    pub args: &'static [(&'static str, &'static str)],
    /// Its result type.
    pub ret: &'static str,
    /// Its body as `stringify!` gives it (one block).
    pub body: &'static str,
}

impl Rule {
    /// The rule as a WGSL function, its doc comment above it.
    pub fn wgsl(&self) -> String {
        let mut out = String::new();
        for line in self.doc {
            out.push_str("//");
            if !line.is_empty() {
                out.push(' ');
                out.push_str(line.trim());
            }
            out.push('\n');
        }
        let args: Vec<String> = self.args.iter().map(|(a, t)| format!("{a}: {t}")).collect();
        out.push_str(&format!(
            "fn {}({}) -> {} {}",
            self.name,
            args.join(", "),
            self.ret,
            layout(self.body)
        ));
        out
    }
}

/// A block's text laid out a statement a line, four spaces a level: the whitespace of
/// `stringify!` collapsed, a line broken after `{` and `;` and around `}` (`} else` kept on
/// one line).
fn layout(block: &str) -> String {
    let flat = block.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut out = String::new();
    let mut line = String::new();
    let mut depth = 0usize;
    let flush = |out: &mut String, line: &mut String, depth: usize| {
        let text = line.trim();
        if !text.is_empty() {
            out.push_str(&"    ".repeat(depth));
            out.push_str(text);
            out.push('\n');
        }
        line.clear();
    };
    for (i, c) in flat.char_indices() {
        match c {
            '{' => {
                line.push('{');
                flush(&mut out, &mut line, depth);
                depth += 1;
            }
            ';' => {
                line.push(';');
                flush(&mut out, &mut line, depth);
            }
            '}' => {
                flush(&mut out, &mut line, depth);
                depth = depth.saturating_sub(1);
                line.push('}');
                if !flat[i + 1..].trim_start().starts_with("else") {
                    flush(&mut out, &mut line, depth);
                }
            }
            _ => line.push(c),
        }
    }
    flush(&mut out, &mut line, 0);
    out
}

/// Define rules once for Rust and WGSL (see the module doc): each `fn` becomes a Rust
/// function of the calling module, with the visibility written, and `RULES` lists them with
/// their source.
macro_rules! shared_rules {
    ($(
        $(#[doc = $doc:literal])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ident),* $(,)?) -> $ret:ident $body:block
    )*) => {
        $(
            $(#[doc = $doc])*
            // The WGSL-compatible form: an explicit return, operators rather than methods.
            #[allow(clippy::needless_return, clippy::manual_is_multiple_of)]
            $vis fn $name($($arg: $ty),*) -> $ret $body
        )*

        /// The rules above with their source, for the kernels' header.
        pub(crate) const RULES: &[$crate::rules::Rule] = &[$(
            $crate::rules::Rule {
                name: stringify!($name),
                module: module_path!(),
                doc: &[$($doc),*],
                args: &[$((stringify!($arg), stringify!($ty))),*],
                ret: stringify!($ret),
                body: stringify!($body),
            }
        ),*];
    };
}
pub(crate) use shared_rules;

#[cfg(test)]
mod tests {
    use super::*;

    const LIMIT: u32 = 4;

    shared_rules! {
        /// Which side of ±`half` x is on.
        fn side_of(x: Float, half: Float) -> i32 {
            if x > half {
                return 1;
            } else if x < -half {
                return -1;
            }
            return 0;
        }

        /// Below the limit.
        fn below(k: u32) -> bool {
            return k < LIMIT && max(k, 2) == k;
        }
    }

    #[test]
    fn a_rule_runs_as_rust_and_reads_as_wgsl() {
        assert_eq!((side_of(0.3, 0.1), side_of(-0.3, 0.1)), (1, -1));
        assert_eq!(side_of(f64::NAN, 0.1), 0);
        assert!(below(3) && !below(4) && !below(1));
        assert_eq!(RULES.len(), 2);
        assert_eq!(
            RULES[0].wgsl(),
            "// Which side of ±`half` x is on.\n\
             fn side_of(x: Float, half: Float) -> i32 {\n\
             \x20   if x > half {\n\
             \x20       return 1;\n\
             \x20   } else if x < -half {\n\
             \x20       return -1;\n\
             \x20   }\n\
             \x20   return 0;\n\
             }\n"
        );
        assert!(
            RULES[1]
                .wgsl()
                .contains("    return k < LIMIT && max(k, 2) == k;\n")
        );
        assert!(RULES[1].module.ends_with("rules::tests"));
    }

    #[test]
    fn min_and_max_pass_a_nan_over_as_rust_does() {
        assert_eq!(max(f64::NAN, 1.0), 1.0);
        assert_eq!(min(2.0, f64::NAN), 2.0);
        assert_eq!((min(3u32, 5), max(-2i32, 7)), (3, 7));
    }
}

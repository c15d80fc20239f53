//! A recorded [`Tape`] written out as a Rust function generic over the lane type
//! ([`crate::model::Lane`]): one `let` per operation the outputs need, in the tape's order,
//! each the lane operation the recorded code did (`+`, `v_sin_cos`, `T::if_positive`, …), so
//! that every lane type computes what the code it was recorded from computes, bit for bit.
//! Constants are `T::splat` of the `f64` the code gave, inputs the expressions they were
//! recorded with (each read once, into its own `let`).

use super::sym::{Bin, Node, Sym, Tape, Un};
use super::wgsl::needed;
use std::collections::HashMap;
use std::fmt::Write;

/// A Rust function made from a tape.
pub(crate) struct Function<'a> {
    /// Doc-comment lines above it (without `/// `).
    pub doc: &'a [&'a str],
    /// `pub(super) fn name<T: Lane>(args) -> ret`.
    pub signature: &'a str,
    /// Lines before the operations (bindings the inputs read), already indented.
    pub preamble: &'a str,
    /// What the function writes: `target = value;`, or `let name = value;` where the target
    /// starts with `let `.
    pub stores: Vec<(String, Sym)>,
    /// Lines after the stores (the value returned), already indented.
    pub tail: &'a str,
}

/// `x` as a Rust `f64` literal that reads back as exactly `x`.
fn literal(x: f64) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else {
        format!("f64::from_bits({:#018x})", x.to_bits())
    }
}

/// How an operand reads: a splatted literal or a `let`'s name.
fn operand(tape: &Tape, s: Sym) -> String {
    match &tape.nodes[s.index()] {
        Node::Const(bits) => format!("T::splat({})", literal(f64::from_bits(*bits))),
        _ => format!("v{}", s.index()),
    }
}

/// Each operand's sine and cosine nodes: one `v_sin_cos` call gives both, as in the code the
/// tape was recorded from.
fn sin_cos_pairs(tape: &Tape) -> HashMap<Sym, [Option<usize>; 2]> {
    let mut pairs: HashMap<Sym, [Option<usize>; 2]> = HashMap::new();
    for (i, node) in tape.nodes.iter().enumerate() {
        if let Node::Un(op @ (Un::Sin | Un::Cos), a) = node {
            pairs.entry(*a).or_default()[usize::from(*op == Un::Cos)] = Some(i);
        }
    }
    pairs
}

/// The `let` of node `i`, or `None` for a constant, or a sine or cosine its pair's `let`
/// already binds.
fn binding(
    tape: &Tape,
    i: usize,
    need: &[bool],
    pairs: &HashMap<Sym, [Option<usize>; 2]>,
) -> Option<String> {
    let o = |s: &Sym| operand(tape, *s);
    let value = match &tape.nodes[i] {
        Node::Const(_) => return None,
        Node::Input(expr) => expr.clone(),
        Node::Un(Un::Neg, a) => format!("-{}", o(a)),
        Node::Un(Un::Sin | Un::Cos, a) => {
            let [sin, cos] = pairs[a];
            if [sin, cos].into_iter().flatten().find(|&j| need[j]) != Some(i) {
                return None;
            }
            let name = |j: Option<usize>| {
                j.filter(|&j| need[j])
                    .map_or("_".into(), |j| format!("v{j}"))
            };
            return Some(format!(
                "let ({}, {}) = {}.v_sin_cos();",
                name(sin),
                name(cos),
                o(a)
            ));
        }
        Node::Bin(Bin::Max, a, b) => format!("{}.v_max({})", o(a), o(b)),
        Node::Bin(op, a, b) => {
            let sign = match op {
                Bin::Add => "+",
                Bin::Sub => "-",
                Bin::Mul => "*",
                Bin::Div => "/",
                Bin::Max => unreachable!("written above"),
            };
            format!("{} {sign} {}", o(a), o(b))
        }
        Node::IfPositive(c, a, b) => format!("T::if_positive({}, {}, {})", o(c), o(a), o(b)),
    };
    Some(format!("let v{i} = {value};"))
}

/// The function's Rust text.
pub(crate) fn emit(tape: &Tape, f: &Function) -> String {
    let mut out = String::new();
    for line in f.doc {
        let _ = writeln!(out, "/// {line}");
    }
    let _ = writeln!(out, "{} {{", f.signature);
    out.push_str(f.preamble);
    let need = needed(tape, &f.stores);
    let pairs = sin_cos_pairs(tape);
    for i in (0..tape.nodes.len()).filter(|&i| need[i]) {
        if let Some(line) = binding(tape, i, &need, &pairs) {
            let _ = writeln!(out, "    {line}");
        }
    }
    for (target, value) in &f.stores {
        let _ = writeln!(out, "    {target} = {};", operand(tape, *value));
    }
    out.push_str(f.tail);
    out.push_str("}\n");
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::codegen::sym::{input, record};
    use crate::model::Lane;

    #[test]
    fn a_sine_and_cosine_of_one_angle_are_one_call_and_constants_keep_f64() {
        let (tape, (s, c, k)) = record(|| {
            let x = input("y[0]");
            let (s, c) = x.v_sin_cos();
            (s, c, x * Sym::splat(0.1))
        });
        let f = Function {
            doc: &["doc"],
            signature: "fn f<T: Lane>(y: &[T]) -> [T; 3]",
            preamble: "",
            stores: vec![
                ("let s".into(), s),
                ("let c".into(), c),
                ("let k".into(), k),
            ],
            tail: "    [s, c, k]\n",
        };
        let text = emit(&tape, &f);
        assert_eq!(text.matches("v_sin_cos").count(), 1, "{text}");
        assert!(text.contains("T::splat(0.1)"), "{text}");
        assert!(text.contains("let v0 = y[0];"), "{text}");
    }
}

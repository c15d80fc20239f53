//! A recorded [`Tape`] written out as a WGSL function: one `let` per operation the outputs
//! need, in the tape's order; constants as exact `f32` literals, inputs as the expressions
//! they were recorded with.

use super::sym::{Bin, Node, Sym, Tape, Un};
use std::fmt::Write;

/// A WGSL function made from a tape.
pub(crate) struct Function<'a> {
    /// Comment lines above it (without `// `).
    pub doc: &'a [&'a str],
    /// `fn name(args) -> ret`.
    pub signature: &'a str,
    /// What the function writes: `target = value;`, or `let name = value;` where the target
    /// starts with `let `.
    pub stores: Vec<(String, Sym)>,
    /// Lines after the stores (a `return`), already indented.
    pub tail: &'a str,
}

/// `x` as a WGSL `f32` literal that reads back as exactly `x`.
fn literal(x: f32) -> String {
    let text = format!("{x:?}");
    let exact = text.parse::<f64>().is_ok_and(|d| d as f32 == x) && x.is_finite();
    let text = if exact {
        format!("{text}f")
    } else {
        format!("bitcast<f32>({:#010x}u)", x.to_bits())
    };
    if x.is_sign_negative() {
        format!("({text})")
    } else {
        text
    }
}

/// The nodes the stores need, marked.
fn needed(tape: &Tape, stores: &[(String, Sym)]) -> Vec<bool> {
    let mut need = vec![false; tape.nodes.len()];
    let mut stack: Vec<Sym> = stores.iter().map(|(_, s)| *s).collect();
    while let Some(s) = stack.pop() {
        if std::mem::replace(&mut need[s.index()], true) {
            continue;
        }
        match &tape.nodes[s.index()] {
            Node::Const(_) | Node::Input(_) => {}
            Node::Un(_, a) => stack.push(*a),
            Node::Bin(_, a, b) => stack.extend([*a, *b]),
            Node::IfPositive(c, a, b) => stack.extend([*c, *a, *b]),
        }
    }
    need
}

/// How an operand reads: a literal, an input's expression or a `let`'s name.
fn operand(tape: &Tape, s: Sym) -> String {
    match &tape.nodes[s.index()] {
        Node::Const(bits) => literal(f32::from_bits(*bits)),
        Node::Input(expr) => expr.clone(),
        _ => format!("v{}", s.index()),
    }
}

/// The expression of an operation node.
fn expression(tape: &Tape, node: &Node) -> Option<String> {
    let o = |s: &Sym| operand(tape, *s);
    Some(match node {
        Node::Const(_) | Node::Input(_) => return None,
        Node::Un(Un::Neg, a) => format!("-{}", o(a)),
        Node::Un(Un::Sin, a) => format!("sin({})", o(a)),
        Node::Un(Un::Cos, a) => format!("cos({})", o(a)),
        Node::Bin(Bin::Max, a, b) => format!("max({}, {})", o(a), o(b)),
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
        Node::IfPositive(c, a, b) => format!("select({}, {}, {} > 0.0f)", o(b), o(a), o(c)),
    })
}

/// The function's WGSL text.
pub(crate) fn emit(tape: &Tape, f: &Function) -> String {
    let mut out = String::new();
    for line in f.doc {
        let _ = writeln!(out, "// {line}");
    }
    let _ = writeln!(out, "{} {{", f.signature);
    body(&mut out, tape, &f.stores, "    ");
    out.push_str(f.tail);
    out.push_str("}\n");
    out
}

/// One part of a function written in parts: a tape and its stores, written once, or in a loop
/// over the segments (`i`) where the tape was recorded on one segment's components.
pub(crate) struct Part {
    pub tape: Tape,
    pub stores: Vec<(String, Sym)>,
    pub per_segment: bool,
}

/// A function of `parts`, in order, with no tail.
pub(crate) fn emit_parts(doc: &[&str], signature: &str, parts: &[Part]) -> String {
    let mut out = String::new();
    for line in doc {
        let _ = writeln!(out, "// {line}");
    }
    let _ = writeln!(out, "{signature} {{");
    for p in parts {
        if p.per_segment {
            out.push_str("    for (var i = 0u; i < N_SEG; i++) {\n");
            body(&mut out, &p.tape, &p.stores, "        ");
            out.push_str("    }\n");
        } else {
            body(&mut out, &p.tape, &p.stores, "    ");
        }
    }
    out.push_str("}\n");
    out
}

/// The `let`s the stores need, then the stores, each line indented by `indent`.
fn body(out: &mut String, tape: &Tape, stores: &[(String, Sym)], indent: &str) {
    let need = needed(tape, stores);
    for (i, node) in tape.nodes.iter().enumerate() {
        if let (true, Some(e)) = (need[i], expression(tape, node)) {
            let _ = writeln!(out, "{indent}let v{i} = {e};");
        }
    }
    for (target, value) in stores {
        let _ = writeln!(out, "{indent}{target} = {};", operand(tape, *value));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::gpu::codegen::sym::{input, record};
    use crate::model::Lane;

    #[test]
    fn literals_read_back_exactly() {
        for x in [0.5f32, 0.1, -2.0, 1e-30, 3.4e38, f32::MIN_POSITIVE / 4.0] {
            let text = literal(x);
            let inner = text.trim_start_matches('(').trim_end_matches(')');
            if let Some(d) = inner.strip_suffix('f') {
                assert_eq!(d.parse::<f64>().unwrap() as f32, x, "{text}");
            } else {
                assert!(inner.starts_with("bitcast"), "{text}");
            }
        }
    }

    #[test]
    fn only_what_the_stores_need_is_written() {
        let (tape, (y, _unused)) = record(|| {
            let x = input("P.k");
            (x * Sym::splat(2.0), x / Sym::splat(3.0))
        });
        let f = Function {
            doc: &["doc"],
            signature: "fn f() -> f32",
            stores: vec![("let y".into(), y)],
            tail: "    return y;\n",
        };
        let text = emit(&tape, &f);
        assert!(text.contains("P.k * 2.0f"), "{text}");
        assert!(!text.contains("3.0f"), "{text}");
    }
}

//! [`Sym`]: a [`Lane`] that records the operations done on it instead of doing them.
//!
//! The chain's Rust code, run on `Sym` inside [`record`], leaves a [`Tape`]: one node per
//! IEEE operation, in the order the code does them, with the inputs it read and the constants
//! it made. The tape is what the WGSL emitter (`super::wgsl`) writes out, so the kernel does
//! the CPU engine's `f32` operations in the CPU engine's order.
//!
//! Identical nodes are recorded once (the same operation on the same operands gives the same
//! value), and the only rewrites are exact ones: `x + 0`, `0 + x`, `x − 0` and `x · 1`, `1 · x`
//! are `x` (up to the sign of a zero sum, which nothing downstream reads), and an operation on
//! two constants is the constant it gives in `f32`.

use crate::model::Lane;
use std::cell::RefCell;
use std::collections::HashMap;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A value of the recorded program: the index of its node on the tape.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Sym(u32);

impl Sym {
    /// Its index on the tape.
    pub(crate) fn index(self) -> usize {
        self.0 as usize
    }
}

/// A binary operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Bin {
    Add,
    Sub,
    Mul,
    Div,
    Max,
}

/// A unary operation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Un {
    Neg,
    Sin,
    Cos,
}

/// One recorded operation.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(crate) enum Node {
    /// An `f32` constant (its bits).
    Const(u32),
    /// An input, by its expression in the kernel (`P.seg_len`, `sth[3]`).
    Input(String),
    Un(Un, Sym),
    Bin(Bin, Sym, Sym),
    /// `if cond > 0 { a } else { b }`.
    IfPositive(Sym, Sym, Sym),
}

/// The recorded program: its nodes, each after its operands.
#[derive(Debug, Default)]
pub struct Tape {
    pub(crate) nodes: Vec<Node>,
    seen: HashMap<Node, Sym>,
}

impl Tape {
    fn push(&mut self, node: Node) -> Sym {
        if let Some(&s) = self.seen.get(&node) {
            return s;
        }
        let s = Sym(self.nodes.len() as u32);
        self.nodes.push(node.clone());
        self.seen.insert(node, s);
        s
    }

    /// Every node's value in `f32`, each input's from `input(expr)`: what the kernel computes
    /// (up to its `sin` and `cos`), evaluated on the CPU to hold the recording against the code
    /// it was recorded from.
    pub fn eval(&self, mut input: impl FnMut(&str) -> f32) -> Vec<f32> {
        let mut v: Vec<f32> = Vec::with_capacity(self.nodes.len());
        for node in &self.nodes {
            let x = match node {
                Node::Const(bits) => f32::from_bits(*bits),
                Node::Input(expr) => input(expr),
                Node::Un(Un::Neg, a) => -v[a.index()],
                Node::Un(Un::Sin, a) => v[a.index()].sin(),
                Node::Un(Un::Cos, a) => v[a.index()].cos(),
                Node::Bin(op, a, b) => fold(*op, v[a.index()], v[b.index()]),
                Node::IfPositive(c, a, b) => {
                    if v[c.index()] > 0.0 {
                        v[a.index()]
                    } else {
                        v[b.index()]
                    }
                }
            };
            v.push(x);
        }
        v
    }

    fn constant(&self, s: Sym) -> Option<f32> {
        match self.nodes[s.index()] {
            Node::Const(bits) => Some(f32::from_bits(bits)),
            _ => None,
        }
    }
}

thread_local! {
    static TAPE: RefCell<Option<Tape>> = const { RefCell::new(None) };
}

/// Run `f` with a fresh tape that its `Sym` operations record onto; the tape and `f`'s
/// result.
pub fn record<R>(f: impl FnOnce() -> R) -> (Tape, R) {
    TAPE.with(|t| {
        let previous = t.borrow_mut().replace(Tape::default());
        assert!(previous.is_none(), "recordings do not nest");
    });
    let out = f();
    let tape = TAPE.with(|t| t.borrow_mut().take()).unwrap_or_default();
    (tape, out)
}

fn with_tape<R>(f: impl FnOnce(&mut Tape) -> R) -> R {
    TAPE.with(|t| {
        let mut t = t.borrow_mut();
        let tape = t
            .as_mut()
            .expect("a symbolic value is used only inside `record`");
        f(tape)
    })
}

/// An input of the program, read in the kernel as `expr`.
pub fn input(expr: impl Into<String>) -> Sym {
    with_tape(|t| t.push(Node::Input(expr.into())))
}

fn constant(x: f32) -> Sym {
    with_tape(|t| t.push(Node::Const(x.to_bits())))
}

fn binary(op: Bin, a: Sym, b: Sym) -> Sym {
    with_tape(|t| {
        let (ca, cb) = (t.constant(a), t.constant(b));
        if let (Some(x), Some(y)) = (ca, cb) {
            return t.push(Node::Const(fold(op, x, y).to_bits()));
        }
        match (op, ca, cb) {
            (Bin::Add | Bin::Sub, _, Some(0.0)) | (Bin::Mul, _, Some(1.0)) => a,
            (Bin::Add, Some(0.0), _) | (Bin::Mul, Some(1.0), _) => b,
            _ => t.push(Node::Bin(op, a, b)),
        }
    })
}

/// `x op y` in `f32`, as the kernel would compute it.
fn fold(op: Bin, x: f32, y: f32) -> f32 {
    match op {
        Bin::Add => x + y,
        Bin::Sub => x - y,
        Bin::Mul => x * y,
        Bin::Div => x / y,
        Bin::Max => x.max(y),
    }
}

fn unary(op: Un, a: Sym) -> Sym {
    with_tape(|t| t.push(Node::Un(op, a)))
}

macro_rules! sym_op {
    ($tr:ident, $f:ident, $atr:ident, $af:ident, $op:expr) => {
        impl $tr for Sym {
            type Output = Sym;
            fn $f(self, rhs: Sym) -> Sym {
                binary($op, self, rhs)
            }
        }
        impl $atr for Sym {
            fn $af(&mut self, rhs: Sym) {
                *self = binary($op, *self, rhs);
            }
        }
    };
}

sym_op!(Add, add, AddAssign, add_assign, Bin::Add);
sym_op!(Sub, sub, SubAssign, sub_assign, Bin::Sub);
sym_op!(Mul, mul, MulAssign, mul_assign, Bin::Mul);

impl Div for Sym {
    type Output = Sym;
    fn div(self, rhs: Sym) -> Sym {
        binary(Bin::Div, self, rhs)
    }
}

impl Neg for Sym {
    type Output = Sym;
    fn neg(self) -> Sym {
        unary(Un::Neg, self)
    }
}

impl Lane for Sym {
    /// The kernels compute in `f32`.
    type Scalar = f32;
    const LANES: usize = 1;
    fn splat(x: f64) -> Self {
        constant(x as f32)
    }
    fn gather(mut f: impl FnMut(usize) -> f64) -> Self {
        constant(f(0) as f32)
    }
    fn lane(self, _: usize) -> f32 {
        unreachable!("a symbolic value has no number until the kernel runs")
    }
    fn with_lane(self, _: usize, _: f32) -> Self {
        unreachable!("a symbolic value has no number until the kernel runs")
    }
    fn v_sin_cos(self) -> (Self, Self) {
        (unary(Un::Sin, self), unary(Un::Cos, self))
    }
    fn v_max(self, y: Self) -> Self {
        binary(Bin::Max, self, y)
    }
    fn if_positive(cond: Self, a: Self, b: Self) -> Self {
        with_tape(|t| t.push(Node::IfPositive(cond, a, b)))
    }
    /// `self · ctl.one` (`ctl.one` = 1, read at run time: [`Lane::opaque`]).
    fn opaque(self) -> Self {
        binary(Bin::Mul, self, input("ctl.one"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_operations_are_recorded_once_and_exact_identities_fold() {
        let (tape, (a, b, c)) = record(|| {
            let x = input("x");
            let y = input("y");
            let a = x * y + Sym::splat(0.0);
            let b = x * y;
            let c = Sym::splat(1.0) * (x - y);
            (a, b, c)
        });
        assert_eq!(a, b);
        // x, y, x·y, x − y, and the constants 0 and 1.
        assert_eq!(tape.nodes.len(), 6, "{:?}", tape.nodes);
        assert!(matches!(tape.nodes[c.index()], Node::Bin(Bin::Sub, _, _)));
    }
}

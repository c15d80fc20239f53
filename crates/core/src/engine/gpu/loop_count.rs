//! Loop iterations counted from the kernels' own code, for lavapipe's loop limit.
//!
//! lavapipe counts every loop iteration of an invocation against one limit and silently ends
//! the loop when it is reached ([`super::buffers`] sizes a dispatch to stay within it). Counts
//! written by hand beside the WGSL go stale when a kernel changes (one once undercounted).
//! Here they are read from the module that runs: the assembled source (header, generated
//! functions, stage files) is parsed by naga, its override constants are given the values of
//! the pipeline, and each function's loops are counted from the IR:
//!
//! ```text
//! loops(block)               = Σ loops(statement)
//! loops(for i in a..b { B }) = t · (1 + loops(B)),  t = b − a (b − a + 1 for ≤), a constant
//! loops(if c { A } else { B }) = loops(A) or loops(B) where c is known, else max of the two
//! loops(call f(x…))          = loops(f) with the arguments known where they are constants
//! ```
//!
//! Trip counts are evaluated as linear forms in the unknowns (`j = abs + 1 − w; j ≤ abs` runs
//! `w` times whatever `abs` is), with the uniform fields a loop bound reads (`ctl.e_p_max`)
//! given by the caller. A `return` or `break` is not followed, so a count is an upper bound.
//! A loop whose trip count is not a constant is an error ([`LoopCountError`]), except in
//! [`LoopCounter::outside_loops`], which leaves out the entry point's run-time loops (the step
//! loop, counted per step by its callees).

use naga::{
    BinaryOperator, Block, Expression, Function, Handle, Literal, Module, Scalar, Statement,
    TypeInner, UnaryOperator,
};
use std::collections::BTreeMap;

/// Why a function's loops could not be counted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub(crate) enum LoopCountError {
    /// The source did not parse (it always does in a run: the same text is compiled).
    #[error("the kernels' WGSL does not parse: {0}")]
    Parse(String),
    /// No function of that name.
    #[error("the kernels define no function `{0}`")]
    NoFunction(String),
    /// A loop whose trip count is not a constant of the pipeline.
    #[error("a loop in `{0}` has no trip count known before the run")]
    Unbounded(String),
}

/// An integer as a linear form `c + Σ k_s · s` in unknown values `s`.
#[derive(Debug, Clone, PartialEq, Default)]
struct Linear {
    constant: i64,
    terms: BTreeMap<Unknown, i64>,
}

/// An unknown value: a function's argument, or any other expression, by its handle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Unknown {
    Argument(u32),
    Expression(usize),
}

impl Linear {
    fn of(constant: i64) -> Linear {
        Linear {
            constant,
            terms: BTreeMap::new(),
        }
    }

    fn unknown(u: Unknown) -> Linear {
        Linear {
            constant: 0,
            terms: BTreeMap::from([(u, 1)]),
        }
    }

    fn known(&self) -> Option<i64> {
        self.terms.is_empty().then_some(self.constant)
    }

    /// `self + k · other`.
    fn plus(mut self, other: &Linear, k: i64) -> Linear {
        self.constant += k * other.constant;
        for (u, c) in &other.terms {
            *self.terms.entry(*u).or_default() += k * c;
        }
        self.terms.retain(|_, c| *c != 0);
        self
    }

    fn times(mut self, k: i64) -> Linear {
        self.constant *= k;
        self.terms.values_mut().for_each(|c| *c *= k);
        self.terms.retain(|_, c| *c != 0);
        self
    }
}

/// A value the counter can reason with.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    Bool(bool),
    Int(Linear),
}

impl Value {
    /// Whether the value holds no unknown (only such values pass into a callee).
    fn is_known(&self) -> bool {
        match self {
            Value::Bool(_) => true,
            Value::Int(l) => l.known().is_some(),
        }
    }

    fn as_bool(&self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(*b),
            Value::Int(_) => None,
        }
    }
}

/// The loops of one kernel module specialised by its override constants.
pub(crate) struct LoopCounter {
    module: Module,
    overrides: BTreeMap<String, f64>,
    uniforms: BTreeMap<String, i64>,
}

/// One function being counted: which, and what is known of its arguments.
struct Frame<'a> {
    function: &'a Function,
    name: &'a str,
    arguments: Vec<Option<Value>>,
}

impl LoopCounter {
    /// The counter of WGSL `source` with the pipeline's override `constants` and the values of
    /// the uniform fields loop bounds read (`("ctl.e_p_max", 8)`).
    pub(crate) fn new(
        source: &str,
        constants: &[(&str, f64)],
        uniforms: &[(&str, i64)],
    ) -> Result<LoopCounter, LoopCountError> {
        let module = naga::front::wgsl::parse_str(source)
            .map_err(|e| LoopCountError::Parse(e.emit_to_string(source)))?;
        Ok(LoopCounter {
            module,
            overrides: constants.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            uniforms: uniforms.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        })
    }

    /// Loop iterations of one call of function `name`, its arguments `known` by name (the
    /// others unknown).
    pub(crate) fn of(&self, name: &str, known: &[(&str, bool)]) -> Result<u64, LoopCountError> {
        let (_, f) = self
            .module
            .functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some(name))
            .ok_or_else(|| LoopCountError::NoFunction(name.into()))?;
        let arguments = f
            .arguments
            .iter()
            .map(|a| {
                known
                    .iter()
                    .find(|(k, _)| a.name.as_deref() == Some(*k))
                    .map(|(_, v)| Value::Bool(*v))
            })
            .collect();
        let frame = Frame {
            function: f,
            name,
            arguments,
        };
        self.block(&frame, &f.body, false)
    }

    /// Loop iterations of one invocation of entry point `name` outside its loops whose trip
    /// count is a run-time value (a dispatch's loads, stores and set-up).
    pub(crate) fn outside_loops(&self, name: &str) -> Result<u64, LoopCountError> {
        let ep = self
            .module
            .entry_points
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| LoopCountError::NoFunction(name.into()))?;
        let frame = Frame {
            function: &ep.function,
            name,
            arguments: Vec::new(),
        };
        self.block(&frame, &ep.function.body, true)
    }

    fn block(&self, fr: &Frame, block: &Block, skip: bool) -> Result<u64, LoopCountError> {
        let mut total = 0;
        for (i, s) in block.iter().enumerate() {
            total += self.statement(fr, s, &block[..i], skip)?;
        }
        Ok(total)
    }

    /// Loop iterations of statement `s`, `before` it the statements of its block.
    fn statement(
        &self,
        fr: &Frame,
        s: &Statement,
        before: &[Statement],
        skip: bool,
    ) -> Result<u64, LoopCountError> {
        Ok(match s {
            Statement::Block(b) => self.block(fr, b, skip)?,
            Statement::If {
                condition,
                accept,
                reject,
            } => match self.eval(fr, *condition).and_then(|v| v.as_bool()) {
                Some(true) => self.block(fr, accept, skip)?,
                Some(false) => self.block(fr, reject, skip)?,
                None => self
                    .block(fr, accept, skip)?
                    .max(self.block(fr, reject, skip)?),
            },
            Statement::Switch { cases, .. } => {
                let mut most = 0;
                for c in cases {
                    most = most.max(self.block(fr, &c.body, skip)?);
                }
                most
            }
            Statement::Loop {
                body, continuing, ..
            } => match self.trips(fr, body, continuing, before) {
                Some(t) => {
                    let inner = self.block(fr, body, skip)? + self.block(fr, continuing, skip)?;
                    t * (1 + inner)
                }
                None if skip => 0,
                None => return Err(LoopCountError::Unbounded(fr.name.into())),
            },
            Statement::Call {
                function,
                arguments,
                ..
            } => {
                let callee = &self.module.functions[*function];
                let frame = Frame {
                    function: callee,
                    name: callee.name.as_deref().unwrap_or("?"),
                    arguments: arguments
                        .iter()
                        .map(|a| self.eval(fr, *a).filter(Value::is_known))
                        .collect(),
                };
                self.block(&frame, &callee.body, false)?
            }
            _ => 0,
        })
    }

    /// The trip count of a `for` loop as naga lowers it: its body opens with `if i < b {}
    /// else { break; }` (or `i ≤ b`, either maybe `&& …`), its continuing block adds 1 to `i`,
    /// and `i` starts at its initialiser or at the last value its block stored before the loop.
    fn trips(
        &self,
        fr: &Frame,
        body: &Block,
        continuing: &Block,
        before: &[Statement],
    ) -> Option<u64> {
        let exprs = &fr.function.expressions;
        let mut stmts = body.iter().filter(|s| !matches!(s, Statement::Emit(_)));
        let condition = match stmts.next()? {
            Statement::If {
                condition,
                accept,
                reject,
            } if accept.is_empty() && is_break(reject) => *condition,
            // `i < b && c`, which naga lowers to `if i < b { t = c; } else { t = false; }`
            // before the test of `t`: the loop runs at most as often as `i < b` holds.
            Statement::If {
                condition, reject, ..
            } => {
                let flag = match reject.iter().next()? {
                    Statement::Store { pointer, .. } => local_of(exprs, *pointer)?,
                    _ => return None,
                };
                match stmts.next()? {
                    Statement::If {
                        condition: test,
                        accept,
                        reject,
                    } if accept.is_empty()
                        && is_break(reject)
                        && matches!(exprs[*test], Expression::Load { pointer }
                            if local_of(exprs, pointer) == Some(flag)) =>
                    {
                        *condition
                    }
                    _ => return None,
                }
            }
            _ => return None,
        };
        let (inclusive, var, bound) = bound_of(exprs, condition)?;
        let steps_by_one = continuing.iter().any(|s| match s {
            Statement::Store { pointer, value } => {
                local_of(exprs, *pointer) == Some(var) && adds_one(exprs, *value, var)
            }
            _ => false,
        });
        if !steps_by_one {
            return None;
        }
        let start = before
            .iter()
            .rev()
            .find_map(|s| match s {
                Statement::Store { pointer, value } if local_of(exprs, *pointer) == Some(var) => {
                    Some(*value)
                }
                _ => None,
            })
            .or(fr.function.local_variables[var].init)?;
        let span = self.int(fr, bound)?.plus(&self.int(fr, start)?, -1);
        let t = span.known()? + i64::from(inclusive);
        Some(t.max(0) as u64)
    }

    fn int(&self, fr: &Frame, e: Handle<Expression>) -> Option<Linear> {
        match self.eval(fr, e)? {
            Value::Int(l) => Some(l),
            Value::Bool(_) => None,
        }
    }

    /// The value of expression `e` of the frame's function, where the counter can know it.
    fn eval(&self, fr: &Frame, e: Handle<Expression>) -> Option<Value> {
        let exprs = &fr.function.expressions;
        let unknown = || Some(Value::Int(Linear::unknown(Unknown::Expression(e.index()))));
        match &exprs[e] {
            Expression::Literal(l) => literal(l),
            Expression::Constant(c) => self.global(self.module.constants[*c].init),
            Expression::Override(o) => self.override_value(*o),
            Expression::FunctionArgument(k) => match fr.arguments.get(*k as usize) {
                Some(Some(v)) => Some(v.clone()),
                _ => Some(Value::Int(Linear::unknown(Unknown::Argument(*k)))),
            },
            Expression::Load { pointer } => match self.uniform(fr, *pointer) {
                Some(v) => Some(Value::Int(Linear::of(v))),
                None => unknown(),
            },
            Expression::Unary {
                op: UnaryOperator::LogicalNot,
                expr,
            } => Some(Value::Bool(!self.eval(fr, *expr)?.as_bool()?)),
            Expression::Binary { op, left, right } => self
                .binary(*op, self.eval(fr, *left), self.eval(fr, *right))
                .or_else(unknown),
            _ => unknown(),
        }
    }

    /// A constant's or an override's initialiser in the module's global expressions.
    fn global(&self, e: Handle<Expression>) -> Option<Value> {
        match &self.module.global_expressions[e] {
            Expression::Literal(l) => literal(l),
            Expression::Constant(c) => self.global(self.module.constants[*c].init),
            Expression::Override(o) => self.override_value(*o),
            Expression::Binary { op, left, right } => {
                self.binary(*op, self.global(*left), self.global(*right))
            }
            _ => None,
        }
    }

    fn override_value(&self, o: Handle<naga::Override>) -> Option<Value> {
        let ov = &self.module.overrides[o];
        let is_bool = matches!(
            self.module.types[ov.ty].inner,
            TypeInner::Scalar(Scalar::BOOL)
        );
        match ov.name.as_ref().and_then(|n| self.overrides.get(n)) {
            Some(&v) if is_bool => Some(Value::Bool(v != 0.0)),
            Some(&v) => Some(Value::Int(Linear::of(v as i64))),
            None => self.global(ov.init?),
        }
    }

    /// The value of a uniform field `global.field` a loop bound loads, where given.
    fn uniform(&self, fr: &Frame, pointer: Handle<Expression>) -> Option<i64> {
        let exprs = &fr.function.expressions;
        let Expression::AccessIndex { base, index } = exprs[pointer] else {
            return None;
        };
        let Expression::GlobalVariable(g) = exprs[base] else {
            return None;
        };
        let global = &self.module.global_variables[g];
        let TypeInner::Struct { members, .. } = &self.module.types[global.ty].inner else {
            return None;
        };
        let key = format!(
            "{}.{}",
            global.name.as_deref()?,
            members.get(index as usize)?.name.as_deref()?
        );
        self.uniforms.get(&key).copied()
    }

    fn binary(&self, op: BinaryOperator, l: Option<Value>, r: Option<Value>) -> Option<Value> {
        use BinaryOperator as B;
        let lb = l.as_ref().and_then(Value::as_bool);
        let rb = r.as_ref().and_then(Value::as_bool);
        let logical = matches!(op, B::LogicalAnd | B::LogicalOr)
            || matches!(
                (&l, &r),
                (Some(Value::Bool(_)), _) | (_, Some(Value::Bool(_)))
            );
        if logical {
            let and = matches!(op, B::LogicalAnd | B::And);
            return match (lb, rb) {
                (Some(x), _) | (_, Some(x)) if x != and => Some(Value::Bool(x)),
                (Some(x), Some(y)) => Some(Value::Bool(if and { x && y } else { x || y })),
                _ => None,
            };
        }
        let (Value::Int(a), Value::Int(b)) = (l?, r?) else {
            return None;
        };
        let known = a.known().zip(b.known());
        Some(match op {
            B::Add => Value::Int(a.plus(&b, 1)),
            B::Subtract => Value::Int(a.plus(&b, -1)),
            B::Multiply => match (a.known(), b.known()) {
                (Some(k), _) => Value::Int(b.times(k)),
                (_, Some(k)) => Value::Int(a.times(k)),
                _ => return None,
            },
            _ => {
                let (x, y) = known?;
                match op {
                    B::Divide if y != 0 => Value::Int(Linear::of(x / y)),
                    B::Modulo if y != 0 => Value::Int(Linear::of(x % y)),
                    B::ShiftLeft => Value::Int(Linear::of(x << y)),
                    B::ShiftRight => Value::Int(Linear::of(x >> y)),
                    B::And => Value::Int(Linear::of(x & y)),
                    B::InclusiveOr => Value::Int(Linear::of(x | y)),
                    B::Less => Value::Bool(x < y),
                    B::LessEqual => Value::Bool(x <= y),
                    B::Greater => Value::Bool(x > y),
                    B::GreaterEqual => Value::Bool(x >= y),
                    B::Equal => Value::Bool(x == y),
                    B::NotEqual => Value::Bool(x != y),
                    _ => return None,
                }
            }
        })
    }
}

fn literal(l: &Literal) -> Option<Value> {
    Some(match *l {
        Literal::U32(v) => Value::Int(Linear::of(i64::from(v))),
        Literal::I32(v) => Value::Int(Linear::of(i64::from(v))),
        Literal::AbstractInt(v) | Literal::I64(v) => Value::Int(Linear::of(v)),
        Literal::Bool(b) => Value::Bool(b),
        _ => return None,
    })
}

fn is_break(b: &Block) -> bool {
    b.len() == 1 && matches!(b[0], Statement::Break)
}

/// The local variable `p` points at.
fn local_of(
    exprs: &naga::Arena<Expression>,
    p: Handle<Expression>,
) -> Option<Handle<naga::LocalVariable>> {
    match exprs[p] {
        Expression::LocalVariable(v) => Some(v),
        _ => None,
    }
}

/// Whether `e` is `load(var) + 1`.
fn adds_one(
    exprs: &naga::Arena<Expression>,
    e: Handle<Expression>,
    var: Handle<naga::LocalVariable>,
) -> bool {
    let Expression::Binary {
        op: BinaryOperator::Add,
        left,
        right,
    } = exprs[e]
    else {
        return false;
    };
    let loads_var = matches!(exprs[left], Expression::Load { pointer } if local_of(exprs, pointer) == Some(var));
    let one = matches!(
        exprs[right],
        Expression::Literal(Literal::U32(1) | Literal::I32(1) | Literal::AbstractInt(1))
    );
    loads_var && one
}

/// `(inclusive, var, bound)` of a loop condition `var < bound` or `var <= bound`, maybe the left
/// side of an `&&`.
fn bound_of(
    exprs: &naga::Arena<Expression>,
    c: Handle<Expression>,
) -> Option<(bool, Handle<naga::LocalVariable>, Handle<Expression>)> {
    let Expression::Binary { op, left, right } = exprs[c] else {
        return None;
    };
    let inclusive = match op {
        BinaryOperator::LogicalAnd => return bound_of(exprs, left),
        BinaryOperator::Less => false,
        BinaryOperator::LessEqual => true,
        _ => return None,
    };
    let Expression::Load { pointer } = exprs[left] else {
        return None;
    };
    Some((inclusive, local_of(exprs, pointer)?, right))
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(super) const SOURCE: &str = "
override N: u32 = 3u;
override FLAG: bool = false;
const BLOCKS: u32 = 8u;
struct Ctl { a: u32, p_max: u32, w: u32 }
@group(0) @binding(0) var<uniform> ctl: Ctl;
var<private> x: array<f32, 64>;

fn flat() {
    for (var i = 0u; i < N; i++) { x[i] = 0.0; }
}
fn nested() {
    for (var i = 1u; i <= BLOCKS; i++) {
        for (var j = 0u; j < 2u * N + 1u; j++) { x[j] = 1.0; }
    }
}
fn shifted(abs: u32, same: bool) {
    let w = ctl.w;
    var ok = same;
    for (var j = abs + 1u - w; j <= abs && ok; j++) { ok = x[0] > 0.0; }
}
fn flagged(handed: bool) {
    if FLAG { nested(); }
    if handed { flat(); } else { flat(); flat(); }
}
fn caller() { flagged(true); shifted(7u, true); }
fn unbounded() {
    var k = 0u;
    loop { k += 1u; if x[k] > 1.0 { break; } }
}
@compute @workgroup_size(1)
fn entry() {
    flat();
    var s = 0u;
    loop { if s >= ctl.a { break; } nested(); s += 1u; }
}
";

    fn counter(n: f64, flag: bool) -> LoopCounter {
        let flag = if flag { 1.0 } else { 0.0 };
        LoopCounter::new(SOURCE, &[("N", n), ("FLAG", flag)], &[("ctl.w", 16)]).unwrap()
    }

    #[test]
    fn for_loops_count_their_trips_with_nested_loops_inside() {
        let c = counter(5.0, false);
        assert_eq!(c.of("flat", &[]), Ok(5));
        // 8 passes, each 1 + (2·5 + 1).
        assert_eq!(c.of("nested", &[]), Ok(8 * (1 + 11)));
        assert_eq!(counter(3.0, false).of("nested", &[]), Ok(8 * (1 + 7)));
    }

    #[test]
    fn a_bound_in_unknowns_counts_when_they_cancel_and_uniforms_are_given() {
        // j from abs + 1 − w to abs: w = 16 trips whatever abs is.
        assert_eq!(counter(3.0, false).of("shifted", &[]), Ok(16));
        let no_w = LoopCounter::new(SOURCE, &[], &[]).unwrap();
        assert_eq!(
            no_w.of("shifted", &[]),
            Err(LoopCountError::Unbounded("shifted".into()))
        );
    }

    #[test]
    fn overrides_and_known_arguments_choose_a_branch_and_unknown_ones_take_the_larger() {
        let c = counter(4.0, false);
        assert_eq!(c.of("flagged", &[("handed", true)]), Ok(4));
        assert_eq!(c.of("flagged", &[("handed", false)]), Ok(8));
        assert_eq!(c.of("flagged", &[]), Ok(8));
        let on = counter(4.0, true);
        assert_eq!(on.of("flagged", &[("handed", true)]), Ok(8 * (1 + 9) + 4));
        // A literal argument is known to the callee.
        assert_eq!(c.of("caller", &[]), Ok(4 + 16));
    }

    #[test]
    fn run_time_loops_are_refused_except_outside_an_entry_points_loops() {
        let c = counter(3.0, false);
        assert_eq!(
            c.of("unbounded", &[]),
            Err(LoopCountError::Unbounded("unbounded".into()))
        );
        assert_eq!(c.outside_loops("entry"), Ok(3));
        assert_eq!(
            c.of("missing", &[]),
            Err(LoopCountError::NoFunction("missing".into()))
        );
    }
}

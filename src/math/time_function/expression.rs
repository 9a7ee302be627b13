//! The expression language of drives and load scales: a small, pure language of `t`.
//!
//! Parsed once into a postfix program and evaluated over [`Jet`]s, so value, rate and
//! acceleration come out of one pass with exact derivatives. Evaluation is a loop over the
//! program with a fixed-size stack: no recursion, no allocation, and no input can overflow
//! the stack. The parser recurses only on nesting (parentheses, function calls, unary
//! signs, powers, conditionals), which is bounded by [`MAX_NESTING`].
//!
//! Grammar (lowest precedence first):
//! ```text
//! expr    = or ( "?" expr ":" expr )?
//! or      = and ( "||" and )*
//! and     = cmp ( "&&" cmp )*
//! cmp     = sum ( ("<" | "<=" | ">" | ">=" | "==" | "!=") sum )?
//! sum     = product ( ("+" | "-") product )*
//! product = unary ( ("*" | "/") unary )*
//! unary   = ("-" | "+" | "!") unary | power
//! power   = atom ( ("^" | "**") unary )?
//! atom    = number | "t" | constant | name "(" expr ("," expr)* ")" | "(" expr ")"
//! ```

use super::jet::Jet;

/// Longest expression accepted, in characters: a 100-term Fourier series is about 3 kB;
/// longer signals belong in a table.
pub const MAX_LENGTH: usize = 20_000;
/// Deepest nesting of parentheses, calls, signs, powers and conditionals.
pub const MAX_NESTING: usize = 64;
/// Operands held on the stack without allocating; deeper programs (rare, contrived) use a
/// heap stack of their exact size.
const INLINE_STACK: usize = 32;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Op {
    Const(f64),
    Time,
    Neg,
    Not,
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
    And,
    Or,
    /// `c ? a : b`: pops c, a, b (both branches are evaluated; one is chosen, so a branch
    /// that is undefined where it is not chosen, e.g. `log(t - 1)` for t < 1, does no harm).
    Select,
    Call(Function),
}

/// Every function of the language: name, arity.
const FUNCTIONS: &[(&str, usize, Function)] = &[
    ("sin", 1, Function::Sin),
    ("cos", 1, Function::Cos),
    ("tan", 1, Function::Tan),
    ("asin", 1, Function::Asin),
    ("acos", 1, Function::Acos),
    ("atan", 1, Function::Atan),
    ("atan2", 2, Function::Atan2),
    ("sinh", 1, Function::Sinh),
    ("cosh", 1, Function::Cosh),
    ("tanh", 1, Function::Tanh),
    ("exp", 1, Function::Exp),
    ("log", 1, Function::Ln),
    ("ln", 1, Function::Ln),
    ("log10", 1, Function::Log10),
    ("log2", 1, Function::Log2),
    ("sqrt", 1, Function::Sqrt),
    ("cbrt", 1, Function::Cbrt),
    ("pow", 2, Function::Pow),
    ("abs", 1, Function::Abs),
    ("sign", 1, Function::Sign),
    ("floor", 1, Function::Floor),
    ("ceil", 1, Function::Ceil),
    ("round", 1, Function::Round),
    ("min", 2, Function::Min),
    ("max", 2, Function::Max),
    ("clamp", 3, Function::Clamp),
    ("step", 1, Function::Step),
    ("smoothstep", 3, Function::Smoothstep),
    ("mod", 2, Function::Mod),
];

#[derive(Clone, Copy, Debug, PartialEq)]
enum Function {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Atan2,
    Sinh,
    Cosh,
    Tanh,
    Exp,
    Ln,
    Log10,
    Log2,
    Sqrt,
    Cbrt,
    Pow,
    Abs,
    Sign,
    Floor,
    Ceil,
    Round,
    Min,
    Max,
    Clamp,
    Step,
    Smoothstep,
    Mod,
}

const CONSTANTS: &[(&str, f64)] = &[
    ("pi", std::f64::consts::PI),
    ("PI", std::f64::consts::PI),
    ("tau", std::f64::consts::TAU),
    ("e", std::f64::consts::E),
    ("E", std::f64::consts::E),
];

/// A parsed expression of `t`.
#[derive(Clone, Debug)]
pub struct Expression {
    program: Vec<Op>,
    /// Most operands on the stack at once while evaluating `program`.
    stack_depth: usize,
    /// Whether `program` branches (see [`Expression::has_branches`]).
    branching: bool,
}

impl Expression {
    /// Parses `text`; the error says what is wrong and where (1-based character column).
    pub fn parse(text: &str) -> Result<Self, String> {
        let n = text.chars().count();
        if n > MAX_LENGTH {
            return Err(format!(
                "expression is {n} characters long; the limit is {MAX_LENGTH} (give a long signal as a table {{t: [...], value: [...]}})"
            ));
        }
        let tokens = lex(text)?;
        let mut p = Parser {
            tokens: &tokens,
            pos: 0,
            depth: 0,
            program: Vec::with_capacity(tokens.len()),
        };
        p.expr()?;
        if let Some(tok) = p.tokens.get(p.pos) {
            return Err(format!(
                "unexpected `{}` at column {}",
                tok.text, tok.column
            ));
        }
        let stack_depth = stack_depth(&p.program);
        let branching = p.program.iter().any(|op| branch_code(op, &[]).is_some());
        Ok(Expression {
            program: p.program,
            stack_depth,
            branching,
        })
    }

    /// Whether the expression mentions `t`.
    pub fn depends_on_time(&self) -> bool {
        self.program.contains(&Op::Time)
    }

    /// Value, rate and acceleration at `t`.
    pub fn eval(&self, t: f64) -> Jet {
        self.run_with(t, |_, _| {})
    }

    /// Whether the expression branches: a comparison, logic, a conditional or a function with
    /// a jump or kink (abs, sign, floor, ceil, round, min, max, clamp, step, smoothstep, mod).
    pub fn has_branches(&self) -> bool {
        self.branching
    }

    /// A code of the branches the expression takes at `t`: of every comparison's and logical
    /// operator's result, every conditional's choice, every kinked function's side and every
    /// stepped function's level. Between two times with the same code the expression is one
    /// smooth formula — unless a switch flipped there and back.
    pub fn branches(&self, t: f64) -> u64 {
        let mut code = 0xcbf2_9ce4_8422_2325u64; // FNV-1a
        self.run_with(t, |op, args| {
            if let Some(b) = branch_code(op, args) {
                code = (code ^ b).wrapping_mul(0x0100_0000_01b3);
            }
        });
        code
    }

    /// Runs the program on a stack inline where it is shallow; `branch(op, operands)` sees
    /// every operator before it applies.
    fn run_with(&self, t: f64, branch: impl FnMut(&Op, &[Jet])) -> Jet {
        if self.stack_depth <= INLINE_STACK {
            self.run_on(t, &mut [Jet::default(); INLINE_STACK], branch)
        } else {
            self.run_on(t, &mut vec![Jet::default(); self.stack_depth], branch)
        }
    }

    fn run_on(&self, t: f64, stack: &mut [Jet], mut branch: impl FnMut(&Op, &[Jet])) -> Jet {
        let mut top = 0usize;
        for op in &self.program {
            match *op {
                Op::Const(c) => {
                    stack[top] = Jet::constant(c);
                    top += 1;
                }
                Op::Time => {
                    stack[top] = Jet::time(t);
                    top += 1;
                }
                Op::Neg => stack[top - 1] = -stack[top - 1],
                Op::Not => {
                    branch(op, &stack[top - 1..top]);
                    stack[top - 1] = truth(stack[top - 1].v == 0.0);
                }
                Op::Select => {
                    top -= 2;
                    branch(op, &stack[top - 1..top]);
                    let (c, a, b) = (stack[top - 1], stack[top], stack[top + 1]);
                    stack[top - 1] = if c.v != 0.0 { a } else { b };
                }
                Op::Call(f) => {
                    let k = arity(f);
                    top -= k - 1;
                    branch(op, &stack[top - 1..top - 1 + k]);
                    stack[top - 1] = call(f, &stack[top - 1..top - 1 + k]);
                }
                binary => {
                    top -= 1;
                    branch(op, &stack[top - 1..=top]);
                    stack[top - 1] = apply(binary, stack[top - 1], stack[top]);
                }
            }
        }
        stack[0]
    }
}

/// Most operands on the stack at once while running `program`.
fn stack_depth(program: &[Op]) -> usize {
    let (mut top, mut most) = (0usize, 0usize);
    for op in program {
        match op {
            Op::Const(_) | Op::Time => top += 1,
            Op::Neg | Op::Not => {}
            Op::Select => top -= 2,
            Op::Call(f) => top -= arity(*f) - 1,
            _ => top -= 1,
        }
        most = most.max(top);
    }
    most
}

/// The branch `op` takes on `args` (its operands), if it branches: comparisons and logic by
/// their result, a conditional by its condition, kinked and stepped functions by their side
/// or level. With no operands, only whether it branches (`Some(0)`).
fn branch_code(op: &Op, args: &[Jet]) -> Option<u64> {
    let side = |x: f64| (x > 0.0) as u64 + 2 * (x < 0.0) as u64;
    let v = |k: usize| args.get(k).map_or(0.0, |j| j.v);
    match op {
        Op::Lt | Op::Le | Op::Gt | Op::Ge | Op::Eq | Op::Ne | Op::And | Op::Or => {
            Some(if args.is_empty() {
                0
            } else {
                apply(*op, args[0], args[1]).v as u64
            })
        }
        Op::Not | Op::Select => Some((v(0) != 0.0) as u64),
        Op::Call(f) => match f {
            Function::Abs | Function::Sign | Function::Step => Some(side(v(0))),
            Function::Floor => Some(v(0).floor().to_bits()),
            Function::Ceil => Some(v(0).ceil().to_bits()),
            Function::Round => Some(v(0).round().to_bits()),
            Function::Min | Function::Max => Some(side(v(1) - v(0))),
            Function::Clamp => Some(side(v(0) - v(1)) + 4 * side(v(0) - v(2))),
            Function::Smoothstep => Some(side(v(2) - v(0)) + 4 * side(v(2) - v(1))),
            Function::Mod => Some((v(0) / v(1)).floor().to_bits()),
            _ => None,
        },
        _ => None,
    }
}

fn truth(b: bool) -> Jet {
    Jet::constant(if b { 1.0 } else { 0.0 })
}

fn apply(op: Op, a: Jet, b: Jet) -> Jet {
    match op {
        Op::Add => a + b,
        Op::Sub => a - b,
        Op::Mul => a * b,
        Op::Div => a / b,
        Op::Pow => a.pow(b),
        Op::Lt => truth(a.v < b.v),
        Op::Le => truth(a.v <= b.v),
        Op::Gt => truth(a.v > b.v),
        Op::Ge => truth(a.v >= b.v),
        Op::Eq => truth(a.v == b.v),
        Op::Ne => truth(a.v != b.v),
        Op::And => truth(a.v != 0.0 && b.v != 0.0),
        Op::Or => truth(a.v != 0.0 || b.v != 0.0),
        _ => unreachable!("not a binary operator: {op:?}"),
    }
}

fn arity(f: Function) -> usize {
    FUNCTIONS.iter().find(|e| e.2 == f).map_or(1, |e| e.1)
}

/// Functions with kinks (abs, min, max, clamp) take the derivative of the branch they
/// choose; piecewise-constant ones (floor, ceil, round, sign, step) have zero rates.
fn call(f: Function, x: &[Jet]) -> Jet {
    let a = x[0];
    match f {
        Function::Sin => a.sin(),
        Function::Cos => a.cos(),
        Function::Tan => a.tan(),
        Function::Asin => a.asin(),
        Function::Acos => a.acos(),
        Function::Atan => a.atan(),
        Function::Atan2 => a.atan2(x[1]),
        Function::Sinh => a.sinh(),
        Function::Cosh => a.cosh(),
        Function::Tanh => a.tanh(),
        Function::Exp => a.exp(),
        Function::Ln => a.ln(),
        Function::Log10 => a.ln().scale(1.0 / std::f64::consts::LN_10),
        Function::Log2 => a.ln().scale(1.0 / std::f64::consts::LN_2),
        Function::Sqrt => a.sqrt(),
        Function::Cbrt => a.cbrt(),
        Function::Pow => a.pow(x[1]),
        Function::Abs => {
            if a.v < 0.0 {
                -a
            } else {
                a
            }
        }
        Function::Sign => Jet::flat(if a.v > 0.0 {
            1.0
        } else if a.v < 0.0 {
            -1.0
        } else {
            0.0
        }),
        Function::Floor => Jet::flat(a.v.floor()),
        Function::Ceil => Jet::flat(a.v.ceil()),
        Function::Round => Jet::flat(a.v.round()),
        Function::Min => {
            if x[1].v < a.v {
                x[1]
            } else {
                a
            }
        }
        Function::Max => {
            if x[1].v > a.v {
                x[1]
            } else {
                a
            }
        }
        Function::Clamp => call(Function::Min, &[call(Function::Max, &[a, x[1]]), x[2]]),
        Function::Step => Jet::flat(if a.v >= 0.0 { 1.0 } else { 0.0 }),
        Function::Smoothstep => smoothstep(x[0], x[1], x[2]),
        // a − b·floor(a/b): the floor is locally constant.
        Function::Mod => a - x[1] * Jet::flat((a.v / x[1].v).floor()),
    }
}

/// 0 below `e0`, 1 above `e1`, 3s² − 2s³ between (s = (x − e0)/(e1 − e0)): continuous rate.
fn smoothstep(e0: Jet, e1: Jet, x: Jet) -> Jet {
    let s = (x - e0) / (e1 - e0);
    if s.v <= 0.0 {
        Jet::constant(0.0)
    } else if s.v >= 1.0 {
        Jet::constant(1.0)
    } else {
        s * s * (Jet::constant(3.0) - s.scale(2.0))
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Number(f64),
    Name,
    Symbol,
}

#[derive(Clone, Debug)]
struct Token {
    kind: Kind,
    text: String,
    column: usize,
}

const SYMBOLS: &[&str] = &[
    "**", "<=", ">=", "==", "!=", "&&", "||", "+", "-", "*", "/", "^", "(", ")", ",", "<", ">",
    "!", "?", ":",
];

fn lex(text: &str) -> Result<Vec<Token>, String> {
    let chars: Vec<char> = text.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let column = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit()
            || (c == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit()))
        {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            // Scientific notation: 1e-3, 2.5E+4.
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    i = j;
                    while i < chars.len() && chars[i].is_ascii_digit() {
                        i += 1;
                    }
                }
            }
            let s: String = chars[start..i].iter().collect();
            let v: f64 = s
                .parse()
                .map_err(|_| format!("malformed number `{s}` at column {column}"))?;
            tokens.push(Token {
                kind: Kind::Number(v),
                text: s,
                column,
            });
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            let s: String = chars[start..i].iter().collect();
            tokens.push(Token {
                kind: Kind::Name,
                text: s,
                column,
            });
        } else {
            let rest: String = chars[i..chars.len().min(i + 2)].iter().collect();
            let Some(sym) = SYMBOLS.iter().find(|s| rest.starts_with(**s)) else {
                return Err(format!("unexpected character `{c}` at column {column}"));
            };
            i += sym.chars().count();
            tokens.push(Token {
                kind: Kind::Symbol,
                text: sym.to_string(),
                column,
            });
        }
    }
    Ok(tokens)
}

struct Parser<'a> {
    tokens: &'a [Token],
    pos: usize,
    depth: usize,
    program: Vec<Op>,
}

impl Parser<'_> {
    fn peek(&self) -> Option<&str> {
        self.tokens
            .get(self.pos)
            .filter(|t| t.kind == Kind::Symbol)
            .map(|t| t.text.as_str())
    }

    fn eat(&mut self, sym: &str) -> bool {
        let hit = self.peek() == Some(sym);
        if hit {
            self.pos += 1;
        }
        hit
    }

    fn expect(&mut self, sym: &str) -> Result<(), String> {
        if self.eat(sym) {
            return Ok(());
        }
        Err(match self.tokens.get(self.pos) {
            Some(t) => format!(
                "expected `{sym}` at column {} but found `{}`",
                t.column, t.text
            ),
            None => format!("expected `{sym}` but the expression ended"),
        })
    }

    /// Runs `f` one nesting level deeper; past [`MAX_NESTING`] it is an error.
    fn nested(&mut self, f: impl FnOnce(&mut Self) -> Result<(), String>) -> Result<(), String> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(format!(
                "expression is nested more than {MAX_NESTING} levels deep (parentheses, calls, signs, powers or conditionals)"
            ));
        }
        let r = f(self);
        self.depth -= 1;
        r
    }

    fn expr(&mut self) -> Result<(), String> {
        self.nested(|p| {
            p.binary_chain(0)?;
            if p.eat("?") {
                p.expr()?;
                p.expect(":")?;
                p.expr()?;
                p.program.push(Op::Select);
            }
            Ok(())
        })
    }

    /// Left-associative levels, parsed with loops (a sum of 10,000 terms needs no recursion).
    fn binary_chain(&mut self, level: usize) -> Result<(), String> {
        const LEVELS: &[&[(&str, Op)]] = &[
            &[("||", Op::Or)],
            &[("&&", Op::And)],
            &[
                ("<=", Op::Le),
                (">=", Op::Ge),
                ("<", Op::Lt),
                (">", Op::Gt),
                ("==", Op::Eq),
                ("!=", Op::Ne),
            ],
            &[("+", Op::Add), ("-", Op::Sub)],
            &[("*", Op::Mul), ("/", Op::Div)],
        ];
        let Some(ops) = LEVELS.get(level) else {
            return self.unary();
        };
        self.binary_chain(level + 1)?;
        while let Some(&(_, op)) = ops.iter().find(|(s, _)| self.peek() == Some(*s)) {
            self.pos += 1;
            self.binary_chain(level + 1)?;
            self.program.push(op);
        }
        Ok(())
    }

    fn unary(&mut self) -> Result<(), String> {
        for (sym, op) in [("-", Some(Op::Neg)), ("+", None), ("!", Some(Op::Not))] {
            if self.eat(sym) {
                return self.nested(|p| {
                    p.unary()?;
                    p.program.extend(op);
                    Ok(())
                });
            }
        }
        self.atom()?;
        if self.eat("^") || self.eat("**") {
            // Right-associative and binding tighter than a sign on its left: -t^2 = -(t^2).
            self.nested(|p| p.unary())?;
            self.program.push(Op::Pow);
        }
        Ok(())
    }

    fn atom(&mut self) -> Result<(), String> {
        let Some(tok) = self.tokens.get(self.pos) else {
            return Err(
                "the expression ended where a number, `t`, a call or `(` was expected".into(),
            );
        };
        self.pos += 1;
        match &tok.kind {
            Kind::Number(v) => self.program.push(Op::Const(*v)),
            Kind::Name => self.name(tok)?,
            Kind::Symbol if tok.text == "(" => {
                self.expr()?;
                self.expect(")")?;
            }
            Kind::Symbol => {
                return Err(format!(
                    "unexpected `{}` at column {}",
                    tok.text, tok.column
                ));
            }
        }
        Ok(())
    }

    fn name(&mut self, tok: &Token) -> Result<(), String> {
        let name = tok.text.as_str();
        if name == "t" {
            self.program.push(Op::Time);
            return Ok(());
        }
        if let Some((_, v)) = CONSTANTS.iter().find(|(n, _)| *n == name) {
            self.program.push(Op::Const(*v));
            return Ok(());
        }
        let Some(&(_, arity, f)) = FUNCTIONS.iter().find(|(n, _, _)| *n == name) else {
            return Err(format!(
                "unknown name `{name}` at column {}; an expression may use `t`, the constants pi, tau and e, and the functions {}",
                tok.column,
                FUNCTIONS.iter().map(|f| f.0).collect::<Vec<_>>().join(", ")
            ));
        };
        if self.peek() != Some("(") {
            return Err(format!(
                "`{name}` at column {} is a function: write `{name}(…)`",
                tok.column
            ));
        }
        self.pos += 1;
        // Each argument is an `expr`, which counts the nesting.
        for k in 0..arity {
            if k > 0 {
                self.expect(",")
                    .map_err(|e| format!("`{name}` takes {arity} arguments: {e}"))?;
            }
            self.expr()?;
        }
        self.expect(")")
            .map_err(|e| format!("`{name}` takes {arity} argument(s): {e}"))?;
        self.program.push(Op::Call(f));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(text: &str, t: f64) -> Jet {
        Expression::parse(text)
            .unwrap_or_else(|e| panic!("{text}: {e}"))
            .eval(t)
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * (1.0 + b.abs())
    }

    #[test]
    fn precedence_associativity_and_numbers() {
        let cases = [
            ("1 + 2*3", 7.0),
            ("2^3^2", 512.0),
            ("2**3", 8.0),
            ("-2^2", -4.0),
            ("(1 + 2)*3", 9.0),
            ("10 - 4 - 3", 3.0),
            ("12/3/2", 2.0),
            ("1e-3*1000", 1.0),
            ("2.5E+2", 250.0),
            (".5 + 1.", 1.5),
            ("3 > 2 && 1 < 0 || 2 >= 2", 1.0),
            ("!(1 == 1) + (2 != 3)", 1.0),
            ("1 < 2 ? 10 : 20", 10.0),
            ("0 ? 1 : 0 ? 2 : 3", 3.0),
            ("mod(7.5, 2)", 1.5),
            ("mod(-1, 3)", 2.0),
            ("clamp(5, 0, 2) + clamp(-1, 0, 2)", 2.0),
            ("smoothstep(0, 2, 1)", 0.5),
            ("min(3, -1) + max(3, -1) + abs(-2) + sign(-4) + floor(2.7) + ceil(2.2) + round(2.5)", 11.0),
            ("step(-0.1) + step(0)", 1.0),
            ("log10(1000) + log2(8) + ln(e) + log(1)", 7.0),
            ("atan2(1, 1)*4/pi + tau/pi + cbrt(27) + sqrt(16) + pow(2, 3)", 18.0),
        ];
        for (text, want) in cases {
            let got = eval(text, 0.0).v;
            assert!(close(got, want), "{text} = {got}, want {want}");
        }
    }

    /// Exact derivatives against central differences on both sides of every kink, and the
    /// chosen branch's derivative at a conditional.
    #[test]
    fn rates_and_accelerations_are_exact_where_differentiable() {
        let texts = [
            "0.5*sin(2*pi*t) + 1e-3*t^3",
            "t < 1 ? 0.5*t^2 : t - 0.5",
            "abs(sin(3*t))",
            "min(t^2, 2*t) + max(cos(t), 0.1*t)",
            "clamp(t^2, 0.5, 2)",
            "smoothstep(0.2, 1.7, t) * sin(t)",
            "t^t + exp(-t)*cosh(t) + tanh(t) + atan(t) + sinh(t)/(1 + t)",
            "mod(3*t, 1) + floor(t)*t",
            "asin(0.3*t) + acos(0.2*t) + log10(1 + t) + log2(2 + t) + sqrt(1 + t)",
        ];
        let h = 1e-5;
        for text in texts {
            let e = Expression::parse(text).unwrap();
            for t in [0.13, 0.61, 0.97, 1.21, 1.73, 2.44] {
                let j = e.eval(t);
                let (a, b, c) = (e.eval(t - h).v, j.v, e.eval(t + h).v);
                let (d, dd) = ((c - a) / (2.0 * h), (c - 2.0 * b + a) / (h * h));
                // Truncation h²·f''' ~ 1e-10; the second difference's round-off ε·f/h² ~ 2e-6.
                assert!(
                    (j.d - d).abs() < 1e-7 * (1.0 + d.abs()),
                    "{text}: rate at {t}: {} vs {d}",
                    j.d
                );
                assert!(
                    (j.dd - dd).abs() < 1e-4 * (1.0 + dd.abs()),
                    "{text}: accel at {t}: {} vs {dd}",
                    j.dd
                );
            }
        }
    }

    #[test]
    fn long_and_deep_expressions_evaluate_without_recursion() {
        let sum = vec!["t"; 5000].join(" + ");
        assert!(close(eval(&sum, 2.0).v, 10000.0));
        assert_eq!(eval(&sum, 2.0).d, 5000.0);
        let product = vec!["(1 + 0*t)"; 2000].join("*");
        assert!(close(eval(&product, 1.0).v, 1.0));
        let fourier: Vec<String> = (1..=90)
            .map(|k| format!("{:.3}*sin({k}*2*pi*t + 0.1)", 1.0 / k as f64))
            .collect();
        let f = Expression::parse(&fourier.join(" + ")).unwrap();
        assert!(f.eval(0.3).v.is_finite() && f.eval(0.3).dd.is_finite());
        let nested = format!("{}t{}", "sin(".repeat(46), ")".repeat(46));
        let j = eval(&nested, 0.5);
        assert!(j.v > 0.0 && j.v < 0.5 && j.d > 0.0);
        // Deep enough that the evaluation stack leaves its inline buffer.
        let wide = format!("{}t{}", "(1 + ".repeat(60), ")".repeat(60));
        assert!(close(eval(&wide, 1.0).v, 61.0));
    }

    #[test]
    fn limits_and_mistakes_are_reported() {
        let err = |text: &str| Expression::parse(text).unwrap_err();
        assert!(err(&format!("{}t{}", "sin(".repeat(100), ")".repeat(100)))
            .contains("nested more than 64"));
        assert!(err(&"-".repeat(200)).contains("nested more than"));
        assert!(err(&"t+".repeat(20_000)).contains("limit is 20000"));
        assert!(err("x + t").contains("unknown name `x` at column 1"));
        assert!(err("sin t").contains("is a function"));
        assert!(err("min(t)").contains("takes 2 arguments"));
        assert!(err("t ? 1").contains("expected `:`"));
        assert!(err("2 * ").contains("ended"));
        assert!(err("t $ 2").contains("unexpected character `$` at column 3"));
        assert!(err("1.2.3").contains("malformed number"));
        assert!(err("(t))").contains("unexpected `)` at column 4"));
        assert!(err("").contains("ended"));
    }

    #[test]
    fn a_branch_undefined_where_it_is_not_chosen_does_no_harm() {
        let j = eval("t < 1 ? 0 : log(t - 1)", 0.5);
        assert_eq!((j.v, j.d, j.dd), (0.0, 0.0, 0.0));
        assert!(!Expression::parse("2*pi").unwrap().depends_on_time());
        assert!(Expression::parse("0*t").unwrap().depends_on_time());
    }
}

#[cfg(test)]
mod documented_examples {
    use super::*;

    /// docs/expressions.md's piecewise slider motion is continuous with a continuous rate at
    /// t = 2 s (both pieces give 0.5 m and 0.5 m/s).
    #[test]
    fn piecewise_example_joins_smoothly() {
        let e = Expression::parse("t < 2 ? 0.125*t^2 : t < 15 ? 0.5 + 0.5*(t - 2) : 7").unwrap();
        let (a, b) = (e.eval(2.0 - 1e-12), e.eval(2.0));
        assert!((a.v - b.v).abs() < 1e-12 && (a.d - b.d).abs() < 1e-12);
        assert!((e.eval(15.0 - 1e-12).v - e.eval(15.0).v).abs() < 1e-11);
    }
}

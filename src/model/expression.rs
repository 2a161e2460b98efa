//! Arithmetic expressions over named quantities, as a model file writes a parameter that is a
//! function of others (`radius * cos(angle_a)`, `endstop_a + sqrt(arm_a^2 - radius^2)`):
//! parsed once, evaluated on any [`Scalar`] (so dual numbers carry their derivatives through).
//!
//! Grammar (usual precedence, `^` binding tightest, unary minus below it):
//! numbers (`0.175`, `1e-3`), quantity names, `pi`, `+ - * / ^`, parentheses, and the functions
//! `sin cos tan asin acos atan sqrt exp ln` of one argument and `atan2(y, x)`. The exponent of
//! `^` is a number (`arm^2`, `x^0.5`), not an expression of quantities.
//!
//! Hand-written rather than taken from an expression crate: the ones on crates.io evaluate in
//! `f64` only, and the fit needs the same expression on dual numbers.

use std::fmt;

use num_dual::DualNum;

use crate::scalar::{lift, Scalar};

/// A parsed expression; its names are indices into the list it was parsed against.
#[derive(Debug, Clone, PartialEq)]
pub struct Expression {
    text: String,
    root: Node,
}

/// Why an expression does not parse: the message and the character it points at.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExpressionError {
    /// Position (0-based character index) in the text.
    pub at: usize,
    /// What was expected and found.
    pub message: String,
}

impl fmt::Display for ExpressionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "at character {}: {}", self.at + 1, self.message)
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Node {
    Number(f64),
    Name(usize),
    Negate(Box<Node>),
    Binary(Operator, Box<Node>, Box<Node>),
    Power(Box<Node>, f64),
    Call(Function, Box<Node>),
    Atan2(Box<Node>, Box<Node>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Operator {
    Add,
    Subtract,
    Multiply,
    Divide,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Function {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sqrt,
    Exp,
    Ln,
}

const FUNCTIONS: [(&str, Function); 9] = [
    ("sin", Function::Sin),
    ("cos", Function::Cos),
    ("tan", Function::Tan),
    ("asin", Function::Asin),
    ("acos", Function::Acos),
    ("atan", Function::Atan),
    ("sqrt", Function::Sqrt),
    ("exp", Function::Exp),
    ("ln", Function::Ln),
];

impl Expression {
    /// Parses `text`, whose names must be among `names` (they become indices into it).
    ///
    /// # Errors
    /// The first character that does not fit the grammar, an unknown name or function.
    pub fn parse(text: &str, names: &[&str]) -> Result<Self, ExpressionError> {
        let mut parser = Parser {
            chars: text.chars().collect(),
            at: 0,
            names,
        };
        let root = parser.sum()?;
        parser.skip_space();
        if let Some(c) = parser.peek() {
            return Err(parser.error(format!("expected an operator or the end, found `{c}`")));
        }
        Ok(Self {
            text: text.to_string(),
            root,
        })
    }

    /// The text it was parsed from.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Its value with name `i` standing for `values[i]`.
    ///
    /// # Panics
    /// If `values` is shorter than the names it was parsed against.
    pub fn eval<T: Scalar>(&self, values: &[T]) -> T {
        self.root.eval(values)
    }

    /// The indices of the names it uses, ascending, each once.
    pub fn names_used(&self) -> Vec<usize> {
        let mut used = Vec::new();
        self.root.collect_names(&mut used);
        used.sort_unstable();
        used.dedup();
        used
    }
}

impl Node {
    fn eval<T: Scalar>(&self, values: &[T]) -> T {
        match self {
            Node::Number(v) => lift(*v),
            Node::Name(i) => values[*i],
            Node::Negate(a) => -a.eval(values),
            Node::Binary(op, a, b) => {
                let (a, b) = (a.eval(values), b.eval(values));
                match op {
                    Operator::Add => a + b,
                    Operator::Subtract => a - b,
                    Operator::Multiply => a * b,
                    Operator::Divide => a / b,
                }
            }
            Node::Power(a, exponent) => {
                let a = a.eval(values);
                if exponent.fract() == 0.0 && exponent.abs() <= i32::MAX as f64 {
                    a.powi(*exponent as i32)
                } else {
                    DualNum::powf(&a, *exponent)
                }
            }
            Node::Call(function, a) => {
                let a = a.eval(values);
                match function {
                    Function::Sin => a.sin(),
                    Function::Cos => a.cos(),
                    Function::Tan => a.tan(),
                    Function::Asin => a.asin(),
                    Function::Acos => a.acos(),
                    Function::Atan => a.atan(),
                    Function::Sqrt => a.sqrt(),
                    Function::Exp => a.exp(),
                    Function::Ln => a.ln(),
                }
            }
            Node::Atan2(y, x) => y.eval(values).atan2(x.eval(values)),
        }
    }

    fn collect_names(&self, used: &mut Vec<usize>) {
        match self {
            Node::Number(_) => {}
            Node::Name(i) => used.push(*i),
            Node::Negate(a) | Node::Power(a, _) | Node::Call(_, a) => a.collect_names(used),
            Node::Binary(_, a, b) | Node::Atan2(a, b) => {
                a.collect_names(used);
                b.collect_names(used);
            }
        }
    }
}

struct Parser<'n> {
    chars: Vec<char>,
    at: usize,
    names: &'n [&'n str],
}

impl Parser<'_> {
    fn error(&self, message: String) -> ExpressionError {
        ExpressionError {
            at: self.at.min(self.chars.len()),
            message,
        }
    }

    fn skip_space(&mut self) {
        while self.peek().is_some_and(char::is_whitespace) {
            self.at += 1;
        }
    }

    fn peek(&self) -> Option<char> {
        self.chars.get(self.at).copied()
    }

    /// Skips spaces, then takes `c` if it is next.
    fn take(&mut self, c: char) -> bool {
        self.skip_space();
        let found = self.peek() == Some(c);
        if found {
            self.at += 1;
        }
        found
    }

    fn expect(&mut self, c: char) -> Result<(), ExpressionError> {
        if self.take(c) {
            return Ok(());
        }
        let found = self
            .peek()
            .map_or("the end".to_string(), |f| format!("`{f}`"));
        Err(self.error(format!("expected `{c}`, found {found}")))
    }

    /// `term (('+' | '-') term)*`
    fn sum(&mut self) -> Result<Node, ExpressionError> {
        let mut node = self.product()?;
        loop {
            let op = if self.take('+') {
                Operator::Add
            } else if self.take('-') {
                Operator::Subtract
            } else {
                return Ok(node);
            };
            node = Node::Binary(op, Box::new(node), Box::new(self.product()?));
        }
    }

    /// `unary (('*' | '/') unary)*`
    fn product(&mut self) -> Result<Node, ExpressionError> {
        let mut node = self.unary()?;
        loop {
            let op = if self.take('*') {
                Operator::Multiply
            } else if self.take('/') {
                Operator::Divide
            } else {
                return Ok(node);
            };
            node = Node::Binary(op, Box::new(node), Box::new(self.unary()?));
        }
    }

    /// `'-' unary | '+' unary | power`
    fn unary(&mut self) -> Result<Node, ExpressionError> {
        if self.take('-') {
            return Ok(Node::Negate(Box::new(self.unary()?)));
        }
        if self.take('+') {
            return self.unary();
        }
        self.power()
    }

    /// `atom ('^' signed-number)?`: the exponent is a number.
    fn power(&mut self) -> Result<Node, ExpressionError> {
        let base = self.atom()?;
        if !self.take('^') {
            return Ok(base);
        }
        self.skip_space();
        let negative = self.take('-');
        self.skip_space();
        let exponent = match self.peek() {
            Some(c) if c.is_ascii_digit() || c == '.' => self.number()?,
            _ => {
                return Err(self.error(
                    "expected a number after `^` (an exponent is a number, not an expression)"
                        .to_string(),
                ))
            }
        };
        let exponent = if negative { -exponent } else { exponent };
        Ok(Node::Power(Box::new(base), exponent))
    }

    /// A number, a name, `pi`, a function call or a parenthesised expression.
    fn atom(&mut self) -> Result<Node, ExpressionError> {
        self.skip_space();
        match self.peek() {
            Some('(') => {
                self.at += 1;
                let node = self.sum()?;
                self.expect(')')?;
                Ok(node)
            }
            Some(c) if c.is_ascii_digit() || c == '.' => Ok(Node::Number(self.number()?)),
            Some(c) if c.is_alphabetic() || c == '_' => self.word(),
            Some(c) => Err(self.error(format!("expected a number, a name or `(`, found `{c}`"))),
            None => Err(self.error("expected a number, a name or `(`, found the end".into())),
        }
    }

    fn number(&mut self) -> Result<f64, ExpressionError> {
        let start = self.at;
        while self.peek().is_some_and(|c| c.is_ascii_digit() || c == '.') {
            self.at += 1;
        }
        // An exponent: `e` or `E`, an optional sign, digits.
        if matches!(self.peek(), Some('e' | 'E')) {
            let mark = self.at;
            self.at += 1;
            if matches!(self.peek(), Some('+' | '-')) {
                self.at += 1;
            }
            if !self.peek().is_some_and(|c| c.is_ascii_digit()) {
                self.at = mark;
            }
            while self.peek().is_some_and(|c| c.is_ascii_digit()) {
                self.at += 1;
            }
        }
        let text: String = self.chars[start..self.at].iter().collect();
        text.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| ExpressionError {
                at: start,
                message: format!("`{text}` is not a finite number"),
            })
    }

    /// A name, `pi`, or a function and its parenthesised argument(s).
    fn word(&mut self) -> Result<Node, ExpressionError> {
        let start = self.at;
        while self.peek().is_some_and(|c| c.is_alphanumeric() || c == '_') {
            self.at += 1;
        }
        let word: String = self.chars[start..self.at].iter().collect();
        let at_word = |message: String| ExpressionError { at: start, message };
        if self.take('(') {
            if word == "atan2" {
                let y = self.sum()?;
                self.expect(',')?;
                let x = self.sum()?;
                self.expect(')')?;
                return Ok(Node::Atan2(Box::new(y), Box::new(x)));
            }
            let Some(&(_, function)) = FUNCTIONS.iter().find(|(n, _)| *n == word) else {
                let known: Vec<&str> = FUNCTIONS.iter().map(|(n, _)| *n).collect();
                return Err(at_word(format!(
                    "unknown function `{word}`; expected one of {}, atan2",
                    known.join(", ")
                )));
            };
            let argument = self.sum()?;
            self.expect(')')?;
            return Ok(Node::Call(function, Box::new(argument)));
        }
        if let Some(i) = self.names.iter().position(|n| *n == word) {
            return Ok(Node::Name(i));
        }
        if word == "pi" {
            return Ok(Node::Number(std::f64::consts::PI));
        }
        Err(at_word(match self.names.is_empty() {
            true => format!("`{word}` is not a quantity (the model defines none)"),
            false => format!(
                "`{word}` is not a quantity; expected one of {}",
                self.names.join(", ")
            ),
        }))
    }
}

#[cfg(test)]
mod tests {
    use num_dual::{Dual64, DualNum};

    use super::Expression;

    const NAMES: [&str; 3] = ["radius", "angle", "arm"];

    fn value(text: &str, values: &[f64]) -> f64 {
        Expression::parse(text, &NAMES).unwrap().eval(values)
    }

    /// Each operator, function and precedence rule against the same arithmetic in Rust.
    #[test]
    fn values_follow_the_usual_rules() {
        let v = [0.175, 3.665, 0.3];
        let (r, a, l) = (v[0], v[1], v[2]);
        let cases: [(&str, f64); 16] = [
            ("radius * cos(angle)", r * a.cos()),
            ("radius*sin(angle)", r * a.sin()),
            ("1 + 2 * 3", 7.0),
            ("(1 + 2) * 3", 9.0),
            ("2 - 3 - 4", -5.0),
            ("8 / 4 / 2", 1.0),
            ("-arm^2", -(l * l)),
            ("2^3 * 2", 16.0),
            ("arm^-1", 1.0 / l),
            ("arm^0.5", l.sqrt()),
            ("sqrt(arm^2 - radius^2)", (l * l - r * r).sqrt()),
            ("atan2(radius, -arm)", r.atan2(-l)),
            (
                "tan(angle) + asin(0.5) + acos(0.5) + atan(2)",
                a.tan() + 0.5f64.asin() + 0.5f64.acos() + 2f64.atan(),
            ),
            ("exp(ln(arm))", l),
            ("1.5e-3 + 2E2 + .5", 1.5e-3 + 200.0 + 0.5),
            ("pi / 2 - +angle", std::f64::consts::FRAC_PI_2 - a),
        ];
        for (text, expected) in cases {
            let got = value(text, &v);
            assert!(
                (got - expected).abs() <= 1e-15 * expected.abs().max(1.0),
                "{text}: {got} vs {expected}"
            );
        }
    }

    /// On dual numbers the derivative is the expression's: d/dθ (r cos θ) = −r sin θ, and
    /// d/dr sqrt(L² − r²) = −r / sqrt(L² − r²), against central differences too.
    #[test]
    fn duals_carry_the_derivative() {
        let e = Expression::parse("radius * cos(angle) + sqrt(arm^2 - radius^2)", &NAMES).unwrap();
        let v = [0.175, 3.665, 0.3];
        for k in 0..3 {
            let duals: Vec<Dual64> = (0..3)
                .map(|i| {
                    let d = Dual64::from_re(v[i]);
                    if i == k {
                        d.derivative()
                    } else {
                        d
                    }
                })
                .collect();
            let got = e.eval(&duals).eps;
            let h = 1e-6;
            let (mut up, mut down) = (v, v);
            up[k] += h;
            down[k] -= h;
            let fd = (e.eval(&up) - e.eval(&down)) / (2.0 * h);
            assert!((got - fd).abs() < 1e-8, "column {k}: {got} vs {fd}");
        }
        let angle = Dual64::from_re(v[1]).derivative();
        let d = e.eval(&[Dual64::from_re(v[0]), angle, Dual64::from_re(v[2])]);
        assert!((d.eps + v[0] * v[1].sin()).abs() < 1e-15);
        assert!((d.re - e.eval(&v)).abs() < 1e-15);
    }

    #[test]
    fn names_used_are_listed_once() {
        let e = Expression::parse("arm + radius * arm - 1", &NAMES).unwrap();
        assert_eq!(e.names_used(), vec![0, 2]);
        assert_eq!(e.text(), "arm + radius * arm - 1");
        assert!(Expression::parse("2 * pi", &NAMES)
            .unwrap()
            .names_used()
            .is_empty());
    }

    /// Each malformed expression names the character at fault and what it expected.
    #[test]
    fn errors_point_at_the_character() {
        let cases = [
            ("radius * cos(angle", 18, "expected `)`, found the end"),
            ("radius +", 8, "found the end"),
            (
                "radius * rod",
                9,
                "`rod` is not a quantity; expected one of radius, angle, arm",
            ),
            ("cosh(angle)", 0, "unknown function `cosh`"),
            ("arm ^ radius", 6, "an exponent is a number"),
            ("2 radius", 2, "expected an operator or the end, found `r`"),
            ("radius # 2", 7, "found `#`"),
            ("atan2(radius)", 12, "expected `,`"),
            ("1e999", 0, "`1e999` is not a finite number"),
            ("1.2.3", 0, "`1.2.3` is not a finite number"),
            ("2^3^2", 3, "expected an operator or the end, found `^`"),
            ("", 0, "found the end"),
        ];
        for (text, at, message) in cases {
            let error = Expression::parse(text, &NAMES).unwrap_err();
            assert_eq!(error.at, at, "{text}: {error}");
            assert!(error.message.contains(message), "{text}: {error}");
        }
        let none = Expression::parse("rod", &[]).unwrap_err();
        assert!(none.message.contains("the model defines none"), "{none:?}");
        assert_eq!(
            none.to_string(),
            "at character 1: `rod` is not a quantity (the model defines none)"
        );
    }
}

//! Values: expressions evaluated with units converted to GENESIS units at the model's rate.
//!
//! Every literal with a unit is converted where it is written: `440Hz` becomes `440/Fs` cycles per
//! sample, `10ms` becomes `Fs/100` samples, `1000N/m` becomes `1000/Fs^2`. A bare number is already
//! in GENESIS units. Each value also carries the *kind* of unit it was given in, so that a
//! frequency given where a stiffness is expected is an error rather than a silent mistake.

use std::collections::HashMap;

use crate::error::{did_you_mean, Diagnostic, ErrorKind};
use crate::syntax::{BinOp, Expr, ExprKind};

/// The kind of quantity a value was written as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// No unit: a bare number, taken in GENESIS units.
    Plain,
    /// A time (written in s, ms, us or samples), in samples.
    Time,
    /// A frequency (written in Hz or kHz), in cycles per sample.
    Freq,
    /// A stiffness (written in N/m), in GENESIS units `k/Fs^2`.
    Stiffness,
    /// A viscosity (written in Ns/m), in GENESIS units `z/Fs`.
    Viscosity,
    /// A velocity (written in m/s), in length per sample.
    Velocity,
    /// A product or ratio of different units: not checked.
    Mixed,
}

impl Kind {
    /// How a kind is named in messages.
    pub fn describe(self) -> &'static str {
        match self {
            Kind::Plain => "a plain number",
            Kind::Time => "a time (s, ms)",
            Kind::Freq => "a frequency (Hz)",
            Kind::Stiffness => "a stiffness (N/m)",
            Kind::Viscosity => "a viscosity (Ns/m)",
            Kind::Velocity => "a velocity (m/s)",
            Kind::Mixed => "a combination of units",
        }
    }
}

/// A number and the kind of unit it was written in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Value {
    /// In GENESIS units.
    pub v: f64,
    /// The kind of unit.
    pub kind: Kind,
}

/// What evaluation needs: the sample rate and the `let` values defined so far.
pub struct Env {
    /// Sample rate in Hz, for unit conversion.
    pub fs: f64,
    /// `let` values.
    pub lets: HashMap<String, Value>,
    /// `let` names whose definition failed: uses of them are not reported again.
    pub failed: std::collections::HashSet<String>,
}

const FUNCTIONS: &[&str] = &["sqrt", "sin", "cos", "tan", "exp", "log", "abs"];

fn combine(op: BinOp, a: Kind, b: Kind) -> Kind {
    use Kind::*;
    match op {
        BinOp::Add | BinOp::Sub => match (a, b) {
            (x, y) if x == y => x,
            (Plain, y) => y,
            (x, Plain) => x,
            _ => Mixed,
        },
        BinOp::Mul => match (a, b) {
            (Plain, y) => y,
            (x, Plain) => x,
            _ => Mixed,
        },
        BinOp::Div => match (a, b) {
            (x, Plain) => x,
            (x, y) if x == y => Plain,
            _ => Mixed,
        },
        BinOp::Pow => {
            if a == Plain && b == Plain {
                Plain
            } else {
                Mixed
            }
        }
    }
}

impl Env {
    /// Converts `v` written in `unit` to GENESIS units.
    pub fn convert(&self, v: f64, unit: &str) -> Value {
        let fs = self.fs;
        let (v, kind) = match unit {
            "Hz" => (v / fs, Kind::Freq),
            "kHz" => (v * 1000.0 / fs, Kind::Freq),
            "s" => (v * fs, Kind::Time),
            "ms" => (v * fs / 1000.0, Kind::Time),
            "us" => (v * fs / 1_000_000.0, Kind::Time),
            "samples" => (v, Kind::Time),
            "N/m" => (v / (fs * fs), Kind::Stiffness),
            "Ns/m" | "N.s/m" => (v / fs, Kind::Viscosity),
            "m/s" => (v / fs, Kind::Velocity),
            _ => (v, Kind::Mixed),
        };
        Value { v, kind }
    }

    /// Evaluates a numeric expression.
    pub fn eval(&self, e: &Expr) -> Result<Value, Diagnostic> {
        let plain = |v| Value {
            v,
            kind: Kind::Plain,
        };
        let r = match &e.kind {
            ExprKind::Num(v) => plain(*v),
            ExprKind::Name(n) => match self.lets.get(n) {
                Some(v) => *v,
                None if n == "pi" => plain(std::f64::consts::PI),
                // already reported where it was defined: an empty message is not shown
                None if self.failed.contains(n) => {
                    return Err(Diagnostic::error(ErrorKind::UnknownName, e.span, ""))
                }
                None => {
                    let hint = did_you_mean(n, self.lets.keys().map(String::as_str).chain(["pi"]))
                        .unwrap_or_else(|| "define it first with `let NAME = VALUE`".into());
                    return Err(Diagnostic::error(
                        ErrorKind::UnknownName,
                        e.span,
                        format!("unknown value `{n}`"),
                    )
                    .with_hint(hint));
                }
            },
            ExprKind::Neg(a) => {
                let a = self.eval(a)?;
                Value { v: -a.v, ..a }
            }
            ExprKind::Bin(op, ea, eb) => {
                let (a, b) = (self.eval(ea)?, self.eval(eb)?);
                if matches!(op, BinOp::Add | BinOp::Sub)
                    && a.kind != b.kind
                    && ![Kind::Plain, Kind::Mixed].contains(&a.kind)
                    && ![Kind::Plain, Kind::Mixed].contains(&b.kind)
                {
                    return Err(Diagnostic::error(
                        ErrorKind::UnitMismatch,
                        e.span,
                        format!(
                            "cannot add or subtract {} and {}",
                            a.kind.describe(),
                            b.kind.describe()
                        ),
                    ));
                }
                let v = match op {
                    BinOp::Add => a.v + b.v,
                    BinOp::Sub => a.v - b.v,
                    BinOp::Mul => a.v * b.v,
                    BinOp::Div => a.v / b.v,
                    BinOp::Pow => a.v.powf(b.v),
                };
                Value {
                    v,
                    kind: combine(*op, a.kind, b.kind),
                }
            }
            ExprKind::Call(f, args) => {
                let name = f.text.to_ascii_lowercase();
                if !FUNCTIONS.contains(&name.as_str()) {
                    return Err(Diagnostic::error(
                        ErrorKind::UnknownName,
                        f.span,
                        format!("unknown function `{}`", f.text),
                    )
                    .with_hint(
                        did_you_mean(&f.text, FUNCTIONS.iter().copied())
                            .unwrap_or_else(|| format!("functions are {}", FUNCTIONS.join(", "))),
                    ));
                }
                if args.len() != 1 || args[0].key.is_some() {
                    return Err(Diagnostic::error(
                        ErrorKind::Syntax,
                        e.span,
                        format!("`{name}` takes one value"),
                    ));
                }
                let a = self.eval(&args[0].value)?;
                let v = match name.as_str() {
                    "sqrt" => a.v.sqrt(),
                    "sin" => a.v.sin(),
                    "cos" => a.v.cos(),
                    "tan" => a.v.tan(),
                    "exp" => a.v.exp(),
                    "log" => a.v.ln(),
                    _ => a.v.abs(),
                };
                let kind = if name == "abs" || a.kind == Kind::Plain {
                    a.kind
                } else {
                    Kind::Mixed
                };
                Value { v, kind }
            }
            ExprKind::Unit(inner, unit) => {
                let a = self.eval(inner)?;
                if a.kind != Kind::Plain {
                    return Err(Diagnostic::error(
                        ErrorKind::UnitMismatch,
                        unit.span,
                        format!(
                            "a unit on a value that already has one ({})",
                            a.kind.describe()
                        ),
                    ));
                }
                self.convert(a.v, &unit.text)
            }
            ExprKind::Str(_) | ExprKind::Tuple(_) | ExprKind::Curve(_) | ExprKind::List(_) => {
                return Err(Diagnostic::error(
                    ErrorKind::Syntax,
                    e.span,
                    "expected a number here",
                ));
            }
        };
        if !r.v.is_finite() {
            return Err(Diagnostic::error(ErrorKind::NonFinite, e.span, format!("this value is not finite ({})", r.v))
                .with_hint("check for a division by zero, the log or sqrt of a negative number, or an overflow"));
        }
        Ok(r)
    }

    /// Evaluates a number that should be of kind `want` (a plain number is always accepted, and
    /// read in GENESIS units).
    pub fn number(&self, e: &Expr, want: Kind, what: &str) -> Result<f64, Diagnostic> {
        let v = self.eval(e)?;
        if v.kind != want && v.kind != Kind::Plain && v.kind != Kind::Mixed && want != Kind::Mixed {
            return Err(Diagnostic::error(
                ErrorKind::UnitMismatch,
                e.span,
                format!(
                    "{what} expects {}, but this is {}",
                    want.describe(),
                    v.kind.describe()
                ),
            ));
        }
        Ok(v.v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::syntax::parse_expr;

    fn ev(text: &str) -> Value {
        let env = Env {
            fs: 44100.0,
            lets: HashMap::from([(
                "k".into(),
                Value {
                    v: 0.5,
                    kind: Kind::Plain,
                },
            )]),
            failed: Default::default(),
        };
        env.eval(&parse_expr(text).unwrap()).unwrap()
    }

    #[test]
    fn arithmetic_and_functions() {
        assert_eq!(ev("1 + 2 * 3").v, 7.0);
        assert_eq!(ev("-2^2").v, -4.0);
        assert_eq!(ev("2^-1").v, 0.5);
        assert_eq!(ev("2^3^2").v, 512.0);
        assert_eq!(ev("(1 + 2) * k").v, 1.5);
        assert_eq!(ev("sqrt(16) + exp(0) + log(1) + cos(0) + sin(0)").v, 6.0);
        assert_eq!(ev("pi").v, std::f64::consts::PI);
    }

    #[test]
    fn units_convert_exactly_with_the_rate() {
        assert_eq!(
            ev("10ms"),
            Value {
                v: 441.0,
                kind: Kind::Time
            }
        );
        assert_eq!(ev("1.5s").v, 66150.0);
        assert_eq!(ev("441Hz").v, 0.01);
        assert_eq!(ev("44100N/m").v, 1.0 / 44100.0);
        assert_eq!(ev("4410Ns/m").v, 0.1);
        assert_eq!(ev("2 * 440Hz").kind, Kind::Freq);
        assert_eq!(ev("10ms / 1s").kind, Kind::Plain);
    }

    #[test]
    fn wrong_kinds_are_refused() {
        let env = Env {
            fs: 44100.0,
            lets: HashMap::new(),
            failed: Default::default(),
        };
        let e = env
            .number(&parse_expr("440Hz").unwrap(), Kind::Stiffness, "K")
            .unwrap_err();
        assert_eq!(e.kind, ErrorKind::UnitMismatch);
        assert!(e.message.contains("K expects a stiffness"), "{}", e.message);
        assert!(env.eval(&parse_expr("1/0").unwrap()).is_err());
        let e = env.eval(&parse_expr("kk").unwrap()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::UnknownName);
        let e = env.eval(&parse_expr("1N/m + 1Hz").unwrap()).unwrap_err();
        assert_eq!(e.kind, ErrorKind::UnitMismatch);
        assert!(
            e.message.contains("a stiffness (N/m) and a frequency (Hz)"),
            "{}",
            e.message
        );
        assert!(env.eval(&parse_expr("1N/m + 2").unwrap()).is_ok());
    }
}

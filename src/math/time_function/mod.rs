//! Functions of time for drives and loads: constants, expressions of `t` and tables.
//!
//! Expressions are written in a small pure language ([`expression`]): a model file can name
//! arithmetic, `sin`, `cos`, `exp`, …, comparisons and conditionals of `t` and the constants
//! `pi`, `tau`, `e`, and nothing else — it can never execute code. Value, rate and
//! acceleration come from one evaluation over second-order Taylor numbers ([`jet`]), so
//! prescribed motions have exact, consistent velocities and accelerations.

pub mod expression;
pub mod jet;
mod mean;

use expression::Expression;
use jet::Jet;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// A function of time: a number, an expression of `t` (e.g. `"0.5*sin(2*pi*t)"`) or a table.
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(untagged)]
pub enum TimeFunctionSpec {
    Constant(f64),
    Expression(String),
    /// Piecewise-linear in `t`, held constant beyond the ends.
    Table(TableSpec),
}

/// A table of a function of time: `{t: [...], value: [...]}` (no other keys).
#[derive(Serialize, Deserialize, JsonSchema, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    pub t: Vec<f64>,
    pub value: Vec<f64>,
}

#[derive(Clone, Debug)]
pub enum TimeFunction {
    Constant(f64),
    Expression {
        text: String,
        expression: Expression,
    },
    /// Piecewise-linear table; constant beyond its ends.
    Table {
        t: Vec<f64>,
        v: Vec<f64>,
    },
}

impl TimeFunction {
    /// The function of an expression known to be valid (tests).
    #[cfg(test)]
    pub fn expression(text: &str) -> TimeFunction {
        TimeFunction::new(&TimeFunctionSpec::Expression(text.into())).unwrap()
    }

    /// Builds a time function; the error text says what is wrong with the expression or table.
    pub fn new(spec: &TimeFunctionSpec) -> Result<Self, String> {
        match spec {
            TimeFunctionSpec::Constant(c) => {
                if !c.is_finite() {
                    return Err("must be a finite number".into());
                }
                Ok(TimeFunction::Constant(*c))
            }
            TimeFunctionSpec::Expression(text) => {
                let expression = Expression::parse(text)
                    .map_err(|e| format!("cannot use expression `{}`: {e}", abbreviated(text)))?;
                let f = TimeFunction::Expression {
                    text: text.clone(),
                    expression,
                };
                // Evaluate once to catch e.g. `log(t - 1)` at t = 0 before a run starts.
                let v0 = f.value(0.0);
                if !v0.is_finite() {
                    return Err(format!(
                        "expression `{}` is not finite at t = 0 (value {v0})",
                        abbreviated(text)
                    ));
                }
                Ok(f)
            }
            TimeFunctionSpec::Table(TableSpec { t, value }) => {
                if t.len() != value.len() || t.is_empty() {
                    return Err(format!(
                        "table needs equally long, non-empty `t` and `value` (got {} and {})",
                        t.len(),
                        value.len()
                    ));
                }
                if t.windows(2).any(|w| w[1] <= w[0]) {
                    return Err("table times `t` must be strictly increasing".into());
                }
                if t.iter().chain(value).any(|x| !x.is_finite()) {
                    return Err("table entries must be finite numbers".into());
                }
                Ok(TimeFunction::Table {
                    t: t.clone(),
                    v: value.clone(),
                })
            }
        }
    }

    pub fn value(&self, time: f64) -> f64 {
        match self {
            TimeFunction::Constant(c) => *c,
            TimeFunction::Expression { expression, .. } => expression.eval(time).v,
            TimeFunction::Table { t, v } => {
                let (k, s) = locate(t, time);
                if t.len() == 1 {
                    v[0]
                } else {
                    v[k] + s * (v[k + 1] - v[k])
                }
            }
        }
    }

    /// Time derivative (for tables: the slope of the segment; 0 outside the table).
    pub fn rate(&self, time: f64) -> f64 {
        match self {
            TimeFunction::Constant(_) => 0.0,
            TimeFunction::Expression { expression, .. } => expression.eval(time).d,
            TimeFunction::Table { t, v } => {
                if t.len() == 1 || time < t[0] || time > t[t.len() - 1] {
                    return 0.0;
                }
                let (k, _) = locate(t, time);
                (v[k + 1] - v[k]) / (t[k + 1] - t[k])
            }
        }
    }

    /// The middle of each segment of a table (empty for other functions): a short segment
    /// can hold a burst of rate that sampling at even times would miss.
    pub fn segment_midpoints(&self) -> impl Iterator<Item = f64> + '_ {
        let t: &[f64] = match self {
            TimeFunction::Table { t, .. } => t,
            _ => &[],
        };
        t.windows(2).map(|w| 0.5 * (w[0] + w[1]))
    }

    /// Value, rate and acceleration in one evaluation.
    pub fn jet(&self, time: f64) -> Jet {
        match self {
            TimeFunction::Expression { expression, .. } => expression.eval(time),
            _ => Jet {
                v: self.value(time),
                d: self.rate(time),
                dd: 0.0,
            },
        }
    }

    pub fn accel(&self, time: f64) -> f64 {
        match self {
            TimeFunction::Expression { expression, .. } => expression.eval(time).dd,
            _ => 0.0,
        }
    }
}

/// The start of a long expression, for messages.
fn abbreviated(text: &str) -> String {
    const SHOWN: usize = 60;
    if text.chars().count() <= SHOWN {
        text.to_string()
    } else {
        format!("{}…", text.chars().take(SHOWN).collect::<String>())
    }
}

/// Segment index and fraction for linear interpolation, clamped to the table.
fn locate(t: &[f64], time: f64) -> (usize, f64) {
    if time.is_nan() {
        return (0, f64::NAN);
    }
    if t.len() == 1 || time <= t[0] {
        return (0, 0.0);
    }
    if time >= t[t.len() - 1] {
        return (t.len().saturating_sub(2), 1.0);
    }
    let k = t.partition_point(|&x| x <= time) - 1;
    (k, (time - t[k]) / (t[k + 1] - t[k]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn expr(s: &str) -> Result<TimeFunction, String> {
        TimeFunction::new(&TimeFunctionSpec::Expression(s.into()))
    }

    #[test]
    fn vdtr_nacelle_tilt_expression_and_its_rate() {
        let f = expr("0.25*pi*(1 - sin(2*pi*(t/40 + 0.25)))").unwrap();
        let g = |t: f64| {
            0.25 * std::f64::consts::PI
                * (1.0 - (2.0 * std::f64::consts::PI * (t / 40.0 + 0.25)).sin())
        };
        for t in [0.0, 3.7, 20.0] {
            assert!((f.value(t) - g(t)).abs() < 1e-14);
            let fd = (g(t + 1e-5) - g(t - 1e-5)) / 2e-5;
            assert!((f.rate(t) - fd).abs() < 1e-9, "rate at {t}");
        }
        assert!((f.value(20.0) - 0.5 * std::f64::consts::PI).abs() < 1e-14);
    }

    #[test]
    fn malformed_or_foreign_expressions_are_errors() {
        assert!(expr("sin(t").unwrap_err().contains("expected `)`"));
        assert!(expr("x + t").unwrap_err().contains("unknown name `x`"));
        assert!(expr("import os").is_err());
        assert!(expr("log(t - 1)").unwrap_err().contains("not finite"));
    }

    #[test]
    fn expression_without_t_and_linear_rate() {
        let f = expr("2*pi").unwrap();
        assert_eq!(f.rate(1.0), 0.0);
        let g = expr("3*t + 1").unwrap();
        assert_eq!(g.rate(5.0), 3.0);
        assert_eq!(g.accel(5.0), 0.0);
    }

    #[test]
    fn table_interpolates_and_holds_ends() {
        let f = TimeFunction::new(&TimeFunctionSpec::Table(TableSpec {
            t: vec![0.0, 1.0, 3.0],
            value: vec![0.0, 2.0, 0.0],
        }))
        .unwrap();
        assert_eq!(f.value(0.5), 1.0);
        assert_eq!(f.value(2.0), 1.0);
        assert_eq!(f.value(10.0), 0.0);
        assert_eq!(f.rate(0.5), 2.0);
        assert_eq!(f.rate(2.0), -1.0);
        assert!(TimeFunction::new(&TimeFunctionSpec::Table(TableSpec {
            t: vec![0.0, 0.0],
            value: vec![1.0, 2.0]
        }))
        .is_err());
    }
}

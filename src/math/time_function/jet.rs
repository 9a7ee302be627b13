//! Second-order Taylor numbers: a value with its first and second time derivatives.
//!
//! Evaluating an expression of `t` over `Jet { v: t, d: 1, dd: 0 }` gives the function, its
//! rate and its acceleration exactly (to round-off) in one pass, by the chain rule
//! f(g)'' = f''(g)·g'² + f'(g)·g''. No symbolic differentiation, so no expression can make
//! the derivative grow or recurse.

use std::ops::{Add, Div, Mul, Neg, Sub};

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Jet {
    pub v: f64,
    pub d: f64,
    pub dd: f64,
}

impl Jet {
    pub const fn constant(v: f64) -> Self {
        Jet { v, d: 0.0, dd: 0.0 }
    }
    pub const fn time(t: f64) -> Self {
        Jet {
            v: t,
            d: 1.0,
            dd: 0.0,
        }
    }
    /// f(self) from f(v), f'(v), f''(v) (chain rule to second order).
    pub fn chain(self, f: f64, df: f64, ddf: f64) -> Self {
        Jet {
            v: f,
            d: df * self.d,
            dd: ddf * self.d * self.d + df * self.dd,
        }
    }
    pub fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(s, c, -s)
    }
    pub fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.chain(c, -s, -c)
    }
    pub fn tan(self) -> Self {
        let t = self.v.tan();
        let sec2 = 1.0 + t * t;
        self.chain(t, sec2, 2.0 * t * sec2)
    }
    pub fn asin(self) -> Self {
        let q = 1.0 - self.v * self.v;
        self.chain(self.v.asin(), q.powf(-0.5), self.v * q.powf(-1.5))
    }
    pub fn acos(self) -> Self {
        let q = 1.0 - self.v * self.v;
        self.chain(self.v.acos(), -q.powf(-0.5), -self.v * q.powf(-1.5))
    }
    pub fn atan(self) -> Self {
        let q = 1.0 + self.v * self.v;
        self.chain(self.v.atan(), 1.0 / q, -2.0 * self.v / (q * q))
    }
    pub fn sinh(self) -> Self {
        self.chain(self.v.sinh(), self.v.cosh(), self.v.sinh())
    }
    pub fn cosh(self) -> Self {
        self.chain(self.v.cosh(), self.v.sinh(), self.v.cosh())
    }
    pub fn tanh(self) -> Self {
        let t = self.v.tanh();
        let s = 1.0 - t * t;
        self.chain(t, s, -2.0 * t * s)
    }
    pub fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e, e)
    }
    /// Natural logarithm.
    pub fn ln(self) -> Self {
        self.chain(self.v.ln(), 1.0 / self.v, -1.0 / (self.v * self.v))
    }
    pub fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        self.chain(r, 0.5 / r, -0.25 / (r * self.v))
    }
    pub fn cbrt(self) -> Self {
        let r = self.v.cbrt();
        let d = 1.0 / (3.0 * r * r);
        self.chain(r, d, -2.0 * d / (3.0 * self.v))
    }
    /// `self^p` for a constant exponent `p` (exact also for negative bases and integer `p`).
    pub fn powf(self, p: f64) -> Self {
        if p == 0.0 {
            return Jet::constant(1.0);
        }
        let f = self.v.powf(p);
        let df = p * self.v.powf(p - 1.0);
        let ddf = if p == 1.0 {
            0.0
        } else {
            p * (p - 1.0) * self.v.powf(p - 2.0)
        };
        self.chain(f, df, ddf)
    }
    /// `self^e` for a time-varying exponent: exp(e·ln self), defined for a positive base.
    pub fn pow(self, e: Jet) -> Self {
        if e.d == 0.0 && e.dd == 0.0 {
            return self.powf(e.v);
        }
        (e * self.ln()).exp()
    }
    pub fn atan2(self, x: Jet) -> Self {
        // atan2(y, x) has the derivatives of atan(y/x) wherever it is differentiable.
        let r2 = self.v * self.v + x.v * x.v;
        let v = self.v.atan2(x.v);
        let d = (x.v * self.d - self.v * x.d) / r2;
        // d/dt of (x y' − y x')/r² = (x y'' − y x'')/r² − (x y' − y x')·2(x x' + y y')/r⁴
        let num = x.v * self.d - self.v * x.d;
        let dd = (x.v * self.dd - self.v * x.dd) / r2
            - num * 2.0 * (x.v * x.d + self.v * self.d) / (r2 * r2);
        Jet { v, d, dd }
    }
    /// A function that is locally constant (floor, ceil, round, sign, step): zero rates.
    pub fn flat(v: f64) -> Self {
        Jet::constant(v)
    }
    pub fn scale(self, s: f64) -> Self {
        Jet {
            v: self.v * s,
            d: self.d * s,
            dd: self.dd * s,
        }
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(self, o: Jet) -> Jet {
        Jet {
            v: self.v + o.v,
            d: self.d + o.d,
            dd: self.dd + o.dd,
        }
    }
}
impl Sub for Jet {
    type Output = Jet;
    fn sub(self, o: Jet) -> Jet {
        Jet {
            v: self.v - o.v,
            d: self.d - o.d,
            dd: self.dd - o.dd,
        }
    }
}
impl Mul for Jet {
    type Output = Jet;
    fn mul(self, o: Jet) -> Jet {
        Jet {
            v: self.v * o.v,
            d: self.d * o.v + self.v * o.d,
            dd: self.dd * o.v + 2.0 * self.d * o.d + self.v * o.dd,
        }
    }
}
impl Div for Jet {
    type Output = Jet;
    fn div(self, o: Jet) -> Jet {
        // q = a/b, q' = (a' − q b')/b, q'' = (a'' − 2 q' b' − q b'')/b
        let q = self.v / o.v;
        let d = (self.d - q * o.d) / o.v;
        let dd = (self.dd - 2.0 * d * o.d - q * o.dd) / o.v;
        Jet { v: q, d, dd }
    }
}
impl Neg for Jet {
    type Output = Jet;
    fn neg(self) -> Jet {
        self.scale(-1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of a scalar function: rate and acceleration (h = 1e-4 leaves
    /// truncation ~1e-8 and round-off ~1e-8 for O(1) functions).
    fn fd(f: impl Fn(f64) -> f64, t: f64) -> (f64, f64) {
        let h = 1e-4;
        let (a, b, c) = (f(t - h), f(t), f(t + h));
        ((c - a) / (2.0 * h), (c - 2.0 * b + a) / (h * h))
    }

    #[test]
    fn every_operation_matches_central_differences() {
        let cases: Vec<(&str, Box<dyn Fn(Jet) -> Jet>)> = vec![
            ("sin", Box::new(|x: Jet| x.sin())),
            ("cos", Box::new(|x: Jet| x.cos())),
            ("tan", Box::new(|x: Jet| x.tan())),
            ("asin", Box::new(|x: Jet| x.scale(0.1).asin())),
            ("acos", Box::new(|x: Jet| x.scale(0.1).acos())),
            ("atan", Box::new(|x: Jet| x.atan())),
            ("sinh", Box::new(|x: Jet| x.sinh())),
            ("cosh", Box::new(|x: Jet| x.cosh())),
            ("tanh", Box::new(|x: Jet| x.tanh())),
            ("exp", Box::new(|x: Jet| x.exp())),
            ("ln", Box::new(|x: Jet| x.ln())),
            ("sqrt", Box::new(|x: Jet| x.sqrt())),
            ("cbrt", Box::new(|x: Jet| x.cbrt())),
            ("powf", Box::new(|x: Jet| x.powf(2.5))),
            ("pow", Box::new(|x: Jet| x.pow(x.sin()))),
            ("atan2", Box::new(|x: Jet| x.sin().atan2(x.cos() + x))),
            ("mul", Box::new(|x: Jet| x * x.exp())),
            (
                "div",
                Box::new(|x: Jet| x.sin() / (x * x + Jet::constant(1.0))),
            ),
        ];
        for (name, f) in cases {
            for t in [0.4, 1.3, 2.2] {
                // Inner function g(t) = t² + 0.1 t so the chain rule's g'' term is exercised.
                let g = |t: f64| Jet::time(t) * Jet::time(t) + Jet::time(t).scale(0.1);
                let j = f(g(t));
                let (d, dd) = fd(|s| f(g(s)).v, t);
                let tol = 1e-6 * (1.0 + j.d.abs() + j.dd.abs());
                assert!((j.d - d).abs() < tol, "{name}'({t}): {} vs {d}", j.d);
                assert!(
                    (j.dd - dd).abs() < 1e3 * tol,
                    "{name}''({t}): {} vs {dd}",
                    j.dd
                );
            }
        }
    }
}

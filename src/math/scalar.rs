//! Scalars the physics is written over: `f64` for residuals and a forward-mode dual number
//! [`Dual`] for exact tangents.
//!
//! Every element and joint evaluates its residual through the generic [`Real`] trait, so its
//! tangent is the exact derivative of the very residual it assembles (no hand-derived
//! linearisation to drift out of step with the forces). `Dual` is `Copy` and lives on the stack,
//! which keeps the Newton loop free of allocations.

use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// Number of derivative directions carried by one dual pass. A local block with `n` unknowns
/// takes `ceil(n / DUAL_WIDTH)` residual evaluations.
pub const DUAL_WIDTH: usize = 8;

/// The arithmetic the physics needs: field operations, mixed operations with `f64`, and the
/// few elementary functions of rotations.
pub trait Real:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
    + 'static
{
    /// Whether values carry derivatives (a dual); `f64` carries none, so first-order shortcuts
    /// may skip their variation terms.
    const DERIVATIVES: bool;
    fn cst(x: f64) -> Self;
    /// The value part (drops derivatives).
    fn re(self) -> f64;
    fn sqrt(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn zero() -> Self {
        Self::cst(0.0)
    }
    fn one() -> Self {
        Self::cst(1.0)
    }
    fn powi2(self) -> Self {
        self * self
    }
}

impl Real for f64 {
    const DERIVATIVES: bool = false;
    #[inline]
    fn cst(x: f64) -> Self {
        x
    }
    #[inline]
    fn re(self) -> f64 {
        self
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        f64::atan2(self, x)
    }
}

/// Forward-mode dual number with `N` derivative directions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const N: usize> {
    pub re: f64,
    pub du: [f64; N],
}

impl<const N: usize> Dual<N> {
    #[inline]
    pub fn constant(re: f64) -> Self {
        Self { re, du: [0.0; N] }
    }
    /// A variable seeded in direction `k` (or a constant if `k` is `None`).
    #[inline]
    pub fn seeded(re: f64, k: Option<usize>) -> Self {
        let mut d = Self::constant(re);
        if let Some(k) = k {
            d.du[k] = 1.0;
        }
        d
    }
    #[inline]
    fn chain(self, f: f64, df: f64) -> Self {
        let mut du = self.du;
        for v in &mut du {
            *v *= df;
        }
        Self { re: f, du }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: Self) -> Self {
        self.re += o.re;
        for k in 0..N {
            self.du[k] += o.du[k];
        }
        self
    }
}
impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: Self) -> Self {
        self.re -= o.re;
        for k in 0..N {
            self.du[k] -= o.du[k];
        }
        self
    }
}
impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        let mut du = [0.0; N];
        for (k, d) in du.iter_mut().enumerate() {
            *d = self.du[k] * o.re + self.re * o.du[k];
        }
        Self {
            re: self.re * o.re,
            du,
        }
    }
}
impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.re;
        let re = self.re * inv;
        let mut du = [0.0; N];
        for (k, d) in du.iter_mut().enumerate() {
            *d = (self.du[k] - re * o.du[k]) * inv;
        }
        Self { re, du }
    }
}
impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline]
    fn neg(mut self) -> Self {
        self.re = -self.re;
        for v in &mut self.du {
            *v = -*v;
        }
        self
    }
}
impl<const N: usize> Add<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: f64) -> Self {
        self.re += o;
        self
    }
}
impl<const N: usize> Sub<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: f64) -> Self {
        self.re -= o;
        self
    }
}
impl<const N: usize> Mul<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(mut self, o: f64) -> Self {
        self.re *= o;
        for v in &mut self.du {
            *v *= o;
        }
        self
    }
}
impl<const N: usize> Div<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: f64) -> Self {
        self * (1.0 / o)
    }
}
macro_rules! assign_ops {
    ($($tr:ident $m:ident $op:tt),*) => {$(
        impl<const N: usize> $tr for Dual<N> {
            #[inline]
            fn $m(&mut self, o: Self) { *self = *self $op o; }
        }
    )*};
}
assign_ops!(AddAssign add_assign +, SubAssign sub_assign -, MulAssign mul_assign *, DivAssign div_assign /);

impl<const N: usize> Real for Dual<N> {
    const DERIVATIVES: bool = true;
    #[inline]
    fn cst(x: f64) -> Self {
        Self::constant(x)
    }
    #[inline]
    fn re(self) -> f64 {
        self.re
    }
    #[inline]
    fn sqrt(self) -> Self {
        let s = self.re.sqrt();
        // d sqrt(x) = 1/(2 sqrt x); at x = 0 the derivative is unbounded: callers avoid it.
        self.chain(s, 0.5 / s)
    }
    #[inline]
    fn sin(self) -> Self {
        self.chain(self.re.sin(), self.re.cos())
    }
    #[inline]
    fn cos(self) -> Self {
        self.chain(self.re.cos(), -self.re.sin())
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        let r2 = self.re * self.re + x.re * x.re;
        let mut du = [0.0; N];
        for (k, d) in du.iter_mut().enumerate() {
            *d = (x.re * self.du[k] - self.re * x.du[k]) / r2;
        }
        Self {
            re: self.re.atan2(x.re),
            du,
        }
    }
}

/// `sin(x/2)/(x/2)`, smooth through `x = 0` (the `S_m` factor of the paper's eq. 20).
pub fn sinc_half<T: Real>(x: T) -> T {
    let h = x * 0.5;
    if h.re().abs() < 1e-4 {
        // Taylor series to O(h^6): error below 1e-24 in this range.
        let h2 = h * h;
        T::one() - h2 / 6.0 + h2 * h2 / 120.0
    } else {
        h.sin() / h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f<T: Real>(x: T, y: T) -> T {
        (x * y).sin() / (y + 2.0) + (x * x + 1.0).sqrt() - y.atan2(x + 3.0) * x.cos()
    }

    #[test]
    fn dual_matches_central_differences() {
        let (x, y) = (0.3, -0.7);
        let d = f(Dual::<2>::seeded(x, Some(0)), Dual::<2>::seeded(y, Some(1)));
        let e = 1e-6;
        let fx = (f(x + e, y) - f(x - e, y)) / (2.0 * e);
        let fy = (f(x, y + e) - f(x, y - e)) / (2.0 * e);
        // central differences: truncation error ~e^2 * f''' ~ 1e-12, round-off ~1e-16/e ~ 1e-10
        assert!((d.du[0] - fx).abs() < 1e-9);
        assert!((d.du[1] - fy).abs() < 1e-9);
        assert!((d.re - f(x, y)).abs() < 1e-15);
    }

    #[test]
    fn sinc_half_is_continuous_at_the_switch() {
        let a = sinc_half(2e-4 - 1e-12);
        let b = sinc_half(2e-4 + 1e-12);
        assert!((a - b).abs() < 1e-15);
        assert_eq!(sinc_half(0.0), 1.0);
        let d = sinc_half(Dual::<1>::seeded(0.0, Some(0)));
        assert_eq!(d.du[0], 0.0);
    }
}

//! 3-vectors and 3×3 matrices over any [`Real`], small and `Copy`, for the kinematics of nodes,
//! triads and joints. Components are in the inertial frame unless a name says otherwise.

use crate::math::scalar::Real;
use std::ops::{Add, AddAssign, Index, IndexMut, Mul, Neg, Sub, SubAssign};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct V3<T>(pub [T; 3]);

/// Row-major 3×3 matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct M3<T>(pub [[T; 3]; 3]);

impl<T: Real> V3<T> {
    #[inline]
    pub fn new(x: T, y: T, z: T) -> Self {
        V3([x, y, z])
    }
    #[inline]
    pub fn zero() -> Self {
        V3([T::zero(); 3])
    }
    #[inline]
    pub fn from_f64(v: V3<f64>) -> Self {
        V3([T::cst(v.0[0]), T::cst(v.0[1]), T::cst(v.0[2])])
    }
    #[inline]
    pub fn re(&self) -> V3<f64> {
        V3([self.0[0].re(), self.0[1].re(), self.0[2].re()])
    }
    #[inline]
    pub fn dot(&self, o: &Self) -> T {
        self.0[0] * o.0[0] + self.0[1] * o.0[1] + self.0[2] * o.0[2]
    }
    #[inline]
    pub fn cross(&self, o: &Self) -> Self {
        let (a, b) = (&self.0, &o.0);
        V3([
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ])
    }
    #[inline]
    pub fn norm_sq(&self) -> T {
        self.dot(self)
    }
    #[inline]
    pub fn norm(&self) -> T {
        self.norm_sq().sqrt()
    }
    #[inline]
    pub fn scale(&self, s: T) -> Self {
        V3([self.0[0] * s, self.0[1] * s, self.0[2] * s])
    }
    #[inline]
    pub fn scale_f(&self, s: f64) -> Self {
        V3([self.0[0] * s, self.0[1] * s, self.0[2] * s])
    }
    /// Skew-symmetric matrix `ṽ` with `ṽ a = v × a` (the paper's tilde).
    #[inline]
    pub fn tilde(&self) -> M3<T> {
        let [x, y, z] = self.0;
        let o = T::zero();
        M3([[o, -z, y], [z, o, -x], [-y, x, o]])
    }
    /// Outer product `self otherᵀ`.
    #[inline]
    pub fn outer(&self, o: &Self) -> M3<T> {
        let mut m = M3::zero();
        for i in 0..3 {
            for j in 0..3 {
                m.0[i][j] = self.0[i] * o.0[j];
            }
        }
        m
    }
    pub fn from_slice(s: &[T]) -> Self {
        V3([s[0], s[1], s[2]])
    }
    pub fn write_to(&self, s: &mut [T]) {
        s[..3].copy_from_slice(&self.0);
    }
    pub fn add_to(&self, s: &mut [T]) {
        for k in 0..3 {
            s[k] += self.0[k];
        }
    }
}

impl V3<f64> {
    pub fn max_abs(&self) -> f64 {
        self.0.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }
}

impl<T: Real> M3<T> {
    #[inline]
    pub fn zero() -> Self {
        M3([[T::zero(); 3]; 3])
    }
    #[inline]
    pub fn identity() -> Self {
        let mut m = Self::zero();
        for i in 0..3 {
            m.0[i][i] = T::one();
        }
        m
    }
    #[inline]
    pub fn from_f64(m: &M3<f64>) -> Self {
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] = T::cst(m.0[i][j]);
            }
        }
        r
    }
    pub fn re(&self) -> M3<f64> {
        let mut r = M3::<f64>::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] = self.0[i][j].re();
            }
        }
        r
    }
    /// Matrix from its three columns.
    pub fn from_cols(a: V3<T>, b: V3<T>, c: V3<T>) -> Self {
        M3([
            [a.0[0], b.0[0], c.0[0]],
            [a.0[1], b.0[1], c.0[1]],
            [a.0[2], b.0[2], c.0[2]],
        ])
    }
    #[inline]
    pub fn col(&self, j: usize) -> V3<T> {
        V3([self.0[0][j], self.0[1][j], self.0[2][j]])
    }
    #[inline]
    pub fn transpose(&self) -> Self {
        let mut t = *self;
        for i in 0..3 {
            for j in 0..3 {
                t.0[i][j] = self.0[j][i];
            }
        }
        t
    }
    #[inline]
    pub fn mul_v(&self, v: &V3<T>) -> V3<T> {
        let m = &self.0;
        let x = &v.0;
        V3([
            m[0][0] * x[0] + m[0][1] * x[1] + m[0][2] * x[2],
            m[1][0] * x[0] + m[1][1] * x[1] + m[1][2] * x[2],
            m[2][0] * x[0] + m[2][1] * x[1] + m[2][2] * x[2],
        ])
    }
    /// `self v` for a constant vector (cheaper than lifting `v` to `T`).
    #[inline]
    pub fn mul_vf(&self, v: &V3<f64>) -> V3<T> {
        let m = &self.0;
        let x = &v.0;
        V3([
            m[0][0] * x[0] + m[0][1] * x[1] + m[0][2] * x[2],
            m[1][0] * x[0] + m[1][1] * x[1] + m[1][2] * x[2],
            m[2][0] * x[0] + m[2][1] * x[1] + m[2][2] * x[2],
        ])
    }
    /// `selfᵀ v` without forming the transpose.
    #[inline]
    pub fn tmul_v(&self, v: &V3<T>) -> V3<T> {
        let m = &self.0;
        let x = &v.0;
        V3([
            m[0][0] * x[0] + m[1][0] * x[1] + m[2][0] * x[2],
            m[0][1] * x[0] + m[1][1] * x[1] + m[2][1] * x[2],
            m[0][2] * x[0] + m[1][2] * x[1] + m[2][2] * x[2],
        ])
    }
    /// The matrix whose entry (i, j) is `Σ_k term(i, k, j)`: one loop for the products
    /// below, whatever the scalar type of each factor.
    #[inline]
    fn product(term: impl Fn(usize, usize, usize) -> T) -> Self {
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] = term(i, 0, j) + term(i, 1, j) + term(i, 2, j);
            }
        }
        r
    }
    #[inline]
    pub fn mul_m(&self, o: &Self) -> Self {
        Self::product(|i, k, j| self.0[i][k] * o.0[k][j])
    }
    /// `self o` for a constant matrix `o` (cheaper than lifting `o` to `T`).
    #[inline]
    pub fn mul_mf(&self, o: &M3<f64>) -> Self {
        Self::product(|i, k, j| self.0[i][k] * o.0[k][j])
    }
    /// `a self` for a constant matrix `a`.
    #[inline]
    pub fn pre_mul_f(&self, a: &M3<f64>) -> Self {
        Self::product(|i, k, j| self.0[k][j] * a.0[i][k])
    }
    pub fn scale(&self, s: T) -> Self {
        let mut r = *self;
        for row in &mut r.0 {
            for v in row {
                *v *= s;
            }
        }
        r
    }
    /// `s self` for a constant `s` (cheaper than lifting `s` to `T`).
    pub fn scale_f(&self, s: f64) -> Self {
        let mut r = *self;
        for row in &mut r.0 {
            for v in row {
                *v = *v * s;
            }
        }
        r
    }
    pub fn trace(&self) -> T {
        self.0[0][0] + self.0[1][1] + self.0[2][2]
    }
    pub fn det(&self) -> T {
        let m = &self.0;
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    }
    /// Inverse by cofactors (3×3 only; the caller guarantees a non-singular matrix).
    pub fn inverse(&self) -> Self {
        let m = &self.0;
        let d = T::one() / self.det();
        let c = |a: usize, b: usize, c: usize, e: usize| m[a][b] * m[c][e] - m[a][e] * m[c][b];
        M3([
            [c(1, 1, 2, 2) * d, -c(0, 1, 2, 2) * d, c(0, 1, 1, 2) * d],
            [-c(1, 0, 2, 2) * d, c(0, 0, 2, 2) * d, -c(0, 0, 1, 2) * d],
            [c(1, 0, 2, 1) * d, -c(0, 0, 2, 1) * d, c(0, 0, 1, 1) * d],
        ])
    }
    /// Axial vector of the skew part: `axial(ṽ) = v`.
    pub fn axial(&self) -> V3<T> {
        let m = &self.0;
        V3([
            (m[2][1] - m[1][2]) * 0.5,
            (m[0][2] - m[2][0]) * 0.5,
            (m[1][0] - m[0][1]) * 0.5,
        ])
    }
}

impl M3<f64> {
    pub fn max_abs(&self) -> f64 {
        self.0.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()))
    }
}

impl<T: Real> Add for V3<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        V3([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}
impl<T: Real> Sub for V3<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        V3([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}
impl<T: Real> Neg for V3<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        V3([-self.0[0], -self.0[1], -self.0[2]])
    }
}
impl<T: Real> AddAssign for V3<T> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
impl<T: Real> SubAssign for V3<T> {
    #[inline]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}
impl<T: Real> Mul<T> for V3<T> {
    type Output = Self;
    #[inline]
    fn mul(self, s: T) -> Self {
        self.scale(s)
    }
}
impl<T> Index<usize> for V3<T> {
    type Output = T;
    fn index(&self, i: usize) -> &T {
        &self.0[i]
    }
}
impl<T> IndexMut<usize> for V3<T> {
    fn index_mut(&mut self, i: usize) -> &mut T {
        &mut self.0[i]
    }
}
impl<T: Real> Add for M3<T> {
    type Output = Self;
    fn add(mut self, o: Self) -> Self {
        for i in 0..3 {
            for j in 0..3 {
                self.0[i][j] += o.0[i][j];
            }
        }
        self
    }
}
impl<T: Real> Sub for M3<T> {
    type Output = Self;
    fn sub(mut self, o: Self) -> Self {
        for i in 0..3 {
            for j in 0..3 {
                self.0[i][j] -= o.0[i][j];
            }
        }
        self
    }
}
impl<T: Real> Mul for M3<T> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        self.mul_m(&o)
    }
}
impl<T: Real> Mul<V3<T>> for M3<T> {
    type Output = V3<T>;
    fn mul(self, v: V3<T>) -> V3<T> {
        self.mul_v(&v)
    }
}

//! A beam seen as a path for a point that slides along it (sliding-joint-notes §2.2–2.3).
//!
//! The contact point is located by the *element coordinate* ζ ∈ [0, N_e]: element e = ⌊ζ⌋
//! (the last element at ζ = N_e), local ξ = ζ − e ∈ [0, 1], so element boundaries are exact
//! integers. The shape functions are the element's Lagrange polynomials in ξ placed on its
//! nodes, zero elsewhere: C0 and single-valued at shared nodes, so `Σ_α (h_f^α − h_i^α) X^α =
//! P(ζ_f) − P(ζ_i)` for any ζ_i, ζ_f. The paper's η is ζ / N_e.
//!
//! The discrete forces of eq. (33) need the secant `S^α = (h^α(ζ_f) − h^α(ζ_i))/(ζ_f − ζ_i)`,
//! which must stay exact and bounded as ζ_f → ζ_i (the predictor starts with ζ_f = ζ_i): inside
//! an element it is the polynomial divided difference, written without division; across
//! elements a convex combination of per-piece secants, weighted by length ratios in [0, 1].

use super::shape::MAX_NODES;
use crate::math::scalar::Real;

/// Most nodes a secant can touch: the pieces of three elements (a step within a window of
/// one element either side).
pub const MAX_SECANT_NODES: usize = 3 * MAX_NODES;

#[derive(Clone, Debug)]
pub struct BeamPath {
    /// Element count N_e and order p (p + 1 nodes per element, shared at boundaries).
    pub elements: usize,
    pub order: usize,
    /// `coeffs[α][k]`: shape function α of an element is `Σ_k coeffs[α][k] ξ^k`, ξ ∈ [0, 1].
    coeffs: [[f64; MAX_NODES]; MAX_NODES],
}

/// Shape-function weights on beam nodes (indices along the beam, 0 … N_e·p): a fixed-size
/// list, so that evaluating them allocates nothing inside Newton's loop.
#[derive(Clone, Copy, Debug)]
pub struct NodeWeights<T> {
    pub node: [usize; MAX_SECANT_NODES],
    pub weight: [T; MAX_SECANT_NODES],
    pub len: usize,
}

impl<T: Real> NodeWeights<T> {
    fn new() -> Self {
        NodeWeights {
            node: [0; MAX_SECANT_NODES],
            weight: [T::zero(); MAX_SECANT_NODES],
            len: 0,
        }
    }

    /// Adds `w` to the weight of `node`.
    fn add(&mut self, node: usize, w: T) {
        match self.node[..self.len].iter().position(|&n| n == node) {
            Some(k) => self.weight[k] += w,
            None => {
                assert!(
                    self.len < MAX_SECANT_NODES,
                    "secant spans more than three elements"
                );
                self.node[self.len] = node;
                self.weight[self.len] = w;
                self.len += 1;
            }
        }
    }

    pub fn iter(&self) -> impl Iterator<Item = (usize, T)> + '_ {
        (0..self.len).map(move |k| (self.node[k], self.weight[k]))
    }
}

impl BeamPath {
    pub fn new(elements: usize, order: usize) -> Self {
        assert!(elements >= 1 && (1..MAX_NODES).contains(&order));
        // Expand h_α(ξ) = Π_{β≠α} (ξ − ξ_β)/(ξ_α − ξ_β) with ξ_β = β/p into monomials.
        let n = order + 1;
        let mut coeffs = [[0.0; MAX_NODES]; MAX_NODES];
        for (a, c) in coeffs.iter_mut().enumerate().take(n) {
            let mut poly = [0.0; MAX_NODES];
            poly[0] = 1.0;
            let xa = a as f64 / order as f64;
            for b in (0..n).filter(|&b| b != a) {
                let xb = b as f64 / order as f64;
                let den = xa - xb;
                let mut next = [0.0; MAX_NODES];
                for k in 0..MAX_NODES {
                    if k + 1 < MAX_NODES {
                        next[k + 1] += poly[k] / den;
                    }
                    next[k] -= poly[k] * xb / den;
                }
                poly = next;
            }
            *c = poly;
        }
        BeamPath {
            elements,
            order,
            coeffs,
        }
    }

    /// Element and local coordinate of ζ (clamped to the path; a boundary belongs to the
    /// element after it, the end to the last element).
    pub fn locate(&self, zeta: f64) -> (usize, f64) {
        self.locate_in(zeta, self.all())
    }

    /// All elements, as a range for the `_in` methods.
    pub fn all(&self) -> (usize, usize) {
        (0, self.elements - 1)
    }

    /// As [`Self::locate`], with the element restricted to `first ..= last` (beyond them the
    /// end elements of the range extend): a sliding joint whose unknowns cover a window of
    /// elements evaluates its path within it.
    pub fn locate_in(&self, zeta: f64, (first, last): (usize, usize)) -> (usize, f64) {
        let e = (zeta.max(first as f64).floor() as usize).clamp(first, last);
        (e, zeta - e as f64)
    }

    /// Beam node index of local node α of element e.
    pub fn node(&self, e: usize, alpha: usize) -> usize {
        e * self.order + alpha
    }

    /// Values and ξ-derivatives of element shape functions at local ξ (any real ξ: the end
    /// elements extrapolate).
    pub fn shape<T: Real>(&self, xi: T) -> ([T; MAX_NODES], [T; MAX_NODES]) {
        let mut h = [T::zero(); MAX_NODES];
        let mut dh = [T::zero(); MAX_NODES];
        for a in 0..=self.order {
            // Horner for the value and the derivative together.
            let c = &self.coeffs[a];
            let mut v = T::zero();
            let mut d = T::zero();
            for k in (0..=self.order).rev() {
                d = d * xi + v;
                v = v * xi + c[k];
            }
            h[a] = v;
            dh[a] = d;
        }
        (h, dh)
    }

    /// Shape-function weights at ζ: `P(ζ) = Σ w_α X^α`.
    pub fn weights<T: Real>(&self, zeta: T) -> NodeWeights<T> {
        self.weights_in(zeta, self.all())
    }

    pub fn weights_in<T: Real>(&self, zeta: T, range: (usize, usize)) -> NodeWeights<T> {
        let (e, _) = self.locate_in(zeta.re(), range);
        let (h, _) = self.shape(zeta - e as f64);
        let mut w = NodeWeights::new();
        for (a, ha) in h.iter().enumerate().take(self.order + 1) {
            w.add(self.node(e, a), *ha);
        }
        w
    }

    /// Weights of the path's tangent at ζ: `P′(ζ) = Σ w_α X^α` (per unit ζ).
    pub fn tangent_weights<T: Real>(&self, zeta: T, range: (usize, usize)) -> NodeWeights<T> {
        let (e, _) = self.locate_in(zeta.re(), range);
        let (_, dh) = self.shape(zeta - e as f64);
        let mut w = NodeWeights::new();
        for (a, da) in dh.iter().enumerate().take(self.order + 1) {
            w.add(self.node(e, a), *da);
        }
        w
    }

    /// Divided difference of element shape functions between local ξ_a and ξ_b, without
    /// division: `Σ_k c_k Σ_{j<k} ξ_b^j ξ_a^{k−1−j}` (h′(ξ) at ξ_a = ξ_b).
    pub fn element_secant<T: Real>(&self, xa: T, xb: T) -> [T; MAX_NODES] {
        let mut s = [T::zero(); MAX_NODES];
        for (a, sa) in s.iter_mut().enumerate().take(self.order + 1) {
            for k in 1..=self.order {
                let mut sum = T::zero();
                for j in 0..k {
                    sum += pow(xb, j) * pow(xa, k - 1 - j);
                }
                *sa += sum * self.coeffs[a][k];
            }
        }
        s
    }

    /// Secant weights `S^α` between ζ_i and ζ_f: `Σ_α S^α X^α (ζ_f − ζ_i) = P(ζ_f) − P(ζ_i)`
    /// exactly, bounded and accurate to round-off as ζ_f → ζ_i, within one element or across
    /// boundaries (a convex combination of the pieces' secants).
    pub fn secant<T: Real>(&self, zi: T, zf: T) -> NodeWeights<T> {
        self.secant_in(zi, zf, self.all())
    }

    pub fn secant_in<T: Real>(&self, zi: T, zf: T, range: (usize, usize)) -> NodeWeights<T> {
        let (ei, _) = self.locate_in(zi.re(), range);
        let (ef, _) = self.locate_in(zf.re(), range);
        let mut out = NodeWeights::new();
        if ei == ef {
            let s = self.element_secant(zi - ei as f64, zf - ei as f64);
            for (a, sa) in s.iter().enumerate().take(self.order + 1) {
                out.add(self.node(ei, a), *sa);
            }
            return out;
        }
        let (lo, hi, elo, ehi) = if zi.re() < zf.re() {
            (zi, zf, ei, ef)
        } else {
            (zf, zi, ef, ei)
        };
        let width = hi - lo;
        let mut start = lo;
        for e in elo..=ehi {
            let end = if e == ehi { hi } else { T::cst((e + 1) as f64) };
            let share = (end - start) / width;
            let s = self.element_secant(start - e as f64, end - e as f64);
            for (a, sa) in s.iter().enumerate().take(self.order + 1) {
                out.add(self.node(e, a), *sa * share);
            }
            start = end;
        }
        out
    }
}

/// The user's contact coordinate η = s/L (fraction of the beam's reference length) and the
/// element coordinate ζ: piecewise linear through the element ends, exact at the boundaries
/// (η = ζ/N_e on a uniformly meshed beam). Beyond the ends the end elements extend linearly.
#[derive(Clone, Debug)]
pub struct ArcMap {
    /// η at the element boundaries, 0 … 1 (N_e + 1 values).
    ends: Vec<f64>,
}

impl ArcMap {
    /// From the elements' arc-length spans and the beam's length.
    pub fn new(spans: &[(f64, f64)], length: f64) -> Self {
        let mut ends: Vec<f64> = spans.iter().map(|&(a, _)| a / length).collect();
        ends.push(1.0);
        ends[0] = 0.0;
        ArcMap { ends }
    }

    /// Equal elements: η = ζ/N_e.
    pub fn uniform(elements: usize) -> Self {
        ArcMap {
            ends: (0..=elements).map(|e| e as f64 / elements as f64).collect(),
        }
    }

    pub fn elements(&self) -> usize {
        self.ends.len() - 1
    }

    /// The piece of η(ζ) holding ζ (the end pieces extend past the ends): its element (as a
    /// number), η at the element's start, and its slope dη/dζ.
    pub fn piece(&self, zeta: f64) -> (f64, f64, f64) {
        let e = (zeta.max(0.0).floor() as usize).min(self.elements() - 1);
        (e as f64, self.ends[e], self.ends[e + 1] - self.ends[e])
    }

    /// dη/dζ at ζ.
    pub fn deta_dzeta(&self, zeta: f64) -> f64 {
        let e = (zeta.max(0.0).floor() as usize).min(self.elements() - 1);
        self.ends[e + 1] - self.ends[e]
    }

    fn element_of_eta(&self, eta: f64) -> usize {
        let n = self.elements();
        self.ends[1..n].iter().take_while(|&&b| eta >= b).count()
    }

    pub fn zeta(&self, eta: f64) -> f64 {
        let e = self.element_of_eta(eta);
        e as f64 + (eta - self.ends[e]) / (self.ends[e + 1] - self.ends[e])
    }

    /// dζ/dη at η (the right derivative at a boundary).
    pub fn dzeta_deta(&self, eta: f64) -> f64 {
        let e = self.element_of_eta(eta);
        1.0 / (self.ends[e + 1] - self.ends[e])
    }

    pub fn eta(&self, zeta: f64) -> f64 {
        let e = (zeta.max(0.0).floor() as usize).min(self.elements() - 1);
        self.ends[e] + (zeta - e as f64) * (self.ends[e + 1] - self.ends[e])
    }

    /// Whether all elements have the same length (to 1e-9), so that η = ζ/N_e exactly.
    pub fn is_uniform(&self) -> bool {
        let n = self.elements() as f64;
        self.ends
            .windows(2)
            .all(|w| ((w[1] - w[0]) * n - 1.0).abs() < 1e-9)
    }
}

fn pow<T: Real>(x: T, k: usize) -> T {
    let mut p = T::one();
    for _ in 0..k {
        p = p * x;
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::beam::shape::lagrange;

    /// Beam node positions along a wavy 3-D curve (any values would do).
    fn positions(path: &BeamPath) -> Vec<[f64; 3]> {
        (0..=path.elements * path.order)
            .map(|k| {
                let s = k as f64 * 0.37;
                [
                    s + 0.1 * (3.0 * s).sin(),
                    0.4 * (1.7 * s).cos(),
                    0.05 * s * s,
                ]
            })
            .collect()
    }

    fn apply(w: &NodeWeights<f64>, x: &[[f64; 3]]) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (n, wn) in w.iter() {
            for c in 0..3 {
                p[c] += wn * x[n][c];
            }
        }
        p
    }

    #[test]
    fn monomial_shape_functions_are_the_lagrange_ones() {
        for p in 1..=3 {
            let path = BeamPath::new(2, p);
            for xi in [0.0, 0.13, 0.5, 0.91, 1.0] {
                let (h, dh) = path.shape(xi);
                let (hl, dhl) = lagrange(p + 1, 2.0 * xi - 1.0);
                for a in 0..=p {
                    assert!((h[a] - hl[a]).abs() < 1e-14);
                    assert!((dh[a] - 2.0 * dhl[a]).abs() < 1e-13);
                }
            }
        }
    }

    #[test]
    fn secant_times_the_step_is_the_path_increment_everywhere() {
        // Within elements, across one or two boundaries, backwards, and zero steps.
        for p in 1..=3 {
            let path = BeamPath::new(6, p);
            let x = positions(&path);
            for (zi, zf) in [
                (1.2, 1.7),
                (1.7, 1.2),
                (0.9, 1.1),
                (2.95, 4.2),
                (4.2, 2.95),
                (3.0, 3.0),
                (5.5, 6.0),
            ] {
                let s = path.secant(zi, zf);
                let pi = apply(&path.weights(zi), &x);
                let pf = apply(&path.weights(zf), &x);
                let sx = apply(&s, &x);
                for c in 0..3 {
                    let lhs = sx[c] * (zf - zi);
                    assert!(
                        (lhs - (pf[c] - pi[c])).abs() < 1e-14,
                        "p={p} {zi}→{zf}: {lhs} vs {}",
                        pf[c] - pi[c]
                    );
                }
                if zi == zf {
                    // The derivative of the path at ζ.
                    let (e, xi) = path.locate(zi);
                    let (_, dh) = path.shape(xi);
                    for a in 0..=p {
                        let w = s.iter().find(|(n, _)| *n == path.node(e, a)).unwrap().1;
                        assert!((w - dh[a]).abs() < 1e-13);
                    }
                }
            }
        }
    }

    #[test]
    fn secant_stays_bounded_for_tiny_steps_across_a_node() {
        // ζ from just below to just above a boundary: the secant is a convex combination of
        // the two one-sided derivatives, with no cancellation (the naive quotient of
        // positions loses ~1e-16/Δζ).
        let path = BeamPath::new(4, 3);
        let x = positions(&path);
        // One-sided derivatives at the node ζ = 2: element 1 at ξ = 1, element 2 at ξ = 0.
        let one_sided = |e: usize, xi: f64| {
            let (_, dh) = path.shape(xi);
            let mut d = [0.0; 3];
            for a in 0..4 {
                for c in 0..3 {
                    d[c] += dh[a] * x[path.node(e, a)][c];
                }
            }
            d
        };
        let (left, right) = (one_sided(1, 1.0), one_sided(2, 0.0));
        for dz in [1e-6, 1e-10, 1e-14] {
            let (lo, hi) = (2.0 - dz / 2.0, 2.0 + dz / 2.0);
            let s = apply(&path.secant(lo, hi), &x);
            // The shares of the step on each side (as the rounded ζ's have them) weight the
            // one-sided derivatives, up to O(Δζ) from the curvature.
            let (wl, wr) = ((2.0 - lo) / (hi - lo), (hi - 2.0) / (hi - lo));
            for c in 0..3 {
                let expect = wl * left[c] + wr * right[c];
                assert!(
                    (s[c] - expect).abs() < 1e-13 * (1.0 + expect.abs()) + 10.0 * dz,
                    "dz={dz}: {} vs {expect}",
                    s[c]
                );
            }
        }
    }

    #[test]
    fn secant_tangent_matches_finite_differences() {
        use crate::math::scalar::Dual;
        let path = BeamPath::new(5, 3);
        // Inside an element, across a boundary, and a zero step (S′ = h″/2 there). At a zero
        // step exactly on a node S has a genuine kink, so no derivative to check.
        for (zi, zf) in [(1.3, 1.6), (1.8, 2.4), (2.3, 2.3)] {
            let s = path.secant(Dual::<1>::constant(zi), Dual::<1>::seeded(zf, Some(0)));
            let e = 1e-6;
            let sp = path.secant(zi, zf + e);
            let sm = path.secant(zi, zf - e);
            for (n, w) in s.iter() {
                let fd = (sp.iter().find(|(m, _)| *m == n).map_or(0.0, |v| v.1)
                    - sm.iter().find(|(m, _)| *m == n).map_or(0.0, |v| v.1))
                    / (2.0 * e);
                // Central differences: truncation ~e² |S'''|, round-off ~1e-16/e.
                assert!(
                    (w.du[0] - fd).abs() < 1e-7,
                    "{zi}→{zf} node {n}: {} vs {fd}",
                    w.du[0]
                );
            }
        }
    }
}

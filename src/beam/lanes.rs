//! 3×3 blocks of an element's column nodes side by side, `[i][j][b]`: the beam tangent's
//! chain rule sums the Gauss points and maps the columns of every node `b` at once, four lanes
//! wide (an element has at most [`MAX_NODES`] = 4 nodes). Each lane's arithmetic is the one
//! the plain 3×3 blocks do, in the same order, so the lanes agree with them to the bit.

// Every operand is indexed by the same lane.
#![allow(clippy::needless_range_loop)]

use super::shape::MAX_NODES;
use crate::math::vec3::M3;

/// One number per column node.
pub(super) type Lanes = [f64; MAX_NODES];

/// A 3×3 block per column node, entry `[i][j][b]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct B3Lanes(pub [[Lanes; 3]; 3]);

impl B3Lanes {
    pub const ZERO: Self = B3Lanes([[[0.0; MAX_NODES]; 3]; 3]);

    /// Column node `b`'s block.
    #[inline(always)]
    pub fn lane(&self, b: usize) -> M3<f64> {
        M3(std::array::from_fn(|i| {
            std::array::from_fn(|j| self.0[i][j][b])
        }))
    }

    /// Sets column node `b`'s block.
    #[inline(always)]
    pub fn set_lane(&mut self, b: usize, m: &M3<f64>) {
        for i in 0..3 {
            for j in 0..3 {
                self.0[i][j][b] = m.0[i][j];
            }
        }
    }

    /// `self += c_b x` in lane `b`: one block `x` weighted per node (a shape function).
    #[inline(always)]
    pub fn add_scaled(&mut self, x: &M3<f64>, c: &Lanes) {
        for i in 0..3 {
            for j in 0..3 {
                let (y, v) = (&mut self.0[i][j], x.0[i][j]);
                for l in 0..MAX_NODES {
                    y[l] += c[l] * v;
                }
            }
        }
    }

    /// `x` weighted per lane: `c_b x` in lane `b`.
    #[inline(always)]
    pub fn scaled(x: &M3<f64>, c: &Lanes) -> B3Lanes {
        let mut r = B3Lanes::ZERO;
        for i in 0..3 {
            for j in 0..3 {
                for l in 0..MAX_NODES {
                    r.0[i][j][l] = x.0[i][j] * c[l];
                }
            }
        }
        r
    }

    /// `self += c_b x_a` in lane `b`: lane `a` of `x` weighted per lane.
    #[inline(always)]
    pub fn add_scaled_lane(&mut self, x: &B3Lanes, a: usize, c: &Lanes) {
        for i in 0..3 {
            for j in 0..3 {
                let (y, v) = (&mut self.0[i][j], x.0[i][j][a]);
                for l in 0..MAX_NODES {
                    y[l] += c[l] * v;
                }
            }
        }
    }

    /// `self += c_b x_a + d_b z_a` in lane `b`: [`Self::add_scaled_lane`] of `x` then of `z`
    /// (the same arithmetic in the same order), with `self` loaded and stored once.
    #[inline(always)]
    pub fn add_two_scaled_lanes(
        &mut self,
        (x, c): (&B3Lanes, &Lanes),
        (z, d): (&B3Lanes, &Lanes),
        a: usize,
    ) {
        for i in 0..3 {
            for j in 0..3 {
                let (y, v, w) = (&mut self.0[i][j], x.0[i][j][a], z.0[i][j][a]);
                for l in 0..MAX_NODES {
                    let t = y[l] + c[l] * v;
                    y[l] = t + d[l] * w;
                }
            }
        }
    }

    /// `self += c_b g_b` in lane `b`.
    #[inline(always)]
    pub fn add_lane_scaled(&mut self, c: &Lanes, g: &B3Lanes) {
        for i in 0..3 {
            for j in 0..3 {
                for l in 0..MAX_NODES {
                    self.0[i][j][l] += c[l] * g.0[i][j][l];
                }
            }
        }
    }

    /// `self += g_b q_b` in lane `b`, the product formed before it is added (as
    /// `out + g.mul_m(q)` on plain blocks).
    #[inline(always)]
    pub fn add_product(&mut self, g: &B3Lanes, q: &B3Lanes) {
        for i in 0..3 {
            for j in 0..3 {
                for l in 0..MAX_NODES {
                    let p = g.0[i][0][l] * q.0[0][j][l]
                        + g.0[i][1][l] * q.0[1][j][l]
                        + g.0[i][2][l] * q.0[2][j][l];
                    self.0[i][j][l] += p;
                }
            }
        }
    }

    /// `a u_b` in lane `b`, for a block `a` common to the lanes (a row node's rotation).
    #[inline(always)]
    pub fn pre_mul(a: &M3<f64>, u: &B3Lanes) -> B3Lanes {
        let mut r = B3Lanes::ZERO;
        for i in 0..3 {
            for j in 0..3 {
                for l in 0..MAX_NODES {
                    r.0[i][j][l] = a.0[i][0] * u.0[0][j][l]
                        + a.0[i][1] * u.0[1][j][l]
                        + a.0[i][2] * u.0[2][j][l];
                }
            }
        }
        r
    }

    /// `self + o` entry by entry.
    #[inline(always)]
    pub fn plus(mut self, o: &B3Lanes) -> B3Lanes {
        for i in 0..3 {
            for j in 0..3 {
                for l in 0..MAX_NODES {
                    self.0[i][j][l] += o.0[i][j][l];
                }
            }
        }
        self
    }

    /// `self − o` entry by entry.
    #[inline(always)]
    pub fn minus(mut self, o: &B3Lanes) -> B3Lanes {
        for i in 0..3 {
            for j in 0..3 {
                for l in 0..MAX_NODES {
                    self.0[i][j][l] -= o.0[i][j][l];
                }
            }
        }
        self
    }
}

/// What multiplying by a lane block takes in every lane that is used: nothing, a per-lane
/// scaling (`c_b I`), or a matrix product.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum LaneKind {
    Zero,
    Identity(Lanes),
    Full,
}

impl LaneKind {
    /// The kind of `m` over its first `used` lanes.
    #[inline(always)]
    pub fn of(m: &B3Lanes, used: usize) -> Self {
        let mut c = [0.0; MAX_NODES];
        for (l, cl) in c.iter_mut().enumerate().take(used) {
            let d = m.0[0][0][l];
            let scaled_identity =
                (0..3).all(|i| (0..3).all(|j| m.0[i][j][l] == if i == j { d } else { 0.0 }));
            if !scaled_identity {
                return LaneKind::Full;
            }
            *cl = d;
        }
        if c.iter().all(|&v| v == 0.0) {
            LaneKind::Zero
        } else {
            LaneKind::Identity(c)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(seed: f64) -> M3<f64> {
        M3(std::array::from_fn(|i| {
            std::array::from_fn(|j| ((i * 3 + j) as f64 * 0.77 + seed).sin() * 1e3 / 7.0)
        }))
    }

    fn lanes(seed: f64) -> B3Lanes {
        let mut r = B3Lanes::ZERO;
        for b in 0..MAX_NODES {
            r.set_lane(b, &block(seed + b as f64));
        }
        r
    }

    /// Every lane operation is its plain-block counterpart in each lane, to the bit: the
    /// tangent's results must not depend on how its blocks are laid out.
    #[test]
    fn each_lane_computes_what_a_plain_block_does() {
        let (g, q, y0) = (lanes(0.1), lanes(2.3), lanes(4.7));
        let (x, a) = (block(9.1), block(5.5));
        let c = [0.3, -1.7, 2.9, 1e-3];
        let mut y = y0;
        y.add_scaled(&x, &c);
        let mut z = y0;
        z.add_lane_scaled(&c, &g);
        let scaled = B3Lanes::scaled(&x, &c);
        let mut from_lane = y0;
        from_lane.add_scaled_lane(&g, 2, &c);
        let d = [-0.9, 4.1, 0.25, 7.0];
        let (mut two, mut one_by_one) = (y0, y0);
        two.add_two_scaled_lanes((&g, &c), (&q, &d), 1);
        one_by_one.add_scaled_lane(&g, 1, &c);
        one_by_one.add_scaled_lane(&q, 1, &d);
        assert_eq!(two, one_by_one);
        let mut p = y0;
        p.add_product(&g, &q);
        let pre = B3Lanes::pre_mul(&a, &g);
        let (sum, diff) = (y0.plus(&g), y0.minus(&g));
        for b in 0..MAX_NODES {
            let (gb, qb, yb) = (g.lane(b), q.lane(b), y0.lane(b));
            let mut want = yb;
            for i in 0..3 {
                for j in 0..3 {
                    want.0[i][j] += c[b] * x.0[i][j];
                }
            }
            assert_eq!(y.lane(b), want);
            assert_eq!(scaled.lane(b), x.scale_f(c[b]));
            let mut want = yb;
            for i in 0..3 {
                for j in 0..3 {
                    want.0[i][j] += c[b] * g.lane(2).0[i][j];
                }
            }
            assert_eq!(from_lane.lane(b), want);
            let mut want = yb;
            for i in 0..3 {
                for j in 0..3 {
                    want.0[i][j] += c[b] * gb.0[i][j];
                }
            }
            assert_eq!(z.lane(b), want);
            assert_eq!(p.lane(b), yb + gb.mul_m(&qb));
            assert_eq!(pre.lane(b), a.mul_m(&gb));
            assert_eq!(sum.lane(b), yb + gb);
            assert_eq!(diff.lane(b), yb - gb);
        }
    }

    /// Kinds over the used lanes only: a lane past the element's nodes does not make a block
    /// full, a rotation in one lane does.
    #[test]
    fn kinds_look_at_the_used_lanes() {
        let mut m = B3Lanes::ZERO;
        assert_eq!(LaneKind::of(&m, 4), LaneKind::Zero);
        for b in 0..2 {
            m.set_lane(b, &M3::identity().scale_f(2.0 + b as f64));
        }
        m.set_lane(3, &block(1.0));
        assert_eq!(
            LaneKind::of(&m, 2),
            LaneKind::Identity([2.0, 3.0, 0.0, 0.0])
        );
        assert_eq!(LaneKind::of(&m, 4), LaneKind::Full);
    }
}

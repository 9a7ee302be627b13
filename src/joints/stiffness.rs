//! The geometric stiffness of a joint's discrete constraint forces in closed form: for fixed
//! multipliers λ, the derivative of `g = B^Dᵀ λ` (eqs. 10, 16, 23) with respect to the end
//! state of the step, `K = ∂g/∂z` with `z = [Δx₁, θ₁, Δx₂, θ₂, Δq]` — spatial variations of
//! the end state, `δR_f = θ̃ R_f`, so every unit vector and arm at the end moves as
//! `δe_f = θ × e_f`. The start state is a constant of the step.
//!
//! With it a joint's EP tangent needs no dual pass (`joints::closed_tangent`): the constraint
//! rows' columns are the rate operator `B(q_f)`, the multipliers' columns `B^Dᵀ`, and the
//! force rows' geometric columns this `K`. Each building block of [`super::kinematics`] has
//! its stiffness here; the law tests check every law's against a dual-number derivative of
//! its discrete gradient.

use super::kinematics::{point, unit};
use super::revolute::AngleTerms;
use super::{JointState, NCOL};
use crate::math::scalar::{sinc_half, Dual};
use crate::math::vec3::{M3, V3};

/// `∂(B^Dᵀλ)/∂z`: rows the force columns `[x₁, θ₁, x₂, θ₂, q]`, columns the end-state
/// variations in the same order.
pub type Stiffness = [[f64; NCOL]; NCOL];

/// Column (and row) offsets of side `k`'s translation and rotation, and of coordinate `q`.
const fn x_of(k: usize) -> usize {
    6 * k
}
const fn th_of(k: usize) -> usize {
    6 * k + 3
}
const fn q_of(qi: usize) -> usize {
    12 + qi
}

/// `K[r₀+i][c₀+j] += a m[i][j]`.
fn add_block(k: &mut Stiffness, r0: usize, c0: usize, m: &M3<f64>, a: f64) {
    for i in 0..3 {
        for j in 0..3 {
            k[r0 + i][c0 + j] += a * m.0[i][j];
        }
    }
}

/// `K[r₀+i][c] += a v[i]` (a column).
fn add_col(k: &mut Stiffness, r0: usize, c: usize, v: &V3<f64>, a: f64) {
    for i in 0..3 {
        k[r0 + i][c] += a * v.0[i];
    }
}

/// `K[r][c₀+j] += a v[j]` (a row).
fn add_row(k: &mut Stiffness, r: usize, c0: usize, v: &V3<f64>, a: f64) {
    for j in 0..3 {
        k[r][c0 + j] += a * v.0[j];
    }
}

fn mid(a: V3<f64>, b: V3<f64>) -> V3<f64> {
    (a + b).scale_f(0.5)
}

/// Coincident points (rows of [`super::kinematics::points_gradient`]) with multipliers `lam`:
/// the moment on side k is `±(a_m × λ)` with the mid arm `a_m = (a_i + a_f)/2`, and
/// `δa_f = θ × a_f`, so `∂/∂θ_k = ±½ λ̃ ã_f`.
pub fn points(sf: &JointState<f64>, lam: V3<f64>, k: &mut Stiffness) {
    for side in 0..2 {
        let sign = if side == 0 { -1.0 } else { 1.0 };
        let m = lam.tilde().mul_m(&sf.arm[side].tilde());
        add_block(k, th_of(side), th_of(side), &m, 0.5 * sign);
    }
}

/// A rotation pair `[0, w h_m, 0, −w h_m]` of the product `g = e_αᵏ·e_βˡ`
/// ([`super::kinematics::dot_mid`], eq. 15) with weight `w` (λ times the row's factor):
/// `h_m = e_αmᵏ × e_βmˡ` varies as `∂h_m/∂θ₁ = ½ ẽ_βmˡ ẽ_αfᵏ`, `∂h_m/∂θ₂ = −½ ẽ_αmᵏ ẽ_βfˡ`.
pub fn dot_pair(
    si: &JointState<f64>,
    sf: &JointState<f64>,
    alpha: usize,
    beta: usize,
    w: f64,
    k: &mut Stiffness,
) {
    let (ekf, elf) = (unit(sf, 0, alpha), unit(sf, 1, beta));
    let (ekm, elm) = (mid(unit(si, 0, alpha), ekf), mid(unit(si, 1, beta), elf));
    let d0 = elm.tilde().mul_m(&ekf.tilde());
    let d1 = ekm.tilde().mul_m(&elf.tilde());
    add_block(k, th_of(0), th_of(0), &d0, 0.5 * w);
    add_block(k, th_of(0), th_of(1), &d1, -0.5 * w);
    add_block(k, th_of(1), th_of(0), &d0, -0.5 * w);
    add_block(k, th_of(1), th_of(1), &d1, 0.5 * w);
}

/// `d sinc_half(x)/dx` (the derivative of eq. 22's `S_m`).
fn sinc_half_slope(x: f64) -> f64 {
    sinc_half(Dual::<1>::seeded(x, Some(0))).du[0]
}

/// An angle row ([`super::revolute::angle_gradient`], eq. 22) with multiplier `lam`: rotation
/// pair `H = h₁ sin_m c_s + h₂ cos_m c_c`, coordinate column `Q = (g₁ cos φ_m c_s − g₂ sin φ_m
/// c_c) S_m`, varying with the rotations through `h`, `g` (`∂g_m/∂θ₁ = −∂g_m/∂θ₂ = ½ h_f`)
/// and with `φ_f` through the means and `S_m`.
pub fn angle(
    si: &JointState<f64>,
    sf: &JointState<f64>,
    qi: usize,
    terms: AngleTerms,
    lam: f64,
    k: &mut Stiffness,
) {
    let ((a, b, cs), (c, d, cc)) = terms;
    let (pi, pf) = (si.q[qi], sf.q[qi]);
    let (sin_m, cos_m) = ((pi.sin() + pf.sin()) * 0.5, (pi.cos() + pf.cos()) * 0.5);
    let phi_m = (pi + pf) * 0.5;
    let (s_m, ds_m) = (sinc_half(pf - pi), sinc_half_slope(pf - pi));
    dot_pair(si, sf, a, b, lam * sin_m * cs, k);
    dot_pair(si, sf, c, d, lam * cos_m * cc, k);
    let h_mid = |a: usize, b: usize| {
        let (ek, el) = (
            mid(unit(si, 0, a), unit(sf, 0, a)),
            mid(unit(si, 1, b), unit(sf, 1, b)),
        );
        ek.cross(&el)
    };
    let g_mid = |a: usize, b: usize| {
        (unit(si, 0, a).dot(&unit(si, 1, b)) + unit(sf, 0, a).dot(&unit(sf, 1, b))) * 0.5
    };
    let h_end = |a: usize, b: usize| unit(sf, 0, a).cross(&unit(sf, 1, b));
    let q = q_of(qi);
    // Rotation rows against φ_f: ∂H/∂φ_f.
    let dh = h_mid(a, b).scale_f(0.5 * pf.cos() * cs) - h_mid(c, d).scale_f(0.5 * pf.sin() * cc);
    add_col(k, th_of(0), q, &dh, lam);
    add_col(k, th_of(1), q, &dh, -lam);
    // The coordinate row against the rotations and φ_f.
    let dq = (h_end(a, b).scale_f(phi_m.cos() * cs) - h_end(c, d).scale_f(phi_m.sin() * cc))
        .scale_f(0.5 * s_m);
    add_row(k, q, th_of(0), &dq, lam);
    add_row(k, q, th_of(1), &dq, -lam);
    let (g1, g2) = (g_mid(a, b), g_mid(c, d));
    let d_phi = -(g1 * phi_m.sin() * cs + g2 * phi_m.cos() * cc) * 0.5 * s_m
        + (g1 * phi_m.cos() * cs - g2 * phi_m.sin() * cc) * ds_m;
    k[q][q] += lam * d_phi;
}

/// A projection row ([`super::kinematics::projection_gradient`], eq. 8) on side l's unit
/// vector β with multiplier `lam`: forces `∓λ e_m` on the translations, `λ e_m × a_m₁` on
/// side k's rotation and `λ (a_m₂ × e_m + e_m × u_m)` on side l's, varying through the mid
/// unit vector (`∂e_m/∂θ₂ = −½ ẽ_f`), the mid arms (`∂a_m/∂θ = −½ ã_f`) and the mid
/// separation `u_m`.
pub fn projection(
    si: &JointState<f64>,
    sf: &JointState<f64>,
    beta: usize,
    lam: f64,
    k: &mut Stiffness,
) {
    let ef = unit(sf, 1, beta);
    let em = mid(unit(si, 1, beta), ef);
    let (af0, af1) = (sf.arm[0], sf.arm[1]);
    let (am0, am1) = (mid(si.arm[0], af0), mid(si.arm[1], af1));
    let u = |s: &JointState<f64>| point(s, 1) - point(s, 0);
    let um = mid(u(si), u(sf));
    let (eft, emt) = (ef.tilde(), em.tilde());
    let h = 0.5 * lam;
    add_block(k, x_of(0), th_of(1), &eft, h);
    add_block(k, x_of(1), th_of(1), &eft, -h);
    add_block(k, th_of(0), th_of(1), &am0.tilde().mul_m(&eft), h);
    add_block(k, th_of(0), th_of(0), &emt.mul_m(&af0.tilde()), -h);
    add_block(k, th_of(1), th_of(1), &(um - am1).tilde().mul_m(&eft), h);
    add_block(k, th_of(1), x_of(0), &emt, -h);
    add_block(k, th_of(1), x_of(1), &emt, h);
    add_block(k, th_of(1), th_of(0), &emt.mul_m(&af0.tilde()), h);
}

/// The two axis rows `e₃ᵏ·e₁ˡ = e₃ᵏ·e₂ˡ = 0` ([`super::revolute::axis_gradient`]).
pub fn axis(si: &JointState<f64>, sf: &JointState<f64>, lam: &[f64], k: &mut Stiffness) {
    dot_pair(si, sf, 2, 0, lam[0], k);
    dot_pair(si, sf, 2, 1, lam[1], k);
}

/// The three rows of identical orientations ([`super::kinematics::orientation_gradient`]).
pub fn orientation(si: &JointState<f64>, sf: &JointState<f64>, lam: &[f64], k: &mut Stiffness) {
    for (r, (a, b)) in super::kinematics::ORIENTATION_PAIRS.iter().enumerate() {
        dot_pair(si, sf, *a, *b, lam[r], k);
    }
}

/// The three separation rows of a prismatic or cylindrical joint
/// ([`super::prismatic::slide_gradient`]; the coordinate's column is constant).
pub fn slide(si: &JointState<f64>, sf: &JointState<f64>, lam: &[f64], k: &mut Stiffness) {
    for (beta, l) in lam.iter().enumerate().take(3) {
        projection(si, sf, beta, *l, k);
    }
}

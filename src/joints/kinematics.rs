//! Building blocks shared by the joint laws: coincident points and the orthogonality of two
//! body-fixed unit vectors (the universal-joint constraint, eqs. 11–16).

use super::{Attachment, JointState, Rows};
use crate::scalar::Real;
use crate::vec3::{M3, V3};

/// Spatial attachment point `x + R p` of side `k`.
pub fn point<T: Real>(s: &JointState<T>, k: usize, a: &Attachment) -> V3<T> {
    s.x[k] + s.r[k].mul_vf(&a.offset)
}

/// Unit vector `α` (0-based column) of side `k`'s attachment triad.
pub fn unit<T: Real>(s: &JointState<T>, k: usize, a: &Attachment, alpha: usize) -> V3<T> {
    s.r[k].mul_vf(&a.triad.col(alpha))
}

fn put<T: Real>(row: &mut [T], at: usize, v: V3<T>) {
    row[at..at + 3].copy_from_slice(&v.0);
}

/// Coincident points: `C = P₂ − P₁` (3 rows starting at `row`).
pub fn points_value<T: Real>(s: &JointState<T>, at: &[Attachment; 2], out: &mut [T]) {
    let d = point(s, 1, &at[1]) - point(s, 0, &at[0]);
    out[..3].copy_from_slice(&d.0);
}

/// Rows `[−I, (R₁p₁)~, I, −(R₂p₂)~]` of coincident points for the given side rotations.
fn points_rows<T: Real>(rot: [M3<T>; 2], at: &[Attachment; 2], out: &mut Rows<T>, row: usize) {
    for k in 0..2 {
        let sign = if k == 0 { -1.0 } else { 1.0 };
        let arm = rot[k].mul_vf(&at[k].offset).tilde();
        for c in 0..3 {
            out[row + c][6 * k + c] = T::cst(sign);
            for d in 0..3 {
                out[row + c][6 * k + 3 + d] = arm.0[c][d] * (-sign);
            }
        }
    }
}

/// Exact discrete gradient of coincident points: `(R_f − R_i) p = −(R_m p)~ ρ` with
/// `R_m = (R_i + R_f)/2` (identity A5/A6).
pub fn points_gradient<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    at: &[Attachment; 2],
    out: &mut Rows<T>,
    row: usize,
) {
    let mid = |k: usize| (si.r[k] + sf.r[k]).scale_f(0.5);
    points_rows([mid(0), mid(1)], at, out, row);
}

/// Rate of coincident points: `Ċ = v₂ + ω₂ × R₂p₂ − v₁ − ω₁ × R₁p₁`.
pub fn points_rate<T: Real>(
    s: &JointState<T>,
    at: &[Attachment; 2],
    out: &mut Rows<T>,
    row: usize,
) {
    points_rows(s.r, at, out, row);
}

/// `g = e_αᵏ · e_βˡ`, eq. (11).
pub fn dot_value<T: Real>(s: &JointState<T>, at: &[Attachment; 2], alpha: usize, beta: usize) -> T {
    unit(s, 0, &at[0], alpha).dot(&unit(s, 1, &at[1], beta))
}

/// `h_m = ẽ_αmᵏ e_βmˡ` with mid-step unit vectors `e_m = (e_i + e_f)/2` and `g_m`: eq. (15),
/// `g_f − g_i = (ρᵏ − ρˡ)ᵀ h_m`.
pub fn dot_mid<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    at: &[Attachment; 2],
    alpha: usize,
    beta: usize,
) -> (V3<T>, T) {
    let ek = (unit(si, 0, &at[0], alpha) + unit(sf, 0, &at[0], alpha)).scale_f(0.5);
    let el = (unit(si, 1, &at[1], beta) + unit(sf, 1, &at[1], beta)).scale_f(0.5);
    let gm = (dot_value(si, at, alpha, beta) + dot_value(sf, at, alpha, beta)) * 0.5;
    (ek.cross(&el), gm)
}

/// `h = ẽ_αᵏ e_βˡ` at one state: `ġ = (ωᵏ − ωˡ)ᵀ h`.
pub fn dot_h<T: Real>(s: &JointState<T>, at: &[Attachment; 2], alpha: usize, beta: usize) -> V3<T> {
    unit(s, 0, &at[0], alpha).cross(&unit(s, 1, &at[1], beta))
}

/// Writes `[0, h, 0, −h]·scale` into a row's rotation columns (adds to what is there).
pub fn add_rotation_pair<T: Real>(row: &mut [T], h: V3<T>, scale: T) {
    let hs = h.scale(scale);
    let mut k = [T::zero(); 3];
    let mut l = [T::zero(); 3];
    for c in 0..3 {
        k[c] = row[3 + c] + hs.0[c];
        l[c] = row[9 + c] - hs.0[c];
    }
    put(row, 3, V3(k));
    put(row, 9, V3(l));
}

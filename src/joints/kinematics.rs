//! Building blocks shared by the joint laws: coincident points and the orthogonality of two
//! body-fixed unit vectors (the universal-joint constraint, eqs. 11–16).

use super::{JointState, Rows};
use crate::math::scalar::Real;
use crate::math::vec3::V3;

/// Spatial attachment point `x + R p` of side `k`.
pub fn point<T: Real>(s: &JointState<T>, k: usize) -> V3<T> {
    s.x[k] + s.arm[k]
}

/// Unit vector `α` (0-based column) of side `k`'s attachment triad, `R A` column α.
pub fn unit<T: Real>(s: &JointState<T>, k: usize, alpha: usize) -> V3<T> {
    s.e[k].col(alpha)
}

fn put<T: Real>(row: &mut [T], at: usize, v: V3<T>) {
    row[at..at + 3].copy_from_slice(&v.0);
}

/// Coincident points: `C = P₂ − P₁` (3 rows starting at `row`).
pub fn points_value<T: Real>(s: &JointState<T>, out: &mut [T]) {
    let d = point(s, 1) - point(s, 0);
    out[..3].copy_from_slice(&d.0);
}

/// Rows `[−I, (R₁p₁)~, I, −(R₂p₂)~]` of coincident points for the given arms `R_k p_k`.
fn points_rows<T: Real>(arms: [V3<T>; 2], out: &mut Rows<T>, row: usize) {
    for k in 0..2 {
        let sign = if k == 0 { -1.0 } else { 1.0 };
        let arm = arms[k].tilde();
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
    out: &mut Rows<T>,
    row: usize,
) {
    let mid = |k: usize| (si.arm[k] + sf.arm[k]).scale_f(0.5);
    points_rows([mid(0), mid(1)], out, row);
}

/// Rate of coincident points: `Ċ = v₂ + ω₂ × R₂p₂ − v₁ − ω₁ × R₁p₁`.
pub fn points_rate<T: Real>(s: &JointState<T>, out: &mut Rows<T>, row: usize) {
    points_rows(s.arm, out, row);
}

/// `g = e_αᵏ · e_βˡ`, eq. (11).
pub fn dot_value<T: Real>(s: &JointState<T>, alpha: usize, beta: usize) -> T {
    unit(s, 0, alpha).dot(&unit(s, 1, beta))
}

/// `h_m = ẽ_αmᵏ e_βmˡ` with mid-step unit vectors `e_m = (e_i + e_f)/2` and `g_m`: eq. (15),
/// `g_f − g_i = (ρᵏ − ρˡ)ᵀ h_m`.
pub fn dot_mid<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    alpha: usize,
    beta: usize,
) -> (V3<T>, T) {
    let (eki, ekf) = (unit(si, 0, alpha), unit(sf, 0, alpha));
    let (eli, elf) = (unit(si, 1, beta), unit(sf, 1, beta));
    let gm = (eki.dot(&eli) + ekf.dot(&elf)) * 0.5;
    let (ek, el) = ((eki + ekf).scale_f(0.5), (eli + elf).scale_f(0.5));
    (ek.cross(&el), gm)
}

/// `h = ẽ_αᵏ e_βˡ` at one state: `ġ = (ωᵏ − ωˡ)ᵀ h`.
pub fn dot_h<T: Real>(s: &JointState<T>, alpha: usize, beta: usize) -> V3<T> {
    unit(s, 0, alpha).cross(&unit(s, 1, beta))
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

/// Separation of the attachment points projected on side l's unit vector β:
/// `C = e_βˡ·u`, `u = P₂ − P₁` (the prismatic constraints, eqs. 3–4).
pub fn projection_value<T: Real>(s: &JointState<T>, beta: usize) -> T {
    let u = point(s, 1) - point(s, 0);
    unit(s, 1, beta).dot(&u)
}

/// `row += e · G` for the three rows of `g`: a projection of point rows.
fn project_rows<T: Real>(g: &Rows<T>, e: &V3<T>, row: &mut [T]) {
    for (c, v) in row.iter_mut().enumerate().take(12) {
        *v += e.0[0] * g[0][c] + e.0[1] * g[1][c] + e.0[2] * g[2][c];
    }
}

/// Exact discrete gradient of a projection, eq. (8): `C_f − C_i = e_mᵀ(u_f − u_i) + u_mᵀ(e_f − e_i)`
/// with `e_f − e_i = ρ̃ˡ e_m`, so the rotation of side l gets `e_m × u_m`; mid values are the
/// means of the i and f values (eq. 9).
pub fn projection_gradient<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    beta: usize,
    row: &mut [T],
) {
    let mut g = [[T::zero(); super::NCOL]; super::MAX_ROWS];
    points_gradient(si, sf, &mut g, 0);
    let e_m = (unit(si, 1, beta) + unit(sf, 1, beta)).scale_f(0.5);
    let u = |s: &JointState<T>| point(s, 1) - point(s, 0);
    let u_m = (u(si) + u(sf)).scale_f(0.5);
    project_rows(&g, &e_m, row);
    let h = e_m.cross(&u_m);
    for c in 0..3 {
        row[9 + c] += h.0[c];
    }
}

/// Rate of a projection: `Ċ = eᵀu̇ + ωˡ·(e × u)`.
pub fn projection_rate<T: Real>(s: &JointState<T>, beta: usize, row: &mut [T]) {
    let mut g = [[T::zero(); super::NCOL]; super::MAX_ROWS];
    points_rate(s, &mut g, 0);
    let e = unit(s, 1, beta);
    let u = point(s, 1) - point(s, 0);
    project_rows(&g, &e, row);
    let h = e.cross(&u);
    for c in 0..3 {
        row[9 + c] += h.0[c];
    }
}

/// The three rows of identical orientations, `e₂ᵏ·e₃ˡ = e₃ᵏ·e₁ˡ = e₁ᵏ·e₂ˡ = 0` (each a
/// universal-joint constraint, eqs. 11–16), starting at `row`.
pub const ORIENTATION_PAIRS: [(usize, usize); 3] = [(1, 2), (2, 0), (0, 1)];

pub fn orientation_value<T: Real>(s: &JointState<T>, out: &mut [T]) {
    for (r, (a, b)) in ORIENTATION_PAIRS.iter().enumerate() {
        out[r] = dot_value(s, *a, *b);
    }
}

pub fn orientation_gradient<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    out: &mut Rows<T>,
    row: usize,
) {
    for (r, (a, b)) in ORIENTATION_PAIRS.iter().enumerate() {
        add_rotation_pair(&mut out[row + r], dot_mid(si, sf, *a, *b).0, T::one());
    }
}

pub fn orientation_rate<T: Real>(s: &JointState<T>, out: &mut Rows<T>, row: usize) {
    for (r, (a, b)) in ORIENTATION_PAIRS.iter().enumerate() {
        add_rotation_pair(&mut out[row + r], dot_h(s, *a, *b), T::one());
    }
}

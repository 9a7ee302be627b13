//! Finite rotations: Rodrigues (Cayley) parameters with the seed's identities (A1)–(A6),
//! Wiener–Milenkovic parameters, the rotation vector (exp/log) and composition.
//!
//! Total orientations are stored as rotation matrices (never as parameters, which become
//! singular); parameters describe *increments* within a step and interpolation. The identity
//! behind every discrete force of the paper is (A5)/(A6): with `R = cay(r)`,
//! `R − I = r̃ (R + I)/2`, so `e_f − e_i = r̃ (e_f + e_i)/2` exactly (eq. 7).

use crate::math::scalar::Real;
use crate::math::vec3::{M3, V3};

/// The largest incremental rotation accepted within one step. Rodrigues parameters grow as
/// `2 tan(φ/2)` and are infinite at 180°; past about 150° a step is no longer a meaningful
/// increment, so the integrator asks for a smaller step instead.
pub const MAX_STEP_ROTATION: f64 = 150.0 * std::f64::consts::PI / 180.0;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RotationError {
    #[error("incremental rotation of {angle_deg:.1}° in one step exceeds the {limit_deg:.0}° limit of Rodrigues parameters (singular at 180°); reduce the time step")]
    StepTooLarge { angle_deg: f64, limit_deg: f64 },
    #[error("rotation of 180° has no Rodrigues parameters (tan(φ/2) is infinite)")]
    HalfTurn,
    #[error("matrix is not a rotation: |RᵀR − I| = {orth_err:.3e}, det = {det:.6}")]
    NotARotation { orth_err: f64, det: f64 },
}

/// `r0 = cos²(φ/2) = 1/(1 + rᵀr/4)`, eq. (A1).
#[inline]
pub fn rodrigues_r0<T: Real>(r: &V3<T>) -> T {
    T::one() / (r.norm_sq() * 0.25 + 1.0)
}

/// Rotation tensor of Rodrigues parameters `r = 2 tan(φ/2) n`: `R = I + r0 r̃ + (r0/2) r̃ r̃`,
/// eq. (A2). Equals the Cayley transform `(I − r̃/2)⁻¹(I + r̃/2)`.
#[inline]
pub fn cayley<T: Real>(r: &V3<T>) -> M3<T> {
    let r0 = rodrigues_r0(r);
    let rt = r.tilde();
    M3::identity() + rt.scale(r0) + rt.mul_m(&rt).scale(r0 * 0.5)
}

/// `cay(r) w = w + r0 r × w + (r0/2) r × (r × w)`, eq. (A2) applied to a vector without
/// forming the tensor (a third of its arithmetic).
#[inline]
pub fn cayley_rotate<T: Real>(r: &V3<T>, w: &V3<T>) -> V3<T> {
    let r0 = rodrigues_r0(r);
    let rw = r.cross(w);
    *w + (rw + r.cross(&rw).scale_f(0.5)).scale(r0)
}

/// `H(r) = r0 (I + r̃/2)`, eq. (A3): the spatial angular velocity of `R(r)` is `ω = H ṙ`.
#[inline]
pub fn rodrigues_h<T: Real>(r: &V3<T>) -> M3<T> {
    let r0 = rodrigues_r0(r);
    (M3::identity() + r.tilde().scale_f(0.5)).scale(r0)
}

/// Material tangent of the Cayley map: for `R = R_i cay(r)`, `Rᵀ dR = (T(r) dr)~` with
/// `T(r) = Hᵀ = r0 (I − r̃/2)`.
#[inline]
pub fn cayley_tangent<T: Real>(r: &V3<T>) -> M3<T> {
    rodrigues_h(r).transpose()
}

/// `R_i cay(r)` for an increment `r` in `f64` or a first-order dual: the value from `f64`
/// algebra and the variation from the material tangent, `δ(R_i cay(r)) = R_f (T(r) δr)~`
/// ([`cayley_tangent`]). Equal to `R_i cay(r)` to first order — all a dual carries — without
/// forming `cay(r)` in duals (a dual 3×3 product fewer); in `f64` it is just `R_i cay(r)`.
#[inline]
pub fn rotate_material<T: Real>(r_i: &M3<f64>, r: &V3<T>) -> M3<T> {
    let r0 = r.re();
    let rf = r_i.mul_m(&cayley(&r0));
    if !T::DERIVATIVES {
        return M3::from_f64(&rf);
    }
    let t = cayley_tangent(&r0).0;
    let dr = r.0.map(|v| v - v.re());
    let th = V3(std::array::from_fn(|i| {
        dr[0] * t[i][0] + dr[1] * t[i][1] + dr[2] * t[i][2]
    }));
    M3::from_f64(&rf) + th.tilde().pre_mul_f(&rf)
}

/// `(I − r̃/2)⁻¹ = I + r0 (r̃/2 + r̃r̃/4)`; note `R_i (I − r̃/2)⁻¹ = (R_i + R_f)/2`.
#[inline]
pub fn inv_i_minus_half_tilde<T: Real>(r: &V3<T>) -> M3<T> {
    let r0 = rodrigues_r0(r);
    let rt = r.tilde();
    M3::identity() + (rt.scale_f(0.5) + rt.mul_m(&rt).scale_f(0.25)).scale(r0)
}

/// Rodrigues parameters of an increment, refusing rotations past [`MAX_STEP_ROTATION`].
pub fn check_step_rotation(r: &V3<f64>) -> Result<(), RotationError> {
    let angle = 2.0 * (0.5 * r.norm()).atan();
    if !angle.is_finite() || angle > MAX_STEP_ROTATION {
        return Err(RotationError::StepTooLarge {
            angle_deg: angle.to_degrees(),
            limit_deg: MAX_STEP_ROTATION.to_degrees(),
        });
    }
    Ok(())
}

/// Rodrigues parameters of a rotation matrix: `r = 4 axial(R)/(1 + tr R)` with
/// `axial(R) = sin φ n`. Errors at (or numerically near) a half turn.
pub fn cayley_log(rm: &M3<f64>) -> Result<V3<f64>, RotationError> {
    let den = 1.0 + rm.trace();
    if den < 1e-12 {
        return Err(RotationError::HalfTurn);
    }
    Ok(rm.axial().scale_f(4.0 / den))
}

/// Rotation vector `φ n` to rotation tensor (Euler–Rodrigues formula).
pub fn exp_map<T: Real>(phi: &V3<T>) -> M3<T> {
    let t2 = phi.norm_sq();
    let pt = phi.tilde();
    // a = sin t / t, b = (1 − cos t)/t², by series below 1e-4 rad (error < 1e-17).
    let (a, b) = if t2.re() < 1e-8 {
        (T::one() - t2 / 6.0, T::cst(0.5) - t2 / 24.0)
    } else {
        let t = t2.sqrt();
        (t.sin() / t, (T::one() - t.cos()) / t2)
    };
    M3::identity() + pt.scale(a) + pt.mul_m(&pt).scale(b)
}

/// Rotation tensor to rotation vector with angle in `[0, π]`, accurate near 0 and near π.
pub fn log_map(rm: &M3<f64>) -> V3<f64> {
    let c = ((rm.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
    let ax = rm.axial(); // sin φ n
    let s = ax.norm();
    let angle = s.atan2(c);
    if angle < 1e-6 {
        // φ n = axial / (sin φ/φ), series of sin φ/φ.
        return ax.scale_f(1.0 / (1.0 - angle * angle / 6.0));
    }
    if angle < std::f64::consts::PI - 1e-4 {
        return ax.scale_f(angle / s);
    }
    // Near π the skew part vanishes: take the axis from the symmetric part
    // (R + Rᵀ)/2 = cos φ I + (1 − cos φ) n nᵀ, using its largest diagonal entry.
    let mut b = M3::<f64>::zero();
    for i in 0..3 {
        for j in 0..3 {
            b.0[i][j] = 0.5 * (rm.0[i][j] + rm.0[j][i]) - if i == j { c } else { 0.0 };
        }
    }
    let k = (0..3)
        .max_by(|&i, &j| b.0[i][i].total_cmp(&b.0[j][j]))
        .unwrap();
    let mut n = b.col(k).scale_f(1.0 / b.0[k][k].max(1e-300).sqrt());
    n = n.scale_f(1.0 / n.norm());
    // The sign of n follows the (small) skew part.
    if n.dot(&ax) < 0.0 {
        n = -n;
    }
    n.scale_f(angle)
}

/// Wiener–Milenkovic parameters `c = 4 tan(φ/4) n` to rotation tensor:
/// `R = [(c0² − cᵀc) I + 2 c cᵀ + 2 c0 c̃] / (4 − c0)²`, `c0 = 2 − cᵀc/8`.
pub fn wiener_milenkovic<T: Real>(c: &V3<T>) -> M3<T> {
    let cc = c.norm_sq();
    let c0 = T::cst(2.0) - cc / 8.0;
    let den = (T::cst(4.0) - c0) * (T::cst(4.0) - c0);
    (M3::identity().scale(c0 * c0 - cc) + c.outer(c).scale_f(2.0) + c.tilde().scale(c0 * 2.0))
        .scale(T::one() / den)
}

/// Wiener–Milenkovic parameters of a rotation (angle in `[0, π]`, so `|c| ≤ 4`).
pub fn wiener_milenkovic_log(rm: &M3<f64>) -> V3<f64> {
    let phi = log_map(rm);
    let a = phi.norm();
    if a < 1e-12 {
        return phi; // 4 tan(a/4) ≈ a
    }
    phi.scale_f(4.0 * (a / 4.0).tan() / a)
}

/// Composition `R(c) = R(c2) R(c1)` directly in Wiener–Milenkovic parameters, rescaled
/// (equivalently: the axis flipped) so the result stays on the branch `|φ| ≤ π`.
pub fn wiener_milenkovic_compose(c2: &V3<f64>, c1: &V3<f64>) -> V3<f64> {
    let c10 = 2.0 - c1.norm_sq() / 8.0;
    let c20 = 2.0 - c2.norm_sq() / 8.0;
    let d1 = (4.0 - c10) * (4.0 - c20);
    let d2 = c10 * c20 - c1.dot(c2);
    let num = c1.scale_f(c20) + c2.scale_f(c10) + c2.cross(c1);
    if d2 >= 0.0 {
        num.scale_f(4.0 / (d1 + d2))
    } else {
        num.scale_f(-4.0 / (d1 - d2))
    }
}

/// Re-orthonormalise a rotation matrix that has accumulated round-off (Gram–Schmidt on the
/// columns, which changes an orthonormal input by at most round-off).
pub fn orthonormalize(rm: &M3<f64>) -> M3<f64> {
    let a = rm.col(0);
    let e1 = a.scale_f(1.0 / a.norm());
    let b = rm.col(1);
    let b = b - e1.scale_f(e1.dot(&b));
    let e2 = b.scale_f(1.0 / b.norm());
    let e3 = e1.cross(&e2);
    M3::from_cols(e1, e2, e3)
}

/// Checks that `rm` is a proper rotation to `tol`.
pub fn check_rotation(rm: &M3<f64>, tol: f64) -> Result<(), RotationError> {
    let e = (rm.transpose().mul_m(rm) - M3::identity()).max_abs();
    let det = rm.det();
    if e > tol || (det - 1.0).abs() > tol {
        return Err(RotationError::NotARotation { orth_err: e, det });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v(a: [f64; 3]) -> V3<f64> {
        V3(a)
    }
    fn close(a: &M3<f64>, b: &M3<f64>, tol: f64) -> bool {
        (*a - *b).max_abs() <= tol
    }
    /// Rodrigues parameters of rotations up to 170°: |r| ≤ 2 tan(85°) ≈ 22.9.
    fn arb_r() -> impl Strategy<Value = V3<f64>> {
        (prop::array::uniform3(-1.0f64..1.0), 0.0f64..170.0).prop_filter_map(
            "nonzero axis",
            |(a, deg)| {
                let n = v(a);
                let l = n.norm();
                (l > 1e-3).then(|| n.scale_f(2.0 * (deg.to_radians() / 2.0).tan() / l))
            },
        )
    }

    // Round-off of these identities grows with |r|² (entries of r̃r̃): the bound below is
    // 1e-14 relative to the size of the terms, i.e. ~1e-14·(1 + |r|²).
    fn tol(r: &V3<f64>) -> f64 {
        1e-14 * (1.0 + r.norm_sq())
    }

    proptest! {
        #[test]
        fn a4_orthogonal_fixes_axis_and_factors(r in arb_r()) {
            let rm = cayley(&r);
            let i = M3::<f64>::identity();
            prop_assert!(close(&rm.mul_m(&rm.transpose()), &i, 1e-14));
            prop_assert!((rm.mul_v(&r) - r).max_abs() <= tol(&r));
            let h = rodrigues_h(&r);
            let hinv_t = h.inverse().transpose();
            prop_assert!(close(&h.mul_m(&hinv_t), &rm, tol(&r)));
            prop_assert!(close(&hinv_t.mul_m(&h), &rm, tol(&r)));
            prop_assert!((rm.det() - 1.0).abs() < 1e-14);
        }

        #[test]
        fn a5_a6_midpoint_identities(r in arb_r()) {
            let rm = cayley(&r);
            let i = M3::<f64>::identity();
            let half = (rm + i).scale_f(0.5);
            let p = i + r.tilde().scale_f(0.5);
            let m = i - r.tilde().scale_f(0.5);
            prop_assert!(close(&p.mul_m(&half), &rm, tol(&r)));   // (A5)
            prop_assert!(close(&half.mul_m(&p), &rm, tol(&r)));
            prop_assert!(close(&m.mul_m(&half), &i, tol(&r)));    // (A6)
            prop_assert!(close(&half.mul_m(&m), &i, tol(&r)));
        }

        #[test]
        fn cayley_equals_cayley_transform_and_log_round_trips(r in arb_r()) {
            let i = M3::<f64>::identity();
            let ct = (i - r.tilde().scale_f(0.5)).inverse().mul_m(&(i + r.tilde().scale_f(0.5)));
            prop_assert!(close(&cayley(&r), &ct, tol(&r)));
            let back = cayley_log(&cayley(&r)).unwrap();
            prop_assert!((back - r).max_abs() <= 1e-13 * (1.0 + r.norm_sq()));
        }

        #[test]
        fn exp_log_and_cayley_agree(r in arb_r()) {
            // Same rotation as a rotation vector: angle 2 atan(|r|/2) about r.
            let l = r.norm();
            let phi = r.scale_f(2.0 * (0.5 * l).atan() / l);
            prop_assert!(close(&exp_map(&phi), &cayley(&r), tol(&r)));
            prop_assert!((log_map(&exp_map(&phi)) - phi).max_abs() < 1e-12);
        }

        #[test]
        fn wiener_milenkovic_round_trip_and_composition(r1 in arb_r(), r2 in arb_r()) {
            let (a, b) = (cayley(&r1), cayley(&r2));
            let c1 = wiener_milenkovic_log(&a);
            let c2 = wiener_milenkovic_log(&b);
            prop_assert!(close(&wiener_milenkovic(&c1), &a, 1e-13));
            let c = wiener_milenkovic_compose(&c2, &c1);
            prop_assert!(c.norm() <= 4.0 + 1e-12);
            prop_assert!(close(&wiener_milenkovic(&c), &b.mul_m(&a), 1e-13));
        }

        #[test]
        fn cayley_rotate_is_the_tensor_applied(r in arb_r(), w in prop::array::uniform3(-1.0f64..1.0)) {
            let w = v(w);
            let e = (cayley_rotate(&r, &w) - cayley(&r).mul_v(&w)).max_abs();
            // Both round the same ~10 operations on entries of size ≤ |r|²: round-off.
            prop_assert!(e <= 1e-14 * (1.0 + r.norm_sq()), "{e:e}");
        }

        #[test]
        fn cayley_tangent_matches_finite_differences(r in arb_r(), d in prop::array::uniform3(-1.0f64..1.0)) {
            let d = v(d);
            let e = 1e-6 * (1.0 + r.norm());
            let rp = cayley(&(r + d.scale_f(e)));
            let rmn = cayley(&(r - d.scale_f(e)));
            let rm = cayley(&r);
            // Rᵀ dR ≈ Rᵀ (R(r+εd) − R(r−εd))/(2ε): central difference, O(ε²) truncation.
            let w = rm.transpose().mul_m(&(rp - rmn)).scale_f(0.5 / e).axial();
            let t = cayley_tangent(&r).mul_v(&d);
            prop_assert!((w - t).max_abs() < 1e-7 * (1.0 + d.norm()));
        }
    }

    #[test]
    fn rotate_material_is_r_i_cayley_to_first_order() {
        use crate::math::scalar::Dual;
        let ri = exp_map(&v([0.3, -1.2, 0.4]));
        let r = v([0.8, 0.1, -2.0]);
        let rd = V3(std::array::from_fn(|k| Dual::<3>::seeded(r.0[k], Some(k))));
        let (fast, full) = (rotate_material(&ri, &rd), cayley(&rd).pre_mul_f(&ri));
        for i in 0..3 {
            for j in 0..3 {
                let (a, b) = (fast.0[i][j], full.0[i][j]);
                // Both are exact to first order: they differ by round-off of O(1) entries.
                assert!((a.re - b.re).abs() < 1e-15, "value {i}{j}");
                for k in 0..3 {
                    assert!((a.du[k] - b.du[k]).abs() < 1e-14, "d/dr{k} of {i}{j}");
                }
            }
        }
        assert!(close(
            &rotate_material(&ri, &r),
            &ri.mul_m(&cayley(&r)),
            0.0
        ));
    }

    #[test]
    fn spatial_increment_identity_eq7() {
        // e_f − e_i = r̃ (e_f + e_i)/2 for R_f = cay(r) R_i.
        let ri = exp_map(&v([0.3, -1.2, 0.4]));
        let r = v([0.8, 0.1, -2.0]);
        let rf = cayley(&r).mul_m(&ri);
        let lhs = rf - ri;
        let rhs = r.tilde().mul_m(&(rf + ri)).scale_f(0.5);
        assert!(close(&lhs, &rhs, 1e-14));
    }

    #[test]
    fn near_half_turn_is_a_clear_error_not_nan() {
        let n = v([1.0, 2.0, 2.0]).scale_f(1.0 / 3.0);
        for deg in [149.0, 151.0, 179.9, 180.0] {
            let a = f64::to_radians(deg);
            let r = n.scale_f(2.0 * (a / 2.0).tan());
            let res = check_step_rotation(&r);
            if deg < 150.0 {
                assert!(res.is_ok());
            } else {
                let msg = res.unwrap_err().to_string();
                assert!(msg.contains("reduce the time step"), "{msg}");
            }
        }
        let half_turn = exp_map(&n.scale_f(std::f64::consts::PI));
        assert_eq!(cayley_log(&half_turn), Err(RotationError::HalfTurn));
        // The rotation vector is well defined at π: axis recovered, no NaN.
        let phi = log_map(&half_turn);
        assert!(phi.0.iter().all(|x| x.is_finite()));
        assert!((phi.norm() - std::f64::consts::PI).abs() < 1e-12);
        assert!(close(&exp_map(&phi), &half_turn, 1e-12));
        // And just below π, where the skew part is tiny.
        let near = exp_map(&n.scale_f(std::f64::consts::PI - 1e-7));
        assert!((log_map(&near) - n.scale_f(std::f64::consts::PI - 1e-7)).max_abs() < 1e-8);
    }

    #[test]
    fn orthonormalize_repairs_drift() {
        let mut r = exp_map(&v([0.3, 0.2, -0.1]));
        r.0[0][0] += 1e-9;
        let q = orthonormalize(&r);
        assert!(check_rotation(&q, 1e-15).is_ok());
        assert!(check_rotation(&r, 1e-12).is_err());
    }
}

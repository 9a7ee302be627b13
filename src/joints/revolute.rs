//! Revolute joint (section 4.2): coincident points, `e₃ᵏ·e₁ˡ = e₃ᵏ·e₂ˡ = 0` (eq. 11) and the
//! relative rotation φ about e₃ defined by `C = g₁₁ sin φ + g₁₂ cos φ = 0` (eq. 17), with
//! `g_αβ = e_αᵏ·e_βˡ`. Its exact discrete gradient is eq. (22) and the discrete forces eq. (23).

use super::kinematics::*;
use super::stiffness::{self, Stiffness};
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::{sinc_half, Real};
use crate::math::vec3::V3;

#[derive(Clone, Debug)]
pub struct Revolute {
    /// Triads whose third unit vector is the axis; φ = 0 when they coincide.
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Revolute {
    fn attachments(&self) -> &[Attachment; 2] {
        &self.at
    }
    fn n_rows(&self) -> usize {
        6
    }
    fn n_coords(&self) -> usize {
        1
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, out);
        axis_value(s, &mut out[3..5]);
        out[5] = phi_value(s, 0);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, out, 0);
        axis_gradient(si, sf, out, 3);
        phi_gradient(si, sf, 0, &mut out[5]);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, out, 0);
        axis_rate(s, out, 3);
        phi_rate(s, 0, &mut out[5]);
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        stiffness::points(sf, V3([lam[0], lam[1], lam[2]]), k);
        stiffness::axis(si, sf, &lam[3..5], k);
        stiffness::angle(si, sf, 0, REVOLUTE_PHI, lam[5], k);
    }
    fn affine_in_translations(&self) -> bool {
        true
    }
    fn coincident_point_rows(&self) -> Option<usize> {
        Some(0)
    }
}

/// The two rows keeping the axes aligned, `e₃ᵏ·e₁ˡ = e₃ᵏ·e₂ˡ = 0` (eq. 11).
pub fn axis_value<T: Real>(s: &JointState<T>, out: &mut [T]) {
    out[0] = dot_value(s, 2, 0);
    out[1] = dot_value(s, 2, 1);
}

pub fn axis_gradient<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    out: &mut Rows<T>,
    row: usize,
) {
    add_rotation_pair(&mut out[row], dot_mid(si, sf, 2, 0).0, T::one());
    add_rotation_pair(&mut out[row + 1], dot_mid(si, sf, 2, 1).0, T::one());
}

pub fn axis_rate<T: Real>(s: &JointState<T>, out: &mut Rows<T>, row: usize) {
    add_rotation_pair(&mut out[row], dot_h(s, 2, 0), T::one());
    add_rotation_pair(&mut out[row + 1], dot_h(s, 2, 1), T::one());
}

/// Which products define an angle: `C = c_s g_{a b} sin φ + c_c g_{c d} cos φ = 0`, with
/// `g_αβ = e_αᵏ·e_βˡ` — (a, b, c_s) and (c, d, c_c).
pub type AngleTerms = ((usize, usize, f64), (usize, usize, f64));

/// The revolute's φ about e₃ᵏ: `g₁₁ sin φ + g₁₂ cos φ = 0` (eq. 17).
pub const REVOLUTE_PHI: AngleTerms = ((0, 0, 1.0), (0, 1, 1.0));

/// The row defining φ (coordinate `qi`) about e₃ᵏ: `g₁₁ sin φ + g₁₂ cos φ = 0` (eq. 17).
pub fn phi_value<T: Real>(s: &JointState<T>, qi: usize) -> T {
    angle_value(s, qi, REVOLUTE_PHI)
}

/// Eq. (22): sin_m, cos_m are mean values, φ_m the mean angle, S_m = sin(Δφ/2)/(Δφ/2).
pub fn phi_gradient<T: Real>(si: &JointState<T>, sf: &JointState<T>, qi: usize, row: &mut [T]) {
    angle_gradient(si, sf, qi, REVOLUTE_PHI, row)
}

pub fn phi_rate<T: Real>(s: &JointState<T>, qi: usize, row: &mut [T]) {
    angle_rate(s, qi, REVOLUTE_PHI, row)
}

/// An angle row of the form of eq. (17) over any pair of products (see [`AngleTerms`]).
pub fn angle_value<T: Real>(s: &JointState<T>, qi: usize, g: AngleTerms) -> T {
    let ((a, b, cs), (c, d, cc)) = g;
    let phi = s.q[qi];
    dot_value(s, a, b) * phi.sin() * cs + dot_value(s, c, d) * phi.cos() * cc
}

/// Its exact discrete gradient, eq. (22) generalized.
pub fn angle_gradient<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    qi: usize,
    g: AngleTerms,
    row: &mut [T],
) {
    let ((a, b, cs), (c, d, cc)) = g;
    let (pi, pf) = (si.q[qi], sf.q[qi]);
    let sin_m = (pi.sin() + pf.sin()) * 0.5;
    let cos_m = (pi.cos() + pf.cos()) * 0.5;
    let phi_m = (pi + pf) * 0.5;
    let s_m = sinc_half(pf - pi);
    let (h1, g1) = dot_mid(si, sf, a, b);
    let (h2, g2) = dot_mid(si, sf, c, d);
    add_rotation_pair(row, h1.scale(sin_m * cs) + h2.scale(cos_m * cc), T::one());
    row[12 + qi] = (g1 * phi_m.cos() * cs - g2 * phi_m.sin() * cc) * s_m;
}

pub fn angle_rate<T: Real>(s: &JointState<T>, qi: usize, g: AngleTerms, row: &mut [T]) {
    let ((a, b, cs), (c, d, cc)) = g;
    let phi = s.q[qi];
    let h = dot_h(s, a, b).scale(phi.sin() * cs) + dot_h(s, c, d).scale(phi.cos() * cc);
    add_rotation_pair(row, h, T::one());
    row[12 + qi] = dot_value(s, a, b) * phi.cos() * cs - dot_value(s, c, d) * phi.sin() * cc;
}

/// The relative rotation of side l about e₃ᵏ, for initial values: φ = atan2(e₂ᵏ·e₁ˡ, e₁ᵏ·e₁ˡ).
pub fn relative_angle(s: &JointState<f64>) -> f64 {
    let e1l = unit(s, 1, 0);
    unit(s, 0, 1).dot(&e1l).atan2(unit(s, 0, 0).dot(&e1l))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::law_tests::{assert_law, attachments};
    use crate::math::rotation::exp_map;
    use crate::math::vec3::V3;

    #[test]
    fn discrete_gradient_exact_and_rate_consistent() {
        assert_law(&Revolute { at: attachments() });
    }

    #[test]
    fn phi_is_the_rotation_of_l_about_the_axis() {
        use crate::joints::{JointState, MAX_COORDS};
        use crate::math::vec3::M3;
        let at = [Attachment {
            offset: V3([0.0; 3]),
            triad: M3::identity(),
        }; 2];
        let phi = 0.7;
        let s = JointState::new(
            [V3([0.0; 3]); 2],
            [M3::identity(), exp_map(&V3([0.0, 0.0, phi]))],
            [phi; MAX_COORDS],
            &at,
        );
        let mut c = [0.0; 6];
        Revolute { at }.value(&s, &mut c);
        assert!(c.iter().all(|v| v.abs() < 1e-15), "{c:?}");
        assert!((relative_angle(&s) - phi).abs() < 1e-15);
    }
}

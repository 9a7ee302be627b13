//! Universal joint: coincident points and `e₃ᵏ · e₃ˡ = 0` (eq. 11 with α = β = 3); the
//! attachment triads carry `axis1` and `axis2` as their third unit vectors. Discrete force:
//! eq. (16), `F = ±sλ_m h_m` with `h_m = ẽ_mᵏ e_mˡ`.
//!
//! Its two rotations are coordinates (a gimbal's angles), each defined by a row of the form of
//! eq. (17) with its exact discrete gradient eq. (22): φ₁ turns the cross (and `axis2`) about
//! `axis1`, `e₃ˡ = cos φ₁ e₁ᵏ + sin φ₁ e₂ᵏ`; φ₂ turns side l about `axis2`,
//! `e₃ᵏ = cos φ₂ e₁ˡ − sin φ₂ e₂ˡ`. The triads are set so both are zero initially
//! (`e₁ᵏ = axis2`, `e₁ˡ = axis1`); springs, dampers and drives act on them as on a revolute's φ.

use super::kinematics::*;
use super::revolute::{angle_gradient, angle_rate, angle_value, AngleTerms};
use super::stiffness::{self, Stiffness};
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::Real;
use crate::math::vec3::V3;

/// φ₁: `g₁₃ sin φ₁ − g₂₃ cos φ₁ = 0`.
const PHI1: AngleTerms = ((0, 2, 1.0), (1, 2, -1.0));
/// φ₂: `g₃₁ sin φ₂ + g₃₂ cos φ₂ = 0`.
const PHI2: AngleTerms = ((2, 0, 1.0), (2, 1, 1.0));

#[derive(Clone, Debug)]
pub struct Universal {
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Universal {
    fn attachments(&self) -> &[Attachment; 2] {
        &self.at
    }
    fn n_rows(&self) -> usize {
        6
    }
    fn n_coords(&self) -> usize {
        2
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, out);
        out[3] = dot_value(s, 2, 2);
        out[4] = angle_value(s, 0, PHI1);
        out[5] = angle_value(s, 1, PHI2);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, out, 0);
        let (hm, _) = dot_mid(si, sf, 2, 2); // eq. (15)
        add_rotation_pair(&mut out[3], hm, T::one());
        angle_gradient(si, sf, 0, PHI1, &mut out[4]);
        angle_gradient(si, sf, 1, PHI2, &mut out[5]);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, out, 0);
        add_rotation_pair(&mut out[3], dot_h(s, 2, 2), T::one());
        angle_rate(s, 0, PHI1, &mut out[4]);
        angle_rate(s, 1, PHI2, &mut out[5]);
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        stiffness::points(sf, V3([lam[0], lam[1], lam[2]]), k);
        stiffness::dot_pair(si, sf, 2, 2, lam[3], k);
        stiffness::angle(si, sf, 0, PHI1, lam[4], k);
        stiffness::angle(si, sf, 1, PHI2, lam[5], k);
    }
    fn affine_in_translations(&self) -> bool {
        true
    }
    fn coincident_point_rows(&self) -> Option<usize> {
        Some(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::law_tests::{assert_law, attachments};

    #[test]
    fn discrete_gradient_exact_and_rate_consistent() {
        assert_law(&Universal { at: attachments() });
    }
}

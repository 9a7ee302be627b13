//! Clamp: a rigid connection, coincident points and identical triads (6 constraints:
//! `e₂ᵏ·e₃ˡ = e₃ᵏ·e₁ˡ = e₁ᵏ·e₂ˡ = 0`, each a universal-joint constraint, eqs. 11–16).
//! Also used internally to carry a rigid body whose centre of mass is offset from its node.

use super::kinematics::*;
use super::stiffness::{self, Stiffness};
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::Real;
use crate::math::vec3::V3;

#[derive(Clone, Debug)]
pub struct Clamp {
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Clamp {
    fn attachments(&self) -> &[Attachment; 2] {
        &self.at
    }
    fn n_rows(&self) -> usize {
        6
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, out);
        orientation_value(s, &mut out[3..6]);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, out, 0);
        orientation_gradient(si, sf, out, 3);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, out, 0);
        orientation_rate(s, out, 3);
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        stiffness::points(sf, V3([lam[0], lam[1], lam[2]]), k);
        stiffness::orientation(si, sf, &lam[3..6], k);
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
        assert_law(&Clamp { at: attachments() });
    }
}

//! Spherical joint: the attachment points of both nodes coincide (3 constraints).

use super::kinematics::*;
use super::stiffness::{self, Stiffness};
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::Real;
use crate::math::vec3::V3;

#[derive(Clone, Debug)]
pub struct Spherical {
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Spherical {
    fn attachments(&self) -> &[Attachment; 2] {
        &self.at
    }
    fn n_rows(&self) -> usize {
        3
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, out);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, out, 0);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, out, 0);
    }
    fn force_stiffness(
        &self,
        _si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        stiffness::points(sf, V3([lam[0], lam[1], lam[2]]), k);
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
        assert_law(&Spherical { at: attachments() });
    }
}

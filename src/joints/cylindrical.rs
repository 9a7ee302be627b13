//! Cylindrical joint (section 4.3): the prismatic joint's separation constraints (eqs. 3–4,
//! defining Δ, coordinate 0) with the revolute joint's rotation constraints (eqs. 11 and 17,
//! defining φ about the common axis, coordinate 1). Six rows, two relative motions.

use super::prismatic::{slide_gradient, slide_rate, slide_value};
use super::revolute::{
    axis_gradient, axis_rate, axis_value, phi_gradient, phi_rate, phi_value, REVOLUTE_PHI,
};
use super::stiffness::{self, Stiffness};
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::Real;

#[derive(Clone, Debug)]
pub struct Cylindrical {
    /// Triads whose third unit vector is the axis; Δ = 0 and φ = 0 when they coincide.
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Cylindrical {
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
        slide_value(s, 0, out);
        axis_value(s, &mut out[3..5]);
        out[5] = phi_value(s, 1);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        slide_gradient(si, sf, 0, out);
        axis_gradient(si, sf, out, 3);
        phi_gradient(si, sf, 1, &mut out[5]);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        slide_rate(s, 0, out);
        axis_rate(s, out, 3);
        phi_rate(s, 1, &mut out[5]);
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        stiffness::slide(si, sf, &lam[..3], k);
        stiffness::axis(si, sf, &lam[3..5], k);
        stiffness::angle(si, sf, 1, REVOLUTE_PHI, lam[5], k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::law_tests::{assert_law, attachments};

    #[test]
    fn discrete_gradient_exact_and_rate_consistent() {
        assert_law(&Cylindrical { at: attachments() });
    }
}

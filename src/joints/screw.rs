//! Screw joint (section 4.4): the cylindrical joint with the linear constraint
//! `Δ − p φ = 0` (eq. 24) between its relative displacement and rotation; p is the pitch
//! (m/rad: the advance per radian of turn, so a full turn advances 2π p).

use super::cylindrical::Cylindrical;
use super::stiffness::Stiffness;
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::Real;

#[derive(Clone, Debug)]
pub struct Screw {
    pub cylinder: Cylindrical,
    /// m/rad.
    pub pitch: f64,
}

impl ConstraintLaw for Screw {
    fn attachments(&self) -> &[Attachment; 2] {
        &self.cylinder.at
    }
    fn n_rows(&self) -> usize {
        7
    }
    fn n_coords(&self) -> usize {
        2
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        self.cylinder.value(s, out);
        out[6] = s.q[0] - s.q[1] * self.pitch;
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        self.cylinder.discrete_gradient(si, sf, out);
        // Linear: its discrete gradient is its gradient.
        out[6][12] = T::one();
        out[6][13] = T::cst(-self.pitch);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        self.cylinder.rate(s, out);
        out[6][12] = T::one();
        out[6][13] = T::cst(-self.pitch);
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        // Row 6 is linear in the coordinates: no stiffness.
        self.cylinder.force_stiffness(si, sf, &lam[..6], k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::law_tests::{assert_law, attachments};

    #[test]
    fn discrete_gradient_exact_and_rate_consistent() {
        assert_law(&Screw {
            cylinder: Cylindrical { at: attachments() },
            pitch: 0.013,
        });
    }
}

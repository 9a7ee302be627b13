//! Prismatic joint (section 3): identical orientations and the separation `u = P₂ − P₁` of
//! the joint points along side l's axis e₃ˡ only: `C_α = e_αˡ·u = 0` (α = 1, 2, eq. 3) and
//! `C₃ = e₃ˡ·u − Δ = 0` (eq. 4), which defines the relative displacement Δ. The discrete
//! gradient is eq. (8) with the mid values of eq. (9); its transpose gives the forces of
//! eq. (10). Identical orientations are the three clamp rows `e₂ᵏ·e₃ˡ = e₃ᵏ·e₁ˡ = e₁ᵏ·e₂ˡ = 0`.

use super::kinematics::*;
use super::stiffness::{self, Stiffness};
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::math::scalar::Real;

#[derive(Clone, Debug)]
pub struct Prismatic {
    /// Triads whose third unit vector is the sliding axis; Δ = 0 when the points coincide.
    pub at: [Attachment; 2],
}

/// Rows 0–2: the separation across and along the axis (Δ is coordinate `qi`).
pub fn slide_value<T: Real>(s: &JointState<T>, qi: usize, out: &mut [T]) {
    out[0] = projection_value(s, 0);
    out[1] = projection_value(s, 1);
    out[2] = projection_value(s, 2) - s.q[qi];
}

pub fn slide_gradient<T: Real>(
    si: &JointState<T>,
    sf: &JointState<T>,
    qi: usize,
    out: &mut Rows<T>,
) {
    for beta in 0..3 {
        projection_gradient(si, sf, beta, &mut out[beta]);
    }
    out[2][12 + qi] = -T::one();
}

pub fn slide_rate<T: Real>(s: &JointState<T>, qi: usize, out: &mut Rows<T>) {
    for beta in 0..3 {
        projection_rate(s, beta, &mut out[beta]);
    }
    out[2][12 + qi] = -T::one();
}

impl ConstraintLaw for Prismatic {
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
        slide_value(s, 0, out);
        orientation_value(s, &mut out[3..6]);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        slide_gradient(si, sf, 0, out);
        orientation_gradient(si, sf, out, 3);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        slide_rate(s, 0, out);
        orientation_rate(s, out, 3);
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut Stiffness,
    ) {
        stiffness::slide(si, sf, &lam[..3], k);
        stiffness::orientation(si, sf, &lam[3..6], k);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::law_tests::{assert_law, attachments};
    use crate::joints::MAX_COORDS;
    use crate::math::vec3::{M3, V3};

    #[test]
    fn discrete_gradient_exact_and_rate_consistent() {
        assert_law(&Prismatic { at: attachments() });
    }

    #[test]
    fn delta_is_the_separation_along_the_axis() {
        let at = [Attachment {
            offset: V3([0.0; 3]),
            triad: M3::identity(),
        }; 2];
        let s = JointState::new(
            [V3([1.0, 2.0, 3.0]), V3([1.0, 2.0, 3.7])],
            [M3::identity(); 2],
            [0.7; MAX_COORDS],
            &at,
        );
        let mut c = [1.0; 6];
        Prismatic { at }.value(&s, &mut c);
        assert!(c.iter().all(|v| v.abs() < 1e-15), "{c:?}");
    }
}

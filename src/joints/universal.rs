//! Universal joint: coincident points and `e₃ᵏ · e₃ˡ = 0` (eq. 11 with α = β = 3); the
//! attachment triads carry `axis1` and `axis2` as their third unit vectors. Discrete force:
//! eq. (16), `F = ±sλ_m h_m` with `h_m = ẽ_mᵏ e_mˡ`.

use super::kinematics::*;
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::scalar::Real;

#[derive(Clone, Debug)]
pub struct Universal {
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Universal {
    fn n_rows(&self) -> usize {
        4
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, &self.at, out);
        out[3] = dot_value(s, &self.at, 2, 2);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, &self.at, out, 0);
        let (hm, _) = dot_mid(si, sf, &self.at, 2, 2); // eq. (15)
        add_rotation_pair(&mut out[3], hm, T::one());
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, &self.at, out, 0);
        add_rotation_pair(&mut out[3], dot_h(s, &self.at, 2, 2), T::one());
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

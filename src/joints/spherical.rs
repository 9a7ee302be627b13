//! Spherical joint: the attachment points of both nodes coincide (3 constraints).

use super::kinematics::*;
use super::{Attachment, ConstraintLaw, JointState, Rows};
use crate::scalar::Real;

#[derive(Clone, Debug)]
pub struct Spherical {
    pub at: [Attachment; 2],
}

impl ConstraintLaw for Spherical {
    fn n_rows(&self) -> usize {
        3
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, &self.at, out);
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, &self.at, out, 0);
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, &self.at, out, 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::joints::law_tests::assert_law;
    use crate::rotation::exp_map;
    use crate::vec3::V3;

    #[test]
    fn discrete_gradient_exact_and_rate_consistent() {
        let at = [
            Attachment {
                offset: V3([0.3, -0.2, 0.5]),
                triad: exp_map(&V3([0.1, 0.2, 0.3])),
            },
            Attachment {
                offset: V3([-0.4, 0.1, 0.2]),
                triad: exp_map(&V3([0.0, -0.5, 0.3])),
            },
        ];
        assert_law(&Spherical { at });
    }
}

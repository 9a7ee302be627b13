//! Spherical joint: both sides share a point.

use super::{PairJoint, Placement};
use crate::joints::{spherical::Spherical, JointLaw};
use crate::math::vec3::M3;
use crate::model::{ModelError, SphericalJoint};

impl PairJoint for SphericalJoint {
    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        let p = at.point(self.position);
        Ok(JointLaw::Spherical(Spherical {
            at: at.both(p, M3::identity()),
        }))
    }
}

//! Clamp: the two sides move as one body, as placed at t = 0.

use super::{PairJoint, Placement};
use crate::joints::{clamp::Clamp, JointLaw};
use crate::math::vec3::M3;
use crate::model::{ClampJoint, ModelError};

impl PairJoint for ClampJoint {
    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        Ok(JointLaw::Clamp(Clamp {
            at: at.both(at.point(None), M3::identity()),
        }))
    }
}

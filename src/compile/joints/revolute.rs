//! Revolute joint: a shared axis; φ turns side 2 about it.

use super::{PairJoint, Placement};
use crate::joints::{revolute::Revolute, JointLaw};
use crate::model::check::Checker;
use crate::model::{ModelError, RevoluteJoint};

impl PairJoint for RevoluteJoint {
    fn check(&self, c: &mut Checker, p: &str) {
        c.unit(format!("{p}.axis"), &self.axis, "axis");
    }

    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        Ok(JointLaw::Revolute(Revolute {
            at: at.axial(self.axis, self.position, 0.0, at.initial[0]),
        }))
    }
}

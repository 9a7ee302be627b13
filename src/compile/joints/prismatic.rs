//! Prismatic joint: side 2 slides by Δ along the axis without turning.

use super::{PairJoint, Placement};
use crate::joints::{prismatic::Prismatic, JointLaw};
use crate::model::check::Checker;
use crate::model::{ModelError, PrismaticJoint};

impl PairJoint for PrismaticJoint {
    fn check(&self, c: &mut Checker, p: &str) {
        c.unit(format!("{p}.axis"), &self.axis, "axis");
    }

    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        Ok(JointLaw::Prismatic(Prismatic {
            at: at.axial(self.axis, self.position, at.initial[0], 0.0),
        }))
    }
}

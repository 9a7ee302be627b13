//! Cylindrical joint: side 2 slides by Δ along and turns by φ about the axis.

use super::{PairJoint, Placement};
use crate::joints::{cylindrical::Cylindrical, JointLaw};
use crate::model::check::Checker;
use crate::model::{CylindricalJoint, ModelError};

impl PairJoint for CylindricalJoint {
    fn check(&self, c: &mut Checker, p: &str) {
        c.unit(format!("{p}.axis"), &self.axis, "axis");
    }

    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        let [delta0, phi0] = at.initial;
        Ok(JointLaw::Cylindrical(Cylindrical {
            at: at.axial(self.axis, self.position, delta0, phi0),
        }))
    }
}

//! Screw joint: a cylindrical joint whose thread ties the slide to the turn, Δ = pitch·φ.

use super::{PairJoint, Placement};
use crate::joints::{cylindrical::Cylindrical, screw::Screw, JointLaw};
use crate::model::check::Checker;
use crate::model::{ModelError, ScrewJoint};

impl PairJoint for ScrewJoint {
    fn check(&self, c: &mut Checker, p: &str) {
        c.unit(format!("{p}.axis"), &self.axis, "axis");
        if !(self.pitch.is_finite() && self.pitch != 0.0) {
            c.err(
                format!("{p}.pitch"),
                format!(
                    "joint `{}`: the pitch must be a nonzero number of m/rad (got {})",
                    self.name, self.pitch
                ),
            );
        }
        if self.drive_delta.is_some() && self.drive_phi.is_some() {
            c.err(format!("{p}.drive_phi"), format!("joint `{}`: Δ and φ are tied by the thread (Δ = pitch·φ); prescribe only one of drive_delta and drive_phi", self.name));
        }
    }

    /// The one prescribed sets the other.
    fn initial(&self, [delta, phi]: [f64; 2]) -> [f64; 2] {
        if self.drive_phi.is_some() {
            [self.pitch * phi, phi]
        } else {
            [delta, delta / self.pitch]
        }
    }

    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        let [delta0, phi0] = at.initial;
        Ok(JointLaw::Screw(Screw {
            cylinder: Cylindrical {
                at: at.axial(self.axis, self.position, delta0, phi0),
            },
            pitch: self.pitch,
        }))
    }
}

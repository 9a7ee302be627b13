//! Universal joint: a shared point and two orthogonal axes, one on each side.

use super::{PairJoint, Placement};
use crate::joints::{universal::Universal, JointLaw};
use crate::math::vec3::{M3, V3};
use crate::model::check::{Checker, UNIT_TOL};
use crate::model::{ModelError, UniversalJoint};

impl PairJoint for UniversalJoint {
    fn check(&self, c: &mut Checker, p: &str) {
        c.unit(format!("{p}.axis1"), &self.axis1, "axis1");
        c.unit(format!("{p}.axis2"), &self.axis2, "axis2");
        let d: f64 = (0..3).map(|k| self.axis1[k] * self.axis2[k]).sum();
        if d.abs() > UNIT_TOL {
            c.err(
                format!("{p}.axis2"),
                format!(
                    "joint `{}`: axis1 and axis2 must be orthogonal (axis1·axis2 = {d:.3e})",
                    self.name
                ),
            );
        }
    }

    fn law(&self, at: &Placement) -> Result<JointLaw, ModelError> {
        if let Some(k) = at.initial.iter().position(|v| *v != 0.0) {
            return Err(at.error(
                &format!("drive{}", k + 1),
                format!("joint `{}`: a universal joint's drive must start at 0 (it gives {:.6} rad at t = 0); offset the function or turn the model to that angle", self.name, at.initial[k]),
            ));
        }
        let p = at.point(self.position);
        let (a1, a2) = (at.along(self.axis1), at.along(self.axis2));
        // e₁ᵏ = axis2 and e₁ˡ = axis1, so that φ1 = φ2 = 0 initially.
        let triad = |e3: V3<f64>, e1: V3<f64>| {
            let e3 = e3.scale_f(1.0 / e3.norm());
            let e1 = e1 - e3.scale_f(e1.dot(&e3));
            let e1 = e1.scale_f(1.0 / e1.norm());
            M3::from_cols(e1, e3.cross(&e1), e3)
        };
        Ok(JointLaw::Universal(Universal {
            at: [
                at.attach(0, p, triad(a1, a2)),
                at.attach(1, p, triad(a2, a1)),
            ],
        }))
    }
}

//! Rigid placements of model items: the frame a node gives (`frame: hub`) and the turn of a
//! pattern's copy move an item's geometry — its points, directions and triads — as one rigid
//! body. [`Pose`] is such a placement; [`Place`] moves one item by it.

use super::{Beam, InitialSpin, Joint, JointFrame, Load, Node, Orientation, Vec3};
use crate::math::default_axes::default_e2;
use crate::math::rotation::exp_map;
use crate::math::vec3::{M3, V3};

/// A rigid placement `x ↦ origin + rotation·x` (a frame's pose in the inertial frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Where the frame's origin is, m.
    pub origin: V3<f64>,
    /// The frame's triad: its columns are the frame's unit vectors.
    pub rotation: M3<f64>,
}

impl Pose {
    pub fn identity() -> Pose {
        Pose {
            origin: V3::zero(),
            rotation: M3::identity(),
        }
    }

    /// A turn by `angle` (rad, right-handed) about the unit `axis` through `center`.
    pub fn turn(center: Vec3, axis: Vec3, angle: f64) -> Pose {
        let a = V3(axis);
        let rotation = exp_map(&a.scale_f(angle / a.norm()));
        let c = V3(center);
        Pose {
            origin: c - rotation.mul_v(&c),
            rotation,
        }
    }

    /// The initial frame of a node: its position and triad.
    pub fn of_node(n: &Node) -> Pose {
        Pose {
            origin: V3(n.position),
            rotation: triad(&n.orientation),
        }
    }

    /// `self` after `inner`: first `inner`, then `self`.
    pub fn then(&self, inner: &Pose) -> Pose {
        Pose {
            origin: self.point_v(inner.origin),
            rotation: self.rotation.mul_m(&inner.rotation),
        }
    }

    /// The inverse placement.
    pub fn inverse(&self) -> Pose {
        let rotation = self.rotation.transpose();
        Pose {
            origin: V3::zero() - rotation.mul_v(&self.origin),
            rotation,
        }
    }

    fn point_v(&self, p: V3<f64>) -> V3<f64> {
        self.origin + self.rotation.mul_v(&p)
    }

    pub fn point(&self, p: Vec3) -> Vec3 {
        self.point_v(V3(p)).0
    }

    pub fn direction(&self, d: Vec3) -> Vec3 {
        self.rotation.mul_v(&V3(d)).0
    }

    /// A triad given relative to this frame, as an inertial orientation matrix.
    pub fn orientation(&self, o: &Orientation) -> Orientation {
        Orientation {
            matrix: Some(self.rotation.mul_m(&triad(o)).0),
            rotation_vector: None,
        }
    }

    fn is_identity(&self) -> bool {
        *self == Pose::identity()
    }
}

/// The triad an orientation gives (the identity when it gives none).
pub fn triad(o: &Orientation) -> M3<f64> {
    match (o.matrix, o.rotation_vector) {
        (Some(m), _) => M3(m),
        (None, Some(v)) => exp_map(&V3(v)),
        (None, None) => M3::identity(),
    }
}

/// An item whose geometry can be placed rigidly.
pub trait Place {
    /// Moves the item's geometry by `pose`: points, directions and triads given in the frame
    /// `pose` places become inertial.
    fn place(&mut self, pose: &Pose);
}

fn place_opt(v: &mut Option<Vec3>, f: impl Fn(Vec3) -> Vec3) {
    if let Some(x) = v {
        *x = f(*x);
    }
}

impl Place for Node {
    fn place(&mut self, pose: &Pose) {
        self.position = pose.point(self.position);
        if !pose.is_identity() {
            self.orientation = pose.orientation(&self.orientation);
        }
        place_opt(&mut self.velocity, |v| pose.direction(v));
        place_opt(&mut self.angular_velocity, |v| pose.direction(v));
    }
}

impl Beam {
    /// The beam's direction at its start, given its end points (`end_points`).
    pub fn start_tangent(&self, start: Vec3, end: Vec3) -> Vec3 {
        let (a, b) = (V3(start), V3(end));
        match (&self.arc, self.via.first()) {
            (Some(arc), _) => {
                V3(arc.axis)
                    .cross(&(a - V3(arc.center)))
                    .scale_f(arc.angle.signum())
                    .0
            }
            (None, Some(p)) => (V3(*p) - a).0,
            (None, None) => (b - a).0,
        }
    }

    /// Places the beam; `tangent`, its start direction before the placement (if known), fixes
    /// the default section axis 2 where the beam gives none, so that it is placed with the
    /// beam (the default rule is not invariant under turns about a non-vertical axis).
    pub fn place_with(&mut self, pose: &Pose, tangent: Option<Vec3>) {
        if self.e2.is_none() {
            self.e2 = tangent.map(|t| {
                let e2 = default_e2(V3(t));
                e2.scale_f(1.0 / e2.norm().max(1e-300)).0
            });
        }
        place_opt(&mut self.start, |p| pose.point(p));
        place_opt(&mut self.end, |p| pose.point(p));
        for p in &mut self.via {
            *p = pose.point(*p);
        }
        if let Some(arc) = &mut self.arc {
            arc.center = pose.point(arc.center);
            arc.axis = pose.direction(arc.axis);
        }
        place_opt(&mut self.e2, |d| pose.direction(d));
        place_opt(&mut self.velocity, |v| pose.direction(v));
        place_opt(&mut self.angular_velocity, |v| pose.direction(v));
    }
}

impl Joint {
    /// Places an inertially given joint: its position and axes.
    pub fn place(&mut self, pose: &Pose) {
        let dir = |d: &mut Vec3| *d = pose.direction(*d);
        let (position, axes): (&mut Option<Vec3>, Vec<&mut Vec3>) = match self {
            Joint::Spherical(j) => (&mut j.position, vec![]),
            Joint::Revolute(j) => (&mut j.position, vec![&mut j.axis]),
            Joint::Universal(j) => (&mut j.position, vec![&mut j.axis1, &mut j.axis2]),
            Joint::Prismatic(j) => (&mut j.position, vec![&mut j.axis]),
            Joint::Cylindrical(j) => (&mut j.position, vec![&mut j.axis]),
            Joint::Screw(j) => (&mut j.position, vec![&mut j.axis]),
            Joint::Clamp(_)
            | Joint::Sliding(_)
            | Joint::SlidingScrew(_)
            | Joint::SlidingClamp(_) => return,
        };
        place_opt(position, |p| pose.point(p));
        axes.into_iter().for_each(dir);
    }

    /// Gives the joint's geometry in the inertial frame instead of its `frame` node's, whose
    /// initial frame is `node_frame`.
    pub fn to_inertial(&mut self, node_frame: &Pose) {
        if self.frame() != JointFrame::Inertial {
            self.place(node_frame);
            self.set_frame(JointFrame::Inertial);
        }
    }

    fn set_frame(&mut self, f: JointFrame) {
        match self {
            Joint::Spherical(j) => j.frame = f,
            Joint::Revolute(j) => j.frame = f,
            Joint::Universal(j) => j.frame = f,
            Joint::Prismatic(j) => j.frame = f,
            Joint::Cylindrical(j) => j.frame = f,
            Joint::Screw(j) => j.frame = f,
            Joint::Clamp(_)
            | Joint::Sliding(_)
            | Joint::SlidingScrew(_)
            | Joint::SlidingClamp(_) => {}
        }
    }
}

impl Place for Load {
    /// A dead load's vector turns with its copy; a follower load is given in its node's (or
    /// section's) frame and turns with that.
    fn place(&mut self, pose: &Pose) {
        let (value, follower) = match self {
            Load::Force(l) | Load::Moment(l) => (&mut l.value, l.follower),
            Load::DistributedForce(l) | Load::DistributedMoment(l) => (&mut l.value, l.follower),
        };
        if !follower {
            *value = pose.direction(*value);
        }
    }
}

impl Place for InitialSpin {
    fn place(&mut self, pose: &Pose) {
        self.axis = pose.direction(self.axis);
        self.center = pose.point(self.center);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (V3(a) - V3(b)).norm() < 1e-12
    }

    #[test]
    fn a_turn_keeps_its_axis_and_moves_points_about_it() {
        let p = Pose::turn(
            [1.0, 2.0, 0.0],
            [0.0, 0.0, 1.0],
            std::f64::consts::FRAC_PI_2,
        );
        assert!(close(p.point([1.0, 2.0, 5.0]), [1.0, 2.0, 5.0]));
        assert!(close(p.point([2.0, 2.0, 0.0]), [1.0, 3.0, 0.0]));
        assert!(close(p.direction([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        let q = p.then(&p.inverse());
        assert!(close(q.point([3.0, -1.0, 2.0]), [3.0, -1.0, 2.0]));
    }
}

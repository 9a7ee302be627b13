//! Newton's starting guess for a node's increments over a step: the part of its velocity
//! across its angular velocity turning with it, `v⊥(t) = Q(ωt) v⊥`, the part along it constant
//! — the exact motion of a point of a body in steady rotation (or screw motion) about a fixed
//! axis, and constant velocity for a node that does not turn. (A body that also translates
//! across its spin axis, a rotor in forward flight, is guessed as turning about a shifted
//! axis: an error of the order of the constant-velocity guess's in that translation.) A plain
//! constant-velocity guess puts a point turning at Ω on its tangent, ½Ω²ρh² off its circle:
//! 0.2 m at a 5 m blade tip at 20 rad/s with 15 ms steps — far enough that Newton's first
//! iterates stretch the blades by percents and overshoot the sliding joints.

use crate::math::vec3::{M3, V3};

/// Predicted `(Δx, r)` over `h` for a node at orientation `rm` with velocity `v` and material
/// angular velocity `w`: Δx = h v∥ + (sin θ/|ω|) v⊥ + ((1 − cos θ)/|ω|²) ω×v with ω = R W,
/// θ = |ω|h, v∥ the part of v along ω; and r the Cayley parameter of the turn Wh,
/// 2 tan(θ/2) Ŵ.
pub fn turning_increment(rm: &M3<f64>, v: V3<f64>, w: V3<f64>, h: f64) -> (V3<f64>, V3<f64>) {
    let omega = rm.mul_v(&w);
    let rate = omega.norm();
    let theta = rate * h;
    if theta < 1e-6 {
        // Series of the same expressions (relative error < θ²/12 ≈ 1e-13).
        return (
            v.scale_f(h) + omega.cross(&v).scale_f(0.5 * h * h),
            w.scale_f(h),
        );
    }
    // A guess, not a step: a turn of more than ~170° per step is capped below the Cayley
    // map's singularity at 180°.
    let theta = theta.min(3.0);
    let along = omega.scale_f(omega.dot(&v) / (rate * rate));
    let across = v - along;
    let dx = along.scale_f(h)
        + across.scale_f(theta.sin() / rate)
        + omega.cross(&v).scale_f((1.0 - theta.cos()) / (rate * rate));
    let r = w.scale_f(2.0 * (0.5 * theta).tan() / rate);
    (dx, r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotation::{cayley, exp_map};

    #[test]
    fn a_node_in_steady_rotation_is_predicted_exactly() {
        // A node at ρ = 5 m from an axis through c, turning with the body at Ω about n̂:
        // after h it is at c + Q(Ωh)(x − c) with triad Q(Ωh) R.
        let (omega, h) = (V3([0.3, -0.4, 20.0]), 0.015);
        let c = V3([0.2, 0.1, -0.3]);
        let x = V3([5.0, 1.0, 0.7]);
        let rm = exp_map(&V3([0.4, -0.2, 0.9]));
        let v = omega.cross(&(x - c));
        let w = rm.tmul_v(&omega);
        let (dx, r) = turning_increment(&rm, v, w, h);
        let q = exp_map(&omega.scale_f(h));
        let x_end = c + q.mul_v(&(x - c));
        assert!((x + dx - x_end).norm() < 1e-12, "{:?}", x + dx - x_end);
        let r_end = q.mul_m(&rm);
        let r_pred = rm.mul_m(&cayley(&r));
        assert!((r_pred - r_end).max_abs() < 1e-12);
        // The constant-velocity guess misses by ½Ω²ρh².
        assert!((x + v.scale_f(h) - x_end).norm() > 0.2);
        // Screw motion: the same turn plus a slide of 3 m/s along the axis.
        let slide = omega.scale_f(3.0 / omega.norm());
        let (dx, _) = turning_increment(&rm, v + slide, w, h);
        let miss = x + dx - (x_end + slide.scale_f(h));
        assert!(miss.norm() < 1e-12, "{miss:?}");
    }

    #[test]
    fn a_node_that_does_not_turn_keeps_its_velocity() {
        let rm = exp_map(&V3([0.4, -0.2, 0.9]));
        let (dx, r) = turning_increment(&rm, V3([1.0, 2.0, 3.0]), V3::zero(), 0.1);
        assert_eq!(dx.0, [0.1, 0.2, 0.30000000000000004]);
        assert_eq!(r.0, [0.0; 3]);
    }
}

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
use crate::state::State;

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

/// The motion's second derivatives over the last converged steps, for a second-order guess
/// of the next: per node the acceleration the steady turn does not explain (inertial; the
/// finite difference `(v_f − v_i)/h` less `ω × v` at mid-step, so a steady spin adds
/// nothing to [`turning_increment`]'s exact turn) and the material angular acceleration
/// `(W_f − W_i)/h`; per joint coordinate its acceleration; per constraint row the rate of
/// its multiplier.
///
/// Two slots: the step that produced the state a step starts from, and the one before — a
/// step rejected by the error controller is retried, smaller, from the same start, whose
/// trend is then still at hand. A slot applies only to the state its step ended in, bit for
/// bit (time, velocities, rates): a state changed between steps (velocity projection, a
/// stick–slip event, a restart) gets the first-order guess.
#[derive(Default)]
pub struct Trend {
    slots: [Slot; 2],
}

#[derive(Default)]
struct Slot {
    valid: bool,
    t_end: f64,
    end_rates: Vec<[V3<f64>; 2]>,
    end_coord_rates: Vec<f64>,
    accel: Vec<[V3<f64>; 2]>,
    coord_accel: Vec<f64>,
    lambda_rate: Vec<f64>,
}

/// The second-order terms of a step of size `h` from a state: `½h² a` on each node's
/// increment and `½h² Ẇ` on its Cayley parameters, `½h² q̈` on each coordinate's, `h λ̇` on
/// each multiplier.
pub struct Curvature<'a> {
    pub accel: &'a [[V3<f64>; 2]],
    pub coord_accel: &'a [f64],
    pub lambda_rate: &'a [f64],
}

impl Slot {
    fn ends_in(&self, state: &State) -> bool {
        self.valid
            && self.t_end == state.t
            && self.end_coord_rates == state.coord_rates
            && self.end_rates.len() == state.nodes.len()
            && self
                .end_rates
                .iter()
                .zip(&state.nodes)
                .all(|(e, n)| e[0] == n.v && e[1] == n.w)
    }

    fn record(&mut self, start: &State, end: &State, h: f64) {
        self.valid = true;
        self.t_end = end.t;
        self.end_rates.clear();
        self.end_rates.extend(end.nodes.iter().map(|n| [n.v, n.w]));
        self.end_coord_rates.clear();
        self.end_coord_rates.extend_from_slice(&end.coord_rates);
        self.accel.clear();
        self.accel
            .extend(start.nodes.iter().zip(&end.nodes).map(|(i, f)| {
                let omega = (i.omega() + f.omega()).scale_f(0.5);
                let v = (i.v + f.v).scale_f(0.5);
                let a = (f.v - i.v).scale_f(1.0 / h) - omega.cross(&v);
                [a, (f.w - i.w).scale_f(1.0 / h)]
            }));
        let rate = |i: &[f64], f: &[f64], out: &mut Vec<f64>| {
            out.clear();
            out.extend(i.iter().zip(f).map(|(a, b)| (b - a) / h));
        };
        rate(&start.coord_rates, &end.coord_rates, &mut self.coord_accel);
        let same_rows = start.lambda.len() == end.lambda.len();
        rate(
            if same_rows {
                &start.lambda
            } else {
                &end.lambda
            },
            &end.lambda,
            &mut self.lambda_rate,
        );
    }
}

impl Trend {
    /// The step from `start` to `end` (of size `h`) converged: its trend replaces the slot of
    /// a step that did not lead to `start` (one the error controller rejected).
    pub fn record(&mut self, start: &State, end: &State, h: f64) {
        if self.slots[0].ends_in(start) {
            self.slots.swap(0, 1);
        }
        self.slots[0].record(start, end, h);
    }

    /// The trend of the step that ended in `state`, if one did.
    pub fn at(&self, state: &State) -> Option<Curvature<'_>> {
        self.slots
            .iter()
            .find(|s| s.ends_in(state))
            .map(|s| Curvature {
                accel: &s.accel,
                coord_accel: &s.coord_accel,
                lambda_rate: &s.lambda_rate,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rotation::{cayley, exp_map};
    use crate::state::NodeState;

    fn state(t: f64, v: V3<f64>, w: V3<f64>, rate: f64, lambda: f64) -> State {
        let node = NodeState {
            x: V3::zero(),
            r: exp_map(&V3([0.3, 0.2, -0.1])),
            v,
            w,
        };
        State {
            t,
            coords: vec![0.0],
            coord_rates: vec![rate],
            lambda: vec![lambda],
            ..State::of_nodes(vec![node])
        }
    }

    #[test]
    fn a_steady_trend_is_extrapolated_and_a_steady_spin_adds_nothing() {
        // Constant acceleration a, no turn: (v_f − v_i)/h is a; coordinate and multiplier
        // rates likewise.
        let (h, a) = (0.01, V3([0.0, 0.0, -9.81]));
        let start = state(0.0, V3([1.0, 2.0, 3.0]), V3::zero(), 0.5, 10.0);
        let end = state(
            h,
            start.nodes[0].v + a.scale_f(h),
            V3::zero(),
            0.5 + 2.0 * h,
            10.0 + 30.0 * h,
        );
        let mut trend = Trend::default();
        trend.record(&start, &end, h);
        let c = trend.at(&end).expect("the step's own end");
        assert!((c.accel[0][0] - a).norm() < 1e-12);
        assert!((c.coord_accel[0] - 2.0).abs() < 1e-12 && (c.lambda_rate[0] - 30.0).abs() < 1e-9);
        // A point turning at Ω with its body (v = ω × ρ): the finite difference is the
        // centripetal ω × v at mid-step, which the turning guess already has.
        let rm = exp_map(&V3([0.3, 0.2, -0.1]));
        let (omega, rho) = (V3([0.0, 0.0, 20.0]), V3([2.0, 0.5, 0.0]));
        let w = rm.tmul_v(&omega);
        let turned = exp_map(&omega.scale_f(h)).mul_v(&rho);
        let spin_i = state(0.0, omega.cross(&rho), w, 0.0, 0.0);
        let spin_f = state(h, omega.cross(&turned), w, 0.0, 0.0);
        trend.record(&spin_i, &spin_f, h);
        let c = trend.at(&spin_f).unwrap();
        // O((Ωh)²) of the centripetal 8e2 m/s²: the guess's ½h² term is then ~1e-6 of Ωρh.
        assert!(c.accel[0][0].norm() < 1e-2 * omega.cross(&omega.cross(&rho)).norm());
        assert_eq!(c.accel[0][1].0, [0.0; 3]);
    }

    #[test]
    fn a_trend_applies_only_to_the_state_its_step_ended_in() {
        let h = 0.01;
        let s0 = state(0.0, V3([1.0, 0.0, 0.0]), V3::zero(), 0.0, 0.0);
        let s1 = state(h, V3([1.1, 0.0, 0.0]), V3::zero(), 0.0, 0.0);
        let mut trend = Trend::default();
        assert!(trend.at(&s0).is_none());
        trend.record(&s0, &s1, h);
        // A state changed after the step (a velocity projected, an event): first order.
        let mut moved = s1.clone();
        moved.nodes[0].v.0[1] = 1e-15;
        assert!(trend.at(&moved).is_none());
        // A step from s1 the error controller rejected; its retry from s1 still has s1's
        // trend, and the accepted retry's end has its own.
        let rejected = state(3.0 * h, V3([5.0, 0.0, 0.0]), V3::zero(), 0.0, 0.0);
        trend.record(&s1, &rejected, 2.0 * h);
        assert!((trend.at(&s1).unwrap().accel[0][0].0[0] - 10.0).abs() < 1e-9);
        let s2 = state(2.0 * h, V3([1.2, 0.0, 0.0]), V3::zero(), 0.0, 0.0);
        trend.record(&s1, &s2, h);
        assert!((trend.at(&s2).unwrap().accel[0][0].0[0] - 10.0).abs() < 1e-9);
        assert!(trend.at(&rejected).is_none() && trend.at(&s1).is_some());
    }

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

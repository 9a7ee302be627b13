//! Placing a sliding joint: where the contact point starts, how the follower is attached to
//! it, and the user's η-quantities (drive, spring) brought to the element coordinate ζ.

use crate::beam::path::{ArcMap, BeamPath};
use crate::elements::coordinate::SpringLaw;
use crate::joints::sliding::{orthonormal_frame, SlidingKind};
use crate::joints::Attachment;
use crate::math::vec3::{M3, V3};
use crate::model::SpringDamper;
use crate::state::NodeState;
use crate::system::BeamInfo;

/// The beam point `P(ζ)` and its section frame (interpolated directors made orthonormal) in
/// the initial configuration.
pub fn beam_point(
    path: &BeamPath,
    info: &BeamInfo,
    nodes: &[NodeState],
    zeta: f64,
) -> (V3<f64>, M3<f64>) {
    let w = path.weights(zeta);
    let (mut p, mut d1, mut d2) = (V3::zero(), V3::zero(), V3::zero());
    for (n, h) in w.iter() {
        let node = &nodes[info.nodes[n]];
        p += node.x.scale_f(h);
        d1 += node.r.col(0).scale_f(h);
        d2 += node.r.col(1).scale_f(h);
    }
    (p, orthonormal_frame(d1, d2))
}

/// The element coordinate of the beam point closest to `x`: the best of a sampling of every
/// element, refined by Newton's method on `(P − x)·P′ = 0`.
pub fn closest_point(path: &BeamPath, info: &BeamInfo, nodes: &[NodeState], x: V3<f64>) -> f64 {
    let at = |z: f64| {
        let w = path.weights(z);
        let dw = path.tangent_weights(z, path.all());
        let (mut p, mut dp) = (V3::zero(), V3::zero());
        for (n, h) in w.iter() {
            p += nodes[info.nodes[n]].x.scale_f(h);
        }
        for (n, h) in dw.iter() {
            dp += nodes[info.nodes[n]].x.scale_f(h);
        }
        (p, dp)
    };
    let samples = 16 * path.elements;
    let mut best = 0.0;
    let mut best_d = f64::INFINITY;
    for k in 0..=samples {
        let z = path.elements as f64 * k as f64 / samples as f64;
        let d = (at(z).0 - x).norm();
        if d < best_d {
            best_d = d;
            best = z;
        }
    }
    // Gauss–Newton on the distance (enough near the sampled minimum).
    let mut z = best;
    for _ in 0..20 {
        let (p, dp) = at(z);
        let step = (p - x).dot(&dp) / dp.norm_sq();
        z = (z - step).clamp(0.0, path.elements as f64);
        if step.abs() < 1e-14 {
            break;
        }
    }
    z
}

/// The follower's joint triad (in its node's triad) such that the sliding joint's orientation
/// rows hold in the initial configuration: the section frame E at the contact point for the
/// screw row `d₂·e₃ˡ = 0` (E₃ ⊥ d₁, d₂), and for the sliding clamp the rotation of E that also
/// zeroes `d₃·e₁ˡ` and `d₁·e₂ˡ` with the interpolated (not quite orthonormal) directors.
pub fn follower_triad(
    kind: SlidingKind,
    path: &BeamPath,
    info: &BeamInfo,
    nodes: &[NodeState],
    zeta: f64,
) -> M3<f64> {
    let (_, mut e) = beam_point(path, info, nodes, zeta);
    if kind != SlidingKind::Clamp {
        return e;
    }
    let w = path.weights(zeta);
    let mut d = [V3::zero(); 3];
    for (n, h) in w.iter() {
        for (k, dk) in d.iter_mut().enumerate() {
            *dk += nodes[info.nodes[n]].r.col(k).scale_f(h);
        }
    }
    // Rows f = [d₂·E₃, d₃·E₁, d₁·E₂]; under E → exp(θ̃)E, δ(d_a·E_b) = θ·(E_b × d_a).
    const PAIRS: [(usize, usize); 3] = [(1, 2), (2, 0), (0, 1)];
    for _ in 0..20 {
        let mut f = V3::zero();
        let mut jac = M3::zero();
        for (r, (a, b)) in PAIRS.iter().enumerate() {
            f.0[r] = d[*a].dot(&e.col(*b));
            let g = e.col(*b).cross(&d[*a]);
            jac.0[r] = g.0;
        }
        if f.max_abs() < 1e-15 {
            break;
        }
        let theta = jac.inverse().mul_v(&f).scale_f(-1.0);
        e = crate::math::rotation::exp_map(&theta).mul_m(&e);
    }
    e
}

/// The follower's attachment: its contact point and joint triad in its node's triad.
pub fn follower_attachment(node: (V3<f64>, M3<f64>), point: V3<f64>, triad: M3<f64>) -> Attachment {
    Attachment {
        offset: node.1.tmul_v(&(point - node.0)),
        triad: node.1.transpose().mul_m(&triad),
    }
}

/// A spring along the beam (N/m, N·s/m, rest η; or a table of force in N against η) as a law
/// and damping on ζ: with `s = ζ L/N_e` on a uniform mesh, `V(s)` becomes `V(ζ L/N_e)`.
pub fn spring_on_zeta(
    spring: &SpringDamper,
    map: &ArcMap,
    length: f64,
) -> Result<(SpringLaw, f64), String> {
    if !map.is_uniform() {
        return Err("a spring along a beam needs the beam meshed into equal elements (its corners split it unevenly); give the beam a uniform mesh or drive η instead".into());
    }
    let n = map.elements() as f64;
    let ds = length / n; // m per unit ζ
    let law = match &spring.table {
        Some(t) => SpringLaw::table(
            t.at.iter().map(|eta| eta * n).collect(),
            t.force.iter().map(|f| f * ds).collect(),
        ),
        None => SpringLaw::Linear {
            stiffness: spring.stiffness * ds * ds,
            rest: spring.rest * n,
        },
    };
    Ok((law, spring.damping * ds * ds))
}

/// Elastic end stops as a spring on ζ: no force on the beam, `k (s − s_end)` past an end, with
/// `s` measured along the end element (`k_ζ = k ds²`, ds the end element's length per unit ζ).
pub fn end_stops_on_zeta(stiffness: f64, info: &BeamInfo) -> SpringLaw {
    let n = info.count as f64;
    let first = info.spans[0].1 - info.spans[0].0;
    let last = info.spans[info.count - 1].1 - info.spans[info.count - 1].0;
    SpringLaw::table(
        vec![-1.0, 0.0, n, n + 1.0],
        vec![
            -stiffness * first * first,
            0.0,
            0.0,
            stiffness * last * last,
        ],
    )
}

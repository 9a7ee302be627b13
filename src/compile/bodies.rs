//! Rigid bodies: their checks, and their mass on the node table. A body (or a beam node)
//! whose centre of mass is offset from its node gets an internal centre-of-mass node clamped
//! to the carrier, so that every node's inertia is about its own position.

use super::nodes::NodeTable;
use crate::math::vec3::{M3, V3};
use crate::model::check::{Checker, NodeNames};
use crate::model::{Mat3, Model};

/// A mass moved to an internal node `cm`, clamped to its carrier `node` at `offset`
/// (carrier triad).
pub struct CmLink {
    /// The owner's name (a body, or the beam node).
    pub owner: String,
    pub node: usize,
    pub cm: usize,
    pub offset: V3<f64>,
}

/// Cholesky test of a symmetric 3×3 matrix.
fn is_spd(m: &Mat3) -> bool {
    let a = m[0][0];
    if a <= 0.0 {
        return false;
    }
    let l10 = m[1][0] / a.sqrt();
    let d1 = m[1][1] - l10 * l10;
    if d1 <= 0.0 {
        return false;
    }
    let l20 = m[2][0] / a.sqrt();
    let l21 = (m[2][1] - l20 * l10) / d1.sqrt();
    m[2][2] - l20 * l20 - l21 * l21 > 0.0
}

/// Checks each body's node, mass, inertia and centre-of-mass offset.
pub fn check(model: &Model, names: &NodeNames, c: &mut Checker) {
    for (i, b) in model.bodies.iter().enumerate() {
        let p = format!("bodies[{i}]");
        names.check(c, format!("{p}.node"), &b.node, false);
        if !(b.mass.is_finite() && b.mass > 0.0) {
            c.err(
                format!("{p}.mass"),
                format!("body `{}`: mass must be positive (got {})", b.name, b.mass),
            );
        }
        let m = b.inertia.matrix();
        let finite = m.iter().flatten().all(|x| x.is_finite());
        let scale = m.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
        let sym = (0..3).all(|r| (0..3).all(|s| (m[r][s] - m[s][r]).abs() <= 1e-9 * scale));
        if !finite || !sym {
            c.err(
                format!("{p}.inertia"),
                format!(
                    "body `{}`: inertia must be a symmetric matrix of finite numbers",
                    b.name
                ),
            );
        } else if !is_spd(&m) {
            c.err(
                format!("{p}.inertia"),
                format!(
                    "body `{}`: inertia must be positive definite (all principal moments > 0)",
                    b.name
                ),
            );
        }
        c.vec3(format!("{p}.cm_offset"), &b.cm_offset);
    }
}

/// Adds each body's mass to its node, or to a new centre-of-mass node if offset.
pub fn add(model: &Model, table: &mut NodeTable) -> Vec<CmLink> {
    let mut links = Vec::new();
    for b in &model.bodies {
        let a = table.index(&b.node);
        let c = V3(b.cm_offset);
        let j = M3(b.inertia.matrix());
        let at = if c.max_abs() == 0.0 {
            a
        } else {
            let cm = table.push_carried(format!("{}.cm", b.name), a, c);
            links.push(CmLink {
                owner: b.name.clone(),
                node: a,
                cm,
                offset: c,
            });
            cm
        };
        table.lumped.mass[at] += b.mass;
        table.lumped.inertia[at] = table.lumped.inertia[at] + j;
    }
    links
}

/// Beam nodes whose sections' centres of mass are offset: all of the node's mass moves to
/// its combined centre of mass, with the inertia about it (parallel axes).
pub fn centre_offset_masses(table: &mut NodeTable, links: &mut Vec<CmLink>) {
    let scale = table.length_scale(); // once: per node it made compiling quadratic
    for a in 0..table.states.len() {
        let (m, s1) = (table.lumped.mass[a], table.lumped.first_moment[a]);
        if m <= 0.0 || s1.norm() <= 1e-12 * m * scale {
            continue;
        }
        let c = s1.scale_f(1.0 / m);
        let j = table.lumped.inertia[a];
        let j_cm = j - (M3::identity().scale_f(c.norm_sq()) - c.outer(&c)).scale_f(m);
        let owner = table.names[a].clone();
        let cm = table.push_carried(format!("{owner}.cm"), a, c);
        table.lumped.mass[cm] = m;
        table.lumped.inertia[cm] = j_cm;
        table.lumped.mass[a] = 0.0;
        table.lumped.inertia[a] = M3::zero();
        links.push(CmLink {
            owner,
            node: a,
            cm,
            offset: c,
        });
    }
}

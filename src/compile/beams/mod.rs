//! Beams: their checks (ends, mesh, sections, pre-twist, line geometry), their reference line
//! and sections in the physics' terms, and their meshing into nodes and elements.

mod mesh;

pub use mesh::BeamMesh;

use super::nodes::NodeTable;
use crate::beam::element::BeamElement;
use crate::beam::geometry::{LinePath, Pretwist, ReferenceLine};
use crate::beam::section::{Section, SectionProperties};
use crate::math::layout::Layout;
use crate::math::vec3::{M3, V3};
use crate::model::check::Checker;
use crate::model::{Beam, MaterialShape, Model, SectionSpec, ShapeSpec, Shorthand};
use crate::system::{BeamInfo, BeamNodeInertia};

/// The physics' section of a model section.
pub fn section_of(spec: &SectionSpec) -> Result<Section, String> {
    match spec {
        SectionSpec::Shorthand(s) => Section::from_properties(&properties(s)),
        SectionSpec::Matrices(m) => Section::from_matrices(m.stiffness, m.mass),
        SectionSpec::MaterialShape(ms) => Section::from_properties(&material_shape(ms)?),
    }
}

/// The engineering properties of a material and shape (checked).
pub fn material_shape(ms: &MaterialShape) -> Result<SectionProperties, String> {
    use crate::beam::section_shapes::{properties, Material, Shape};
    let m = &ms.material;
    let g = m.shear_modulus()?;
    if ![m.e, g, m.density]
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
    {
        return Err("material: E, G (Pa) and density (kg/m³) must be finite and > 0".into());
    }
    let shape = match ms.shape {
        ShapeSpec::Rectangle { width, height } => Shape::Rectangle { width, height },
        ShapeSpec::Circle { diameter } => Shape::Circle { diameter },
        ShapeSpec::Tube { diameter, wall } => Shape::Tube { diameter, wall },
        ShapeSpec::Box {
            width,
            height,
            wall,
        } => Shape::Box {
            width,
            height,
            wall,
        },
        ShapeSpec::IBeam {
            width,
            height,
            flange,
            web,
        } => Shape::IBeam {
            width,
            height,
            flange,
            web,
        },
    };
    shape.check().map_err(|e| format!("shape: {e}"))?;
    let material = Material {
        e: m.e,
        g,
        rho: m.density,
    };
    Ok(properties(&material, &shape))
}

fn properties(s: &Shorthand) -> SectionProperties {
    SectionProperties {
        ea: s.ea,
        ga2: s.ga2,
        ga3: s.ga3,
        gj: s.gj,
        ei2: s.ei2,
        ei3: s.ei3,
        m: s.m,
        i22: s.i22,
        i33: s.i33,
        i23: s.i23,
        cm_offset: s.cm_offset,
        tension_center: s.tension_center,
        shear_center: s.shear_center,
    }
}

/// The reference line of beam `b` from `start` to `end` (its end points resolved).
pub fn reference_line(b: &Beam, start: V3<f64>, end: V3<f64>) -> Result<ReferenceLine, String> {
    let path = match &b.arc {
        Some(arc) => LinePath::Arc {
            start,
            end,
            center: V3(arc.center),
            axis: V3(arc.axis),
            angle: arc.angle,
        },
        None => {
            let mut pts = vec![start];
            pts.extend(b.via.iter().map(|p| V3(*p)));
            pts.push(end);
            LinePath::Polyline(pts)
        }
    };
    let twist = match &b.twist {
        Some(t) => Pretwist::Table {
            eta: t.eta.clone(),
            angle: t.angle.clone(),
        },
        None => Pretwist::Rate(b.twist_rate),
    };
    ReferenceLine::new(&path, b.e2.map(V3), &twist)
}

/// Reference length along the beam's line, if its end points are known and its line valid.
pub fn length(b: &Beam, model: &Model) -> Option<f64> {
    let (a, e) = b.end_points(model)?;
    Some(reference_line(b, V3(a), V3(e)).ok()?.length())
}

/// Stations along a span: at least two, strictly increasing from 0 to 1.
fn stations(eta: &[f64]) -> Result<(), String> {
    if eta.len() < 2 {
        return Err("need at least two entries (eta = 0 and eta = 1)".into());
    }
    if eta[0] != 0.0 || eta[eta.len() - 1] != 1.0 {
        return Err(format!(
            "must start at eta = 0 and end at eta = 1 (got {} … {})",
            eta[0],
            eta[eta.len() - 1]
        ));
    }
    if !eta.windows(2).all(|w| w[1] > w[0]) {
        return Err("must increase strictly".into());
    }
    Ok(())
}

/// Checks every beam.
pub fn check(model: &Model, c: &mut Checker) {
    for (i, b) in model.beams.iter().enumerate() {
        let p = format!("beams[{i}]");
        check_ends(model, b, c, &p);
        check_mesh(b, c, &p);
        check_sections(b, c, &p);
        check_damping(b, c, &p);
        check_line(b, c, &p);
        // The line itself (arc in its plane and reaching the end, no folds, no repeated
        // points), once its end points are known.
        if let Some((a, e)) = b.end_points(model) {
            if let Err(msg) = reference_line(b, V3(a), V3(e)) {
                c.err(p.clone(), format!("beam `{}`: {msg}", b.name));
            }
        }
    }
}

/// Each end given once: a point or an existing node (an arc's end follows from its start).
fn check_ends(model: &Model, b: &Beam, c: &mut Checker, p: &str) {
    let name = &b.name;
    for (field, point, node) in [
        ("start", &b.start, &b.start_node),
        ("end", &b.end, &b.end_node),
    ] {
        match (point, node) {
            (Some(_), Some(_)) => c.err(
                format!("{p}.{field}"),
                format!("beam `{name}`: give only one of `{field}` and `{field}_node`"),
            ),
            (None, None) if field == "end" && b.arc.is_some() => {}
            (None, None) => c.err(
                format!("{p}.{field}"),
                format!("beam `{name}`: give exactly one of `{field}` and `{field}_node`"),
            ),
            (Some(v), None) => c.vec3(format!("{p}.{field}"), v),
            (None, Some(n)) => {
                if !model.nodes.iter().any(|x| &x.name == n) {
                    c.err(
                        format!("{p}.{field}_node"),
                        format!("refers to node `{n}`, which is not defined in `nodes` (a beam's ends can be nodes of `nodes`, which other beams may share, not another beam's own nodes)"),
                    );
                }
            }
        }
    }
}

fn check_mesh(b: &Beam, c: &mut Checker, p: &str) {
    let name = &b.name;
    if b.elements == 0 {
        c.err(
            format!("{p}.elements"),
            format!("beam `{name}`: needs at least one element"),
        );
    }
    if !(1..=3).contains(&b.order) {
        c.err(
            format!("{p}.order"),
            format!(
                "beam `{name}`: order must be 1 (linear), 2 (quadratic) or 3 (cubic), got {}",
                b.order
            ),
        );
    }
    if b.elements > 0 && b.elements < b.via.len() + 1 {
        c.err(
            format!("{p}.elements"),
            format!(
                "beam `{name}`: a polyline of {} segments needs at least one element per segment",
                b.via.len() + 1
            ),
        );
    }
    for (field, v) in [
        ("velocity", &b.velocity),
        ("angular_velocity", &b.angular_velocity),
    ] {
        if let Some(v) = v {
            c.vec3(format!("{p}.{field}"), v);
        }
    }
}

/// One uniform `section` or stations of `sections`, each admissible and lumpable.
fn check_sections(b: &Beam, c: &mut Checker, p: &str) {
    let name = &b.name;
    let check_section = |c: &mut Checker, path: String, spec: &SectionSpec| {
        if let Err(e) = section_of(spec).and_then(|s| s.check_lumpable()) {
            c.err(path, format!("beam `{name}`: {e}"));
        }
    };
    match (&b.section, b.sections.is_empty()) {
        (Some(_), false) | (None, true) => c.err(
            format!("{p}.section"),
            format!("beam `{name}`: give either `section` (uniform) or `sections` (stations along the span)"),
        ),
        (Some(spec), true) => check_section(c, format!("{p}.section"), spec),
        (None, false) => {
            let etas: Vec<f64> = b.sections.iter().map(|st| st.eta).collect();
            if let Err(e) = stations(&etas) {
                c.err(format!("{p}.sections"), format!("beam `{name}`: section stations {e}"));
            }
            for (k, st) in b.sections.iter().enumerate() {
                check_section(c, format!("{p}.sections[{k}].section"), &st.section);
            }
        }
    }
}

/// Structural damping: coefficients finite and ≥ 0, μ given once (directly or as a ratio at a
/// frequency), the matrix symmetric positive semi-definite.
fn check_damping(b: &Beam, c: &mut Checker, p: &str) {
    let Some(d) = &b.damping else { return };
    let name = &b.name;
    let mut bad = |field: &str, msg: &str| {
        c.err(
            format!("{p}.damping.{field}"),
            format!("beam `{name}`: {msg}"),
        )
    };
    for (field, v) in [
        ("stiffness_proportional", d.stiffness_proportional),
        ("ratio", d.ratio),
        ("mass_proportional", d.mass_proportional),
    ] {
        if v.is_some_and(|v| !(v.is_finite() && v >= 0.0)) {
            bad(field, "must be a finite number ≥ 0");
        }
    }
    match (d.stiffness_proportional, d.ratio, d.frequency) {
        (Some(_), Some(_), _) => bad(
            "ratio",
            "give either `stiffness_proportional` (μ, s) or `ratio` with `frequency`, not both",
        ),
        (_, Some(_), None) => bad(
            "frequency",
            "`ratio` needs the `frequency` (Hz) at which it holds",
        ),
        (_, None, Some(_)) => bad(
            "frequency",
            "`frequency` goes with a damping `ratio`; give both, or `stiffness_proportional`",
        ),
        (_, _, Some(f)) if !(f.is_finite() && f > 0.0) => {
            bad("frequency", "must be a finite frequency > 0, Hz")
        }
        _ => {}
    }
    if let Some(m) = &d.matrix {
        if let Err(e) = crate::beam::section::check_semidefinite(m) {
            bad("matrix", &e);
        }
    }
}

/// The line's data: `e2`, pre-twist, arc or via points.
fn check_line(b: &Beam, c: &mut Checker, p: &str) {
    let name = &b.name;
    if let Some(e2) = &b.e2 {
        c.vec3(format!("{p}.e2"), e2);
    }
    if !b.twist_rate.is_finite() {
        c.err(format!("{p}.twist_rate"), "must be a finite number");
    }
    if let Some(t) = &b.twist {
        if b.twist_rate != 0.0 {
            c.err(
                format!("{p}.twist"),
                format!("beam `{name}`: give either `twist_rate` or a `twist` table, not both"),
            );
        }
        if t.eta.len() != t.angle.len() || !t.angle.iter().all(|a| a.is_finite()) {
            c.err(format!("{p}.twist"), format!("beam `{name}`: `eta` and `angle` must be lists of finite numbers of the same length"));
        } else if let Err(e) = stations(&t.eta) {
            c.err(
                format!("{p}.twist.eta"),
                format!("beam `{name}`: twist stations {e}"),
            );
        }
    }
    if let Some(arc) = &b.arc {
        c.vec3(format!("{p}.arc.center"), &arc.center);
        c.vec3(format!("{p}.arc.axis"), &arc.axis);
        if !b.via.is_empty() {
            c.err(
                format!("{p}.via"),
                format!("beam `{name}`: give either `arc` or `via` points, not both"),
            );
        }
    }
    for (k, v) in b.via.iter().enumerate() {
        c.vec3(format!("{p}.via[{k}]"), v);
    }
}

/// A meshed beam with its line and its own share of the lumped inertia (for its
/// kinetic-energy sensor).
pub struct Meshed {
    pub mesh: BeamMesh,
    pub line: ReferenceLine,
    pub inertia: Vec<BeamNodeInertia>,
}

/// Meshes every beam into `table`, in order: shared end nodes are reused.
pub fn mesh_all(model: &Model, table: &mut NodeTable) -> Vec<Meshed> {
    model
        .beams
        .iter()
        .map(|b| {
            let (start, end) = end_points(b, table);
            let line = reference_line(b, start, end).expect("validated geometry");
            let before = table.lumped.clone();
            let mesh = mesh::mesh(b, &line, start, table);
            for (alias, target) in b.end_aliases() {
                table.alias(alias, &target);
            }
            let inertia = own_share(&before, &table.lumped);
            Meshed {
                mesh,
                line,
                inertia,
            }
        })
        .collect()
}

/// A beam's start and end points: given, an existing node's, or (the end) along its arc.
fn end_points(b: &Beam, table: &NodeTable) -> (V3<f64>, V3<f64>) {
    let at = |p: &Option<[f64; 3]>, n: &Option<String>| match (p, n) {
        (Some(p), _) => V3(*p),
        (None, Some(n)) => table.states[table.index(n)].x,
        _ => unreachable!("validated"),
    };
    let start = at(&b.start, &b.start_node);
    let end = match &b.arc {
        Some(arc) => V3(arc.end(start.0)),
        None => at(&b.end, &b.end_node),
    };
    (start, end)
}

/// What meshing one beam added to the lumped inertia, node by node.
fn own_share(before: &super::nodes::Lumped, after: &super::nodes::Lumped) -> Vec<BeamNodeInertia> {
    (0..after.mass.len())
        .filter_map(|a| {
            let m = after.mass[a] - before.mass.get(a).copied().unwrap_or(0.0);
            (m > 0.0).then(|| BeamNodeInertia {
                node: a,
                mass: m,
                first_moment: after.first_moment[a]
                    - before.first_moment.get(a).copied().unwrap_or(V3::zero()),
                inertia: after.inertia[a] - before.inertia.get(a).copied().unwrap_or(M3::zero()),
            })
        })
        .collect()
}

/// What sensors and sliding joints need of each beam.
pub fn info(model: &Model, meshed: &[Meshed]) -> Vec<BeamInfo> {
    let mut first = 0;
    model
        .beams
        .iter()
        .zip(meshed)
        .map(|(b, m)| {
            let count = m.mesh.elements.len();
            first += count;
            BeamInfo {
                name: b.name.clone(),
                first: first - count,
                count,
                length: m.mesh.length,
                spans: m.mesh.spans.clone(),
                inertia: m.inertia.clone(),
                nodes: m.mesh.nodes.clone(),
                order: b.order,
                line: m.line.clone(),
            }
        })
        .collect()
}

/// The beams' elements on the layout, their history laid out one after the other.
pub fn elements(meshed: &mut [Meshed], layout: &Layout) -> (Vec<BeamElement>, Vec<f64>) {
    let mut history = Vec::new();
    let mut elements = Vec::new();
    for e in meshed.iter_mut().flat_map(|m| m.mesh.elements.drain(..)) {
        let mut element = BeamElement::new(e.name, e.nodes, e.points, history.len(), layout);
        element.mass_damping = e.mass_damping;
        elements.push(element);
        history.extend_from_slice(&e.history);
    }
    (elements, history)
}

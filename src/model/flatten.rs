//! Flattening a model for the compiler: patterns expanded into their copies, and nodes and
//! beams given in a node's frame placed in the inertial frame. Errors about a copied item
//! name the item as the user wrote it (`patterns[0].beams[1] (copy 2 of pattern `rotor`)`).

use super::placement::{Place, Pose};
use super::{JointFrame, Model, ModelError, ModelErrors, Pattern, GROUND};
use std::collections::HashMap;

/// The copy of a pattern an item of the flat model belongs to, and its turn.
#[derive(Clone, Copy)]
struct Copy {
    id: usize,
    pose: Pose,
}

/// A model being flattened, with the copy of each node, beam and joint.
struct Flat {
    model: Model,
    node_copy: Vec<Option<Copy>>,
    beam_copy: Vec<Option<Copy>>,
    /// Copied joints given in a node's frame, with their copies.
    joints_in_frames: Vec<(usize, Copy)>,
    errors: Vec<ModelError>,
}

impl Model {
    /// Has no patterns and no items given in a node's frame.
    pub fn is_flat(&self) -> bool {
        self.patterns.is_empty()
            && self.nodes.iter().all(|n| n.frame.is_none())
            && self.beams.iter().all(|b| b.frame.is_none())
    }

    /// The model with its patterns expanded (after its own items) and every node and beam
    /// placed in the inertial frame; `origins` records where copied items came from.
    pub fn flattened(&self) -> Result<Model, ModelErrors> {
        if self.is_flat() {
            return Ok(self.clone());
        }
        let mut flat = Flat {
            node_copy: vec![None; self.nodes.len()],
            beam_copy: vec![None; self.beams.len()],
            joints_in_frames: vec![],
            model: Model {
                patterns: vec![],
                ..self.clone()
            },
            errors: vec![],
        };
        for (p, pattern) in self.patterns.iter().enumerate() {
            flat.expand(p, pattern);
        }
        if flat.errors.is_empty() {
            flat.place_nodes();
            flat.place_beams();
            flat.place_copied_joints();
        }
        if flat.errors.is_empty() {
            return Ok(flat.model);
        }
        let errors = std::mem::take(&mut flat.errors);
        Err(ModelErrors(errors).located(&flat.model))
    }

    /// The path the user wrote for a path of the flat model.
    pub fn source_path(&self, path: &str) -> String {
        for (flat, source) in &self.origins {
            if let Some(rest) = path.strip_prefix(flat.as_str()) {
                if rest.is_empty() || rest.starts_with('.') {
                    return format!("{source}{rest}");
                }
            }
        }
        path.to_string()
    }
}

impl ModelErrors {
    /// The errors with the paths the user wrote (see [`Model::source_path`]).
    pub fn located(self, model: &Model) -> ModelErrors {
        if model.origins.is_empty() {
            return self;
        }
        ModelErrors(
            self.0
                .into_iter()
                .map(|e| ModelError::new(model.source_path(&e.path), e.message))
                .collect(),
        )
    }
}

impl Flat {
    /// Appends the copies of pattern `p`, turned (placement of nodes and beams given in a
    /// frame waits until every node is known).
    fn expand(&mut self, p: usize, pattern: &Pattern) {
        let problems = pattern.problems(p);
        if !problems.is_empty() {
            let e = problems.into_iter().map(|(a, b)| ModelError::new(a, b));
            self.errors.extend(e);
            return;
        }
        for k in 0..pattern.count {
            let copy = match pattern.numbered(k) {
                Ok(c) => c,
                Err(e) => {
                    let path = format!("patterns[{p}]");
                    self.errors.push(ModelError::new(path, e));
                    return;
                }
            };
            let tag = Copy {
                id: self.model.origins.len(),
                pose: Pose::turn(pattern.center, pattern.axis, pattern.angle(k)),
            };
            let label = format!("(copy {} of {})", k + 1, pattern.label(p));
            self.append(p, copy, tag, &label);
        }
    }

    fn append(&mut self, p: usize, copy: Pattern, tag: Copy, label: &str) {
        let m = &mut self.model;
        let mut origin = |kind: &str, flat: usize, j: usize| {
            let source = format!("patterns[{p}].{kind}[{j}] {label}");
            m.origins.push((format!("{kind}[{flat}]"), source));
        };
        let counts = [
            ("nodes", m.nodes.len(), copy.nodes.len()),
            ("bodies", m.bodies.len(), copy.bodies.len()),
            ("beams", m.beams.len(), copy.beams.len()),
            ("joints", m.joints.len(), copy.joints.len()),
            ("loads", m.loads.len(), copy.loads.len()),
            ("sensors", m.sensors.len(), copy.sensors.len()),
            (
                "initial_spins",
                m.initial_spins.len(),
                copy.initial_spins.len(),
            ),
        ];
        for (kind, first, n) in counts {
            (0..n).for_each(|j| origin(kind, first + j, j));
        }
        // Joints, loads and spins given in the inertial frame turn with the copy now; those
        // given in a node's frame wait for the nodes (`place_copied_joints`).
        let m = &mut self.model;
        m.nodes.extend(copy.nodes.iter().cloned().map(|mut n| {
            if n.frame.is_none() {
                n.place(&tag.pose);
            }
            n
        }));
        self.node_copy.extend(copy.nodes.iter().map(|_| Some(tag)));
        self.beam_copy.extend(copy.beams.iter().map(|_| Some(tag)));
        m.beams.extend(copy.beams);
        m.bodies.extend(copy.bodies);
        m.sensors.extend(copy.sensors);
        for mut j in copy.joints {
            match j.frame() {
                JointFrame::Inertial => j.place(&tag.pose),
                _ => self.joints_in_frames.push((m.joints.len(), tag)),
            }
            m.joints.push(j);
        }
        m.loads.extend(copy.loads.into_iter().map(|mut l| {
            l.place(&tag.pose);
            l
        }));
        m.initial_spins
            .extend(copy.initial_spins.into_iter().map(|mut s| {
                s.place(&tag.pose);
                s
            }));
    }
}

/// How an item in copy `item` is placed when given in a frame whose pose is `frame`
/// (`None`: the inertial frame). A frame of the item's own copy has been turned with it
/// already; any other frame stays where it is, and the item is turned with its copy.
fn placement(item: Option<Copy>, frame: Option<(Option<Copy>, Pose)>) -> Pose {
    let turn = item.map_or(Pose::identity(), |c| c.pose);
    match frame {
        None => turn,
        Some((Some(f), pose)) if item.is_some_and(|c| c.id == f.id) => pose,
        Some((_, pose)) => turn.then(&pose),
    }
}

impl Flat {
    fn node_index(&self) -> HashMap<String, usize> {
        let mut index = HashMap::new();
        for (i, n) in self.model.nodes.iter().enumerate() {
            index.entry(n.name.clone()).or_insert(i);
        }
        index
    }

    /// The frame a node name gives: `Ok(None)` for the ground, else its copy and placed pose.
    fn frame_of(
        &self,
        index: &HashMap<String, usize>,
        name: &str,
    ) -> Result<Option<(Option<Copy>, Pose)>, String> {
        if name == GROUND {
            return Ok(None);
        }
        match index.get(name) {
            Some(&j) => Ok(Some((self.node_copy[j], Pose::of_node(&self.model.nodes[j])))),
            None => Err(format!(
                "`{name}` is not a node of `nodes` (a frame is a node of `nodes`, a pattern's own or `ground`)"
            )),
        }
    }

    /// Places the nodes given in another node's frame, that node first (a chain of frames is
    /// followed to its end; a loop is an error).
    fn place_nodes(&mut self) {
        let index = self.node_index();
        let n = self.model.nodes.len();
        let mut on_chain = vec![false; n];
        for start in 0..n {
            let mut chain = vec![start];
            while let Some(&i) = chain.last() {
                let Some(frame) = self.model.nodes[i].frame.clone() else {
                    chain.pop();
                    on_chain[i] = false;
                    continue;
                };
                on_chain[i] = true;
                match index.get(&frame) {
                    Some(&j) if self.model.nodes[j].frame.is_some() => {
                        if on_chain[j] {
                            self.frame_loop(&chain, j);
                            chain.iter().for_each(|&c| on_chain[c] = false);
                            break;
                        }
                        chain.push(j);
                    }
                    _ => {
                        self.place_node(&index, i, &frame);
                        chain.pop();
                        on_chain[i] = false;
                    }
                }
            }
        }
    }

    fn place_node(&mut self, index: &HashMap<String, usize>, i: usize, frame: &str) {
        match self.frame_of(index, frame) {
            Ok(f) => {
                let pose = placement(self.node_copy[i], f);
                self.model.nodes[i].place(&pose);
            }
            Err(e) => {
                let name = &self.model.nodes[i].name;
                let msg = format!("node `{name}`: {e}");
                self.errors
                    .push(ModelError::new(format!("nodes[{i}].frame"), msg));
            }
        }
        self.model.nodes[i].frame = None;
    }

    fn frame_loop(&mut self, chain: &[usize], j: usize) {
        let from = chain.iter().position(|&c| c == j).unwrap_or(0);
        let names: Vec<&str> = chain[from..]
            .iter()
            .map(|&c| self.model.nodes[c].name.as_str())
            .collect();
        let msg = format!(
            "node frames form a loop ({} → {}): give one of them in the inertial frame",
            names.join(" → "),
            names[0]
        );
        self.errors
            .push(ModelError::new(format!("nodes[{j}].frame"), msg));
        for &c in &chain[from..] {
            self.model.nodes[c].frame = None;
        }
    }

    /// Places the beams given in a node's frame or copied by a pattern; a copied beam gets
    /// its default section axis 2 before it turns, so that the copies' sections turn alike.
    fn place_beams(&mut self) {
        let index = self.node_index();
        for i in 0..self.model.beams.len() {
            let (copy, frame) = (self.beam_copy[i], self.model.beams[i].frame.take());
            if copy.is_none() && frame.is_none() {
                continue;
            }
            let f = match frame.as_deref().map(|x| self.frame_of(&index, x)) {
                None => None,
                Some(Ok(f)) => f,
                Some(Err(e)) => {
                    let msg = format!("beam `{}`: {e}", self.model.beams[i].name);
                    self.errors
                        .push(ModelError::new(format!("beams[{i}].frame"), msg));
                    continue;
                }
            };
            let pose = placement(copy, f);
            let tangent = self.local_tangent(&index, i, &pose);
            self.model.beams[i].place_with(&pose, tangent);
        }
    }

    /// A beam's start direction in the frame it is given in (`pose` places that frame), if
    /// its end points are known.
    fn local_tangent(
        &self,
        index: &HashMap<String, usize>,
        i: usize,
        pose: &Pose,
    ) -> Option<super::Vec3> {
        let b = &self.model.beams[i];
        let back = pose.inverse();
        let at = |p: &Option<super::Vec3>, n: &Option<String>| {
            p.or_else(|| {
                let j = *index.get(n.as_deref()?)?;
                Some(back.point(self.model.nodes[j].position))
            })
        };
        let start = at(&b.start, &b.start_node)?;
        let end = match b.arc.is_some() || !b.via.is_empty() {
            true => start,
            false => at(&b.end, &b.end_node)?,
        };
        Some(b.start_tangent(start, end))
    }

    /// Copied joints given in a node's frame: a node of their own copy turned with them; any
    /// other node's frame is resolved now, and the joint turned with its copy.
    fn place_copied_joints(&mut self) {
        let index = self.node_index();
        for (i, tag) in std::mem::take(&mut self.joints_in_frames) {
            let j = &self.model.joints[i];
            let (n1, n2) = j.nodes();
            let node = if j.frame() == JointFrame::Node1 {
                n1
            } else {
                n2
            };
            if self.in_copy(&index, node, tag.id) {
                continue;
            }
            match self.frame_of(&index, node) {
                Ok(f) => {
                    let pose = placement(Some(tag), f);
                    self.model.joints[i].to_inertial(&pose);
                }
                Err(_) => {
                    let msg = format!(
                        "joint `{}` is copied by a pattern and given in the frame of `{node}`, which is neither a node of `nodes` nor of its copy: give its geometry in the inertial frame, or in a node of the copy",
                        j.name()
                    );
                    self.errors
                        .push(ModelError::new(format!("joints[{i}].frame"), msg));
                }
            }
        }
    }

    /// Whether `node` (a node or a beam's node) belongs to copy `id`.
    fn in_copy(&self, index: &HashMap<String, usize>, node: &str, id: usize) -> bool {
        if let Some(&j) = index.get(node) {
            return self.node_copy[j].is_some_and(|c| c.id == id);
        }
        let Some((beam, _)) = node.rsplit_once('.') else {
            return false;
        };
        let m = &self.model;
        m.beams
            .iter()
            .position(|b| b.name == beam)
            .is_some_and(|b| self.beam_copy[b].is_some_and(|c| c.id == id))
    }
}

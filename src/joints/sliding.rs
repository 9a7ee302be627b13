//! Sliding joints (seed sections 5–6, corrected in `reference/sliding-joint-notes.md`): a
//! follower stays in contact with a flexible beam at a moving point, located by the element
//! coordinate ζ ∈ [0, N_e] — a joint coordinate, an unknown of the problem.
//!
//! Every member of the family is `C = Σ_α h^α(ζ) g(node α, follower)`, a two-node law `g`
//! between each beam node (its section triad) and the follower, blended by the beam's global
//! shape functions:
//! - **sliding joint** (eq. 28): `g = Y − X^α`, so `C = Y − P(ζ)`;
//! - **sliding screw joint** (eq. 34, the notes' "Option B"): adds `g = e₂^{kα}·e₃ˡ`, the
//!   interpolated director `Σ h^α e₂^{kα}` stays orthogonal to the follower's e₃, so the
//!   follower turns with the beam's pre-twist and elastic twist;
//! - **sliding clamp**: adds all three orientation rows (a sleeve that cannot turn on the
//!   beam).
//!
//! Exact split (eqs. 32–33 generalised): with `h_m = (h_i + h_f)/2`, the secant
//! `S = (h_f − h_i)/(ζ_f − ζ_i)` ([`BeamPath::secant_in`], division-free) and `g_m = (g_i + g_f)/2`,
//! `C_f − C_i = Σ_α h_m^α (g_f^α − g_i^α) + Δζ Σ_α S^α g_m^α`, and each `g_f − g_i` is the
//! two-node law's exact discrete gradient (eqs. 8, 15). Hence `B^D` rows: `h_m^α B_g^D` on node
//! α and the follower, `Σ S^α g_m^α` on ζ; the forces `B^Dᵀ sλ` do no work, across element
//! boundaries too. For eq. (28) this is eq. (33) with the total midpoint positions.
//!
//! The unknowns cover a *window* of elements around the one holding ζ at the start of the step
//! (one either side): the Newton matrix's pattern follows the contact point as it travels, and
//! [`SlidingJoint::place_window`] moves it between steps.

use super::closed_tangent::{self, BlockColumns, ClosedTangent, Geometric, SideFrame};
use super::equations::*;
use super::kinematics::*;
use super::{
    Attachment, ConstraintLaw, JointState, JointStep, Rows, Side, MAX_COORDS, MAX_ROWS, NCOL,
};
use crate::beam::path::{ArcMap, BeamPath, NodeWeights};
use crate::beam::shape::MAX_NODES;
use crate::elements::{v3, Kernel, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::rotation::rotate_material;
use crate::math::scalar::{Dual, Real};
use crate::math::vec3::{M3, V3};
use crate::state::State;

/// Most beam nodes in a window of three cubic elements.
pub const MAX_WINDOW_NODES: usize = 3 * (MAX_NODES - 1) + 1;
const FOLLOWER_COL: usize = 6 * MAX_WINDOW_NODES;
const ZETA_COL: usize = FOLLOWER_COL + 6;
/// Gradient columns: the window's nodes, the follower, ζ.
const NC: usize = ZETA_COL + 1;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlidingKind {
    /// The follower's point stays on the beam (3 rows).
    Point,
    /// ... and turns with the beam's section about its axis (4 rows).
    Screw,
    /// ... and keeps its orientation relative to the section (6 rows).
    Clamp,
}

/// The two-node law `g` between one beam node (side 0: its section triad, no offset) and the
/// follower (side 1: its contact point and joint triad).
#[derive(Clone, Debug)]
pub struct ContactLaw {
    pub kind: SlidingKind,
    pub at: [Attachment; 2],
}

impl ConstraintLaw for ContactLaw {
    fn attachments(&self) -> &[Attachment; 2] {
        &self.at
    }
    fn n_rows(&self) -> usize {
        match self.kind {
            SlidingKind::Point => 3,
            SlidingKind::Screw => 4,
            SlidingKind::Clamp => 6,
        }
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        points_value(s, out);
        match self.kind {
            SlidingKind::Point => {}
            SlidingKind::Screw => out[3] = dot_value(s, 1, 2), // eq. (34)
            SlidingKind::Clamp => orientation_value(s, &mut out[3..6]),
        }
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        points_gradient(si, sf, out, 0);
        match self.kind {
            SlidingKind::Point => {}
            SlidingKind::Screw => add_rotation_pair(&mut out[3], dot_mid(si, sf, 1, 2).0, T::one()),
            SlidingKind::Clamp => orientation_gradient(si, sf, out, 3),
        }
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        points_rate(s, out, 0);
        match self.kind {
            SlidingKind::Point => {}
            SlidingKind::Screw => add_rotation_pair(&mut out[3], dot_h(s, 1, 2), T::one()),
            SlidingKind::Clamp => orientation_rate(s, out, 3),
        }
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut super::stiffness::Stiffness,
    ) {
        use super::stiffness;
        stiffness::points(sf, V3([lam[0], lam[1], lam[2]]), k);
        match self.kind {
            SlidingKind::Point => {}
            SlidingKind::Screw => stiffness::dot_pair(si, sf, 1, 2, lam[3], k),
            SlidingKind::Clamp => stiffness::orientation(si, sf, &lam[3..6], k),
        }
    }
}

/// How far (in elements) a sliding contact point may pass its window's middle element before
/// the window moves after it: moves happen once per crossing, not at every step of a contact
/// point that lingers on an element boundary.
pub const WINDOW_HYSTERESIS: f64 = 0.25;

/// A sliding joint in a system.
#[derive(Clone, Debug)]
pub struct SlidingJoint {
    pub name: String,
    pub law: ContactLaw,
    /// The beam as a path, and the system node of each of its nodes (in order along it).
    pub path: BeamPath,
    pub beam_nodes: Vec<usize>,
    pub follower: Side,
    /// Global index of ζ among the coordinates.
    pub coord: usize,
    pub row0: usize,
    /// The beam (index in `System::beam_info`), and the user's η = s/L against ζ.
    pub beam: usize,
    pub arc: ArcMap,
    /// Elastic stops at the ends: the contact point may run slightly past them.
    pub end_stops: bool,
    /// First and last element the unknowns cover.
    window: (usize, usize),
    layout: Layout,
    unknowns: Vec<usize>,
    follower_slot: Option<usize>,
    coord_slot: usize,
    mult_slot: usize,
}

/// Dense per-window-node weights.
type Weights<T> = [T; MAX_WINDOW_NODES];

/// A node's share has the columns `[node, follower, ζ]`.
const SHARE_NC: usize = 13;
const SHARE_ZETA: usize = 12;
/// Unknowns of a share: node and follower (12 each under ED), ζ and its jump, 2 × 6
/// multipliers.
const MAX_SHARE: usize = 12 + 12 + 2 + 2 * MAX_ROWS;

/// The window's weights for one step: `h(ζ_i)`, `h(ζ_f)`, the secant, `h′(ζ_i)`, `h′(ζ_f)`.
struct WindowWeights<T> {
    hi: Weights<T>,
    hf: Weights<T>,
    sec: Weights<T>,
    dhi: Weights<T>,
    dhf: Weights<T>,
}

impl<T: Real> WindowWeights<T> {
    /// Whether node j takes part in the step (a weight or a derivative of one is nonzero).
    fn active(&self, j: usize) -> bool {
        [
            self.hi[j],
            self.hf[j],
            self.sec[j],
            self.dhi[j],
            self.dhf[j],
        ]
        .iter()
        .any(|w| w.re() != 0.0)
    }
}

/// One node's share of the value and gradients.
struct Share<T> {
    c_f: [T; MAX_ROWS],
    b: Grad<T, SHARE_NC>,
    /// ED: `B(q_i)` (a constant of the step, plain numbers) and `B(q_f)`.
    rates: Option<(Grad<f64, SHARE_NC>, Grad<T, SHARE_NC>)>,
}

impl<T: Real> Share<T> {
    /// A share to be written by [`SlidingJoint::node_share`] (with rates under ED).
    fn new(ed: bool) -> Self {
        Share {
            c_f: [T::zero(); MAX_ROWS],
            b: zero_grad(),
            rates: ed.then(|| (zero_grad(), zero_grad())),
        }
    }
}

/// Adds a share's columns into the joint's: node j's block, the follower's, ζ.
fn scatter<T: Real>(b: &mut Grad<T, NC>, share: &Grad<T, SHARE_NC>, col: usize, n: usize) {
    for r in 0..n {
        for c in 0..6 {
            b[r][col + c] += share[r][c];
            b[r][FOLLOWER_COL + c] += share[r][6 + c];
        }
        b[r][ZETA_COL] += share[r][SHARE_ZETA];
    }
}

/// Node j's share of a sliding joint as a kernel over its own unknowns (a subset of the
/// joint's, `map` giving their places in the joint's local block).
struct NodeShare<'a> {
    joint: &'a SlidingJoint,
    j: usize,
    map: [usize; MAX_SHARE],
    unknowns: [usize; MAX_SHARE],
    len: usize,
}

impl Kernel for NodeShare<'_> {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns[..self.len]
    }

    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        self.equations_residual(ctx, y, res)
    }

    fn evaluate(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        jac: Option<(&mut [f64], &[ValuePos])>,
    ) {
        closed_tangent::evaluate(self, ctx, y, res, jac)
    }

    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        closed_tangent::evaluate_decoupled(self, ctx, y, res, vals, pos)
    }

    fn decoupled_tangent(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        _scratch: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        closed_tangent::decoupled_tangent(self, ctx, y, vals, pos)
    }
}

/// EP's equations of a share with their tangent in closed form: the residual, the
/// multipliers' columns from the blended `B^D`, and the geometric ones from
/// [`NodeShare::geometric_derivative`].
impl ClosedTangent<SHARE_NC> for NodeShare<'_> {
    fn evaluate_closed(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: Option<&mut [f64]>,
        (vals, pos): (&mut [f64], &[ValuePos]),
        tangent: Tangent,
    ) {
        let n = self.len;
        let mut buf = [0.0; MAX_SHARE];
        for (b, &g) in buf.iter_mut().zip(&self.unknowns[..n]) {
            *b = y[g];
        }
        let yl = &buf[..n];
        self.with_equations(ctx, yl, |map, terms| {
            if let Some(res) = res {
                let mut rl = [0.0; MAX_SHARE];
                add_constraint_equations(ctx, map, terms, yl, &mut rl[..n]);
                for (&g, r) in self.unknowns[..n].iter().zip(&rl[..n]) {
                    res[g] += r;
                }
            }
            add_linear_columns(ctx, map, terms, n, vals, pos);
        });
        let (mut d, sides) = self.geometric_derivative(ctx, yl);
        let (_, coord_slot, mult_slot) = self.slots(ctx);
        let block = BlockColumns {
            sides,
            coords: &[coord_slot],
            mult: mult_slot,
            per: self.joint.per(),
            n_rows: self.joint.n_rows(),
            translations_linear: false,
        };
        block.add(&mut d, tangent, n, vals, pos);
    }
}

impl NodeShare<'_> {
    /// The share's `∂(bᵀ sλ, s c_f)/∂` the end state's spatial variations `[node, follower,
    /// ζ]` (eq. 33 generalised): with the pair law's `g`, its `B^D`, its rate operator `B`
    /// at the end and its force stiffness `K`, and node j's weights `h_m = (h_i + h_f)/2`,
    /// `h_f` and the secant `S` (their ζ derivatives `h_f′`, `S′`):
    /// - forces on the node and follower `h_m B^Dᵀλ`: `h_m K`, on ζ `(h_f′/2) B^Dᵀλ`;
    /// - the force on ζ `S λ·(g_i + g_f)/2`: `(S/2) Bᵀλ`, on ζ `S′ λ·(g_i + g_f)/2`;
    /// - the constraint rows `s h_f g_f`: `s h_f B`, on ζ `s h_f′ g_f`.
    ///
    /// Also returns the sides' frames for [`BlockColumns`].
    fn geometric_derivative(
        &self,
        ctx: &StepCtx,
        yl: &[f64],
    ) -> (Geometric, [Option<SideFrame>; 2]) {
        let joint = self.joint;
        let nr = joint.n_rows();
        let (fol_slot, coord_slot, mult_slot) = self.slots(ctx);
        let zf = Dual::<1>::seeded(ctx.state.coords[joint.coord] + yl[coord_slot], Some(0));
        let w = joint.window_weights(ctx, zf);
        let (hf, sec) = (w.hf[self.j], w.sec[self.j]);
        let hm = (w.hi[self.j].re + hf.re) * 0.5;
        let side = Side::Node(joint.beam_nodes[joint.first_node() + self.j]);
        let node = [
            joint.pose::<f64>(ctx.state, side, None, None),
            joint.pose(ctx.state, side, Some(0), Some(yl)),
        ];
        let fol = [
            joint.pose::<f64>(ctx.state, joint.follower, None, None),
            joint.pose(ctx.state, joint.follower, fol_slot, Some(yl)),
        ];
        let (si, sf) = (
            joint.pair_state(node[0], fol[0]),
            joint.pair_state(node[1], fol[1]),
        );
        let (mut gi, mut gf) = ([0.0; MAX_ROWS], [0.0; MAX_ROWS]);
        joint.law.value(&si, &mut gi);
        joint.law.value(&sf, &mut gf);
        let mut lam = [0.0; MAX_ROWS];
        for (r, l) in lam.iter_mut().enumerate().take(nr) {
            *l = yl[mult_slot + joint.per() * r] * ctx.s;
        }
        let (mut bd, mut rate) = ([[0.0; NCOL]; MAX_ROWS], [[0.0; NCOL]; MAX_ROWS]);
        joint.law.discrete_gradient(&si, &sf, &mut bd);
        joint.law.rate(&sf, &mut rate);
        let mut d = Geometric::zero();
        joint
            .law
            .force_stiffness(&si, &sf, &lam[..nr], &mut d.force);
        let z = SHARE_ZETA;
        for c in 0..12 {
            let (mut bd_lam, mut rate_lam) = (0.0, 0.0);
            for r in 0..nr {
                bd_lam += bd[r][c] * lam[r];
                rate_lam += rate[r][c] * lam[r];
            }
            for k in &mut d.force[c][..12] {
                *k *= hm;
            }
            d.force[c][z] = 0.5 * hf.du[0] * bd_lam;
            d.force[z][c] = 0.5 * sec.re * rate_lam;
        }
        let g_m_lam: f64 = (0..nr).map(|r| lam[r] * (gi[r] + gf[r]) * 0.5).sum();
        d.force[z][z] = sec.du[0] * g_m_lam;
        for ((row, b), g) in d.constraint.iter_mut().zip(&rate).zip(&gf).take(nr) {
            for (v, x) in row[..12].iter_mut().zip(b) {
                *v = ctx.s * hf.re * x;
            }
            row[z] = ctx.s * hf.du[0] * g;
        }
        let frame = |delta: Option<usize>, pose: &[(V3<f64>, M3<f64>); 2]| {
            delta.map(|delta| SideFrame {
                delta,
                r_i: pose[0].1,
                r_f: pose[1].1,
                r: v3(yl, delta + 3),
            })
        };
        (d, [frame(Some(0), &node), frame(fol_slot, &fol)])
    }

    /// Local slots: the node's `[Δx, r]` (and jumps), the follower's, ζ, the multipliers.
    fn slots(&self, ctx: &StepCtx) -> (Option<usize>, usize, usize) {
        let per = self.joint.per();
        let fol_slot = self.joint.follower_slot.map(|_| 6 * per);
        let coord_slot = 6 * per * (1 + usize::from(fol_slot.is_some()));
        // ED's decoupled surrogate evaluates EP's equations on the ED block (per = 2).
        debug_assert!(per == 2 || !ctx.ed());
        (fol_slot, coord_slot, coord_slot + per)
    }
}

impl StepEquations<SHARE_NC> for NodeShare<'_> {
    fn geometric_slots(&self, ctx: &StepCtx, out: &mut [usize; SHARE_NC]) -> usize {
        let (fol_slot, coord_slot, _) = self.slots(ctx);
        let mut g = 0;
        for d in std::iter::once(0).chain(fol_slot) {
            for c in 0..6 {
                out[g] = d + c;
                g += 1;
            }
        }
        out[g] = coord_slot;
        g + 1
    }

    fn with_equations<T: Real, R>(
        &self,
        ctx: &StepCtx,
        y: &[T],
        f: impl FnOnce(&ColumnMap<T>, &ConstraintTerms<T, SHARE_NC>) -> R,
    ) -> R {
        let joint = self.joint;
        let n = joint.n_rows();
        let node_slot = 0;
        let (fol_slot, coord_slot, mult_slot) = self.slots(ctx);
        let zf = T::cst(ctx.state.coords[joint.coord]) + y[coord_slot];
        let w = joint.window_weights(ctx, zf);
        let side = Side::Node(joint.beam_nodes[joint.first_node() + self.j]);
        let node = [
            joint.pose::<T>(ctx.state, side, None, None),
            joint.pose(ctx.state, side, Some(node_slot), Some(y)),
        ];
        let fol = [
            joint.pose::<T>(ctx.state, joint.follower, None, None),
            joint.pose(ctx.state, joint.follower, fol_slot, Some(y)),
        ];
        let mut share = Share::new(ctx.ed());
        joint.node_share(ctx, self.j, &w, node, fol, &mut share);
        // Jump slots as the block is laid out (ED's, also under its decoupled surrogate).
        let ed = self.joint.per() == 2;
        let mut blocks = [NodeColumns {
            col: 0,
            delta: node_slot,
            jump: ed.then_some(node_slot + 6),
            r_i: node[0].1,
            r_f: node[1].1,
        }; 2];
        let mut nb = 1;
        if let Some(d) = fol_slot {
            blocks[1] = NodeColumns {
                col: 6,
                delta: d,
                jump: ed.then_some(d + 6),
                r_i: fol[0].1,
                r_f: fol[1].1,
            };
            nb = 2;
        }
        let coords = [CoordColumn {
            col: SHARE_ZETA,
            slot: coord_slot,
        }];
        let map = ColumnMap {
            nodes: &blocks[..nb],
            coords: &coords,
            mult: mult_slot,
            per: self.joint.per(),
            n_rows: n,
        };
        let rates = share.rates.as_ref().map(|(a, b)| (a, b));
        let terms = ConstraintTerms {
            c_f: &share.c_f[..n],
            b: &share.b,
            rates,
        };
        f(&map, &terms)
    }
}

/// Everything one evaluation of the joint produces.
struct Terms<T> {
    c_f: [T; MAX_ROWS],
    b: Grad<T, NC>,
    rates: Option<(Grad<f64, NC>, Grad<T, NC>)>,
    nodes: [Option<NodeColumns<T>>; MAX_WINDOW_NODES + 1],
}

impl SlidingJoint {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: String,
        law: ContactLaw,
        path: BeamPath,
        beam_nodes: Vec<usize>,
        follower: Side,
        coord: usize,
        row0: usize,
        layout: &Layout,
        zeta0: f64,
    ) -> Self {
        assert_eq!(beam_nodes.len(), path.elements * path.order + 1);
        let elements = path.elements;
        let mut j = SlidingJoint {
            name,
            law,
            path,
            beam_nodes,
            follower,
            coord,
            row0,
            beam: 0,
            arc: ArcMap::uniform(elements),
            end_stops: false,
            window: (usize::MAX, 0),
            layout: *layout,
            unknowns: vec![],
            follower_slot: None,
            coord_slot: 0,
            mult_slot: 0,
        };
        j.place_window(zeta0);
        j
    }

    pub fn n_rows(&self) -> usize {
        self.law.n_rows()
    }

    /// The window of elements for a step starting at ζ: the element holding it and one either
    /// side.
    fn window_for(&self, zeta: f64) -> (usize, usize) {
        let (e, _) = self.path.locate(zeta);
        (e.saturating_sub(1), (e + 1).min(self.path.elements - 1))
    }

    pub fn window(&self) -> (usize, usize) {
        self.window
    }

    /// The number of elements of the beam the contact slides on.
    pub fn beam_elements(&self) -> usize {
        self.path.elements
    }

    /// Whether the window in place still serves a step starting at ζ: ζ lies at least
    /// `1 − WINDOW_HYSTERESIS` of an element inside each of its limits (the ends of a beam
    /// limit nothing).
    fn window_holds(&self, zeta: f64) -> bool {
        if self.window.0 == usize::MAX || !zeta.is_finite() {
            return false;
        }
        let (lo, hi) = self.zeta_limits();
        let margin = 1.0 - WINDOW_HYSTERESIS;
        zeta >= lo + margin && zeta <= hi - margin
    }

    /// Moves the window to a step starting at ζ; true if it changed (then the kernel's
    /// unknowns, and so the Newton matrix's pattern, changed). The window stays while ζ is
    /// within [`WINDOW_HYSTERESIS`] of an element past its middle element: a contact point
    /// resting on an element boundary (a collar at mid-span of an even mesh) moved the window
    /// to and fro every step, each move a new pattern, ordering and pivoting LU (290 of 400
    /// steps on a still collar at 5 ms), while a step may still move ζ by
    /// `1 − WINDOW_HYSTERESIS` of an element before the window's edge holds it.
    pub fn place_window(&mut self, zeta: f64) -> bool {
        if self.window_holds(zeta) {
            return false;
        }
        let w = self.window_for(zeta);
        if w == self.window {
            return false;
        }
        self.window = w;
        let layout = self.layout;
        let ed = layout.ed();
        let mut unknowns = Vec::new();
        let push_node = |unknowns: &mut Vec<usize>, a: usize| {
            unknowns.extend((0..6).map(|c| layout.node_delta(a) + c));
            if ed {
                unknowns.extend((0..6).map(|c| layout.node_jump(a) + c));
            }
        };
        for k in self.first_node()..=self.last_node() {
            push_node(&mut unknowns, self.beam_nodes[k]);
        }
        self.follower_slot = match self.follower {
            Side::Node(a) => {
                let at = unknowns.len();
                push_node(&mut unknowns, a);
                Some(at)
            }
            Side::Ground { .. } => None,
        };
        self.coord_slot = unknowns.len();
        unknowns.push(layout.coord_delta(self.coord));
        if ed {
            unknowns.push(layout.coord_jump(self.coord));
        }
        self.mult_slot = unknowns.len();
        for r in 0..self.n_rows() {
            unknowns.push(layout.mult(self.row0 + r));
            if ed {
                unknowns.push(layout.mult_jump(self.row0 + r));
            }
        }
        self.unknowns = unknowns;
        true
    }

    fn first_node(&self) -> usize {
        self.window.0 * self.path.order
    }
    fn last_node(&self) -> usize {
        (self.window.1 + 1) * self.path.order
    }

    /// Why a Newton failure left this joint's ζ equation unbalanced, if its contact point sat
    /// on an interior node at the step's start (ζ_i within 1e-6 of an element boundary): the
    /// beam's path, interpolated element by element, can kink there under the follower's own
    /// load, and a free follower pressing across the beam then has no balanced position — the
    /// secant slope in `λ·S(ζ_f) = 0` jumps from one element's to the other's as ζ_f passes ζ_i.
    pub fn node_kink_hint(&self, zeta_i: f64) -> Option<String> {
        let node = zeta_i.round();
        let interior = node > 0.0 && node < self.path.elements as f64;
        if interior && (zeta_i - node).abs() <= 1e-6 {
            let eta = self.arc.eta(node);
            Some(format!("the contact point of sliding joint `{}` sat on a node of its beam (η = {eta:.6}), where the beam's path can kink under the follower's own load: a free follower pressing across the beam has no balanced position on the kink. Place it off the node, or prescribe η with a `drive`", self.name))
        } else {
            None
        }
    }

    /// The range ζ may take within a step: the window, except that at the beam's ends it
    /// extends (a contact point past an end is detected after the step converges).
    pub fn zeta_limits(&self) -> (f64, f64) {
        let lo = if self.window.0 == 0 {
            f64::NEG_INFINITY
        } else {
            self.window.0 as f64
        };
        let hi = if self.window.1 + 1 == self.path.elements {
            f64::INFINITY
        } else {
            (self.window.1 + 1) as f64
        };
        (lo, hi)
    }

    fn per(&self) -> usize {
        if self.layout.ed() {
            2
        } else {
            1
        }
    }

    /// Dense window weights from a list over beam nodes.
    fn dense<T: Real>(&self, w: &NodeWeights<T>) -> Weights<T> {
        let mut out = [T::zero(); MAX_WINDOW_NODES];
        let first = self.first_node();
        for (n, v) in w.iter() {
            debug_assert!(n >= first && n <= self.last_node());
            out[n - first] += v;
        }
        out
    }

    /// A node's pose (as `T`) at the start of the step, and at its end from the local block.
    fn pose<T: Real>(
        &self,
        state: &State,
        side: Side,
        slot: Option<usize>,
        y: Option<&[T]>,
    ) -> (V3<T>, M3<T>) {
        let (x, r) = match side {
            Side::Node(a) => (state.nodes[a].x, state.nodes[a].r),
            Side::Ground { x, r } => (x, r),
        };
        let x = V3::from_f64(x);
        match (slot, y) {
            (Some(d), Some(y)) => (x + v3(y, d), rotate_material(&r, &v3(y, d + 3))),
            _ => (x, M3::from_f64(&r)),
        }
    }

    fn pair_state<T: Real>(&self, node: (V3<T>, M3<T>), follower: (V3<T>, M3<T>)) -> JointState<T> {
        JointState::new(
            [node.0, follower.0],
            [node.1, follower.1],
            [T::zero(); MAX_COORDS],
            &self.law.at,
        )
    }

    /// Writes `w·pair` (the pair law's 12 columns: node, follower) into a share's columns,
    /// each entry through `to` (the identity, or the value part for a constant of the step).
    fn blend<T: Real, U>(
        b: &mut Grad<U, SHARE_NC>,
        pair: &Rows<T>,
        w: T,
        n: usize,
        to: impl Fn(T) -> U,
    ) {
        for r in 0..n {
            for c in 0..12 {
                b[r][c] = to(pair[r][c] * w);
            }
        }
    }

    /// The shape-function weights of the window's nodes for a step from ζ_i to `zf`.
    fn window_weights<T: Real>(&self, ctx: &StepCtx, zf: T) -> WindowWeights<T> {
        let range = self.window;
        let zi = T::cst(ctx.state.coords[self.coord]);
        let none = [T::zero(); MAX_WINDOW_NODES];
        let statics = ctx.is_static();
        WindowWeights {
            hi: if statics {
                none
            } else {
                self.dense(&self.path.weights_in(zi, range))
            },
            hf: self.dense(&self.path.weights_in(zf, range)),
            dhf: self.dense(&self.path.tangent_weights(zf, range)),
            sec: if statics {
                none
            } else {
                self.dense(&self.path.secant_in(zi, zf, range))
            },
            dhi: if ctx.ed() {
                self.dense(&self.path.tangent_weights(zi, range))
            } else {
                none
            },
        }
    }

    /// Window node `j`'s share of the joint's equations: its pair law with the follower,
    /// blended by its weights, over the columns `[node j, follower, ζ]`, written into every
    /// row of `share` the law has (in place: a share of dual numbers is tens of kilobytes).
    /// The joint's value and gradients are the sums of these shares.
    #[allow(clippy::too_many_arguments)]
    fn node_share<T: Real>(
        &self,
        ctx: &StepCtx,
        j: usize,
        w: &WindowWeights<T>,
        node: [(V3<T>, M3<T>); 2],
        fol: [(V3<T>, M3<T>); 2],
        share: &mut Share<T>,
    ) {
        let n = self.n_rows();
        let si = self.pair_state(node[0], fol[0]);
        let sf = self.pair_state(node[1], fol[1]);
        let (mut gi, mut gf) = ([T::zero(); MAX_ROWS], [T::zero(); MAX_ROWS]);
        self.law.value(&si, &mut gi);
        self.law.value(&sf, &mut gf);
        debug_assert_eq!(
            share.rates.is_some(),
            ctx.ed(),
            "a share with rates under ED"
        );
        for r in 0..n {
            share.c_f[r] = w.hf[j] * gf[r];
        }
        let mut pair = [[T::zero(); NCOL]; MAX_ROWS];
        if ctx.is_static() {
            // B(q_f): h_f B_g(f), and on ζ h_f′ g_f.
            self.law.rate(&sf, &mut pair);
            Self::blend(&mut share.b, &pair, w.hf[j], n, |v| v);
            for r in 0..n {
                share.b[r][SHARE_ZETA] = w.dhf[j] * gf[r];
            }
        } else {
            // B^D: h_m B_g^D, and on ζ S g_m (eq. 33 generalised).
            self.law.discrete_gradient(&si, &sf, &mut pair);
            Self::blend(&mut share.b, &pair, (w.hi[j] + w.hf[j]) * 0.5, n, |v| v);
            for r in 0..n {
                share.b[r][SHARE_ZETA] = w.sec[j] * (gi[r] + gf[r]) * 0.5;
            }
        }
        if let Some((b_i, b_f)) = share.rates.as_mut() {
            // Only the law's rows are read back. The start state, its weights and value do
            // not depend on the unknowns: B(q_i) is their value part.
            pair[..n].fill([T::zero(); NCOL]);
            self.law.rate(&si, &mut pair);
            Self::blend(b_i, &pair, w.hi[j], n, T::re);
            for r in 0..n {
                b_i[r][SHARE_ZETA] = (w.dhi[j] * gi[r]).re();
            }
            pair[..n].fill([T::zero(); NCOL]);
            self.law.rate(&sf, &mut pair);
            Self::blend(b_f, &pair, w.hf[j], n, |v| v);
            for r in 0..n {
                b_f[r][SHARE_ZETA] = w.dhf[j] * gf[r];
            }
        }
    }

    /// The joint's value and gradients for a step (or a static solve) at the local block `y`:
    /// the sum of the active nodes' shares.
    fn terms<T: Real>(&self, ctx: &StepCtx, y: &[T]) -> Terms<T> {
        let n = self.n_rows();
        let zf = T::cst(ctx.state.coords[self.coord]) + y[self.coord_slot];
        let ed = ctx.ed();
        let w = self.window_weights(ctx, zf);
        let fol = [
            self.pose::<T>(ctx.state, self.follower, None, None),
            self.pose(ctx.state, self.follower, self.follower_slot, Some(y)),
        ];
        let per = self.per();
        let mut t = Terms {
            c_f: [T::zero(); MAX_ROWS],
            b: zero_grad(),
            rates: ed.then(|| (zero_grad(), zero_grad())),
            nodes: [None; MAX_WINDOW_NODES + 1],
        };
        let first = self.first_node();
        // Each share writes all of its rows: one serves every node.
        let mut share = Share::new(ed);
        for j in (0..=(self.last_node() - first)).filter(|&j| w.active(j)) {
            let side = Side::Node(self.beam_nodes[first + j]);
            let slot = 6 * per * j;
            let node = [
                self.pose::<T>(ctx.state, side, None, None),
                self.pose(ctx.state, side, Some(slot), Some(y)),
            ];
            self.node_share(ctx, j, &w, node, fol, &mut share);
            for r in 0..n {
                t.c_f[r] += share.c_f[r];
            }
            scatter(&mut t.b, &share.b, 6 * j, n);
            if let (Some((b_i, b_f)), Some((s_i, s_f))) = (t.rates.as_mut(), share.rates.as_ref()) {
                scatter(b_i, s_i, 6 * j, n);
                scatter(b_f, s_f, 6 * j, n);
            }
            t.nodes[j] = Some(NodeColumns {
                col: 6 * j,
                delta: slot,
                jump: ed.then_some(slot + 6),
                r_i: node[0].1,
                r_f: node[1].1,
            });
        }
        if let Some(d) = self.follower_slot {
            t.nodes[MAX_WINDOW_NODES] = Some(NodeColumns {
                col: FOLLOWER_COL,
                delta: d,
                jump: ed.then_some(d + 6),
                r_i: fol[0].1,
                r_f: fol[1].1,
            });
        }
        t
    }

    /// Node `j`'s share as a small kernel of its own unknowns (node j, follower, ζ,
    /// multipliers), for differentiating the joint share by share.
    fn share_kernel(&self, j: usize) -> NodeShare<'_> {
        let per = self.per();
        let mut map = [0usize; MAX_SHARE];
        let mut len = 0;
        let mut push = |from: usize, count: usize| {
            for k in 0..count {
                map[len] = from + k;
                len += 1;
            }
        };
        push(6 * per * j, 6 * per);
        if let Some(d) = self.follower_slot {
            push(d, 6 * per);
        }
        push(self.coord_slot, per);
        push(self.mult_slot, per * self.n_rows());
        let mut unknowns = [0usize; MAX_SHARE];
        for k in 0..len {
            unknowns[k] = self.unknowns[map[k]];
        }
        NodeShare {
            joint: self,
            j,
            map,
            unknowns,
            len,
        }
    }

    fn with_map<T: Real, R>(&self, t: &Terms<T>, f: impl FnOnce(&ColumnMap<T>) -> R) -> R {
        let mut nodes = [None; MAX_WINDOW_NODES + 1];
        let mut k = 0;
        for n in t.nodes.iter().flatten() {
            nodes[k] = Some(*n);
            k += 1;
        }
        let cols: [NodeColumns<T>; MAX_WINDOW_NODES + 1] = std::array::from_fn(|i| {
            nodes[i].unwrap_or(NodeColumns {
                col: 0,
                delta: 0,
                jump: None,
                r_i: M3::identity(),
                r_f: M3::identity(),
            })
        });
        let coords = [CoordColumn {
            col: ZETA_COL,
            slot: self.coord_slot,
        }];
        let map = ColumnMap {
            nodes: &cols[..k],
            coords: &coords,
            mult: self.mult_slot,
            per: self.per(),
            n_rows: self.n_rows(),
        };
        f(&map)
    }

    fn gather(&self, y: &[f64]) -> [f64; crate::elements::MAX_LOCAL] {
        let mut buf = [0.0; crate::elements::MAX_LOCAL];
        for (b, &g) in buf.iter_mut().zip(self.unknowns.iter()) {
            *b = y[g];
        }
        buf
    }

    /// What a converged step tells of the joint (see [`JointStep`]): the constraint values at
    /// the end, the work `λ·(B^D Δ)` of the constraint forces (zero to round-off), and the
    /// contact force and moment on the follower at its contact point (inertial) with the
    /// beam's section frame there (axis 1 along the beam) — from one evaluation of its terms.
    pub fn step_outcome(&self, ctx: &StepCtx, y: &[f64]) -> JointStep {
        let buf = self.gather(y);
        let yl = &buf[..self.unknowns.len()];
        let t = self.terms(ctx, yl);
        let n = self.n_rows();
        let (lam, work) = self.with_map(&t, |map| {
            let lam = map.multipliers(ctx, yl, false);
            let mut bd = [0.0; MAX_ROWS];
            gradient_times_increment(map, &t.b, yl, &mut bd);
            (lam, (0..n).map(|r| lam[r] * bd[r]).sum())
        });
        let (f, m_node) = node_force(&t.b, &lam[..n], FOLLOWER_COL);
        let (_, r_f) = self.pose(ctx.state, self.follower, self.follower_slot, Some(yl));
        let arm = r_f.mul_v(&self.law.at[1].offset);
        // The forces are step averages: give them in the mid-step section frame (the end
        // frame would lean by half the step's rotation).
        let zeta_i = ctx.state.coords[self.coord];
        let zeta_f = zeta_i + yl[self.coord_slot];
        let (df1, df2) = self.directors(zeta_f, |a| self.end_rotation(ctx.state, a, yl));
        let frame = if ctx.is_static() {
            orthonormal_frame(df1, df2)
        } else {
            let (di1, di2) = self.directors(zeta_i, |a| ctx.state.nodes[self.beam_nodes[a]].r);
            orthonormal_frame(di1 + df1, di2 + df2)
        };
        JointStep {
            values: t.c_f,
            work,
            reaction: (f, m_node - arm.cross(&f), frame),
        }
    }

    /// The end rotation of beam node `a` (index along the beam) after the local increments
    /// `yl`: moved if it is in the window, as at the start otherwise.
    fn end_rotation(&self, state: &State, a: usize, yl: &[f64]) -> M3<f64> {
        let node = Side::Node(self.beam_nodes[a]);
        if (self.first_node()..=self.last_node()).contains(&a) {
            let slot = 6 * self.per() * (a - self.first_node());
            self.pose(state, node, Some(slot), Some(yl)).1
        } else {
            self.pose::<f64>(state, node, None, None).1
        }
    }

    /// The interpolated directors `Σ h^α e₁^α`, `Σ h^α e₂^α` at ζ, the rotation of beam node
    /// `a` (index along the beam) from `rotation(a)`.
    fn directors(&self, zeta: f64, rotation: impl Fn(usize) -> M3<f64>) -> (V3<f64>, V3<f64>) {
        let mut d1 = V3::zero();
        let mut d2 = V3::zero();
        for (n, h) in self.path.weights_in(zeta, self.path.all()).iter() {
            let r = rotation(n);
            d1 += r.col(0).scale_f(h);
            d2 += r.col(1).scale_f(h);
        }
        (d1, d2)
    }
    /// The contact point `P(ζ)`, the section frame there (the interpolated directors
    /// `Σ h^α e_k^α` made orthonormal, axis 1 first) and the path's speed `|P′(ζ)|` (m per unit
    /// ζ), at a state.
    pub fn contact(&self, state: &State, zeta: f64) -> (V3<f64>, M3<f64>, f64) {
        let range = self.path.all();
        let w = self.path.weights_in(zeta, range);
        let dw = self.path.tangent_weights(zeta, range);
        let mut p = V3::zero();
        let mut dp = V3::zero();
        let mut d1 = V3::zero();
        let mut d2 = V3::zero();
        for (n, h) in w.iter() {
            let node = &state.nodes[self.beam_nodes[n]];
            p += node.x.scale_f(h);
            d1 += node.r.col(0).scale_f(h);
            d2 += node.r.col(1).scale_f(h);
        }
        for (n, h) in dw.iter() {
            dp += state.nodes[self.beam_nodes[n]].x.scale_f(h);
        }
        (p, orthonormal_frame(d1, d2), dp.norm())
    }

    /// The beam's axis (section axis 1) at the contact point, predicted at the middle of a
    /// step of `h` from `state`: ζ advanced at its rate, each node's triad turned by its
    /// angular velocity over h/2 — second-order accurate, for quantities that belong to the
    /// step's middle (a friction's normal force).
    pub fn mid_step_axis(&self, state: &State, h: f64) -> V3<f64> {
        let zeta = state.coords[self.coord] + 0.5 * h * state.coord_rates[self.coord];
        let w = self.path.weights_in(zeta, self.path.all());
        let mut d1 = V3::zero();
        let mut d2 = V3::zero();
        for (n, weight) in w.iter() {
            let node = &state.nodes[self.beam_nodes[n]];
            let r = crate::math::rotation::exp_map(&node.omega().scale_f(0.5 * h)).mul_m(&node.r);
            d1 += r.col(0).scale_f(weight);
            d2 += r.col(1).scale_f(weight);
        }
        orthonormal_frame(d1, d2).col(0)
    }

    /// Constraint values at a state.
    pub fn values_at(&self, state: &State) -> [f64; MAX_ROWS] {
        let zeta = state.coords[self.coord];
        let w = self.path.weights_in(zeta, self.path.all());
        let fol = self.pose::<f64>(state, self.follower, None, None);
        let mut c = [0.0; MAX_ROWS];
        for (n, h) in w.iter() {
            let node = self.pose::<f64>(state, Side::Node(self.beam_nodes[n]), None, None);
            let mut g = [0.0; MAX_ROWS];
            self.law.value(&self.pair_state(node, fol), &mut g);
            for r in 0..self.n_rows() {
                c[r] += h * g[r];
            }
        }
        c
    }

    /// The velocity-level rows `Ċ = Σ h^α B_g(α) V + ζ̇ Σ h′^α g^α` at a state, as terms
    /// (local row, term).
    pub fn rate_terms(&self, state: &State, out: &mut Vec<(usize, super::RateTerm)>) {
        use super::RateTerm;
        let zeta = state.coords[self.coord];
        let range = self.path.all();
        let w = self.path.weights_in(zeta, range);
        let dw = self.path.tangent_weights(zeta, range);
        let fol = self.pose::<f64>(state, self.follower, None, None);
        let n = self.n_rows();
        let mut dzeta = [0.0; MAX_ROWS];
        let mut fv = [(V3::zero(), V3::zero()); MAX_ROWS];
        for (node_k, h) in w.iter() {
            let a = self.beam_nodes[node_k];
            let node = self.pose::<f64>(state, Side::Node(a), None, None);
            let s = self.pair_state(node, fol);
            let mut pair = [[0.0; NCOL]; MAX_ROWS];
            self.law.rate(&s, &mut pair);
            for (r, f) in fv.iter_mut().enumerate().take(n) {
                out.push((
                    r,
                    RateTerm::Node {
                        node: a,
                        v: V3([pair[r][0], pair[r][1], pair[r][2]]).scale_f(h),
                        omega: V3([pair[r][3], pair[r][4], pair[r][5]]).scale_f(h),
                    },
                ));
                f.0 += V3([pair[r][6], pair[r][7], pair[r][8]]).scale_f(h);
                f.1 += V3([pair[r][9], pair[r][10], pair[r][11]]).scale_f(h);
            }
        }
        for (node_k, dh) in dw.iter() {
            let node = self.pose::<f64>(state, Side::Node(self.beam_nodes[node_k]), None, None);
            let mut g = [0.0; MAX_ROWS];
            self.law.value(&self.pair_state(node, fol), &mut g);
            for r in 0..n {
                dzeta[r] += dh * g[r];
            }
        }
        for r in 0..n {
            if let Side::Node(a) = self.follower {
                out.push((
                    r,
                    RateTerm::Node {
                        node: a,
                        v: fv[r].0,
                        omega: fv[r].1,
                    },
                ));
            }
            out.push((
                r,
                RateTerm::Coord {
                    coord: self.coord,
                    value: dzeta[r],
                },
            ));
        }
    }
}

/// An orthonormal frame whose first axis is along `d1` and second in the plane of `d1, d2`.
pub fn orthonormal_frame(d1: V3<f64>, d2: V3<f64>) -> M3<f64> {
    let e1 = d1.scale_f(1.0 / d1.norm());
    let e2 = d2 - e1.scale_f(d2.dot(&e1));
    let e2 = e2.scale_f(1.0 / e2.norm());
    M3::from_cols(e1, e2, e1.cross(&e2))
}

impl SlidingJoint {
    /// Calls `f` with each window node's share that takes part in the step and the positions
    /// of its local tangent block in the joint's (`pos`, row-major over the joint's unknowns).
    fn for_each_share(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        pos: &[ValuePos],
        mut f: impl FnMut(&NodeShare, &[ValuePos]),
    ) {
        let n = self.unknowns.len();
        let zf = ctx.state.coords[self.coord] + y[self.unknowns[self.coord_slot]];
        let w = self.window_weights::<f64>(ctx, zf);
        let mut spos = [0 as ValuePos; MAX_SHARE * MAX_SHARE];
        for j in (0..=(self.last_node() - self.first_node())).filter(|&j| w.active(j)) {
            let share = self.share_kernel(j);
            let ns = share.len;
            for a in 0..ns {
                for b in 0..ns {
                    spos[a * ns + b] = pos[share.map[a] * n + share.map[b]];
                }
            }
            f(&share, &spos[..ns * ns]);
        }
    }
}

impl Kernel for SlidingJoint {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }

    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], res: &mut [T]) {
        let t = self.terms(ctx, y);
        let rates = t.rates.as_ref().map(|(a, b)| (a, b));
        let terms = ConstraintTerms {
            c_f: &t.c_f[..self.n_rows()],
            b: &t.b,
            rates,
        };
        self.with_map(&t, |map| add_constraint_equations(ctx, map, &terms, y, res));
    }

    /// The residual is a sum of the window nodes' shares, each depending on one node, the
    /// follower, ζ and the multipliers: the tangent is assembled share by share (one small
    /// dual-number pass each) rather than by differentiating the whole window at once.
    fn evaluate(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        jac: Option<(&mut [f64], &[ValuePos])>,
    ) {
        let Some((vals, pos)) = jac else {
            return crate::elements::eval_kernel(self, ctx, y, res, None);
        };
        self.for_each_share(ctx, y, pos, |share, spos| {
            share.evaluate(ctx, y, res, Some((vals, spos)))
        });
    }

    /// ED's decoupled surrogate share by share, as pair joints write it
    /// ([`evaluate_constraint_decoupled`]): EP's equations on the ED block.
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        self.for_each_share(ctx, y, pos, |share, spos| {
            share.evaluate_decoupled(ctx, y, res, vals, spos)
        });
    }

    /// The shares' decoupled entries without their residuals (a border refresh): a third of
    /// the work, the shares' ED residual passes each recomputing the window's weights.
    fn decoupled_tangent(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        scratch: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        self.for_each_share(ctx, y, pos, |share, spos| {
            share.decoupled_tangent(ctx, y, scratch, vals, spos)
        });
    }

    /// The pattern must hold wherever ζ is in the window during the step: the union of the
    /// structures with the step ending in each of its elements, of the exact tangent and of
    /// ED's decoupled one (the latter once missing: 20 entries written outside the pattern
    /// per 2000 ED steps of the free collar). Each share depends on one window node, the
    /// follower, ζ and the multipliers, its weight the mean of ζ_i's and ζ_f's: ζ_f in every
    /// element reaches every node's entries, so a step starting in an outer element (the
    /// window lingers, [`WINDOW_HYSTERESIS`]) needs no probe of its own.
    fn structure(&self, ctx: &StepCtx, y: &[f64]) -> Vec<bool> {
        let mut state = ctx.state.clone();
        let centre = (self.window.0 + self.window.1) as f64 * 0.5 + 0.5;
        state.coords[self.coord] = centre;
        let probe = StepCtx {
            state: &state,
            ..*ctx
        };
        let mut yl = y.to_vec();
        let delta = self.layout_coord_delta();
        let mut mask: Vec<bool> = Vec::new();
        for e in self.window.0..=self.window.1 {
            for frac in [0.3, 0.7] {
                yl[delta] = e as f64 + frac - centre;
                let m = crate::elements::tangent_structure(self, &probe, &yl);
                if mask.is_empty() {
                    mask = m;
                } else {
                    mask.iter_mut().zip(m).for_each(|(a, b)| *a |= b);
                }
            }
        }
        mask
    }

    /// The number of window nodes: the rest of the block (follower, ζ, multipliers) is the
    /// joint's own, and each share couples its node with it by the same law, so windows of
    /// as many nodes have one structure wherever they sit on the beam (the window at a
    /// beam's end has fewer).
    fn structure_shape(&self) -> Option<usize> {
        Some(self.last_node() + 1 - self.first_node())
    }
}

impl SlidingJoint {
    fn layout_coord_delta(&self) -> usize {
        self.layout.coord_delta(self.coord)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::joints::law_tests::{assert_law, attachments};
    use crate::math::layout::Scheme;
    use crate::math::rotation::exp_map;
    use crate::state::NodeState;

    const KINDS: [SlidingKind; 3] = [SlidingKind::Point, SlidingKind::Screw, SlidingKind::Clamp];

    #[test]
    fn contact_laws_have_exact_discrete_gradients() {
        for kind in KINDS {
            assert_law(&ContactLaw {
                kind,
                at: attachments(),
            });
        }
    }

    /// A wavy, twisted 3-D beam of `ne` elements of order `p` (nodes 0 … ne·p) and a moving,
    /// turning follower (the last node).
    fn setup(ne: usize, p: usize) -> State {
        let nb = ne * p + 1;
        let mut nodes: Vec<NodeState> = (0..nb)
            .map(|k| {
                let s = k as f64 * 0.37;
                NodeState {
                    x: V3([
                        s + 0.1 * (3.0 * s).sin(),
                        0.4 * (1.7 * s).cos(),
                        0.05 * s * s,
                    ]),
                    r: exp_map(&V3([0.3 * s, 0.2 * (2.0 * s).sin(), -0.1 * s])),
                    v: V3([0.2 * s, -0.5, 0.1]),
                    w: V3([1.0, 0.3 * s, -0.2]),
                }
            })
            .collect();
        nodes.push(NodeState {
            x: V3([0.9, 0.3, -0.2]),
            r: exp_map(&V3([0.5, -0.4, 0.2])),
            v: V3([0.7, 0.1, -0.3]),
            w: V3([-0.4, 0.8, 0.6]),
        });
        State {
            t: 0.2,
            nodes,
            coords: vec![0.0],
            coord_rates: vec![0.9],
            lambda: vec![],
            history: vec![],
        }
    }

    fn joint(
        kind: SlidingKind,
        ne: usize,
        p: usize,
        zeta0: f64,
        ground: bool,
        layout: &Layout,
    ) -> SlidingJoint {
        let at = attachments();
        let follower = if ground {
            Side::Ground {
                x: V3([0.4, -0.3, 0.2]),
                r: exp_map(&V3([0.1, 0.2, -0.3])),
            }
        } else {
            Side::Node(ne * p + 1)
        };
        SlidingJoint::new(
            "slider".into(),
            ContactLaw {
                kind,
                at: [
                    Attachment {
                        offset: V3::zero(),
                        triad: M3::identity(),
                    },
                    at[1],
                ],
            },
            BeamPath::new(ne, p),
            (0..=ne * p).collect(),
            follower,
            0,
            0,
            layout,
            zeta0,
        )
    }

    /// The wavy beam of 5 elements of order p with ζ_i = zi, its layout and the joint.
    fn case(
        scheme: Scheme,
        kind: SlidingKind,
        p: usize,
        zi: f64,
        ground: bool,
    ) -> (State, Layout, SlidingJoint) {
        let mut state = setup(5, p);
        state.coords[0] = zi;
        let n_rows = ContactLaw {
            kind,
            at: attachments(),
        }
        .n_rows();
        let layout = Layout::new(scheme, state.nodes.len(), 1, n_rows);
        let j = joint(kind, 5, p, zi, ground, &layout);
        (state, layout, j)
    }

    /// Unknowns with large increments (rotations of tens of degrees) and the given Δζ.
    fn unknowns(layout: &Layout, dzeta: f64, seed: f64) -> Vec<f64> {
        let mut y: Vec<f64> = (0..layout.n_unknowns())
            .map(|i| 0.2 * ((i as f64 + seed) * 1.3).sin())
            .collect();
        y[layout.coord_delta(0)] = dzeta;
        y
    }

    /// ζ_i in element 2 and steps inside it, across one boundary either way, of zero length
    /// (the Newton predictor's first iterate), and from a node either way. (A zero step
    /// exactly on a node sits on the path's kink: no derivative to compare with there.)
    const STEPS: [(f64, f64); 6] = [
        (2.4, 0.3),
        (2.4, 0.8),
        (2.4, -0.6),
        (2.4, 0.0),
        (2.0, 0.3),
        (2.0, -0.3),
    ];

    #[test]
    fn constraint_increment_is_exactly_the_discrete_gradient_times_the_step() {
        // W = sλ·(C_f − C_i) for any λ: the forces B^Dᵀλ do no work on a constrained step.
        for p in 1..=3 {
            for kind in KINDS {
                for (zi, dz) in STEPS {
                    let (state, layout, j) = case(Scheme::Ep, kind, p, zi, false);
                    let n_rows = j.n_rows();
                    let y = unknowns(&layout, dz, 3.0);
                    let ctx = StepCtx {
                        layout,
                        h: 0.01,
                        t_i: 0.2,
                        t_f: 0.21,
                        s: 1.0,
                        state: &state,
                        gravity: V3::zero(),
                        statics: None,
                    };
                    let yl: Vec<f64> = j.unknowns().iter().map(|&g| y[g]).collect();
                    let t = j.terms(&ctx, &yl);
                    let c_i = j.values_at(&state);
                    let mut bd = [0.0; MAX_ROWS];
                    j.with_map(&t, |map| gradient_times_increment(map, &t.b, &yl, &mut bd));
                    for r in 0..n_rows {
                        let dc = t.c_f[r] - c_i[r];
                        // An algebraic identity: round-off of O(1) data.
                        assert!(
                            (bd[r] - dc).abs() < 1e-13,
                            "p={p} {kind:?} ζ {zi}+{dz} row {r}: B^DΔ = {} vs ΔC = {dc}",
                            bd[r]
                        );
                    }
                }
            }
        }
    }

    /// A 10 ms step from t = 0.2 s with scale 30 (statics at `statics`), at `state`.
    fn step_ctx(layout: Layout, state: &State, statics: Option<f64>) -> StepCtx<'_> {
        StepCtx {
            layout,
            h: 0.01,
            t_i: 0.2,
            t_f: 0.21,
            s: 30.0,
            state,
            gravity: V3::zero(),
            statics,
        }
    }

    #[test]
    fn tangents_match_finite_differences_inside_and_across_elements() {
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            for p in 1..=3 {
                for kind in KINDS {
                    for ground in [false, true] {
                        for (zi, dz) in STEPS {
                            let (state, layout, j) = case(scheme, kind, p, zi, ground);
                            let y = unknowns(&layout, dz, 1.0);
                            let ctx = step_ctx(layout, &state, statics);
                            let e = tangent_error(&j, &ctx, &y);
                            // FD truncation and round-off relative to |J|, as for every kernel.
                            assert!(
                                e < 1e-7,
                                "{scheme:?} statics={statics:?} p={p} {kind:?} ground={ground} ζ {zi}+{dz}: {e:e}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// The shares' closed-form tangent ([`NodeShare::evaluate_closed`]) is the dual pass's,
    /// EP's and ED's decoupled surrogate alike, for every kind and element order, to a node
    /// and to the ground, inside an element and across a boundary: round-off only. Under ED
    /// the border refresh's tangent-only evaluation (`decoupled_tangent`) writes the very
    /// entries `evaluate_decoupled` does, bit for bit.
    #[test]
    fn closed_form_tangent_is_the_dual_pass_tangent() {
        for scheme in [Scheme::Ep, Scheme::Ed] {
            for p in 1..=3 {
                for kind in KINDS {
                    for ground in [false, true] {
                        for (zi, dz) in STEPS {
                            let (state, layout, j) = case(scheme, kind, p, zi, ground);
                            let y = unknowns(&layout, dz, 1.0);
                            let ctx = step_ctx(layout, &state, None);
                            let n = j.unknowns().len();
                            let pos = crate::elements::own_block_positions(n);
                            let (mut jc, mut jd) = (vec![0.0; n * n], vec![0.0; n * n]);
                            let (mut rc, mut rd) = (vec![0.0; y.len()], vec![0.0; y.len()]);
                            if scheme == Scheme::Ep {
                                j.evaluate(&ctx, &y, &mut rc, Some((&mut jc, &pos)));
                                j.for_each_share(&ctx, &y, &pos, |share, spos| {
                                    evaluate_constraint(
                                        share,
                                        &ctx,
                                        &y,
                                        &mut rd,
                                        Some((&mut jd, spos)),
                                    )
                                });
                            } else {
                                j.evaluate_decoupled(&ctx, &y, &mut rc, &mut jc, &pos);
                                let mut alone = vec![0.0; n * n];
                                let mut scratch = vec![0.0; y.len()];
                                j.decoupled_tangent(&ctx, &y, &mut scratch, &mut alone, &pos);
                                assert_eq!(alone, jc, "{kind:?} p={p}: tangent alone");
                                j.for_each_share(&ctx, &y, &pos, |share, spos| {
                                    evaluate_constraint_decoupled(
                                        share, &ctx, &y, &mut rd, &mut jd, spos,
                                    )
                                });
                            }
                            let what =
                                format!("{scheme:?} p={p} {kind:?} ground={ground} ζ {zi}+{dz}");
                            closed_tangent::assert_same_evaluation((&rc, &jc), (&rd, &jd), &what);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn window_follows_the_contact_point_and_limits_the_step() {
        let state = setup(6, 3);
        let layout = Layout::new(Scheme::Ed, state.nodes.len(), 1, 4);
        let mut j = joint(SlidingKind::Screw, 6, 3, 0.2, false, &layout);
        assert_eq!(j.window(), (0, 1));
        assert_eq!(j.zeta_limits(), (f64::NEG_INFINITY, 2.0));
        assert!(!j.place_window(0.9));
        assert!(j.place_window(3.5));
        assert_eq!(j.window(), (2, 4));
        assert_eq!(j.zeta_limits(), (2.0, 5.0));
        // Ten beam nodes and the follower, 12 unknowns each, ζ and its jump, 2 × 4 multipliers.
        assert_eq!(j.unknowns().len(), 11 * 12 + 2 + 8);
        assert!(j.place_window(6.0));
        assert_eq!(j.window(), (4, 5));
        assert_eq!(j.zeta_limits(), (4.0, f64::INFINITY));
    }

    #[test]
    fn only_a_contact_resting_on_an_interior_node_gets_the_kink_hint() {
        let state = setup(6, 3);
        let layout = Layout::new(Scheme::Ep, state.nodes.len(), 1, 4);
        let j = joint(SlidingKind::Point, 6, 3, 0.2, false, &layout);
        let hint = j
            .node_kink_hint(3.0 + 1e-8)
            .expect("on node 3 of 6 elements");
        assert!(hint.contains("η = 0.500000"), "{hint}");
        for zeta in [3.001, 2.5, 0.0, 6.0] {
            assert!(j.node_kink_hint(zeta).is_none(), "ζ = {zeta}");
        }
    }

    #[test]
    fn window_moves_once_per_crossing_not_at_every_step_on_a_boundary() {
        let state = setup(6, 3);
        let layout = Layout::new(Scheme::Ep, state.nodes.len(), 1, 4);
        let mut j = joint(SlidingKind::Point, 6, 3, 0.2, false, &layout);
        assert!(j.place_window(2.5));
        assert_eq!(j.window(), (1, 3));
        // To and fro across the boundary at 3 within the hysteresis: the window stays.
        for zeta in [
            3.01,
            2.99,
            3.2,
            2.0 - WINDOW_HYSTERESIS + 1.0,
            3.0 + WINDOW_HYSTERESIS,
        ] {
            assert!(!j.place_window(zeta), "moved at ζ = {zeta}");
        }
        // Past it, the window moves to the element now holding ζ, then stays on the way back.
        assert!(j.place_window(3.26));
        assert_eq!(j.window(), (2, 4));
        assert!(!j.place_window(2.8));
        assert!(j.place_window(2.7));
        assert_eq!(j.window(), (1, 3));
        // At the beam's end the window never limits the step: it stays on any ζ past it.
        assert!(j.place_window(5.5));
        assert_eq!(j.window(), (4, 5));
        assert!(!j.place_window(7.0));
    }
}

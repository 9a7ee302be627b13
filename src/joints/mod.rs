//! Joints: holonomic constraints enforced with Lagrange multipliers.
//!
//! Each joint type is a [`ConstraintLaw`]: its constraint values `C`, its exact discrete
//! gradient `B^D` with `C_f − C_i = B^D Δ` (the paper's eqs. 8, 15, 22, whose transposes are the
//! discrete constraint forces of eqs. 10, 16, 23), and its rate operator `Ċ = B(q) V` (for the
//! ED scheme's velocity-level condition). [`JointKernel`] turns any law into the discrete
//! equations of a step: EP applies `B^Dᵀ λ` and enforces `C_f = 0`, so the constraint forces do
//! zero work; ED follows ed-scheme-notes §3.2–3.3.
//!
//! Gradients are written over *spatial* increments `[Δx₁, ρ₁, Δx₂, ρ₂, Δq…]` with
//! `R_f = cay(ρ) R_i`; the kernel converts to the material unknowns (`ρ = R_i r`), which makes
//! them "spatially consistent" (ed-scheme-notes §4).

pub mod clamp;
pub(crate) mod closed_tangent;
pub mod cylindrical;
pub mod equations;
pub mod friction;
pub mod kinematics;
pub mod prismatic;
pub mod revolute;
pub mod screw;
pub mod sliding;
pub mod spherical;
pub mod stiffness;
pub mod universal;

use crate::elements::{v3, Kernel, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::rotation::rotate_material;
use crate::math::scalar::Real;
use crate::math::vec3::{M3, V3};
use equations::{ColumnMap, ConstraintTerms, CoordColumn, NodeColumns, StepEquations};

/// Most constraint rows of one joint (the screw joint's 7).
pub const MAX_ROWS: usize = 8;
pub const MAX_COORDS: usize = 2;
/// Columns of a gradient row: two nodes × (3 + 3) and the joint's coordinates.
pub const NCOL: usize = 12 + MAX_COORDS;
/// A pair joint's largest local block: two nodes' increments and jumps, the coordinates'
/// and the rows' multipliers with their jumps (ED).
const MAX_PAIR_LOCAL: usize = 2 * 12 + 2 * MAX_COORDS + 2 * MAX_ROWS;

pub type Rows<T> = [[T; NCOL]; MAX_ROWS];

/// The configuration seen by a joint: both sides' node positions and rotations, the spatial
/// attachment frames they carry, and the joint's coordinates.
#[derive(Clone, Copy, Debug)]
pub struct JointState<T> {
    pub x: [V3<T>; 2],
    pub r: [M3<T>; 2],
    pub q: [T; MAX_COORDS],
    /// Each side's attachment triad in space, `R_k A_k`: its columns are the unit vectors
    /// `e_αᵏ` every law is written with (formed once per state, not once per use).
    pub e: [M3<T>; 2],
    /// Each side's attachment arm in space, `R_k p_k`: the attachment point is `x_k + arm_k`.
    pub arm: [V3<T>; 2],
}

impl<T: Real> JointState<T> {
    /// The state of sides at `x`, `r` (coordinates `q`) carrying the attachments `at`.
    pub fn new(x: [V3<T>; 2], r: [M3<T>; 2], q: [T; MAX_COORDS], at: &[Attachment; 2]) -> Self {
        let mut s = JointState {
            x,
            r,
            q,
            e: [M3::identity(); 2],
            arm: [V3::zero(); 2],
        };
        for k in 0..2 {
            s.set_side(k, x[k], r[k], &at[k]);
        }
        s
    }

    /// Moves side `k` to `x`, `r` (its attachment frame with it).
    pub fn set_side(&mut self, k: usize, x: V3<T>, r: M3<T>, at: &Attachment) {
        self.x[k] = x;
        self.r[k] = r;
        self.e[k] = r.mul_mf(&at.triad);
        self.arm[k] = r.mul_vf(&at.offset);
    }
}

impl JointState<f64> {
    /// The same state as constants of `T`.
    pub fn lift<T: Real>(&self) -> JointState<T> {
        let v = |a: &[V3<f64>; 2]| [V3::from_f64(a[0]), V3::from_f64(a[1])];
        let m = |a: &[M3<f64>; 2]| [M3::from_f64(&a[0]), M3::from_f64(&a[1])];
        JointState {
            x: v(&self.x),
            r: m(&self.r),
            q: self.q.map(T::cst),
            e: m(&self.e),
            arm: v(&self.arm),
        }
    }
}

/// Attachment of a joint to a node: a point and a triad fixed to the node (in its triad).
#[derive(Clone, Copy, Debug)]
pub struct Attachment {
    pub offset: V3<f64>,
    pub triad: M3<f64>,
}

pub trait ConstraintLaw {
    /// The law's attachments to its two sides (the frames its states carry).
    fn attachments(&self) -> &[Attachment; 2];
    fn n_rows(&self) -> usize;
    fn n_coords(&self) -> usize {
        0
    }
    /// `C(q)`.
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]);
    /// Exact discrete gradient: `C(f) − C(i) = B^D [Δx₁, ρ₁, Δx₂, ρ₂, Δq]`.
    fn discrete_gradient<T: Real>(&self, si: &JointState<T>, sf: &JointState<T>, out: &mut Rows<T>);
    /// Rate operator: `Ċ = B [v₁, ω₁, v₂, ω₂, q̇]` (spatial angular velocities).
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>);
    /// The discrete constraint forces' geometric stiffness `∂(B^Dᵀλ)/∂z` for fixed
    /// multipliers `lam` (one per row), added to `k`: `z` the end state's spatial variations
    /// (see [`stiffness`]). Checked against a dual derivative of `discrete_gradient` by the
    /// law tests.
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut stiffness::Stiffness,
    );
    /// Whether the positions enter `C` only as `x₂ − x₁` (coincident points, no projection
    /// on a moving axis), so that `B^D` and `B` do not depend on them and their columns are
    /// `∓I`: the tangent's translation columns are then the gradient's own, written in closed
    /// form, and the dual pass differentiates rotations and coordinates only (6–7 directions
    /// instead of 12–13). Checked by the law tests.
    fn affine_in_translations(&self) -> bool {
        false
    }
    /// The first of the law's three coincident-point rows `x₂ + R₂p₂ − x₁ − R₁p₁`, a spatial
    /// vector, if it has them (modified Newton turns such rows with the bodies,
    /// see [`SpatialRows`]). Checked by the law tests.
    fn coincident_point_rows(&self) -> Option<usize> {
        None
    }
}

/// The joint types, each a law with its own module.
#[derive(Clone, Debug)]
pub enum JointLaw {
    Spherical(spherical::Spherical),
    Revolute(revolute::Revolute),
    Universal(universal::Universal),
    Clamp(clamp::Clamp),
    Prismatic(prismatic::Prismatic),
    Cylindrical(cylindrical::Cylindrical),
    Screw(screw::Screw),
}

macro_rules! dispatch {
    ($self:expr, $j:ident => $e:expr) => {
        match $self {
            JointLaw::Spherical($j) => $e,
            JointLaw::Revolute($j) => $e,
            JointLaw::Universal($j) => $e,
            JointLaw::Clamp($j) => $e,
            JointLaw::Prismatic($j) => $e,
            JointLaw::Cylindrical($j) => $e,
            JointLaw::Screw($j) => $e,
        }
    };
}

impl ConstraintLaw for JointLaw {
    fn attachments(&self) -> &[Attachment; 2] {
        dispatch!(self, j => j.attachments())
    }
    fn n_rows(&self) -> usize {
        dispatch!(self, j => j.n_rows())
    }
    fn n_coords(&self) -> usize {
        dispatch!(self, j => j.n_coords())
    }
    fn value<T: Real>(&self, s: &JointState<T>, out: &mut [T]) {
        dispatch!(self, j => j.value(s, out))
    }
    fn discrete_gradient<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
        out: &mut Rows<T>,
    ) {
        dispatch!(self, j => j.discrete_gradient(si, sf, out))
    }
    fn rate<T: Real>(&self, s: &JointState<T>, out: &mut Rows<T>) {
        dispatch!(self, j => j.rate(s, out))
    }
    fn force_stiffness(
        &self,
        si: &JointState<f64>,
        sf: &JointState<f64>,
        lam: &[f64],
        k: &mut stiffness::Stiffness,
    ) {
        dispatch!(self, j => j.force_stiffness(si, sf, lam, k))
    }
    fn affine_in_translations(&self) -> bool {
        dispatch!(self, j => j.affine_in_translations())
    }
    fn coincident_point_rows(&self) -> Option<usize> {
        dispatch!(self, j => j.coincident_point_rows())
    }
}

/// One term of a velocity-level constraint row `Ċ = B V`: the coefficients of a node's
/// velocity and (spatial) angular velocity, or of a coordinate's rate.
#[derive(Clone, Copy, Debug)]
pub enum RateTerm {
    Node {
        node: usize,
        v: V3<f64>,
        omega: V3<f64>,
    },
    Coord {
        coord: usize,
        value: f64,
    },
}

/// A joint's three spatial constraint rows (a coincident-point vector, and its multipliers a
/// force) and the nodes of its sides, side 2's first. Modified Newton turns them with the
/// first of these nodes that it co-rotates (`integrator::corotation`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialRows {
    /// The first of the three global constraint rows.
    pub row: usize,
    pub nodes: [Option<usize>; 2],
}

/// A joint of a system: between two nodes (or a node and the ground), or a sliding joint
/// between a follower and a beam.
#[derive(Clone, Debug)]
pub enum Joint {
    Pair(JointKernel),
    Sliding(sliding::SlidingJoint),
}

macro_rules! each_joint {
    ($self:expr, $j:ident => $e:expr) => {
        match $self {
            Joint::Pair($j) => $e,
            Joint::Sliding($j) => $e,
        }
    };
}

impl Joint {
    /// The nodes of the two sides (None: the ground); a sliding joint's follower and None.
    pub fn nodes(&self) -> [Option<usize>; 2] {
        let node = |s: &Side| match s {
            Side::Node(a) => Some(*a),
            Side::Ground { .. } => None,
        };
        match self {
            Joint::Pair(j) => [node(&j.sides[0]), node(&j.sides[1])],
            Joint::Sliding(s) => [node(&s.follower), None],
        }
    }
    /// The joint's coincident-point rows (three spatial rows) and the nodes whose turn they
    /// follow, side 2's first: a pair joint's law's, a sliding joint's contact rows (turning
    /// with the follower).
    pub fn spatial_rows(&self) -> Option<SpatialRows> {
        let [one, two] = self.nodes();
        match self {
            Joint::Pair(j) => j.law.coincident_point_rows().map(|r| SpatialRows {
                row: j.row0 + r,
                nodes: [two, one],
            }),
            Joint::Sliding(s) => one.map(|_| SpatialRows {
                row: s.row0,
                nodes: [one, None],
            }),
        }
    }
    pub fn name(&self) -> &str {
        each_joint!(self, j => &j.name)
    }
    pub fn n_rows(&self) -> usize {
        each_joint!(self, j => j.n_rows())
    }
    /// First global constraint row.
    pub fn row0(&self) -> usize {
        each_joint!(self, j => j.row0)
    }
    pub fn as_sliding(&self) -> Option<&sliding::SlidingJoint> {
        match self {
            Joint::Sliding(s) => Some(s),
            Joint::Pair(_) => None,
        }
    }
    /// What the converged step at unknowns `y` tells of the joint (see [`JointStep`]).
    pub fn step_outcome(&self, ctx: &StepCtx, y: &[f64]) -> JointStep {
        each_joint!(self, j => j.step_outcome(ctx, y))
    }
    pub fn values_at(&self, state: &crate::state::State) -> [f64; MAX_ROWS] {
        each_joint!(self, j => j.values_at(state))
    }
    /// The velocity-level rows at a state, as (local row, term) pairs.
    pub fn rate_terms(&self, state: &crate::state::State, out: &mut Vec<(usize, RateTerm)>) {
        each_joint!(self, j => j.rate_terms(state, out))
    }
}

impl Kernel for Joint {
    fn unknowns(&self) -> &[usize] {
        each_joint!(self, j => j.unknowns())
    }
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T]) {
        each_joint!(self, j => j.residual(ctx, y, r))
    }
    fn structure(&self, ctx: &StepCtx, y: &[f64]) -> Vec<bool> {
        each_joint!(self, j => j.structure(ctx, y))
    }
    fn structure_shape(&self) -> Option<usize> {
        each_joint!(self, j => j.structure_shape())
    }
    fn evaluate(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        jac: Option<(&mut [f64], &[ValuePos])>,
    ) {
        each_joint!(self, j => j.evaluate(ctx, y, res, jac))
    }
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        each_joint!(self, j => j.evaluate_decoupled(ctx, y, res, vals, pos))
    }
    fn decoupled_tangent(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        scratch: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        each_joint!(self, j => j.decoupled_tangent(ctx, y, scratch, vals, pos))
    }
}

/// One side of a joint: a node with unknowns, or the ground (a fixed pose).
#[derive(Clone, Copy, Debug)]
pub enum Side {
    Node(usize),
    Ground { x: V3<f64>, r: M3<f64> },
}

/// Where a side's unknowns sit in the kernel's local block.
#[derive(Clone, Copy, Debug, Default)]
struct SideSlots {
    delta: Option<usize>,
    jump: Option<usize>,
}

/// A joint instance in a system: its law, sides, coordinates and constraint rows, and the
/// scheme's discrete equations for it.
#[derive(Clone, Debug)]
pub struct JointKernel {
    pub name: String,
    pub law: JointLaw,
    pub sides: [Side; 2],
    /// Global indices of the joint's coordinates.
    pub coords: Vec<usize>,
    /// First global constraint row.
    pub row0: usize,
    unknowns: Vec<usize>,
    slots: [SideSlots; 2],
    coord_slot: usize,
    mult_slot: usize,
    /// Slots per coordinate and per multiplier: 2 under ED (the jump, λ_d follow), else 1.
    per: usize,
}

/// What a converged step tells of a joint, from one evaluation of its equations.
#[derive(Clone, Copy, Debug)]
pub struct JointStep {
    /// Constraint values `C` at the end of the step (its first `n_rows` entries).
    pub values: [f64; MAX_ROWS],
    /// Work of the constraint forces over the step, `λ·(B^D Δ) = λ·(C_f − C_i)`: zero to
    /// round-off when the constraints hold.
    pub work: f64,
    /// Force and moment (N, N·m, inertial) on node2 — the follower — at the joint point,
    /// step averages, and the joint frame they are reported in.
    pub reaction: (V3<f64>, V3<f64>, M3<f64>),
}

fn zero_rows<T: Real>() -> Rows<T> {
    [[T::zero(); NCOL]; MAX_ROWS]
}

impl JointKernel {
    pub fn new(
        name: String,
        law: JointLaw,
        sides: [Side; 2],
        coords: Vec<usize>,
        row0: usize,
        layout: &Layout,
    ) -> Self {
        assert_eq!(coords.len(), law.n_coords());
        let ed = layout.ed();
        let mut unknowns = Vec::new();
        let mut slots = [SideSlots::default(); 2];
        for (k, side) in sides.iter().enumerate() {
            if let Side::Node(a) = side {
                slots[k].delta = Some(unknowns.len());
                unknowns.extend((0..6).map(|c| layout.node_delta(*a) + c));
                if ed {
                    slots[k].jump = Some(unknowns.len());
                    unknowns.extend((0..6).map(|c| layout.node_jump(*a) + c));
                }
            }
        }
        let coord_slot = unknowns.len();
        for &c in &coords {
            unknowns.push(layout.coord_delta(c));
            if ed {
                unknowns.push(layout.coord_jump(c));
            }
        }
        let mult_slot = unknowns.len();
        for r in 0..law.n_rows() {
            unknowns.push(layout.mult(row0 + r));
            if ed {
                unknowns.push(layout.mult_jump(row0 + r));
            }
        }
        JointKernel {
            name,
            law,
            sides,
            coords,
            row0,
            unknowns,
            slots,
            coord_slot,
            mult_slot,
            per: if ed { 2 } else { 1 },
        }
    }

    pub fn n_rows(&self) -> usize {
        self.law.n_rows()
    }

    /// Start state of the joint (a constant of the step).
    fn state_i(&self, ctx: &StepCtx) -> JointState<f64> {
        let mut x = [V3::zero(); 2];
        let mut r = [M3::identity(); 2];
        for (k, side) in self.sides.iter().enumerate() {
            (x[k], r[k]) = match side {
                Side::Node(a) => (ctx.state.nodes[*a].x, ctx.state.nodes[*a].r),
                Side::Ground { x, r } => (*x, *r),
            };
        }
        let mut q = [0.0; MAX_COORDS];
        for (c, &g) in self.coords.iter().enumerate() {
            q[c] = ctx.state.coords[g];
        }
        JointState::new(x, r, q, self.law.attachments())
    }

    /// End state from the local increments, starting from `si` (`start` is `si` as `T`);
    /// also returns the material `r` of each side.
    fn state_f<T: Real>(
        &self,
        si: &JointState<f64>,
        start: &JointState<T>,
        y: &[T],
    ) -> (JointState<T>, [V3<T>; 2]) {
        let mut sf = *start;
        let mut rs = [V3::zero(); 2];
        let at = self.law.attachments();
        for k in 0..2 {
            if let Some(d) = self.slots[k].delta {
                rs[k] = v3(y, d + 3);
                let x = start.x[k] + v3(y, d);
                sf.set_side(k, x, rotate_material(&si.r[k], &rs[k]), &at[k]);
            }
        }
        let per = self.per;
        for c in 0..self.coords.len() {
            sf.q[c] = start.q[c] + y[self.coord_slot + per * c];
        }
        (sf, rs)
    }

    /// Current multipliers (physical constraint forces `λ = s μ`) from a local block.
    fn multipliers<T: Real>(&self, ctx: &StepCtx, y: &[T], jump: bool) -> [T; MAX_ROWS] {
        let per = self.per;
        let mut l = [T::zero(); MAX_ROWS];
        for (r, lr) in l.iter_mut().enumerate().take(self.n_rows()) {
            *lr = y[self.mult_slot + per * r + usize::from(jump)] * ctx.s;
        }
        l
    }

    /// The joint's local unknowns from the global vector (on the stack).
    fn gather(&self, y: &[f64]) -> [f64; MAX_PAIR_LOCAL] {
        let mut buf = [0.0; MAX_PAIR_LOCAL];
        for (b, &g) in buf.iter_mut().zip(self.unknowns.iter()) {
            *b = y[g];
        }
        buf
    }

    /// The joint's gradient columns (`[Δx₁, ρ₁, Δx₂, ρ₂, q…]`) mapped to its local unknowns.
    #[allow(clippy::type_complexity)]
    fn columns<T: Real>(
        &self,
        si: &JointState<T>,
        sf: &JointState<T>,
    ) -> ([NodeColumns<T>; 2], usize, [CoordColumn; MAX_COORDS]) {
        let per = self.per;
        let none = NodeColumns {
            col: 0,
            delta: 0,
            jump: None,
            r_i: M3::identity(),
            r_f: M3::identity(),
        };
        let mut blocks = [none; 2];
        let mut nb = 0;
        for k in 0..2 {
            if let Some(d) = self.slots[k].delta {
                blocks[nb] = NodeColumns {
                    col: 6 * k,
                    delta: d,
                    jump: self.slots[k].jump,
                    r_i: si.r[k],
                    r_f: sf.r[k],
                };
                nb += 1;
            }
        }
        let mut coords = [CoordColumn { col: 0, slot: 0 }; MAX_COORDS];
        for (c, cc) in coords.iter_mut().enumerate().take(self.coords.len()) {
            *cc = CoordColumn {
                col: 12 + c,
                slot: self.coord_slot + per * c,
            };
        }
        (blocks, nb, coords)
    }

    /// What a converged step tells of the joint (see [`JointStep`]), from one evaluation of
    /// its start and end states and its discrete gradient.
    pub fn step_outcome(&self, ctx: &StepCtx, y: &[f64]) -> JointStep {
        let buf = self.gather(y);
        let yl = &buf[..self.unknowns.len()];
        let si = self.state_i(ctx);
        let (sf, _) = self.state_f(&si, &si, yl);
        let mut values = [0.0; MAX_ROWS];
        self.law.value(&sf, &mut values);
        let mut bd = zero_rows::<f64>();
        self.law.discrete_gradient(&si, &sf, &mut bd);
        let lam = self.multipliers(ctx, yl, false);
        let work = self.gradient_work(&bd, &lam, &si, &sf, yl);
        // Statics: the forces of B(q_f) in the end frame; a step's: of B^D, step averages in
        // the mid-step frame.
        let reaction = if ctx.is_static() {
            self.reaction(&self.rate_rows_at(&sf), &lam, &sf, sf.r[1])
        } else {
            let mid = crate::math::rotation::orthonormalize(&(si.r[1] + sf.r[1]).scale_f(0.5));
            self.reaction(&bd, &lam, &sf, mid)
        };
        JointStep {
            values,
            work,
            reaction,
        }
    }

    /// The work `λ·(B^D Δ)` of the constraint forces over the step
    /// ([`equations::gradient_times_increment`] over the joint's columns).
    fn gradient_work(
        &self,
        bd: &Rows<f64>,
        lam: &[f64; MAX_ROWS],
        si: &JointState<f64>,
        sf: &JointState<f64>,
        yl: &[f64],
    ) -> f64 {
        let (blocks, nb, coords) = self.columns(si, sf);
        let map = ColumnMap {
            nodes: &blocks[..nb],
            coords: &coords[..self.coords.len()],
            mult: self.mult_slot,
            per: self.per,
            n_rows: self.n_rows(),
        };
        let mut bd_delta = [0.0; MAX_ROWS];
        equations::gradient_times_increment(&map, bd, yl, &mut bd_delta);
        (0..self.n_rows()).map(|r| lam[r] * bd_delta[r]).sum()
    }

    /// The reaction `−bᵀλ` on node2's side as force and moment about the joint point at the
    /// end state `sf` (inertial), and the joint frame on node2's side when node2 has the
    /// rotation `r2`.
    fn reaction(
        &self,
        b: &Rows<f64>,
        lam: &[f64; MAX_ROWS],
        sf: &JointState<f64>,
        r2: M3<f64>,
    ) -> (V3<f64>, V3<f64>, M3<f64>) {
        let at2 = self.law.attachments()[1];
        let mut g = [0.0; NCOL];
        for (c, gc) in g.iter_mut().enumerate() {
            for r in 0..self.n_rows() {
                *gc -= b[r][c] * lam[r];
            }
        }
        let f = v3(&g, 6);
        let m_node = v3(&g, 9);
        let arm = sf.r[1].mul_v(&at2.offset);
        (f, m_node - arm.cross(&f), r2.mul_m(&at2.triad))
    }

    /// Constraint values at a state (for the violation sensor).
    pub fn values_at(&self, state: &crate::state::State) -> [f64; MAX_ROWS] {
        let (_, s) = self.rate_rows(state);
        let mut c = [0.0; MAX_ROWS];
        self.law.value(&s, &mut c);
        c
    }

    /// The velocity-level rows at a state, as (local row, term) pairs.
    pub fn rate_terms(&self, state: &crate::state::State, out: &mut Vec<(usize, RateTerm)>) {
        let (b, _) = self.rate_rows(state);
        for (r, row) in b.iter().enumerate().take(self.n_rows()) {
            for (k, side) in self.sides.iter().enumerate() {
                if let Side::Node(node) = side {
                    out.push((
                        r,
                        RateTerm::Node {
                            node: *node,
                            v: v3(row, 6 * k),
                            omega: v3(row, 6 * k + 3),
                        },
                    ));
                }
            }
            for (c, &coord) in self.coords.iter().enumerate() {
                out.push((
                    r,
                    RateTerm::Coord {
                        coord,
                        value: row[12 + c],
                    },
                ));
            }
        }
    }

    /// Velocity-level rows of the constraint at a state (for initial-velocity projection).
    pub fn rate_rows(&self, state: &crate::state::State) -> (Rows<f64>, JointState<f64>) {
        let ctx_nodes = |k: usize| match self.sides[k] {
            Side::Node(a) => (state.nodes[a].x, state.nodes[a].r),
            Side::Ground { x, r } => (x, r),
        };
        let (x0, r0) = ctx_nodes(0);
        let (x1, r1) = ctx_nodes(1);
        let mut q = [0.0; MAX_COORDS];
        for (c, &g) in self.coords.iter().enumerate() {
            q[c] = state.coords[g];
        }
        let s = JointState::new([x0, x1], [r0, r1], q, self.law.attachments());
        (self.rate_rows_at(&s), s)
    }

    /// The rate operator `B(q)` at joint state `s`.
    fn rate_rows_at<T: Real>(&self, s: &JointState<T>) -> Rows<T> {
        let mut b = zero_rows();
        self.law.rate(s, &mut b);
        b
    }
}

impl Kernel for JointKernel {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
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

impl StepEquations<NCOL> for JointKernel {
    fn translations_linear(&self) -> bool {
        self.law.affine_in_translations()
    }

    fn geometric_slots(&self, _ctx: &StepCtx, out: &mut [usize; NCOL]) -> usize {
        let mut g = 0;
        let first = if self.translations_linear() { 3 } else { 0 };
        for d in self.slots.iter().filter_map(|s| s.delta) {
            for c in first..6 {
                out[g] = d + c;
                g += 1;
            }
        }
        for c in 0..self.coords.len() {
            out[g] = self.coord_slot + self.per * c;
            g += 1;
        }
        g
    }

    fn with_equations<T: Real, R>(
        &self,
        ctx: &StepCtx,
        y: &[T],
        f: impl FnOnce(&ColumnMap<T>, &ConstraintTerms<T, NCOL>) -> R,
    ) -> R {
        let n = self.n_rows();
        let si64 = self.state_i(ctx);
        let si = si64.lift::<T>();
        let (sf, _) = self.state_f(&si64, &si, y);
        let (blocks, nb, coords) = self.columns(&si, &sf);
        let map = ColumnMap {
            nodes: &blocks[..nb],
            coords: &coords[..self.coords.len()],
            mult: self.mult_slot,
            per: self.per,
            n_rows: n,
        };
        let mut c = [T::zero(); MAX_ROWS];
        self.law.value(&sf, &mut c);
        let mut b = zero_rows::<T>();
        if ctx.is_static() {
            self.law.rate(&sf, &mut b);
        } else {
            self.law.discrete_gradient(&si, &sf, &mut b);
        }
        // Only ED needs the rate operators (buffers of duals are costly to zero); they are
        // built in place, not moved out of a closure. B(q_i) is a constant of the step.
        let (b_i, b_f);
        let rates = if ctx.ed() {
            b_i = self.rate_rows_at(&si64);
            b_f = self.rate_rows_at(&sf);
            Some((&b_i, &b_f))
        } else {
            None
        };
        let terms = ConstraintTerms {
            c_f: &c[..n],
            b: &b,
            rates,
        };
        f(&map, &terms)
    }
}

#[cfg(test)]
pub mod law_tests {
    //! Generic checks every joint law must pass: exactness of its discrete gradient
    //! (`C_f − C_i = B^D Δ` for large increments) and its rate operator against a
    //! finite-difference derivative of `C` along a motion.
    use super::*;
    use crate::math::rotation::{cayley, exp_map};

    /// Generic attachments (offsets and tilted triads) for the law tests.
    pub fn attachments() -> [Attachment; 2] {
        [
            Attachment {
                offset: V3([0.3, -0.2, 0.5]),
                triad: exp_map(&V3([0.1, 0.2, 0.3])),
            },
            Attachment {
                offset: V3([-0.4, 0.1, 0.2]),
                triad: exp_map(&V3([0.0, -0.5, 0.3])),
            },
        ]
    }

    pub fn random_state(seed: f64, nq: usize, at: &[Attachment; 2]) -> JointState<f64> {
        let s = |k: f64| ((seed + k) * 12.9898).sin() * 1.3;
        let mut q = [0.0; MAX_COORDS];
        for (c, qc) in q.iter_mut().enumerate().take(nq) {
            *qc = s(20.0 + c as f64);
        }
        JointState::new(
            [V3([s(1.0), s(2.0), s(3.0)]), V3([s(4.0), s(5.0), s(6.0)])],
            [
                exp_map(&V3([s(7.0), s(8.0), s(9.0)])),
                exp_map(&V3([s(10.0), s(11.0), s(12.0)])),
            ],
            q,
            at,
        )
    }

    /// Checks a law; returns (discrete-gradient error, rate error).
    pub fn check_law<L: ConstraintLaw>(law: &L) -> (f64, f64) {
        let nq = law.n_coords();
        let n = law.n_rows();
        let mut worst_d = 0.0f64;
        let mut worst_r = 0.0f64;
        for trial in 0..20 {
            let at = law.attachments();
            let si = random_state(trial as f64, nq, at);
            // Large increments (rotations up to ~100°) to show the identity is exact, not a
            // linearisation.
            let inc = random_state(100.0 + trial as f64, nq, at);
            let rho = [inc.x[0].scale_f(0.8), inc.x[1].scale_f(0.8)];
            let dx = [inc.x[1], inc.x[0]];
            let mut sf = si;
            for k in 0..2 {
                let r = cayley(&rho[k]).mul_m(&si.r[k]);
                sf.set_side(k, si.x[k] + dx[k], r, &at[k]);
            }
            for c in 0..nq {
                sf.q[c] = si.q[c] + inc.q[c];
            }
            let mut b = zero_rows::<f64>();
            law.discrete_gradient(&si, &sf, &mut b);
            let (mut cf, mut ci) = ([0.0; MAX_ROWS], [0.0; MAX_ROWS]);
            law.value(&sf, &mut cf);
            law.value(&si, &mut ci);
            for r in 0..n {
                let mut bd = 0.0;
                for k in 0..2 {
                    for c in 0..3 {
                        bd += b[r][6 * k + c] * dx[k].0[c] + b[r][6 * k + 3 + c] * rho[k].0[c];
                    }
                }
                for c in 0..nq {
                    bd += b[r][12 + c] * inc.q[c];
                }
                worst_d = worst_d.max((cf[r] - ci[r] - bd).abs());
            }
            // Rate: Ċ along x(t) = x + t v, R(t) = exp(t ω̃) R, q(t) = q + t q̇.
            let vel = random_state(200.0 + trial as f64, nq, at);
            let mut rb = zero_rows::<f64>();
            law.rate(&si, &mut rb);
            let eps = 1e-6;
            let moved = |t: f64| {
                let mut s = si;
                for k in 0..2 {
                    let r = exp_map(&vel.x[1 - k].scale_f(t)).mul_m(&si.r[k]);
                    s.set_side(k, si.x[k] + vel.x[k].scale_f(t), r, &at[k]);
                }
                for c in 0..nq {
                    s.q[c] = si.q[c] + t * vel.q[c];
                }
                s
            };
            let (mut cp, mut cm) = ([0.0; MAX_ROWS], [0.0; MAX_ROWS]);
            law.value(&moved(eps), &mut cp);
            law.value(&moved(-eps), &mut cm);
            for r in 0..n {
                let mut bv = 0.0;
                for k in 0..2 {
                    for c in 0..3 {
                        bv += rb[r][6 * k + c] * vel.x[k].0[c]
                            + rb[r][6 * k + 3 + c] * vel.x[1 - k].0[c];
                    }
                }
                for c in 0..nq {
                    bv += rb[r][12 + c] * vel.q[c];
                }
                worst_r = worst_r.max(((cp[r] - cm[r]) / (2.0 * eps) - bv).abs());
            }
        }
        (worst_d, worst_r)
    }

    /// Tolerances: the discrete gradient is an algebraic identity (round-off, ~1e-14 for O(1)
    /// data); the rate is compared with a central difference (truncation ~1e-12, round-off
    /// ~1e-10).
    pub fn assert_law<L: ConstraintLaw>(law: &L) {
        let (d, r) = check_law(law);
        assert!(d < 1e-13, "discrete gradient not exact: {d:e}");
        assert!(r < 1e-8, "rate operator wrong: {r:e}");
        if law.affine_in_translations() {
            let a = affine_defect(law);
            assert!(a < 1e-13, "not affine in the translations: {a:e}");
        }
        let k = stiffness_defect(law);
        // Closed form against a dual derivative of the same arithmetic: round-off of O(1)
        // entries.
        assert!(k < 1e-13, "force stiffness wrong: {k:e}");
        let k = rate_stiffness_defect(law);
        assert!(
            k < 1e-13,
            "rate stiffness is not twice the force stiffness: {k:e}"
        );
        if let Some(row) = law.coincident_point_rows() {
            let p = point_rows_defect(law, row);
            assert!(
                p < 1e-14,
                "rows {row}.. are not the point separation: {p:e}"
            );
        }
    }

    /// The largest difference, relative to its largest entry, between a law's closed-form
    /// `force_stiffness` and the dual derivative of `B^D(s_i, s_f)ᵀλ` over the end state's
    /// spatial variations (`x + δx`, `(I + θ̃) R`, `q + δq`), over random states and
    /// multipliers.
    pub fn stiffness_defect<L: ConstraintLaw>(law: &L) -> f64 {
        stiffness_defect_of(law, false)
    }

    /// The same for the rate operator at one state against `2 K(s, s, λ)`: `B(s) = B^D(s, s)`
    /// with forms symmetric in the two states, so `∂(B(s)ᵀλ)/∂z` is twice the stiffness of
    /// the end state alone (what ED's rate operators' stiffness can be built from).
    pub fn rate_stiffness_defect<L: ConstraintLaw>(law: &L) -> f64 {
        stiffness_defect_of(law, true)
    }

    fn stiffness_defect_of<L: ConstraintLaw>(law: &L, rate: bool) -> f64 {
        use crate::math::scalar::Dual;
        type D = Dual<NCOL>;
        let (nq, at) = (law.n_coords(), law.attachments());
        let mut worst = 0.0f64;
        for trial in 0..10 {
            let sf = random_state(trial as f64 + 0.37, nq, at);
            let si = if rate {
                sf
            } else {
                random_state(trial as f64, nq, at)
            };
            let lam: Vec<f64> = (0..law.n_rows())
                .map(|r| ((trial * 7 + r) as f64 * 1.7).cos() * 40.0)
                .collect();
            let seeded = |v: &V3<f64>, c0: usize| {
                V3(std::array::from_fn(|c| D::seeded(v.0[c], Some(c0 + c))))
            };
            let side = |k: usize| {
                let theta = seeded(&V3::zero(), 6 * k + 3);
                let r = M3::from_f64(&sf.r[k]) + theta.tilde().mul_m(&M3::from_f64(&sf.r[k]));
                (seeded(&sf.x[k], 6 * k), r)
            };
            let ((x0, r0), (x1, r1)) = (side(0), side(1));
            let q = std::array::from_fn(|c| D::seeded(sf.q[c], Some(12 + c)));
            let sfd = JointState::new([x0, x1], [r0, r1], q, at);
            let mut b = [[D::constant(0.0); NCOL]; MAX_ROWS];
            if rate {
                law.rate(&sfd, &mut b);
            } else {
                law.discrete_gradient(&si.lift(), &sfd, &mut b);
            }
            let mut k = [[0.0; NCOL]; NCOL];
            law.force_stiffness(&si, &sf, &lam, &mut k);
            let factor = if rate { 2.0 } else { 1.0 };
            let mut scale = 0.0f64;
            let mut diff = 0.0f64;
            for (c, k_row) in k.iter().enumerate() {
                let mut g = D::constant(0.0);
                for (r, l) in lam.iter().enumerate() {
                    g += b[r][c] * *l;
                }
                for (dual, closed) in g.du.iter().zip(k_row) {
                    scale = scale.max(dual.abs());
                    diff = diff.max((dual - factor * closed).abs());
                }
            }
            worst = worst.max(diff / scale.max(1.0));
        }
        worst
    }

    /// For a law that claims coincident-point rows at `row`: the largest difference between
    /// those rows of `C` and `x₂ + R₂p₂ − x₁ − R₁p₁` over random states.
    pub fn point_rows_defect<L: ConstraintLaw>(law: &L, row: usize) -> f64 {
        let (nq, at) = (law.n_coords(), law.attachments());
        let mut worst = 0.0f64;
        for trial in 0..10 {
            let s = random_state(trial as f64, nq, at);
            let mut c = [0.0; MAX_ROWS];
            law.value(&s, &mut c);
            let d = kinematics::point(&s, 1) - kinematics::point(&s, 0);
            for k in 0..3 {
                worst = worst.max((c[row + k] - d.0[k]).abs());
            }
        }
        worst
    }

    /// For a law that claims `affine_in_translations`: moving both sides' positions (not
    /// their rotations) changes `C` by exactly `B[:, x]·d` and neither `B^D` nor `B`, and the
    /// translation columns of both are the same. Returns the largest defect (round-off of
    /// O(1) data, ~1e-15, for a true claim; O(1) for a projection on a moving axis).
    pub fn affine_defect<L: ConstraintLaw>(law: &L) -> f64 {
        let (n, nq, at) = (law.n_rows(), law.n_coords(), law.attachments());
        let mut worst = 0.0f64;
        for trial in 0..10 {
            let si = random_state(trial as f64, nq, at);
            let sf = random_state(50.0 + trial as f64, nq, at);
            let d = random_state(100.0 + trial as f64, nq, at).x;
            let shift = |s: &JointState<f64>| {
                let mut m = *s;
                for k in 0..2 {
                    m.set_side(k, s.x[k] + d[k], s.r[k], &at[k]);
                }
                m
            };
            let (sim, sfm) = (shift(&si), shift(&sf));
            let (mut b, mut bm) = (zero_rows::<f64>(), zero_rows::<f64>());
            law.discrete_gradient(&si, &sf, &mut b);
            law.discrete_gradient(&sim, &sfm, &mut bm);
            let (mut rb, mut rbm) = (zero_rows::<f64>(), zero_rows::<f64>());
            law.rate(&sf, &mut rb);
            law.rate(&sfm, &mut rbm);
            let (mut c, mut cm) = ([0.0; MAX_ROWS], [0.0; MAX_ROWS]);
            law.value(&sf, &mut c);
            law.value(&sfm, &mut cm);
            for r in 0..n {
                let mut moved = 0.0;
                for k in 0..2 {
                    for j in 0..3 {
                        moved += rb[r][6 * k + j] * d[k].0[j];
                        worst = worst.max((b[r][6 * k + j] - rb[r][6 * k + j]).abs());
                    }
                }
                worst = worst.max((cm[r] - c[r] - moved).abs());
                for col in 0..NCOL {
                    worst = worst.max((bm[r][col] - b[r][col]).abs());
                    worst = worst.max((rbm[r][col] - rb[r][col]).abs());
                }
            }
        }
        worst
    }

    #[test]
    fn a_projection_is_not_a_point_separation() {
        // The check must be able to fail: a prismatic joint's first rows project the
        // separation on side 1's triad.
        let law = prismatic::Prismatic { at: attachments() };
        assert!(point_rows_defect(&law, 0) > 1e-3);
    }

    #[test]
    fn projections_are_not_affine_in_the_translations() {
        // The check must be able to fail: a prismatic joint's projection on a moving axis.
        let law = prismatic::Prismatic { at: attachments() };
        assert!(affine_defect(&law) > 1e-3);
    }
}

#[cfg(test)]
mod kernel_tests {
    //! Every joint kernel's tangent against central differences of its residual, for EP and
    //! ED, with one side a node and the other a node or the ground.
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Scheme;
    use crate::math::rotation::exp_map;
    use crate::state::{NodeState, State};

    fn laws() -> Vec<JointLaw> {
        let at = super::law_tests::attachments();
        vec![
            JointLaw::Spherical(spherical::Spherical { at }),
            JointLaw::Universal(universal::Universal { at }),
            JointLaw::Revolute(revolute::Revolute { at }),
            JointLaw::Clamp(clamp::Clamp { at }),
            JointLaw::Prismatic(prismatic::Prismatic { at }),
            JointLaw::Cylindrical(cylindrical::Cylindrical { at }),
            JointLaw::Screw(screw::Screw {
                cylinder: cylindrical::Cylindrical { at },
                pitch: 0.02,
            }),
        ]
    }

    /// Two moving, rotated nodes and two coordinates with rates: a state without symmetry.
    fn generic_state() -> State {
        let node = |k: f64| NodeState {
            x: V3([0.1 * k, -0.2, 0.3 * k]),
            r: exp_map(&V3([0.4 * k, -0.2, 0.9])),
            v: V3([1.0, -2.0 * k, 0.5]),
            w: V3([0.3, 5.0, -k]),
        };
        State {
            t: 0.1,
            nodes: vec![node(1.0), node(-0.7)],
            coords: vec![0.3, -1.1],
            coord_rates: vec![-0.8, 0.6],
            lambda: vec![],
            history: vec![],
        }
    }

    /// Node 0 and node 1, or a tilted ground pose and node 1.
    fn generic_sides(ground: bool) -> [Side; 2] {
        if ground {
            [
                Side::Ground {
                    x: V3([0.5, 0.0, 0.1]),
                    r: exp_map(&V3([0.2, 0.1, 0.0])),
                },
                Side::Node(1),
            ]
        } else {
            [Side::Node(0), Side::Node(1)]
        }
    }

    /// A 10 ms step from t = 0.1 s with scale 30 (statics at `statics`), at `state`.
    fn step_ctx(layout: Layout, state: &State, statics: Option<f64>) -> StepCtx<'_> {
        StepCtx {
            layout,
            h: 0.01,
            t_i: 0.1,
            t_f: 0.11,
            s: 30.0,
            state,
            gravity: V3([0.0; 3]),
            statics,
        }
    }

    #[test]
    fn joint_tangents_match_finite_differences() {
        let state = generic_state();
        // Time steps of both schemes, and static solves (EP layout).
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            for law in laws() {
                for ground in [false, true] {
                    let nq = law.n_coords();
                    let nr = law.n_rows();
                    let layout = Layout::new(scheme, 2, nq, nr);
                    let sides = generic_sides(ground);
                    let kind = format!("{scheme:?} statics={statics:?} {law:?} ground={ground}");
                    let k = JointKernel::new(
                        "j".into(),
                        law.clone(),
                        sides,
                        (0..nq).collect(),
                        0,
                        &layout,
                    );
                    let ctx = step_ctx(layout, &state, statics);
                    let y: Vec<f64> = (0..layout.n_unknowns())
                        .map(|i| 0.02 * ((i as f64) * 1.3).sin())
                        .collect();
                    let e = tangent_error(&k, &ctx, &y);
                    // Same bound as the other kernels: FD truncation and round-off, relative to |J|.
                    assert!(e < 1e-7, "{kind}: tangent error {e:e}");
                }
            }
        }
    }

    /// The closed-form tangent ([`closed_tangent`]) is the dual pass's, EP's and ED's
    /// decoupled surrogate alike, for every law to a node and to the ground at a state with
    /// loaded multipliers: the same derivatives by other arithmetic, so round-off only.
    #[test]
    fn closed_form_tangent_is_the_dual_pass_tangent() {
        let state = generic_state();
        for scheme in [Scheme::Ep, Scheme::Ed] {
            for law in laws() {
                for ground in [false, true] {
                    let (nq, nr) = (law.n_coords(), law.n_rows());
                    let layout = Layout::new(scheme, 2, nq, nr);
                    let k = JointKernel::new(
                        "j".into(),
                        law.clone(),
                        generic_sides(ground),
                        (0..nq).collect(),
                        0,
                        &layout,
                    );
                    let ctx = step_ctx(layout, &state, None);
                    let y: Vec<f64> = (0..layout.n_unknowns())
                        .map(|i| {
                            0.02 * ((i as f64) * 1.3).sin() + 0.5 * f64::from(i >= layout.mult(0))
                        })
                        .collect();
                    let n = k.unknowns().len();
                    let pos = crate::elements::own_block_positions(n);
                    let (mut jc, mut jd) = (vec![0.0; n * n], vec![0.0; n * n]);
                    let (mut rc, mut rd) = (vec![0.0; y.len()], vec![0.0; y.len()]);
                    if scheme == Scheme::Ep {
                        k.evaluate(&ctx, &y, &mut rc, Some((&mut jc, &pos)));
                        equations::evaluate_constraint(
                            &k,
                            &ctx,
                            &y,
                            &mut rd,
                            Some((&mut jd, &pos)),
                        );
                    } else {
                        k.evaluate_decoupled(&ctx, &y, &mut rc, &mut jc, &pos);
                        // The border refresh's tangent-only evaluation: the same entries.
                        let mut alone = vec![0.0; n * n];
                        let mut scratch = vec![0.0; y.len()];
                        k.decoupled_tangent(&ctx, &y, &mut scratch, &mut alone, &pos);
                        assert_eq!(alone, jc, "{law:?} ground={ground}: tangent alone");
                        equations::evaluate_constraint_decoupled(
                            &k, &ctx, &y, &mut rd, &mut jd, &pos,
                        );
                    }
                    let kind = format!("{scheme:?} {law:?} ground={ground}");
                    closed_tangent::assert_same_evaluation((&rc, &jc), (&rd, &jd), &kind);
                }
            }
        }
    }

    /// ED's decoupled evaluation of a joint ([`equations::evaluate_constraint_decoupled`]) is
    /// ED's residual with EP's tangent of the same joint at the same increments and
    /// multipliers mapped into the rows the decoupled system reads: the f-rows' λ columns and
    /// the constraint rows' increment columns as they are, the f-rows' increment columns as
    /// `−4/9` of them on the j-rows' increment columns and `1/9` on their jump columns; nothing
    /// else. Every law, to a node and to the ground, at a generic state with loaded
    /// multipliers.
    /// What an ED unknown is: an increment, a jump, a multiplier or a multiplier's jump.
    #[derive(Clone, Copy, PartialEq)]
    enum Kind {
        Delta,
        Jump,
        Lambda,
        LambdaD,
    }

    /// Each ED unknown's kind and its EP twin, for two nodes, `nq` coordinates, `nr` rows.
    fn ed_twins(ed: &Layout, ep: &Layout, nq: usize, nr: usize) -> Vec<(Kind, usize)> {
        let mut twin = vec![(Kind::Delta, 0); ed.n_unknowns()];
        for a in 0..2 {
            for c in 0..6 {
                twin[ed.node_delta(a) + c] = (Kind::Delta, ep.node_delta(a) + c);
                twin[ed.node_jump(a) + c] = (Kind::Jump, ep.node_delta(a) + c);
            }
        }
        for c in 0..nq {
            twin[ed.coord_delta(c)] = (Kind::Delta, ep.coord_delta(c));
            twin[ed.coord_jump(c)] = (Kind::Jump, ep.coord_delta(c));
        }
        for r in 0..nr {
            twin[ed.mult(r)] = (Kind::Lambda, ep.mult(r));
            twin[ed.mult_jump(r)] = (Kind::LambdaD, ep.mult(r));
        }
        twin
    }

    #[test]
    fn decoupled_surrogate_is_the_ep_tangent_mapped() {
        let state = generic_state();
        for law in laws() {
            for ground in [false, true] {
                let (nq, nr) = (law.n_coords(), law.n_rows());
                let ed = Layout::new(Scheme::Ed, 2, nq, nr);
                let ep = Layout::new(Scheme::Ep, 2, nq, nr);
                let twin = ed_twins(&ed, &ep, nq, nr);
                let sides = generic_sides(ground);
                let kernel = |layout: &Layout| {
                    JointKernel::new("j".into(), law.clone(), sides, (0..nq).collect(), 0, layout)
                };
                let ctx = |layout: Layout| step_ctx(layout, &state, None);
                let y_ed: Vec<f64> = (0..ed.n_unknowns())
                    .map(|i| 0.02 * ((i as f64) * 1.3).sin() + 0.5 * f64::from(i >= ed.mult(0)))
                    .collect();
                let mut y_ep = vec![0.0; ep.n_unknowns()];
                for (i, &(kind, j)) in twin.iter().enumerate() {
                    if kind == Kind::Delta || kind == Kind::Lambda {
                        y_ep[j] = y_ed[i];
                    }
                }
                // Dense global tangents through identity positions.
                let dense = |k: &JointKernel| -> (Vec<ValuePos>, usize) {
                    let n = k.unknowns().len();
                    (crate::elements::own_block_positions(n), n)
                };
                let k_ep = kernel(&ep);
                let (pos, n_ep) = dense(&k_ep);
                let mut j_ep = vec![0.0; n_ep * n_ep];
                let mut r_ep = vec![0.0; ep.n_unknowns()];
                k_ep.evaluate(&ctx(ep), &y_ep, &mut r_ep, Some((&mut j_ep, &pos)));
                let ep_at = |gi: usize, gj: usize| {
                    let u = k_ep.unknowns();
                    match (
                        u.iter().position(|&g| g == gi),
                        u.iter().position(|&g| g == gj),
                    ) {
                        (Some(a), Some(b)) => j_ep[a * n_ep + b],
                        _ => 0.0,
                    }
                };
                let k_ed = kernel(&ed);
                let (pos, n) = dense(&k_ed);
                let mut dec = vec![0.0; n * n];
                let mut r_dec = vec![0.0; ed.n_unknowns()];
                k_ed.evaluate_decoupled(&ctx(ed), &y_ed, &mut r_dec, &mut dec, &pos);
                let mut r_exact = vec![0.0; ed.n_unknowns()];
                k_ed.evaluate(&ctx(ed), &y_ed, &mut r_exact, None);
                let kind = format!("{law:?} ground={ground}");
                assert_eq!(r_dec, r_exact, "{kind}: the residual is ED's");
                let scale = j_ep.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let u = k_ed.unknowns();
                for (a, &gi) in u.iter().enumerate() {
                    for (b, &gj) in u.iter().enumerate() {
                        let ((ki, ei), (kj, ej)) = (twin[gi], twin[gj]);
                        let expected = match (ki, kj) {
                            (Kind::Delta, Kind::Lambda) | (Kind::Lambda, Kind::Delta) => {
                                ep_at(ei, ej)
                            }
                            (Kind::Jump, Kind::Delta) => -4.0 / 9.0 * ep_at(ei, ej),
                            (Kind::Jump, Kind::Jump) => ep_at(ei, ej) / 9.0,
                            _ => 0.0,
                        };
                        let got = dec[a * n + b];
                        // Both from one dual pass over the same arithmetic: round-off only.
                        assert!(
                            (got - expected).abs() <= 1e-12 * scale,
                            "{kind}: row {gi} col {gj}: decoupled {got:e}, expected {expected:e}"
                        );
                    }
                }
            }
        }
    }
}

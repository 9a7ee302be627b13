//! Coulomb friction on a joint's sliding motion: prismatic, cylindrical and screw joints, and
//! the sliding family (a follower on a beam).
//!
//! The joint's **slip** `u` is a function of its relative coordinates: Δ (prismatic,
//! cylindrical), the arc length `L η(ζ)` along the beam (sliding joints), the length along a
//! screw's helix `Δ sin α + r φ cos α` (lead angle α, thread radius r). The **normal force**
//! `N` comes from the joint's own constraint forces (the multipliers normal to the slip), plus
//! a preload. The friction force `F` on the slip is one extra multiplier with its own row,
//! which holds one of two equations, the joint's *mode* for the step:
//!
//! - **stick**: `u_f = u_hold`, a scleronomic constraint on the coordinates (the generic EP/ED
//!   equations of a drive with a constant target; ED adds its velocity-level row) — stiction is
//!   exact, nothing creeps. `F` is whatever holds the joint.
//! - **slip** in direction `d = ±1`: `F = d μk N + c Δu/h` (c the viscous coefficient). `N` is
//!   the step's mean constraint force, as every multiplier is.
//!
//! `F` acts on the coordinates through the exact secant of `u` (`Σ a_k Δq_k = u_f − u_i`), so
//! its work over a step is exactly `−F Δu`: zero while sticking, `−(μk N |Δu| + c Δu²/h) ≤ 0`
//! while slipping in the direction the mode assumed — which the simulation checks before
//! accepting a step (`simulation/stick_slip.rs`: a step that stops or reverses inside is
//! shortened to the stop, a sticking joint whose force exceeds μs N breaks away). So friction
//! never adds energy, and the discrete energy identity closes with its work as one more term.
//!
//! The mode lives in the element's history (`State::history`, [`HISTORY_LEN`] slots), like a
//! beam's path-dependent Gauss-point triads: it belongs to the state a step starts from.
//! Statics leave friction out (`F = 0`: a static equilibrium with friction is not unique).

use crate::beam::path::ArcMap;
use crate::elements::{eval_kernel, tangent_structure, Kernel, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::scalar::Real;
use crate::math::vec3::V3;
use crate::state::State;

/// History slots: mode (0 stick, ±1 slipping towards ±u), the held slip position (m) while
/// sticking, and the last sticking step's force ratio |F|/(μs N) (−1: unknown) and length (s).
pub const HISTORY_LEN: usize = 4;

/// A sticking step's force ratio |F|/(μs N) — a mean over the step, so the value at its
/// middle — and the step's length (s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StickRatio {
    pub value: f64,
    pub step: f64,
}

/// History code of a joint that cannot stick while its prescribed slip rests (no friction).
const IDLE: f64 = 2.0;

/// Most unknowns of a friction kernel: two coordinates and their jumps, four normal-force
/// multipliers, its own pair.
const MAX_UNKNOWNS: usize = 10;
/// Row-major positions of a block in itself.
const BLOCK_POSITIONS: [ValuePos; MAX_UNKNOWNS * MAX_UNKNOWNS] = {
    let mut p = [0; MAX_UNKNOWNS * MAX_UNKNOWNS];
    let mut i = 0;
    while i < p.len() {
        p[i] = i as ValuePos;
        i += 1;
    }
    p
};

/// An event closer than this fraction of the step to its start is taken at the start.
pub const MIN_EVENT_FRACTION: f64 = 1e-3;

/// How far above 1 a sticking step's force ratio |F|/(μs N) may end when it breaks away at
/// the step's end: placing the breakaway closer takes steps so short that their mean forces
/// are no better known.
const BREAKAWAY_RATIO: f64 = 1e-2;

/// A slip rate this fraction of the step's starting rate, and falling, ends the step stopped.
const STOPPED_RATE: f64 = 0.1;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// The joint holds its slip at `hold` (m).
    Stick { hold: f64 },
    /// The joint slides towards `direction` (±1) of its slip.
    Slip { direction: f64 },
}

/// The friction law's coefficients.
#[derive(Clone, Copy, Debug)]
pub struct Coefficients {
    /// μs, μk (–).
    pub static_: f64,
    pub kinetic: f64,
    /// N·s/m of slip rate, while slipping.
    pub viscous: f64,
    /// N, added to the joint's normal force.
    pub preload: f64,
}

/// How the slip `u` (m) follows from the joint's coordinates (at most two).
#[derive(Clone, Debug)]
pub enum Slip {
    /// `u = Σ w_k q_k`.
    Linear { weights: [f64; 2] },
    /// `u = L η(ζ)`: arc length along a beam's reference line.
    Arc { map: ArcMap, length: f64 },
}

impl Slip {
    fn value<T: Real>(&self, q: [T; 2]) -> T {
        match self {
            Slip::Linear { weights } => q[0] * weights[0] + q[1] * weights[1],
            Slip::Arc { map, length } => {
                let (e, eta0, slope) = map.piece(q[0].re());
                (q[0] - e) * (slope * length) + eta0 * length
            }
        }
    }

    /// Coefficients `a` with `Σ a_k (q_f − q_i)_k = u(q_f) − u(q_i)` exactly: the weights, or
    /// along a beam the mean slope of the piecewise-linear η(ζ) over [ζ_i, ζ_f] (a weighted
    /// sum of the pieces' slopes, no quotient of differences).
    fn secant<T: Real>(&self, qi: [f64; 2], qf: [T; 2]) -> [T; 2] {
        match self {
            Slip::Linear { weights } => [T::cst(weights[0]), T::cst(weights[1])],
            Slip::Arc { map, length } => {
                let (a, b) = (qi[0], qf[0]);
                let (ea, _, sa) = map.piece(a);
                let (eb, _, _) = map.piece(b.re());
                if ea == eb {
                    return [T::cst(sa * length), T::zero()];
                }
                // Pieces between a and b, each weighted by its share of the interval.
                let (lo, hi, up) = if b.re() > a {
                    (T::cst(a), b, true)
                } else {
                    (b, T::cst(a), false)
                };
                let width = hi - lo;
                let (first, last) = if up { (ea, eb) } else { (eb, ea) };
                let mut acc = T::zero();
                let mut start = lo;
                let mut e = first;
                while e < last {
                    let end = T::cst(e + 1.0);
                    acc += (end - start) / width * map.piece(e + 0.5).2;
                    start = end;
                    e += 1.0;
                }
                acc += (hi - start) / width * map.piece(last + 0.5).2;
                [acc * *length, T::zero()]
            }
        }
    }

    /// `du/dq_k` at `q` (piecewise constant along a beam).
    fn rates(&self, q: [f64; 2]) -> [f64; 2] {
        match self {
            Slip::Linear { weights } => *weights,
            Slip::Arc { map, length } => [map.piece(q[0]).2 * length, 0.0],
        }
    }
}

/// Where the normal force comes from: constraint rows of the joint (global row numbers),
/// their multipliers being forces (N) or a moment (N·m).
#[derive(Clone, Debug)]
pub enum Normal {
    /// `√(λ_a² + λ_b²)`: forces along two directions normal to the slip (prismatic and
    /// cylindrical: the separation's projections normal to the axis).
    Axes { rows: [usize; 2] },
    /// `|λ| · factor`: a screw thread's row, whose multiplier is the axial load; the thread's
    /// normal force is `1/(cos α cos β)` times it.
    Thread { row: usize, factor: f64 },
    /// `|λ − (λ·t) t|` over three rows whose multipliers are a spatial force: a sliding
    /// joint's contact force normal to the beam's axis `t` (predicted at the step's middle);
    /// with a `thread`, plus the thread's share from the axial load (see [`Thread`]).
    Lateral {
        row: usize,
        axis: V3<f64>,
        thread: Option<Thread>,
    },
}

/// A thread between a sliding joint's follower and the beam (a nut on a jackscrew whose turn
/// the slide's drive stands for): lead angle α at the thread's radius, flank half-angle β.
/// With the axial force on the follower `A = −λ·t` and the friction force F on the slip, the
/// flank's normal force is `N_s = (A + F sin²α)/cos α` (the thread force's axial part is
/// `N_s cos α − f sin α`, its friction `f = F sin α` — the slip along the helix is `ds/sin α`),
/// and friction acts on the slip as `μ N_s/(sin α cos β)`: the normal force's share is
/// `|λ·t − F sin²α|/(cos α sin α cos β)`. A thread holding its load without a drive needs
/// `μs ≥ tan α cos β` (self-locking), exactly; a drive raising a load P at constant speed
/// pays `P tan(α + φ)/tan α` (φ = atan μ), a screw's efficiency.
#[derive(Clone, Copy, Debug)]
pub struct Thread {
    pub sin_lead: f64,
    pub cos_lead: f64,
    pub cos_flank: f64,
}

impl Normal {
    /// The same source with its rows shifted by `row0` (local rows of a joint → global).
    pub fn offset(&self, row0: usize) -> Normal {
        match self {
            Normal::Axes { rows } => Normal::Axes {
                rows: [rows[0] + row0, rows[1] + row0],
            },
            Normal::Thread { row, factor } => Normal::Thread {
                row: row + row0,
                factor: *factor,
            },
            Normal::Lateral { row, axis, thread } => Normal::Lateral {
                row: row + row0,
                axis: *axis,
                thread: *thread,
            },
        }
    }

    fn rows(&self) -> ([usize; 3], usize) {
        match self {
            Normal::Axes { rows } => ([rows[0], rows[1], 0], 2),
            Normal::Thread { row, .. } => ([*row, 0, 0], 1),
            Normal::Lateral { row, .. } => ([*row, row + 1, row + 2], 3),
        }
    }
}

/// One converged step's friction quantities.
#[derive(Clone, Copy, Debug, Default)]
pub struct FrictionStep {
    /// The friction force on the slip (N; it acts as −F on u), and the normal force (N).
    pub force: f64,
    pub normal: f64,
    /// The slip increment Δu (m) and the friction's work `−F Δu` (J, never positive).
    pub slip: f64,
    pub work: f64,
}

/// What a converged step means for a friction's mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Verdict {
    /// The step is consistent with its mode; the next step starts in `next`.
    Holds {
        next: Mode,
        ratio: Option<StickRatio>,
    },
    /// The mode changes at the step's start: redo the step in this mode.
    Switch(Mode),
    /// The mode changes inside the step, at about this fraction of it: redo it that long.
    Shorten(f64),
}

/// Friction on one joint: a kernel on the joint's coordinates, the multipliers its normal
/// force comes from, and its own row.
#[derive(Clone, Debug)]
pub struct Friction {
    /// The joint's name, and its kernel (index in `System::joints`).
    pub joint: String,
    pub kernel: usize,
    pub coefficients: Coefficients,
    pub slip: Slip,
    pub normal: Normal,
    /// A moment row adding `|λ|/r` to the normal force (a sliding screw's twist row), with 1/r.
    pub moment: Option<(usize, f64)>,
    /// The friction force's own constraint row, and its history offset.
    pub row: usize,
    pub history: usize,
    /// Whether the joint can stick: not when its slip is prescribed (a drive, or a mechanism
    /// that moves it), which a stick row would over-constrain.
    pub can_stick: bool,
    /// N: smoothing of the normal force's norm at zero, and the force below which a sticking
    /// joint with no normal force still holds.
    pub force_floor: f64,
    /// m and m/s: a slip increment and a slip rate below which the slip is at rest.
    pub rest_slip: f64,
    pub rest_rate: f64,
    coords: [usize; 2],
    n_coords: usize,
    n_normal: usize,
    per: usize,
    unknowns: Vec<usize>,
}

impl Friction {
    /// A friction on coordinates `coords` (one or two), its own row `row`, its history at
    /// `history`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        joint: String,
        coefficients: Coefficients,
        slip: Slip,
        coords: &[usize],
        normal: Normal,
        moment: Option<(usize, f64)>,
        row: usize,
        history: usize,
        layout: &Layout,
    ) -> Friction {
        let per = if layout.ed() { 2 } else { 1 };
        let mut unknowns = Vec::new();
        for &c in coords {
            unknowns.push(layout.coord_delta(c));
            if layout.ed() {
                unknowns.push(layout.coord_jump(c));
            }
        }
        let (rows, n_rows) = normal.rows();
        let mut n_normal = n_rows;
        unknowns.extend(rows[..n_rows].iter().map(|&r| layout.mult(r)));
        if let Some((r, _)) = moment {
            unknowns.push(layout.mult(r));
            n_normal += 1;
        }
        unknowns.push(layout.mult(row));
        if layout.ed() {
            unknowns.push(layout.mult_jump(row));
        }
        let mut cs = [0; 2];
        cs[..coords.len()].copy_from_slice(coords);
        Friction {
            joint,
            kernel: 0,
            coefficients,
            slip,
            normal,
            moment,
            row,
            history,
            can_stick: true,
            force_floor: 1e-9,
            rest_slip: 1e-14,
            rest_rate: 1e-9,
            coords: cs,
            n_coords: coords.len(),
            n_normal,
            per,
            unknowns,
        }
    }

    /// A sliding joint's friction: the beam's axis at the contact point, normal to which the
    /// contact force presses (set before each step).
    pub fn set_axis(&mut self, t: V3<f64>) {
        if let Normal::Lateral { axis, .. } = &mut self.normal {
            *axis = t;
        }
    }

    /// The joint coordinates the slip depends on.
    pub fn coords(&self) -> &[usize] {
        &self.coords[..self.n_coords]
    }

    fn own(&self) -> usize {
        self.n_coords * self.per + self.n_normal
    }

    /// The coordinates at a state (unused second slot 0).
    fn coords_at(&self, s: &State) -> [f64; 2] {
        let mut q = [0.0; 2];
        for (k, &c) in self.coords().iter().enumerate() {
            q[k] = s.coords[c];
        }
        q
    }

    /// The slip `u` (m) at a state, and its rate (m/s).
    pub fn slip_at(&self, s: &State) -> (f64, f64) {
        let q = self.coords_at(s);
        let b = self.slip.rates(q);
        let rate = self
            .coords()
            .iter()
            .enumerate()
            .map(|(k, &c)| b[k] * s.coord_rates[c])
            .sum();
        (self.slip.value(q), rate)
    }

    /// The stick row's gradient at a state: `du/dq_k` over [`coords`](Self::coords) (with the
    /// slip there).
    pub fn stick_gradient(&self, s: &State) -> (f64, [f64; 2]) {
        let q = self.coords_at(s);
        (self.slip.value(q), self.slip.rates(q))
    }

    /// The mode a step from `s` takes.
    pub fn mode(&self, s: &State) -> Mode {
        let h = &s.history[self.history..self.history + HISTORY_LEN];
        if h[0] == 0.0 {
            Mode::Stick { hold: h[1] }
        } else if h[0] == IDLE {
            Mode::Slip { direction: 0.0 }
        } else {
            Mode::Slip { direction: h[0] }
        }
    }

    /// The last sticking step's force ratio, if known.
    fn last_ratio(&self, s: &State) -> Option<StickRatio> {
        let h = &s.history[self.history..self.history + HISTORY_LEN];
        (h[2] >= 0.0).then_some(StickRatio {
            value: h[2],
            step: h[3],
        })
    }

    /// Writes the mode a step from `s` takes (and the sticking step's ratio it leaves).
    pub fn set_mode(&self, s: &mut State, mode: Mode, ratio: Option<StickRatio>) {
        let h = &mut s.history[self.history..self.history + HISTORY_LEN];
        match mode {
            Mode::Stick { hold } => {
                h[0] = 0.0;
                h[1] = hold;
            }
            Mode::Slip { direction } => {
                h[0] = if direction == 0.0 {
                    IDLE
                } else {
                    direction.signum()
                };
                h[1] = 0.0;
            }
        }
        (h[2], h[3]) = ratio.map_or((-1.0, 0.0), |r| (r.value, r.step));
    }

    /// The mode a run starts in: sliding if the slip already moves (or cannot stick), else
    /// stuck where it is.
    pub fn initial_mode(&self, s: &State) -> Mode {
        let (u, rate) = self.slip_at(s);
        if rate.abs() > self.rest_rate {
            Mode::Slip {
                direction: rate.signum(),
            }
        } else if self.can_stick {
            Mode::Stick { hold: u }
        } else {
            Mode::Slip { direction: 0.0 }
        }
    }

    /// The normal force (N) from the local block.
    fn normal_force<T: Real>(&self, ctx: &StepCtx, y: &[T]) -> T {
        let base = self.n_coords * self.per;
        let l = |k: usize| y[base + k] * ctx.s;
        let eps = self.force_floor;
        // √(x² + ε²): smooth at zero, off by ε²/2x (nothing) where there is a force.
        let norm = |sq: T| (sq + eps * eps).sqrt();
        let mut n = match &self.normal {
            Normal::Axes { .. } => norm(l(0) * l(0) + l(1) * l(1)),
            Normal::Thread { factor, .. } => norm(l(0) * l(0)) * *factor,
            Normal::Lateral { axis, thread, .. } => {
                let f = V3([l(0), l(1), l(2)]);
                let t = V3([T::cst(axis.0[0]), T::cst(axis.0[1]), T::cst(axis.0[2])]);
                let along = f.dot(&t);
                let lateral = norm(f.dot(&f) - along * along);
                match thread {
                    None => lateral,
                    Some(th) => {
                        let friction = y[self.own()] * ctx.s;
                        let flank = along - friction * th.sin_lead.powi(2);
                        let share = th.cos_lead * th.sin_lead * th.cos_flank;
                        lateral + norm(flank * flank) / share
                    }
                }
            }
        };
        if let Some((_, inv_r)) = self.moment {
            let m = l(self.n_normal - 1);
            n += norm(m * m) * inv_r;
        }
        n + self.coefficients.preload
    }

    /// Coordinates at the start, and increments and end values over the block.
    fn increments<T: Real>(&self, ctx: &StepCtx, y: &[T]) -> ([f64; 2], [T; 2], [T; 2]) {
        let qi = self.coords_at(ctx.state);
        let mut dq = [T::zero(); 2];
        let mut qf = [T::zero(); 2];
        for k in 0..self.n_coords {
            dq[k] = y[k * self.per];
            qf[k] = dq[k] + qi[k];
        }
        (qi, dq, qf)
    }

    /// ED's velocity-level multiplier on the coordinates and the stick row's j-condition,
    /// as a drive's with a constant target (see `elements::coordinate::CoordinateDrive`).
    fn rate_rows<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T], stick: bool) {
        let (qi, dq, qf) = self.increments(ctx, y);
        let qf_re = [qf[0].re(), qf[1].re()];
        let (bi, bf) = (self.slip.rates(qi), self.slip.rates(qf_re));
        let own = self.own();
        let md = y[own + 1] * ctx.s;
        let (mut ci, mut cf) = (T::zero(), T::zero());
        for k in 0..self.n_coords {
            r[k * 2] += md * ((bf[k] - bi[k]) / 12.0);
            r[k * 2 + 1] -= md * ((bi[k] + bf[k]) / 12.0);
            let rate_j = y[k * 2 + 1] / ctx.h;
            let rate_f = dq[k] * (2.0 / ctx.h) - rate_j;
            ci += rate_j * bi[k];
            cf += rate_f * bf[k];
        }
        if stick {
            r[own + 1] += (ci - cf) * (ctx.s * ctx.h);
        } else {
            // No velocity condition while slipping: λ_d = 0, written so that ED's decoupled
            // iteration solves it exactly (`integrator::ed_decoupled`).
            r[own + 1] -= md;
        }
    }

    /// The step's friction quantities from the converged unknowns `y` (global).
    pub fn step(&self, ctx: &StepCtx, y: &[f64]) -> FrictionStep {
        let mut local = [0.0; MAX_UNKNOWNS];
        for (l, &g) in local.iter_mut().zip(&self.unknowns) {
            *l = y[g];
        }
        let (qi, dq, qf) = self.increments(ctx, &local);
        let a = self.slip.secant(qi, qf);
        let slip: f64 = (0..self.n_coords).map(|k| a[k] * dq[k]).sum();
        let force = local[self.own()] * ctx.s;
        let normal = if ctx.is_static() {
            0.0
        } else {
            self.normal_force(ctx, &local)
        };
        FrictionStep {
            force,
            normal,
            slip,
            work: -force * slip,
        }
    }

    /// What the converged step from `start` to `end` means for the mode (see [`Verdict`]).
    /// `h` (s) is the step's length.
    pub fn verdict(&self, start: &State, end: &State, step: &FrictionStep, h: f64) -> Verdict {
        match self.mode(start) {
            Mode::Stick { hold } => self.stick_verdict(start, step, hold, h),
            Mode::Slip { direction } => self.slip_verdict(start, end, step, direction),
        }
    }

    /// The mode after an event of this step placed at its start: a sticking joint breaks
    /// away against its force, a slipping one sticks where it was (or slides back when it
    /// cannot stick).
    pub fn after_event(&self, start: &State, step: &FrictionStep) -> Mode {
        match self.mode(start) {
            Mode::Stick { .. } => Mode::Slip {
                direction: if step.force < 0.0 { -1.0 } else { 1.0 },
            },
            Mode::Slip { direction } if !self.can_stick => Mode::Slip {
                direction: -direction,
            },
            Mode::Slip { .. } => Mode::Stick {
                hold: self.slip_at(start).0,
            },
        }
    }

    fn stick_verdict(&self, start: &State, step: &FrictionStep, hold: f64, h: f64) -> Verdict {
        let limit = self.coefficients.static_ * step.normal;
        let ratio = StickRatio {
            value: if limit > 0.0 {
                step.force.abs() / limit
            } else {
                0.0
            },
            step: h,
        };
        if step.force.abs() <= limit * (1.0 + 1e-9) + self.force_floor {
            return Verdict::Holds {
                next: Mode::Stick { hold },
                ratio: Some(ratio),
            };
        }
        // It breaks away towards the slip the stick force was resisting, at the crossing of
        // the ratio through 1, else at the start.
        let direction = step.force.signum();
        let fraction = self
            .last_ratio(start)
            .map_or(0.0, |last| crossing(last, ratio) / h);
        let slip = Mode::Slip { direction };
        // A step whose ratio exceeds 1 by less than the ratio is known to (step means of a
        // very short step carry the force residual's error) has found the crossing.
        if fraction >= 0.95 || ratio.value <= 1.0 + BREAKAWAY_RATIO {
            Verdict::Holds {
                next: slip,
                ratio: Some(ratio),
            }
        } else if fraction < MIN_EVENT_FRACTION {
            Verdict::Switch(slip)
        } else {
            Verdict::Shorten(fraction)
        }
    }

    /// A joint that cannot stick, its prescribed slip at rest or set going: no friction while
    /// it rests (how much of the load the friction would take from the drive is undetermined:
    /// the drive carries it), the kinetic one once it moves.
    fn prescribed_rest(&self, end: &State, step: &FrictionStep, d: f64) -> Option<Verdict> {
        let moving = step.slip.abs() > self.rest_slip;
        if d == 0.0 {
            return Some(if moving {
                Verdict::Switch(Mode::Slip {
                    direction: step.slip.signum(),
                })
            } else {
                Verdict::Holds {
                    next: Mode::Slip { direction: 0.0 },
                    ratio: None,
                }
            });
        }
        let resting = !moving && self.slip_at(end).1.abs() <= self.rest_rate;
        resting.then_some(Verdict::Holds {
            next: Mode::Slip { direction: 0.0 },
            ratio: None,
        })
    }

    fn slip_verdict(&self, start: &State, end: &State, step: &FrictionStep, d: f64) -> Verdict {
        if !self.can_stick {
            if let Some(v) = self.prescribed_rest(end, step, d) {
                return v;
            }
        }
        let (_, rate_i) = self.slip_at(start);
        let (u_f, rate_f) = self.slip_at(end);
        let (vi, vf) = (d * rate_i, d * rate_f);
        let forward = d * step.slip >= 0.0;
        // A slip that ends the step all but stopped, on either side of zero, stopped there:
        // a stop placed by a shortened step lands a hair before or after it, and a hair
        // before must not leave a sliver of a step to place it again. (A prescribed slip
        // goes on: its next step says which way.)
        let stopped = forward && vf < vi && vf.abs() <= STOPPED_RATE * vi;
        if forward && vf >= 0.0 && !(stopped && self.can_stick) {
            return Verdict::Holds {
                next: Mode::Slip { direction: d },
                ratio: None,
            };
        }
        if !forward && !self.can_stick {
            // A prescribed slip went the other way: redo the step slipping that way (its
            // motion hardly depends on the friction). A rate that only touches zero then
            // goes on as it was, where locating a stop would chatter.
            return Verdict::Switch(Mode::Slip { direction: -d });
        }
        // The slip stopped (or turned) inside the step: stick there, or slide back if it
        // cannot stick. The stop is where the slip rate, linear over the step, vanishes.
        let (u_i, _) = self.slip_at(start);
        let stop = |hold| {
            if self.can_stick {
                Mode::Stick { hold }
            } else {
                Mode::Slip { direction: -d }
            }
        };
        let fraction = match vi / (vi - vf) {
            _ if vi <= 0.0 => 0.0,
            // Forward at both ends of a step whose slip went back, the rate turned twice
            // inside it: no line through its ends places the stop, so the step is halved.
            // (The line's zero past the step's end lengthened the step, and the same trial
            // came back for ever: a collar ringing against its end stop on a spinning blade.)
            x if !forward && x >= 1.0 => 0.5,
            x => x,
        };
        if forward && (fraction >= 0.9 || stopped) {
            // Stopped at the step's end, to a residual rate the stick's projection removes.
            Verdict::Holds {
                next: stop(u_f),
                ratio: None,
            }
        } else if fraction < MIN_EVENT_FRACTION {
            Verdict::Switch(stop(u_i))
        } else {
            Verdict::Shorten(fraction)
        }
    }
}

/// Where, in time from the step's start (s), a force ratio that rose from the last sticking
/// step's mean `last` (below 1) to this step's mean `now` (above it) crossed 1: linear between
/// the steps' middles, as means of a smoothly varying ratio are. Zero (at the start) when it
/// did not rise through 1 or crossed before the start.
fn crossing(last: StickRatio, now: StickRatio) -> f64 {
    if last.value >= 1.0 || now.value <= last.value {
        return 0.0;
    }
    let span = 0.5 * (last.step + now.step);
    ((1.0 - last.value) / (now.value - last.value) * span - 0.5 * last.step).max(0.0)
}

impl Kernel for Friction {
    fn unknowns(&self) -> &[usize] {
        &self.unknowns
    }

    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T]) {
        let own = self.own();
        let force = y[own] * ctx.s;
        if ctx.is_static() {
            // Statics leave friction out: F = 0.
            r[own] += force;
            return;
        }
        let (qi, dq, qf) = self.increments(ctx, y);
        let a = self.slip.secant(qi, qf);
        for k in 0..self.n_coords {
            r[k * self.per] += force * a[k];
        }
        let stick = match self.mode(ctx.state) {
            Mode::Stick { hold } => {
                r[own] += (self.slip.value(qf) - hold) * ctx.s;
                true
            }
            Mode::Slip { direction } => {
                let c = &self.coefficients;
                let mut du = T::zero();
                for k in 0..self.n_coords {
                    du += a[k] * dq[k];
                }
                let kinetic = self.normal_force(ctx, y) * (c.kinetic * direction);
                r[own] += force - kinetic - du * (c.viscous / ctx.h);
                false
            }
        };
        if ctx.ed() {
            self.rate_rows(ctx, y, r, stick);
        }
    }

    /// Under ED's decoupled iteration a slipping row writes only its own multipliers'
    /// entries: its dependence on the normal force and the slip lags by an iteration (the
    /// complex system cannot represent it), which modified Newton tolerates.
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) {
        let n = self.unknowns.len();
        let mut block = [0.0; MAX_UNKNOWNS * MAX_UNKNOWNS];
        eval_kernel(
            self,
            ctx,
            y,
            res,
            Some((&mut block[..n * n], &BLOCK_POSITIONS[..n * n])),
        );
        let own = self.own();
        let slipping = matches!(self.mode(ctx.state), Mode::Slip { .. });
        for i in 0..n {
            for j in 0..n {
                if slipping && i == own && j != own {
                    continue;
                }
                vals[pos[i * n + j] as usize] += block[i * n + j];
            }
        }
    }

    /// Both modes' entries: the mode changes between steps, the pattern does not.
    fn structure(&self, ctx: &StepCtx, y: &[f64]) -> Vec<bool> {
        let mut mask = vec![false; self.unknowns.len().pow(2)];
        for mode in [Mode::Stick { hold: 0.1 }, Mode::Slip { direction: 1.0 }] {
            let mut state = ctx.state.clone();
            self.set_mode(&mut state, mode, None);
            let c = StepCtx {
                state: &state,
                ..*ctx
            };
            let m = tangent_structure(self, &c, y);
            mask.iter_mut().zip(m).for_each(|(a, b)| *a |= b);
        }
        mask
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::elements::fd_harness::tangent_error;
    use crate::math::layout::Scheme;

    /// Two coordinates, a joint of five rows (normal force from rows 1–3, a moment row 4),
    /// the friction's own row 5.
    fn state() -> State {
        State {
            t: 0.3,
            nodes: vec![],
            coords: vec![1.37, 0.4],
            coord_rates: vec![0.8, -0.3],
            lambda: vec![0.0; 6],
            history: vec![1.0, 0.0, -1.0, 0.0],
        }
    }

    fn frictions(layout: &Layout) -> Vec<Friction> {
        let c = Coefficients {
            static_: 0.4,
            kinetic: 0.3,
            viscous: 2.0,
            preload: 1.5,
        };
        let thread = Friction::new(
            "screw".into(),
            c,
            Slip::Linear {
                weights: [0.08, 0.01],
            },
            &[0, 1],
            Normal::Thread {
                row: 1,
                factor: 1.003,
            },
            None,
            5,
            0,
            layout,
        );
        let axes = Friction::new(
            "prismatic".into(),
            c,
            Slip::Linear {
                weights: [1.0, 0.0],
            },
            &[0],
            Normal::Axes { rows: [1, 2] },
            None,
            5,
            0,
            layout,
        );
        // Along a beam of unequal elements; ζ_i = 1.37 and the step crosses into element 2.
        let spans = [(0.0, 0.3), (0.3, 0.8), (0.8, 1.0)];
        let arc = Friction::new(
            "sliding".into(),
            c,
            Slip::Arc {
                map: ArcMap::new(&spans, 1.0),
                length: 2.5,
            },
            &[0],
            Normal::Lateral {
                row: 1,
                axis: V3([0.6, 0.8, 0.0]),
                thread: Some(Thread {
                    sin_lead: 0.1,
                    cos_lead: 0.99f64.sqrt(),
                    cos_flank: 0.9,
                }),
            },
            Some((4, 1.0 / 0.02)),
            5,
            0,
            layout,
        );
        vec![thread, axes, arc]
    }

    #[test]
    fn tangents_match_finite_differences_in_both_modes_and_schemes() {
        for (scheme, statics) in [
            (Scheme::Ep, None),
            (Scheme::Ed, None),
            (Scheme::Ep, Some(0.6)),
        ] {
            let layout = Layout::new(scheme, 0, 2, 6);
            for mode in [Mode::Stick { hold: 0.1 }, Mode::Slip { direction: -1.0 }] {
                for f in frictions(&layout) {
                    let mut st = state();
                    f.set_mode(&mut st, mode, None);
                    let ctx = StepCtx {
                        layout,
                        h: 0.02,
                        t_i: 0.3,
                        t_f: 0.32,
                        s: 50.0,
                        state: &st,
                        gravity: V3([0.0; 3]),
                        statics,
                    };
                    let y: Vec<f64> = (0..layout.n_unknowns())
                        .map(|i| 0.31 + 0.07 * (i as f64).sin())
                        .collect();
                    let e = tangent_error(&f, &ctx, &y);
                    assert!(e < 1e-7, "{} {scheme:?} {statics:?} {mode:?}: {e}", f.joint);
                }
            }
        }
    }

    #[test]
    fn the_force_does_work_minus_f_times_the_exact_slip() {
        // Σ a_k Δq_k is u(q_f) − u(q_i) exactly, across element boundaries too: the work of
        // the friction force is −F Δu, what the energy identity books.
        let layout = Layout::new(Scheme::Ep, 0, 2, 6);
        for f in frictions(&layout) {
            for (qf0, qf1) in [(1.37, 0.4), (1.9, 0.1), (0.2, 0.45), (3.4, -0.2)] {
                let qi = [1.37, 0.4];
                let a = f.slip.secant(qi, [qf0, qf1]);
                let n = f.coords().len();
                let du: f64 = (0..n).map(|k| a[k] * ([qf0, qf1][k] - qi[k])).sum();
                let exact = f.slip.value([qf0, qf1]) - f.slip.value(qi);
                assert!(
                    (du - exact).abs() < 1e-14 * (1.0 + exact.abs()),
                    "{}",
                    f.joint
                );
            }
        }
    }

    fn step(force: f64, normal: f64, slip: f64) -> FrictionStep {
        FrictionStep {
            force,
            normal,
            slip,
            work: -force * slip,
        }
    }

    #[test]
    fn verdicts_hold_break_away_and_stop() {
        let layout = Layout::new(Scheme::Ep, 0, 2, 6);
        let f = &frictions(&layout)[1];
        let mut start = state();
        let h = 1e-3;
        let last = StickRatio {
            value: 0.5,
            step: h,
        };
        f.set_mode(&mut start, Mode::Stick { hold: 1.37 }, Some(last));
        let end = start.clone();
        // μs N = 0.4 × 10: 3.9 N holds, 4.4 N breaks away (towards +u, the slip it resisted)
        // where the ratio, rising linearly from 0.5 at the last step's middle to 1.1 at this
        // one's, crossed 1: 5/6 of the way, a third into this step.
        assert!(matches!(
            f.verdict(&start, &end, &step(3.9, 10.0, 0.0), h),
            Verdict::Holds {
                next: Mode::Stick { .. },
                ..
            }
        ));
        match f.verdict(&start, &end, &step(4.4, 10.0, 0.0), h) {
            Verdict::Shorten(x) => assert!((x - 1.0 / 3.0).abs() < 1e-12, "{x}"),
            v => panic!("{v:?}"),
        }
        // A ratio that reaches 1.5 by this step's middle crossed at its start (the last
        // step's ratio is a mean, not its end's value) ...
        assert_eq!(
            f.verdict(&start, &end, &step(6.0, 10.0, 0.0), h),
            Verdict::Switch(Mode::Slip { direction: 1.0 })
        );
        // ... as does one whose history is unknown.
        f.set_mode(&mut start, Mode::Stick { hold: 1.37 }, None);
        assert_eq!(
            f.verdict(&start, &end, &step(-6.0, 10.0, 0.0), h),
            Verdict::Switch(Mode::Slip { direction: -1.0 })
        );
        // Slipping towards +u at 0.8 m/s; ending at −0.8 m/s it stopped half-way.
        f.set_mode(&mut start, Mode::Slip { direction: 1.0 }, None);
        let mut end = start.clone();
        end.coord_rates[0] = -0.8;
        assert_eq!(
            f.verdict(&start, &end, &step(3.0, 10.0, 1e-3), h),
            Verdict::Shorten(0.5)
        );
        // Ending nearly at rest: it sticks there, from the end state's slip.
        end.coord_rates[0] = -0.01;
        end.coords[0] = 1.38;
        assert_eq!(
            f.verdict(&start, &end, &step(3.0, 10.0, 1e-2), h),
            Verdict::Holds {
                next: Mode::Stick { hold: 1.38 },
                ratio: None
            }
        );
        // Forward at both ends, but the step's slip went back: the rate turned twice inside
        // the step, so it is halved (the rates' line, 0.8 → 0.5, reaches zero only at 2.67
        // steps: a "shorter" step that was longer, tried again for ever).
        end.coord_rates[0] = 0.5;
        assert_eq!(
            f.verdict(&start, &end, &step(3.0, 10.0, -1e-4), h),
            Verdict::Shorten(0.5)
        );
        // Still sliding: nothing happens.
        end.coord_rates[0] = 0.5;
        assert!(matches!(
            f.verdict(&start, &end, &step(3.0, 10.0, 1e-2), h),
            Verdict::Holds {
                next: Mode::Slip { direction } ,
                ..
            } if direction == 1.0
        ));
    }
}

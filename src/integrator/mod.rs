//! One time step: Newton's method on the EP or ED discrete equations of all kernels, with the
//! sparse LU's symbolic analysis reused, and the bookkeeping of the energy identity (work of
//! drives, loads, dampers and constraints, and ED's jump dissipation).

mod contact_border;
pub mod convergence;
pub mod corotation;
pub mod dense_output;
mod ed_decoupled;
mod kept_patterns;
mod load_response;
mod positions;
mod predicted_stop;
pub mod predictor;
mod renewal;
mod structure;
pub mod timings;

use contact_border::ContactBorder;
use convergence::{inf_norm, Measure};
use corotation::CoRotation;
use ed_decoupled::DecoupledSystem;
pub use load_response::LoadResponse;
use positions::KernelPositions;
use renewal::{KindStreak, Renewal};
use structure::BlockStructure;
use timings::{Phase, Timings};

use crate::elements::{Kernel, StepCtx, ValuePos};
use crate::math::layout::Layout;
use crate::math::rotation::{cayley, check_step_rotation, orthonormalize};
use crate::math::vec3::V3;
use crate::model::SimulationSettings;
use crate::state::{NodeState, State};
use crate::system::paired::PairedLu;
use crate::system::sparse::NewtonMatrix;
use crate::system::System;

/// Modified Newton: the most further iterations the kept factors may need before a fresh
/// tangent pays (a residual-only iteration costs ~1/5 of one with tangent and LU).
const STALE_ITERATIONS: f64 = 5.0;

/// ED: the most further iterations decoupled factors fresh in this step may need before the
/// exact matrix's pay (its tangent and LU cost ~18 residual-only iterations with the
/// decoupled system's back-substitution, against its own ~7).
const DECOUPLED_ITERATIONS: f64 = 15.0;

/// ED: fresh factors' cost in residual-only iterations on decoupled factors — the exact
/// matrix's tangent and block LU, the decoupled system's (beam pendulum, wall time: an
/// iteration 16 µs, the exact refresh 286 µs, the decoupled 107 µs).
const EXACT_REFRESH: f64 = 18.0;
const DECOUPLED_REFRESH: f64 = 7.0;

/// ED: an iteration on the exact matrix's factors against one on the decoupled system's —
/// the same residual, a dearer solve (12-element beam pendulum: residual 10.8 µs and block
/// solve 6.0 µs, against the complex solve's 5.5 µs).
const EXACT_ITERATION: f64 = 1.05;

/// What the rate test asks of kept factors that contract too slowly.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Refresh {
    /// They still pay.
    No,
    /// Fresh factors of the kind the step would take.
    Fresh,
    /// ED's exact matrix: the decoupled system's factors, kept, contract about as fast as
    /// fresh ones did — its approximation, not their age, is what is slow.
    Exact,
}

/// Which LU factors are in hand.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Factors {
    /// Of the assembled Newton matrix.
    Exact,
    /// ED only: of the complex EP-sized system equivalent to it (see [`ed_decoupled`]).
    Decoupled,
}

/// Energy bookkeeping and checks of one converged step.
#[derive(Clone, Debug, Default)]
pub struct StepReport {
    pub iterations: usize,
    /// ∞-norm of the residual after each iteration (the first is the predictor's).
    pub residuals: Vec<f64>,
    pub drive_work: f64,
    /// Per drive: its work over the step.
    pub drive_works: Vec<f64>,
    pub external_work: f64,
    pub damper_work: f64,
    /// ED: `½Σ|v_j − v_i|²_M + ½Σ(ε_j − ε_i)ᵀK(ε_j − ε_i)` (0 for EP).
    pub numerical_dissipation: f64,
    /// ED: its parts — the jumps' translational and rotational kinetic energy, and the
    /// strain (and spring) jumps' energy.
    pub jump_energies: [f64; 3],
    /// Work of all constraint forces over the step (zero to round-off).
    pub constraint_work: f64,
    /// Largest |C_f| over all constraint rows.
    pub max_violation: f64,
    /// Per drive: driving force/torque.
    pub drive_forces: Vec<f64>,
    /// Per friction: its force, normal force, slip and work over the step.
    pub frictions: Vec<crate::joints::friction::FrictionStep>,
    /// Work of all friction forces over the step (never positive).
    pub friction_work: f64,
    /// Per joint kernel: reaction force and moment on node2 at the joint point (inertial), and
    /// the joint frame on node2's side.
    pub reactions: Vec<(V3<f64>, V3<f64>, crate::math::vec3::M3<f64>)>,
    /// Per joint kernel (sliding joints; 0 for others): the path's speed `|P′(ζ_f)|` in m
    /// per unit ζ, and `dζ/dη` there, to turn the driving force on ζ into N along the beam
    /// and per unit η.
    pub path_rates: Vec<(f64, f64)>,
}

#[derive(Clone, Debug)]
pub struct StepFailure {
    pub t: f64,
    pub h: f64,
    pub reason: String,
    /// Whether a smaller step could help (not for a singular Newton matrix).
    pub retry: bool,
    /// A static load step: the load factor it aimed at.
    pub load_factor: Option<f64>,
    /// The equation that did not balance when Newton ran out of iterations (its row).
    pub row: Option<usize>,
}

/// A failure of the step in `ctx`.
fn step_failure(ctx: &StepCtx, reason: String, retry: bool) -> StepFailure {
    StepFailure {
        t: ctx.t_i,
        h: ctx.h,
        reason,
        retry,
        load_factor: ctx.statics,
        row: None,
    }
}

impl std::fmt::Display for StepFailure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.load_factor {
            Some(l) => write!(
                f,
                "static load step to load factor {l:.4} failed: {}",
                self.reason
            ),
            None => write!(
                f,
                "step from t = {} s with h = {:.3e} s failed: {}",
                crate::math::seconds::Seconds(self.t),
                self.h,
                self.reason
            ),
        }
    }
}

pub struct Integrator {
    layout: Layout,
    pub matrix: NewtonMatrix,
    /// Where each kernel's tangent block goes in `matrix.values`.
    pos: KernelPositions,
    /// Which entries of each kernel's block the pattern holds.
    structure: BlockStructure,
    y: Vec<f64>,
    res: Vec<f64>,
    /// Per row: the sum of the magnitudes of every kernel's contribution to it (the forces
    /// acting in a momentum equation), the scale its residual is judged against.
    activity: Vec<f64>,
    pub tol: f64,
    /// Convergence on a small update (see `SimulationSettings::newton_increment_tol`).
    pub increment_tol: f64,
    pub max_iter: usize,
    pub total_iterations: usize,
    /// Assemblies in which a kernel wrote outside the detected pattern (should stay 0).
    pub pattern_misses: usize,
    /// Times the pattern was rebuilt (sliding contact points entering new elements).
    pub pattern_rebuilds: usize,
    /// Modified Newton: keep the LU factors across iterations and steps of the same size
    /// while the iteration contracts fast enough (see `contraction_too_slow`).
    pub modified_newton: bool,
    /// Whether the constraint rows may be redundant — the rigidified mechanism of a pre-load,
    /// whose rigid beams over-constrain the loops their flexibility closed (a slider-crank's
    /// rod between parallel pins): see [`Self::regularize_multipliers`].
    pub redundant_rows: bool,
    /// The step size the current LU factors were computed for (None: no valid factors).
    factored_for: Option<f64>,
    /// Whether the last step converged, so its factors may start the next one.
    last_converged: bool,
    /// Whether the current Newton iteration started from an earlier step's factors.
    started_stale: bool,
    /// Linear solves (one per Newton update).
    pub solves: usize,
    /// The step size and force residual at which the last step accepted by a stall at its
    /// round-off floor stopped (see `at_seen_floor`).
    seen_floor: Option<(f64, f64)>,
    /// Assemblies of the Newton equations (each a residual, some with a tangent): with
    /// modified Newton, what most of a step's cost is counted in.
    pub residual_evaluations: usize,
    /// ED under modified Newton: the decoupled complex system and the kernels' block
    /// positions in it (built at its first use).
    decoupled: Option<DecoupledSystem>,
    /// Factorizations of the decoupled system, over every pattern.
    decoupled_factorizations: usize,
    /// Pivoting factorizations of the decoupled systems of earlier patterns.
    retired_decoupled_pivoting: usize,
    factors: Factors,
    /// The decoupled factors did not serve this step (they contracted too slowly when fresh,
    /// or the step failed with them): factor the exact matrix until the step is done.
    exact_for_step: bool,
    /// Whether the factors in hand were computed in the current Newton solve.
    factored_this_solve: bool,
    /// Fresh factorizations still to take on the exact matrix after decoupled factors did not
    /// serve (`2^k` after the k-th such step in a row, at most 16): at large steps the
    /// nonlinear terms the decoupled system approximates can make it contract too slowly
    /// step after step, and each such try costs its LU and iterations.
    decoupled_backoff: u32,
    decoupled_misses: u32,
    /// Whether the assembled tangent values are the exact Newton matrix (not the decoupled
    /// system's rows only).
    values_exact: bool,
    /// Kept factors followed through the nodes' rotations since they were computed.
    corotation: CoRotation,
    /// The last converged steps' accelerations, for the predictor's second-order terms.
    trend: predictor::Trend,
    /// ED: the contraction per iteration that the last fresh decoupled factors achieved over
    /// the solve they were computed in, and where they started (distance, iteration).
    decoupled_rate: Option<f64>,
    decoupled_from: Option<(f64, usize)>,
    /// Steps and iterations the factors in hand have served (when they no longer pay:
    /// [`renewal`]), and per kind (exact, decoupled) how many steps recent factors served (a
    /// running mean): ED's exact factors pay only where they last.
    served: Renewal,
    lifetimes: [Option<f64>; 2],
    /// ED: fresh factorizations of the same kind in a row, and when the other is retried.
    kinds: KindStreak,
    /// Newton iterations per converged step, a running mean (what a dearer solve costs).
    iterations_per_step: f64,
    /// The sliding contacts' rows and columns, refreshed in kept factors at each step: EP's
    /// matrix's, ED's decoupled system's (built with it).
    contact_border: Option<ContactBorder>,
    decoupled_border: Option<ContactBorder<faer::c64>>,
    /// ED's exact matrix factored by 2 × 2 blocks of its pairs (made at its first exact
    /// factorization), and whether the exact factors in hand are those.
    paired: Option<PairedLu>,
    exact_in_pairs: bool,
    /// Steps whose kept factors had their border refreshed.
    pub border_refreshes: usize,
    /// Constraint rows evaluated alone after an update predicted to balance the forces
    /// (`predicted_stop`), and of those, the steps they converged.
    pub constraint_checks: usize,
    pub predicted_stops: usize,
    /// The sliding windows the pattern in hand was built for, and the patterns built for
    /// others that were left (see [`kept_patterns`]).
    placement: kept_patterns::Placement,
    kept: kept_patterns::KeptPatterns,
    /// Pattern rebuilds that took back a kept pattern.
    pub patterns_taken_back: usize,
    /// Wall time per phase, if `simulation.timings` asked for it.
    pub timings: Timings,
}

/// A Newton matrix's pattern, each kernel's block positions in it and the block structure
/// it was built from.
struct Pattern {
    matrix: NewtonMatrix,
    pos: KernelPositions,
    structure: BlockStructure,
}

impl Pattern {
    /// Only the structurally nonzero entries enter the pattern: less fill, faster LU. For
    /// modified Newton (`bordered`), the sliding contacts' unknowns are EP's border (their
    /// blocks' rows and columns kept whole under either scheme).
    fn of(sys: &System, structure: BlockStructure, bordered: bool) -> Self {
        let n = sys.layout.n_unknowns();
        let blocks = structure.unknowns();
        let border = contact_border::border_of(sys, bordered);
        let masks = contact_border::open_border(&blocks, structure.masks(), &border);
        let (mut matrix, pos) = NewtonMatrix::from_blocks(n, &blocks, Some(&masks));
        // Under ED the border is the decoupled system's (`DecoupledSystem::new`).
        if !sys.layout.ed() {
            matrix.set_border(&border);
        }
        Pattern {
            matrix,
            pos: KernelPositions::split(sys, pos),
            structure,
        }
    }
}

impl Integrator {
    pub fn new(sys: &System, settings: &SimulationSettings) -> Self {
        let probe = BlockStructure::probe(sys, settings.dt);
        let pattern = Pattern::of(sys, probe, settings.modified_newton);
        Self::with_settings(sys, settings, pattern)
    }

    /// A fresh integrator for the same system and settings, with this one's Newton-matrix
    /// pattern and ordering (nothing probed or ordered again): the instant values at a
    /// run's ends.
    pub fn sibling(&self, sys: &System, settings: &SimulationSettings) -> Self {
        let pattern = Pattern {
            matrix: self.matrix.same_pattern(),
            pos: self.pos.clone(),
            structure: self.structure.clone(),
        };
        Self::with_settings(sys, settings, pattern)
    }

    fn with_settings(sys: &System, settings: &SimulationSettings, pattern: Pattern) -> Self {
        let mut integ = Self::with_pattern(sys, pattern);
        integ.tol = settings.newton_tol;
        integ.increment_tol = settings.newton_increment_tol;
        integ.max_iter = settings.max_newton_iterations as usize;
        integ.modified_newton = settings.modified_newton;
        integ.timings = Timings::new(settings.timings);
        integ.contact_border =
            ContactBorder::new(sys, &integ.matrix).filter(|_| settings.modified_newton);
        integ
    }

    /// Rebuilds the Newton matrix's pattern after a kernel's unknowns changed (a sliding
    /// joint's window moved to the next element): only that kernel's structure is probed
    /// again. The factors in hand go with the old pattern; the counters, the predictor's
    /// trend and what the step history taught about factors carry on.
    ///
    /// A pattern built for the same windows before is taken back as it was left (see
    /// [`kept_patterns`]); the one left is kept.
    pub fn rebuild_pattern(&mut self, sys: &System, h: f64) {
        let started = self.timings.start();
        let placement = kept_patterns::placement(sys);
        let incoming = match self.kept.take(&placement) {
            Some(set) => {
                self.patterns_taken_back += 1;
                set
            }
            None => self.new_pattern(sys, h, placement),
        };
        let left = self.swap_pattern(incoming);
        if left.placement != self.placement {
            self.kept.keep(left);
        }
        self.factored_for = None;
        self.factors = Factors::Exact;
        self.values_exact = false;
        self.factored_this_solve = false;
        self.corotation = CoRotation::new(sys);
        self.exact_in_pairs = false;
        self.served.restart();
        self.pattern_rebuilds += 1;
        self.timings.add(Phase::Patterns, started);
    }

    /// The pattern of `sys` as its sliding windows are now placed (only kernels with new
    /// unknowns probed).
    fn new_pattern(
        &self,
        sys: &System,
        h: f64,
        placement: kept_patterns::Placement,
    ) -> kept_patterns::PatternSet {
        let fresh = Pattern::of(sys, self.structure.reprobe(sys, h), self.modified_newton);
        let contact_border =
            ContactBorder::new(sys, &fresh.matrix).filter(|_| self.modified_newton);
        kept_patterns::PatternSet {
            placement,
            matrix: fresh.matrix,
            pos: fresh.pos,
            structure: fresh.structure,
            decoupled: None,
            paired: None,
            contact_border,
            decoupled_border: None,
        }
    }

    /// Puts `incoming` in place and returns the pattern it replaces, whose matrices' counts
    /// pass to the incoming ones (a kept pattern carries none).
    fn swap_pattern(&mut self, incoming: kept_patterns::PatternSet) -> kept_patterns::PatternSet {
        use std::mem::replace;
        let mut left = kept_patterns::PatternSet {
            placement: replace(&mut self.placement, incoming.placement),
            matrix: replace(&mut self.matrix, incoming.matrix),
            pos: replace(&mut self.pos, incoming.pos),
            structure: replace(&mut self.structure, incoming.structure),
            decoupled: replace(&mut self.decoupled, incoming.decoupled),
            paired: replace(&mut self.paired, incoming.paired),
            contact_border: replace(&mut self.contact_border, incoming.contact_border),
            decoupled_border: replace(&mut self.decoupled_border, incoming.decoupled_border),
        };
        let (old, new) = (&mut left.matrix, &mut self.matrix);
        new.numeric_factorizations += replace(&mut old.numeric_factorizations, 0);
        new.refactorizations += replace(&mut old.refactorizations, 0);
        new.orderings += replace(&mut old.orderings, 0);
        if let Some(d) = left.decoupled.as_mut() {
            self.retired_decoupled_pivoting += d.matrix.retire_counts();
        }
        left
    }

    fn with_pattern(
        sys: &System,
        Pattern {
            matrix,
            pos,
            structure,
        }: Pattern,
    ) -> Self {
        let n = sys.layout.n_unknowns();
        Integrator {
            layout: sys.layout,
            matrix,
            pos,
            structure,
            y: vec![0.0; n],
            res: vec![0.0; n],
            activity: vec![0.0; n],
            tol: 1e-10,
            increment_tol: 0.0,
            max_iter: 20,
            total_iterations: 0,
            pattern_misses: 0,
            pattern_rebuilds: 0,
            modified_newton: false,
            redundant_rows: false,
            factored_for: None,
            last_converged: false,
            started_stale: false,
            solves: 0,
            seen_floor: None,
            residual_evaluations: 0,
            decoupled: None,
            decoupled_factorizations: 0,
            retired_decoupled_pivoting: 0,
            factors: Factors::Exact,
            exact_for_step: false,
            factored_this_solve: false,
            decoupled_backoff: 0,
            decoupled_misses: 0,
            values_exact: false,
            corotation: CoRotation::new(sys),
            trend: predictor::Trend::default(),
            decoupled_rate: None,
            decoupled_from: None,
            served: Renewal::default(),
            lifetimes: [None; 2],
            kinds: KindStreak::default(),
            iterations_per_step: 0.0,
            contact_border: None,
            decoupled_border: None,
            paired: None,
            exact_in_pairs: false,
            border_refreshes: 0,
            constraint_checks: 0,
            predicted_stops: 0,
            placement: kept_patterns::placement(sys),
            kept: Default::default(),
            patterns_taken_back: 0,
            timings: Timings::default(),
        }
    }

    /// Predictor: each node's velocity turning with its angular velocity (see [`predictor`]),
    /// joint coordinates at constant rate, multipliers from the last step — plus, where the
    /// step that ended in `state` left its trend ([`predictor::Trend`]), the second-order
    /// terms of its accelerations and multiplier rates. The first residual of a swinging beam
    /// pendulum falls from its tip's weight (4e2 N) to ~4 N at 1 ms; ED then needs 3.3
    /// iterations per step there instead of 4.0; linkages' default ED runs take 6–17 % fewer
    /// instructions.
    pub fn predict(&mut self, sys: &System, state: &State, h: f64) {
        self.predict_with(sys, state, h, true);
    }

    fn predict_with(&mut self, sys: &System, state: &State, h: f64, second_order: bool) {
        let started = self.timings.start();
        self.predict_unknowns(sys, state, h, second_order);
        self.timings.add(Phase::Predictor, started);
    }

    fn predict_unknowns(&mut self, sys: &System, state: &State, h: f64, second_order: bool) {
        let layout = sys.layout;
        let ed = layout.ed();
        let s = Self::scaling(sys, h);
        self.y.iter_mut().for_each(|v| *v = 0.0);
        let trend = self.trend.at(state).filter(|_| second_order);
        let half_h2 = 0.5 * h * h;
        for (a, n) in state.nodes.iter().enumerate() {
            let d = layout.node_delta(a);
            let (mut dx, mut r) = predictor::turning_increment(&n.r, n.v, n.w, h);
            if let Some(c) = &trend {
                dx += c.accel[a][0].scale_f(half_h2);
                r += c.accel[a][1].scale_f(half_h2);
            }
            dx.write_to(&mut self.y[d..]);
            r.write_to(&mut self.y[d + 3..]);
            if ed {
                let j = layout.node_jump(a);
                n.v.scale_f(h).write_to(&mut self.y[j..]);
                n.w.scale_f(h).write_to(&mut self.y[j + 3..]);
            }
        }
        for c in 0..layout.n_coords {
            let curve = trend.as_ref().map_or(0.0, |t| half_h2 * t.coord_accel[c]);
            self.y[layout.coord_delta(c)] = h * state.coord_rates[c] + curve;
            if ed {
                self.y[layout.coord_jump(c)] = h * state.coord_rates[c];
            }
        }
        for r in 0..layout.n_rows {
            let rate = trend.as_ref().map_or(0.0, |t| h * t.lambda_rate[r]);
            self.y[layout.mult(r)] = (state.lambda[r] + rate) / s;
        }
    }

    /// One Newton iteration from the current unknowns: assemble residual and tangent, factor
    /// (numeric only), solve, update. Returns the residual norm before the update.
    pub fn newton_iteration(&mut self, sys: &System, ctx: &StepCtx) -> Result<f64, String> {
        self.newton_iteration_with(sys, ctx, Factors::Exact)
    }

    /// [`Integrator::newton_iteration`] with the tangent factored as `factors` (ED's decoupled
    /// system is what modified Newton factors by default).
    pub fn newton_iteration_with(
        &mut self,
        sys: &System,
        ctx: &StepCtx,
        factors: Factors,
    ) -> Result<f64, String> {
        let factors = self.available(factors);
        self.assemble_tangent(sys, ctx, factors);
        let (rn, _) = inf_norm(&self.res);
        self.solve_update(factors)?;
        Ok(rn)
    }

    /// Assembles the residual and the tangent entries `factors` read (benchmarks).
    pub fn assemble_tangent(&mut self, sys: &System, ctx: &StepCtx, factors: Factors) {
        let factors = self.available(factors);
        self.assemble_for(sys, ctx, Some(factors));
    }

    /// `factors`, or the exact matrix's where there is no decoupled system (EP): asking an
    /// EP integrator for ED's decoupled factors gets its exact ones, not a panic.
    fn available(&self, factors: Factors) -> Factors {
        match factors {
            Factors::Decoupled if !self.layout.ed() => Factors::Exact,
            f => f,
        }
    }

    /// All numeric LU factorizations so far (of the Newton matrix and of ED's decoupled
    /// system).
    pub fn factorizations(&self) -> usize {
        self.matrix.numeric_factorizations + self.decoupled_factorizations
    }

    /// Of those, the factorizations that chose their pivots (partial pivoting; the others
    /// refactored with an earlier one's pivots and patterns).
    pub fn pivoting_factorizations(&self) -> usize {
        let m = &self.matrix;
        let decoupled = self.decoupled.as_ref();
        m.numeric_factorizations - m.refactorizations
            + decoupled.map_or(0, |d| d.matrix.pivoting_factorizations())
            + self.retired_decoupled_pivoting
    }

    /// The factors a fresh tangent gets: under ED with modified Newton, those of the
    /// decoupled complex system (half the unknowns, ~⅓ of the LU's cost; see
    /// [`ed_decoupled`]) unless they did not serve this step; the exact matrix's otherwise
    /// (full Newton keeps its quadratic convergence).
    fn fresh_factors(&self, ctx: &StepCtx) -> Factors {
        if ctx.ed()
            && self.modified_newton
            && !ctx.is_static()
            && !self.exact_for_step
            && self.decoupled_backoff == 0
            && !self.exact_preferred()
        {
            Factors::Decoupled
        } else {
            Factors::Exact
        }
    }

    /// Decoupled factors fresh in this step did not serve it: the exact matrix's until the
    /// step is done, and for the next `2^k` fresh factorizations.
    fn decoupled_missed(&mut self) {
        self.exact_for_step = true;
        self.decoupled_misses += 1;
        self.decoupled_backoff = 1 << self.decoupled_misses.min(4);
    }

    /// Factors the assembled tangent and applies the update.
    fn solve_update(&mut self, factors: Factors) -> Result<(), String> {
        self.factor_tangent(factors)?;
        self.back_substitute();
        Ok(())
    }

    /// Factors the assembled tangent (symbolic analysis reused) as the exact matrix or as
    /// ED's decoupled system.
    pub fn factor_tangent(&mut self, factors: Factors) -> Result<(), String> {
        let started = self.timings.start();
        let factored = self.factor_kind(factors);
        self.timings.add(Phase::Factorizations, started);
        factored
    }

    fn factor_kind(&mut self, factors: Factors) -> Result<(), String> {
        let factors = self.available(factors);
        self.factored_for = None;
        // The tangent in hand is the kind asked for: the exact values, or the decoupled
        // system's (assembled into its own values, the real ones then not exact).
        debug_assert_eq!(factors == Factors::Exact, self.values_exact);
        match factors {
            Factors::Exact => {
                self.factor_exact()?;
                self.decoupled_backoff = self.decoupled_backoff.saturating_sub(1);
            }
            Factors::Decoupled => {
                let d = self
                    .decoupled
                    .as_mut()
                    .ok_or("no decoupled assembly to factor")?;
                d.matrix.factor()?;
                self.decoupled_factorizations += 1;
            }
        }
        self.factors = factors;
        Ok(())
    }

    /// Factors the exact Newton matrix: under ED by 2 × 2 blocks of its pairs where they
    /// factor ([`PairedLu`]; about half the scalar LU's time on beams), else by scalars.
    fn factor_exact(&mut self) -> Result<(), String> {
        self.exact_in_pairs = false;
        if self.layout.ed() && self.matrix.border().is_empty() {
            let (col_ptr, row_idx) = self.matrix.pattern();
            let paired = self
                .paired
                .get_or_insert_with(|| PairedLu::new(&self.layout, col_ptr, row_idx));
            if let Some(refactored) = paired.factor(&self.matrix.values) {
                self.matrix.numeric_factorizations += 1;
                self.matrix.refactorizations += usize::from(refactored);
                self.exact_in_pairs = true;
                return Ok(());
            }
        }
        self.matrix.factor()
    }

    /// The residual the last assembly left, which [`Self::solve_residual`] turns into the
    /// update in place (benchmarks set it before each solve: repeated in-place solves drift
    /// into subnormal or overflowing numbers, whose arithmetic is not a solve's cost).
    pub fn residual_mut(&mut self) -> &mut [f64] {
        &mut self.res
    }

    /// The step's unknowns: the predictor's values, then each iteration's updates (benchmarks
    /// restore a predicted state through it, so that a timed iteration does not include the
    /// predictor, which runs once per step).
    pub fn unknowns_mut(&mut self) -> &mut [f64] {
        &mut self.y
    }

    /// The update for the residual in `res` with the factors in hand, left in `res`
    /// (benchmarks).
    pub fn solve_residual(&mut self) {
        match (self.factors, self.decoupled.as_mut()) {
            (Factors::Decoupled, Some(d)) => d.matrix.solve(&mut self.res),
            _ => match self.paired.as_mut().filter(|_| self.exact_in_pairs) {
                Some(paired) => paired.solve(&mut self.res),
                None => self.matrix.solve(&mut self.res),
            },
        }
    }

    /// Applies the Newton update from the residual in `res` with the LU factors in hand (the
    /// update stays in `res`).
    fn back_substitute(&mut self) {
        let started = self.timings.start();
        let turning = self.corotation.is_turning();
        if turning {
            self.corotation.to_factored(&mut self.res);
        }
        self.solve_residual();
        if turning {
            self.corotation.from_factored(&mut self.res);
        }
        self.solves += 1;
        for (y, d) in self.y.iter_mut().zip(self.res.iter()) {
            *y -= d;
        }
        self.timings.add(Phase::Solves, started);
    }

    /// Assembles the residual (and the tangent values if asked) at the current unknowns,
    /// and each row's activity.
    pub fn assemble(&mut self, sys: &System, ctx: &StepCtx, with_jacobian: bool) {
        let tangent = if with_jacobian {
            Some(Factors::Exact)
        } else {
            None
        };
        self.assemble_for(sys, ctx, tangent);
    }

    /// [`Integrator::assemble`] with the tangent the given factors need, if any: the exact
    /// one, or for ED's decoupled system only the rows it reads ([`Kernel::evaluate_decoupled`]:
    /// the beams' and joints' from their EP stiffness).
    fn assemble_for(&mut self, sys: &System, ctx: &StepCtx, tangent: Option<Factors>) {
        let started = self.timings.start();
        self.assemble_kernels(sys, ctx, tangent);
        if self.redundant_rows && tangent == Some(Factors::Exact) {
            self.regularize_multipliers(sys, ctx);
        }
        let phase = if tangent.is_some() {
            Phase::Tangents
        } else {
            Phase::Residuals
        };
        self.timings.add(phase, started);
    }

    /// [`Self::assemble_for`]'s work: every kernel's rows, and its tangent block if asked.
    fn assemble_kernels(&mut self, sys: &System, ctx: &StepCtx, tangent: Option<Factors>) {
        let with_jacobian = tangent.is_some();
        let decoupled = tangent == Some(Factors::Decoupled);
        self.residual_evaluations += 1;
        if with_jacobian {
            self.values_exact = tangent == Some(Factors::Exact);
        }
        self.res.iter_mut().for_each(|r| *r = 0.0);
        self.activity.iter_mut().for_each(|r| *r = 0.0);
        // The decoupled system's kernels write straight into its complex values.
        let (vals, pos) = if decoupled {
            let (layout, matrix, pos) = (self.layout, &self.matrix, &self.pos);
            let modified = self.modified_newton;
            let d = self.decoupled.get_or_insert_with(|| {
                let border = contact_border::border_of(sys, modified);
                DecoupledSystem::new(layout, matrix, pos, &border)
            });
            (d.matrix.start_assembly(), &d.pos)
        } else {
            if with_jacobian {
                self.matrix.clear();
            }
            (&mut self.matrix.values[..], &self.pos)
        };
        let y = &self.y;
        let res = &mut self.res;
        let activity = &mut self.activity;
        // Each kernel's rows before it adds to them: its contribution's magnitude is activity.
        let mut before = [0.0f64; crate::elements::MAX_LOCAL];
        // `$eval(kernel, jac)` evaluates one kernel; the macro records its rows' activity.
        macro_rules! run {
            ($list:expr, $pos:expr) => {
                run!(
                    $list,
                    $pos,
                    |k: &_, jac: Option<(&mut [f64], &[ValuePos])>| match jac {
                        Some((vals, pos)) if decoupled => {
                            Kernel::evaluate_decoupled(k, ctx, y, res, vals, pos)
                        }
                        jac => Kernel::evaluate(k, ctx, y, res, jac),
                    }
                )
            };
            ($list:expr, $pos:expr, $eval:expr) => {
                if with_jacobian {
                    for (k, p) in $list.iter().zip($pos.iter()) {
                        let idx = k.unknowns();
                        for (b, &g) in before.iter_mut().zip(idx) {
                            *b = res[g];
                        }
                        let jac = Some((&mut vals[..], &p[..]));
                        #[allow(clippy::redundant_closure_call)]
                        ($eval)(k, jac);
                        for (b, &g) in before.iter().zip(idx) {
                            activity[g] += (res[g] - b).abs();
                        }
                    }
                } else {
                    // Residual only: each kernel adds its rows' magnitudes from its local
                    // block (no gather of the rows before and after it).
                    for k in $list.iter() {
                        Kernel::residual_with_activity(k, ctx, y, res, activity);
                    }
                }
            };
        }
        run!(sys.inertias, pos.inertia);
        run!(sys.beams, pos.beam);
        run!(sys.joints, pos.joint);
        run!(sys.springs, pos.spring);
        run!(sys.drives, pos.drive);
        run!(sys.frictions, pos.friction);
        run!(sys.loads, pos.load);
        run!(sys.line_loads, pos.line_load);
        self.note_pattern_miss(tangent);
    }

    /// A tangent entry the structure detection judged zero is not: the tangent is incomplete
    /// (slower convergence, same solution). Counted so tests can see it.
    fn note_pattern_miss(&mut self, tangent: Option<Factors>) {
        let missed = match (tangent, &self.decoupled) {
            (Some(Factors::Decoupled), Some(d)) => d.matrix.wrote_outside(1e-10),
            (Some(_), _) => self.matrix.wrote_outside(1e-10),
            (None, _) => false,
        };
        if missed {
            self.pattern_misses += 1;
        }
    }

    /// Multiplier scaling `s = m_ref/h²`: constraint rows and forces then have the size of the
    /// inertia terms, so the Newton matrix's conditioning does not degrade as h shrinks.
    pub fn scaling(sys: &System, h: f64) -> f64 {
        sys.mass_ref / (h * h)
    }

    /// The context of a dynamic step of `h` from `state`.
    pub fn step_ctx<'a>(sys: &System, state: &'a State, h: f64) -> StepCtx<'a> {
        StepCtx {
            layout: sys.layout,
            h,
            t_i: state.t,
            t_f: state.t + h,
            s: Self::scaling(sys, h),
            state,
            gravity: sys.gravity,
            statics: None,
        }
    }

    /// Advances `state` by `h`. On failure nothing is changed.
    pub fn step(
        &mut self,
        sys: &System,
        state: &State,
        h: f64,
    ) -> Result<(State, StepReport), StepFailure> {
        let ctx = Self::step_ctx(sys, state, h);
        self.exact_for_step = false;
        self.predict(sys, state, h);
        let mut result = self.newton(sys, &ctx);
        // Modified Newton started from an earlier step's factors and failed: the tangent
        // had moved on (a rotor turns its tangent by Ωh every step). Retry this step with
        // fresh factors before anyone shrinks it; and with the exact matrix's if the
        // decoupled system's failed fresh.
        if matches!(&result, Err(e) if e.retry && self.started_stale) {
            self.factored_for = None;
            self.predict_with(sys, state, h, false);
            result = self.newton(sys, &ctx);
        }
        if matches!(&result, Err(e) if e.retry && self.factors == Factors::Decoupled) {
            self.decoupled_missed();
            self.factored_for = None;
            self.predict_with(sys, state, h, false);
            result = self.newton(sys, &ctx);
        }
        let started = self.timings.start();
        let (end, report) = self.commit(sys, &ctx, result?);
        self.trend.record(state, &end, h);
        self.timings.add(Phase::StepEnds, started);
        Ok((end, report))
    }

    /// Multiplier scaling of a static solve: the stiffness scale `EA/L` of the stiffest
    /// section (or weight over size), so constraint rows weigh like elastic ones.
    pub fn static_scaling(sys: &System) -> f64 {
        let k = (sys.force_ref * 1e8).max(sys.mass_ref * sys.gravity.norm());
        let k = sys.springs.iter().fold(k, |m, sp| {
            m.max(sp.law.stiffness_scale() / sys.length_ref.powi(2))
        });
        if k > 0.0 {
            k / sys.length_ref
        } else {
            1.0
        }
    }

    /// Static equilibrium at time `state.t` under the loads (and gravity) times `load_factor`,
    /// from `state` (the previous load step) by Newton's method. Velocities are zero.
    pub fn static_step(
        &mut self,
        sys: &System,
        state: &State,
        load_factor: f64,
    ) -> Result<(State, StepReport), StepFailure> {
        let ctx = self.start_static(sys, state, load_factor);
        let report = self.newton(sys, &ctx)?;
        Ok(self.commit(sys, &ctx, report))
    }

    /// The static tangent at `state` over the EP layout, in compressed sparse columns (see
    /// `NewtonMatrix::to_csc`): the stiffness of elements, springs and follower loads with
    /// the geometric stiffness of the current constraint forces, bordered by the constraint
    /// gradients (rows scaled by `s`).
    pub fn static_tangent(
        &mut self,
        sys: &System,
        state: &State,
        load_factor: f64,
    ) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let ctx = self.start_static(sys, state, load_factor);
        self.assemble(sys, &ctx, true);
        self.matrix.to_csc()
    }

    /// The static residual at `state` (zero increments, its multipliers) under the loads
    /// times `load_factor`, at `state.t`: differenced in time, the explicit rate of the
    /// equilibrium equations (drives, loads that follow a function of time).
    pub fn static_residual(&mut self, sys: &System, state: &State, load_factor: f64) -> &[f64] {
        let ctx = self.start_static(sys, state, load_factor);
        self.assemble(sys, &ctx, false);
        &self.res
    }

    /// The context of a static solve from `state`, with the unknowns at `state` (zero
    /// increments, the multipliers of `state`).
    fn start_static<'a>(
        &mut self,
        sys: &System,
        state: &'a State,
        load_factor: f64,
    ) -> StepCtx<'a> {
        assert!(!sys.layout.ed(), "static solves use the EP layout");
        let s = Self::static_scaling(sys);
        self.y.iter_mut().for_each(|v| *v = 0.0);
        for r in 0..sys.layout.n_rows {
            self.y[sys.layout.mult(r)] = state.lambda[r] / s;
        }
        StepCtx {
            layout: sys.layout,
            h: 1.0,
            t_i: state.t,
            t_f: state.t,
            s,
            state,
            gravity: sys.gravity,
            statics: Some(load_factor),
        }
    }

    /// Statics: motions without stiffness in the current state (a pendulum before its
    /// weight is applied, the spin of a rod on a ball joint) make the tangent singular. A
    /// diagonal stiffness 1e-12 of the model's on every node that carries inertia keeps it
    /// regular; it changes the Newton direction only, never the residual, so the
    /// equilibrium is unchanged.
    fn regularize_static(&mut self, sys: &System, ctx: &StepCtx) {
        let k = 1e-12 * ctx.s;
        let kr = k * sys.length_ref * sys.length_ref;
        for inertia in &sys.inertias {
            let d = sys.layout.node_delta(inertia.node);
            for c in 0..6 {
                self.matrix
                    .add_to_diagonal(d + c, if c < 3 { k } else { kr });
            }
        }
    }

    /// Redundant constraint rows make the Newton matrix singular in their multipliers only
    /// (the motion stays unique). `−1e-8 s` on every multiplier's diagonal — a compliance a
    /// hundred-millionth of the inertia's at the step — keeps the LU regular; like
    /// [`Self::regularize_static`] it changes the Newton direction only, never the residual,
    /// so Newton converges to the constraints themselves, the redundant rows' multipliers to
    /// one of their solutions.
    fn regularize_multipliers(&mut self, sys: &System, ctx: &StepCtx) {
        for r in 0..sys.layout.n_rows {
            self.matrix
                .add_to_diagonal(ctx.layout.mult(r), -1e-8 * ctx.s);
        }
    }

    /// Newton's method on the assembled equations from the current unknowns. A step is
    /// converged only when its forces balance *and* its constraints hold (see
    /// [`convergence`]); otherwise it fails (and is retried smaller or stops the run).
    fn newton(&mut self, sys: &System, ctx: &StepCtx) -> Result<StepReport, StepFailure> {
        let mut report = StepReport::default();
        let mut clamped: Option<&str> = None;
        let mut small_update = false;
        let converged_before = std::mem::replace(&mut self.last_converged, false);
        let mut previous: Option<Measure> = None;
        let mut before_previous: Option<Measure> = None;
        // The iterate with the smallest force residual so far: stagnation is judged against
        // it, so that a residual cycling at round-off (8e-11, 2e-10, 8e-11, …) counts as
        // stalled, not as falling every other iteration.
        let mut best: Option<Measure> = None;
        let mut fresh_update = false;
        let mut stalls = 0;
        self.factored_this_solve = false;
        self.decoupled_from = None;
        let force_floor = Measure::force_floor(sys, ctx);
        let mut trend = predicted_stop::ForceTrend::default();
        for it in 0..=self.max_iter {
            let mut reuse = self.keep_factors(sys, ctx, it, converged_before);
            let tangent = (!reuse).then(|| self.fresh_factors(ctx));
            self.assemble_for(sys, ctx, tangent);
            if ctx.is_static() {
                self.regularize_static(sys, ctx);
            }
            let m = Measure::with_floor(sys, ctx, &self.res, &self.activity, force_floor);
            report.residuals.push(m.stored);
            if !m.finite {
                return Err(self.not_finite(sys, ctx, &m));
            }
            let stalled = best.as_ref().is_some_and(|b| m.force > 0.5 * b.force);
            stalls = if stalled { stalls + 1 } else { 0 };
            let judged = best.as_ref().filter(|_| fresh_update || stalls >= 2);
            let settled = small_update && fresh_update && self.settled(sys, &m, judged);
            let at_floor = self.at_seen_floor(sys, ctx, &m);
            if m.converged(sys, self.tol, judged) || settled || at_floor {
                self.note_decoupled_rate(m.distance(sys, self.tol), it);
                if !at_floor {
                    self.note_stall_floor(ctx, &m);
                }
                if reuse && !settled {
                    // Modified Newton stops just below the tolerance (linear convergence,
                    // where full Newton overshoots it quadratically). One more update with
                    // the factors and residual at hand costs a back-substitution and cuts the
                    // error by θ (≤ 0.2 where factors were kept): energy identities close
                    // 5–10× tighter at no assembly's cost.
                    self.back_substitute();
                }
                break;
            }
            let recent = [previous.as_ref(), before_previous.as_ref()];
            reuse = reuse && self.factors_still_pay(sys, ctx, &m, recent);
            let (f, c) = (m.force_ratio(self.tol), m.constraint_ratio(sys, self.tol));
            let predicted = trend
                .record(f, c, reuse)
                .filter(|_| predicted_stop::pays(sys));
            self.note_fresh_decoupled_start(sys, &m, it, fresh_update);
            if best.as_ref().is_none_or(|b| m.force < b.force) {
                best = Some(m);
            }
            before_previous = previous.replace(m);
            if it == self.max_iter {
                return Err(self.not_converged(sys, ctx, &m, clamped));
            }
            self.apply_update(reuse, ctx)?;
            fresh_update = !reuse;
            small_update = self.update_is_small(sys);
            clamped = self.keep_contacts_in_windows(sys, ctx);
            self.check_iterate(sys, ctx)?;
            report.iterations += 1;
            if let Some(forces) = predicted.filter(|_| clamped.is_none()) {
                if let Some(c) = self.constraints_hold_after_update(sys, ctx, &m) {
                    self.note_decoupled_rate(forces.max(c), it + 1);
                    self.predicted_stops += 1;
                    break;
                }
            }
        }
        self.finish_solve(sys, ctx, report)
    }

    /// A converged solve's books: iterations, the decoupled factors' misses, the contacts'
    /// check, what a solve costs.
    fn finish_solve(
        &mut self,
        sys: &System,
        ctx: &StepCtx,
        report: StepReport,
    ) -> Result<StepReport, StepFailure> {
        self.total_iterations += report.iterations;
        if self.factors == Factors::Decoupled && self.factored_this_solve {
            self.decoupled_misses = 0;
        }
        self.check_contacts_on_beams(sys, ctx)?;
        self.last_converged = true;
        self.served.record(report.iterations);
        let it = report.iterations as f64;
        self.iterations_per_step += 0.1 * (it - self.iterations_per_step);
        Ok(report)
    }

    /// Whether iterate `m` is at the round-off floor earlier steps of this size stalled at:
    /// its forces within twice the residual at which the last step accepted by a stall
    /// stopped ([`Self::note_stall_floor`]), below the floor estimate, the constraints
    /// holding. Such an iterate cannot be improved, and waiting to see it stall costs two
    /// residual assemblies with kept factors (one stall is not told from slow contraction).
    /// The floor seen is the measured one, not the estimate: the energy identities close as
    /// tightly as when every step stalled (12-element beam pendulum at 1 ms: residuals of
    /// 1e0, 1e-3, 6e-8, then 9e-9, 7e-9, 9e-9 seen stalling).
    fn at_seen_floor(&self, sys: &System, ctx: &StepCtx, m: &Measure) -> bool {
        // The same size up to round-off (a fixed step recomputed as t_f − t_i varies in its
        // last bits), as for kept factors.
        self.seen_floor
            .is_some_and(|(h, force)| (h - ctx.h).abs() <= 1e-9 * h && m.force <= 2.0 * force)
            && m.force <= m.force_floor
            && m.constraints_hold(sys, self.tol, None)
    }

    /// A step accepted at `m` below its force tolerance (its residual seen stalling at the
    /// round-off floor) records that floor for the steps of its size that follow.
    fn note_stall_floor(&mut self, ctx: &StepCtx, m: &Measure) {
        if m.force_ratio(self.tol) > 1.0 {
            self.seen_floor = Some((ctx.h, m.force));
        }
    }

    /// Whether iteration `it` goes on with the factors in hand: kept factors start a step that
    /// follows a converged one (followed through the nodes' rotations since they were
    /// computed) unless they no longer pay ([`renewal`]); a fresh tangent otherwise (the first
    /// step, after a failure, a new step size).
    fn keep_factors(
        &mut self,
        sys: &System,
        ctx: &StepCtx,
        it: usize,
        converged_before: bool,
    ) -> bool {
        let mut reuse =
            self.factors_fit(ctx) && (it > 0 || (converged_before && !self.renewal_due()));
        if it == 0 && reuse {
            self.corotation.follow(ctx.state, &self.y);
            reuse = self.refresh_contact_border(sys, ctx);
        }
        if it == 0 {
            self.started_stale = reuse;
        }
        reuse
    }

    /// Whether the factors in hand, though they still converge, cost more per step than fresh
    /// ones would ([`renewal`]; their refresh cost from the matrix they factor).
    fn renewal_due(&self) -> bool {
        let decoupled = self.factors == Factors::Decoupled;
        let cost = renewal::refresh_cost(self.matrix.nnz(), self.y.len(), decoupled);
        self.served.due(cost)
    }

    /// The rate test on kept factors at iterate `m`: if they no longer pay, the tangent for
    /// fresh ones is prepared (see [`Self::prepare_fresh_tangent`]) and `false` returned.
    fn factors_still_pay(
        &mut self,
        sys: &System,
        ctx: &StepCtx,
        m: &Measure,
        recent: [Option<&Measure>; 2],
    ) -> bool {
        let refresh = self.contraction_too_slow(sys, m, recent);
        if refresh != Refresh::No {
            self.prepare_fresh_tangent(sys, ctx, refresh == Refresh::Exact);
        }
        refresh == Refresh::No
    }

    /// ED: the first iterate after a fresh decoupled update is where those factors' rate is
    /// measured from (see [`Self::note_decoupled_rate`]).
    fn note_fresh_decoupled_start(&mut self, sys: &System, m: &Measure, it: usize, fresh: bool) {
        if fresh
            && self.factors == Factors::Decoupled
            && self.factored_this_solve
            && self.decoupled_from.is_none()
        {
            self.decoupled_from = Some((m.distance(sys, self.tol), it));
        }
    }

    /// The kept factors no longer pay: the tangent at this iterate is assembled for fresh
    /// factors — the exact matrix's if the decoupled system's did not pay even fresh, and
    /// then, if that exact tangent is still the one assembled (iterations since assembled
    /// residuals only), it is factored at once without assembling again.
    fn prepare_fresh_tangent(&mut self, sys: &System, ctx: &StepCtx, exact: bool) {
        let missed = self.factors == Factors::Decoupled && (self.factored_this_solve || exact);
        if missed {
            self.decoupled_missed();
        }
        if !(missed && self.values_exact) {
            let tangent = self.fresh_factors(ctx);
            self.assemble_for(sys, ctx, Some(tangent));
        }
    }

    /// The failure of a step whose Newton iteration ran out of iterations at `m`, naming a
    /// sliding contact held at its window's edge if one was (`clamped`).
    fn not_converged(
        &self,
        sys: &System,
        ctx: &StepCtx,
        m: &Measure,
        clamped: Option<&str>,
    ) -> StepFailure {
        let window = clamped.map_or(String::new(), |name| format!("; the contact point of sliding joint `{name}` was held at the edge of its window (it would move about an element or more in this step)"));
        let row = if m.force_ratio(self.tol) > 1.0 || !m.force.is_finite() {
            m.force_row
        } else {
            m.constraint_row
        };
        let on_node = sys
            .node_kink_hint(row, ctx.state)
            .map_or(String::new(), |(_, hint)| format!("; {hint}"));
        StepFailure {
            row: Some(row),
            ..step_failure(
                ctx,
                format!(
                    "Newton did not converge in {} iterations: {}{window}{on_node}",
                    self.max_iter,
                    m.describe(sys, self.tol)
                ),
                true,
            )
        }
    }

    /// The increment test (an explicit setting): after a fresh tangent's update that moved
    /// nothing by more than `increment_tol`, a residual at its round-off floor is accepted;
    /// the constraints must hold to as much.
    ///
    /// (In `newton`, a residual that stopped falling, or a tiny update, shows convergence only
    /// after a fresh tangent's update, or after kept factors failed to halve it twice in a
    /// row — `judged`: with kept factors the iteration contracts linearly, and one slow
    /// contraction is neither round-off nor convergence; a second one below the round-off
    /// floor is round-off, else every step of a model whose residual bottoms out just above
    /// the tolerance would pay a fresh tangent and LU.)
    fn settled(&self, sys: &System, m: &Measure, judged: Option<&Measure>) -> bool {
        m.force <= 1e-6 * m.force_scale
            && (m.constraint <= self.increment_tol * sys.length_ref
                || m.constraints_hold(sys, self.tol, judged))
    }

    /// Whether the LU factors in hand may serve this step: modified Newton, dynamics, and
    /// factors computed for this very step size (the Newton matrix depends on h through
    /// the inertia terms, 4/h², and the multiplier scaling).
    fn factors_fit(&self, ctx: &StepCtx) -> bool {
        // Equal up to round-off: a fixed step's size recomputed as t_f − t_i varies in its
        // last bits.
        self.modified_newton
            && !ctx.is_static()
            && self
                .factored_for
                .is_some_and(|h| (h - ctx.h).abs() <= 1e-9 * ctx.h)
    }

    /// Modified Newton's rate test (Hairer & Wanner II, IV.8): with kept factors the
    /// iteration contracts linearly, the distance to convergence (the residual in units of
    /// its tolerance, see [`Measure::distance`]) falling by θ per iteration. Factor afresh
    /// when it diverges (θ ≥ 0.9) or would need more than [`STALE_ITERATIONS`] more
    /// iterations `ln d / ln(1/θ)`: a fresh tangent and LU cost about as much as that many
    /// back-substitutions with residual-only assemblies, and they serve the next steps too.
    fn contraction_too_slow(
        &self,
        sys: &System,
        m: &Measure,
        [previous, before_previous]: [Option<&Measure>; 2],
    ) -> Refresh {
        let Some(p) = previous else {
            return Refresh::No;
        };
        // Below its round-off floor a residual stalls whatever the factors: the next stall
        // accepts the step (see `newton`); a fresh tangent would buy nothing.
        if m.force <= m.force_floor && m.constraints_hold(sys, self.tol, None) {
            return Refresh::No;
        }
        let d = m.distance(sys, self.tol);
        let theta = d / p.distance(sys, self.tol).max(f64::MIN_POSITIVE);
        // θ over the last two iterations for ED's fresh decoupled factors (whose miss costs
        // the exact LU): their error swaps between row groups, so the residual falls 100× in
        // one iteration and not at all in the next (1.7e-2, 4.0e-5, 5.3e-5) — a contraction
        // of 0.06 per iteration, not a divergence.
        let fresh_decoupled = self.factors == Factors::Decoupled && self.factored_this_solve;
        let two = before_previous.filter(|_| fresh_decoupled);
        let theta = two.map_or(theta, |b| {
            theta.min((d / b.distance(sys, self.tol).max(f64::MIN_POSITIVE)).sqrt())
        });
        // Fresh decoupled factors that contract slowly give way to the exact matrix's,
        // whose tangent and LU cost many more iterations than a decoupled refresh.
        let budget = if fresh_decoupled {
            DECOUPLED_ITERATIONS
        } else {
            STALE_ITERATIONS
        };
        if theta < 0.9 && d.ln() <= budget * (1.0 / theta).ln() {
            return Refresh::No;
        }
        // Kept decoupled factors about as fast as fresh ones were: refreshing them would not
        // help (a rotor's blades at 1 ms steps refactored every step at the same ~0.2 per
        // iteration); the exact matrix's factors, followed through the rotations, serve.
        let kept_decoupled = self.factors == Factors::Decoupled && !fresh_decoupled;
        // Their error swaps between row groups as fresh ones' does: judged over two iterations.
        let theta2 = before_previous.map_or(theta, |b| {
            theta.min((d / b.distance(sys, self.tol).max(f64::MIN_POSITIVE)).sqrt())
        });
        if kept_decoupled
            && self.decoupled_rate.is_some_and(|r| theta2 <= 2.0 * r)
            && self.exact_factors_last()
        {
            Refresh::Exact
        } else {
            Refresh::Fresh
        }
    }

    /// ED: whether fresh factors are the exact matrix's by choice — where decoupled ones last
    /// about a step each (the beam pendulum at 10 ms steps: ~0.1 per iteration fresh, too slow
    /// kept, 8.5 iterations per step) and exact ones, co-rotated, last long enough
    /// ([`Self::exact_outlasts`]). Untried, they are tried where decoupled ones last at most
    /// 1.5 steps; after 16 fresh factorizations of one kind the other is tried again (where
    /// decoupled ones last at most 2 steps), so neither judgement goes stale — a retrial that
    /// loses doubles the wait before the next ([`KindStreak`]). Only factors
    /// replaced at the step size they were computed for count (see `note_lifetime`).
    fn exact_preferred(&self) -> bool {
        let [exact, Some(decoupled)] = self.lifetimes else {
            return false;
        };
        if self.kinds.retrial_due() {
            return self.kinds.last_decoupled() && decoupled <= 2.0;
        }
        match exact {
            Some(exact) => self.exact_outlasts(exact, decoupled),
            None => decoupled <= 1.5,
        }
    }

    /// Whether ED's exact factors have lasted (or are untried) against decoupled ones (one
    /// step if untried): see [`Self::exact_outlasts`].
    fn exact_factors_last(&self) -> bool {
        match self.lifetimes {
            [Some(exact), decoupled] => self.exact_outlasts(exact, decoupled.unwrap_or(1.0)),
            [None, _] => true,
        }
    }

    /// Exact factors that last `exact` steps pay against decoupled ones that last `decoupled`
    /// where they cost less per step: their refresh (tangent and LU: ~20 residual-only
    /// iterations on the beam pendulum, against the decoupled system's ~9) spread over the
    /// steps they serve, plus their dearer solves at every iteration ([`EXACT_ITERATION`]).
    /// Where contact windows move or the configuration changes fast (a collar sliding on a
    /// tumbling beam) exact factors last hardly longer, and their solves decide: by the
    /// refreshes alone, a free collar at 5 ms took them whenever they happened to last 3
    /// steps against 1.1 (16 exact factorizations in 4 s against 8; 4.6 % more instructions).
    fn exact_outlasts(&self, exact: f64, decoupled: f64) -> bool {
        let solves = (EXACT_ITERATION - 1.0) * self.iterations_per_step;
        EXACT_REFRESH / exact + solves <= DECOUPLED_REFRESH / decoupled
    }

    /// Fresh factors of `kind` replace those in hand: the steps these served join their kind's
    /// running mean if they were still `fit` for the step size (a factor dropped for a new h
    /// says nothing about how long its kind lasts).
    fn note_lifetime(&mut self, kind: Factors, fit: bool) {
        self.kinds.record(kind == Factors::Decoupled);
        if fit {
            let k = (self.factors == Factors::Decoupled) as usize;
            let served = self.served.steps().max(1) as f64;
            self.lifetimes[k] = Some(self.lifetimes[k].map_or(served, |l| 0.5 * (l + served)));
        }
        self.served.restart();
    }

    /// A step converged at distance `d` (in units of its tolerances) at iteration `it`: the
    /// rate at which fresh decoupled factors of this solve contracted, if they served at least
    /// two iterations.
    fn note_decoupled_rate(&mut self, d: f64, it: usize) {
        if let Some((d0, i0)) = self.decoupled_from.take() {
            if self.factors == Factors::Decoupled && it >= i0 + 2 && d0 > 0.0 {
                self.decoupled_rate = Some((d.max(1e-300) / d0).powf(1.0 / (it - i0) as f64));
            }
        }
    }

    /// Solves for the Newton update (with the kept factors, or factoring afresh) and
    /// applies it; the update stays in `res`.
    fn apply_update(&mut self, reuse: bool, ctx: &StepCtx) -> Result<(), StepFailure> {
        if reuse {
            self.back_substitute();
        } else {
            self.corotation.record(ctx.state, &self.y);
            // The kind the tangent was assembled for, before the lifetimes change.
            let kind = self.fresh_factors(ctx);
            self.note_lifetime(kind, self.factors_fit(ctx));
            self.solve_update(kind)
                .map_err(|reason| step_failure(ctx, reason, true))?;
            self.factored_for = Some(ctx.h);
            self.factored_this_solve = true;
        }
        Ok(())
    }

    /// Whether the update just applied (left in `res` by the solve) moved every node by
    /// less than `increment_tol` (relative to the model's size; radians).
    fn update_is_small(&self, sys: &System) -> bool {
        let layout = sys.layout;
        self.increment_tol > 0.0
            && (0..layout.n_nodes).all(|a| {
                let d = layout.node_delta(a);
                let u = &self.res[d..d + 6];
                let dx = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt() / sys.length_ref;
                let dr = (u[3] * u[3] + u[4] * u[4] + u[5] * u[5]).sqrt();
                dx.max(dr) <= self.increment_tol
            })
    }

    /// The iterate must be finite (a singular matrix is no step-size problem) and turn no
    /// node past the Rodrigues parameters' limit.
    fn check_iterate(&self, sys: &System, ctx: &StepCtx) -> Result<(), StepFailure> {
        let layout = sys.layout;
        if let Some(bad) = self.y.iter().position(|v| !v.is_finite()) {
            let what = if ctx.is_static() {
                "a motion there is resisted neither by stiffness nor by joints (statics needs every rigid-body motion restrained)"
            } else {
                "a motion there is determined neither by mass nor by joints (give the node a body or constrain it)"
            };
            return Err(step_failure(
                ctx,
                format!(
                    "singular Newton matrix at {}: {what}, or the mechanism is at a singular configuration",
                    sys.describe_row(bad)
                ),
                false,
            ));
        }
        for a in 0..layout.n_nodes {
            let d = layout.node_delta(a) + 3;
            let r = V3([self.y[d], self.y[d + 1], self.y[d + 2]]);
            check_step_rotation(&r).map_err(|e| {
                let node = &sys.node_names[a];
                let reason = if ctx.is_static() {
                    let angle = 2.0 * (0.5 * r.norm()).atan().to_degrees();
                    format!("a Newton iteration turns node `{node}` by {angle:.1}° (limit 150°): use more load_steps, or the model lacks a restraint against a rigid-body motion under this load")
                } else {
                    format!("node `{node}`: {e}")
                };
                step_failure(ctx, reason, true)
            })?;
        }
        Ok(())
    }

    /// A residual that is not finite: a drive or load that is undefined at this time is the
    /// model's doing (no step helps); otherwise the step went somewhere the physics is not
    /// defined, and a smaller one may not.
    fn not_finite(&self, sys: &System, ctx: &StepCtx, m: &Measure) -> StepFailure {
        if let Some(what) = sys.undefined_time_function(ctx.t_i, ctx.t_f) {
            return step_failure(ctx, what, false);
        }
        let row = if m.force.is_finite() {
            m.constraint_row
        } else {
            m.force_row
        };
        step_failure(
            ctx,
            format!("residual is not finite at {}", sys.describe_row(row)),
            true,
        )
    }

    /// Newton's iterate of a sliding joint's ζ stays within the window its unknowns cover;
    /// returns the name of a joint held at the window's edge.
    fn keep_contacts_in_windows<'s>(&mut self, sys: &'s System, ctx: &StepCtx) -> Option<&'s str> {
        let mut held = None;
        for sl in sys.joints.iter().filter_map(|j| j.as_sliding()) {
            let d = sys.layout.coord_delta(sl.coord);
            let zi = ctx.state.coords[sl.coord];
            let (lo, hi) = sl.zeta_limits();
            let z = zi + self.y[d];
            if z < lo || z > hi {
                self.y[d] = z.clamp(lo, hi) - zi;
                held = Some(sl.name.as_str());
            }
        }
        held
    }

    /// A converged step whose contact point left its beam cannot continue: the beam has no
    /// material there. Stop with a message (no smaller step helps).
    fn check_contacts_on_beams(&self, sys: &System, ctx: &StepCtx) -> Result<(), StepFailure> {
        for sl in sys.joints.iter().filter_map(|j| j.as_sliding()) {
            let z = ctx.state.coords[sl.coord] + self.y[sys.layout.coord_delta(sl.coord)];
            let n = sl.path.elements as f64;
            // With end stops the contact point runs past an end by the stop's compression
            // (the end element extends); half an element means the stop is far too soft.
            let slack = if sl.end_stops { 0.5 } else { 1e-9 };
            if !(-slack..=n + slack).contains(&z) {
                let beam = &sys.beam_info[sl.beam].name;
                let end = if z < 0.0 {
                    "first end (η = 0)"
                } else {
                    "second end (η = 1)"
                };
                return Err(StepFailure {
                    t: ctx.t_i,
                    h: ctx.h,
                    reason: if sl.end_stops {
                        format!("the contact point of sliding joint `{}` ran half an element through its end stop at the {end} of beam `{beam}`: the stop is too soft for this impact; stiffen `end_stops`", sl.name)
                    } else {
                        format!("the contact point of sliding joint `{}` slid off the {end} of beam `{beam}`: nothing in the model stops it there; add `end_stops`, prescribe η with a drive, hold it with a spring, or lengthen the beam", sl.name)
                    },
                    retry: false,
                    load_factor: ctx.statics,
                    row: None,
                });
            }
        }
        Ok(())
    }

    /// Element history at the end of the converged step, and the beams' strain-jump part of
    /// ED's numerical dissipation (0 under EP) from the same pass.
    fn history_f(&self, sys: &System, ctx: &StepCtx) -> (Vec<f64>, f64) {
        let mut h = ctx.state.history.clone();
        let mut local = Vec::new();
        let mut strain_jumps = 0.0;
        for b in &sys.beams {
            local.clear();
            local.extend(Kernel::unknowns(b).iter().map(|&g| self.y[g]));
            let span = b.history..b.history + b.history_len();
            strain_jumps += b.end_of_step(ctx, &local, &mut h[span]);
        }
        (h, strain_jumps)
    }

    /// Builds the f-state from the converged unknowns and fills the step report.
    fn commit(
        &mut self,
        sys: &System,
        ctx: &StepCtx,
        mut report: StepReport,
    ) -> (State, StepReport) {
        let (history, strain_jumps) = self.history_f(sys, ctx);
        let state = self.end_state(sys, ctx, history);
        self.account_energy(sys, ctx, strain_jumps, &mut report);
        let y = &self.y;
        // Each joint's values, work and reaction from one evaluation.
        report.max_violation = 0.0;
        report.constraint_work = 0.0;
        report.reactions = Vec::with_capacity(sys.joints.len());
        for j in &sys.joints {
            let outcome = j.step_outcome(ctx, y);
            let violation = outcome.values.iter().take(j.n_rows());
            report.max_violation = violation.fold(report.max_violation, |m, v| m.max(v.abs()));
            report.constraint_work += outcome.work;
            report.reactions.push(outcome.reaction);
        }
        report.path_rates = sys
            .joints
            .iter()
            .map(|j| match j.as_sliding() {
                Some(sl) => {
                    let z = state.coords[sl.coord];
                    let (_, _, speed) = sl.contact(&state, z);
                    (speed, 1.0 / sl.arc.deta_dzeta(z))
                }
                None => (0.0, 0.0),
            })
            .collect();
        (state, report)
    }

    /// The state at the end of the converged step: positions, rotations, velocities from
    /// `Δ = h (V_start + V_f)/2` (V_start = V_i under EP, V_j under ED; zero velocities in
    /// statics), coordinates, multipliers, and the element `history` ([`Self::history_f`]).
    fn end_state(&self, sys: &System, ctx: &StepCtx, history: Vec<f64>) -> State {
        let layout = sys.layout;
        let ed = layout.ed();
        let (h, st, y) = (ctx.h, ctx.state, &self.y);
        let nodes = st
            .nodes
            .iter()
            .enumerate()
            .map(|(a, n)| {
                let d = layout.node_delta(a);
                let dx = V3([y[d], y[d + 1], y[d + 2]]);
                let r = V3([y[d + 3], y[d + 4], y[d + 5]]);
                let (vs, ws) = if ctx.is_static() {
                    // Zero velocities at f: v_f = 2Δx/h − v_start.
                    (dx.scale_f(2.0 / h), r.scale_f(2.0 / h))
                } else if ed {
                    let j = layout.node_jump(a);
                    (
                        V3([y[j], y[j + 1], y[j + 2]]).scale_f(1.0 / h),
                        V3([y[j + 3], y[j + 4], y[j + 5]]).scale_f(1.0 / h),
                    )
                } else {
                    (n.v, n.w)
                };
                NodeState {
                    x: n.x + dx,
                    r: orthonormalize(&n.r.mul_m(&cayley(&r))),
                    v: dx.scale_f(2.0 / h) - vs,
                    w: r.scale_f(2.0 / h) - ws,
                }
            })
            .collect();
        let mut coords = st.coords.clone();
        let mut rates = st.coord_rates.clone();
        for c in 0..layout.n_coords {
            let dq = y[layout.coord_delta(c)];
            let start = if ctx.is_static() {
                2.0 * dq / h
            } else if ed {
                y[layout.coord_jump(c)] / h
            } else {
                st.coord_rates[c]
            };
            coords[c] += dq;
            rates[c] = 2.0 * dq / h - start;
        }
        State {
            t: ctx.t_f,
            nodes,
            coords,
            coord_rates: rates,
            lambda: (0..layout.n_rows)
                .map(|r| ctx.s * y[layout.mult(r)])
                .collect(),
            history,
        }
    }

    /// The step's energy bookkeeping (ed-scheme-notes §3.4): `E_f − E_i = W_drive + W_ext +
    /// W_damp + W_friction − D` (W_damp: joint dampers and the beams' structural damping; the
    /// constraint forces' work, zero to round-off, comes with the joints' other step outcomes
    /// in [`Self::commit`]). `strain_jumps`: the beams' part of ED's numerical dissipation
    /// ([`Self::history_f`]).
    fn account_energy(
        &self,
        sys: &System,
        ctx: &StepCtx,
        strain_jumps: f64,
        report: &mut StepReport,
    ) {
        let layout = sys.layout;
        let (h, st, y) = (ctx.h, ctx.state, &self.y);
        report.drive_works = sys.drives.iter().map(|d| d.step_work(ctx, y)).collect();
        report.drive_work = report.drive_works.iter().sum();
        report.drive_forces = sys.drives.iter().map(|d| d.force(ctx, y)).collect();
        report.external_work = sys.loads.iter().map(|l| l.step_work(ctx, y)).sum::<f64>()
            + sys
                .line_loads
                .iter()
                .map(|l| l.step_work(ctx, y))
                .sum::<f64>();
        report.damper_work = sys
            .springs
            .iter()
            .map(|sp| -sp.damping * y[layout.coord_delta(sp.coord)].powi(2) / h)
            .sum::<f64>()
            + sys
                .beams
                .iter()
                .filter(|b| b.is_damped())
                .map(|b| b.damping_work(ctx, &b.gather(y)))
                .sum::<f64>();
        if layout.ed() {
            let mut d = [0.0; 3];
            for k in &sys.inertias {
                let j = layout.node_jump(k.node);
                let n = &st.nodes[k.node];
                let dv = V3([y[j], y[j + 1], y[j + 2]]).scale_f(1.0 / h) - n.v;
                let dw = V3([y[j + 3], y[j + 4], y[j + 5]]).scale_f(1.0 / h) - n.w;
                d[0] += 0.5 * k.mass * dv.norm_sq();
                d[1] += 0.5 * dw.dot(&k.inertia.mul_v(&dw));
            }
            for sp in &sys.springs {
                d[2] += sp.dissipation(ctx, y);
            }
            d[2] += strain_jumps;
            report.jump_energies = d;
            report.numerical_dissipation = d.iter().sum();
        }
        report.frictions = sys.frictions.iter().map(|f| f.step(ctx, y)).collect();
        report.friction_work = report.frictions.iter().map(|f| f.work).sum();
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::math::layout::Scheme;

    /// The system of model file `text` under `scheme` and an integrator (the model's
    /// settings) predicted for a step of `h` from its initial state.
    pub(crate) fn predicted_start(text: &str, scheme: Scheme, h: f64) -> (System, Integrator) {
        let model = crate::compile::from_yaml_str(text).unwrap();
        let sys = crate::compile::compile(&model, scheme).unwrap();
        let mut integ = Integrator::new(&sys, &model.simulation);
        integ.predict(&sys, &sys.initial, h);
        (sys, integ)
    }

    /// A residual-only assembly (modified Newton's iterations: each kernel's residual and its
    /// rows' activity from its local block, `Kernel::residual_with_activity`) adds what the
    /// tangent assembly adds through `Kernel::evaluate`: the same residual and the same force
    /// scale, over the examples' kernels (beams, bodies, classic, sliding and sliding-screw
    /// joints, drives, springs), EP and ED. A kernel whose residual-only path drifted from its
    /// `evaluate` would break the equality.
    #[test]
    fn residual_only_assembly_adds_what_the_tangent_assembly_adds() {
        for name in [
            "beam_pendulum",
            "free_collar",
            "four_bar",
            "slider_crank",
            "heavy_top",
            "beam_slider/case1",
            "beam_slider/twisted_case1",
        ] {
            let path = format!("{}/examples/{name}.yaml", env!("CARGO_MANIFEST_DIR"));
            let Ok(text) = std::fs::read_to_string(&path) else {
                panic!("example {path} is missing");
            };
            for scheme in [Scheme::Ep, Scheme::Ed] {
                let h = 1e-3;
                let (sys, mut integ) = predicted_start(&text, scheme, h);
                let ctx = Integrator::step_ctx(&sys, &sys.initial, h);
                integ.assemble(&sys, &ctx, true);
                let (res, activity) = (integ.res.clone(), integ.activity.clone());
                integ.assemble(&sys, &ctx, false);
                let scale = activity.iter().fold(1e-300f64, |m, a| m.max(*a));
                for i in 0..res.len() {
                    // Round-off of a sum taken in another order.
                    let what = sys.describe_row(i);
                    assert!(
                        (res[i] - integ.res[i]).abs() <= 1e-12 * scale,
                        "{name} {scheme:?}: residual at {what}"
                    );
                    assert!(
                        (activity[i] - integ.activity[i]).abs() <= 1e-12 * scale,
                        "{name} {scheme:?}: activity at {what}"
                    );
                }
            }
        }
    }

    /// ED's exact Newton matrix is factored by 2 × 2 blocks of its pairs on the examples'
    /// models (beams, bodies, classic and sliding joints, drives) and its update is the scalar
    /// LU's.
    #[test]
    fn ed_exact_factors_are_paired_and_solve_like_the_scalar_lu() {
        for name in [
            "beam_pendulum",
            "free_collar",
            "four_bar",
            "heavy_top",
            "slider_crank",
        ] {
            let path = format!("{}/examples/{name}.yaml", env!("CARGO_MANIFEST_DIR"));
            let text = std::fs::read_to_string(&path).unwrap();
            let h = 1e-3;
            let (sys, mut integ) = predicted_start(&text, Scheme::Ed, h);
            let ctx = Integrator::step_ctx(&sys, &sys.initial, h);
            integ.assemble(&sys, &ctx, true);
            let mut scalar = integ.res.clone();
            integ.factor_tangent(Factors::Exact).unwrap();
            assert!(integ.exact_in_pairs, "{name}: factored by scalars");
            integ.solve_residual();
            integ.matrix.factor().unwrap();
            integ.matrix.solve(&mut scalar);
            let size = scalar.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (i, (a, b)) in integ.res.iter().zip(&scalar).enumerate() {
                // Two LUs' round-off; the matrices span m/h² to EA/L (~1e2 between).
                let what = sys.describe_row(i);
                assert!(
                    (a - b).abs() <= 1e-9 * size,
                    "{name} at {what}: {a:e} ≠ {b:e}"
                );
            }
        }
    }

    /// Kept factors that still converge but need more iterations step after step are replaced
    /// where fresh ones pay ([`renewal`]): the four-bar linkage at 1 ms, whose kept factors age
    /// from 3 iterations per step to 5 (EP) or 8 (ED, decoupled factors) within ~50 steps.
    /// Over 0.6 s the rule brings ED from 4.9 to 3.9 iterations per step and EP from 4.07 to
    /// 3.80 (fixed steps: deterministic counts; the bounds sit between the two).
    #[test]
    fn kept_factors_are_replaced_when_they_no_longer_pay() {
        let path = format!("{}/examples/four_bar.yaml", env!("CARGO_MANIFEST_DIR"));
        let mut model =
            crate::compile::from_yaml_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        model.simulation.dt = 1e-3;
        model.simulation.step_control = crate::model::StepControl::Fixed;
        for (scheme, bound) in [(Scheme::Ep, 4.0), (Scheme::Ed, 4.2)] {
            let mut sim = crate::simulation::Simulation::with_scheme(&model, scheme).unwrap();
            sim.advance_to(0.6).unwrap();
            let steps = sim.stats.steps as f64;
            let per_step = sim.stats.newton_iterations as f64 / steps;
            assert!(
                per_step <= bound,
                "{scheme:?}: {per_step} iterations per step"
            );
            let factorizations = sim.stats.factorizations as f64;
            assert!(factorizations < 0.2 * steps, "{scheme:?}: factors kept");
        }
    }

    /// The free-collar example: a collar on a sliding joint along a free beam.
    fn free_collar() -> crate::model::Model {
        let path = format!("{}/examples/free_collar.yaml", env!("CARGO_MANIFEST_DIR"));
        crate::compile::from_yaml_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    /// A sibling integrator (the instant values at a run's ends) takes this one's pattern
    /// as is and steps exactly as a freshly probed one: same pattern, same column order,
    /// the same step to the bit (a sliding joint's model after a rebuild, EP and ED).
    #[test]
    fn a_sibling_steps_as_a_freshly_built_integrator() {
        let model = free_collar();
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let sys = crate::compile::compile(&model, scheme).unwrap();
            let settings = &model.simulation;
            let mut first = Integrator::new(&sys, settings);
            first.rebuild_pattern(&sys, settings.dt);
            assert_eq!(first.structure.probed, 0, "nothing moved, nothing probed");
            let sibling = first.sibling(&sys, settings);
            let fresh = Integrator::new(&sys, settings);
            assert_eq!(sibling.matrix.pattern(), fresh.matrix.pattern());
            assert_eq!(sibling.matrix.col_perm(), fresh.matrix.col_perm());
            assert_eq!(sibling.matrix.orderings, 0, "{scheme:?}: ordered again");
            let state = sys.initial.clone();
            let [(sibling_end, sibling_iterations), (fresh_end, fresh_iterations)] =
                [sibling, fresh].map(|mut integ| {
                    let (end, report) = integ.step(&sys, &state, 1e-3).unwrap();
                    (end, report.iterations)
                });
            assert_eq!(sibling_iterations, fresh_iterations, "{scheme:?}");
            // From the same start through the same pattern and order: equal to the bit.
            for (a, (s, f)) in sibling_end.nodes.iter().zip(&fresh_end.nodes).enumerate() {
                assert!(
                    s.x == f.x && s.v == f.v && s.w == f.w,
                    "{scheme:?}: node {a}"
                );
            }
        }
    }

    /// Asking an EP integrator for ED's decoupled factors (the benchmarks' public calls) gets
    /// its exact ones: the same update as `Factors::Exact`, where it used to index past the
    /// beam's EP block and panic.
    #[test]
    fn an_ep_integrator_asked_for_decoupled_factors_uses_its_exact_ones() {
        let model = free_collar();
        let sys = crate::compile::compile(&model, Scheme::Ep).unwrap();
        let h = model.simulation.dt;
        let ctx = Integrator::step_ctx(&sys, &sys.initial, h);
        let update = |factors: Factors| {
            let mut integ = Integrator::new(&sys, &model.simulation);
            integ.predict(&sys, &sys.initial, h);
            integ.newton_iteration_with(&sys, &ctx, factors).unwrap();
            integ.y.clone()
        };
        assert_eq!(update(Factors::Decoupled), update(Factors::Exact));
    }

    /// A rebuilt pattern keeps the counts of what was factored before it: numeric,
    /// pivoting (of the exact and the decoupled matrices) and orderings, so run statistics
    /// stay whole over a sliding joint's window moves (EP and ED, modified Newton).
    #[test]
    fn a_rebuild_keeps_the_factorization_counts() {
        let model = free_collar();
        for scheme in [Scheme::Ep, Scheme::Ed] {
            let sys = crate::compile::compile(&model, scheme).unwrap();
            let mut integ = Integrator::new(&sys, &model.simulation);
            let mut state = sys.initial.clone();
            for _ in 0..20 {
                state = integ.step(&sys, &state, 5e-3).unwrap().0;
            }
            let counts = |i: &Integrator| {
                [
                    i.factorizations(),
                    i.pivoting_factorizations(),
                    i.matrix.orderings,
                ]
            };
            let before = counts(&integ);
            assert!(before[0] > before[1], "{scheme:?}: some refactorizations");
            integ.rebuild_pattern(&sys, model.simulation.dt);
            assert_eq!(counts(&integ)[..2], before[..2], "{scheme:?}");
            assert_eq!(
                counts(&integ)[2],
                before[2] + 1,
                "{scheme:?}: one more ordering"
            );
        }
    }
}

//! Everything that adds to the discrete equations of a step is a *kernel*: it owns a list of
//! unknowns (its local block) and evaluates its residual over them, generically over [`Real`].
//! [`eval_kernel`] evaluates a kernel with dual numbers, which yields the residual and the
//! exact tangent block in one go; the generic finite-difference harness in the tests checks
//! every kernel against central differences of the same residual.

pub mod coordinate;
pub mod inertia;
pub mod loads;

use crate::math::layout::Layout;
use crate::math::layout::Scheme;
use crate::math::scalar::{Dual, Real, DUAL_WIDTH};
use crate::math::vec3::V3;
use crate::math::wide::wide;
use crate::state::State;

/// Where a kernel's local tangent entry lands in a matrix's values (`vals[pos[i·n + j]]`).
/// Assembly reads these tables and writes the values at random: 32 bits halve the tables
/// (a pattern of 2³² entries would need 32 GB of values, far beyond any model here).
pub type ValuePos = u32;

/// Value position `p` as stored in a block's table (a pattern of 2³² entries cannot be held
/// in memory first).
pub fn value_pos(p: usize) -> ValuePos {
    ValuePos::try_from(p).expect("fewer than 2³² matrix entries")
}

/// The positions of an `n × n` block in a matrix of its own (row-major): for probing a
/// kernel's block alone.
pub fn own_block_positions(n: usize) -> Vec<ValuePos> {
    (0..value_pos(n * n)).collect()
}

/// Largest local block (unknowns of one kernel). A sliding clamp on cubic elements under ED
/// has the most: a window of 10 beam nodes and the follower (11×12), ζ and its jump, and
/// 2×6 multipliers = 146.
pub const MAX_LOCAL: usize = 160;
/// Largest block differentiated in one piece with dual numbers (a two-node joint under ED has
/// 2×12 + 2×2 + 2×8 = 44; a sliding joint differentiates node by node). Kept small: the
/// dual-number buffers are initialised on every evaluation.
pub const MAX_DUAL_LOCAL: usize = 64;

/// What a kernel needs to know about the step being taken.
pub struct StepCtx<'a> {
    pub layout: Layout,
    pub h: f64,
    pub t_i: f64,
    pub t_f: f64,
    /// Multiplier scaling `s` (kg/s²): constraint forces are `s μ`, constraint rows `s C`.
    pub s: f64,
    /// The converged state at the start of the step.
    pub state: &'a State,
    pub gravity: V3<f64>,
    /// `Some(λ)` in a static solve at load factor λ (loads and gravity times λ; no inertia,
    /// sectional and constraint forces at the end state); `None` in a time step.
    pub statics: Option<f64>,
}

impl StepCtx<'_> {
    /// A time step with the ED scheme (never in statics, whose layout is EP's).
    pub fn ed(&self) -> bool {
        self.statics.is_none() && self.layout.scheme == Scheme::Ed
    }
    pub fn is_static(&self) -> bool {
        self.statics.is_some()
    }
    /// Multiplier of applied loads and gravity: the load factor in statics, 1 in dynamics.
    pub fn load_factor(&self) -> f64 {
        self.statics.unwrap_or(1.0)
    }
}

pub trait Kernel {
    /// Global indices of the kernel's unknowns; its residual rows are the same indices.
    fn unknowns(&self) -> &[usize];
    /// Residual contributions over the local unknowns `y` (rows scaled by 1/h: forces).
    fn residual<T: Real>(&self, ctx: &StepCtx, y: &[T], r: &mut [T]);
    /// Adds the residual to `res` and each row's contribution magnitude to `activity` (the
    /// convergence test's force scale): what a residual-only assembly calls. Must add what
    /// [`Kernel::evaluate`] adds without a tangent.
    fn residual_with_activity(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        activity: &mut [f64],
    ) where
        Self: Sized,
    {
        wide(
            #[inline(always)]
            || residual_sized(self, ctx, y, res, Some(activity)),
        )
    }
    /// Adds the residual and, if asked, the exact tangent block (see [`eval_kernel`]). A
    /// kernel whose residual is a sum of small parts over subsets of its unknowns (a sliding
    /// joint's window) differentiates them part by part.
    fn evaluate(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        jac: Option<(&mut [f64], &[ValuePos])>,
    ) where
        Self: Sized,
    {
        eval_kernel(self, ctx, y, res, jac)
    }
    /// ED under modified Newton: the residual and, of the tangent, at least the rows the
    /// decoupled complex system reads (`integrator::ed_decoupled`: the j-rows' motion
    /// columns, the f-rows' multiplier columns, the constraint rows' increment columns). A
    /// kernel may write them from a cheaper surrogate (an EP stiffness); by default they
    /// are the exact tangent's.
    fn evaluate_decoupled(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        res: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) where
        Self: Sized,
    {
        self.evaluate(ctx, y, res, Some((vals, pos)))
    }
    /// [`Kernel::evaluate_decoupled`]'s tangent entries where the residual is not wanted (a
    /// contact border's refresh): by default with the residual added into `scratch`; a
    /// kernel that computes its residual apart from those entries skips it.
    fn decoupled_tangent(
        &self,
        ctx: &StepCtx,
        y: &[f64],
        scratch: &mut [f64],
        vals: &mut [f64],
        pos: &[ValuePos],
    ) where
        Self: Sized,
    {
        self.evaluate_decoupled(ctx, y, scratch, vals, pos)
    }
    /// The structurally nonzero entries of the tangent block (row-major), probed at a
    /// generic state and unknowns `y`: of the exact tangent and, under ED, of the decoupled
    /// evaluation's. A kernel whose block depends on where the step goes (a sliding joint's
    /// contact point changing element) covers every case it allows.
    fn structure(&self, ctx: &StepCtx, y: &[f64]) -> Vec<bool>
    where
        Self: Sized,
    {
        tangent_structure(self, ctx, y)
    }
    /// For a kernel whose unknowns move during a run (a sliding joint's window of beam
    /// nodes), a key of its block's shape: blocks of one shape have one [`Kernel::structure`]
    /// wherever they sit, so a moved kernel takes the mask probed for its shape before
    /// instead of being probed again. `None` (the default): probed whenever its unknowns
    /// change.
    fn structure_shape(&self) -> Option<usize> {
        None
    }
}

/// Adds the kernel's residual into `res` and, if `jac` is given, its exact tangent block into
/// the sparse values at the kernel's precomputed positions (row-major `n × n`).
pub fn eval_kernel<K: Kernel>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    jac: Option<(&mut [f64], &[ValuePos])>,
) {
    let idx = k.unknowns();
    let n = idx.len();
    assert!(
        n <= MAX_LOCAL,
        "kernel block of {n} unknowns exceeds MAX_LOCAL"
    );
    match jac {
        None => wide(
            #[inline(always)]
            || residual_sized(k, ctx, y, res, None),
        ),
        Some((vals, pos)) => {
            assert!(
                n <= MAX_DUAL_LOCAL,
                "kernel block of {n} unknowns is too large to differentiate in one piece"
            );
            // Buffers sized to the block: they are initialised on every pass.
            // One pass as wide as a small block (a node's 12 ED unknowns), else passes of 8.
            match n {
                0..=8 => dual_passes::<K, 8, 8>(k, ctx, y, res, vals, pos),
                9..=12 => dual_passes::<K, 12, 12>(k, ctx, y, res, vals, pos),
                13..=16 => dual_passes::<K, 16, 16>(k, ctx, y, res, vals, pos),
                17..=32 => dual_passes::<K, 32, DUAL_WIDTH>(k, ctx, y, res, vals, pos),
                _ => dual_passes::<K, MAX_DUAL_LOCAL, DUAL_WIDTH>(k, ctx, y, res, vals, pos),
            }
        }
    }
}

/// [`residual_pass`] with buffers sized to the block: zeroing MAX_LOCAL entries for every
/// kernel was 7–10 % of a beam model's residual.
#[inline(always)]
pub(crate) fn residual_sized<K: Kernel>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    activity: Option<&mut [f64]>,
) {
    match k.unknowns().len() {
        0..=12 => residual_pass::<K, 12>(k, ctx, y, res, activity),
        13..=24 => residual_pass::<K, 24>(k, ctx, y, res, activity),
        25..=48 => residual_pass::<K, 48>(k, ctx, y, res, activity),
        49..=96 => residual_pass::<K, 96>(k, ctx, y, res, activity),
        _ => residual_pass::<K, MAX_LOCAL>(k, ctx, y, res, activity),
    }
}

/// The residual alone, with local buffers of `M ≥ n` entries (and, if given, each row's
/// contribution magnitude added to `activity`).
#[inline(always)]
fn residual_pass<K: Kernel, const M: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    activity: Option<&mut [f64]>,
) {
    let idx = k.unknowns();
    let n = idx.len();
    let mut yl = [0.0f64; M];
    let mut rl = [0.0f64; M];
    for (l, &g) in idx.iter().enumerate() {
        yl[l] = y[g];
    }
    k.residual(ctx, &yl[..n], &mut rl[..n]);
    // One pass over the indices for both sums.
    match activity {
        Some(activity) => {
            for (&r, &g) in rl[..n].iter().zip(idx) {
                res[g] += r;
                activity[g] += r.abs();
            }
        }
        None => {
            for (&r, &g) in rl[..n].iter().zip(idx) {
                res[g] += r;
            }
        }
    }
}

/// The residual and the tangent block by `⌈n / W⌉` dual-number passes of width `W`, with
/// local buffers of `M ≥ n` entries.
fn dual_passes<K: Kernel, const M: usize, const W: usize>(
    k: &K,
    ctx: &StepCtx,
    y: &[f64],
    res: &mut [f64],
    vals: &mut [f64],
    pos: &[ValuePos],
) {
    let idx = k.unknowns();
    let n = idx.len();
    let mut yl = [Dual::<W>::constant(0.0); M];
    let mut rl = [Dual::<W>::constant(0.0); M];
    let mut start = 0;
    while start < n.max(1) {
        for (l, &g) in idx.iter().enumerate() {
            let dir = (l >= start && l < start + W).then(|| l - start);
            yl[l] = Dual::seeded(y[g], dir);
        }
        if start > 0 {
            for v in rl[..n].iter_mut() {
                *v = Dual::constant(0.0);
            }
        }
        k.residual(ctx, &yl[..n], &mut rl[..n]);
        if start == 0 {
            for (l, &g) in idx.iter().enumerate() {
                res[g] += rl[l].re;
            }
        }
        let width = W.min(n - start);
        for i in 0..n {
            for d in 0..width {
                vals[pos[i * n + start + d] as usize] += rl[i].du[d];
            }
        }
        start += W;
    }
}

/// The nonzero entries of a kernel's tangent block (row-major) at the local unknowns `y`.
/// Entries at round-off level (an analytically zero term computed as 1e-17, e.g. a moment
/// about a lever arm's own axis) count as zero.
pub fn block_structure<K: Kernel>(k: &K, ctx: &StepCtx, y: &[f64]) -> Vec<bool> {
    let n = k.unknowns().len();
    let pos = own_block_positions(n);
    let mut vals = vec![0.0; n * n];
    with_residual_scratch(k, y.len(), |res| {
        k.evaluate(ctx, y, res, Some((&mut vals, &pos)))
    });
    let scale = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    vals.iter().map(|v| v.abs() > 1e-13 * scale).collect()
}

thread_local! {
    /// A whole-system residual for the structure probes, zero between uses.
    static RESIDUAL_SCRATCH: std::cell::RefCell<Vec<f64>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// `probe` with a zero residual of `len` entries, which `k` writes at its own unknowns (the
/// structure reads only the tangent block). One buffer for all kernels, cleared at those
/// unknowns after each: a fresh zero-filled one per kernel made a model's structure
/// O(kernels × unknowns) (a 2000-element beam's rigidified pre-load: 6 000 kernels × 72 000
/// unknowns, a fifth of its set-up in zero-fills).
fn with_residual_scratch<K: Kernel>(k: &K, len: usize, probe: impl FnOnce(&mut [f64])) {
    RESIDUAL_SCRATCH.with(|scratch| {
        let mut res = scratch.borrow_mut();
        if res.len() < len {
            res.resize(len, 0.0);
        }
        probe(&mut res[..len]);
        for &u in k.unknowns() {
            res[u] = 0.0;
        }
    })
}

/// The entries any tangent the kernel assembles at `y` can write (row-major): the exact
/// one's and, under ED, the decoupled evaluation's. Kernels that override
/// [`Kernel::structure`] to probe several states take the union of these.
pub fn tangent_structure<K: Kernel>(k: &K, ctx: &StepCtx, y: &[f64]) -> Vec<bool> {
    let mut mask = block_structure(k, ctx, y);
    if ctx.ed() {
        let decoupled = decoupled_structure(k, ctx, y);
        mask.iter_mut().zip(decoupled).for_each(|(a, b)| *a |= b);
    }
    mask
}

/// The nonzero entries [`Kernel::evaluate_decoupled`] writes (row-major) at `y`.
pub fn decoupled_structure<K: Kernel>(k: &K, ctx: &StepCtx, y: &[f64]) -> Vec<bool> {
    let n = k.unknowns().len();
    let pos = own_block_positions(n);
    let mut vals = vec![0.0; n * n];
    with_residual_scratch(k, y.len(), |res| {
        k.evaluate_decoupled(ctx, y, res, &mut vals, &pos)
    });
    let scale = vals.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    vals.iter().map(|v| v.abs() > 1e-13 * scale).collect()
}

/// Reads a 3-vector from a local block.
#[inline]
pub fn v3<T: Real>(y: &[T], at: usize) -> V3<T> {
    V3([y[at], y[at + 1], y[at + 2]])
}

#[inline]
pub fn add3<T: Real>(r: &mut [T], at: usize, v: V3<T>) {
    r[at] += v.0[0];
    r[at + 1] += v.0[1];
    r[at + 2] += v.0[2];
}

#[cfg(test)]
pub mod fd_harness {
    //! The one generic tangent test: any kernel's dual-number tangent against central finite
    //! differences of its own residual.
    use super::*;

    /// Returns the largest |J_ad − J_fd| relative to max(1, |J|) over the block.
    pub fn tangent_error<K: Kernel>(k: &K, ctx: &StepCtx, y: &[f64]) -> f64 {
        let idx = k.unknowns();
        let n = idx.len();
        let ng = y.len();
        let pos = own_block_positions(n);
        let mut vals = vec![0.0; n * n];
        let mut res = vec![0.0; ng];
        k.evaluate(ctx, y, &mut res, Some((&mut vals, &pos)));
        let scale = vals.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        // The residual from the tangent's path must be the residual (kernels with their own
        // tangent compute it twice).
        let mut plain = vec![0.0; ng];
        k.evaluate(ctx, y, &mut plain, None);
        let res_scale = plain.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let mut worst = idx
            .iter()
            .fold(0.0f64, |m, &g| m.max((res[g] - plain[g]).abs() / res_scale));
        for j in 0..n {
            let g = idx[j];
            let e = 1e-6 * (1.0 + y[g].abs());
            let mut yp = y.to_vec();
            yp[g] += e;
            let mut ym = y.to_vec();
            ym[g] -= e;
            let mut rp = vec![0.0; ng];
            let mut rm = vec![0.0; ng];
            k.evaluate(ctx, &yp, &mut rp, None);
            k.evaluate(ctx, &ym, &mut rm, None);
            for i in 0..n {
                let fd = (rp[idx[i]] - rm[idx[i]]) / (2.0 * e);
                worst = worst.max((vals[i * n + j] - fd).abs() / scale);
            }
        }
        worst
    }
}

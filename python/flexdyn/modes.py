"""Natural frequencies and mode shapes, linearized about a static equilibrium.

The Rust core gives the static tangent K (elastic and geometric stiffness, including that of
the constraint forces, bordered by the constraint gradients) and the lumped mass matrix M,
both sparse. The lowest modes are those of `K φ = ω² M φ` on the motions the constraints
admit, found by shift-invert: the eigenvalues μ = 1/(ω² + σ) of largest magnitude of
`(K + σM)⁻¹M`. Small models (up to `DENSE_LIMIT` unknowns) eliminate the constraints with a
null-space basis of their gradients and solve densely with numpy; larger ones solve the
bordered system `[K + σM  Bᵀ; B  0]` with a sparse LU (SuperLU) inside ARPACK's Arnoldi
iteration (scipy), so memory and time grow with the matrix's nonzeros, not n². (K carries the
static solver's 1e-12 tangent regularisation, far below round-off of the eigenvalues.)

With viscous damping C (beams' structural damping, joint dampers) each mode's damped root
λ = −ζω ± iω√(1 − ζ²) of `(λ²M + λC + K) φ = 0` is found by Newton's method from the
undamped mode (see `_damped_roots`): the roots that belong to the lowest modes, not the
cluster of overdamped roots at −1/μ that stiffness-proportional damping gives the highest ones.
"""

from __future__ import annotations

import json

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import xarray as xr

from . import _core
from .results import static_model_data

# Above this many unknowns the sparse path (dense below: every mode, no iteration).
DENSE_LIMIT = 1500


def modes(
    model,
    count: int = 10,
    *,
    preload: bool = True,
    load_steps: int | None = None,
    method: str = "auto",
) -> xr.Dataset:
    """The `count` lowest modes of a model about its static equilibrium under its loads and
    gravity (`preload=True`, solved as by `solve_static`) or about its initial configuration.

    Returns an xarray.Dataset over `mode` (1, 2, …) with `omega` (rad/s), `frequency` (Hz)
    of the undamped modes; `damping_ratio` ζ, `damped_frequency` (Hz, ω√(1 − ζ²)/2π) and
    `decay_rate` (ζω, 1/s) of the damped ones (0, `frequency` and 0 without damping; an
    overdamped mode has ζ ≥ 1 and no damped frequency); and
    `shape[mode, dof]` of the undamped modes: mass-normalized nodal displacements and (material) rotations,
    `dof` labels `<node>.<x|y|z|rx|ry|rz>`. Rigid-body modes of an unrestrained model appear
    with ω ≈ 0. Raises ModelError if some admissible motion carries no mass (give the node a
    body or restrain it).

    `method`: "dense" (every mode of the constrained problem, memory ∝ n²), "sparse"
    (shift-invert Arnoldi on the sparse matrices: a 1000-element beam's lowest modes in
    seconds), or "auto" (dense up to DENSE_LIMIT unknowns).
    """
    if method not in ("auto", "dense", "sparse"):
        raise _core.ModelError(f'modes: method must be "auto", "dense" or "sparse", not {method!r}')
    data = static_model_data(model, load_steps)
    data["simulation"]["fields"] = True  # the equilibrium's geometry, to draw the shapes
    sim = _core.Simulation(json.dumps(data))
    if preload:
        try:
            sim.solve_static()
        except _core.SolverError as e:
            raise _core.SolverError(
                f"{e}\nmodes: the static pre-load has no solution near this configuration; "
                "linearize about the initial configuration instead with preload=False "
                "(flexdyn modes --no-preload)"
            ) from None
    geometry = _equilibrium_geometry(sim)
    omega2, omega, roots, shape, node_dofs_labels = _solve(sim.linearize(), count, method)
    count = omega2.size
    natural = np.abs(roots)
    zeta = np.where(natural > 0, -roots.real / np.where(natural > 0, natural, 1.0), 0.0)
    node_names, x0, topology = geometry
    return xr.Dataset(
        {
            "node_position": (("node", "xyz"), x0, {"units": "m", "long_name": "equilibrium position"}),
            "omega": ("mode", omega, {"units": "rad/s"}),
            # Negative below an unstable equilibrium (ω is then shown as 0).
            "omega_squared": ("mode", omega2, {"units": "rad^2/s^2"}),
            "frequency": ("mode", omega / (2 * np.pi), {"units": "Hz"}),
            "damping_ratio": ("mode", zeta, {"units": "1"}),
            "damped_frequency": ("mode", np.abs(roots.imag) / (2 * np.pi), {"units": "Hz"}),
            "decay_rate": ("mode", -roots.real, {"units": "1/s"}),
            "shape": (("mode", "dof"), shape, {"units": "mass-normalized"}),
        },
        coords={
            "mode": np.arange(1, count + 1),
            "dof": node_dofs_labels,
            "node": node_names,
            "xyz": ["x", "y", "z"],
        },
        attrs={"model": data.get("name") or "", "flexdyn_topology": topology},
    )


def _solve(linearization, count: int, method: str):
    """The `count` lowest modes of a linearization (`Simulation.linearize`): ω², ω, the damped
    roots, the shapes over the nodes' unknowns and their labels."""
    n, (kp, ki, kv), (mr, mc, mv), (cr, cc, cv), labels = linearization
    k = sp.csc_matrix((kv, ki, kp), shape=(n, n))
    m = sp.csc_matrix((mv, (mr, mc)), shape=(n, n))
    c = sp.csc_matrix((cv, (cr, cc)), shape=(n, n))
    rows = np.array([lab.startswith("row:") for lab in labels], dtype=bool)
    dense = method == "dense" or (method == "auto" and n <= DENSE_LIMIT)
    if dense:
        omega2, shapes_q = _dense_modes(k.toarray(), m.toarray(), rows, count)
    else:
        omega2, shapes_q = _sparse_modes(k, m, rows, count)
    omega = np.sqrt(np.clip(omega2, 0.0, None))
    if c.nnz:
        roots = (_dense_damped if dense else _sparse_damped)(k, m, c, rows, omega, shapes_q)
    else:
        roots = omega.astype(complex) * 1j
    q_labels = [lab for lab, keep in zip(labels, ~rows) if keep]
    node_dofs = [i for i, lab in enumerate(q_labels) if not lab.startswith("coord:")]
    return omega2, omega, roots, shapes_q[node_dofs, :].T, [q_labels[i] for i in node_dofs]


def _equilibrium_geometry(sim) -> tuple[list[str], np.ndarray, str]:
    """Node names, their positions in the current (equilibrium) state and the topology JSON,
    from the static run's last sample (its field columns: positions first)."""
    layout = sim.field_layout
    _, values = sim.take_samples()
    topology = json.loads(layout["topology"])
    n = len(topology["nodes"])
    first = len(sim.channel_names)
    x0 = values[-1, first : first + 3 * n].reshape(n, 3)
    return topology["nodes"], x0, layout["topology"]


def _shift(kqq_diag, mqq_diag):
    """The shift σ: far below any elastic ω², enough to keep K + σM regular when there
    are rigid-body modes."""
    return 1e-10 * np.sum(kqq_diag) / np.sum(mqq_diag)


def _mass_normalized(vecs, mqq):
    return vecs / np.sqrt(np.einsum("im,im->m", vecs, mqq @ vecs))


def _dense_modes(k, m, rows, count):
    """Every mode of a small model: constraints eliminated with the null space Z of their
    gradients, `ZᵀKZ φ = ω² ZᵀMZ φ` in shift-invert form. Returns (ω², shapes over the
    non-row unknowns) of the `count` lowest."""
    q = ~rows
    kqq = k[np.ix_(q, q)]
    mqq = m[np.ix_(q, q)]
    z = _null_space(k, rows)
    # K is not symmetrized: follower loads make it unsymmetric (their eigenvalues may then
    # be complex near flutter; the real part of ω² is reported).
    kr = z.T @ kqq @ z
    mr = z.T @ mqq @ z
    mr = 0.5 * (mr + mr.T)
    if np.any(np.linalg.eigvalsh(mr) <= 1e-14 * np.abs(mr).max()):
        raise _core.ModelError(NO_MASS)
    # The lowest modes get the largest μ and so full relative accuracy, even when tiny
    # rotary inertias put the highest ω² twenty orders of magnitude above them (a direct
    # solve loses them).
    sigma = _shift(np.diag(kr), np.diag(mr))
    mu, vecs = np.linalg.eig(np.linalg.solve(kr + sigma * mr, mr))
    mu, vecs = mu.real, vecs.real
    order = np.argsort(-mu)[: min(count, mu.size)]
    vecs = z @ _mass_normalized(vecs[:, order], mr)
    return 1.0 / mu[order] - sigma, vecs


def _sparse_modes(k, m, rows, count):
    """The `count` lowest modes of a large model by shift-invert Arnoldi on the bordered
    system (the solves keep the iterates on the constraints). Same results as the dense
    path (tests compare them)."""
    q = np.flatnonzero(~rows)
    mqq = m[q][:, q].tocsr()
    sigma = _shift(k.diagonal()[q], mqq.diagonal())
    try:
        lu = spla.splu((k + sigma * m).tocsc())
    except RuntimeError:
        raise _core.ModelError(NO_MASS_OR_REDUNDANT) from None
    n = k.shape[0]
    rhs = np.zeros(n)

    def apply(v):
        rhs[q] = mqq @ v
        return lu.solve(rhs)[q]

    op = spla.LinearOperator((q.size, q.size), matvec=apply, dtype=float)
    count = min(count, q.size - 2)
    mu, vecs = spla.eigs(op, k=count, which="LM")
    mu, vecs = mu.real, vecs.real
    if not np.all(np.isfinite(mu)):
        raise _core.ModelError(NO_MASS_OR_REDUNDANT)
    order = np.argsort(-mu)
    return 1.0 / mu[order] - sigma, _mass_normalized(vecs[:, order], mqq)


def _damped_roots(solve, m, c, omega, shapes):
    """The damped root λ of each undamped mode (ω_i, φ_i), by Newton's method on
    `Q(λ) x = (λ²M + λC + K) x = 0` with `φ_iᵀ x = 1` (nonlinear inverse iteration:
    `Q(λ) y = Q′(λ) x`, `λ ← λ − 1/φᵀy`, `x ← y/φᵀy`), from the root of the mode's own
    projection `λ² + λ c_ii + ω_i² = 0`, `c_ii = φ_iᵀCφ_i` (exact for Rayleigh damping).
    `solve(λ, b)` solves with Q(λ) on the admissible motions. A mode whose projection is
    overdamped keeps the projection's slow real root."""
    roots = np.empty(omega.size, dtype=complex)
    for i, (w, phi) in enumerate(zip(omega, shapes.T)):
        cii = phi @ (c @ phi)
        disc = 0.25 * cii * cii - w * w
        if disc >= 0.0:
            roots[i] = -0.5 * cii + np.sqrt(disc)
            continue
        lam, x = complex(-0.5 * cii, np.sqrt(-disc)), phi.astype(complex)
        for _ in range(30):
            y = solve(lam, (2 * lam) * (m @ x) + c @ x)
            step = 1.0 / (phi @ y)
            lam, x = lam - step, y * step
            if abs(step) <= 1e-13 * abs(lam):
                break
        roots[i] = lam
    return roots


def _dense_damped(k, m, c, rows, omega, shapes):
    """Damped roots of a small model, constraints eliminated as in `_dense_modes`."""
    k, m, c = k.toarray(), m.toarray(), c.toarray()
    q = ~rows
    z = _null_space(k, rows)
    kr, mr, cr = (z.T @ a[np.ix_(q, q)] @ z for a in (k, m, c))
    reduced = z.T @ shapes  # z is orthonormal: the shapes' coordinates in its basis

    def solve(lam, b):
        return np.linalg.solve(lam * lam * mr + lam * cr + kr, b)

    return _damped_roots(solve, mr, cr, omega, reduced)


def _sparse_damped(k, m, c, rows, omega, shapes):
    """Damped roots of a large model, with bordered complex solves as in `_sparse_modes`."""
    q = np.flatnonzero(~rows)
    mqq, cqq = m[q][:, q].tocsr(), c[q][:, q].tocsr()
    rhs = np.zeros(k.shape[0], dtype=complex)

    def solve(lam, b):
        rhs[q] = b
        return spla.splu((lam * lam * m + lam * c + k).tocsc()).solve(rhs)[q]

    return _damped_roots(solve, mqq, cqq, omega, shapes)


def _null_space(k, rows):
    """A basis Z of the motions the constraints admit (null space of their gradients)."""
    q = ~rows
    if not rows.any():
        return np.eye(int(q.sum()))
    _, sv, vt = np.linalg.svd(k[np.ix_(rows, q)])
    rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size else 0
    return vt[rank:].T


NO_MASS = (
    "modes: some admissible motion carries no mass (a node without a body or beam "
    "inertia that no joint restrains); give it a body or restrain it"
)
NO_MASS_OR_REDUNDANT = (
    "modes: the shifted stiffness is singular: some admissible motion carries neither mass "
    "nor stiffness (a node without a body or beam inertia that no joint restrains), or "
    "constraints are redundant; give the node a body or restrain it"
)

"""Natural frequencies and mode shapes, linearized about a static equilibrium.

The Rust core gives the static tangent K (elastic and geometric stiffness, including that of
the constraint forces, bordered by the constraint gradients) and the lumped mass matrix M.
The constraints are eliminated exactly with a null-space basis Z of their gradients, and the
problem `ZᵀKZ φ = ω² ZᵀMZ φ` is solved densely with numpy in shift-invert form. (K carries
the static solver's 1e-12 tangent regularisation, far below round-off of the eigenvalues.)
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from . import _core
from .results import static_model_data


def modes(model, count: int = 10, *, preload: bool = True, load_steps: int | None = None) -> xr.Dataset:
    """The `count` lowest modes of a model about its static equilibrium under its loads and
    gravity (`preload=True`, solved as by `solve_static`) or about its initial configuration.

    Returns an xarray.Dataset over `mode` (1, 2, …) with `omega` (rad/s), `frequency` (Hz)
    and `shape[mode, dof]`: mass-normalized nodal displacements and (material) rotations,
    `dof` labels `<node>.<x|y|z|rx|ry|rz>`. Rigid-body modes of an unrestrained model appear
    with ω ≈ 0. Raises ModelError if some admissible motion carries no mass (give the node a
    body or restrain it).
    """
    data = static_model_data(model, load_steps)
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
    k, m, labels = sim.linearize()
    rows = np.array([lab.startswith("row:") for lab in labels])
    q = ~rows
    kqq = k[np.ix_(q, q)]
    mqq = m[np.ix_(q, q)]
    if rows.any():
        b = k[np.ix_(rows, q)]
        _, sv, vt = np.linalg.svd(b)
        rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size else 0
        z = vt[rank:].T
    else:
        z = np.eye(int(q.sum()))
    # K is not symmetrized: follower loads make it unsymmetric (their eigenvalues may then
    # be complex near flutter; the real part of ω² is reported).
    kr = z.T @ kqq @ z
    mr = z.T @ mqq @ z
    mr = 0.5 * (mr + mr.T)
    if np.any(np.linalg.eigvalsh(mr) <= 1e-14 * np.abs(mr).max()):
        raise _core.ModelError(
            "modes: some admissible motion carries no mass (a node without a body or beam "
            "inertia that no joint restrains); give it a body or restrain it"
        )
    # Shift-invert: μ = 1/(ω² + σ) are the eigenvalues of (K + σM)⁻¹M. The lowest modes get
    # the largest μ and so full relative accuracy, even when tiny rotary inertias put the
    # highest ω² twenty orders of magnitude above them (a direct solve loses them). The
    # shift (far below any elastic ω²) keeps K + σM regular when there are rigid-body modes.
    sigma = 1e-10 * np.trace(kr) / np.trace(mr)
    mu, vecs = np.linalg.eig(np.linalg.solve(kr + sigma * mr, mr))
    mu, vecs = mu.real, vecs.real
    order = np.argsort(-mu)
    count = min(count, mu.size)
    omega2 = 1.0 / mu[order[:count]] - sigma
    vecs = vecs[:, order[:count]]
    vecs /= np.sqrt(np.einsum("im,ij,jm->m", vecs, mr, vecs))
    omega = np.sqrt(np.clip(omega2, 0.0, None))
    shapes_q = z @ vecs
    q_labels = [lab for lab, keep in zip(labels, q) if keep]
    node_dofs = [i for i, lab in enumerate(q_labels) if not lab.startswith("coord:")]
    shape = shapes_q[node_dofs, :].T
    return xr.Dataset(
        {
            "omega": ("mode", omega, {"units": "rad/s"}),
            # Negative below an unstable equilibrium (ω is then shown as 0).
            "omega_squared": ("mode", omega2, {"units": "rad^2/s^2"}),
            "frequency": ("mode", omega / (2 * np.pi), {"units": "Hz"}),
            "shape": (("mode", "dof"), shape, {"units": "mass-normalized"}),
        },
        coords={"mode": np.arange(1, count + 1), "dof": [q_labels[i] for i in node_dofs]},
        attrs={"model": data.get("name") or ""},
    )

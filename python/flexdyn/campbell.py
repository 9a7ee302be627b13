"""Campbell diagrams: the natural frequencies of a spinning model over a range of spin rates,
with the gyroscopic (Coriolis) terms.

At each rate the model's static equilibrium in the frame turning with its `initial_spins`
(centrifugal loads, so centrifugal stiffening and spin softening) is solved, linearized
(`Simulation.linearize`, `Simulation.gyroscopic`), and the quadratic eigenproblem
`(λ²M + λG + K) φ = 0` solved on the motions the joints admit (its state-space form, densely).
Frequencies are those seen in the turning frame (a blade's); for an axisymmetric rotor the
fixed frame's whirl frequencies are these ± Ω. Modes are followed from rate to rate by the
correlation (MAC) of their shapes, so a line of the diagram is one mode even where modes cross.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import xarray as xr

from . import _core
from .modes import DENSE_LIMIT, _null_space
from .results import model_data, static_model_data


def campbell(model, speeds, *, speed: str | None = None, count: int = 6) -> xr.Dataset:
    """Frequencies (Hz, turning frame) of the `count` lowest modes of `model` at each spin rate
    of `speeds` (rad/s), set through `speed`: an override path (`initial_spins.1.rate`), a
    joint's name (the rotor's revolute: the initial spin about its axis), or by default the
    model's only initial spin. Returns a Dataset over `speed` (rad/s) and `mode` with
    `frequency` and `omega`, modes tracked across the rates."""
    from .builder import Model

    data = model_data(model)
    speed = _spin_path(data, speed)
    speeds = np.asarray(speeds, dtype=float)
    if speeds.ndim != 1 or speeds.size == 0:
        raise _core.ModelError("speeds: give one or more spin rates, rad/s")
    omegas, shapes = [], []
    for rate in speeds:
        w, phi = _spinning_modes(Model.from_dict(data).with_({speed: float(rate)}), count)
        omegas.append(w)
        shapes.append(phi)
    omega = _tracked(omegas, shapes)
    return xr.Dataset(
        {
            "frequency": (
                ("speed", "mode"),
                omega / (2 * np.pi),
                {"units": "Hz", "frame": "turning with the spin"},
            ),
            "omega": (("speed", "mode"), omega, {"units": "rad/s"}),
        },
        coords={
            "speed": ("speed", speeds, {"units": "rad/s", "path": speed}),
            "mode": np.arange(1, count + 1),
        },
        attrs={"model": data.get("name") or ""},
    )


def _spin_path(data: dict, speed: str | None) -> str:
    """The override path of the spin rate to vary: given, the initial spin about a named
    joint's axis, or the model's only initial spin."""
    spins = data.get("initial_spins", [])
    if speed and "." in speed:
        return speed
    if speed:
        return f"initial_spins.{_spin_about_joint(data, speed, spins)}.rate"
    if len(spins) != 1:
        raise _core.ModelError(
            f"campbell: the model has {len(spins)} initial spins; name the rate to vary, e.g. "
            "--speed initial_spins.0.rate=0:40:21, or the rotor's joint, --speed shaft=0:40:21"
        )
    return "initial_spins.0.rate"


def _spin_about_joint(data: dict, name: str, spins: list) -> int:
    """The index of the initial spin about joint `name`'s axis (inertial-frame joints)."""
    joint = next((j for j in data.get("joints", []) if j.get("name") == name), None)
    if joint is None or "axis" not in joint or joint.get("frame", "inertial") != "inertial":
        raise _core.ModelError(
            f"campbell: --speed `{name}` is neither an override path nor a joint with an axis in "
            "the inertial frame; give the path of the spin rate, e.g. initial_spins.0.rate"
        )
    axis = np.asarray(joint["axis"], dtype=float)
    matches = [
        k
        for k, s in enumerate(spins)
        if abs(np.dot(axis, s["axis"])) >= (1 - 1e-9) * np.linalg.norm(axis) * np.linalg.norm(s["axis"])
    ]
    if len(matches) != 1:
        raise _core.ModelError(
            f"campbell: joint `{name}`'s axis {joint['axis']} has {len(matches)} initial spins about it; "
            "give the rotor's nodes and beams one (initial_spins: [{axis, rate, items}]), or the path "
            "of the rate to vary"
        )
    return matches[0]


def _spinning_modes(model, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The `count` lowest frequencies (rad/s) and their shapes (complex, over the admissible
    coordinates) of the model linearized about its spinning equilibrium."""
    sim = _core.Simulation(json.dumps(static_model_data(model)))
    sim.solve_static()
    n, (kp, ki, kv), (mr, mc, mv), _, labels = sim.linearize()
    if n > DENSE_LIMIT:
        raise _core.ModelError(
            f"campbell: {n} unknowns; the dense gyroscopic eigen-solve takes up to {DENSE_LIMIT}"
        )
    gr, gc, gv = sim.gyroscopic()
    k = sp.csc_matrix((kv, ki, kp), shape=(n, n)).toarray()
    m = sp.csc_matrix((mv, (mr, mc)), shape=(n, n)).toarray()
    g = sp.csc_matrix((gv, (gr, gc)), shape=(n, n)).toarray()
    rows = np.array([lab.startswith("row:") for lab in labels])
    z = _null_space(k, rows)
    kr, mq, gq = (z.T @ a[np.ix_(~rows, ~rows)] @ z for a in (k, m, g))
    r = kr.shape[0]
    state = np.block([[np.zeros((r, r)), np.eye(r)], [-np.linalg.solve(mq, kr), -np.linalg.solve(mq, gq)]])
    lam, vecs = np.linalg.eig(state)
    keep = lam.imag > 1e-9 * max(np.abs(lam).max(), 1.0)
    order = np.argsort(lam.imag[keep])[:count]
    w = lam.imag[keep][order]
    if w.size < count:
        raise _core.ModelError(f"campbell: the model has only {w.size} oscillating modes; ask for fewer")
    return w, vecs[:r, keep][:, order]


def _tracked(omegas: list[np.ndarray], shapes: list[np.ndarray]) -> np.ndarray:
    """Frequencies reordered so that each column follows one mode: at each rate, the
    assignment to the previous rate's modes that maximizes the shapes' total correlation."""
    from scipy.optimize import linear_sum_assignment

    out = [omegas[0]]
    previous = shapes[0]
    for w, phi in zip(omegas[1:], shapes[1:]):
        mac = np.abs(previous.conj().T @ phi) ** 2
        mac /= np.outer(np.sum(np.abs(previous) ** 2, axis=0), np.sum(np.abs(phi) ** 2, axis=0))
        _, columns = linear_sum_assignment(-mac)
        out.append(w[columns])
        previous = phi[:, columns]
    return np.array(out)


def plot_campbell(ds: xr.Dataset, out: str | Path, orders: int = 4) -> Path:
    """The Campbell diagram: each mode's frequency against the spin rate, with the
    excitation lines n·Ω/2π (n = 1 … `orders`) dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    speed = ds["speed"].values
    fig, ax = plt.subplots(figsize=(7, 4.8))
    for k in ds["mode"].values:
        ax.plot(speed, ds["frequency"].sel(mode=k), "o-", ms=3, lw=1.3, label=f"mode {k}")
    top = float(ds["frequency"].max())
    for n in range(1, orders + 1):
        line = n * speed / (2 * np.pi)
        shown = line <= 1.05 * top
        ax.plot(speed[shown], line[shown], "--", color="0.6", lw=0.8)
        if shown.any():
            ax.annotate(f"{n}P", (speed[shown][-1], line[shown][-1]), color="0.4", fontsize="small")
    ax.set(
        xlabel="spin rate Ω [rad/s]", ylabel="frequency [Hz], turning frame", title=ds.attrs.get("model", "")
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize="small", ncol=2)
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out)
    plt.close(fig)
    return out

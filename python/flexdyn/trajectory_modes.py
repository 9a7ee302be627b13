"""Natural frequencies along a trajectory: the model run in time, stopped at chosen instants,
and linearized about each state reached — its positions, joint coordinates (a slider's η) and
internal forces, at that time — by a static analysis of the same model
(`Simulation.linearize_about`). Frozen-time frequencies: how the system's frequencies move as
the mechanism moves (the beam slider's as the contact point travels, a telescoping rotor's
as its blades retract). Velocities are not part of it (no gyroscopic terms).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import xarray as xr

from . import _core
from .fields import FieldLayout
from .modes import _solve
from .results import model_data, static_model_data


def frequencies_along(
    model,
    times=None,
    *,
    count: int = 4,
    samples: int = 21,
    method: str = "auto",
    out: str | Path | None = None,
) -> xr.Dataset:
    """The `count` lowest natural frequencies of `model` (a Model, dict or path) at `times`
    (s; default `samples` instants evenly over the run) of its run. Returns a Dataset over
    `time` with `frequency[time, mode]` (Hz) and `omega` (rad/s), and each sliding joint's
    `eta.<joint>` there; with `out`, also written as channels `frequency.mode<k>` (and the
    η's) to that NetCDF file."""
    data = model_data(model)
    data["simulation"]["fields"] = True  # the contact points' η come with the state
    run = _core.Simulation(json.dumps(data))
    times = np.linspace(0.0, run.t_end, samples) if times is None else np.asarray(times, dtype=float)
    if (
        times.ndim != 1
        or times.size == 0
        or np.any(np.diff(times) < 0)
        or times[0] < 0
        or times[-1] > run.t_end
    ):
        raise _core.ModelError(f"times: give increasing instants within the run's [0, {run.t_end:g}] s")
    static = _core.Simulation(json.dumps(static_model_data(data)))
    layout = FieldLayout.from_core(run.field_layout)
    contacts = [c["name"] for c in layout.topology["contacts"]]
    reached, freqs, etas = [], [], []
    for t in times:
        while run.t < t - 1e-12 * max(run.t_end, 1.0):
            run.advance_to(float(t), 3600.0)
        _, values = run.take_samples()
        omega2, *_ = _solve(static.linearize_about(run), count, method)
        freqs.append(np.sqrt(np.clip(omega2, 0.0, None)))
        etas.append(_contact_eta(layout, values, len(run.channel_names)))
        reached.append(run.t)
    return _dataset(np.array(reached), np.array(freqs), np.array(etas), contacts, data, out)


def _contact_eta(layout: FieldLayout, values: np.ndarray, first: int) -> np.ndarray:
    """The sliding joints' η in the last sample recorded (the state reached)."""
    if not len(values):
        return np.full(layout.sizes["contact"], np.nan)
    return layout.split(values[-1:, first:])["contact_eta"][0]


def _dataset(t, omega, etas, contacts, data, out) -> xr.Dataset:
    modes = np.arange(1, omega.shape[1] + 1)
    ds = xr.Dataset(
        {
            "frequency": (("time", "mode"), omega / (2 * np.pi), {"units": "Hz"}),
            "omega": (("time", "mode"), omega, {"units": "rad/s"}),
        },
        coords={"time": ("time", t, {"units": "s"}), "mode": modes},
        attrs={"model": data.get("name") or ""},
    )
    for k, name in enumerate(contacts):
        ds[f"eta.{name}"] = ("time", etas[:, k], {"units": "1"})
    if out is not None:
        _write(ds, out, data)
    return ds


def _write(ds: xr.Dataset, out, data: dict):
    """The frequencies as channels `frequency.mode<k>` (and the η's) of a results file."""
    from .storage import AppendOnlyNetcdf

    names = [f"frequency.mode{k}" for k in ds["mode"].values]
    names += [n for n in ds.data_vars if n.startswith("eta.")]
    columns = [ds["frequency"].values] + [ds[n].values[:, None] for n in names[len(ds["mode"]) :]]
    units = ["Hz"] * len(ds["mode"]) + ["1"] * (len(names) - len(ds["mode"]))
    attrs = {"model": ds.attrs["model"], "analysis": "frequencies_along", "flexdyn_model": json.dumps(data)}
    writer = AppendOnlyNetcdf(out, names, units, attrs)
    try:
        writer.append(ds["time"].values, np.concatenate(columns, axis=1))
        writer.finish({"completed": 1})
    finally:
        writer.close()

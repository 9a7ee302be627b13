"""Running a model and collecting its sensors as named, unit-annotated time histories.

Samples come from Rust in chunks and are appended to a NetCDF file with an unlimited time
dimension, so memory stays flat and an interrupted or failed run leaves a valid file holding
every completed step.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
import xarray as xr

from . import _core
from .builder import Model, load

#: Steps per chunk handed from Rust to Python (long enough that the seam costs nothing).
CHUNK_STEPS = 500


class _NetcdfWriter:
    def __init__(self, path: Path, names, units, attrs, dim="time", dim_units="s"):
        import netCDF4

        self.ds = netCDF4.Dataset(path, "w", format="NETCDF4")
        self.dim = dim
        self.ds.createDimension(dim, None)
        t = self.ds.createVariable(dim, "f8", (dim,))
        t.units = dim_units
        self.vars = []
        for n, u in zip(names, units):
            v = self.ds.createVariable(n, "f8", (dim,), zlib=False)
            v.units = u
            self.vars.append(v)
        for k, val in attrs.items():
            self.ds.setncattr(k, val)
        self.n = 0

    def append(self, times, values):
        m = len(times)
        if m == 0:
            return
        self.ds[self.dim][self.n : self.n + m] = times
        for j, v in enumerate(self.vars):
            v[self.n : self.n + m] = values[:, j]
        self.n += m
        self.ds.sync()

    def set_attrs(self, attrs):
        for k, val in attrs.items():
            self.ds.setncattr(k, val)

    def close(self):
        self.ds.close()


def model_data(model) -> dict:
    """The model-file dict of a Model, a dict, or a YAML/JSON path."""
    if isinstance(model, (str, Path)):
        model = load(model)
    elif isinstance(model, dict):
        model = Model.from_dict(model)
    return model.to_dict()


def static_model_data(model, load_steps: int | None = None) -> dict:
    """The model-file dict with a static analysis (and `load_steps` if given)."""
    data = model_data(model)
    data["simulation"]["analysis"] = "static"
    if load_steps is not None:
        data["simulation"]["load_steps"] = load_steps
    return data


def _dataset(times, values, names, units, attrs, dim="time", dim_units="s") -> xr.Dataset:
    data = {n: (dim, values[:, j], {"units": u}) for j, (n, u) in enumerate(zip(names, units))}
    return xr.Dataset(data, coords={dim: (dim, times, {"units": dim_units})}, attrs=attrs)


def _progress(sim, start):
    """One line on stderr: simulated time, step size, Newton iterations per step, wall time and
    the estimated time left."""
    t, t_end = sim.t, sim.t_end
    frac = t / t_end if t_end > 0 else 1.0
    bar = "#" * int(30 * frac)
    wall = time.perf_counter() - start
    left = wall * (1 - frac) / frac if frac > 0 else float("nan")
    s = sim.stats
    per_step = s["newton_iterations"] / max(s["steps"], 1)
    sys.stderr.write(
        f"\r[{bar:<30}] {100 * frac:5.1f}%  t = {t:.4g} s  dt = {sim.last_dt:.2e} s  "
        f"{per_step:.1f} it/step  wall {wall:.1f} s  left ~{left:.0f} s "
    )
    sys.stderr.flush()


def simulate(
    model,
    *,
    t_end: float | None = None,
    dt: float | None = None,
    scheme: str | None = None,
    output_dt: float | None = None,
    newton_tol: float | None = None,
    step_control: str | None = None,
    tolerance: float | None = None,
    out: str | Path | None = None,
    progress: bool = False,
    on_chunk=None,
) -> xr.Dataset:
    """Runs a model (a Model, a dict, or a YAML path) and returns its sensors as an
    xarray.Dataset with a `time` coordinate; with `out`, streams them to that NetCDF file.
    A model whose `simulation.analysis` is `static` is solved as by `solve_static`.

    Keyword arguments override the model's `simulation` settings (steps are adaptive to
    `tolerance` by default, `dt` the first; `step_control="fixed"` keeps them at `dt`;
    `output_dt` records at exactly k·output_dt). With `out`, samples go to
    disk chunk by chunk and are not kept in memory: the returned dataset reads the file
    lazily, so memory stays flat however long the run. `on_chunk(times, values)` is called
    for every chunk (live plots, custom sinks). If a step cannot be completed, SolverError is
    raised after every completed step has been written; the partial results are on the
    exception as `.results`.
    """
    data = model_data(model)
    overrides = {
        "t_end": t_end,
        "dt": dt,
        "scheme": scheme,
        "output_dt": output_dt,
        "newton_tol": newton_tol,
        "step_control": step_control,
        "tolerance": tolerance,
    }
    data["simulation"].update({k: v for k, v in overrides.items() if v is not None})
    sim = _core.Simulation(json.dumps(data))
    names, units = sim.channel_names, sim.channel_units
    attrs = {
        "model": data.get("name") or "",
        "analysis": "static" if sim.is_static else "dynamic",
        "scheme": sim.scheme,
        "dt": sim.dt,
        "flexdyn_model": json.dumps(data),
    }
    dim, dim_units = ("load_factor", "1") if sim.is_static else ("time", "s")
    writer = _NetcdfWriter(Path(out), names, units, attrs, dim, dim_units) if out is not None else None
    chunks_t, chunks_v = [], []
    start = time.perf_counter()
    error = None

    def drain(callback=True):
        """Hands the samples Rust has recorded to the file (first) and to the caller."""
        t, v = sim.take_samples()
        if writer:
            writer.append(t, v)
        else:
            chunks_t.append(t)
            chunks_v.append(v)
        if callback and on_chunk is not None:
            on_chunk(t, v)

    try:
        while not sim.done:
            try:
                if sim.is_static:
                    sim.solve_static()
                else:
                    # Chunks of CHUNK_STEPS·dt (memory), or 1 % of the run when a progress line
                    # is shown, so it moves.
                    chunk = CHUNK_STEPS * sim.dt
                    sim.advance_to(sim.t + (min(chunk, 0.01 * sim.t_end) if progress else chunk))
            except _core.SolverError as e:
                error = e
            drain()
            if progress:
                _progress(sim, start)
            if error is not None:
                break
    except KeyboardInterrupt:
        error = KeyboardInterrupt(f"interrupted at t = {sim.t:.6g} s; completed steps were kept")
        sim.flush()
        drain(callback=False)
    finally:
        wall = time.perf_counter() - start
        stats = dict(sim.stats)
        stats["wall_time_s"] = wall
        run_attrs = {f"stats_{k}": v for k, v in stats.items()}
        run_attrs["warnings"] = "\n".join(sim.warnings)
        run_attrs["completed"] = int(error is None)
        if writer:
            writer.set_attrs(run_attrs)
            writer.close()
        if progress:
            sys.stderr.write("\n")
    if writer:
        ds = xr.open_dataset(out)
    else:
        times = np.concatenate(chunks_t) if chunks_t else np.zeros(0)
        values = np.concatenate(chunks_v) if chunks_v else np.zeros((0, len(names)))
        ds = _dataset(times, values, names, units, {**attrs, **run_attrs}, dim, dim_units)
    ds.attrs["stats"] = stats
    ds.attrs["warnings_list"] = list(sim.warnings)
    if error is not None:
        error.results = ds
        raise error
    return ds


def solve_static(
    model,
    *,
    load_steps: int | None = None,
    newton_tol: float | None = None,
    out: str | Path | None = None,
) -> xr.Dataset:
    """Static equilibrium of a model at t = 0: loads and gravity are ramped by a load factor
    from 0 to 1 in `load_steps` equal steps (each halved automatically if Newton fails);
    drives are held at their value at t = 0 and velocities are zero.

    Returns the sensors as an xarray.Dataset with a `load_factor` coordinate (one sample per
    converged load step, the unloaded state first); `ds.isel(load_factor=-1)` is the
    equilibrium under the full loads. Arguments as for `simulate`.
    """
    data = static_model_data(model, load_steps)
    return simulate(Model.from_dict(data), newton_tol=newton_tol, out=out)


def open_results(path: str | Path) -> xr.Dataset:
    """Opens a results file written by `simulate(..., out=...)` or `flexdyn run`."""
    return xr.open_dataset(path)

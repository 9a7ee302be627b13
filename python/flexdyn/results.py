"""Running a model and collecting its sensors as named, unit-annotated time histories.

Samples come from Rust in chunks and are appended to a NetCDF file with an unlimited time
dimension (see `storage`), at least every FLUSH_WALL_S of wall time, so memory stays flat and a
run stopped by anything — a failed step, Ctrl-C, SIGTERM, SIGKILL, a full disk, an exception in
a callback — leaves a file that opens and holds every sample up to the last flush.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import xarray as xr

from . import _core
from . import progress as progress_bar
from .accessor import FlexdynAccessor  # noqa: F401  (registers `ds.flexdyn`)
from .builder import Model, load
from .channels import channel_attrs, global_attrs
from .fields import FieldLayout
from .storage import AppendOnlyNetcdf, OutputError

#: Steps per chunk handed from Rust to Python (long enough that the seam costs nothing).
CHUNK_STEPS = 500
#: Wall time between flushes to disk, s: at most this much work is lost to a kill or a power
#: loss, and Ctrl-C or SIGTERM is answered within about this long.
FLUSH_WALL_S = 1.0
#: Results kept in memory (without `out`) beyond this many bytes are refused before the run.
MAX_IN_MEMORY_BYTES = 4 * 2**30
#: Samples held back from the file beyond this many bytes are written at once.
PENDING_BYTES = 16 * 2**20
#: Results files up to this size are read into memory when a run returns (the file is not
#: held open); larger ones are read lazily (close the dataset, or let it go, to release it).
LOAD_BYTES = 512 * 2**20

#: The record dimension's coordinate: CF attributes.
_DIM_ATTRS = {
    "time": {"units": "s", "standard_name": "time", "long_name": "time", "axis": "T"},
    "load_factor": {"units": "1", "long_name": "load factor (fraction of the full loads)"},
}


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
    """Channels as variables over `dim`; `units` (and `dim_units`) are units or attribute dicts."""
    as_attrs = lambda u: dict(u) if isinstance(u, dict) else {"units": u}
    data = {n: (dim, values[:, j], as_attrs(u)) for j, (n, u) in enumerate(zip(names, units))}
    return xr.Dataset(data, coords={dim: (dim, times, as_attrs(dim_units))}, attrs=attrs)


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
    fields: bool | None = None,
    timings: bool | None = None,
    out: str | Path | None = None,
    progress: bool | None = None,
    on_chunk=None,
) -> xr.Dataset:
    """Runs a model (a Model, a dict, or a YAML path) and returns its sensors as an
    xarray.Dataset with a `time` coordinate; with `out`, streams them to that NetCDF file.
    A model whose `simulation.analysis` is `static` is solved as by `solve_static`.

    Keyword arguments override the model's `simulation` settings (steps are adaptive to
    `tolerance` by default, `dt` the first; `step_control="fixed"` keeps them at `dt`;
    `output_dt` records at exactly k·output_dt; `fields` records the full-field motion, see
    `flexdyn.fields`; `timings` records where the wall time goes, phase by phase, in the
    statistics `time_<phase>_s`, see `timing_report`). With `out`, samples go to
    disk chunk by chunk and are not kept in memory: the returned dataset reads the file
    lazily, so memory stays flat however long the run. `on_chunk(times, values)` is called
    for every chunk (live plots, custom sinks). `progress` shows a progress bar (tqdm) once
    the run has taken 2 s; None (the default) shows it on a terminal and in Jupyter, not
    under CI or when stderr goes to a file. If a step cannot be completed, SolverError is
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
    data["simulation"].update({k: _number(k, v) for k, v in overrides.items() if v is not None})
    if fields is not None:
        data["simulation"]["fields"] = bool(fields)
    if timings is not None:
        data["simulation"]["timings"] = bool(timings)
    if out is not None:
        _check_output_path(Path(out), model)
    sim = _core.Simulation(json.dumps(data))
    names, units = sim.channel_names, sim.channel_units
    layout = FieldLayout.from_core(sim.field_layout)
    columns = len(names) + (layout.width() if layout else 0)
    if out is None:
        _check_in_memory_size(data["simulation"], columns)
    analysis = "static" if sim.is_static else "dynamic"
    attrs = {
        **global_attrs(data, analysis, sim.scheme, _version()),
        "model": data.get("name") or "",
        "analysis": analysis,
        "scheme": sim.scheme,
        "dt": sim.dt,
        "flexdyn_model": json.dumps(data),
        "completed": 0,  # until the run reaches its end
    }
    if layout:
        attrs["flexdyn_topology"] = json.dumps(layout.topology)
    units = channel_attrs(names, units, data.get("sensors", []))
    dim = "load_factor" if sim.is_static else "time"
    dim_units = _DIM_ATTRS[dim]
    writer = None
    if out is not None:
        arrays, dims = layout.netcdf(dim) if layout else ((), {})
        writer = AppendOnlyNetcdf(out, names, units, attrs, dim, dim_units, arrays, dims)
    # Asked for: at once; by default: once the run has taken DELAY_S.
    delay = progress_bar.DELAY_S if progress is None else 0.0
    run = _Run(sim, writer, on_chunk, delay if progress_bar.wanted(progress) else None, layout)
    with _StopRequests() as stop:
        try:
            run.loop(stop)
        finally:
            run.close()
    ds = _read_back(Path(out)) if writer else run.dataset(names, units, attrs, dim, dim_units)
    if run.error is not None:
        run.error.results = ds
        raise run.error
    return ds


def _version() -> str:
    from . import __version__

    return __version__


def _read_back(path: Path) -> xr.Dataset:
    """A run's results file as a dataset: in memory (the file closed) up to LOAD_BYTES, else
    lazily."""
    if path.stat().st_size <= LOAD_BYTES:
        return xr.load_dataset(path)
    return xr.open_dataset(path)


def _number(key, v):
    """A setting given as a number (numpy scalars and 0-d arrays accepted)."""
    if isinstance(v, str):
        return v
    try:
        x = np.asarray(v).item()
    except (TypeError, ValueError):
        x = None
    if not isinstance(x, (int, float)) or not np.isfinite(x):
        raise _core.ModelError(f"simulation.{key}: must be a finite number (got {v!r})")
    return x


def _check_output_path(out: Path, model):
    if isinstance(model, (str, Path)) and out.resolve() == Path(model).resolve():
        raise _core.ModelError(f"out: `{out}` is the model file itself; choose another results file")
    if out.is_dir():
        raise _core.ModelError(f"out: `{out}` is a folder; give a file name such as {out / 'results.nc'}")


def _check_in_memory_size(settings: dict, channels: int):
    """Refuses in-memory results that would not fit, before the run (files stream instead)."""
    interval = settings.get("output_dt") or (
        settings.get("dt") if settings.get("step_control") == "fixed" else None
    )
    if not interval:
        return
    samples = float(settings.get("t_end", 1.0)) / float(interval)
    need = samples * (channels + 1) * 8
    if need > MAX_IN_MEMORY_BYTES:
        raise _core.ModelError(
            f"simulation.output_dt: {samples:.3g} samples of {channels} channels need "
            f"{need / 2**30:.1f} GiB in memory; give `out=` to stream them to a file, or raise output_dt"
        )


class _StopRequests:
    """While a run is on: SIGINT and SIGTERM (and SIGHUP) ask it to stop after the current
    chunk (≤ FLUSH_WALL_S), so the file ends cleanly; a second SIGINT interrupts at once.
    Only in the main thread and only where the handlers are Python's defaults."""

    def __init__(self):
        self.signal = None
        self.saved = {}

    def __enter__(self):
        import signal
        import threading

        if threading.current_thread() is not threading.main_thread():
            return self
        for name in ("SIGINT", "SIGTERM", "SIGHUP"):
            sig = getattr(signal, name, None)
            if sig is None:
                continue
            current = signal.getsignal(sig)
            if current in (signal.SIG_DFL, signal.default_int_handler):
                self.saved[sig] = current
                signal.signal(sig, self._request)
        return self

    def _request(self, signum, frame):
        import signal

        if self.signal == signal.SIGINT and signum == signal.SIGINT:
            raise KeyboardInterrupt  # asked twice: stop now
        self.signal = signum

    def __exit__(self, *exc):
        import signal

        for sig, handler in self.saved.items():
            signal.signal(sig, handler)
        return False


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (Ctrl-C, SIGTERM, SIGHUP); `signal` is its number."""

    def __init__(self, message, signal_number):
        super().__init__(message)
        self.signal = signal_number


class _Run:
    """One run's loop: advance, hand samples to the file and the caller, stop cleanly."""

    def __init__(self, sim, writer, on_chunk, progress, layout=None):
        self.sim, self.writer, self.on_chunk = sim, writer, on_chunk
        # `progress`: the bar's delay (s), None for no bar.
        end = 1.0 if sim.is_static else sim.t_end
        self.progress = None if progress is None else progress_bar.Bar(end, sim.is_static, progress)
        self.chunks_t, self.chunks_v = [], []
        self.pending, self.pending_rows = [], 0
        self.start = self.last_flush = time.perf_counter()
        self.error = None
        # Field columns (if recorded) follow the channels in every sample.
        self.layout, self.n_channels = layout, len(sim.channel_names)
        self.completed = False
        self.stats = {}

    def drain(self, callback=True, flush=False):
        """Hands the samples Rust has recorded to the caller and towards the file, which is
        written (and synced) once FLUSH_WALL_S has passed since the last write, or `flush`:
        often enough to lose little, seldom enough that syncing costs nothing."""
        t, v = self.sim.take_samples()
        if self.writer:
            self.pending.append((t, v))
            self.pending_rows += len(t)
            due = time.perf_counter() - self.last_flush >= FLUSH_WALL_S
            if flush or due or self.pending_rows * v.shape[1] * 8 > PENDING_BYTES:
                self.flush()
        else:
            self.chunks_t.append(t)
            self.chunks_v.append(v)
        if callback and self.on_chunk is not None:
            self.on_chunk(t, v[:, : self.n_channels])

    def flush(self):
        """Writes the pending samples to the file (durably)."""
        if self.pending:
            times = np.concatenate([t for t, _ in self.pending])
            values = np.concatenate([v for _, v in self.pending])
            self.pending, self.pending_rows = [], 0
            self.writer.append(times, values)
        self.last_flush = time.perf_counter()

    def loop(self, stop):
        sim = self.sim
        try:
            while not sim.done and stop.signal is None:
                try:
                    if sim.is_static:
                        sim.solve_static()
                    else:
                        chunk = CHUNK_STEPS * sim.dt
                        if self.progress:  # 1 % of the run, so the bar moves
                            chunk = min(chunk, 0.01 * sim.t_end)
                        sim.advance_to(sim.t + chunk, FLUSH_WALL_S)
                except _core.SolverError as e:
                    self.error = e
                self.drain(flush=self.error is not None or sim.done)
                if self.progress:
                    self.progress.update(sim.load_factor if sim.is_static else sim.t, sim.stats, sim.last_dt)
                if self.error is not None:
                    return
            if stop.signal is not None:
                self.interrupted(stop.signal)
            else:
                self.completed = True
        except KeyboardInterrupt:
            import signal

            self.interrupted(signal.SIGINT)
        except OutputError as e:
            self.error = _core.SolverError(f"{e}; the run stopped at t = {sim.t:.6g} s")

    def interrupted(self, signum):
        import signal

        name = signal.Signals(signum).name
        self.error = Interrupted(
            f"interrupted ({name}) at t = {self.sim.t:.6g} s; completed steps were kept", signum
        )
        try:
            self.sim.flush()
            self.drain(callback=False, flush=True)
        except OutputError:
            pass  # the file keeps what it had; the interruption is what gets reported

    def close(self):
        """Final statistics and attributes; `completed` only for a run that reached its end."""
        sim = self.sim
        self.stats = dict(sim.stats)
        self.stats["wall_time_s"] = time.perf_counter() - self.start
        self.run_attrs = {f"stats_{k}": v for k, v in self.stats.items()}
        self.run_attrs["warnings"] = "\n".join(sim.warnings)
        self.run_attrs["completed"] = int(self.completed and sim.done)
        if self.writer:
            try:
                self.flush()  # what an exception in user code left pending
                self.writer.finish(self.run_attrs)
            except OutputError as e:
                if self.error is None:
                    self.error = _core.SolverError(str(e))
            finally:
                self.writer.close()
        if self.progress:
            self.progress.close()

    def dataset(self, names, units, attrs, dim, dim_units):
        times = np.concatenate(self.chunks_t) if self.chunks_t else np.zeros(0)
        width = len(names) + (self.layout.width() if self.layout else 0)
        values = np.concatenate(self.chunks_v) if self.chunks_v else np.zeros((0, width))
        ds = _dataset(times, values, names, units, {**attrs, **self.run_attrs}, dim, dim_units)
        if self.layout:
            ds = self.layout.add_to(ds, values[:, len(names) :], dim)
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

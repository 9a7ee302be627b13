"""Parameter sweeps: one model run for each set of overrides (`flexdyn.overrides`), on local
processes by default or on any `concurrent.futures` executor — a Dask `distributed` client's
(`Client(address)`, or `flexdyn sweep --scheduler ADDRESS`) runs the same sweep on a cluster.

Each case writes `<folder>/case_<k>.nc`; `<folder>/manifest.json` lists every case with its
parameters, status (`done`, `failed`, `pending`), error message, wall time and a summary of
chosen channels (largest magnitude and final value), rewritten atomically as cases finish. A
failed case does not stop the others; running the same sweep again into the same folder skips
the cases already done (their files complete and their parameters unchanged) — so a killed
sweep resumes. `Sweep.dataset()` gathers the channels into one xarray Dataset with a `case`
dimension, or the parameters as dimensions for a grid.
"""

from __future__ import annotations

import itertools
import json
import os
import time
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from . import _core
from . import progress as progress_bar

MANIFEST = "manifest.json"


def grid(parameters: Mapping[str, Sequence[Any]]) -> list[dict]:
    """Every combination of the values of `parameters` (path → values), first path slowest."""
    paths = list(parameters)
    return [dict(zip(paths, combo)) for combo in itertools.product(*(parameters[p] for p in paths))]


def _run_case(model: dict, overrides: dict, path: str, summary: list[str]) -> dict:
    """One case in a worker: the model with its overrides, run to `path`. Never raises: a
    failure is reported in the returned record (so one case cannot stop the sweep)."""
    from .builder import Model
    from .results import simulate

    start = time.perf_counter()
    record = {"status": "failed", "error": None, "wall_time_s": None, "summary": {}}
    try:
        res = simulate(Model.from_dict(model).with_(overrides), out=path, progress=False)
        record["summary"] = _summary(res, summary)
        record["status"] = "done"
    except BaseException as e:
        record["error"] = f"{type(e).__name__}: {e}"
        if isinstance(e, KeyboardInterrupt):
            raise
    record["wall_time_s"] = time.perf_counter() - start
    return record


def _summary(res: xr.Dataset, channels: list[str]) -> dict:
    out = {}
    for name in channels:
        if name in res:
            v = res[name].values
            finite = v[np.isfinite(v)]
            out[name] = {
                "max_abs": float(np.abs(finite).max()) if finite.size else None,
                "final": float(v[-1]) if v.size and np.isfinite(v[-1]) else None,
            }
    return out


class Sweep:
    """A sweep's folder: its manifest, files and gathered results."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        self.manifest = json.loads((self.folder / MANIFEST).read_text())

    @property
    def cases(self) -> list[dict]:
        """Every case of the sweep: its overrides, results file and status (manifest entries)."""
        return self.manifest["cases"]

    def failed(self) -> list[dict]:
        """The cases whose run failed (their manifest entries, with the error)."""
        return [c for c in self.cases if c["status"] == "failed"]

    def dataset(self, channels: Sequence[str] | None = None) -> xr.Dataset:
        """The channels (default: all) of the finished cases, along `case` (with each
        parameter as a coordinate); a grid sweep with every case done is unstacked so that its
        parameters are dimensions. Cases whose output times differ are joined on the union
        of the times (NaN where a case has no sample): give `output_dt` to align them."""
        from .fields import is_field_variable

        sets, done = [], [c for c in self.cases if c["status"] == "done"]
        for c in done:
            with xr.open_dataset(self.folder / c["file"]) as ds:
                keep = [n for n in (channels or ds.data_vars) if not is_field_variable(n)]
                sets.append(ds[keep].load())
        if not sets:
            raise ValueError(f"no finished case in {self.folder}")
        ds = xr.concat(sets, dim="case", join="outer", combine_attrs="drop")
        ds = ds.assign_coords(case=[c["index"] for c in done])
        paths = list(done[0]["parameters"])
        scalar = True
        for p in paths:
            values = [c["parameters"][p] for c in done]
            plain = all(isinstance(v, (int, float, str, bool)) for v in values)
            scalar &= plain
            # A list value (a vector) is labelled by its text: a coordinate holds scalars.
            ds = ds.assign_coords({p: ("case", values if plain else [json.dumps(v) for v in values])})
        if self.manifest.get("grid") and len(done) == len(self.cases) and scalar:
            if len(paths) == 1:
                return ds.swap_dims(case=paths[0]).transpose(paths[0], ...)
            ds = ds.set_index(case=paths).unstack("case").transpose(*paths, ...)
        return ds


def sweep(
    model,
    parameters: Mapping[str, Sequence[Any]] | Sequence[Mapping[str, Any]],
    folder: str | Path,
    *,
    executor: Executor | None = None,
    workers: int | None = None,
    summary: Sequence[str] = (),
    progress: bool | None = None,
    **settings,
) -> Sweep:
    """Runs `model` (a Model, dict or path) once per case into `folder`: `parameters` is a
    grid (path → values: every combination) or a list of cases (each a dict of path → value).
    `executor`: any concurrent.futures executor (a Dask client is turned into its executor);
    default a process pool of `workers` (default: the CPU count) processes, one solver
    thread each, started fresh (spawn: in a script, call this under `if __name__ ==
    "__main__":`). `summary`: channels summarized in the manifest. `settings` are `simulate`'s
    `simulation` settings (t_end, scheme, output_dt, …) for every case, under the cases' own
    overrides. `progress`: a bar counting the cases (None, the default: on a terminal or in
    Jupyter once the sweep has taken 2 s, not under CI). Returns the `Sweep`."""
    from .builder import Model
    from .results import model_data

    is_grid = isinstance(parameters, Mapping)
    cases = grid(parameters) if is_grid else [dict(c) for c in parameters]
    if not cases:
        raise _core.ModelError("sweep: no cases (give at least one value per parameter)")
    data = model_data(model)
    if settings:
        data = Model.from_dict(data).with_({f"simulation.{k}": v for k, v in settings.items()}).to_dict()
    for overrides in cases:  # every case is checked before any runs
        _check_case(data, overrides)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    manifest = _manifest(folder, data, cases, is_grid, list(summary))
    todo = [c for c in manifest["cases"] if c["status"] != "done"]
    own = executor is None
    executor = _executor(executor, workers, len(todo))
    try:
        _dispatch(executor, folder, manifest, todo, data, list(summary), progress)
    finally:
        if own:
            executor.shutdown(wait=True, cancel_futures=True)
    return Sweep(folder)


def _check_case(data: dict, overrides: Mapping[str, Any]):
    from .builder import Model

    try:
        Model.from_dict(data).with_(overrides)
    except _core.ModelError as e:
        raise _core.ModelError(f"sweep case {dict(overrides)}: {e}") from None


def _executor(executor, workers: int | None, cases: int) -> Executor:
    if executor is None:
        import multiprocessing

        n = max(1, min(workers or os.cpu_count() or 1, cases))
        return ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"))
    if hasattr(executor, "get_executor") and not isinstance(executor, Executor):
        return executor.get_executor()  # a dask.distributed Client
    return executor


def _manifest(folder: Path, data: dict, cases: list[dict], is_grid: bool, summary: list) -> dict:
    """The folder's manifest, keeping the records of cases already done with the same model
    and parameters (a resumed sweep)."""
    old = {}
    path = folder / MANIFEST
    if path.is_file():
        previous = json.loads(path.read_text())
        if previous.get("model") == data:
            old = {json.dumps(c["parameters"], sort_keys=True): c for c in previous["cases"]}
    records = []
    for k, params in enumerate(cases):
        key = json.dumps(params, sort_keys=True)
        done = old.get(key, {})
        file = f"case_{k:04d}.nc"
        if done.get("status") == "done" and done.get("file") == file and _complete(folder / file):
            records.append(done | {"index": k})
            continue
        records.append({"index": k, "file": file, "parameters": params, "status": "pending", "error": None})
    manifest = {"model": data, "grid": is_grid, "summary_channels": summary}
    manifest["cases"] = records
    _write_manifest(folder, manifest)
    return manifest


def _complete(path: Path) -> bool:
    """Whether a results file is there and says its run reached the end."""
    try:
        with xr.open_dataset(path) as ds:
            return int(ds.attrs.get("completed", 0)) == 1
    except (OSError, ValueError):
        return False


def _write_manifest(folder: Path, manifest: dict):
    """Written to a temporary file and renamed: a reader never sees half a manifest."""
    tmp = folder / (MANIFEST + ".tmp")
    tmp.write_text(json.dumps(manifest, indent=1, allow_nan=False))
    os.replace(tmp, folder / MANIFEST)


def _dispatch(executor, folder, manifest, todo, data, summary, progress):
    futures = {
        executor.submit(_run_case, data, c["parameters"], str(folder / c["file"]), summary): c for c in todo
    }
    done = sum(c["status"] == "done" for c in manifest["cases"])
    failed = 0
    delay = progress_bar.DELAY_S if progress is None else 0.0
    bar = progress_bar.cases(len(manifest["cases"]), done, delay) if progress_bar.wanted(progress) else None
    for future in as_completed(futures):
        case = futures[future]
        try:
            case.update(future.result())
        except Exception as e:  # noqa: BLE001 (the worker itself died: killed, out of memory)
            case.update({"status": "failed", "error": f"worker lost: {type(e).__name__}: {e}"})
        done += case["status"] == "done"
        failed += case["status"] == "failed"
        _write_manifest(folder, manifest)
        if bar is not None:
            bar.set_postfix_str(f"{failed} failed", refresh=False)
            bar.update(1)
    if bar is not None:
        bar.close()

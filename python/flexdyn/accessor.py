"""`ds.flexdyn`: a results dataset's run facts, read from its attributes, on any dataset that
flexdyn wrote — returned by `simulate` or opened from a file.

The attributes themselves stay plain numbers and strings (`stats_steps`, `warnings`,
`flexdyn_model`), so a result can be written again with `to_netcdf` like any dataset.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr


def _plain(v):
    """A NumPy scalar as the Python number it is."""
    return v.item() if isinstance(v, np.generic) else v


@xr.register_dataset_accessor("flexdyn")
class FlexdynAccessor:
    """Run facts of a flexdyn results dataset: `ds.flexdyn.stats`, `.warnings`, `.model`,
    `.completed`, `.channels`."""

    def __init__(self, ds: xr.Dataset):
        self._ds = ds

    @property
    def stats(self) -> dict:
        """The run's statistics (steps, rejected steps, Newton iterations, factorizations,
        the smallest and largest step in s, wall time in s, …) by name."""
        prefix = "stats_"
        return {k[len(prefix) :]: _plain(v) for k, v in self._ds.attrs.items() if k.startswith(prefix)}

    @property
    def timings(self) -> dict[str, float]:
        """Where the run's wall time went, s, by phase of its steps (`predictor`, `residuals`,
        `tangents`, `factorizations`, `solves`, `contact_borders`, `step_ends`, `patterns`,
        `outputs`, and `other`: step control, friction events, contact windows), and `core`,
        their sum. Recorded only for a run with `simulation.timings: true` (`simulate(...,
        timings=True)`, `flexdyn run --timings`); empty otherwise."""
        stats = self.stats
        return {
            k[len("time_") : -len("_s")]: v
            for k, v in stats.items()
            if k.startswith("time_") and k.endswith("_s")
        }

    def timing_report(self) -> str:
        """The run's [`timings`](#timings) as a table, the largest phase first, each with its
        share of the core's time; the wall time around it includes writing the results."""
        t = self.timings
        if not t:
            raise KeyError(
                "this run recorded no timings: run it with `timings=True` (simulate), "
                "`simulation: {timings: true}` (model file) or `flexdyn run --timings`"
            )
        core = t["core"]
        lines = [
            f"time in the solver core: {core:.3f} s (wall {self.stats.get('wall_time_s', float('nan')):.3f} s)"
        ]
        phases = sorted(((v, k) for k, v in t.items() if k != "core"), reverse=True)
        for v, k in phases:
            share = 100.0 * v / core if core > 0 else 0.0
            lines.append(f"  {k.replace('_', ' '):<16}{v:9.3f} s {share:6.1f} %")
        return "\n".join(lines)

    @property
    def warnings(self) -> list[str]:
        """The run's warnings, one string each (empty if none)."""
        text = self._ds.attrs.get("warnings", "")
        return [w for w in str(text).split("\n") if w]

    @property
    def completed(self) -> bool:
        """Whether the run reached its end (False for results a failure or a stop cut short)."""
        return bool(self._ds.attrs.get("completed", 0))

    @property
    def model(self):
        """The model that was run, as a `flexdyn.Model` (from the `flexdyn_model` attribute)."""
        from .builder import Model

        text = self._ds.attrs.get("flexdyn_model")
        if text is None:
            raise KeyError("these results carry no `flexdyn_model` attribute: not written by flexdyn")
        return Model.from_dict(json.loads(text))

    @property
    def channels(self) -> list[str]:
        """The sensor channels (`<sensor>.<component>`), in recording order."""
        return [n for n, v in self._ds.data_vars.items() if "sensor" in v.attrs]

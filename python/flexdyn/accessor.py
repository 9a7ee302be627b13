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

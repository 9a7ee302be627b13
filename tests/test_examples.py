"""Every example runs (shortened), so no example can rot."""

from pathlib import Path

import numpy as np
import pytest

import flexdyn as fd

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").rglob("*.yaml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(path, tmp_path):
    model = fd.load(path)
    dt = model.data["simulation"].get("dt", 1e-3)
    res = fd.simulate(
        model, t_end=min(model.data["simulation"].get("t_end", 1.0), 200 * dt), out=tmp_path / "r.nc"
    )
    assert res.attrs["completed"] == 1
    for name in res.data_vars:
        assert np.all(np.isfinite(res[name].values[1:])), name
    assert res.attrs["stats_max_constraint_violation"] < 1e-10


def test_there_are_examples():
    assert len(EXAMPLES) >= 3

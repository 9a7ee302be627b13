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


def test_the_worked_example_of_the_readme_runs_with_its_blades_alike():
    # examples/wind_turbine.py, the README's worked example, at its default settings: no
    # warning, and once spun up (4–7 s, 1.4 revolutions) the three patterned blades swing through the same
    # edgewise gravity moment, ±m g L²/2 ≈ ±1.2 kN·m, each in its own section frame (a blade
    # with a flipped frame would read it with the other sign at the same azimuth, and the
    # ranges would still agree — so the peaks are compared by sign). Measured within 0.5 %:
    # the decaying ring of the spin-up differs by blade.
    import runpy

    script = runpy.run_path(str(Path(__file__).parent.parent / "examples" / "wind_turbine.py"))
    res = fd.simulate(script["wind_turbine"](t_end=7.0), output_dt=0.01)
    assert res.attrs["warnings"] == ""
    late = res["time"].values >= 4.0
    peaks = [
        (res[f"root{k}.M3"].values[late].max(), res[f"root{k}.M3"].values[late].min()) for k in (1, 2, 3)
    ]
    for top, bottom in peaks:
        assert 1000 < top < 1400 and -1400 < bottom < -1000, peaks
    assert np.ptp([p[0] for p in peaks]) < 0.03 * peaks[0][0], peaks
    # At rest at t = 0 (its drives start from rest), it starts in its static sag: the first
    # sample's root moments are the static solve's (both Newton-converged: 1e-9).
    static = fd.solve_static(script["wind_turbine"]().simulation(analysis="static"))
    for k in (2, 3):
        start, sag = res[f"root{k}.M3"].values[0], static[f"root{k}.M3"].values[-1]
        assert abs(sag) > 1000 and start == pytest.approx(sag, rel=1e-9)


def test_the_readme_worked_example_code_runs_as_printed(tmp_path, monkeypatch):
    # The README's copy of the example (so that what a reader pastes works).
    text = (Path(__file__).parent.parent / "README.md").read_text()
    block = text[text.index("## A worked example") :].split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    scope: dict = {}
    exec(block, scope)  # noqa: S102 -- the README is ours; running it is the point
    assert scope["res"].attrs["warnings"] == ""
    assert (tmp_path / "wind_turbine.nc").exists()

"""Frequencies along a trajectory (issue 21, item 4): the run stopped at instants and
linearized about each state reached — a mass sliding along a cantilever against the closed form
of a cantilever carrying a point mass at s."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import flexdyn as fd
from flexdyn import _core
from flexdyn.trajectory_modes import frequencies_along

EI, MASS, L = 2.0e3, 5.0, 1.0
# A light bar (its own mass 1e-4 of the slider's) stiff in shear and extension: the slider on a
# massless Euler–Bernoulli cantilever, k = 3EI/s³.
SECTION = {"ea": 1e9, "ga2": 1e9, "ga3": 1e9, "gj": 1e3, "ei2": EI, "ei3": EI, "m": 5e-4}
SECTION |= {"i22": 1e-9, "i33": 1e-9}


def sliding_mass():
    m = fd.Model("sliding mass")
    m.beam("bar", [0, 0, 0], [L, 0, 0], elements=8, section=SECTION)
    m.clamp("root", "ground", "bar.0")
    m.node("sleeve", [0.3, 0, 0]).body("mass", "sleeve", mass=MASS, inertia=[1e-9, 1e-9, 1e-9])
    # From η = 0.3 to 0.9 over 2 s, smoothly (the sleeve cannot turn on the bar).
    m.sliding_clamp("ride", "bar", "sleeve", drive="0.3 + 0.6*(3*(t/2)^2 - 2*(t/2)^3)")
    m.simulation(t_end=2.0)  # default scheme and steps
    return m


def test_the_first_frequency_follows_the_sliding_mass():
    ds = frequencies_along(sliding_mass(), np.linspace(0.0, 2.0, 7), count=2)
    s = ds["eta.ride"].values * L
    assert s[0] == pytest.approx(0.3) and s[-1] == pytest.approx(0.9)
    exact = np.sqrt(3 * EI / (MASS * s**3)) / (2 * np.pi)
    # Measured within 3.5e-4 (the bar's own mass, 1e-4 of the slider's, and the cubic
    # interpolation at a contact point between nodes): 1e-3 leaves room, a wrong s or k fails.
    np.testing.assert_allclose(ds["frequency"].values[:, 0], exact, rtol=1e-3)
    # Equal bending stiffnesses: the two lowest modes are the same frequency (y and z), to the
    # round-off of the run's state and the eigen-solve (2e-9 measured).
    np.testing.assert_allclose(ds["frequency"].values[:, 1], ds["frequency"].values[:, 0], rtol=1e-7)
    # The instants reached are the step ends at or just after those asked for.
    assert np.all(ds["time"].values >= np.linspace(0.0, 2.0, 7) - 1e-12)


def test_written_as_channels_and_from_the_command_line(tmp_path):
    model = tmp_path / "slide.yaml"
    sliding_mass().to_yaml(model)
    out, fig = tmp_path / "f.nc", tmp_path / "f.png"
    done = subprocess.run(
        [sys.executable, "-m", "flexdyn", "modes", str(model), "--along", "4", "-n", "1", "-o", str(out), "--plot", str(fig)],
        check=False, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(out) as ds:
        assert list(ds.data_vars) == ["frequency.mode1", "eta.ride"]
        assert ds["frequency.mode1"].attrs["units"] == "Hz" and ds.sizes["time"] == 4
        s = ds["eta.ride"].values
        np.testing.assert_allclose(
            ds["frequency.mode1"].values, np.sqrt(3 * EI / (MASS * s**3)) / (2 * np.pi), rtol=1e-3
        )
    assert fig.is_file()
    assert "eta.ride" in done.stdout


def test_a_state_of_another_model_is_refused():
    static = fd.results.static_model_data(sliding_mass())
    other = fd.load(Path(__file__).resolve().parent.parent / "examples" / "pendulum.yaml")
    run = _core.Simulation(json.dumps(other.to_dict()))
    with pytest.raises(fd.ModelError, match="not of this model"):
        _core.Simulation(json.dumps(static)).linearize_about(run)
    with pytest.raises(fd.ModelError, match="increasing instants"):
        frequencies_along(sliding_mass(), [0.5, 0.2])

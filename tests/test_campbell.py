"""Campbell diagrams (issue 21, item 3): frequencies over spin rates with the gyroscopic terms —
the spin-up of a rotor's blades against Southwell, a whirling shaft's split against its
closed form, modes followed through their crossings."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from test_gyroscopic import EI, MASS, L, overhung
from test_steady_spin import OMEGA, spinning_blade

import flexdyn as fd
from flexdyn.campbell import _tracked


def test_a_rotor_s_blades_follow_southwell_with_coriolis_small():
    """Two 2 m blades on a hub spinning about z: at rest the frequencies are `modes`'s; at
    20 rad/s ω² = ω0² + K Ω² with Southwell's K = 0.193 (lag) within 5 % as the Southwell test
    without Coriolis measured (lumped mass, 4 elements). The gyroscopic terms move the
    frequencies by < 1e-3 (Coriolis on lag with EA = 2e8 N; on flap the sections' rotary
    inertia couples flap slope and torsion through Ω: 1.6e-4 of the frequency, which is 3 % of
    the flap's small centrifugal increase, K 1.153 → 1.115, so flap gets 10 % of 1.193)."""
    still = spinning_blade(False)
    still.data["initial_spins"] = []
    at_rest = fd.modes(still, count=4)["omega"].values
    ds = fd.campbell(spinning_blade(False), [0.0, OMEGA], count=4)
    np.testing.assert_allclose(ds["omega"].values[0], at_rest, rtol=1e-9)
    w = ds["omega"].values[1]
    k = (w**2 - at_rest**2) / OMEGA**2
    assert k[:2] == pytest.approx([0.193] * 2, rel=0.05)
    assert k[2:] == pytest.approx([1.193] * 2, rel=0.1)
    without_coriolis = fd.modes(spinning_blade(False), count=4)["omega"].values
    assert np.abs(w / without_coriolis - 1).max() < 1e-3
    assert np.abs(w / without_coriolis - 1).max() > 0  # the terms are there


def test_a_whirling_shaft_splits_and_its_modes_are_followed():
    """A point mass on a light shaft: in the turning frame ω0 − Ω and ω0 + Ω, each a line of
    its own as the spin grows (the two start together at Ω = 0, so either column may take
    either line)."""
    spins = np.array([0.0, 4.0, 8.0, 12.0])
    model = overhung(1e-9, 1e-9)
    ds = fd.campbell(model, spins, count=2)
    w0 = np.sqrt(3 * EI / (MASS * L**3))
    # At Ω = 0 the two bending directions coincide; the shaft's mass shifts ω0 by 2e-5.
    w = ds["omega"].values
    np.testing.assert_allclose(np.sort(w, axis=1), np.c_[w0 - spins, w0 + spins], rtol=1e-4)
    rising = int(np.argmax(w[-1]))
    np.testing.assert_allclose(w[1:, rising], w0 + spins[1:], rtol=1e-4)
    np.testing.assert_allclose(w[1:, 1 - rising], w0 - spins[1:], rtol=1e-4)


def test_tracking_follows_shapes_through_a_crossing():
    """Two modes whose frequencies cross between rates keep their lines (by shape), where
    sorting by frequency would swap them."""
    a, b = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    omegas = [np.array([1.0, 2.0]), np.array([1.4, 1.6]), np.array([1.5, 1.7])]
    shapes = [np.c_[a, b], np.c_[a, b], np.c_[b, a]]  # at the third rate mode "a" is the higher
    tracked = _tracked(omegas, [s.astype(complex) for s in shapes])
    np.testing.assert_array_equal(tracked[:, 0], [1.0, 1.4, 1.7])
    np.testing.assert_array_equal(tracked[:, 1], [2.0, 1.6, 1.5])


def test_campbell_command(tmp_path):
    model = tmp_path / "rotor.yaml"
    spinning_blade(False).to_yaml(model)
    out, fig = tmp_path / "c.nc", tmp_path / "c.png"
    done = subprocess.run(
        [sys.executable, "-m", "flexdyn", "campbell", str(model), "--speed", "0:40:3", "-n", "2",
         "--plot", str(fig), "-o", str(out)],
        check=False, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(out) as ds:
        assert ds["frequency"].shape == (3, 2) and ds["speed"].values[-1] == 40.0
    assert fig.is_file()
    bad = subprocess.run(
        [sys.executable, "-m", "flexdyn", "campbell", str(model), "--speed", "0-40"],
        check=False, capture_output=True, text=True,
    )  # fmt: skip
    assert bad.returncode == 2 and "START:STOP:COUNT" in bad.stderr


def test_the_speed_can_name_the_rotor_s_joint():
    """`--speed shaft=…` varies the initial spin about the revolute `shaft`'s axis."""
    by_joint = fd.campbell(spinning_blade(False), [0.0, OMEGA], speed="shaft", count=2)
    by_path = fd.campbell(spinning_blade(False), [0.0, OMEGA], speed="initial_spins.0.rate", count=2)
    np.testing.assert_array_equal(by_joint["omega"].values, by_path["omega"].values)
    assert by_joint["speed"].attrs["path"] == "initial_spins.0.rate"
    with pytest.raises(fd.ModelError, match="neither an override path nor a joint"):
        fd.campbell(spinning_blade(False), [0.0], speed="shaf")


def test_a_model_without_a_spin_to_vary_is_refused():
    m = spinning_blade(False)
    m.data["initial_spins"] = []
    with pytest.raises(fd.ModelError, match="0 initial spins"):
        fd.campbell(m, [0.0, 10.0])

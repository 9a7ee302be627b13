"""Sweeps (issue 21, item 2): one run per case on local processes or a Dask cluster with the
same results, a manifest that records failures, resuming a killed sweep, the results gathered
with the parameters as dimensions."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import flexdyn as fd

ROOT = Path(__file__).resolve().parent.parent
FOUR_BAR = ROOT / "examples" / "four_bar.yaml"
GRID = {"bodies.coupler_bar.mass": [0.6, 2.4], "joints.crank_pin.spring.damping": [0.0, 5.0]}
SETTINGS = {"t_end": 0.3, "output_dt": 0.01}


@pytest.fixture(scope="module")
def local(tmp_path_factory):
    return fd.sweep(
        FOUR_BAR,
        GRID,
        tmp_path_factory.mktemp("local"),
        workers=2,
        summary=["crank_drive.torque"],
        **SETTINGS,
    )


def test_a_grid_gathers_with_its_parameters_as_dimensions(local):
    ds = local.dataset(["crank_drive.torque"])
    assert ds["crank_drive.torque"].dims == (
        "bodies.coupler_bar.mass",
        "joints.crank_pin.spring.damping",
        "time",
    )
    assert ds.sizes["time"] == 31
    # Each case is the model run with its overrides: the same numbers as a run by hand.
    m = fd.load(FOUR_BAR).with_({"bodies.coupler_bar.mass": 2.4, "joints.crank_pin.spring.damping": 5.0})
    by_hand = fd.simulate(m, **SETTINGS)["crank_drive.torque"].values
    got = ds["crank_drive.torque"].sel(
        {"bodies.coupler_bar.mass": 2.4, "joints.crank_pin.spring.damping": 5.0}
    )
    np.testing.assert_array_equal(got.values, by_hand)
    # A heavier coupler needs more torque from the crank's drive.
    peak = np.abs(ds["crank_drive.torque"]).max("time")
    assert (peak.sel({"bodies.coupler_bar.mass": 2.4}) > peak.sel({"bodies.coupler_bar.mass": 0.6})).all()
    summary = local.cases[3]["summary"]["crank_drive.torque"]
    assert summary["max_abs"] == pytest.approx(float(np.abs(by_hand).max()))
    assert all(c["status"] == "done" and c["wall_time_s"] > 0 for c in local.cases)


def test_a_dask_cluster_gives_the_same_results(local, tmp_path):
    import distributed  # a test dependency: the sweep must run on a real Dask cluster

    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = fd.sweep(FOUR_BAR, GRID, tmp_path, executor=client, **SETTINGS)
    a, b = local.dataset(), remote.dataset()
    for name in ("crank_drive.torque", "rocker_angle.phi"):
        np.testing.assert_array_equal(a[name].values, b[name].values)


def test_a_failing_case_is_recorded_and_the_others_run(tmp_path):
    """A drive defined only up to t = 0.1 s passes the checks and fails in its run."""
    cases = [{"simulation.t_end": 0.1}, {"joints.crank_pin.drive": "asin(10*t)"}, {"simulation.t_end": 0.2}]
    s = fd.sweep(FOUR_BAR, cases, tmp_path, workers=2, t_end=0.3)
    # The cases' own overrides win over the sweep's settings.
    with fd.open_results(tmp_path / "case_0000.nc") as first:
        assert first["time"].values[-1] == pytest.approx(0.1)
    status = [c["status"] for c in s.cases]
    assert status == ["done", "failed", "done"]
    error = s.cases[1]["error"]
    assert error.startswith("SolverError") and "is not defined at t = 0.100" in error
    assert json.loads((tmp_path / "manifest.json").read_text())["cases"][1]["status"] == "failed"
    assert s.dataset().sizes["case"] == 2  # the finished ones


def test_a_bad_case_is_refused_before_anything_runs(tmp_path):
    with pytest.raises(fd.ModelError, match="no body named `couplr`"):
        fd.sweep(FOUR_BAR, {"bodies.couplr.mass": [1.0, 2.0]}, tmp_path)
    assert not (tmp_path / "manifest.json").exists()


def test_a_killed_sweep_resumes_where_it_stopped(tmp_path):
    out = tmp_path / "sweep"
    args = [sys.executable, "-m", "flexdyn", "sweep", str(FOUR_BAR), "-o", str(out), "--workers", "1", "-q"]
    args += [
        "--grid",
        "bodies.coupler_bar.mass=0.5,0.75,1.0,1.25,1.5,1.75",
        "--t-end",
        "3",
        "--output-dt",
        "0.01",
    ]
    proc = subprocess.Popen(args, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    manifest = out / "manifest.json"
    deadline = time.time() + 120
    while time.time() < deadline:
        if (
            manifest.is_file()
            and sum(c["status"] == "done" for c in json.loads(manifest.read_text())["cases"]) >= 2
        ):
            break
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    first = json.loads(manifest.read_text())["cases"]
    finished = [c for c in first if c["status"] == "done"]
    assert 2 <= len(finished) < 6, "the sweep should have been stopped part way"
    stamps = {c["file"]: (out / c["file"]).stat().st_mtime_ns for c in finished}
    again = subprocess.run(args, check=False, capture_output=True, text=True)
    assert again.returncode == 0, again.stderr
    assert "6 of 6 cases done" in again.stdout
    # The cases done before the kill were not run again.
    assert {f: (out / f).stat().st_mtime_ns for f in stamps} == stamps
    assert fd.Sweep(out).dataset().sizes["bodies.coupler_bar.mass"] == 6


def test_sweep_command_values_with_commas_inside(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "flexdyn", "sweep", str(FOUR_BAR), "-o", str(tmp_path), "--t-end", "0.05",
         "--grid", "gravity=[0, 0, 0],[0, 0, -9.81]", "--summary", "crank_drive.torque"],
        check=False, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    params = [c["parameters"]["gravity"] for c in fd.Sweep(tmp_path).cases]
    assert params == [[0, 0, 0], [0, 0, -9.81]]


@pytest.mark.parametrize("script", ["sweep_four_bar.py", "sliding_mass_frequencies.py", "campbell_rotor.py"])
def test_the_study_examples_run(script, tmp_path):
    """The README's study figures come from these scripts."""
    args = [sys.executable, str(ROOT / "examples" / "studies" / script), "--figure", str(tmp_path / "f.png")]
    if script.startswith("sweep"):
        args += ["--out", str(tmp_path / "sweep")]
    done = subprocess.run(args, check=False, capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "f.png").is_file()
    if script.startswith("sliding"):
        error = float(done.stdout.split("closed form ")[1].split(";")[0])
        assert error < 1e-3  # the README quotes 3.4e-4

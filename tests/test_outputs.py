"""Results files, streaming in chunks, failure diagnostics, the CLI, Newton's convergence."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import flexdyn as fd
import flexdyn.results

from test_conservation import double_pendulum

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def spun_up_body(max_halvings=2):
    """A body spun up by a growing moment until one step would rotate it past the Rodrigues
    limit even after halving: the run must stop with a diagnostic."""
    m = fd.Model("spin-up")
    m.node("disk", [0, 0, 0])
    m.body("disk_body", "disk", mass=1.0, inertia=[1.0, 1.0, 1.0])
    m.moment("motor", "disk", [0, 0, 100.0], scale="t")
    m.sensor("node_velocity", "disk_vel", node="disk")
    m.simulation(scheme="ed", step_control="fixed", dt=0.01, t_end=10.0, max_step_halvings=max_halvings)
    return m


def test_results_stream_to_netcdf_in_chunks(tmp_nc, monkeypatch):
    monkeypatch.setattr(flexdyn.results, "CHUNK_STEPS", 100)
    sizes = []
    res = fd.simulate(
        double_pendulum("ed", 0.01, 5.0), out=tmp_nc, on_chunk=lambda t, v: sizes.append(len(t))
    )
    # 500 steps in chunks of 100: Rust hands over at most 100 samples (+ t = 0) at a time.
    assert len(sizes) == 5 and max(sizes) <= 101
    assert res.sizes["time"] == 501
    on_disk = xr.open_dataset(tmp_nc)
    assert on_disk["e.total"].attrs["units"] == "J"
    assert on_disk["knee_angle.phi"].attrs["units"] == "rad"
    assert on_disk.attrs["completed"] == 1
    assert on_disk.attrs["stats_steps"] == 500
    np.testing.assert_array_equal(on_disk["knee_angle.phi"].values, res["knee_angle.phi"].values)


def test_output_dt_records_every_kth_step():
    res = fd.simulate(double_pendulum("ep", 0.01, 1.0), output_dt=0.05)
    np.testing.assert_allclose(np.diff(res.time.values), 0.05, rtol=1e-12)
    assert res.time.values[-1] == pytest.approx(1.0)


def test_outputs_inside_steps_interpolate_the_books_between_the_step_ends():
    """With `output_dt` a step's end is sampled only if an output falls in the step, and a step
    with an output strictly inside it samples its start then, before its books change the
    totals. Its bookkeeping channels (energies, the drive's work: exact at step ends) are the
    linear interpolation between the step ends, which a run recording every step gives; its
    outputs at step ends are that run's samples. Four-bar, fixed 10 ms steps, outputs every
    25 ms: every other output inside a step, and steps with no output at all."""
    model = fd.load(EXAMPLES / "four_bar.yaml")
    model.simulation(step_control="fixed", dt=0.01, t_end=0.5, output_dt=None)
    every = fd.simulate(model)
    model.simulation(output_dt=0.025)
    sparse = fd.simulate(model)
    t = sparse.time.values
    assert len(t) == 21
    for channel in ["energy.kinetic", "energy.total", "energy.drive_work", "crank_drive.work"]:
        expected = np.interp(t, every.time.values, every[channel].values)
        scale = np.abs(every[channel].values).max()
        # Interpolation weights differ from np.interp's by round-off only.
        np.testing.assert_allclose(sparse[channel].values, expected, rtol=0, atol=1e-12 * scale)
    at_step_ends = np.isclose(t / 0.01, np.round(t / 0.01), rtol=0, atol=1e-9)
    assert at_step_ends.sum() == 11
    for channel in ["rocker_angle.phi", "coupler_cm.x", "energy.potential"]:
        picked = np.interp(t[at_step_ends], every.time.values, every[channel].values)
        np.testing.assert_allclose(sparse[channel].values[at_step_ends], picked, rtol=0, atol=1e-14)


def test_a_run_that_cannot_go_on_stops_with_a_diagnostic_and_keeps_its_steps(tmp_nc):
    with pytest.raises(fd.SolverError) as e:
        fd.simulate(spun_up_body(), out=tmp_nc)
    msg = str(e.value)
    assert "node `disk`" in msg and "reduce the time step" in msg
    partial = e.value.results
    t_stop = partial.time.values[-1]
    # ω = 50 t²; the Cayley parameter of a quarter step, |r| = ω dt/4, reaches the 150° limit
    # 2 tan 75° = 7.46 at t = sqrt(7.46 / (50 · 0.0025)) = 7.72 s.
    assert 7.6 < t_stop < 7.8
    on_disk = xr.open_dataset(tmp_nc)
    assert on_disk.attrs["completed"] == 0
    assert on_disk.time.values[-1] == t_stop
    assert on_disk.attrs["stats_halvings"] > 0


def assert_quadratic(residuals, floor):
    """Newton's residual history of a step: quadratic, e_{k+1} ≤ C e_k² with a modest constant
    (measured C ≈ 0.01–0.6), for every iterate above the round-off `floor` (relative to the
    first). Returns how many iterates were checked."""
    e = np.array(residuals) / residuals[0]
    checked = 0
    for k in range(len(e) - 1):
        if e[k + 1] > floor:
            assert e[k + 1] <= 10 * e[k] ** 2, e
            checked += 1
    return checked


def test_newton_converges_quadratically():
    m = double_pendulum("ed", 0.02, 0.2).to_dict()
    m["simulation"]["newton_tol"] = 1e-15
    # Full Newton (a fresh tangent every iteration): quadratic convergence shows the tangent
    # is the residual's derivative. The default modified Newton converges linearly.
    m["simulation"]["modified_newton"] = False
    sim = fd._core.Simulation(json.dumps(m))
    sim.advance_to(0.02)
    assert assert_quadratic(sim.last_residuals, 1e-12) >= 2, sim.last_residuals


def test_cli_run_writes_results(tmp_path):
    model = tmp_path / "pendulum.yaml"
    double_pendulum("ed", 0.01, 0.5).to_yaml(model)
    out = tmp_path / "r.nc"
    p = subprocess.run(
        [sys.executable, "-m", "flexdyn.cli", "run", str(model), "-o", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert p.returncode == 0, p.stderr
    assert "51 samples" in p.stdout and "ED:" in p.stdout
    assert xr.open_dataset(out).sizes["time"] == 51


def test_cli_run_steps_adaptively_unless_told_to_keep_dt(tmp_path):
    model = tmp_path / "pendulum.yaml"
    double_pendulum("ed", 0.01, 0.5).to_yaml(model)  # the file says step_control: fixed
    fd.load(model).simulation(step_control="adaptive").to_yaml(model)
    steps = {}
    for flag in ([], ["--fixed-step"]):
        p = subprocess.run(
            [sys.executable, "-m", "flexdyn.cli", "run", str(model), *flag],
            capture_output=True,
            text=True,
            check=False,
        )
        assert p.returncode == 0, p.stderr
        steps[bool(flag)] = int(p.stdout.split("ED: ")[1].split(" steps")[0])
    assert steps[True] == 50 and steps[False] != 50, steps


def test_cli_run_failure_exits_nonzero_and_keeps_partial_file(tmp_path):
    model = tmp_path / "spin.yaml"
    spun_up_body().to_yaml(model)
    out = tmp_path / "r.nc"
    p = subprocess.run(
        [sys.executable, "-m", "flexdyn.cli", "run", str(model), "-o", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert p.returncode == 3
    assert "node `disk`" in p.stderr and "partial results" in p.stderr
    assert xr.open_dataset(out).sizes["time"] > 700


def test_inconsistent_given_velocities_are_projected_and_reported():
    m = fd.Model("pendulum", gravity=[0, 0, -9.81])
    # The bob is given a radial velocity component, which the pin does not allow.
    m.node("bob", [1, 0, 0], velocity=[0.3, 0, -2.0])
    m.body("ball", "bob", mass=2.0, inertia=[0.01] * 3)
    m.revolute("pin", "ground", "bob", axis=[0, 1, 0], position=[0, 0, 0])
    m.sensor("node_velocity", "v", node="bob")
    res = fd.simulate(m, scheme="ed", step_control="fixed", dt=1e-3, t_end=0.01)
    (w,) = res.flexdyn.warnings
    assert "`bob`" in w and "adjusted" in w and "give consistent velocities" in w
    # The kinetic-energy-closest admissible velocity keeps the tangential part only; the
    # bob's spin, not given, follows the pin (ω = v/r) without pulling on its velocity.
    assert res["v.vx"].values[0] == pytest.approx(0.0, abs=1e-12)
    assert res["v.vz"].values[0] == pytest.approx(-2.0, rel=1e-9)
    assert res["v.wy"].values[0] == pytest.approx(2.0, rel=1e-9)


def test_an_interrupted_run_keeps_a_valid_file(tmp_nc, monkeypatch):
    # Ctrl-C arrives between chunks (here raised by the chunk callback after the second one).
    monkeypatch.setattr(flexdyn.results, "CHUNK_STEPS", 50)
    seen = []

    def interrupt(t, v):
        seen.append(len(t))
        if len(seen) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt) as e:
        fd.simulate(double_pendulum("ed", 0.01, 5.0), out=tmp_nc, on_chunk=interrupt)
    assert "completed steps were kept" in str(e.value)
    on_disk = xr.open_dataset(tmp_nc)
    assert on_disk.attrs["completed"] == 0
    # Both chunks handed over before the interrupt are on disk (written before the callback).
    # (plus the sample that was waiting for the next step, completed by the flush).
    assert sum(seen) <= on_disk.sizes["time"] <= sum(seen) + 1
    assert np.all(np.isfinite(on_disk["e.total"].values))


def test_unspecified_velocities_follow_the_given_ones():
    # Node b is clamped to node a and given no velocity: it takes a's motion, and a's given
    # velocity is kept (no warning).
    m = fd.Model("carried")
    m.node("a", [0, 0, 0], velocity=[1.0, 0, 0], angular_velocity=[0, 0, 2.0])
    m.node("b", [0.5, 0, 0])
    m.body("body_a", "a", mass=1.0, inertia=[1, 1, 1])
    m.body("body_b", "b", mass=5.0, inertia=[1, 1, 1])
    m.clamp("weld", "a", "b")
    m.sensor("node_velocity", "va", node="a").sensor("node_velocity", "vb", node="b")
    res = fd.simulate(m, scheme="ed", step_control="fixed", dt=1e-3, t_end=0.002)
    assert res.flexdyn.warnings == []
    # Unspecified nodes weigh 1e-6 of their mass in the projection, and three proximal solves
    # shrink the pull on the given velocities to ~1e-18.
    assert res["va.vx"].values[0] == pytest.approx(1.0, abs=1e-10)
    assert res["va.wz"].values[0] == pytest.approx(2.0, abs=1e-10)
    # v_b = v_a + ω × r = (1, 1, 0), ω_b = ω_a.
    assert res["vb.vx"].values[0] == pytest.approx(1.0, abs=1e-9)
    assert res["vb.vy"].values[0] == pytest.approx(1.0, abs=1e-9)
    assert res["vb.wz"].values[0] == pytest.approx(2.0, abs=1e-9)


def test_a_spin_not_given_follows_the_joint_instead_of_kinking_the_beam():
    # A collar clamped to a tumbling soft beam, given its velocity but not its spin: the spin
    # is the beam section's (no warning), so the beam starts in its rigid tumble and the
    # adaptive steps stay long. Giving the spin, zero, is inconsistent: the projection
    # shares the change with the beam, kinking it at the collar, and the kink rings (the
    # steps shrink ~100-fold to resolve it).
    from test_sliding import tumbling_soft_beam

    def collar(**spin):
        m = tumbling_soft_beam("clamped collar")
        m.node("collar", [1.2, 0, 0], velocity=[0, 0, 0], **spin)
        m.body("c", "collar", mass=2.0, inertia=[0.01] * 3)
        m.clamp("weld", "beam.18", "collar")
        m.sensor("node_velocity", "v", node="collar").sensor("node_velocity", "s", node="beam.18")
        return fd.simulate(m, t_end=0.05)

    free = collar()
    assert free.flexdyn.warnings == []
    for k in ("wx", "wy", "wz", "vx", "vy", "vz"):
        assert free[f"v.{k}"].values[0] == pytest.approx(free[f"s.{k}"].values[0], abs=1e-9)
    # The given spin to 1e-7: the beam starts strained by its tumble's loads, its sections
    # turned by them, and the velocities are projected again there (measured 3.6e-9).
    assert free["v.wz"].values[0] == pytest.approx(0.5, abs=1e-7)
    held = collar(angular_velocity=[0, 0, 0])
    assert "`collar`" in held.flexdyn.warnings[0]
    assert held.flexdyn.stats["steps"] > 20 * free.flexdyn.stats["steps"]


def test_a_sensor_component_is_one_channel_named_after_the_sensor():
    # The same quantities through full sensors and through one-component sensors, including a
    # step channel (the pin's reaction, interpolated between mid-steps).
    m = double_pendulum("ed", 0.01, 0.3)
    m.sensor("joint_reaction", "pin_all", joint="knee")
    m.sensor("joint_reaction", "pin_Fz", joint="knee", component="Fz")
    m.sensor("energy", "kinetic", component="kinetic")
    res = fd.simulate(m, output_dt=0.02)
    assert "pin_Fz" in res and "pin_Fz.Fz" not in res and res["pin_Fz"].attrs["units"] == "N"
    np.testing.assert_array_equal(res["pin_Fz"].values, res["pin_all.Fz"].values)
    np.testing.assert_array_equal(res["kinetic"].values, res["e.kinetic"].values)
    m.sensor("energy", "wrong", component="Fz")
    with pytest.raises(
        fd.ModelError,
        match=r"sensors\[\d+\]\.component: `Fz` is not a component of sensor `wrong`; it has kinetic",
    ):
        fd.simulate(m)


def test_cli_info_check_plot_and_compare(tmp_path):
    def cli(*args):
        return subprocess.run(
            [sys.executable, "-m", "flexdyn.cli", *map(str, args)],
            capture_output=True,
            text=True,
            check=False,
        )

    model = tmp_path / "pendulum.yaml"
    double_pendulum("ed", 0.01, 0.2).to_yaml(model)
    info = cli("info", model)
    assert info.returncode == 0, info.stderr
    # Two bars (12 unknowns) and three joint angles; a universal joint (4 equations, and 2
    # defining its angles) and a revolute (5, and 1 defining its angle): 3 degrees of freedom,
    # 2 + 1 as a mechanism.
    assert "nodes       2" in info.stdout and "constraints 12 equations" in info.stdout, info.stdout
    assert "DOFs        3 free" in info.stdout, info.stdout
    assert cli("check", model).returncode == 0
    runs = []
    for scheme in ("ep", "ed"):
        out = tmp_path / f"{scheme}.nc"
        assert cli("run", model, "--scheme", scheme, "-o", out).returncode == 0
        runs.append(out)
    p = cli("plot", runs[0], "knee_angle", "-o", tmp_path / "a.png")
    assert p.returncode == 0 and (tmp_path / "a.png").stat().st_size > 1000, p.stderr
    p = cli("compare", *runs, "--sensors", "knee_angle.phi", "e.total", "-o", tmp_path / "c.pdf")
    assert p.returncode == 0 and (tmp_path / "c.pdf").read_bytes().startswith(b"%PDF"), p.stderr
    missing = cli("info", tmp_path / "missing.yaml")
    assert missing.returncode == 2 and "no such model file" in missing.stderr
    bad = cli("plot", runs[0], "nope", "-o", tmp_path / "b.png")
    assert bad.returncode == 2 and "no channel or sensor `nope`" in bad.stderr


def test_relative_position_is_measured_in_the_reference_triad():
    # A crank turning about a tilted axis carries an arm point 0.5 m along its axis 1 and
    # 0.2 m along axis 3: in the crank's triad it stays there however the crank turns, and
    # its distance from the crank's axis 3 is 0.5 m, from axis 1 0.2 m.
    axis = np.array([0.0, 0.6, 0.8])
    m = fd.Model("crank")
    # Triad turned about x so that its axis 3 is the revolute's axis.
    m.node("crank", [1.0, 2.0, 3.0], rotation_vector=[-np.arcsin(0.6), 0, 0])
    m.body("crank_body", "crank", mass=2.0, inertia=[0.1, 0.1, 0.2])
    tip = np.array([1.0, 2.0, 3.0]) + 0.5 * np.array([1, 0, 0]) + 0.2 * axis
    m.node("tip", tip.tolist()).body("tip_body", "tip", mass=0.5, inertia=[1e-3] * 3)
    m.clamp("arm", "crank", "tip")
    m.revolute("pin", "ground", "crank", axis=axis.tolist(), position=[1.0, 2.0, 3.0], drive="3*t")
    m.sensor("relative_position", "rel", node="tip", reference="crank")
    m.sensor("node_position", "abs", node="tip")
    m.simulation(scheme="ed", t_end=1.0, dt=1e-2, step_control="fixed")
    r = fd.simulate(m)
    for c, value in (("x1", 0.5), ("x2", 0.0), ("x3", 0.2), ("r3", 0.5), ("r1", 0.2)):
        # The clamp holds to Newton's tolerance (~1e-12 m).
        assert np.abs(r[f"rel.{c}"].values - value).max() < 1e-9, c
    assert np.ptp(r["abs.x"].values) > 0.9  # the tip did turn (diameter 1 m)
    assert np.abs(r["rel.r2"].values - np.hypot(0.5, 0.2)).max() < 1e-9

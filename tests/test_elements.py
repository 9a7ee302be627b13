"""Rigid bodies with offset centres of mass, clamps, point loads, dampers and joint reactions,
each against an exact or independent result."""

import numpy as np
import pytest

import flexdyn as fd

from conftest import track


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_constant_force_and_moment_give_exact_motion(scheme):
    # x = x0 + v0 t + F t²/(2m) and ω_z = ω0 + M t/J_z are reproduced exactly by both
    # schemes (the midpoint rule integrates constant acceleration exactly).
    m, jz, force, moment = 2.0, 0.5, np.array([1.0, -2.0, 3.0]), 0.7
    model = fd.Model("loads")
    model.node("b", [0, 0, 0], velocity=[0.1, 0, 0], angular_velocity=[0, 0, 0.2])
    model.body("body", "b", mass=m, inertia=[0.3, 0.4, jz])
    model.force("push", "b", force)
    model.moment("twist", "b", [0, 0, moment], scale=1.0)
    model.sensor("node_position", "p", node="b").sensor("node_velocity", "v", node="b").sensor("energy", "e")
    res = fd.simulate(model, scheme=scheme, step_control="fixed", dt=0.01, t_end=2.0)
    t = res.time.values
    for k, c in enumerate("xyz"):
        exact = [0.1, 0, 0][k] * t + force[k] * t**2 / (2 * m)
        np.testing.assert_allclose(res[f"p.{c}"].values, exact, atol=1e-12)
    np.testing.assert_allclose(res["v.wz"].values, 0.2 + moment * t / jz, atol=1e-12)
    # Work of the loads = gain of kinetic energy.
    ke = res["e.kinetic"].values
    np.testing.assert_allclose(res["e.external_work"].values, ke - ke[0], atol=1e-10)


def heavy_top_model(at_pivot: bool):
    omega = np.array([0.0, 15.0, -1.0])
    m = fd.Model("top", gravity=[0, 0, -9.81])
    if at_pivot:
        # Node at the pivot, body's centre of mass offset along the node's y axis.
        m.node("top", [0, 0, 0], angular_velocity=omega)
        m.body("body", "top", mass=15.0, inertia=[0.234375, 0.46875, 0.234375], cm_offset=[0, 1, 0])
    else:
        m.node("top", [0, 1, 0], angular_velocity=omega, velocity=np.cross(omega, [0, 1, 0]))
        m.body("body", "top", mass=15.0, inertia=[0.234375, 0.46875, 0.234375])
    m.spherical("pivot", "ground", "top", position=[0, 0, 0])
    m.sensor("node_rotation", "rot", node="top").sensor("energy", "e")
    return m


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_offset_centre_of_mass_equals_node_at_centre_of_mass(scheme):
    run = {"scheme": scheme, "step_control": "fixed", "dt": 1e-3, "t_end": 1.0, "newton_tol": 1e-13}
    a, b = (fd.simulate(heavy_top_model(at_pivot=p), **run) for p in (True, False))
    for c in ["R11", "R12", "R21", "R23", "R32", "R33"]:
        np.testing.assert_allclose(a[f"rot.{c}"].values, b[f"rot.{c}"].values, atol=1e-9)
    np.testing.assert_allclose(a["e.total"].values, b["e.total"].values, atol=1e-9)


def test_clamped_halves_move_as_one_rigid_body():
    # Two clamped halves of a pendulum against one body with the combined mass properties
    # about the combined centre of mass (parallel-axis theorem).
    split = fd.Model("split", gravity=[0, 0, -9.81])
    split.node("a", [0.5, 0, 0]).node("b", [1.0, 0, 0])
    split.body("half_a", "a", mass=1.0, inertia=[0.001, 0.02, 0.02])
    split.body("half_b", "b", mass=1.0, inertia=[0.001, 0.02, 0.02])
    split.clamp("weld", "a", "b")
    split.revolute("pin", "ground", "a", axis=[0, 1, 0], position=[0, 0, 0])
    split.sensor("joint_coordinate", "angle", joint="pin")
    whole = fd.Model("whole", gravity=[0, 0, -9.81])
    whole.node("c", [0.75, 0, 0])
    whole.body("body", "c", mass=2.0, inertia=[0.002, 0.04 + 2 * 0.25**2, 0.04 + 2 * 0.25**2])
    whole.revolute("pin", "ground", "c", axis=[0, 1, 0], position=[0, 0, 0])
    whole.sensor("joint_coordinate", "angle", joint="pin")
    for scheme in ["ep", "ed"]:
        r1 = fd.simulate(split, scheme=scheme, step_control="fixed", dt=2e-3, t_end=2.0, newton_tol=1e-13)
        r2 = fd.simulate(whole, scheme=scheme, step_control="fixed", dt=2e-3, t_end=2.0, newton_tol=1e-13)
        assert np.ptp(r2["angle.phi"].values) > 1.0
        np.testing.assert_allclose(r1["angle.phi"].values, r2["angle.phi"].values, atol=1e-9)


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_damper_dissipates_and_the_energy_balance_closes(scheme):
    m = fd.Model("damped", gravity=[0, 0, -9.81])
    m.node("bob", [1, 0, 0])
    m.body("ball", "bob", mass=2.0, inertia=[0.01] * 3)
    m.revolute(
        "pin",
        "ground",
        "bob",
        axis=[0, 1, 0],
        position=[0, 0, 0],
        spring={"stiffness": 5.0, "damping": 0.5, "rest": 0.2},
    )
    m.sensor("energy", "e")
    res = fd.simulate(m, scheme=scheme, step_control="fixed", dt=5e-3, t_end=5.0)
    w = res["e.damper_work"].values
    assert np.all(np.diff(w) <= 0) and w[-1] < -1.0
    scale = np.max(np.abs(res["e.total"].values))
    assert np.max(np.abs(res["e.balance"].values)) < 1e-10 * scale


def test_reaction_is_the_force_that_moves_the_body():
    # Newton's law for the bob at every sample time: F_pin = m (a − g). With a constant step,
    # the reaction at t_k is the mean of the two steps' forces and the central difference of
    # the recorded velocities is the mean of their momentum changes, so this holds to
    # round-off (measured 1e-13 of the weight) in both schemes.
    mass, h = 2.0, 1e-3
    m = fd.Model("pendulum", gravity=[0, 0, -9.81])
    m.node("bob", [1, 0, 0])
    m.body("ball", "bob", mass=mass, inertia=[0.01] * 3)
    m.revolute("pin", "ground", "bob", axis=[0, 1, 0], position=[0, 0, 0])
    m.sensor("joint_reaction", "rx", joint="pin")
    track(m, "bob")
    for scheme in ["ep", "ed"]:
        res = fd.simulate(m, scheme=scheme, step_control="fixed", dt=h, t_end=1.0, newton_tol=1e-13)
        g = np.array([0, 0, -9.81])
        v = np.stack([res[f"bob_vel.v{c}"].values for c in "xyz"], axis=-1)
        f = np.stack([res[f"rx.F{c}"].values for c in "xyz"], axis=-1)
        accel = (v[2:] - v[:-2]) / (2 * h)
        np.testing.assert_allclose(f[1:-1], mass * (accel - g), atol=1e-9 * mass * 9.81)
        # At release from rest the pin carries m (g − a): a_z = −g m L²/(m L² + I).
        a_z = -9.81 * mass / (mass + 0.01)
        assert f[0, 2] == pytest.approx(mass * (a_z + 9.81), rel=1e-3)
        # The pin carries the weight plus the centripetal force: tens of newtons at the bottom.
        assert np.max(np.linalg.norm(f, axis=1)) > 3 * mass * 9.81 * 0.9
        assert np.all(np.isfinite(f))

"""Steady spin: in a static solve, nodes given an initial spin carry the inertia of that steady
rotation (centrifugal force, gyroscopic moment), so the solution is the equilibrium in the frame
turning with them; `preload: true` starts a spinning run from it."""

import numpy as np
import pytest
from test_step_control import rotor

import flexdyn as fd

OMEGA = 20.0


def slider_on_spinning_arm(k=2e4, mass=5.0, r0=1.0):
    """A mass on a radial prismatic joint with a spring, on a hub spun about z."""
    m = fd.Model("mass on a spinning arm")
    m.node("hub", [0, 0, 0]).body("hub_body", "hub", mass=10.0, inertia=[1, 1, 1])
    m.node("slider", [r0, 0, 0]).body("slider_body", "slider", mass=mass, inertia=[0.01] * 3)
    m.revolute("shaft", "ground", "hub", axis=[0, 0, 1], position=[0, 0, 0], drive=f"{OMEGA}*t")
    m.prismatic("arm", "hub", "slider", axis=[1, 0, 0], spring={"stiffness": k})
    m.initial_spin(["hub", "slider"], axis=[0, 0, 1], rate=OMEGA)
    m.sensor("joint_coordinate", "stretch", joint="arm", component="delta")
    m.sensor("drive_force", "motor", joint="shaft", component="torque")
    return m


def test_static_solve_of_a_spinning_slider_is_its_relative_equilibrium():
    # k Δ = m Ω² (r0 + Δ): exact for a point mass, so to Newton's tolerance.
    k, mass, r0 = 2e4, 5.0, 1.0
    res = fd.solve_static(slider_on_spinning_arm(k, mass, r0).simulation(analysis="static"))
    expected = mass * OMEGA**2 * r0 / (k - mass * OMEGA**2)
    assert res["stretch"].values[-1] == pytest.approx(expected, rel=1e-9)


def test_preloaded_spinning_slider_stays_in_its_relative_equilibrium():
    # Started from the steady-spin equilibrium with velocities of the spin at that radius, the
    # slider stays there: the spring's stretch does not oscillate and the drive carries no
    # torque. Unloaded, it swings about the equilibrium by its full stretch.
    k, mass, r0 = 2e4, 5.0, 1.0
    expected = mass * OMEGA**2 * r0 / (k - mass * OMEGA**2)
    runs = {}
    for preload in (False, True):
        m = slider_on_spinning_arm(k, mass, r0)
        m.simulation(t_end=0.5, dt=1e-3, scheme="ed", step_control="fixed", preload=preload)
        runs[preload] = fd.simulate(m)
    assert np.ptp(runs[False]["stretch"].values) > 1.5 * expected
    steady = runs[True]
    # A fixed step keeps the discrete spin rate constant: the stretch holds to the discrete
    # rotation's O((Ωh)²) ≈ 4e-4 relative offset in centrifugal force (measured 1.5e-4).
    assert np.ptp(steady["stretch"].values) < 1e-3 * expected
    # Torque scale: the centrifugal force times 1 m, ~2.2 kN·m (the unloaded run needs 1.5
    # kN·m). Measured ≤ 0.11 N·m after the first steps: the t = 0 sample of a multiplier is
    # extrapolated from the first step (7 N·m here, −9 N·m on the unloaded run, whose true
    # value is 0), and ED settles it within a few steps.
    late = steady["time"].values >= 5e-3
    assert np.abs(steady["motor"].values[late]).max() < 1e-4 * k * expected  # times 1 m


def spinning_blade(preload):
    """test_step_control's rotor — a hub and two 2 m blades (8 kg/m, EA 2e8 N, lag ei2 5e4
    and flap ei3 5e5 N·m²) driven at 20 rad/s about z — with blade 1's tip position. Without
    `preload`, the blades start unstrained (no inertial pre-load either)."""
    m = rotor(True)
    m.sensor("node_position", "tip", node="blade1.12")
    m.simulation(
        t_end=0.3, dt=5e-4, scheme="ed", step_control="fixed", preload=preload, inertial_preload=preload
    )
    return m


def test_spinning_beam_stretches_as_the_analytic_rod():
    # Tension N(x) = mΩ²(L² − x²)/2 integrates to a tip stretch mΩ²L³/(3 EA) = 4.27e-5 m. The
    # beam's mass is lumped at its nodes: with 4 cubic elements that moves the stretch by
    # ~0.1 % (measured); 1 % bounds it.
    res = fd.solve_static(spinning_blade(False).simulation(analysis="static"))
    analytic = 8.0 * OMEGA**2 * 2.0**3 / (3 * 2e8)
    assert res["tip.x"].values[-1] - 2.0 == pytest.approx(analytic, rel=1e-2)


def stretch(res):
    return np.hypot(res["tip.x"].values, res["tip.y"].values) - 2.0


def test_preloaded_spinning_beam_needs_no_drive_torque():
    # Started stretched, the blade spins steadily; started unstretched, its stretch rings and
    # the drive feels the Coriolis forces of that radial motion.
    free, steady = (fd.simulate(spinning_blade(p)) for p in (False, True))
    analytic = 8.0 * OMEGA**2 * 2.0**3 / (3 * 2e8)
    assert np.ptp(stretch(steady)) < 1e-2 * analytic
    assert np.ptp(stretch(free)) > 0.5 * analytic
    # Torque scale: the blade's centrifugal force (32 kN) times its 1 m mean radius; measured
    # 0.28 N·m after the first steps (see the slider test on the t = 0 sample of a
    # multiplier). The stiff blade's stretch is tiny, so the unloaded run's Coriolis torque is
    # only ~2 N·m: the slider test is the one that contrasts torques.
    late = steady["time"].values >= 5e-3
    assert np.abs(steady["motor.torque"].values[late]).max() < 1e-4 * 3.2e4


def test_modes_about_the_steady_spin_follow_southwell():
    # A uniform cantilever blade rotating about its root: ω² = ω0² + K Ω² with Southwell's
    # K = 1.193 for the first out-of-plane (flap) mode and K − 1 = 0.193 in plane (lag: the
    # centrifugal softening −mΩ² in the rotation plane). The blade's lag stiffness (ei2, axis
    # 2 along z) is the softer: modes 1–2 are the two blades' lag, 3–4 their flap (the hub is
    # held by its drive, so the blades do not couple). Measured 0.1907 and 1.153: the
    # lumped mass of 4 elements moves the coefficients by 1–3 %; 5 % bounds it. (Modes about
    # the steady spin leave out the Coriolis coupling, as a Southwell analysis does.)
    still = spinning_blade(False)
    still.data["initial_spins"] = []
    w0 = fd.modes(still, count=4)["omega"].values
    w = fd.modes(spinning_blade(False), count=4)["omega"].values
    k = (w**2 - w0**2) / OMEGA**2
    assert k[:2] == pytest.approx([0.193] * 2, rel=0.05)
    assert k[2:] == pytest.approx([1.193] * 2, rel=0.05)

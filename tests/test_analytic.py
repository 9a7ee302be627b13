"""Validation against closed-form solutions: small-amplitude pendulum period and a driven
four-bar linkage (kinematics and driving torque from inverse dynamics)."""

import numpy as np
import pytest

import flexdyn as fd

G = 9.81


def zero_up_crossings(t, y):
    i = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_small_amplitude_pendulum_period(scheme):
    L, m, i_cm, theta0 = 0.8, 1.5, 0.02, 0.01
    omega = np.sqrt(m * G * L / (i_cm + m * L**2))
    model = fd.Model("pendulum", gravity=[0, 0, -G])
    # Start at the bottom with the rate that gives amplitude theta0 (velocities are made
    # consistent with the joint by the initial projection).
    model.node(
        "bob", [0, 0, -L], angular_velocity=[0, theta0 * omega, 0], velocity=[-theta0 * omega * L, 0, 0]
    )
    model.body("ball", "bob", mass=m, inertia=[i_cm] * 3)
    model.revolute("pin", "ground", "bob", axis=[0, 1, 0], position=[0, 0, 0])
    model.sensor("joint_coordinate", "angle", joint="pin")
    res = fd.simulate(model, scheme=scheme, step_control="fixed", dt=1e-3, t_end=12.0)
    t0 = zero_up_crossings(res.time.values, res["angle.phi"].values)
    period = np.mean(np.diff(t0))
    # Finite-amplitude correction T0 (1 + θ0²/16); the scheme's own period error is
    # (ω h)²/12 ≈ 8e-7 for both EP and ED at this step.
    expected = 2 * np.pi / omega * (1 + theta0**2 / 16)
    assert abs(period - expected) / expected < 3e-6
    assert abs(np.max(res["angle.phi"].values) - theta0) < 1e-4 * theta0


# Four-bar: ground d, crank a (driven at constant rate), coupler b, rocker c; crank-rocker.
D, A, B, C = 1.0, 0.3, 1.0, 0.8
MASS = {"crank": 0.5, "coupler": 1.2, "rocker": 0.9}
LEN = {"crank": A, "coupler": B, "rocker": C}
RATE = 2.0


def fourbar_points(theta2):
    """Joint points A (crank-coupler) and B (coupler-rocker), open branch (B above)."""
    pa = np.array([A * np.cos(theta2), A * np.sin(theta2), 0.0])
    o4 = np.array([D, 0.0, 0.0])
    dv = o4 - pa
    dist = np.linalg.norm(dv)
    u = dv / dist
    p = (B**2 - C**2 + dist**2) / (2 * dist)
    hgt = np.sqrt(B**2 - p**2)
    n = np.array([-u[1], u[0], 0.0])
    pb = pa + p * u + hgt * n
    return pa, pb


def fourbar_state(theta2):
    """Centres of mass and angles of the three links."""
    pa, pb = fourbar_points(theta2)
    o4 = np.array([D, 0.0, 0.0])
    cms = {"crank": pa / 2, "coupler": (pa + pb) / 2, "rocker": (o4 + pb) / 2}
    ang = {
        "crank": theta2,
        "coupler": np.arctan2(pb[1] - pa[1], pb[0] - pa[0]),
        "rocker": np.arctan2(pb[1], pb[0] - D),
    }
    return cms, ang


def kinetic_energy(t, theta20):
    def at(tt):
        return fourbar_state(theta20 + RATE * tt)

    e = 1e-6
    cp, ap = at(t + e)
    cm, am = at(t - e)
    T = 0.0
    for k, mass in MASS.items():
        v = (cp[k] - cm[k]) / (2 * e)
        w = (ap[k] - am[k]) / (2 * e)
        T += 0.5 * mass * v @ v + 0.5 * mass * LEN[k] ** 2 / 12 * w**2
    return T


def bar_inertia(m, length, direction):
    """Slender bar: m L²/12 about axes normal to it, a small axial value to stay definite."""
    u = np.asarray(direction) / np.linalg.norm(direction)
    i_n = m * length**2 / 12
    return (i_n * (np.eye(3) - np.outer(u, u)) + 1e-3 * i_n * np.outer(u, u)).tolist()


def fourbar_model(theta20):
    pa, pb = fourbar_points(theta20)
    cms, _ = fourbar_state(theta20)
    o4 = np.array([D, 0.0, 0.0])
    dirs = {"crank": pa, "coupler": pb - pa, "rocker": pb - o4}
    m = fd.Model("four-bar")
    for k, mass in MASS.items():
        m.node(k, cms[k])
        m.body(f"{k}_body", k, mass=mass, inertia=bar_inertia(mass, LEN[k], dirs[k]))
    # Revolute–spherical–universal–revolute: a spatial four-bar with one degree of freedom
    # and no redundant constraint.
    m.revolute("crank_pin", "ground", "crank", axis=[0, 0, 1], position=[0, 0, 0], drive=f"{RATE}*t")
    m.spherical("crank_coupler", "crank", "coupler", position=pa)
    u_c = (pb - pa) / np.linalg.norm(pb - pa)
    m.universal(
        "coupler_rocker", "coupler", "rocker", axis1=np.cross([0, 0, 1], u_c), axis2=[0, 0, 1], position=pb
    )
    m.revolute("rocker_pin", "ground", "rocker", axis=[0, 0, 1], position=o4)
    m.sensor("joint_coordinate", "rocker_angle", joint="rocker_pin")
    m.sensor("drive_force", "crank_drive", joint="crank_pin")
    m.sensor("energy", "e")
    return m


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_driven_fourbar_kinematics_and_torque(scheme):
    theta20 = 0.4
    h = 1e-3
    res = fd.simulate(fourbar_model(theta20), scheme=scheme, step_control="fixed", dt=h, t_end=3.2)
    t = res.time.values
    # Kinematics: the rocker angle from the closed form (Freudenstein's geometry).
    rocker0 = fourbar_state(theta20)[1]["rocker"]
    exact = np.array([fourbar_state(theta20 + RATE * tt)[1]["rocker"] for tt in t]) - rocker0
    assert np.max(np.abs(res["rocker_angle.phi"].values - exact)) < 1e-9
    # Driving torque from inverse dynamics: τ θ̇₂ = dT/dt (no gravity, no losses).
    # The driving torque is reported at the sample times: the step-average multipliers
    # (which belong to mid-step times) are interpolated between neighbouring steps.
    tq = res["crank_drive.torque"].values
    e = 1e-4

    def exact_torque(times):
        return np.array(
            [
                (kinetic_energy(x + e, theta20) - kinetic_energy(x - e, theta20)) / (2 * e) / RATE
                for x in times
            ]
        )

    ex = exact_torque(t)
    scale = np.max(np.abs(ex))
    assert scale > 0.1  # the torque is far from trivial
    # Second order at every sample after the start-up (measured 1e-6 of the peak at
    # h = 1e-3 for both schemes: interpolation at the step boundary also averages out EP's
    # undamped period-2 multiplier oscillation, whose amplitude here is 9e-5 of the peak).
    assert np.max(np.abs(tq[2:-1] - ex[2:-1])) < 1e-5 * scale
    # The first and last samples are extrapolated from the two nearest steps, so they keep
    # EP's oscillation (measured 1.8e-4 of the peak at t_end under EP).
    assert abs(tq[0] - ex[0]) < 5e-4 * scale
    assert abs(tq[-1] - ex[-1]) < 5e-4 * scale
    # The driving torque's work is the change of kinetic energy.
    w = res["crank_drive.work"].values
    ke = res["e.kinetic"].values
    assert np.max(np.abs(w - (ke - ke[0]))) < 1e-9 * np.max(ke)
    # Velocities were not given: they are completed from the drive without a warning.
    assert not res.flexdyn.warnings


@pytest.mark.parametrize("scheme", ["ed", "ep"])
def test_a_load_pulse_inside_a_step_carries_its_impulse(scheme):
    # A free 2 kg body pushed by 10 N for 50 ms, from t = 0.12 s, with fixed 0.1 s steps: the
    # pulse lies inside the second step. A load acts over a step with its scale's mean there,
    # so the momentum after it is the impulse, 0.5 N·s, to the quadrature's 1e-12 of a part
    # (the average of the step's end values, both 0, carried nothing). Its momentum then
    # stays; the work done is the kinetic energy (ED's jump dissipation has nothing to damp).
    m = fd.Model("pushed body")
    m.node("body", [0, 0, 0]).body("mass", "body", mass=2.0, inertia=[1.0] * 3)
    m.force("push", node="body", value=[10.0, 0, 0], scale="t > 0.12 && t < 0.17 ? 1 : 0")
    m.sensor("node_velocity", "v", node="body").sensor("energy", "energy")
    res = fd.simulate(m, scheme=scheme, step_control="fixed", dt=0.1, t_end=0.4)
    v = res["v.vx"].values
    assert v[1] == 0.0
    assert v[2:] == pytest.approx(0.25, rel=1e-10)
    assert res["energy.kinetic"].values[-1] == pytest.approx(0.5 * 2.0 * 0.25**2, rel=1e-10)

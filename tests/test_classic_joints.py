"""Prismatic, cylindrical and screw joints (issue 4) against closed-form mechanics: a driven
slider-crank (kinematics and inverse dynamics), a nut running down a frictionless screw, a
mass on a sprung slide, and the invariants of each joint under EP and ED."""

import numpy as np
import pytest

import flexdyn as fd

G = 9.81


def slider_crank(scheme, dt=1e-3, t_end=1.0, omega=2 * np.pi):
    """Crank (radius r) driven at constant speed about z, rod (length l) from the crank pin to
    a slider on the x axis. Crank–rod: spherical; rod–slider: universal (so the rod cannot spin
    about itself); slider–ground: prismatic along x. Gravity along −y."""
    r, l = 0.2, 0.7
    m = fd.Model("slider-crank", gravity=[0, -G, 0])
    # Initial configuration: θ = 0, pin at (r, 0), slider at (r + l, 0), rod centre between.
    m.node("crank", [0, 0, 0]).node("rod", [r + l / 2, 0, 0]).node("slider", [r + l, 0, 0])
    m.body("crank_body", "crank", mass=2.0, inertia=[0.01, 0.01, 0.02])
    m.body("rod_body", "rod", mass=1.5, inertia=[0.001, 1.5 * l**2 / 12, 1.5 * l**2 / 12])
    m.body("slider_body", "slider", mass=3.0, inertia=[0.01, 0.01, 0.01])
    m.revolute("shaft", "ground", "crank", axis=[0, 0, 1], position=[0, 0, 0], drive=f"{omega}*t")
    m.spherical("pin", "crank", "rod", position=[r, 0, 0])
    m.universal("wrist", "rod", "slider", axis1=[0, 0, 1], axis2=[0, 1, 0], position=[r + l, 0, 0])
    m.prismatic("slide", "ground", "slider", axis=[1, 0, 0], position=[r + l, 0, 0])
    m.sensor("node_position", "s", node="slider").sensor("joint_coordinate", "q", joint="slide")
    m.sensor("drive_force", "motor", joint="shaft").sensor("energy", "e")
    m.sensor("joint_reaction", "rail", joint="slide").sensor("joint_reaction", "bearing", joint="shaft")
    return m, r, l, omega, fd.simulate(m, scheme=scheme, step_control="fixed", dt=dt, t_end=t_end)


def slider_crank_energy(t, r, l, omega):
    """Closed-form kinetic + potential energy of the slider-crank at crank angle ωt."""
    th = omega * t

    def pos(th):
        x_pin, y_pin = r * np.cos(th), r * np.sin(th)
        xs = x_pin + np.sqrt(l**2 - y_pin**2)
        beta = np.arctan2(-y_pin, xs - x_pin)
        return x_pin, y_pin, xs, beta

    h = 1e-6
    y_pin = pos(th)[1]
    p1, p0 = pos(th + h), pos(th - h)
    d = [(a - b) / (2 * h) * omega for a, b in zip(p1, p0)]  # time derivatives
    vx_pin, vy_pin, vs, dbeta = d
    v_cm = np.array([(vx_pin + vs) / 2, vy_pin / 2])
    kin = 0.5 * 0.02 * omega**2 + 0.5 * 3.0 * vs**2
    kin += 0.5 * 1.5 * (v_cm**2).sum(axis=0) + 0.5 * (1.5 * l**2 / 12) * dbeta**2
    pot = G * 1.5 * y_pin / 2  # only the rod's centre moves vertically
    return kin + pot


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_slider_crank_kinematics_and_driving_torque(scheme):
    _, r, l, omega, s = slider_crank(scheme)
    t = s.time.values
    th = omega * t
    exact_x = r * np.cos(th) + np.sqrt(l**2 - (r * np.sin(th)) ** 2)
    # The constraints hold to round-off, so the slider follows the closed form exactly.
    np.testing.assert_allclose(s["s.x"].values, exact_x, atol=1e-12)
    np.testing.assert_allclose(s["q.delta"].values, exact_x - (r + l), atol=1e-12)
    assert np.abs(s["s.y"].values).max() < 1e-12
    # Inverse dynamics: at constant crank speed the driving torque supplies dE/dt.
    dt = 1e-6
    de_dt = (slider_crank_energy(t + dt, r, l, omega) - slider_crank_energy(t - dt, r, l, omega)) / (2 * dt)
    torque = s["motor.torque"].values
    scale = np.abs(de_dt).max() / omega
    # Time discretisation O((ωh)²) (ωh = 6e-3): measured 8e-5 of the peak, bound 2.5× that.
    # The first and last samples are extrapolated from the steps around them (their
    # multipliers belong to mid-step times), to 3e-3: compared at the interior samples.
    np.testing.assert_allclose(torque[1:-1], (de_dt / omega)[1:-1], atol=2e-4 * scale)
    assert s.flexdyn.stats["max_constraint_work"] < 1e-12
    # Joint-frame reactions: a frictionless slide carries no force along its axis (3); the
    # driven shaft's moment about its axis is the driving torque (up to O((ωh)²): the step's
    # discrete force is resolved in the end-of-step frame; measured 3e-6).
    rail_force = np.abs(np.stack([s[f"rail.F{c}"].values for c in "123"])).max()
    assert np.abs(s["rail.F3"].values).max() < 1e-9 * rail_force
    np.testing.assert_allclose(s["bearing.M3"].values, torque, atol=1e-5 * scale)
    assert s["rail.violation"].values.max() < 1e-12


def nut_on_screw(scheme, pitch, t_end, dt=1e-3):
    """A nut (mass m, axial inertia J) on a frictionless vertical screw, released from rest
    under gravity; it runs down turning, with Δ = pitch·φ."""
    m_nut, j_nut = 0.5, 2e-4
    m = fd.Model("nut", gravity=[0, 0, -G])
    m.node("nut", [0, 0, 0])
    m.body("nut_body", "nut", mass=m_nut, inertia=[1e-4, 1e-4, j_nut])
    m.screw("thread", "ground", "nut", axis=[0, 0, 1], pitch=pitch)
    m.sensor("joint_coordinate", "q", joint="thread").sensor("node_rotation", "rot", node="nut")
    m.sensor("energy", "e").sensor("node_position", "p", node="nut")
    return m_nut, j_nut, fd.simulate(m, scheme=scheme, step_control="fixed", dt=dt, t_end=t_end)


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_nut_runs_down_a_screw_through_several_turns(scheme):
    # Effective mass m + J/p²: Δ(t) = −½ a t², a = m g/(m + J/p²). Pitch 2 mm/rad: 2 s of
    # fall is 0.19 m and 15 turns, ending at 97 rad/s. The thread keeps Δ = p φ to round-off
    # throughout.
    pitch = 2e-3
    m_nut, j_nut, s = nut_on_screw(scheme, pitch, t_end=2.0)
    t = s.time.values
    a = m_nut * G / (m_nut + j_nut / pitch**2)
    delta, phi = s["q.delta"].values, s["q.phi"].values
    assert phi[-1] / (2 * np.pi) < -5  # several turns (downwards: negative φ)
    np.testing.assert_allclose(delta, pitch * phi, atol=1e-12)
    np.testing.assert_allclose(s["p.z"].values, delta, atol=1e-12)
    # The spin is integrated with Cayley increments (angle 2 atan(ωh/2) per step, not ωh):
    # a relative error of order (ωh)²/12, 8e-4 at the end; measured 5e-4.
    np.testing.assert_allclose(delta, -0.5 * a * t**2, rtol=1e-3, atol=1e-12)
    e = s["e.total"].values
    assert np.abs(e - e[0]).max() < 1e-9 * np.abs(s["e.kinetic"].values).max()
    if scheme == "ed":
        assert np.all(np.diff(e) <= 1e-12 * np.abs(s["e.kinetic"].values).max())
    assert s.flexdyn.stats["max_constraint_work"] < 1e-12


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_sprung_slide_oscillates_at_sqrt_k_over_m(scheme):
    # A 2 kg body on an inclined prismatic slide with a spring k = 800 N/m: it oscillates about
    # the static offset m g sinα/k at ω = √(k/m) = 20 rad/s.
    k, mass, alpha = 800.0, 2.0, 0.5
    axis = [np.cos(alpha), 0.0, -np.sin(alpha)]
    m = fd.Model("slide", gravity=[0, 0, -G])
    m.node("b", [0, 0, 0])
    m.body("body", "b", mass=mass, inertia=[0.01, 0.02, 0.03])
    m.prismatic("rail", "ground", "b", axis=axis, spring={"stiffness": k})
    m.sensor("joint_coordinate", "q", joint="rail").sensor("energy", "e")
    s = fd.simulate(m, scheme=scheme, step_control="fixed", dt=1e-3, t_end=1.0)
    omega = np.sqrt(k / mass)
    static = mass * G * np.sin(alpha) / k
    exact = static * (1 - np.cos(omega * s.time.values))
    # (ωh)²/12 = 3e-5 phase error per radian: after 20 rad, 7e-4 of the amplitude.
    np.testing.assert_allclose(s["q.delta"].values, exact, atol=2e-3 * static)
    e = s["e.total"].values
    if scheme == "ep":
        assert np.abs(e - e[0]).max() < 1e-10 * np.abs(s["e.kinetic"].values).max()
    else:
        assert np.all(np.diff(e) <= 1e-12 * np.abs(s["e.kinetic"].values).max())
    assert s.flexdyn.stats["max_constraint_work"] < 1e-12


def free_cylinder(scheme):
    """A body on a cylindrical joint to a tumbling carrier body: slides and spins freely."""
    m = fd.Model("cylinder")
    m.node("carrier", [0, 0, 0], velocity=[0.1, 0.0, 0.0], angular_velocity=[0.3, 2.0, -1.0])
    m.body("carrier_body", "carrier", mass=5.0, inertia=[0.2, 0.3, 0.4])
    m.node("sleeve", [0.5, 0.1, 0], velocity=[0.1, 1.0, 0.6], angular_velocity=[0.3, 6.0, -1.0])
    m.body("sleeve_body", "sleeve", mass=1.0, inertia=[0.01, 0.02, 0.015], cm_offset=[0.05, 0, 0])
    m.cylindrical(
        "sleeve_joint",
        "carrier",
        "sleeve",
        axis=[0, 1, 0],
        position=[0.5, 0.1, 0],
        spring_delta={"stiffness": 50.0},
    )
    m.sensor("joint_coordinate", "q", joint="sleeve_joint").sensor("energy", "e").sensor("momentum", "p")
    return fd.simulate(m, scheme=scheme, step_control="fixed", dt=2e-3, t_end=2.0, newton_tol=1e-13)


def test_cylindrical_joint_conserves_energy_and_momenta_under_ep():
    s = free_cylinder("ep")
    assert np.ptp(s["q.delta"].values) > 0.05 and np.ptp(s["q.phi"].values) > 1.0
    e = s["e.total"].values
    assert np.abs(e - e[0]).max() < 1e-9 * e[0]
    h = np.stack([s[f"p.H{c}"].values for c in "xyz"])
    assert np.abs(h - h[:, :1]).max() < 1e-9 * np.abs(h).max()
    assert s.flexdyn.stats["max_constraint_work"] < 1e-12
    assert s.flexdyn.stats["max_constraint_violation"] < 1e-12


def test_cylindrical_joint_never_gains_energy_under_ed():
    s = free_cylinder("ed")
    e = s["e.total"].values
    assert np.all(np.diff(e) <= 1e-12 * e[0])
    assert np.abs(s["e.balance"].values).max() < 1e-10 * e[0]


def test_joint_input_errors_say_what_to_fix():
    m = fd.Model()
    m.node("a", [0, 0, 0]).body("ba", "a", mass=1.0, inertia=[1, 1, 1])
    m.screw("s1", "ground", "a", axis=[0, 0, 1], pitch=0.0)
    m.screw("s2", "ground", "a", axis=[0, 0, 1], pitch=0.01, drive_phi="t", drive_delta="0.01*t")
    m.cylindrical("c", "ground", "a", axis=[0, 0, 1], drive_phi="t", drive_delta="t")
    m.sensor("drive_force", "f1", joint="c")
    m.sensor("drive_force", "f2", joint="s1")
    m.sensor("drive_force", "f3", joint="c", coordinate="theta")
    with pytest.raises(fd.ModelError) as e:
        m.validate()
    msg = str(e.value)
    assert "joints[0].pitch: joint `s1`: the pitch must be a nonzero number of m/rad" in msg
    assert "joints[1].drive_phi: joint `s2`: Δ and φ are tied by the thread" in msg
    assert (
        "sensors[0].joint: joint `c` has drives on both `delta` and `phi`; say which with `coordinate: delta`"
        in msg
    )
    assert "sensors[1].joint: joint `s1` has no drive; add `drive_delta:` to it" in msg
    assert "sensors[2].coordinate: joint `c` has no coordinate `theta` (it has: delta, phi)" in msg


def planar_four_bar(last_joint):
    """Crank, coupler and rocker in the x-y plane, all joints about z: a closed loop whose
    joints impose three constraints more than its one degree of freedom needs."""
    m = fd.Model("planar four-bar")
    pts = {"a": [0, 0, 0], "b": [0, 1, 0], "c": [2, 1.2, 0], "d": [2, 0, 0]}
    for name, (p, q) in {"crank": ("a", "b"), "coupler": ("b", "c"), "rocker": ("c", "d")}.items():
        mid = [(x + y) / 2 for x, y in zip(pts[p], pts[q])]
        m.node(name, mid).body(f"{name}_body", name, mass=1.0, inertia=[0.1, 0.1, 0.1])
    m.revolute("ja", "ground", "crank", axis=[0, 0, 1], position=pts["a"])
    m.revolute("jb", "crank", "coupler", axis=[0, 0, 1], position=pts["b"])
    m.revolute("jc", "coupler", "rocker", axis=[0, 0, 1], position=pts["c"])
    last_joint(m, pts["d"])
    return m


def test_an_over_constrained_loop_is_reported_by_its_joints():
    m = planar_four_bar(lambda m, p: m.revolute("jd", "rocker", "ground", axis=[0, 0, 1], position=p))
    with pytest.raises(fd.ModelError) as e:
        fd.simulate(m, t_end=0.01, step_control="fixed", dt=1e-3)
    msg = str(e.value)
    assert "the constraints of `ja`, `jb`, `jc`, `jd` are not independent in the initial configuration" in msg
    # Said once, with how many equations are redundant (a planar loop of four revolutes: 3),
    # not once per dependence.
    assert msg.count("not independent") == 1 and "(3 of their equations are redundant)" in msg
    assert "make one a universal or spherical joint" in msg
    # Releasing the redundancy (a spherical joint closes the loop instead, and a universal
    # stops the coupler spinning about itself) makes a valid mechanism.
    ok = planar_four_bar(lambda m, p: m.spherical("jd", "rocker", "ground", position=p))
    ok.data["joints"][2] = {
        "type": "universal",
        "name": "jc",
        "node1": "coupler",
        "node2": "rocker",
        "position": [2, 1.2, 0],
        "axis1": [0, 0, 1],
        "axis2": [1, 0, 0],
    }
    assert fd.simulate(ok, t_end=0.01, step_control="fixed", dt=1e-3).attrs["completed"] == 1


def test_a_drive_on_a_locked_coordinate_is_reported():
    m = fd.Model()
    m.node("a", [1, 0, 0]).body("b", "a", mass=1.0, inertia=[1, 1, 1])
    m.prismatic("slide", "ground", "a", axis=[1, 0, 0], drive="0.1*t")
    m.clamp("weld", "ground", "a")
    with pytest.raises(
        fd.ModelError, match=r"`slide`, `weld` are not independent .* a drive prescribes a motion"
    ):
        fd.simulate(m, t_end=0.01, step_control="fixed", dt=1e-3)


def carrier_and_slider(local):
    """A tilted, spinning carrier on a ball joint with a sprung slider on it; the slide is
    given in the carrier's triad (local) or in the inertial frame (the same geometry)."""
    rv = np.array([0.3, -0.5, 0.8])
    angle = np.linalg.norm(rv)
    k = rv / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    rot = np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx
    p_local = np.array([0.3, 0.1, 0.0])
    m = fd.Model("carrier and slider", gravity=[0, 0, -G])
    m.node("c", [0, 0, 0], rotation_vector=rv.tolist(), angular_velocity=[0.5, 1.0, 2.0])
    m.body("carrier", "c", mass=3.0, inertia=[0.1, 0.2, 0.3])
    m.node("p", (rot @ (p_local + [0.2, 0, 0])).tolist())
    m.body("pendulum", "p", mass=1.0, inertia=[0.01, 0.02, 0.02])
    m.spherical("ball", "ground", "c", position=[0, 0, 0])
    if local:
        m.prismatic(
            "slide",
            "c",
            "p",
            axis=[1.0, 0.0, 0.0],
            position=(p_local + [0.2, 0, 0]).tolist(),
            frame="node1",
            spring={"stiffness": 30.0},
        )
    else:
        m.prismatic(
            "slide",
            "c",
            "p",
            axis=(rot @ [1.0, 0.0, 0.0]).tolist(),
            position=(rot @ (p_local + [0.2, 0, 0])).tolist(),
            spring={"stiffness": 30.0},
        )
    m.sensor("node_position", "pos", node="p").sensor("joint_coordinate", "q", joint="slide")
    return fd.simulate(m, scheme="ep", step_control="fixed", dt=2e-3, t_end=0.5)


def test_joint_geometry_given_in_a_node_triad_matches_the_inertial_one():
    a, b = carrier_and_slider(True), carrier_and_slider(False)
    assert np.ptp(a["q.delta"].values) > 1e-3  # it slides
    for c in ("pos.x", "pos.y", "pos.z", "q.delta"):
        np.testing.assert_allclose(a[c].values, b[c].values, atol=1e-12)


def stiffening_slide(scheme, spring):
    m = fd.Model("stiffening slide")
    m.node("b", [0, 0, 0], velocity=[3.0, 0, 0])
    m.body("body", "b", mass=2.0, inertia=[0.01, 0.02, 0.03])
    m.prismatic("rail", "ground", "b", axis=[1, 0, 0], spring=spring)
    m.sensor("joint_coordinate", "q", joint="rail").sensor("energy", "e")
    return fd.simulate(m, scheme=scheme, step_control="fixed", dt=2e-3, t_end=2.0)


# A spring that stiffens fourfold beyond ±0.1 m (a bump stop), swept through both ends.
TABLE = {"table": {"at": [-0.3, -0.1, 0.1, 0.3], "force": [-100.0, -20.0, 20.0, 100.0]}}


def test_tabulated_spring_conserves_energy_under_ep():
    s = stiffening_slide("ep", TABLE)
    assert s["q.delta"].values.max() > 0.15  # reaches the stiff part
    e = s["e.total"].values
    assert np.abs(e - e[0]).max() < 1e-10 * e[0]


def test_tabulated_spring_energy_identity_under_ed():
    # The generalised ED spring (secant force between j and f, j-force 2(N̄ − F(ε_j))) loses
    # exactly V(ε_i) − V(ε_j) − F(ε_j)(ε_i − ε_j) per step: the recorded identity closes.
    s = stiffening_slide("ed", TABLE)
    e = s["e.total"].values
    assert np.all(np.diff(e) <= 1e-12 * e[0])
    assert np.abs(s["e.balance"].values).max() < 1e-10 * e[0]
    assert s["e.numerical_dissipation"].values[-1] > 0


@pytest.mark.parametrize("scheme", ["ep", "ed"])
def test_a_linear_table_is_the_linear_spring(scheme):
    lin = stiffening_slide(scheme, {"stiffness": 200.0, "rest": 0.05})
    tab = stiffening_slide(scheme, {"table": {"at": [-1.0, 0.05, 1.0], "force": [-210.0, 0.0, 190.0]}})
    np.testing.assert_allclose(tab["q.delta"].values, lin["q.delta"].values, atol=1e-12)
    # Energies differ by a constant only (the table's energy is zero at its first point).
    d = tab["e.total"].values - lin["e.total"].values
    assert np.ptp(d) < 1e-9


def test_spring_table_errors():
    m = fd.Model()
    m.node("b", [0, 0, 0]).body("body", "b", mass=1.0, inertia=[1, 1, 1])
    m.prismatic(
        "r1",
        "ground",
        "b",
        axis=[1, 0, 0],
        spring={"stiffness": 5.0, "table": {"at": [0, 1], "force": [0, 1]}},
    )
    m.prismatic("r2", "ground", "b", axis=[0, 1, 0], spring={"table": {"at": [0, 1, 2], "force": [0, 2, 1]}})
    with pytest.raises(fd.ModelError) as e:
        m.validate()
    msg = str(e.value)
    assert (
        "joints[0].spring.table: joint `r1`: give either `stiffness`/`rest` (linear) or a `table`, not both"
        in msg
    )
    assert "joints[1].spring.table: joint `r2`: the force must not decrease as the coordinate grows" in msg


def gimbal(scheme, k1=200.0, k2=50.0, c1=0.0, c2=0.0, t_end=2.0, spin=(0.1, 0, 0.2)):
    """A disk on a universal joint to the ground (axis1 = z on the ground, axis2 = x on the
    disk) with springs on both rotations, started turning about x and z (`spin`, rad/s)."""
    m = fd.Model("gimbal")
    m.node("disk", [0, 0, 0], velocity=[0, 0, 0], angular_velocity=list(spin))
    m.body("disk_body", "disk", mass=5.0, inertia=[0.5, 0.3, 2.0])
    m.universal(
        "gimbal",
        "ground",
        "disk",
        axis1=[0, 0, 1],
        axis2=[1, 0, 0],
        position=[0, 0, 0],
        spring1={"stiffness": k1, "damping": c1},
        spring2={"stiffness": k2, "damping": c2},
    )
    m.sensor("joint_coordinate", "g", joint="gimbal").sensor("energy", "e")
    m.simulation(scheme=scheme, step_control="fixed", dt=1e-3, t_end=t_end, newton_tol=1e-12)
    return m


@pytest.mark.parametrize("scheme", ["ep", "ed"])
@pytest.mark.parametrize(
    ("name", "spin", "k", "j"), [("phi1", (0, 0, 0.2), 200.0, 2.0), ("phi2", (0.1, 0, 0), 50.0, 0.5)]
)
def test_gimbal_angles_oscillate_at_sqrt_k_over_j(scheme, name, spin, k, j):
    # φ1 turns the cross and disk about z (J = 2.0), φ2 the disk about x (J = 0.5). Started on
    # one rotation alone, the other stays at rest (their coupling is ∝ φ̇1φ̇2): each is a
    # linear oscillator up to O(φ²) ~ 4e-4 (0.02 rad amplitudes); the schemes' phase error over
    # 2 s at ωh = 0.01 is ~(ωh)²ωt/12 ~ 2e-4 of the amplitude.
    res = fd.simulate(gimbal(scheme, spin=spin))
    t = res["time"].values
    rate = max(spin)
    w = np.sqrt(k / j)
    amplitude = rate / w
    assert np.abs(res[f"g.{name}"].values - amplitude * np.sin(w * t)).max() < 1e-3 * amplitude
    assert res[f"g.{name}_rate"].values[0] == pytest.approx(rate, abs=1e-9)
    other = "phi2" if name == "phi1" else "phi1"
    assert np.abs(res[f"g.{other}"].values).max() < 1e-12
    E = res["e.total"].values
    if scheme == "ep":
        assert np.abs(E - E[0]).max() < 1e-9 * E[0]
    else:
        assert np.all(np.diff(E) <= 1e-15 * E[0]) and E[-1] > 0.99 * E[0]


def test_gimbal_dampers_take_the_energy_the_schemes_account_for():
    res = fd.simulate(gimbal("ep", c1=2.0, c2=0.5, t_end=3.0))
    E = res["e.total"].values
    assert E[-1] < 0.2 * E[0]
    assert np.abs(res["e.balance"].values).max() < 1e-9 * E[0]
    assert res["e.damper_work"].values[-1] == pytest.approx(E[-1] - E[0], rel=1e-6)


def test_gimbal_drive_must_start_at_zero():
    m = gimbal("ed")
    m.data["joints"][0]["drive1"] = "0.1 + t"
    with pytest.raises(
        fd.ModelError, match=r"joints\[0\]\.drive1: joint `gimbal`: a universal joint's drive must start at 0"
    ):
        fd.simulate(m)

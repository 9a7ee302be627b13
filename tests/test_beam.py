"""Geometrically exact beams (issue 3, first part): a free flexible beam in large 3-D motion."""

import numpy as np
import pytest

import flexdyn as fd

# A soft beam so that the motion is genuinely flexible.
SECTION = {
    "ea": 1e4,
    "ga2": 5e3,
    "ga3": 5e3,
    "gj": 5.0,
    "ei2": 8.0,
    "ei3": 5.0,
    "m": 1.0,
    "i22": 0.01,
    "i33": 0.01,
}


def free_beam(scheme, dt, t_end, order=2):
    m = fd.Model("free beam")
    # Released tumbling, with a tip mass whose own velocity is not that of the rigid motion,
    # so that the beam bends, twists and stretches in 3-D (strain energy ~14 % of the total).
    m.node("tip", [2, 0, 0], velocity=[0.0, 3.0, -2.0], angular_velocity=[2.0, 0, 0])
    m.body("tip_mass", "tip", mass=0.3, inertia=[1e-3, 1e-3, 1e-3])
    m.beam(
        "b",
        [0, 0, 0],
        end_node="tip",
        elements=4,
        order=order,
        section=SECTION,
        velocity=[0.5, -1.0, 2.0],
        angular_velocity=[0.3, 2.0, 6.0],
    )
    m.sensor("energy", "e").sensor("momentum", "mom")
    m.simulation(scheme=scheme, step_control="fixed", dt=dt, t_end=t_end, newton_tol=1e-13)
    return m


def test_ep_conserves_energy_and_momenta_of_a_free_beam():
    res = fd.simulate(free_beam("ep", 1e-3, 10.0))
    assert res.flexdyn.stats["steps"] == 10_000
    e = res["e.total"].values
    # The motion is flexible: the strain energy varies by a sizeable amount.
    assert np.ptp(res["e.potential"].values) > 0.1 * e[0]
    assert np.max(np.abs(e - e[0])) / e[0] < 1e-9
    for c in ["px", "py", "pz", "Hx", "Hy", "Hz"]:
        v = res[f"mom.{c}"].values
        scale = np.max(np.abs(np.stack([res[f"mom.{d}"].values for d in ["Hx", "Hy", "Hz"]])))
        assert np.max(np.abs(v - v[0])) < 1e-9 * scale, c


@pytest.mark.parametrize("order", [1, 2, 3])
def test_ed_energy_never_increases_and_the_identity_closes(order):
    res = fd.simulate(free_beam("ed", 2e-3, 2.0, order=order))
    e = res["e.total"].values
    assert np.all(np.diff(e) <= 1e-12 * e[0])
    assert np.max(np.abs(res["e.balance"].values)) < 1e-10 * e[0]
    assert res["e.numerical_dissipation"].values[-1] > 0
    assert res.flexdyn.stats["pattern_misses"] == 0
    # Linear momentum is exact for ED too (internal forces are self-equilibrated).
    p = np.stack([res[f"mom.p{c}"].values for c in "xyz"])
    assert np.max(np.abs(p - p[:, :1])) < 1e-10 * np.max(np.abs(p))


def test_beam_errors_name_the_beam():
    m = fd.Model()
    m.beam("blade", [0, 0, 0], [1, 0, 0], elements=2, order=4, section={**SECTION, "ei2": -1.0})
    with pytest.raises(fd.ModelError) as e:
        m.validate()
    msg = str(e.value)
    assert "beams[0].order: beam `blade`: order must be 1 (linear), 2 (quadratic) or 3 (cubic)" in msg
    assert "beams[0].section: beam `blade`: ei2 must be positive" in msg


def test_geometry_section_and_load_errors_name_the_beam_and_say_what_to_fix():
    m = fd.Model()
    m.beam(
        "arc",
        [1, 0, 0.5],
        elements=2,
        section=SECTION,
        arc={"center": [0, 0, 0], "axis": [0, 0, 1], "angle": 1.0},
    )
    m.beam(
        "twisted",
        [0, 0, 0],
        [1, 0, 0],
        elements=2,
        section=SECTION,
        twist_rate=0.1,
        twist={"eta": [0, 1], "angle": [0, 1]},
    )
    m.beam(
        "tapered",
        [0, 0, 0],
        [1, 0, 0],
        elements=2,
        sections=[{"eta": 0.2, "section": SECTION}, {"eta": 1.0, "section": SECTION}],
    )
    m.beam("none", [0, 0, 0], [1, 0, 0], elements=2)
    m.beam("fold", [0, 0, 0], [0, 0, 0], via=[[1, 0, 0]], elements=2, section=SECTION)
    m.distributed_force("q", "nowhere", [0, 0, 1])
    with pytest.raises(fd.ModelError) as e:
        m.validate()
    msg = str(e.value)
    assert (
        "beams[0]: beam `arc`: arc: the start point is not in the plane through the centre normal to the axis"
        in msg
    )
    assert "beams[1].twist: beam `twisted`: give either `twist_rate` or a `twist` table, not both" in msg
    assert (
        "beams[2].sections: beam `tapered`: section stations must start at eta = 0 and end at eta = 1" in msg
    )
    assert "beams[3].section: beam `none`: give either `section` (uniform) or `sections`" in msg
    assert "beams[4]: beam `fold`: the line folds back on itself at via point 0" in msg
    assert "loads[0].beam: load `q` refers to beam `nowhere`, which is not defined in `beams`" in msg


@pytest.mark.parametrize("order,elements", [(1, 20), (2, 10), (3, 8)])
def test_hanging_beam_carries_the_weight_below_each_section(order, elements):
    # A 2 m, 1 kg/m beam hanging from a spherical joint with a 5 kg weight: at rest its axial
    # force is F1(s) = m g (L − s) + M g. It starts unstretched; the axial vibration (ω h ≈ 9)
    # is annihilated by ED within a few steps, leaving the static state.
    sec = {
        "ea": 1e7,
        "ga2": 5e6,
        "ga3": 5e6,
        "gj": 50.0,
        "ei2": 80.0,
        "ei3": 80.0,
        "m": 1.0,
        "i22": 1e-3,
        "i33": 1e-3,
    }
    m = fd.Model("hanging", gravity=[0, 0, -9.81])
    m.node("top", [0, 0, 0]).node("tip", [0, 0, -2])
    m.body("weight", "tip", mass=5.0, inertia=[0.01, 0.01, 0.01])
    m.beam("rope", start_node="top", end_node="tip", elements=elements, order=order, section=sec)
    m.spherical("hook", "ground", "top", position=[0, 0, 0])
    stations = [0.1, 0.25, 0.5, 0.75, 0.9]
    for eta in stations:
        m.sensor("beam_section", f"s{int(eta * 100)}", beam="rope", eta=eta)
    m.sensor("beam_section", "by_arc_length", beam="rope", s=1.0)
    res = fd.simulate(m, scheme="ed", step_control="fixed", dt=1e-2, t_end=1.0)
    # A station by arc length is the same as by fraction of the length.
    np.testing.assert_array_equal(res["by_arc_length.F1"].values, res["s50.F1"].values)
    # Lumping the mass at the nodes misplaces half a node's weight at a linear element's
    # Gauss point (m g Lₑ/2 = 0.49 N here); higher orders recover the exact statics.
    tol = 0.5 if order == 1 else 1e-3
    for eta in stations:
        s = res.isel(time=-1)
        exact = 9.81 * (2.0 * (1 - eta) + 5.0)
        assert abs(float(s[f"s{int(eta * 100)}.F1"]) - exact) < tol, eta
        for c in ["F2", "F3", "M1", "M2", "M3"]:
            assert abs(float(s[f"s{int(eta * 100)}.{c}"])) < 1e-6
        # Hanging straight down, stretched by F1/EA: z(σ) = −(σ + ∫₀^σ F1/EA).
        sigma = 2 * eta
        stretch = 9.81 * (1.0 * (2.0 * sigma - sigma**2 / 2) + 5.0 * sigma) / 1e7
        assert float(s[f"s{int(eta * 100)}.z"]) == pytest.approx(
            -(sigma + stretch), abs=1e-6 if order > 1 else 1e-5
        )
    assert res["s50.F1"].attrs["units"] == "N"


def test_beam_section_sensor_errors():
    m = fd.Model()
    m.beam("b", [0, 0, 0], [1, 0, 0], elements=2, order=1, section=SECTION)
    m.sensor("beam_section", "s", beam="c", eta=1.5)
    m.sensor("beam_section", "too_far", beam="b", s=1.5)
    m.sensor("beam_section", "both", beam="b", s=0.5, eta=0.5)
    with pytest.raises(fd.ModelError) as e:
        m.validate()
    msg = str(e.value)
    assert "sensors[0].beam: refers to beam `c`" in msg
    assert "sensors[0].eta: must be a fraction of the beam length between 0 and 1" in msg
    assert "sensors[1].s: must be an arc length along the beam (the beam is 1 m long), got 1.5" in msg
    assert "sensors[2]: give exactly one of `eta` (fraction of the length) and `s` (arc length)" in msg


@pytest.mark.parametrize("scheme,order,elements", [("ep", 1, 32), ("ep", 2, 8), ("ep", 3, 4), ("ed", 3, 4)])
def test_cantilever_first_bending_frequency(scheme, order, elements):
    # Euler–Bernoulli cantilever: ω₁ = 1.8751² √(EI/(m L⁴)) = 8.790 rad/s here. Released
    # straight under a small gravity, it vibrates about its static deflection, whose shape is
    # almost exactly mode 1. Measured error 0.8e-4 to 1.9e-4; time discretisation alone gives
    # (ω h)²/12 = 2.6e-5.
    length, ei, mass = 2.0, 100.0, 1.0
    sec = {
        "ea": 1e7,
        "ga2": 1e7,
        "ga3": 1e7,
        "gj": 80.0,
        "ei2": ei,
        "ei3": ei,
        "m": mass,
        "i22": 1e-6,
        "i33": 1e-6,
    }
    m = fd.Model("cantilever", gravity=[0, 0, -0.1])
    m.beam("b", [0, 0, 0], [length, 0, 0], elements=elements, order=order, section=sec)
    m.clamp("root", "ground", "b.0")
    m.sensor("node_position", "tip", node=f"b.{elements * order}")
    m.simulation(preload=False)  # the release (by default it would start at its deflection)
    res = fd.simulate(m, scheme=scheme, step_control="fixed", dt=2e-3, t_end=6.0)
    z = res["tip.z"].values
    t = res.time.values
    zc = z - 0.5 * (z.max() + z.min())
    i = np.nonzero((zc[:-1] < 0) & (zc[1:] >= 0))[0]
    crossings = t[i] - zc[i] * (t[i + 1] - t[i]) / (zc[i + 1] - zc[i])
    omega = 2 * np.pi / np.mean(np.diff(crossings))
    exact = 1.875104068711961**2 * np.sqrt(ei / (mass * length**4))
    assert len(crossings) >= 7
    assert abs(omega - exact) / exact < 1e-3


def spinning_blade_error(elements):
    """Largest relative error of the axial force F1(x) = m Ω² (L² − x²)/2 along a blade spun up
    quasi-statically to Ω = 10 rad/s by a driven hub (φ = Ω(t − τ tanh(t/τ)), rate Ω tanh²(t/τ)).
    The blade is stiff in-plane so that ED removes any lag vibration (ω h ≈ 1.4) while the spin
    stays resolved (Ω h = 0.05)."""
    omega, length, mass, tau = 10.0, 2.0, 1.0, 1.0
    sec = {
        "ea": 1e7,
        "ga2": 1e7,
        "ga3": 1e7,
        "gj": 1e4,
        "ei2": 1e5,
        "ei3": 1e5,
        "m": mass,
        "i22": 1e-4,
        "i33": 1e-4,
    }
    m = fd.Model("spinning blade")
    m.node("hub", [0, 0, 0])
    m.body("hub_body", "hub", mass=10.0, inertia=[1, 1, 1])
    m.revolute(
        "shaft",
        "ground",
        "hub",
        axis=[0, 0, 1],
        position=[0, 0, 0],
        drive=f"{omega}*(t - {tau}*tanh(t/{tau}))",
    )
    m.beam("blade", start_node="hub", end=[length, 0, 0], elements=elements, order=2, section=sec)
    stations = [0.0, 0.25, 0.5, 0.75]
    for eta in stations:
        m.sensor("beam_section", f"s{int(eta * 100)}", beam="blade", eta=eta)
    m.sensor("joint_coordinate", "spin", joint="shaft")
    s = fd.simulate(m, scheme="ed", step_control="fixed", dt=5e-3, t_end=6.0).isel(time=-1)
    rate = float(s["spin.phi_rate"])
    assert rate == pytest.approx(omega, rel=1e-4)
    for eta in stations:
        assert abs(float(s[f"s{int(eta * 100)}.M3"])) < 1e-2  # no lag bending left
    exact = [mass * rate**2 * (length**2 - (eta * length) ** 2) / 2 for eta in stations]
    return max(abs(float(s[f"s{int(eta * 100)}.F1"]) / e - 1) for eta, e in zip(stations, exact))


def test_spinning_blade_axial_force_converges_to_the_centrifugal_value():
    # Lumped masses give an O(Lₑ²) error that halving the elements divides by ~4 (measured
    # 2.4e-2, 6.4e-3, 1.9e-3 for 4, 8, 16 quadratic elements; the time step adds ~2e-4).
    errors = [spinning_blade_error(n) for n in (4, 8, 16)]
    assert errors[0] / errors[1] > 3.0
    assert errors[1] / errors[2] > 2.5
    assert errors[2] < 3e-3


@pytest.mark.parametrize("order,elements", [(2, 4), (3, 3)])
def test_tip_loaded_cantilever_bending_moment(order, elements):
    # Linear range: M3(s) = P (L − s), F2 = P, tip deflection P L³/(3 EI) (+ P L/GA). The load
    # is ramped as tanh²(t/τ) with τ = 0.5 s, seven first-mode periods, so the response is
    # quasi-static; the residual first-mode vibration is ~1.5e-3 of the load.
    length, ei, p = 2.0, 1e4, 10.0
    sec = {
        "ea": 1e8,
        "ga2": 1e8,
        "ga3": 1e8,
        "gj": 1e4,
        "ei2": ei,
        "ei3": ei,
        "m": 1.0,
        "i22": 1e-4,
        "i33": 1e-4,
    }
    m = fd.Model("cantilever")
    n = elements * order
    m.beam("b", [0, 0, 0], [length, 0, 0], elements=elements, order=order, section=sec, e2=[0, 1, 0])
    m.clamp("root", "ground", "b.0")
    m.force("tip_load", f"b.{n}", [0, p, 0], scale="tanh(t/0.5)^2")
    stations = [0.0, 0.25, 0.5, 0.75]
    for eta in stations:
        m.sensor("beam_section", f"s{int(eta * 100)}", beam="b", eta=eta)
    m.sensor("node_displacement", "tip", node=f"b.{n}")
    s = fd.simulate(m, scheme="ed", step_control="fixed", dt=2e-3, t_end=4.0).isel(time=-1)
    for eta in stations:
        assert float(s[f"s{int(eta * 100)}.M3"]) == pytest.approx(
            p * length * (1 - eta), abs=3e-3 * p * length
        )
        assert float(s[f"s{int(eta * 100)}.F2"]) == pytest.approx(p, rel=3e-3)
    deflection = p * length**3 / (3 * ei) + p * length / 1e8
    assert float(s["tip.y"]) == pytest.approx(deflection, rel=2e-3)


def test_a_mass_matrix_that_is_not_a_point_mass_with_inertia_is_refused_clearly():
    mass = np.diag([1.0, 1.0, 1.0, 0.02, 0.01, 0.01])
    mass[3, 0] = mass[0, 3] = 0.05  # couples v1 with ω1: no centre of mass does that
    k = np.diag([1e4, 5e3, 5e3, 5.0, 8.0, 5.0])
    m = fd.Model()
    m.beam(
        "blade",
        [0, 0, 0],
        [1, 0, 0],
        elements=2,
        order=1,
        section={"stiffness": k.tolist(), "mass": mass.tolist()},
    )
    with pytest.raises(
        fd.ModelError, match=r"beams\[0\]\.section: beam `blade`: the mass matrix's coupling block"
    ):
        m.validate()


def test_offset_centres_of_mass_conserve_energy_and_momenta_under_ep():
    # Sections whose centre of mass is off the reference line (the mass sits on internal
    # nodes clamped at the offsets): a free beam tumbling in 3-D keeps EP's invariants, and
    # the beam's own kinetic energy (about its nodes, with the first moment) is the model's.
    sec = {**SECTION, "cm_offset": [0.03, -0.02]}
    m = fd.Model("offset")
    m.beam(
        "b",
        [0, 0, 0],
        [2, 0, 0],
        elements=3,
        order=2,
        section=sec,
        velocity=[0.1, 0.2, 0],
        angular_velocity=[1.0, 0.5, 3.0],
    )
    m.sensor("energy", "e").sensor("momentum", "p").sensor("beam_energy", "be", beam="b")
    s = fd.simulate(m, scheme="ep", step_control="fixed", dt=2e-3, t_end=1.0)
    e = s["e.total"].values
    assert np.abs(e - e[0]).max() < 1e-9 * e[0]
    for c in ("px", "py", "pz", "Hx", "Hy", "Hz"):
        v = s[f"p.{c}"].values
        assert np.abs(v - v[0]).max() < 1e-9 * max(1.0, np.abs(v).max())
    np.testing.assert_allclose(s["be.kinetic"], s["e.kinetic"], rtol=1e-10)


def test_ed_keeps_the_rotational_energy_of_a_spinning_stiff_beam():
    # A free stiff beam spinning at 10 rad/s about its centre (released unstretched, so the
    # centrifugal load sets it vibrating axially), 20 revolutions with Ω h = 0.2: ED may
    # remove the vibration (at most the energy it ever had, bounded by the largest strain
    # energy seen, about twice its mean) but must not drag the rotation. Measured: loss
    # 1.33e-4 J = 4e-6 of the 33 J of rotation, max strain energy 1.34e-4 J.
    sec = {
        "ea": 1e7,
        "ga2": 1e7,
        "ga3": 1e7,
        "gj": 1e4,
        "ei2": 1e5,
        "ei3": 1e5,
        "m": 1.0,
        "i22": 1e-4,
        "i33": 1e-4,
    }
    omega = 10.0
    m = fd.Model("spinning beam")
    m.beam(
        "b",
        [-1, 0, 0],
        [1, 0, 0],
        elements=4,
        order=3,
        section=sec,
        velocity=[0, -omega, 0],
        angular_velocity=[0, 0, omega],
    )
    m.sensor("energy", "e").sensor("momentum", "p").sensor("beam_energy", "be", beam="b")
    s = fd.simulate(m, scheme="ed", step_control="fixed", dt=2e-2, t_end=20 * 2 * np.pi / omega)
    e = s["e.total"].values
    loss = e[0] - e[-1]
    assert 0 <= loss <= 1.5 * s["be.strain"].values.max()
    assert loss < 1e-5 * e[0]
    hz = s["p.Hz"].values
    assert np.abs(hz - hz[0]).max() < 1e-9 * hz[0]

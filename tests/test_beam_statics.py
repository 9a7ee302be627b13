"""Beam statics against closed-form solutions: end-moment roll-up (with convergence rates per
element order), tip-loaded and uniformly loaded cantilevers, shear locking, pre-twist
coupling, curved (arc) and polyline beams, follower pressure on a ring, tapered sections,
and full 6×6 section matrices."""

import numpy as np
import pytest

import flexdyn as fd


def section(ea=1e8, ga=1e8, gj=1e4, ei2=1e4, ei3=1e4, m=1.0):
    return {
        "ea": ea,
        "ga2": ga,
        "ga3": ga,
        "gj": gj,
        "ei2": ei2,
        "ei3": ei3,
        "m": m,
        "i22": 1e-4,
        "i33": 1e-4,
    }


def tip_position(order, elements, load_steps=4):
    """Cantilever (L = 1, EI = 1) under the end moment 2πEI/L that rolls it into a circle."""
    m = fd.Model("roll-up")
    sec = section(ea=1e4, ga=1e4, gj=1.0, ei2=1.0, ei3=1.0, m=0.01)
    n = elements * order
    m.beam("b", [0, 0, 0], [1, 0, 0], elements=elements, order=order, section=sec, e2=[0, 1, 0])
    m.clamp("root", "ground", "b.0")
    m.moment("end_moment", f"b.{n}", [0, 0, 2 * np.pi])
    m.sensor("node_position", "tip", node=f"b.{n}")
    m.sensor("node_position", "mid", node=f"b.{n // 2}")
    s = fd.solve_static(m, load_steps=load_steps).isel(load_factor=-1)
    return np.array([float(s[f"tip.{c}"]) for c in "xyz"]), np.array([float(s[f"mid.{c}"]) for c in "xyz"])


@pytest.mark.parametrize("order,rate", [(1, 2), (2, 4), (3, 6)])
def test_end_moment_rolls_a_cantilever_into_a_circle_converging_at_the_nodal_rate(order, rate):
    # The tip returns to the root and mid-span reaches (0, L/π); nodal values of order-p
    # elements with reduced integration converge as h^(2p) (measured rates 2.03, 4.02, 6.02
    # from 8 to 16 elements; with 16 elements the tip misses by 6.8e-4, 7.4e-7, 7.0e-10 and
    # mid-span by 1.9e-3, 2.4e-6, 6.6e-10). Bounds: twice those.
    errors = [np.linalg.norm(tip_position(order, n)[0]) for n in (4, 8, 16)]
    measured = np.log2(errors[1] / errors[2])
    assert measured == pytest.approx(rate, abs=0.2)
    assert errors[2] < [1.4e-3, 1.5e-6, 1.4e-9][order - 1]
    _, mid = tip_position(order, 16)
    assert np.linalg.norm(mid - [0, 1 / np.pi, 0]) < [3.8e-3, 4.8e-6, 1.4e-9][order - 1]


def test_static_results_have_one_sample_per_load_step():
    m = fd.Model()
    m.beam("b", [0, 0, 0], [1, 0, 0], elements=2, order=2, section=section())
    m.clamp("root", "ground", "b.0")
    m.force("p", "b.4", [0, 10, 0])
    m.sensor("node_displacement", "tip", node="b.4").sensor("joint_reaction", "reaction", joint="root")
    s = fd.solve_static(m, load_steps=5)
    assert s.attrs["analysis"] == "static"
    np.testing.assert_allclose(s.load_factor.values, np.linspace(0, 1, 6))
    # Linear range: the deflection and the reaction grow in proportion to the load factor.
    np.testing.assert_allclose(s["tip.y"].values, s.load_factor.values * float(s["tip.y"][-1]), rtol=1e-6)
    # The clamp holds node2 (the beam's root) against the load: −P.
    np.testing.assert_allclose(s["reaction.Fy"].values, -s.load_factor.values * 10.0, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("order,elements", [(1, 8), (2, 4), (3, 3)])
def test_tip_loaded_cantilever_moment_shear_and_deflection(order, elements):
    # Small load (deflection 3e-5 L): M3(s) = P(L − s), F2 = P, tip deflection
    # PL³/(3EI) + PL/GA. Sectional values are recovered at Gauss points and interpolated, so
    # they are exact for the linear moment with quadratic and cubic elements; linear elements
    # hold one Gauss point (a constant per element): checked only at element mid-points.
    length, ei, ga, p = 2.0, 1e4, 1e6, 0.1
    m = fd.Model("cantilever")
    n = elements * order
    m.beam(
        "b", [0, 0, 0], [length, 0, 0], elements=elements, order=order, section=section(ga=ga), e2=[0, 1, 0]
    )
    m.clamp("root", "ground", "b.0")
    m.force("tip_load", f"b.{n}", [0, p, 0])
    etas = [0.5 / elements] if order == 1 else [0.0, 0.3, 0.5, 0.75]
    for k, eta in enumerate(etas):
        m.sensor("beam_section", f"s{k}", beam="b", eta=eta)
    m.sensor("node_displacement", "tip", node=f"b.{n}")
    s = fd.solve_static(m).isel(load_factor=-1)
    for k, eta in enumerate(etas):
        # Geometric nonlinearity is (δ/L)² ~ 1e-9 of the load.
        assert float(s[f"s{k}.M3"]) == pytest.approx(p * length * (1 - eta), rel=1e-7)
        assert float(s[f"s{k}.F2"]) == pytest.approx(p, rel=1e-7)
    exact = p * length**3 / (3 * ei) + p * length / ga
    # Cubic elements are nodally exact for this load; lower orders carry their O(h^2p) error
    # (8 linear elements: h²/(4L²) = 3.9e-3).
    assert float(s["tip.y"]) == pytest.approx(exact, rel=[5e-3, 1e-5, 1e-7][order - 1])


@pytest.mark.parametrize("order,elements", [(1, 16), (2, 4), (3, 2)])
def test_thin_beam_does_not_lock_in_shear(order, elements):
    # GA = 1e6 EI/L²: the Timoshenko answer is Euler–Bernoulli's within 1e-6. Full Gauss
    # integration would lock (deflections ~1e-4 of the right one for linear elements);
    # reduced integration gives the bending answer to the element's own accuracy.
    length, ei = 1.0, 1.0
    m = fd.Model("thin")
    n = elements * order
    m.beam(
        "b",
        [0, 0, 0],
        [length, 0, 0],
        elements=elements,
        order=order,
        section=section(ea=1e6, ga=1e6, gj=1.0, ei2=ei, ei3=ei),
        e2=[0, 1, 0],
    )
    m.clamp("root", "ground", "b.0")
    m.force("p", f"b.{n}", [0, 1e-4, 0])
    m.sensor("node_displacement", "tip", node=f"b.{n}")
    s = fd.solve_static(m).isel(load_factor=-1)
    exact = 1e-4 * length**3 / (3 * ei)
    # Linear elements: O(h²) error in the bending deflection, 1/(4·16²) ≈ 1e-3.
    assert float(s["tip.y"]) == pytest.approx(exact, rel=[2e-3, 1e-4, 1e-5][order - 1])


def test_uniform_load_on_a_cantilever():
    # q per unit length: tip deflection qL⁴/(8EI) (+ qL²/(2GA)), root moment qL²/2.
    length, ei, ga, q = 2.0, 1e4, 1e7, 0.05
    m = fd.Model()
    m.beam("b", [0, 0, 0], [length, 0, 0], elements=4, order=3, section=section(ga=ga), e2=[0, 1, 0])
    m.clamp("root", "ground", "b.0")
    m.distributed_force("q", "b", [0, q, 0])
    m.sensor("node_displacement", "tip", node="b.12").sensor("joint_reaction", "reaction", joint="root")
    s = fd.solve_static(m).isel(load_factor=-1)
    assert float(s["tip.y"]) == pytest.approx(q * length**4 / (8 * ei) + q * length**2 / (2 * ga), rel=1e-6)
    assert float(s["reaction.Fy"]) == pytest.approx(-q * length, rel=1e-9)
    assert abs(float(s["reaction.Mz"])) == pytest.approx(q * length**2 / 2, rel=1e-6)


def pretwist_reference(length, theta_l, ei2, ei3, p):
    """Small-deflection tip displacement of a cantilever along x whose section turns by
    θ(s) = θ_L s/L, under a tip force P along y: the moment M = P(L − s) about z splits into
    section components M₂ = M e₂·z, M₃ = M e₃·z; the curvatures κ = M₂/EI₂ e₂ + M₃/EI₃ e₃ give
    the displacement u(L) = ∫ (L − s) κ(s) × e₁ ds (Gauss–Legendre quadrature)."""
    x, w = np.polynomial.legendre.leggauss(40)
    s = 0.5 * length * (x + 1)
    w = 0.5 * length * w
    th = theta_l * s / length
    e2 = np.stack([0 * th, np.cos(th), np.sin(th)], axis=1)
    e3 = np.stack([0 * th, -np.sin(th), np.cos(th)], axis=1)
    mz = p * (length - s)
    kappa = (mz * e2[:, 2] / ei2)[:, None] * e2 + (mz * e3[:, 2] / ei3)[:, None] * e3
    slope = np.cross(kappa, [1.0, 0.0, 0.0])
    return ((length - s)[:, None] * slope * w[:, None]).sum(axis=0)


@pytest.mark.parametrize("twist", ["rate", "table"])
def test_pretwisted_cantilever_couples_the_bending_directions(twist):
    # EI₃ = 4 EI₂ and a quarter turn of pre-twist: a tip load along y also deflects the tip
    # along z. Reference: the rotated-section small-deflection solution (quadrature).
    length, theta_l, ei2, ei3, p = 2.0, np.pi / 2, 1e4, 4e4, 1.0
    m = fd.Model("pre-twisted")
    kw = (
        {"twist_rate": theta_l / length}
        if twist == "rate"
        else {"twist": {"eta": [0.0, 0.5, 1.0], "angle": [0.0, theta_l / 2, theta_l]}}
    )
    m.beam(
        "b",
        [0, 0, 0],
        [length, 0, 0],
        elements=16,
        order=3,
        section=section(ei2=ei2, ei3=ei3, ga=1e10, ea=1e10),
        e2=[0, 1, 0],
        **kw,
    )
    m.clamp("root", "ground", "b.0")
    m.force("p", "b.48", [0, p, 0])
    m.sensor("node_displacement", "tip", node="b.48")
    s = fd.solve_static(m).isel(load_factor=-1)
    ref = pretwist_reference(length, theta_l, ei2, ei3, p)
    tip = np.array([float(s[f"tip.{c}"]) for c in "xyz"])
    assert abs(ref[2]) > 0.3 * abs(ref[1])  # the coupling is large
    # Geometric nonlinearity (δ/L ~ 1e-4) and the mesh: agreement to 1e-4 of |u|.
    np.testing.assert_allclose(tip[1:], ref[1:], atol=1e-4 * np.linalg.norm(ref))


def test_quarter_circle_cantilever_under_an_out_of_plane_tip_load():
    # Castigliano: δ = P R³ [π/(4EI) + (3π/4 − 2)/GJ] (bending and torsion; axial and shear
    # made rigid).
    r, ei, gj, p = 1.0, 100.0, 50.0, 1e-3
    m = fd.Model("arc")
    m.beam(
        "b",
        [r, 0, 0],
        elements=8,
        order=3,
        arc={"center": [0, 0, 0], "axis": [0, 0, 1], "angle": np.pi / 2},
        section=section(ea=1e9, ga=1e9, gj=gj, ei2=ei, ei3=ei),
    )
    m.clamp("root", "ground", "b.0")
    m.force("p", "b.24", [0, 0, p])
    m.sensor("node_position", "tip", node="b.24")
    s = fd.solve_static(m).isel(load_factor=-1)
    assert float(s["tip.x"]) == pytest.approx(0.0, abs=1e-5)
    assert float(s["tip.y"]) == pytest.approx(r, rel=1e-5)
    exact = p * r**3 * (np.pi / (4 * ei) + (3 * np.pi / 4 - 2) / gj)
    # Small-deflection theory (δ/R ~ 1e-5) and the mesh: 1e-5 relative.
    assert float(s["tip.z"]) == pytest.approx(exact, rel=1e-5)


def test_l_shaped_polyline_frame_under_an_out_of_plane_tip_load():
    # Segments a (along x) and b (along y): δ = P a³/(3EI) + P b³/(3EI) + P b² a/GJ.
    a, b, ei, gj, p = 1.0, 0.6, 100.0, 40.0, 1e-3
    m = fd.Model("frame")
    m.beam(
        "b",
        [0, 0, 0],
        [a, b, 0],
        via=[[a, 0, 0]],
        elements=4,
        order=3,
        section=section(ea=1e9, ga=1e9, gj=gj, ei2=ei, ei3=ei),
    )
    m.clamp("root", "ground", "b.0")
    m.force("p", "b.12", [0, 0, p])
    m.sensor("node_displacement", "tip", node="b.12")
    s = fd.solve_static(m).isel(load_factor=-1)
    exact = p * a**3 / (3 * ei) + p * b**3 / (3 * ei) + p * b**2 * a / gj
    assert float(s["tip.z"]) == pytest.approx(exact, rel=1e-5)


def test_follower_pressure_on_a_ring_gives_a_uniform_hoop_force():
    # A full ring (an arc of 2π closing on its own start node) under an outward pressure q
    # per unit reference length that follows the sections: hoop force N = q R everywhere (the
    # load per deformed length q/(1+e) times the deformed radius R(1+e)), no bending, and the
    # diameter grows by the hoop strain N/EA. The default section axis 2 of an arc points to
    # the centre, so the outward pressure is −q along axis 2. One node is clamped to fix the
    # rigid-body motion; the self-equilibrated load leaves it without reaction.
    r, ea, q = 1.0, 1e4, 5.0
    m = fd.Model("ring")
    m.node("n0", [r, 0, 0])
    m.beam(
        "ring",
        start_node="n0",
        end_node="n0",
        elements=16,
        order=3,
        arc={"center": [0, 0, 0], "axis": [0, 0, 1], "angle": 2 * np.pi},
        section=section(ea=ea, ga=ea, gj=10.0, ei2=10.0, ei3=10.0),
    )
    m.clamp("fix", "ground", "n0")
    m.distributed_force("pressure", "ring", [0, -q, 0], follower=True)
    etas = np.linspace(0.01, 0.99, 9)
    for k, eta in enumerate(etas):
        m.sensor("beam_section", f"s{k}", beam="ring", eta=eta)
    m.sensor("node_position", "opposite", node="ring.24").sensor(
        "joint_reaction", "clamp_reaction", joint="fix"
    )
    s = fd.solve_static(m, load_steps=2).isel(load_factor=-1)
    hoop = q * r
    # Measured with 16 cubic elements: hoop force within 2.5e-5, diameter strain within 1e-7.
    assert -float(s["opposite.x"]) - r == pytest.approx(2 * r * hoop / ea, rel=1e-4)
    for k in range(len(etas)):
        assert float(s[f"s{k}.F1"]) == pytest.approx(hoop, rel=1e-4)
        assert abs(float(s[f"s{k}.M3"])) < 1e-4 * hoop * r
    assert max(abs(float(s[f"clamp_reaction.F{c}"])) for c in "xyz") < 1e-6 * hoop


def test_tapered_cantilever_interpolates_its_sections():
    # EI(η) linear from EI₀ to EI₀/2: δ = P ∫ (L − s)²/EI(s) ds.
    length, ei0, p = 2.0, 1e4, 0.1
    m = fd.Model("tapered")
    m.beam(
        "b",
        [0, 0, 0],
        [length, 0, 0],
        elements=8,
        order=3,
        e2=[0, 1, 0],
        sections=[
            {"eta": 0.0, "section": section(ei2=ei0, ei3=ei0, ga=1e12)},
            {"eta": 1.0, "section": section(ei2=ei0 / 2, ei3=ei0 / 2, ga=1e12)},
        ],
    )
    m.clamp("root", "ground", "b.0")
    m.force("p", "b.24", [0, p, 0])
    m.sensor("node_displacement", "tip", node="b.24")
    s = fd.solve_static(m).isel(load_factor=-1)
    x, w = np.polynomial.legendre.leggauss(30)
    sv = 0.5 * length * (x + 1)
    ei = ei0 * (1 - 0.5 * sv / length)
    exact = p * np.sum(0.5 * length * w * (length - sv) ** 2 / ei)
    assert float(s["tip.y"]) == pytest.approx(exact, rel=1e-5)


def test_full_section_matrices_match_the_shorthand():
    short = section(ea=2e6, ga=1e6, gj=300.0, ei2=500.0, ei3=800.0)
    k = np.diag([2e6, 1e6, 1e6, 300.0, 500.0, 800.0]).tolist()
    mass = np.diag([1.0, 1.0, 1.0, 2e-4, 1e-4, 1e-4]).tolist()
    tips = []
    for sec in (short, {"stiffness": k, "mass": mass}):
        m = fd.Model()
        m.beam("b", [0, 0, 0], [1, 0, 0], elements=2, order=3, section=sec)
        m.clamp("root", "ground", "b.0")
        m.force("p", "b.6", [0, 3.0, 2.0])
        m.moment("t", "b.6", [1.0, 0, 0])
        m.sensor("node_position", "tip", node="b.6")
        s = fd.solve_static(m).isel(load_factor=-1)
        tips.append([float(s[f"tip.{c}"]) for c in "xyz"])
    np.testing.assert_allclose(tips[0], tips[1], rtol=1e-12, atol=1e-14)


def test_statics_of_an_unrestrained_beam_is_a_clear_error():
    m = fd.Model()
    m.beam("b", [0, 0, 0], [1, 0, 0], elements=2, order=1, section=section())
    m.force("p", "b.2", [0, 1.0, 0])
    # No equilibrium exists: Newton (regularized) runs off, load halvings cannot help.
    with pytest.raises(fd.SolverError, match="lacks a restraint against a rigid-body motion") as e:
        fd.solve_static(m)
    assert e.value.results.sizes["load_factor"] == 1  # the unloaded state is kept


def test_section_rotation_and_beam_energy_sensors():
    # Tip moment M₃ and torque T: bending rotation φ₃(s) = M s/EI, twist φ₁(s) = T s/GJ,
    # strain energy U = (M²/EI + T²/GJ) L/2. Small loads (rotations ~1e-4 rad): linear theory
    # holds to ~1e-8.
    length, ei, gj, moment, torque = 2.0, 1e4, 5e3, 0.5, 0.3
    m = fd.Model()
    m.beam(
        "b",
        [0, 0, 0],
        [length, 0, 0],
        elements=4,
        order=3,
        section=section(ei2=ei, ei3=ei, gj=gj),
        e2=[0, 1, 0],
    )
    m.clamp("root", "ground", "b.0")
    m.moment("m", "b.12", [torque, 0, moment])
    for k, eta in enumerate([0.3, 0.8, 1.0]):
        m.sensor("beam_section", f"s{k}", beam="b", eta=eta)
    m.sensor("beam_energy", "energy", beam="b").sensor("node_displacement", "tip", node="b.12")
    s = fd.solve_static(m).isel(load_factor=-1)
    # The station at the tip moves with the tip node; with the section frame along the
    # inertial axes, the inertial rotation vector is (φ₁, φ₂, φ₃).
    for c in "xyz":
        assert float(s[f"s2.u{c}"]) == pytest.approx(float(s[f"tip.{c}"]), abs=1e-15)
    for c, k in zip("xyz", "123"):
        assert float(s[f"s2.r{c}"]) == pytest.approx(float(s[f"s2.phi{k}"]), abs=1e-15)
    for k, eta in enumerate([0.3, 0.8, 1.0]):
        assert float(s[f"s{k}.phi3"]) == pytest.approx(moment * eta * length / ei, rel=1e-6)
        assert float(s[f"s{k}.phi1"]) == pytest.approx(torque * eta * length / gj, rel=1e-6)
        # Only the second-order coupling φ₁φ₃/2 (~5e-10 here) shows about axis 2.
        assert abs(float(s[f"s{k}.phi2"])) < float(s[f"s{k}.phi1"]) * float(s[f"s{k}.phi3"])
    assert s["s0.phi1"].attrs["units"] == "rad"
    strain = (moment**2 / ei + torque**2 / gj) * length / 2
    assert float(s["energy.strain"]) == pytest.approx(strain, rel=1e-6)
    assert float(s["energy.kinetic"]) == 0.0


def test_beam_energies_add_up_to_the_system_energies():
    # Two beams sharing a node, tumbling freely: their kinetic and strain energies add up to
    # the model's (each shared node's inertia is split between the beams that lump to it).
    m = fd.Model()
    sec = section(ea=1e4, ga=5e3, gj=5.0, ei2=8.0, ei3=5.0)
    m.node("joint", [1, 0, 0])
    m.beam(
        "a", [0, 0, 0], end_node="joint", elements=2, order=2, section=sec, angular_velocity=[0.3, 2.0, 1.0]
    )
    m.beam(
        "b",
        start_node="joint",
        end=[1, 1, 0],
        elements=2,
        order=2,
        section=sec,
        angular_velocity=[0, 0, -3.0],
    )
    m.sensor("beam_energy", "ea", beam="a").sensor("beam_energy", "eb", beam="b").sensor("energy", "e")
    s = fd.simulate(m, scheme="ep", step_control="fixed", dt=1e-3, t_end=0.05)
    assert float(s["e.potential"][-1]) > 1e-6  # the beams are strained by the motion
    np.testing.assert_allclose(s["ea.kinetic"] + s["eb.kinetic"], s["e.kinetic"], rtol=1e-12)
    np.testing.assert_allclose(s["ea.strain"] + s["eb.strain"], s["e.potential"], rtol=1e-12, atol=1e-15)


def test_offset_centre_of_mass_twists_a_cantilever_under_gravity():
    # Centre of mass at x₂ = d from the reference line: the weight m g per unit length acts
    # there, a torque −m g d per unit length about the axis: tip twist −m g d L²/(2GJ), and the
    # bending deflection m g L⁴/(8EI) (+ m g L²/(2GA)).
    length, g, mass, d, gj, ei, ga = 2.0, 9.81, 3.0, 0.05, 2e3, 1e5, 1e8
    sec = {**section(gj=gj, ei2=ei, ei3=ei, ga=ga, m=mass), "cm_offset": [d, 0.0]}
    m = fd.Model("offset", gravity=[0, 0, -g])
    m.beam("b", [0, 0, 0], [length, 0, 0], elements=4, order=3, section=sec, e2=[0, 1, 0])
    m.clamp("root", "ground", "b.0")
    m.sensor("beam_section", "tip", beam="b", eta=1.0).sensor("node_displacement", "tip_u", node="b.12")
    s = fd.solve_static(m).isel(load_factor=-1)
    q = mass * g
    assert float(s["tip.phi1"]) == pytest.approx(-q * d * length**2 / (2 * gj), rel=1e-5)
    assert float(s["tip_u.z"]) == pytest.approx(
        -(q * length**4 / (8 * ei) + q * length**2 / (2 * ga)), rel=1e-4
    )


def test_statics_with_a_free_contact_point_names_it_and_the_ways_out():
    # A 0.5 kg collar on a steel tube clamped at one end and pinned at the other, gravity
    # across: its contact point η is free, and nothing restrains it while the tube is still
    # straight (the first load step's matrix is singular along η). Before, the error named a
    # beam node's force and nothing else; now it names the joint and the two ways out, and a
    # spring along the beam (one of them) lets the same statics converge.
    def collar_on_tube(spring=None):
        m = fd.Model("collar on a tube", gravity=[0, 0, -9.81])
        steel = {"E": 2.1e11, "G": 8.1e10, "density": 7850}
        tube = {"material": steel, "shape": {"tube": {"diameter": 0.03, "wall": 0.003}}}
        m.beam("tube", [0, 0, 0], [1.0, 0, 0], elements=8, section=tube)
        m.clamp("root", "ground", "tube.start")
        m.spherical("bearing", "ground", "tube.end")
        m.node("c", [0.3, 0, 0]).body("collar", "c", mass=0.5, inertia=[2e-4, 1e-4, 1e-4])
        m.sliding("ring", beam="tube", follower="c", eta=0.3, spring=spring)
        return m

    with pytest.raises(fd.SolverError) as e:
        fd.solve_static(collar_on_tube())
    message = str(e.value)
    assert "`ring`" in message and "`drive`" in message and "`spring`" in message
    held = fd.solve_static(collar_on_tube(spring={"stiffness": 100.0, "rest": 0.3}))
    assert held.sizes["load_factor"] >= 2  # the unloaded state and the converged load

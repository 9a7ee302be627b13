"""Sections from a material and a shape (issue 19), in Python and in the model file: the
stiffnesses are computed, not typed by hand, and a steel tube cantilever rings at the
Euler–Bernoulli frequency its dimensions give."""

import numpy as np
import pytest

import flexdyn as fd

STEEL = {"E": 2.1e11, "G": 8.1e10, "density": 7850.0}
D, WALL, L = 0.05, 0.003, 2.0


def cantilever(section):
    m = fd.Model("tube cantilever")
    m.beam("tube", [0, 0, 0], [L, 0, 0], elements=10, section=section)
    m.clamp("root", "ground", "tube.start")
    m.simulation(analysis="static")
    return m


def test_a_tube_from_material_and_shape_rings_at_the_euler_bernoulli_frequency():
    md = fd.modes(
        cantilever({"material": STEEL, "shape": {"tube": {"diameter": D, "wall": WALL}}}), 1, preload=False
    )
    di = D - 2 * WALL
    ei = STEEL["E"] * np.pi * (D**4 - di**4) / 64
    m = STEEL["density"] * np.pi * (D**2 - di**2) / 4
    f1 = 1.875104**2 / (2 * np.pi) * np.sqrt(ei / (m * L**4))
    # Slender (L/D = 40): shear and rotary inertia lower it by ~0.1 %; 10 cubic elements
    # converge it to 1e-6.
    assert float(md.frequency[0]) == pytest.approx(f1, rel=3e-3)


def test_material_and_shape_in_a_model_file(tmp_path):
    text = f"""
name: file tube
beams:
  - name: tube
    start: [0, 0, 0]
    end: [{L}, 0, 0]
    elements: 10
    section:
      material: {{E: 2.1e+11, G: 8.1e+10, density: 7850}}
      shape: {{tube: {{diameter: {D}, wall: {WALL}}}}}
joints:
  - {{type: clamp, name: root, node1: ground, node2: tube.start}}
simulation: {{analysis: static}}
"""
    path = tmp_path / "tube.yaml"
    path.write_text(text)
    from_file = fd.modes(fd.load(path), 3, preload=False).frequency.values
    built = fd.modes(
        cantilever({"material": STEEL, "shape": {"tube": {"diameter": D, "wall": WALL}}}), 3, preload=False
    )
    np.testing.assert_allclose(from_file, built.frequency.values, rtol=1e-12)


def test_poissons_ratio_gives_the_shear_modulus():
    # ν = 0.3: G = E / 2(1 + ν) = 80.77 GPa; the section's stiffnesses equal those built
    # from that G (the same arithmetic: to round-off).
    shape = {"tube": {"diameter": D, "wall": WALL}}
    with_nu = {"material": {"E": 2.1e11, "nu": 0.3, "density": 7850.0}, "shape": shape}
    with_g = {"material": {"E": 2.1e11, "G": 2.1e11 / 2.6, "density": 7850.0}, "shape": shape}
    a = fd.modes(cantilever(with_nu), 6, preload=False).frequency.values
    b = fd.modes(cantilever(with_g), 6, preload=False).frequency.values
    np.testing.assert_allclose(a, b, rtol=1e-12)
    # … and G matters: the torsion mode moves with it (GJ), so the test would see a wrong G.
    c = fd.modes(cantilever({**with_g, "material": {**with_g["material"], "G": 7e10}}), 6, preload=False)
    assert np.max(np.abs(c.frequency.values / b - 1)) > 1e-3


@pytest.mark.parametrize(
    "section, message",
    [
        (
            {"material": STEEL, "shape": {"tube": {"diameter": 0.01, "wall": 0.006}}},
            r"wall .* must be thinner than the radius",
        ),
        (
            {"material": {**STEEL, "E": -1.0}, "shape": {"circle": {"diameter": 0.01}}},
            r"E, G \(Pa\) and density",
        ),
        ({"material": STEEL, "shape": {"hexagon": {"size": 0.01}}}, r"unknown variant `hexagon`"),
        ({"material": STEEL, "shape": {"rectangle": {"width": 0.01, "height": 0.0}}}, r"finite and > 0"),
        (
            {"material": {**STEEL, "nu": 0.3}, "shape": {"circle": {"diameter": 0.01}}},
            r"beams\[0\]\.section: beam `tube`: material: give `G` or `nu`, not both",
        ),
        (
            {"material": {"E": 2.1e11, "density": 7850.0}, "shape": {"circle": {"diameter": 0.01}}},
            r"give the shear modulus `G` \(Pa\) or Poisson's ratio `nu`",
        ),
        (
            {
                "material": {"E": 2.1e11, "nu": 0.7, "density": 7850.0},
                "shape": {"circle": {"diameter": 0.01}},
            },
            r"Poisson's ratio nu must lie in \(-1, 0.5\] \(got 0.7\)",
        ),
    ],
)
def test_bad_materials_and_shapes_are_named(section, message):
    with pytest.raises(fd.ModelError, match=message):
        cantilever(section).validate()

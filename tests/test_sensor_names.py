"""One naming scheme for channels (issue 19): displacements `ux uy uz` and rotations `rx ry rz`
for nodes as for beam sections, the reaction frames' axes as docs/sensors.md documents them for
each joint, `<beam>.start` / `<beam>.end`, and errors that know a beam's nodes."""

import numpy as np
import pytest

import flexdyn as fd

ROD = {
    "ea": 1e6,
    "ga2": 1e5,
    "ga3": 1e5,
    "gj": 10.0,
    "ei2": 10.0,
    "ei3": 10.0,
    "m": 1.0,
    "i22": 1e-3,
    "i33": 1e-3,
}


def cantilever(tip="rod.end", root="rod.start"):
    m = fd.Model("names")
    m.beam("rod", [0, 0, 0], [1, 0, 0], elements=2, section=ROD)
    m.clamp("root", "ground", root)
    m.force("push", node=tip, value=[0, 0, -1])
    m.sensor("node_displacement", "tip", node=tip).sensor("node_rotation", "turn", node=tip)
    m.sensor("beam_section", "end_section", beam="rod", eta=1.0)
    m.simulation(analysis="static")
    return m


def test_beam_end_aliases_name_the_end_nodes():
    by_alias = fd.simulate(cantilever())
    by_number = fd.simulate(cantilever(tip="rod.6", root="rod.0"))
    for ch in ("tip.uz", "turn.ry"):
        assert by_alias[ch].values[-1] == by_number[ch].values[-1] != 0
    # EI = 10 N·m², 1 m, 1 N: the tip deflects 1/30 m (plus shear, 1e-5).
    assert by_alias["tip.uz"].values[-1] == pytest.approx(-1 / 30, rel=1e-3)


def test_node_channels_use_the_beam_section_names_and_keep_the_old_ones_for_now():
    res = fd.simulate(cantilever())
    for comp in ("x", "y", "z"):
        np.testing.assert_array_equal(res[f"tip.u{comp}"], res[f"end_section.u{comp}"])
        np.testing.assert_array_equal(res[f"tip.u{comp}"], res[f"tip.{comp}"])  # former name
        np.testing.assert_allclose(res[f"turn.r{comp}"], res[f"end_section.r{comp}"], atol=1e-14)
        np.testing.assert_array_equal(res[f"turn.r{comp}"], res[f"turn.{comp}"])


@pytest.mark.parametrize(
    "bad, message",
    [
        (
            "rod.7",
            r"refers to node `rod.7`, which beam `rod` does not have: its nodes are `rod.0` … `rod.6` \(`rod.start`, `rod.end`\)",
        ),
        ("rod.tip", r"which beam `rod` does not have"),
        ("rods.1", r"refers to node `rods.1`, which is not defined in `nodes` nor a beam's node"),
    ],
)
def test_a_wrong_beam_node_says_which_nodes_the_beam_has(bad, message):
    with pytest.raises(fd.ModelError, match=message):
        cantilever(tip=bad).validate()


PUSH = np.array([1.0, 2.0, 3.0])


def reaction_in_joint_frame(kind, axis):
    """A body on a joint to ground pushed by PUSH (static): the joint (with its spring along
    the axis) holds it with −PUSH, read in the inertial and the joint frame."""
    m = fd.Model("frames")
    m.node("b", [0, 0, 0]).body("mass", "b", mass=1.0, inertia=[1, 1, 1])
    getattr(m, kind)("j", "ground", "b", position=[0, 0, 0], axis=axis, spring={"stiffness": 1.0})
    m.force("push", node="b", value=PUSH.tolist())
    m.sensor("joint_reaction", "r", joint="j")
    m.simulation(analysis="static")
    res = fd.simulate(m).isel(load_factor=-1)
    inertial = np.array([res[f"r.F{c}"].values for c in "xyz"])
    local = np.array([res[f"r.F{c}"].values for c in "123"])
    return inertial, local


@pytest.mark.parametrize(
    "axis, frame",
    [
        ([1, 0, 0], [[0, 1, 0], [0, 0, 1], [1, 0, 0]]),  # along +x: +y, +z, +x
        ([0, 1, 0], [[-1, 0, 0], [0, 0, 1], [0, 1, 0]]),  # along +y: −x, +z, +y
        ([0, 0, 1], [[1, 0, 0], [0, 1, 0], [0, 0, 1]]),  # steep: x̂ projected, +y, +z
        ([np.cos(2.1), np.sin(2.1), 0], None),  # patterned about z: axis 2 stays up
    ],
)
def test_prismatic_reaction_axes_are_the_documented_ones(axis, frame):
    inertial, local = reaction_in_joint_frame("prismatic", axis)
    a = np.array(axis) / np.linalg.norm(axis)
    if frame is None:
        e1 = np.cross([0, 0, 1], a)
        frame = [e1 / np.linalg.norm(e1), [0, 0, 1], a]
    frame = np.array(frame, dtype=float)
    # Constraint forces and the joint's spring together hold the body.
    np.testing.assert_allclose(inertial, -PUSH, atol=1e-9)
    np.testing.assert_allclose(local, frame @ inertial, atol=1e-9)

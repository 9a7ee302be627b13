"""Bad input gets a one-line error naming the offending item (issue 2)."""

import json
import subprocess
import sys

import pytest

import flexdyn as fd

BASE = """
gravity: [0, 0, -9.81]
nodes:
  - {name: a, position: [0, 0, 0]}
  - {name: b, position: [1, 0, 0]}
bodies:
  - {name: body_a, node: a, mass: 1.0, inertia: [1, 1, 1]}
  - {name: body_b, node: b, mass: 1.0, inertia: [1, 1, 1]}
joints:
  - {type: revolute, name: pin, node1: ground, node2: a, axis: [0, 0, 1]}
  - {type: spherical, name: ball, node1: a, node2: b}
"""


def load_text(tmp_path, text):
    p = tmp_path / "model.yaml"
    p.write_text(text)
    return fd.load(p)


CASES = [
    # (replace this, with that, expected fragments of the message)
    ("type: spherical", "type: hinge", ["joints[1]", "unknown variant `hinge`"]),
    ("node2: b}", "node2: c}", ["joints[1].node2", "node `c`"]),
    (
        "mass: 1.0, inertia: [1, 1, 1]}\n  - {name: body_b",
        "mass: -2.0, inertia: [1, 1, 1]}\n  - {name: body_b",
        ["bodies[0].mass", "body_a", "positive"],
    ),
    (
        "inertia: [1, 1, 1]}\n  - {name: body_b",
        "inertia: [1, -1, 1]}\n  - {name: body_b",
        ["bodies[0].inertia", "body_a", "positive definite"],
    ),
    ("name: ball", "name: pin", ["joints[1].name", "duplicate name `pin`"]),
    ("node: b, mass", "node: nowhere, mass", ["bodies[1].node", "node `nowhere`"]),
    (
        "axis: [0, 0, 1]}",
        "axis: [0, 0, 1], drive: 'sin(t'}",
        ["joints[0].drive", "expected `)` but the expression ended"],
    ),
    ("axis: [0, 0, 1]}", "axis: [0, 0, 1], drive: 'os.system(t)'}", ["joints[0].drive"]),
    ("axis: [0, 0, 1]}", "axis: [0, 0, 2]}", ["joints[0].axis", "must be a unit vector"]),
    ("axis: [0, 0, 1]}", "axsi: [0, 0, 1]}", ["joints[0]", "axsi", "did you mean `axis`?"]),
    ("type: spherical", "type: spherica", ["joints[1].type", "did you mean `spherical`?"]),
    ("name: a, position", "name: ground, position", ["nodes[0].name", "reserved"]),
]


@pytest.mark.parametrize("old,new,fragments", CASES, ids=[c[1][:30] for c in CASES])
def test_bad_input_names_the_item(tmp_path, old, new, fragments):
    assert old in BASE
    with pytest.raises(fd.ModelError) as e:
        load_text(tmp_path, BASE.replace(old, new, 1))
    msg = str(e.value)
    for f in fragments:
        assert f in msg, msg
    # One line per problem (the file name prefixes the first).
    assert all(line.strip() for line in msg.splitlines())


def test_the_base_model_is_valid(tmp_path):
    m = load_text(tmp_path, BASE)
    assert len(m.data["joints"]) == 2


def test_all_problems_are_reported_at_once(tmp_path):
    text = BASE.replace("mass: 1.0", "mass: 0.0", 1).replace("node2: b}", "node2: c}")
    with pytest.raises(fd.ModelError) as e:
        load_text(tmp_path, text)
    assert len(str(e.value).splitlines()) == 2


def test_builder_errors_match_yaml_errors():
    m = fd.Model()
    m.node("a", [0, 0, 0]).body("body", "a", mass=1.0, inertia=[[1, 2, 0], [2, 1, 0], [0, 0, 1]])
    with pytest.raises(
        fd.ModelError, match=r"bodies\[0\]\.inertia: body `body`: inertia must be positive definite"
    ):
        m.validate()


def test_builder_errors_inside_a_section_name_their_path_and_no_text_position():
    # A model built in Python reaches the core as JSON text: an error there named the
    # section only ("beams[0].section: unknown field …") and ended "at line 1 column 310",
    # a position in text the user never saw.
    m = fd.Model()
    steel = {"E": 2.1e11, "G": 8.1e10, "density": 7850}
    shape = {"tube": {"outer_diameter": 0.03, "wall": 0.003}}
    m.beam("shaft", [0, 0, 0], [1, 0, 0], elements=2, section={"material": steel, "shape": shape})
    with pytest.raises(fd.ModelError) as e:
        m.validate()
    assert "beams[0].section: shape.tube.outer_diameter: unknown field" in str(e.value)
    assert " at line " not in str(e.value)


def test_builder_keyword_typos_name_the_keyword_meant():
    """A misspelt keyword gets the accepted one it was likely meant as, like a model file's
    misspelt key; a keyword like none gets no guess; items in a pattern alike."""
    m = fd.Model().node("a", [0, 0, 0])
    with pytest.raises(TypeError, match=r"Model\.revolute\(\) .* 'axsi'; did you mean 'axis'\?"):
        m.revolute("pin", "ground", "a", axsi=[0, 0, 1])
    with pytest.raises(TypeError, match=r"'t_edn'; did you mean 't_end'\?"):
        m.simulation(t_edn=1.0)
    with pytest.raises(TypeError) as unlike:
        m.beam("b", start=[0, 0, 0], end=[1, 0, 0], colour="red")
    assert "'colour'" in str(unlike.value) and "did you mean" not in str(unlike.value)
    p = m.pattern("blades", count=3, axis=[0, 0, 1])
    with pytest.raises(TypeError, match=r"'positon'; did you mean 'position'\?"):
        p.node("tip", positon=[1, 0, 0])
    # Spelt right, the call goes through unchanged.
    m.revolute("pin", "ground", "a", axis=[0, 0, 1])
    assert m.to_dict()["joints"][0]["axis"] == [0, 0, 1]


def test_builder_and_yaml_give_the_same_model(tmp_path):
    m = load_text(tmp_path, BASE)
    text = m.to_yaml(tmp_path / "again.yaml")
    again = fd.load(tmp_path / "again.yaml")
    assert again.to_dict() == m.to_dict()
    assert "revolute" in text


def test_schema_is_generated_from_the_types():
    schema = json.loads(fd.schema())
    joint_kinds = json.dumps(schema["$defs"]["Joint"])
    for kind in ["spherical", "revolute", "universal", "clamp"]:
        assert kind in joint_kinds
    out = subprocess.run(
        [sys.executable, "-m", "flexdyn.cli", "schema"], capture_output=True, text=True, check=True
    )
    assert json.loads(out.stdout) == schema


def test_cli_validate_reports_errors(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text(BASE.replace("axis: [0, 0, 1]", "axis: [0, 0, 3]"))
    out = subprocess.run(
        [sys.executable, "-m", "flexdyn.cli", "validate", str(p)], capture_output=True, text=True, check=False
    )
    assert out.returncode == 2
    assert "joints[0].axis: must be a unit vector" in out.stderr


def test_unconnected_massless_node_is_a_model_error():
    m = fd.Model("loose")
    m.node("a", [0, 0, 0]).node("b", [1, 0, 0]).body("body", "a", 1.0, [1, 1, 1])
    with pytest.raises(fd.ModelError, match=r"nodes\[1\]: node `b` carries no body and no joint connects it"):
        fd.simulate(m, t_end=0.01, step_control="fixed", dt=1e-3)


def test_undetermined_motion_stops_at_once_naming_the_node():
    # A massless node on a spherical joint: its rotation is free and weightless.
    m = fd.Model("floppy", gravity=[0, 0, -9.81])
    m.node("a", [0, 0, 0]).node("b", [1, 0, 0]).body("body", "a", 1.0, [1, 1, 1])
    m.spherical("s", "a", "b")
    with pytest.raises(fd.SolverError, match=r"singular Newton matrix at node `b`") as e:
        fd.simulate(m, t_end=0.01, step_control="fixed", dt=1e-3)
    # Not a step-size problem: no halving was attempted.
    assert e.value.results.attrs["stats_halvings"] == 0

"""The Python builder cannot drift from the file format: each item method is named by the
item's `type:` or its list's singular and takes exactly that item's YAML keys (read from the
JSON Schema the Rust types generate), and the old spellings still work with a warning."""

import inspect
import json
import warnings

import pytest

import flexdyn as fd
from flexdyn import _core

SCHEMA = json.loads(_core.schema())
DEFS = SCHEMA["$defs"]

#: Keys given flat in Python that sit one level down in the file (node → orientation).
FLATTENED = {"node": {"orientation": {"rotation_vector", "matrix"}}}

#: The list keys whose items are built by one method, named by the list's singular.
SINGULAR = {"nodes": ("node", "Node"), "bodies": ("body", "RigidBody"), "beams": ("beam", "Beam")}
SINGULAR["initial_spins"] = ("initial_spin", "InitialSpin")


def keys(definition) -> set[str]:
    return set(definition["properties"]) - {"type"}


def parameters(method) -> set[str]:
    return set(inspect.signature(method).parameters) - {"self"}


def yaml_keys(method_name, definition) -> set[str]:
    out = keys(definition)
    for key, flat in FLATTENED.get(method_name, {}).items():
        out = (out - {key}) | flat
    return out


def typed_variants(group):
    return [(v["properties"]["type"]["const"], v) for v in DEFS[group]["oneOf"]]


@pytest.mark.parametrize("group", ["Joint", "Load"])
def test_every_joint_and_load_type_has_a_method_taking_its_keys(group):
    for type_, variant in typed_variants(group):
        method = getattr(fd.Model, type_, None)
        assert method is not None, f"no Model.{type_} for `type: {type_}`"
        assert parameters(method) == keys(variant), type_


def test_every_item_list_has_its_method():
    lists = {k for k, v in SCHEMA["properties"].items() if v.get("type") == "array" and k != "gravity"}
    assert lists == set(SINGULAR) | {"joints", "loads", "sensors", "patterns"}
    for name, definition in SINGULAR.values():
        method = getattr(fd.Model, name)
        assert parameters(method) == yaml_keys(name, DEFS[definition]), name
    # A pattern's own keys are the method's; its items are added to the pattern it returns.
    own = {
        k
        for k, v in DEFS["Pattern"]["properties"].items()
        if v.get("type") != "array" or k in ("axis", "center")
    }
    assert parameters(fd.Model.pattern) == own
    assert keys(DEFS["Pattern"]) - own == lists - {"patterns"}


def test_simulation_takes_every_setting_and_only_those():
    assert parameters(fd.Model.simulation) == keys(DEFS["SimulationSettings"])


def test_sensor_names_every_sensor_type():
    doc = fd.Model.sensor.__doc__
    missing = [t for t, _ in typed_variants("Sensor") if t not in doc]
    assert not missing, f"Model.sensor's docstring does not name {missing}"


def built(new: bool) -> dict:
    m = fd.Model("m", gravity=[0, 0, -9.81])
    m.node("a", [0, 0, 0]).node("b", [0, 0, -1])
    m.beam(
        "rail",
        [1, 0, 0],
        [3, 0, 0],
        elements=2,
        section={
            "ea": 1e6,
            "ga2": 1e5,
            "ga3": 1e5,
            "gj": 10,
            "ei2": 10,
            "ei3": 10,
            "m": 1,
            "i22": 1e-3,
            "i33": 1e-3,
        },
    )
    m.node("c", [2, 0, 0]).spherical("pin", "ground", "a")
    if new:
        m.body("ball", "b", 1.0, [0.1, 0.1, 0.1]).sliding_screw("s", "rail", "c", eta=fd.drive("0.5"))
        m.sensor("energy", "e").simulation(t_end=0.1, scheme="ep")
    else:
        m.rigid_body("ball", "b", 1.0, [0.1, 0.1, 0.1])
        m.sliding_joint("s", "rail", "c", eta=fd.drive("0.5"), kind="screw")
        m.sensor(kind="energy", name="e").settings(t_end=0.1, scheme="ep")
    return m.to_dict()


def test_old_spellings_warn_and_build_the_same_model():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        old = built(new=False)
    messages = [str(w.message) for w in caught if w.category is DeprecationWarning]
    assert len(messages) == 4, messages
    assert all("deprecated" in msg for msg in messages)
    assert old == built(new=True)


def test_a_drive_is_given_once():
    m = fd.Model("m")
    with pytest.raises(ValueError, match="give the drive once"):
        m.sliding("s", "rail", "c", eta=fd.drive("0.5"), drive="0.5")

"""Overrides (issue 21, item 1): change a model's values by path — from the command line with
`--set PATH=VALUE` or in Python with `Model.with_` — items addressed by name, checked like the
file, the original left alone."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import flexdyn as fd
from flexdyn.overrides import parse_value

from test_fields import swinging_sleeve

ROOT = Path(__file__).resolve().parent.parent


def flexdyn(*args):
    return subprocess.run(
        [sys.executable, "-m", "flexdyn", *map(str, args)], check=False, capture_output=True, text=True
    )


def test_values_read_as_yaml_1_2_like_model_files():
    assert parse_value("2e4") == 20000.0 and isinstance(parse_value("2e4"), float)
    assert parse_value("5") == 5 and isinstance(parse_value("5"), int)
    assert parse_value("-1.5e-3") == -1.5e-3
    assert parse_value("true") is True
    assert parse_value("[0, 0, -1.62]") == [0, 0, -1.62]
    assert parse_value("{stiffness: 1e4, damping: 2}") == {"stiffness": 1e4, "damping": 2}
    assert parse_value("0.2 + 0.3*sin(t)^2") == "0.2 + 0.3*sin(t)^2"  # an expression stays text
    assert parse_value("ep") == "ep"


def test_with_changes_items_by_name_and_leaves_the_original():
    m = swinging_sleeve()
    before = m.to_dict()
    changed = m.with_(
        {
            "joints.shaft.spring.damping": 3.0,  # the revolute has no spring yet: created
            "beams.strip.section.ei3": 450.0,
            "bodies.collar.mass": 0.75,
            "simulation.t_end": 0.1,
            "gravity": [0, 0, -1.62],
            "sensors.1.node": "strip.6",  # by index too
        }
    )
    assert m.to_dict() == before
    d = changed.to_dict()
    shaft = next(j for j in d["joints"] if j["name"] == "shaft")
    assert shaft["spring"] == {"damping": 3.0}
    assert d["beams"][0]["section"]["ei3"] == 450.0 and d["beams"][0]["section"]["ei2"] == 60.0
    assert d["bodies"][1]["mass"] == 0.75 and d["simulation"]["t_end"] == 0.1
    assert d["gravity"] == [0, 0, -1.62] and d["sensors"][1]["node"] == "strip.6"


def test_an_override_changes_the_physics():
    """Halving a beam's bending stiffness doubles a tip's static deflection (linear range)."""
    m = fd.Model("cantilever")
    m.beam(
        "bar",
        [0, 0, 0],
        [1.0, 0, 0],
        elements=4,
        section={
            "ea": 1e9,
            "ga2": 1e9,
            "ga3": 1e9,
            "gj": 1e4,
            "ei2": 1e4,
            "ei3": 1e4,
            "m": 1.0,
            "i22": 1e-4,
            "i33": 1e-4,
        },
    )
    m.clamp("root", "ground", "bar.0")
    m.force("tip_load", "bar.end", [0, 0, -10.0])
    m.sensor("node_displacement", "tip", node="bar.end")
    stiff = fd.solve_static(m)["tip.uz"].values[-1]
    soft = fd.solve_static(m.with_({"beams.bar.section.ei2": 5e3, "beams.bar.section.ei3": 5e3}))[
        "tip.uz"
    ].values[-1]
    # Outside numbers: Timoshenko's cantilever, P L³/3EI + P L/GA (shear, which does not
    # double, is 3e-5 of it); the cubic elements are exact for it, the residue is geometric
    # nonlinearity at a deflection of 3e-4 L.
    bending, shear = 10.0 / (3 * 1e4), 10.0 / 1e9
    assert stiff == pytest.approx(-(bending + shear), rel=1e-5)
    assert soft / stiff == pytest.approx((2 * bending + shear) / (bending + shear), rel=1e-6)


@pytest.mark.parametrize(
    "path,value,message",
    [
        ("joints.shaf.spring.damping", 1.0, "no joint named `shaf` in `joints` (there are: shaft, ride)"),
        ("beams.strip.section.eii", 1.0, "unknown field `eii`"),
        ("simulation.t_end", -1.0, "simulation.t_end: must be positive"),
        ("simulation.t_end.x", 1.0, "`simulation.t_end` is a value"),
        ("joints..x", 1.0, "keys joined by single dots"),
    ],
)
def test_bad_overrides_name_the_path(path, value, message):
    with pytest.raises(fd.ModelError, match=None) as e:
        swinging_sleeve().with_({path: value})
    assert message in str(e.value)
    assert "line 1 column" not in str(e.value)


def test_set_on_the_command_line(tmp_path):
    model = ROOT / "examples" / "four_bar.yaml"
    out = tmp_path / "r.nc"
    done = flexdyn(
        "run", model, "--set", "simulation.t_end=0.05", "--set", "gravity=[0, 0, -1.62]", "-o", out, "-q"
    )
    assert done.returncode == 0, done.stderr
    with xr.open_dataset(out) as ds:
        assert ds["time"].values[-1] == pytest.approx(0.05)
        assert json.loads(ds.attrs["flexdyn_model"])["gravity"] == [0, 0, -1.62]
    info = flexdyn("info", model, "--set", "simulation.t_end=7")
    assert "t_end 7 s" in info.stdout
    bad = flexdyn("check", model, "--set", "joints.crank_pn.spring.stiffness=2e4")
    assert bad.returncode == 2 and "no joint named `crank_pn`" in bad.stderr and "Traceback" not in bad.stderr
    malformed = flexdyn("run", model, "--set", "simulation.t_end")
    assert malformed.returncode == 2 and "PATH=VALUE" in malformed.stderr
    expanded = flexdyn("expand", model, "--set", "bodies.coupler_bar.mass=2.5")
    assert expanded.returncode == 0 and "mass: 2.5" in expanded.stdout
    blade = ROOT / "examples" / "swept_blade_statics.yaml"
    md = flexdyn("modes", blade, "-n", "1", "--set", "simulation.load_steps=2")
    assert md.returncode == 0, md.stderr
    np.testing.assert_array_less(0, [float(md.stdout.split()[-1])])
    # A change that breaks a reference is caught with the reason and the change named.
    coarse = flexdyn("check", blade, "--set", "beams.blade.elements=4")
    assert (
        coarse.returncode == 2
        and "does not have" in coarse.stderr
        and "beams.blade.elements" in coarse.stderr
    )

"""Plots (issue 20): every sensor kind as a readable grid of panels, channels overlaid in one
panel with a legend, static results against the load factor, and mode shapes."""

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from PIL import Image

import flexdyn as fd
from flexdyn.plots import _channels, _grid, plot, plot_modes

from test_fields import strip_alone, swinging_sleeve

#: One sensor of every type the schema knows (the test below checks that none is missing).
EVERY_SENSOR = [
    ("node_position", "s_pos", {"node": "strip.end"}),
    ("node_displacement", "s_disp", {"node": "strip.end"}),
    ("node_rotation", "s_rot", {"node": "strip.end"}),
    ("node_velocity", "s_vel", {"node": "strip.end"}),
    ("relative_position", "s_rel", {"node": "sleeve", "reference": "hub"}),
    ("joint_coordinate", "s_coord", {"joint": "shaft"}),
    ("joint_reaction", "s_react", {"joint": "shaft"}),
    ("drive_force", "s_drive", {"joint": "ride"}),
    ("friction", "s_friction", {"joint": "ride"}),
    ("energy", "s_energy", {}),
    ("beam_section", "s_section", {"beam": "strip", "eta": 0.25}),
    ("beam_energy", "s_beam_energy", {"beam": "strip"}),
    ("momentum", "s_momentum", {}),
]


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    m = swinging_sleeve()
    # The driven sleeve rubs on the strip (its drive pays the friction), for the friction sensor.
    next(j for j in m.data["joints"] if j["name"] == "ride")["friction"] = {"static": 0.2}
    for kind, name, fields in EVERY_SENSOR:
        m.sensor(kind, name, **fields)
    out = tmp_path_factory.mktemp("plots") / "sleeve.nc"
    fd.simulate(m, t_end=0.2, out=out)
    return out


def picture(path):
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def test_the_list_covers_every_sensor_type():
    import json

    defs = json.loads(fd.schema())["$defs"]
    kinds = {v["properties"]["type"]["const"] for v in defs["Sensor"]["oneOf"]}
    assert kinds == {k for k, _, _ in EVERY_SENSOR}


@pytest.mark.parametrize("kind,name,fields", EVERY_SENSOR, ids=[k for k, _, _ in EVERY_SENSOR])
def test_every_sensor_kind_plots_as_a_grid(results, tmp_path, kind, name, fields):
    out = plot([results], [name], tmp_path / f"{name}.png")
    img = picture(out)
    with fd.open_results(results) as ds:
        n = len(_channels(ds, [name]))
    rows, cols = _grid(n)
    # A beam section's 24 channels: 4 columns of 6, not 24 stacked panels.
    assert rows <= 6 and rows * cols >= n
    assert img.shape[0] < 1400  # pixels at 100 dpi: 6 rows at most
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 10


def test_whole_sensors_leave_out_the_old_spellings(results):
    with fd.open_results(results) as ds:
        assert _channels(ds, ["s_disp"]) == ["s_disp.ux", "s_disp.uy", "s_disp.uz"]
        rot = _channels(ds, ["s_rot"])
        assert "s_rot.rx" in rot and "s_rot.x" not in rot and len(rot) == 12
        section = _channels(ds, ["s_section"])
        assert {"s_section.x", "s_section.ux"} <= set(section) and len(section) == 24


def test_overlay_puts_channels_in_one_panel_with_a_legend(results, tmp_path):
    one = picture(plot([results], ["s_pos"], tmp_path / "a.png", overlay=True))
    grid = picture(plot([results], ["s_pos"], tmp_path / "b.png"))
    assert one.shape[0] < grid.shape[0]  # one panel, not three stacked
    # Three colours for the three channels (C0, C1, C2 of matplotlib's cycle).
    for rgb in ((31, 119, 180), (255, 127, 14), (44, 160, 44)):
        assert (np.abs(one.astype(int) - rgb).sum(axis=2) < 30).sum() > 50


def test_static_results_plot_against_the_load_factor(tmp_path):
    m = strip_alone()
    static = tmp_path / "static.nc"
    fd.solve_static(m, load_steps=4, out=static)
    out = plot([static], ["tip", "mid.M2"], tmp_path / "static.png")
    assert out.is_file()
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "flexdyn",
            "plot",
            str(static),
            "tip.z",
            "--overlay",
            "-o",
            str(tmp_path / "c.svg"),
        ],
        check=False,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "load factor" in (tmp_path / "c.svg").read_text()


def test_mode_shapes_are_drawn(tmp_path):
    m = strip_alone()
    md = fd.modes(m, 4)
    # The equilibrium geometry comes with the modes: the strip's tip sags under gravity.
    tip = [str(n) for n in md["node"].values].index("strip.12")
    assert md["node_position"].values[tip, 2] < -1e-3
    out = plot_modes(md, tmp_path / "modes.png")
    assert len(np.unique(picture(out).reshape(-1, 3), axis=0)) > 10
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "flexdyn",
            "modes",
            "examples/swept_blade_statics.yaml",
            "-n",
            "3",
            "--plot",
            str(tmp_path / "m.png"),
        ],
        check=False,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0 and (tmp_path / "m.png").is_file(), done.stderr
    saved = subprocess.run(
        [sys.executable, "-m", "flexdyn", "modes", "examples/swept_blade_statics.yaml", "-n", "2", "-o", str(tmp_path / "m.nc")],
        check=False, capture_output=True, text=True,
    )  # fmt: skip
    assert saved.returncode == 0, saved.stderr
    with xr.open_dataset(tmp_path / "m.nc") as written:
        assert written.sizes["mode"] == 2 and written["frequency"].attrs["units"] == "Hz"


@pytest.fixture(scope="module")
def static_and_dynamic(tmp_path_factory):
    m = strip_alone()
    d = tmp_path_factory.mktemp("mixed")
    fd.solve_static(m, load_steps=2, out=d / "static.nc")
    fd.simulate(m, t_end=0.01, out=d / "dyn.nc")
    m.to_yaml(d / "model.yaml")
    (d / "junk.nc").write_text("not a NetCDF file\n")
    return d


@pytest.mark.parametrize(
    "args,says",
    [
        (
            ["plot", "static.nc", "dyn.nc", "tip"],
            "static.nc is a static result (along the load factor) and dyn.nc a dynamic",
        ),
        (["compare", "dyn.nc", "static.nc", "--sensors", "tip.z"], "plot them separately"),
        (["plot", "model.yaml", "tip"], "model.yaml is a model file: run it first"),
        (["compare", "model.yaml", "--sensors", "tip"], "model.yaml is a model file"),
        (["plot", "junk.nc", "tip"], "junk.nc is not a results file"),
        (["plot", "missing.nc", "tip"], "missing.nc: no such results file"),
        (["plot", "static.nc", "nope"], "no channel or sensor `nope`"),
        (["plot", "static.nc", "tip", "-o", "figure.jpg2"], "Format 'jpg2' is not supported"),
        (["plot", "static.nc"], "give one or more results files"),
    ],
)
def test_every_plot_input_gives_a_figure_or_a_one_line_error(
    static_and_dynamic, monkeypatch, capsys, args, says
):
    from flexdyn.cli import main

    monkeypatch.chdir(static_and_dynamic)
    code = main(args)
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("error: "), err
    assert says in err


def test_static_and_dynamic_results_each_plot_alone_and_with_sensors_flag(
    static_and_dynamic, monkeypatch, capsys
):
    from flexdyn.cli import main

    monkeypatch.chdir(static_and_dynamic)
    assert main(["plot", "static.nc", "--sensors", "tip", "-o", "s.png"]) == 0
    assert main(["compare", "dyn.nc", "dyn.nc", "--sensors", "tip", "-o", "d.png"]) == 0
    assert (static_and_dynamic / "s.png").is_file() and (static_and_dynamic / "d.png").is_file()

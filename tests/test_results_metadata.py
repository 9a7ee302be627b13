"""Results that explain themselves (issue 23): CF attributes on every channel and on the file,
found by a CF-aware reader (cf_xarray); results that behave like any xarray Dataset
(`to_netcdf`, `to_dataframe`, selection) and never hold their file open; `ds.flexdyn`."""

import datetime as dt
import json
import os

import cf_xarray  # noqa: F401  (registers `ds.cf`)
import numpy as np
import pytest
import xarray as xr
from test_plots import EVERY_SENSOR, swinging_sleeve

import flexdyn as fd
from flexdyn.channels import model_hash


@pytest.fixture(scope="module")
def every_sensor(tmp_path_factory):
    m = swinging_sleeve()
    next(j for j in m.data["joints"] if j["name"] == "ride")["friction"] = {"static": 0.2}
    for kind, name, fields in EVERY_SENSOR:
        m.sensor(kind, name, **fields)
    m.simulation(t_end=0.05)
    out = tmp_path_factory.mktemp("meta") / "sleeve.nc"
    return m, fd.simulate(m, out=out), fd.simulate(m), out


def test_cf_reader_finds_the_time_axis_and_its_standard_name(every_sensor):
    _, on_disk, in_memory, _ = every_sensor
    for ds in (on_disk, in_memory):
        assert ds.cf.axes["T"] == ["time"]
        assert ds.cf.standard_names["time"] == ["time"]
        assert ds.cf["T"].attrs["units"] == "s"
        assert ds.attrs["Conventions"].startswith("CF-")


def test_every_channel_has_a_long_name_units_sensor_and_component(every_sensor):
    m, on_disk, in_memory, _ = every_sensor
    kinds = {s["name"]: s["type"] for s in m.data["sensors"]}
    for ds in (on_disk, in_memory):
        channels = ds.flexdyn.channels
        assert {ds[c].attrs["sensor"] for c in channels} == set(kinds)
        for c in channels:
            a = ds[c].attrs
            assert a["sensor_type"] == kinds[a["sensor"]]
            assert c == f"{a['sensor']}.{a['component']}"
            # A described quantity, not the bare component name echoed back.
            assert a["units"] and len(a["long_name"]) > len(a["component"]) + 3, (c, a)


@pytest.mark.parametrize(
    "channel,frame,words",
    [
        ("s_pos.x", "inertial", "position along x of node `strip.end`"),
        ("s_react.F1", "joint", "joint axis 1"),
        ("s_react.Fx", "inertial", "reaction force along x"),
        ("s_section.M2", "section", "bending moment about section axis 2"),
        ("s_section.phi1", "reference section", "twist"),
        ("s_rel.x1", "node hub", "reference's axis 1"),
        ("s_momentum.Hz", "inertial", "angular momentum"),
        ("s_energy.total", None, "total energy"),
        ("s_friction.slip", None, "slip"),
        ("s_coord.phi_rate", None, "rate"),
    ],
)
def test_vector_channels_name_their_frame_and_scalars_have_none(every_sensor, channel, frame, words):
    ds = every_sensor[1]
    assert ds[channel].attrs.get("frame") == frame
    assert words in ds[channel].attrs["long_name"]


def test_the_file_records_version_date_model_hash_and_settings(every_sensor):
    _m, ds, _, _ = every_sensor
    assert ds.attrs["flexdyn_version"] == fd.__version__
    assert fd.__version__ in ds.attrs["source"]
    created = dt.datetime.fromisoformat(ds.attrs["date_created"])
    assert abs((dt.datetime.now(dt.UTC) - created).total_seconds()) < 600
    model = json.loads(ds.attrs["flexdyn_model"])
    assert ds.attrs["model_hash"] == model_hash(model)
    assert json.loads(ds.attrs["settings"])["t_end"] == 0.05
    assert ds.flexdyn.model.to_dict() == model
    # The hash tells models apart.
    assert model_hash({**model, "name": "other"}) != ds.attrs["model_hash"]


def test_results_write_again_and_convert_like_any_dataset(every_sensor, tmp_path):
    _, on_disk, in_memory, _ = every_sensor
    for k, ds in enumerate((on_disk, in_memory)):
        copy = tmp_path / f"copy{k}.nc"
        ds.to_netcdf(copy)
        back = xr.load_dataset(copy)
        np.testing.assert_array_equal(back["s_pos.z"].values, ds["s_pos.z"].values)
        assert back.flexdyn.stats == ds.flexdyn.stats
        frame = ds[["s_pos.x", "s_pos.z"]].to_dataframe()
        assert list(frame.columns) == ["s_pos.x", "s_pos.z"] and len(frame) == ds.sizes["time"]
        assert ds.sel(time=0.02, method="nearest")["s_pos.z"].size == 1


def test_the_same_output_path_is_reused_in_one_process_and_old_results_keep_their_values(tmp_path):
    def run(length):
        m = fd.Model("pendulum", gravity=[0, 0, -9.81])
        m.node("bob", [length, 0, 0]).body("b", "bob", mass=1.0, inertia=[0.01, 0.01, 0.01])
        m.revolute("pin", "ground", "bob", axis=[0, 1, 0])
        m.sensor("node_position", "p", node="bob")
        m.simulation(t_end=0.2)
        return fd.simulate(m, out=tmp_path / "r.nc")

    first = run(1.0)
    x_first = first["p.x"].values.copy()
    second = run(2.0)  # the same file, written again
    np.testing.assert_array_equal(first["p.x"].values, x_first)
    assert second["p.x"].values[0] == pytest.approx(2.0)
    # Neither result holds the file open.
    target = os.path.realpath(tmp_path / "r.nc")
    held = [os.path.realpath(f"/proc/self/fd/{f}") for f in os.listdir("/proc/self/fd")]
    assert target not in held


def test_the_accessor_reads_run_facts_from_files_and_memory(every_sensor):
    _, on_disk, in_memory, path = every_sensor
    with fd.open_results(path) as reopened:
        for ds in (on_disk, in_memory, reopened):
            s = ds.flexdyn.stats
            assert s["steps"] > 0 and isinstance(s["steps"], int)
            assert ds.flexdyn.completed
            assert isinstance(ds.flexdyn.warnings, list)
            assert not any(isinstance(v, (dict, list)) for v in ds.attrs.values())

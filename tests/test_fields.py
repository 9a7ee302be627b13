"""Full-field output (issue 20): every node's position and orientation, the beams' section loads
at their nodes and the sliding joints' contact points at the output times, with the topology,
in the results file and in memory — equal to the sensors that measure the same things."""

import json

import numpy as np
import pytest
import xarray as xr

import flexdyn as fd
from flexdyn import _core
from flexdyn.fields import frames, motion

# A 1.5 m steel-like strip (EI ≠ between axes so that twist and bending show).
STRIP = {"ea": 2e7, "ga2": 8e6, "ga3": 8e6, "gj": 40.0, "ei2": 60.0, "ei3": 900.0, "m": 2.0}
STRIP |= {"i22": 1e-4, "i33": 1e-3}


def swinging_sleeve():
    """A user's mechanism, not an example: a pre-twisted strip hinged at the root to a driven
    hub body, swinging under gravity, with a sleeve (a body on its own node) driven along it."""
    m = fd.Model("swinging sleeve", gravity=[0, 0, -9.81])
    m.node("hub", [0, 0, 0]).body("hub_body", "hub", mass=3.0, inertia=[0.02, 0.02, 0.02])
    m.revolute("shaft", "ground", "hub", axis=[0, 0, 1], drive="0.8*t^2")
    m.beam("strip", None, [1.5, 0, 0], elements=4, section=STRIP, twist_rate=0.6, start_node="hub")
    m.node("sleeve", [0.3, 0, 0]).body("collar", "sleeve", mass=0.5, inertia=[1e-3, 1e-3, 1e-3])
    m.sliding("ride", "strip", "sleeve", drive="0.2 + 0.3*sin(t)^2")
    m.sensor("node_position", "tip", node="strip.end")
    m.sensor("node_rotation", "tip_rot", node="strip.end")
    m.sensor("joint_coordinate", "contact", joint="ride")
    m.sensor("beam_section", "mid", beam="strip", eta=0.5)
    m.simulation(t_end=0.6, output_dt=0.02)
    return m


def strip_alone():
    """The same strip without its sleeve: a cantilever held by the shaft's drive (statics)."""
    m = swinging_sleeve()
    m.data["joints"] = [j for j in m.data["joints"] if j["name"] != "ride"]
    m.data["bodies"] = [b for b in m.data["bodies"] if b["name"] != "collar"]
    m.data["nodes"] = [n for n in m.data["nodes"] if n["name"] != "sleeve"]
    m.data["sensors"] = [s for s in m.data["sensors"] if s["name"] != "contact"]
    return m


@pytest.fixture(scope="module", params=["memory", "file"])
def results(request, tmp_path_factory):
    out = tmp_path_factory.mktemp("fields") / "r.nc" if request.param == "file" else None
    return fd.simulate(swinging_sleeve(), out=out)  # default settings record the fields


def test_fields_are_recorded_by_default_and_agree_with_the_sensors(results):
    ds = results
    nodes = [str(n) for n in ds["node"].values]
    tip = nodes.index("strip.12")
    # Positions: the same state sampled, so equal to round-off.
    xyz = np.stack([ds[f"tip.{c}"].values for c in "xyz"], axis=-1)
    np.testing.assert_allclose(ds["node_position"].values[:, tip], xyz, rtol=0, atol=1e-14)
    # Orientation quaternions → the node_rotation sensor's triad (a quaternion built from the
    # rotation vector: round-off of a few ε).
    r = np.stack([[ds[f"tip_rot.R{i}{j}"].values for j in "123"] for i in "123"]).transpose(2, 0, 1)
    np.testing.assert_allclose(frames(ds["node_orientation"].values[:, tip]), r, atol=1e-13)
    # Contact point and η of the sliding joint.
    pts = np.stack([ds[f"contact.{c}"].values for c in "xyz"], axis=-1)
    np.testing.assert_allclose(ds["contact_position"].values[:, 0], pts, atol=1e-14)
    np.testing.assert_allclose(ds["contact_eta"].values[:, 0], ds["contact.eta"].values, atol=1e-15)
    # Section loads at the node in the middle (η = 0.5 is node 6 of 12, an element boundary:
    # both take the element after it).
    mid = list(ds["beam_point"].values).index("strip[6]")
    for k, c in enumerate(("F1", "F2", "F3")):
        np.testing.assert_allclose(ds["section_force"].values[:, mid, k], ds[f"mid.{c}"].values, atol=1e-9)
    for k, c in enumerate(("M1", "M2", "M3")):
        np.testing.assert_allclose(ds["section_moment"].values[:, mid, k], ds[f"mid.{c}"].values, atol=1e-9)
    # The strip bends under gravity and the drive: the loads are not trivially zero.
    assert np.abs(ds["section_moment"].values).max() > 1.0
    assert ds["node_position"].attrs["units"] == "m"
    assert ds["section_moment"].attrs["units"] == "N*m"


def test_the_topology_names_beams_bodies_joints_and_contacts(results):
    topo = json.loads(results.attrs["flexdyn_topology"])
    nodes = topo["nodes"]
    (strip,) = topo["beams"]
    assert [nodes[n] for n in strip["nodes"]] == ["hub"] + [f"strip.{k}" for k in range(1, 13)]
    assert strip["s"][0] == 0 and strip["s"][-1] == pytest.approx(1.5)
    assert {b["name"]: nodes[b["node"]] for b in topo["bodies"]} == {"hub_body": "hub", "collar": "sleeve"}
    (shaft,) = [j for j in topo["joints"] if j["name"] == "shaft"]
    assert shaft["type"] == "revolute" and shaft["sides"][0]["node"] is None
    assert nodes[shaft["sides"][1]["node"]] == "hub"
    (ride,) = topo["contacts"]
    assert ride["type"] == "sliding" and nodes[ride["follower"]] == "sleeve"
    np.testing.assert_array_equal(results["beam_point_node"].values, strip["nodes"])


def test_section_frames_at_t0_follow_the_pretwist_even_on_a_shared_node(results):
    """The hub node's triad is the identity, the strip's root section is not (twist 0.6 rad/m
    starts at 0 there, but axis 2 is the default one): the stored offset makes the section
    frame at every beam node the reference line's, turned by the twist at its s."""
    beam = motion(results).beam("strip")
    f0 = beam["frames"][0]
    # Axis 1 along the beam (x), axis 2 turned by twist·s from the root section's about x.
    np.testing.assert_allclose(f0[:, :, 0], np.tile([1.0, 0, 0], (13, 1)), atol=1e-12)
    e2_root = f0[0, :, 1]
    angle = np.arctan2(np.cross(e2_root, f0[:, :, 1]) @ [1.0, 0, 0], f0[:, :, 1] @ e2_root)
    np.testing.assert_allclose(angle, 0.6 * beam["s"], atol=1e-12)
    # Frames stay orthonormal along the motion.
    ftf = np.einsum("tpki,tpkj->tpij", beam["frames"], beam["frames"])
    np.testing.assert_allclose(ftf, np.broadcast_to(np.eye(3), ftf.shape), atol=1e-12)


def test_fields_follow_the_setting_and_the_size_estimate():
    m = swinging_sleeve()
    off = fd.simulate(m, t_end=0.04, fields=False)
    assert "node_position" not in off and "tip.x" in off
    m.simulation(t_end=1e4)  # 5e5 samples of 1440 bytes: 720 MB, over the default 100 MB
    per_sample, samples, on = _core.Simulation(m.to_json()).field_estimate
    assert per_sample == 8 * (7 * 14 + 6 * 13 + 4) and samples == 5e5 + 1 and not on
    m.simulation(fields=True)
    assert _core.Simulation(m.to_json()).field_estimate[2]


def test_static_results_carry_fields_per_load_step(tmp_path):
    ds = fd.solve_static(strip_alone(), load_steps=3, out=tmp_path / "s.nc")
    assert ds["node_position"].dims == ("load_factor", "node", "xyz")
    assert ds.sizes["load_factor"] == 4 and "contact_position" not in ds
    tip = [str(n) for n in ds["node"].values].index("strip.12")
    np.testing.assert_allclose(ds["node_position"].values[:, tip, 2], ds["tip.z"].values, atol=1e-14)
    # Cantilever under its own weight (hinge held by the drive at rest): the tip sags.
    assert ds["tip.z"].values[-1] < -1e-3


def test_an_interrupted_run_keeps_its_fields_readable(tmp_path):
    """A run stopped by a callback keeps the completed samples, fields included."""
    out = tmp_path / "cut.nc"

    def stop(t, v):
        if t[-1] > 0.1:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError):
        fd.simulate(swinging_sleeve(), out=out, on_chunk=stop)
    with xr.open_dataset(out) as ds:
        n = ds.sizes["time"]
        assert n > 0 and ds["node_position"].shape == (n, 14, 3)
        assert np.isfinite(ds["node_position"].values).all()
